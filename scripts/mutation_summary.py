"""Per-module count of the mutation run's verdicts, from mutmut's record.

Run in the staging directory (``scripts/mutation.sh --summary`` does). With
``--not-run MODULE...`` (paths under ``podid_rs/``, e.g. ``identification/order.py``)
it prints instead the names of those modules' mutants not yet run, for
``scripts/mutation.sh --not-run``. A mutant is
*killed* when a test failed or errored on it, it timed out or it crashed the process;
it *survived* when the tests passed or no test reached it; it is *not run* when the
run has not come to it yet (or its function changed since it ran).
"""

from __future__ import annotations

import collections
import json
import pathlib
import sys

from mutmut.stats import status_by_exit_code

KILLED = {"killed", "timeout", "segfault"}
SURVIVED = {"survived", "no tests", "suspicious"}


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


def main() -> None:
    """Print killed, survived and not run per mutated module, and the kill rate."""
    total: collections.Counter[str] = collections.Counter()
    print(f"{'module':42} {'killed':>7} {'survived':>9} {'not run':>8} {'kill rate':>10}")
    for meta in sorted(pathlib.Path("mutants/src").rglob("*.py.meta")):
        codes = json.loads(meta.read_text())["exit_code_by_key"].values()
        count = collections.Counter(verdict(c) for c in codes)
        total.update(count)
        print(row(str(meta.relative_to("mutants/src"))[: -len(".meta")], count))
    print(row("all", total))


def row(name: str, count: collections.Counter[str]) -> str:
    """One line of the table: the counts and the kill rate of the mutants run."""
    run = count["killed"] + count["survived"]
    rate = f"{100 * count['killed'] / run:.1f} %" if run else "-"
    return f"{name:42} {count['killed']:7} {count['survived']:9} {count['not run']:8} {rate:>10}"


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
