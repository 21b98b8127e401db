"""Per-module count of the mutation run's verdicts, from mutmut's record.

Run in the staging directory (``scripts/mutation.sh --summary`` does). A mutant is
*killed* when a test failed or errored on it, it timed out or it crashed the process;
it *survived* when the tests passed or no test reached it; it is *not run* when the
run has not come to it yet (or its function changed since it ran). The survivors
listed as equivalent in ``docs/testing.md`` (the block after the line
``<!-- equivalent mutants -->``) are counted apart, and the kill rate is over the
others. The survivors listed after ``<!-- killed by hand -->`` (mutants whose bug only
shows without mutmut's trampolines, run by ``scripts/mutate_by_hand.py``) count as
killed. A listed mutant that is not a survivor (killed since, or renamed because its
function changed) is reported, so that the lists stay true.

With ``--not-run MODULE...`` (paths under ``podid_rs/``, e.g.
``identification/order.py``) it prints instead the names of those modules' mutants
not yet run, for ``scripts/mutation.sh --not-run``.

With ``--not-run-of NAME...`` it prints those of the given mutants not yet run.
With ``--sample N SEED MODULE...`` it draws, for each module, a uniform random sample of
``N`` of its mutants not yet run (all of them if fewer), with ``random.Random(SEED)``
over the names in mutmut's order, writes the names to ``SAMPLE`` (replacing the file) and
prints them, for ``scripts/mutation.sh --sample``. With ``--sample-share N SEED MODULE...``
it draws ``N`` in all instead, each module's number in proportion to its mutants not yet
run (largest remainders), so that the sample's kill rate estimates the rate over all
of them. When ``SAMPLE`` exists, the summary
adds a table of the sample's verdicts per module: the kill rate of the mutants not run
in full, estimated from the sample, with its 95 % (Wilson) interval.
"""

from __future__ import annotations

import collections
import json
import math
import pathlib
import random
import re
import sys

from mutmut.stats import status_by_exit_code

KILLED = {"killed", "timeout", "segfault"}
SURVIVED = {"survived", "no tests", "suspicious"}
DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs" / "testing.md"
EQUIVALENT = "<!-- equivalent mutants -->"
BY_HAND = "<!-- killed by hand -->"
SAMPLE = pathlib.Path(__file__).resolve().parents[1] / "docs" / "mutation-sample.txt"


def verdict(exit_code: int | None) -> str:
    """The verdict of one mutant from the exit code mutmut recorded for it."""
    if exit_code is None:
        return "not run"
    status = status_by_exit_code[exit_code]
    if status in KILLED:
        return "killed"
    if status in SURVIVED:
        return "survived"
    return "not run"


def listed_mutants(marker: str) -> set[str]:
    """The mutant names listed in the first code block after ``marker`` in the docs."""
    text = DOCS.read_text()
    if marker not in text:
        return set()
    block = text.split(marker, 1)[1].split("```", 2)[1]
    return set(re.findall(r"^(podid_rs\.\S+__mutmut_\d+)", block, flags=re.MULTILINE))


def main() -> None:
    """Print killed, survived, equivalent and not run per module, and the kill rate."""
    equivalent, by_hand = listed_mutants(EQUIVALENT), listed_mutants(BY_HAND)
    total: collections.Counter[str] = collections.Counter()
    stale = []
    print(f"{'module':42} {'killed':>7} {'survived':>9} {'equiv.':>7} {'not run':>8} "
          f"{'kill rate':>10}")  # fmt: skip
    for meta in sorted(pathlib.Path("mutants/src").rglob("*.py.meta")):
        count: collections.Counter[str] = collections.Counter()
        for name, code in json.loads(meta.read_text())["exit_code_by_key"].items():
            v = verdict(code)
            if name in by_hand:
                by_hand.discard(name)
                if v != "survived":
                    stale.append(f"{name} ({v})")
                v = "killed"
            count[v] += 1
            if name in equivalent:
                if v == "survived":
                    count["equivalent"] += 1
                else:
                    stale.append(f"{name} ({v})")
                equivalent.discard(name)
        total.update(count)
        print(row(str(meta.relative_to("mutants/src"))[: -len(".meta")], count))
    print(row("all", total))
    stale += sorted(f"{name} (no such mutant)" for name in equivalent | by_hand)
    if stale:
        print("\nlisted in docs/testing.md but not a survivor:\n  " + "\n  ".join(stale))
    if SAMPLE.exists():
        sample_table(equivalent_all=listed_mutants(EQUIVALENT), by_hand=listed_mutants(BY_HAND))


def row(name: str, count: collections.Counter[str]) -> str:
    """One line of the table: the counts and the kill rate of the non-equivalent mutants run."""
    judged = count["killed"] + count["survived"] - count["equivalent"]
    rate = f"{100 * count['killed'] / judged:.1f} %" if judged else "-"
    return (
        f"{name:42} {count['killed']:7} {count['survived']:9} {count['equivalent']:7} "
        f"{count['not run']:8} {rate:>10}"
    )


def verdicts() -> dict[str, tuple[str, str]]:
    """Every mutant's module (path under ``podid_rs/``) and verdict."""
    out = {}
    for meta in sorted(pathlib.Path("mutants/src").rglob("*.py.meta")):
        module = str(meta.relative_to("mutants/src/podid_rs"))[: -len(".meta")]
        for name, code in json.loads(meta.read_text())["exit_code_by_key"].items():
            out[name] = (module, verdict(code))
    return out


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion k / n (95 % for z = 1.96)."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def sample_table(equivalent_all: set[str], by_hand: set[str]) -> None:
    """Killed, survived, equivalent and not yet run among the sampled mutants, per module,
    and the kill rate of the non-equivalent ones with its 95 % interval."""
    names = [line.split()[0] for line in SAMPLE.read_text().splitlines()
             if line.strip() and not line.startswith("#")]  # fmt: skip
    by_name = verdicts()
    count: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    for name in names:
        if name not in by_name:
            continue
        module, v = by_name[name]
        if name in by_hand and v == "survived":
            v = "killed"
        count[module]["sampled"] += 1
        count[module][v] += 1
        if name in equivalent_all and v == "survived":
            count[module]["equivalent"] += 1
    print(f"\nsample ({SAMPLE.name}): mutants not run in full, drawn at random per module")
    print(f"{'module':42} {'sampled':>8} {'killed':>7} {'survived':>9} {'equiv.':>7} "
          f"{'not run':>8} {'kill rate (95 % interval)':>27}")  # fmt: skip
    for module in sorted(count):
        c = count[module]
        judged = c["killed"] + c["survived"] - c["equivalent"]
        if judged:
            lo, hi = wilson(c["killed"], judged)
            rate = f"{100 * c['killed'] / judged:.1f} % ({100 * lo:.0f}-{100 * hi:.0f} %)"
        else:
            rate = "-"
        print(f"{'podid_rs/' + module:42} {c['sampled']:8} {c['killed']:7} {c['survived']:9} "
              f"{c['equivalent']:7} {c['not run']:8} {rate:>27}")  # fmt: skip


def pending_of(module: str) -> list[str]:
    """The names of one module's mutants not yet run, in mutmut's order."""
    meta = pathlib.Path("mutants/src/podid_rs") / f"{module}.meta"
    return [name for name, code in json.loads(meta.read_text())["exit_code_by_key"].items()
            if code is None]  # fmt: skip


def shares(total: int, sizes: list[int]) -> list[int]:
    """``total`` split in proportion to ``sizes`` (each at most its size): the integer
    parts first, then one more each to the largest remainders."""
    whole = sum(sizes)
    exact = [total * s / whole if whole else 0.0 for s in sizes]
    counts = [min(int(e), s) for e, s in zip(exact, sizes, strict=True)]
    by_remainder = sorted(range(len(sizes)), key=lambda i: exact[i] - counts[i], reverse=True)
    for i in by_remainder[: max(0, min(total, whole) - sum(counts))]:
        counts[i] += 1
    return counts


def sample(size: int, seed: int, modules: list[str], share: bool = False) -> None:
    """Draw and record ``size`` not-yet-run mutants per module (or, with ``share``,
    ``size`` in all, split over the modules by their numbers not run), uniformly at
    random within each module."""
    rng = random.Random(seed)
    flag = "--sample-share" if share else "--sample"
    lines = [f"# scripts/mutation.sh {flag} {size} {seed} {' '.join(modules)}"]
    pending = [pending_of(module) for module in modules]
    sizes = shares(size, [len(p) for p in pending]) if share else [size] * len(modules)
    for names, n in zip(pending, sizes, strict=True):
        lines += rng.sample(names, min(n, len(names)))
    SAMPLE.write_text("\n".join(lines) + "\n")
    print("\n".join(lines[1:]))


def not_run(modules: list[str]) -> None:
    """Print the names of the given modules' mutants that have no verdict yet."""
    for module in modules:
        meta = pathlib.Path("mutants/src/podid_rs") / f"{module}.meta"
        for name, code in json.loads(meta.read_text())["exit_code_by_key"].items():
            if code is None:
                print(name)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--not-run"]:
        not_run(sys.argv[2:])
    elif sys.argv[1:2] == ["--not-run-of"]:
        pending = {name for name, (_, v) in verdicts().items() if v == "not run"}
        for name in sys.argv[2:]:
            if name in pending:
                print(name)
    elif sys.argv[1:2] in (["--sample"], ["--sample-share"]):
        sample(int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:],
               share=sys.argv[1] == "--sample-share")
    else:
        main()
