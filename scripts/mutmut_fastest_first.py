"""mutmut's command line, with each mutant's tests run fastest first and the clean run logged.

``scripts/mutation.sh`` runs this instead of ``python -m mutmut`` (same arguments). Two
changes to mutmut 3.8's fork-server runner (``process_isolation = "forkserver"``):

* **Fastest first.** mutmut hands each mutant its tests as a ``set`` turned into a list,
  in an order that changes from run to run (string hashing is randomised), and pytest
  stops at the first failure (``-x``). The fork runner sorts them by the duration recorded
  when the suite ran under the trampolines; the fork-server runner does not, so a mutant
  the fastest test kills in 0.1 s could first wait for a 10 s test to pass. Here the
  tests are sorted by that duration (ties by name) for the mutants and for the clean
  run, so both run in one fixed order: what passes in the clean run is what the mutants
  see, and a verdict does not depend on a random order.
* **Tests that share a fixture's value.** mutmut maps a function to the tests during
  which it ran. A module- or session-scoped fixture runs once, inside the first test
  that asks for it, so the module's other tests that read its value are not mapped to
  the functions the fixture called, and a mutant there was judged by that first test
  alone (``test_uff_out.py``'s written file: only the test that checks the set types
  ran for a mutant of dataset 55, not the one that reads its modal constants). Here a
  mutant's tests are extended by every selected test of the same file when the file
  defines such a fixture, and by every test that takes the session fixture ``beam``
  (``tests/conftest.py``) when one of them is selected.
* **The clean run's output.** The clean run (the selected tests on the unmutated code,
  before any mutant) runs in a forked child whose output mutmut's spinner swallows, so a
  failure only said "Failed to run clean test". Here the child writes pytest's report
  to ``mutants/clean-tests.log``, which names the failing test.

Nothing else changes: the time limits are mutmut's (from the mapped tests' time).
"""

from __future__ import annotations

import re
import sys
from functools import cache
from pathlib import Path

from mutmut.__main__ import cli
from mutmut.state import state
from mutmut.workers import isolation

CLEAN_LOG = Path("mutants") / "clean-tests.log"


SHARED_SCOPE = re.compile(r"scope\s*=\s*[\"'](module|session)[\"']")
TAKES_BEAM = re.compile(r"def (test_\w+)\(([^)]*)\)", re.DOTALL)


@cache
def shared_groups() -> tuple[dict[str, frozenset[str]], frozenset[str]]:
    """The selected tests of each file with a module- or session-scoped fixture (by file),
    and the selected tests that take the session fixture ``beam``."""
    by_file: dict[str, set[str]] = {}
    for name in state().duration_by_test:
        by_file.setdefault(name.split("::", 1)[0], set()).add(name)
    shared, beam = {}, set()
    for file, names in by_file.items():
        path = Path("mutants") / file
        text = path.read_text() if path.exists() else ""
        if SHARED_SCOPE.search(text):
            shared[file] = frozenset(names)
        users = {m.group(1) for m in TAKES_BEAM.finditer(text)
                 if re.search(r"\bbeam\b", m.group(2))}  # fmt: skip
        beam |= {n for n in names if n.split("::", 1)[1].split("[", 1)[0] in users}
    return shared, frozenset(beam)


def with_shared_fixtures(tests: list[str] | set[str]) -> set[str]:
    """The tests, and every selected test that may read a fixture value they computed."""
    shared, beam = shared_groups()
    out = set(tests)
    for name in tests:
        out |= shared.get(name.split("::", 1)[0], frozenset())
    if out & beam:
        out |= beam
    return out


def fastest_first(tests: list[str] | set[str]) -> list[str]:
    """The tests and those sharing their fixtures' values, by the call time recorded in
    the stats run, then by name."""
    duration = state().duration_by_test
    return sorted(with_shared_fixtures(tests), key=lambda name: (duration.get(name, 0.0), name))


_submit = isolation.ForkServerRunner.submit


def submit(
    self: isolation.ForkServerRunner,
    mutant_name: str,
    tests: list[str],
    cpu_time_limit: int,
    estimated_time: float,
) -> None:
    """Hand the mutant to the fork server with its tests fastest first."""
    _submit(self, mutant_name, fastest_first(tests), cpu_time_limit, estimated_time)


def run_clean_tests(self: isolation.ForkServerRunner, tests: list[str] | set[str]) -> int:
    """The clean run, fastest first as the mutants run, its report in ``CLEAN_LOG``."""
    ordered = fastest_first(tests)
    log = CLEAN_LOG.resolve()

    def in_child(child_runner: isolation.TestRunner) -> int:
        with open(log, "w") as out:
            sys.stdout = sys.stderr = out
            return child_runner.run_tests(mutant_name=None, tests=ordered)

    code = self._exit_code_from_child(in_child)
    if code != 0:
        print(f"the clean run failed (exit code {code}); pytest's report is in {log}")
    return code


isolation.ForkServerRunner.submit = submit
isolation.ForkServerRunner.run_clean_tests = run_clean_tests

if __name__ == "__main__":
    cli()
