"""Shared pieces of the benchmarks: isolated workers, peak memory, GEMM rate, tables.

Every measured case runs in a fresh Python process so that its peak resident
memory (``ru_maxrss``) is its own; the parent only collects JSON.
"""

from __future__ import annotations

import json
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np


def peak_rss_gb() -> float:
    """Peak resident set size of this process so far, GB.

    ``VmHWM`` belongs to this address space; ``ru_maxrss`` would not do, since
    Linux carries it over from the parent across fork and exec.
    """
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024 / 1e9
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9


def run_worker(script: str, case: dict, timeout: float = 3600) -> dict:
    """Run ``script --worker JSON`` in a fresh interpreter; return its JSON result."""
    proc = subprocess.run(
        [sys.executable, script, "--worker", json.dumps(case)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:]
        if proc.returncode < 0:
            tail = [f"killed by {signal.Signals(-proc.returncode).name}"] + tail
        return {"error": " / ".join(tail) or f"exit code {proc.returncode}"}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def worker_main(handlers: dict[str, Callable[[dict], dict]]) -> None:
    """Entry of a worker process: run one case, print its result as JSON."""
    case = json.loads(sys.argv[2])
    out = handlers[case["kind"]](case)
    out["peak_gb"] = peak_rss_gb()
    print(json.dumps(out))


def timed(f: Callable[[], object]) -> tuple[object, float]:
    t = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t


def gemm_gflops(n: int = 4000, repeat: int = 3) -> float:
    """Best-of-``repeat`` dense float64 GEMM rate of NumPy's BLAS, GFLOP/s."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((n, n)), rng.standard_normal((n, n))
    a @ b
    best = min(timed(lambda: a @ b)[1] for _ in range(repeat))
    return 2 * n**3 / best / 1e9


def scipy_cholesky(case: dict) -> dict:
    """scipy.linalg.cho_factor on an SPD matrix of order n (in place, lower)."""
    import scipy.linalg

    n = case["n"]
    # Fortran order (the transpose of a C array, no copy): otherwise cho_factor copies
    A = np.random.default_rng(1).standard_normal((n, n)).T
    A[np.diag_indices(n)] += 3 * np.sqrt(n)  # Gershgorin-safe: SPD on the lower triangle
    _, secs = timed(
        lambda: scipy.linalg.cho_factor(A, lower=True, overwrite_a=True, check_finite=False)
    )
    return {"seconds": secs, "gflops": n**3 / 3 / secs / 1e9}


def chain_problem(m: int, lines: int = 400, noise: float = 0.0, seed: int = 0):
    """The full-order chain ``mass_spring_chain(m)`` (R = I), random complex forces on
    every DOF, ``lines`` lines over 5–200 Hz; ``noise`` adds complex noise of that
    RMS fraction of |U| to the responses. Returns (system, U, F, omega)."""
    from podid_rs import mass_spring_chain

    sys_ = mass_spring_chain(m)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, lines)
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((lines, m)) + 1j * rng.standard_normal((lines, m))
    U = sys_.response(omega, F)
    if noise:
        e = rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)
        U = U + noise * np.sqrt(np.mean(np.abs(U) ** 2) / 2) * e
    return sys_, U, F, omega


def val(r: dict | None, key: str) -> float | None:
    """A measured value, or None when the case was skipped or failed."""
    return r.get(key) if r and "error" not in r else None


def ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a is not None and b else None


def fmt(x: object, spec: str = ".3g") -> str:
    if x is None:
        return "—"
    if isinstance(x, str):
        return x
    return format(x, spec)


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)
