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
"""

from __future__ import annotations

import collections
import json
import pathlib
import re
import sys

from mutmut.stats import status_by_exit_code

KILLED = {"killed", "timeout", "segfault"}
SURVIVED = {"survived", "no tests", "suspicious"}
DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs" / "testing.md"
EQUIVALENT = "<!-- equivalent mutants -->"
BY_HAND = "<!-- killed by hand -->"


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


def row(name: str, count: collections.Counter[str]) -> str:
    """One line of the table: the counts and the kill rate of the non-equivalent mutants run."""
    judged = count["killed"] + count["survived"] - count["equivalent"]
    rate = f"{100 * count['killed'] / judged:.1f} %" if judged else "-"
    return (
        f"{name:42} {count['killed']:7} {count['survived']:9} {count['equivalent']:7} "
        f"{count['not run']:8} {rate:>10}"
    )


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
    else:
        main()
