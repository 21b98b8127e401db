"""Mutants that mutmut cannot check: the properties (it skips decorated functions) and a
warning's stacklevel (its trampolines add stack frames between the caller and the warning).

Each entry replaces one expression by a plausible bug, runs the module's test files, and
restores the file (also on Ctrl-C). Run from anywhere:

    python3 scripts/mutate_by_hand.py         # every mutant
    python3 scripts/mutate_by_hand.py 3 12    # only these (by number)

A mutant the tests pass is printed as SURVIVED. Do not edit the package while it runs.
"""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
PKG = ROOT / "python" / "podid_rs"
TESTS = {
    "pod": ["tests/test_pod.py", "tests/test_memory_guards.py"],
    "simulation": ["tests/test_simulation.py"],
    "measured": ["tests/test_measured.py", "tests/test_measurements.py"],
    "physical": ["tests/test_physical.py"],
    "modes": ["tests/test_modes.py", "tests/test_uff_out.py", "tests/test_uff_modes.py"],
    "stabilisation": ["tests/test_stabilisation.py"],
    "identification/order": ["tests/test_model_order.py", "tests/test_latent.py"],
}
MUTANTS = [
    ("pod", "stacklevel=4,", "stacklevel=5,"),
    ("pod", "stacklevel=4,", "stacklevel=3,"),
    ("pod", "            stacklevel=4,\n", ""),
    (
        "pod",
        'return "snapshots" if self._snapshots is not None else "correlation"',
        'return "correlation" if self._snapshots is not None else "snapshots"',
    ),
    ("pod", "return self._snapshots[1].shape[1]", "return self._snapshots[1].shape[0]"),
    ("pod", "return cum / cum[-1]", "return cum / cum[0]"),
    ("simulation", "return self.t.size", "return self.t.size + 1"),
    ("measured", "return self.U.shape[0]", "return self.U.shape[1]"),
    ("measured", "return self.U.shape[1]\n", "return self.U.shape[2]\n"),
    ("measured", "return self.U.shape[2]", "return self.U.shape[1]"),
    ("measured", "return self.omega / (2 * np.pi)", "return self.omega * (2 * np.pi)"),
    ("measured", "return self.F.shape[1] == self.p and", "return self.F.shape[1] == self.p or"),
    (
        "measured",
        "bool(np.all(self.F == np.eye(self.p)))",
        "bool(np.any(self.F == np.eye(self.p)))",
    ),
    (
        "physical",
        "return float(np.max(self.eigenvalues.real)) if self.eigenvalues.size else -np.inf",
        "return float(np.min(self.eigenvalues.real)) if self.eigenvalues.size else -np.inf",
    ),
    ("physical", "if self.eigenvalues.size else -np.inf", "if self.eigenvalues.size else np.inf"),
    ("physical", "self.max_real_part < 0.0", "self.max_real_part <= 0.0"),
    (
        "physical",
        "return self.n_infinite == 0 and self.max_real_part",
        "return self.n_infinite == 0 or self.max_real_part",
    ),
    ("physical", "return self.n_infinite == 0 and", "return self.n_infinite <= 1 and"),
    ("modes", "return np.arange(1, self.n_modes + 1)", "return np.arange(0, self.n_modes)"),
    (
        "modes",
        "return np.abs(self.eigenvalues) / (2 * np.pi)",
        "return np.abs(self.eigenvalues) * (2 * np.pi)",
    ),
    (
        "modes",
        "np.where(mag > 0, -self.eigenvalues.real / mag, 0.0)",
        "np.where(mag > 0, self.eigenvalues.real / mag, 0.0)",
    ),
    (
        "modes",
        "np.where(mag > 0, -self.eigenvalues.real / mag, 0.0)",
        "np.where(mag >= 0, -self.eigenvalues.real / mag, 0.0)",
    ),
    ("modes", "return self.eigenvalues.size", "return self.eigenvalues.size - 1"),
    (
        "stabilisation",
        "return self.modes.eigenvalues.real < 0",
        "return self.modes.eigenvalues.real <= 0",
    ),
    (
        "stabilisation",
        "return self.modes.eigenvalues.imag > 0",
        "return self.modes.eigenvalues.imag >= 0",
    ),
    (
        "stabilisation",
        "return float(self.freq_hz[0]), float(self.freq_hz[-1])",
        "return float(self.freq_hz[1]), float(self.freq_hz[-1])",
    ),
    ("identification/order", "return self.m - self.observed", "return self.m + self.observed"),
]
only = sys.argv[1:]
for i, (mod, old, new) in enumerate(MUTANTS):
    if only and str(i) not in only:
        continue
    path = PKG / f"{mod}.py"
    src = path.read_text()
    assert src.count(old) == 1, (mod, old, src.count(old))
    path.write_text(src.replace(old, new))
    try:
        r = subprocess.run(
            [
                "nice",
                "-n",
                "19",
                sys.executable,
                "-m",
                "pytest",
                "-x",
                "-q",
                "-p",
                "no:cacheprovider",
                *TESTS[mod],
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
        )
    finally:
        path.write_text(src)
    last = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else r.stderr[-200:]
    print(
        f"{i:2d} {'KILLED ' if r.returncode else 'SURVIVED'} {mod}: {old!r} -> {new!r} | {last}",
        flush=True,
    )
