"""Shared pieces of the benchmarks: isolated workers, peak memory, GEMM rate, tables.

Every measured case runs in a fresh Python process so that its peak resident
memory (``ru_maxrss``) is its own; the parent only collects JSON.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

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


def blas_kernel() -> str:
    """NumPy's BLAS, its version and the kernel family it chose for this CPU."""
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return "BLAS unknown"
    for info in threadpool_info():
        if info.get("user_api") == "blas":
            return (
                f"{info.get('internal_api')} {info.get('version')}, "
                f"{info.get('architecture')} kernels, {info.get('num_threads')} threads"
            )
    return "BLAS unknown"


def first_touch_us_per_page(mib: int = 256) -> float:
    """Cost of the first write to fresh memory, µs per 4 KiB page, beyond a rewrite.

    Every solve allocates its working set anew, so this cost is in every timing. On
    the project's VM it was 7–13 µs per page, 50–100× the 0.1–0.2 µs of pages the
    kernel had freed moments before: the guest hands freed memory back to the host
    (virtio-balloon free page reporting), which maps it again on the next first touch.
    """
    n = mib * 2**20 // 8
    a = np.empty(n)
    first = timed(lambda: a.fill(1.0))[1]
    again = timed(lambda: a.fill(2.0))[1]
    return max(first - again, 0.0) * 1e6 / (n * 8 / 4096)


def cpu_model() -> str:
    """The CPU as /proc/cpuinfo names it (model name, family, model), or the platform's."""
    fields: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                fields.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    if "model name" in fields:
        return (f"{fields['model name']} (family {fields.get('cpu family', '?')}, "
                f"model {fields.get('model', '?')})")
    import platform

    return platform.processor() or platform.machine()


def host_line() -> str:
    """One line for a benchmark table: CPU, cores, date (UTC) and the code's git commit."""
    try:
        commit = subprocess.run(["git", "-C", str(Path(__file__).parent), "rev-parse", "--short",
                                 "HEAD"], capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return (f"Host: {cpu_model()}, {os.cpu_count()} logical CPUs; {when}"
            + (f"; commit {commit}" if commit else ""))


def load_average() -> float | None:
    """One-minute load average (other processes share the cores), or None."""
    try:
        return os.getloadavg()[0]
    except OSError:
        return None


def chain_problem(
    n: int,
    band_hz: tuple[float, float] = (5.0, 200.0),
    s: int = 400,
    noise: float = 0.0,
    seed: int = 0,
):
    """Full-order chain ``mass_spring_chain(n)`` (R = I), random complex forces on every
    DOF at s lines evenly spaced over ``band_hz``; ``noise`` adds complex noise of that
    RMS fraction of |U| to the responses.

    The dynamic stiffness of the chain is tridiagonal, so each line is one banded
    solve, O(n): the dense ``SecondOrderSystem.response`` would need s·n² complex
    numbers (32 GB at n = 1000, s = 2000). Returns (system, U, F, omega).
    """
    import scipy.linalg

    from podid_rs import mass_spring_chain

    sys_ = mass_spring_chain(n)
    omega = 2 * np.pi * np.linspace(band_hz[0], band_hz[1], s)
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((s, n)) + 1j * rng.standard_normal((s, n))
    # rows of the banded storage: super-, main and sub-diagonal of M, C, K
    bands = [np.zeros((3, n)) for _ in range(3)]
    for X, b in zip((sys_.M, sys_.C, sys_.K), bands, strict=True):
        b[0, 1:], b[1], b[2, :-1] = X.diagonal(1), X.diagonal(), X.diagonal(-1)
    U = np.empty_like(F)
    for i, w in enumerate(omega):
        ab = -(w**2) * bands[0] + 1j * w * bands[1] + bands[2]
        U[i] = scipy.linalg.solve_banded((1, 1), ab, F[i])
    if noise:
        e = rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)
        U = U + noise * np.sqrt(np.mean(np.abs(U) ** 2) / 2) * e
    return sys_, U, F, omega


def rel_errors(res, sys_) -> tuple[float, float, float]:
    """‖X − X_true‖_F / ‖X_true‖_F for X = M, C, K."""
    pairs = ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K))
    e = [float(np.linalg.norm(X - T) / np.linalg.norm(T)) for X, T in pairs]
    return e[0], e[1], e[2]


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


def write_report(text: str, out: str | Path) -> Path:
    """Print a benchmark's Markdown report and write it to ``out`` (folders created),
    with the host it ran on (:func:`host_line`) as its last line."""
    out = Path(out)
    text = text.rstrip("\n") + "\n\n" + host_line() + "\n"
    print("\n" + text)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text.rstrip("\n") + "\n")
    print(f"\nwritten to {out}")
    return out
