"""Reviewer's operators applied at every place they fit, over the pipeline's modules.

``mutate_by_hand.py`` holds bugs a person chose; mutmut's operators are generic (``<`` for
``<=``, a string changed, an argument dropped). Two kinds of bug that reviewers plant by
hand and mutmut never makes kept surviving the hand-made audits, because the test fixtures
hid them. This script makes them everywhere, so that none is left to a reviewer's luck:

- **one side of a two-sided check**: every ``!=`` becomes ``<`` and, separately, ``>``
  (a shape check tested only with too few lines passes a check that refuses only too few);
- **a transpose or a conjugate dropped**: every ``.T`` and every ``.conj()`` removed
  (symmetric matrices and real forces in the fixtures hide them);
- **a reversal dropped**: every ``[::-1]`` removed;
- **the wrong axis**: every ``axis=0`` becomes ``axis=1`` and the reverse.

Each mutant runs the module's test files of ``mutate_by_hand.py`` (``TESTS`` and
``AUDIT_TESTS``). Run from anywhere:

    python3 scripts/mutate_by_operator.py --list            # every mutant, numbered
    python3 scripts/mutate_by_operator.py                   # run them all
    python3 scripts/mutate_by_operator.py pod modes         # only these modules' mutants
    python3 scripts/mutate_by_operator.py 3 12 40-55        # only these numbers

Mutants are numbered in the order of the modules below and of their places in the file;
a number is stable while the modules' sources are. Every survivor gets the test that
kills it, or goes into ``EQUIVALENT`` below with the reason no input can tell it apart
(those are reported, not run). Do not edit the package while it runs.
"""

from __future__ import annotations

import io
import sys
import tokenize
from collections.abc import Iterator

from mutate_by_hand import AUDIT_TESTS, PKG, TESTS, run_mutant

#: the pipeline's modules, as the mutation runs name them
MODULES = [
    "pod", "simulation", "measured", "physical", "modes", "stabilisation", "statespace",
    "io/uff", "io/npz", "identification/refinement", "identification/order",
    "identification/latent", "identification/lines", "identification/holes",
    "identification/modal_start",
]

#: survivors no input can tell apart from the code, each with the reason: (module, the line
#: as written, the mutated line), both stripped of indentation
EQUIVALENT: dict[tuple[str, str, str], str] = {
    # identification/refinement, identification/order
    ("identification/refinement", 'if name != "C" and not np.any(d > 0):',
     'if name > "C" and not np.any(d > 0):'):
        'name runs over the literal ("M", "C", "K") and both "M" and "K" sort after "C", '
        'so > "C" is true exactly where != "C" is',
    ("identification/refinement",
     'keep = d.min() >= (START_KEEP * np.abs(d).max() if name != "C" else 0.0)',
     'keep = d.min() >= (START_KEEP * np.abs(d).max() if name > "C" else 0.0)'):
        'name runs over the literal ("M", "C", "K") and both "M" and "K" sort after "C", '
        'so > "C" is true exactly where != "C" is',
}


def _offsets(src: str) -> list[int]:
    """Character offset of the start of each line (1-based line numbers as tokenize's)."""
    starts = [0, 0]
    for line in src.splitlines(keepends=True):
        starts.append(starts[-1] + len(line))
    return starts


def mutants(mod: str) -> Iterator[tuple[int, str, str, str]]:
    """The operator mutants of one module: (line number, line, mutated line, mutated source)."""
    src = (PKG / f"{mod}.py").read_text()
    lines = src.splitlines()
    at = _offsets(src)
    toks = [t for t in tokenize.generate_tokens(io.StringIO(src).readline)
            if t.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT)]

    def pos(t: tokenize.TokenInfo, end: bool = False) -> int:
        row, col = t.end if end else t.start
        return at[row] + col

    def cut(a: int, b: int, text: str) -> tuple[int, str, str, str]:
        row = src.count("\n", 0, a) + 1
        new = src[:a] + text + src[b:]
        return row, lines[row - 1], new.splitlines()[row - 1], new

    for k, t in enumerate(toks):
        if t.type == tokenize.OP and t.string == "!=":
            for op in ("<", ">"):
                yield cut(pos(t), pos(t, end=True), op)
        nxt = toks[k + 1] if k + 1 < len(toks) else None
        if t.string == "." and nxt is not None and nxt.type == tokenize.NAME:
            if nxt.string == "T":
                yield cut(pos(t), pos(nxt, end=True), "")
            if (nxt.string == "conj" and k + 3 < len(toks)
                    and toks[k + 2].string == "(" and toks[k + 3].string == ")"):
                yield cut(pos(t), pos(toks[k + 3], end=True), "")
        if t.string == "[" and [u.string for u in toks[k + 1:k + 6]] == [":", ":", "-", "1", "]"]:
            yield cut(pos(t), pos(toks[k + 5], end=True), "")
        if (t.type == tokenize.NAME and t.string == "axis" and nxt is not None
                and nxt.string == "=" and k + 2 < len(toks)
                and toks[k + 2].string in ("0", "1")):
            swap = "1" if toks[k + 2].string == "0" else "0"
            yield cut(pos(toks[k + 2]), pos(toks[k + 2], end=True), swap)


def main() -> None:
    """List or run the mutants the command line selects (all without arguments)."""
    args = [a for a in sys.argv[1:] if a != "--list"]
    mods = [a for a in args if a in MODULES] or MODULES
    only: set[int] = set()
    for arg in (a for a in args if a not in MODULES):
        first, _, last = arg.partition("-")
        only.update(range(int(first), int(last or first) + 1))
    i = 0
    counts = {"KILLED": 0, "SURVIVED": 0, "EQUIVALENT": 0}
    for mod in MODULES:
        for row, line, mutated_line, mutated in mutants(mod):
            i += 1
            if mod not in mods or (only and i not in only):
                continue
            what = f"{i:3d} {mod}:{row}: {line.strip()!r} -> {mutated_line.strip()!r}"
            if "--list" in sys.argv:
                print(what, flush=True)
                continue
            reason = EQUIVALENT.get((mod, line.strip(), mutated_line.strip()))
            if reason is not None:
                verdict, last = "EQUIVALENT", reason
            else:
                killed, last = run_mutant(mod, mutated, [*TESTS[mod], *AUDIT_TESTS.get(mod, [])])
                verdict = "KILLED" if killed else "SURVIVED"
            counts[verdict] += 1
            print(f"{verdict:10s} {what} | {last}", flush=True)
    if "--list" not in sys.argv:
        print(", ".join(f"{v} {k.lower()}" for k, v in counts.items()))

if __name__ == "__main__":
    main()
