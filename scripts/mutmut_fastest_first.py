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
* **The clean run's output.** The clean run (the selected tests on the unmutated code,
  before any mutant) runs in a forked child whose output mutmut's spinner swallows, so a
  failure only said "Failed to run clean test". Here the child writes pytest's report
  to ``mutants/clean-tests.log``, which names the failing test.

Nothing else changes: the same tests run for each mutant, with the same time limits.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mutmut.__main__ import cli
from mutmut.state import state
from mutmut.workers import isolation

CLEAN_LOG = Path("mutants") / "clean-tests.log"


def fastest_first(tests: list[str] | set[str]) -> list[str]:
    """The tests by the call time recorded in the stats run, then by name."""
    duration = state().duration_by_test
    return sorted(tests, key=lambda name: (duration.get(name, 0.0), name))


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
