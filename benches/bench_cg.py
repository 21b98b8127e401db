"""Matrix-free CG benchmark: large reduced orders on the full-order chain.

Problem: ``mass_spring_chain(n)`` identified at full order (R = I, so m = n),
noise-free, random complex forces on every DOF, s = 2n lines evenly spaced in a
band: the paper's 20 % band 102.8–122.8 Hz ("narrow") and 50–150 Hz ("wide").
Modes: exact-symmetric (``symmetric=True``) and the penalty form at the paper's
λ = 100. Every case runs in its own process (time and peak memory are its own).

The ratios it reports, each against a reference measured in the same run:

- "× GEMM": the whole ``identify`` call over one NumPy GEMM of the operator's
  shape (m×3m by 3m×3m, float64, best of several), timed in the same process
  right after the solve (target at m = 1000, 20 % band: ≤ 45);
- "ref / CG": a plain NumPy PCG on the same scaled normal equations (eigenbasis
  of the summed diagonal blocks of H, diagonal pair preconditioner, same tol),
  run in its own process, over the ``identify`` time (target at m = 400: ≥ 8);
- iterations on 50–150 Hz (target at m = 400–1000: ≤ 150).

    python benches/bench_cg.py                      # m = 400, 1000 (≈ 10 min unloaded)
    python benches/bench_cg.py --sizes 100,200 --modes sym --ref-sizes 100
    python benches/bench_cg.py --sizes 400 --bands narrow --pairs 5   # medians of 5 pairs
    python benches/bench_cg.py --auto               # direct vs CG, m = 4 … 30: auto's crossover
    python benches/bench_cg.py --stall              # tol 1e-300: where CG stops
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    blas_kernel,
    chain_problem,
    first_touch_us_per_page,
    gemm_gflops,
    load_average,
    markdown_table,
    rel_errors,
    run_worker,
    timed,
    val,
    worker_main,
    write_report,
)

BANDS = {"narrow": (102.8, 122.8), "wide": (50.0, 150.0)}
MODES = {"sym": (0.0, True), "pen": (100.0, False)}
TOL = 1e-11


def operator_gemm_seconds(m: int, repeat: int = 3) -> float:
    """Best time of one NumPy float64 GEMM of the CG operator's shape, m×3m by 3m×3m."""
    rng = np.random.default_rng(1)
    z, h = rng.standard_normal((m, 3 * m)), rng.standard_normal((3 * m, 3 * m))
    z @ h
    return min(timed(lambda: z @ h)[1] for _ in range(repeat))


def solve_case(case: dict) -> dict:
    from podid_rs import identify

    m = case["m"]
    lam, sym = MODES[case["mode"]]
    sys_, U, F, omega = chain_problem(m, BANDS[case["band"]], 2 * m)
    load = load_average()
    cpu = resource.getrusage(resource.RUSAGE_SELF)
    res, secs = timed(lambda: identify(U, F, omega, lam, sym, solver=case["solver"]))
    after = resource.getrusage(resource.RUSAGE_SELF)
    out = {"seconds": secs, "errs": rel_errors(res, sys_), "n": res.n_unknowns}
    # CPU time of all threads: less sensitive than wall time to other jobs
    out["cpu_s"] = after.ru_utime - cpu.ru_utime + after.ru_stime - cpu.ru_stime
    out.update({f"t_{k}": v for k, v in res.info.get("timings", {}).items()})
    if case["solver"] == "cg":
        out["iterations"] = res.iterations
        out["residual"] = res.relative_residual
        # the same product by faer (the library's own f64 GEMM), which on some hosts
        # runs twice NumPy's rate (OpenBLAS picks an AVX2 kernel on AMD family 26);
        # first, since OpenBLAS's threads busy-wait ~0.1 s after NumPy's GEMM
        from podid_rs import _core

        out["faer_gemm_s"] = 18.0 * m**3 / (_core.operator_gemm_gflops(m, 3) * 1e9)
        out["gemm_s"] = operator_gemm_seconds(m)
    out["load"] = [load, load_average()]
    return out


def stall_case(case: dict) -> dict:
    """CG asked for an unattainable tol (1e-300): where it stops, and the default-tol solve."""
    from podid_rs import identify

    m = case["m"]
    lam, sym = MODES[case["mode"]]
    _, U, F, omega = chain_problem(m, BANDS[case["band"]], 2 * m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res, secs = timed(
            lambda: identify(
                U, F, omega, lam, sym, solver="cg", tol=1e-300, max_iter=case["max_iter"]
            )
        )
    conv = identify(U, F, omega, lam, sym, solver="cg")
    return {
        "seconds": secs,
        "iterations": res.iterations,
        "residual": res.relative_residual,
        "conv_iterations": conv.iterations,
        "conv_residual": conv.relative_residual,
    }


# ---------------------------------------------------------------------------
# The plain NumPy reference: PCG with the diagonal pair preconditioner


def numpy_pcg(U, F, omega, lam: float, symmetric: bool, tol: float = TOL):
    """Identify M, C, K by a plain NumPy PCG on the scaled normal equations.

    The formulation of docs/design.md §2–4: ω, U, F scaled to O(1); H = Re(V Vᴴ),
    B = Re(F Vᴴ); Z̃ = [X̃_M X̃_C X̃_K] in the eigenbasis Q of H_MM + H_CC + H_KK;
    operator Z̃ ↦ Z̃ H̃ (block-symmetrised, or plus 2λ̃²(X̃ − X̃ᵀ) per block); the
    preconditioner keeps of every block of H̃ its diagonal, which decouples the
    entry pairs (j, k) into 3×3 (6×6 with the penalty) solves. Returns
    (M, C, K, iterations).
    """
    w0 = np.sqrt(np.mean(omega**2))
    su, sf = np.sqrt(np.mean(np.abs(U) ** 2)), np.sqrt(np.mean(np.abs(F) ** 2))
    w, u, f = omega / w0, U / su, F / sf
    m = u.shape[1]
    V = np.concatenate([-(w**2)[:, None] * u, 1j * w[:, None] * u, u], axis=1)
    Vr = np.concatenate([V.real, V.imag])  # (2s, 3m): H = Re(V Vᴴ) = Vrᵀ Vr
    H = Vr.T @ Vr
    B = np.concatenate([f.real, f.imag]).T @ Vr
    blk = [H[b * m : (b + 1) * m, b * m : (b + 1) * m] for b in range(3)]
    Q = np.linalg.eigh(blk[0] + blk[1] + blk[2])[1]
    Ht = np.empty_like(H)
    for b in range(3):
        for c in range(3):
            Ht[b * m : (b + 1) * m, c * m : (c + 1) * m] = (
                Q.T @ H[b * m : (b + 1) * m, c * m : (c + 1) * m] @ Q
            )
    Bt = np.concatenate([Q.T @ B[:, b * m : (b + 1) * m] @ Q for b in range(3)], axis=1)
    factors = sf / su * np.array([1 / w0**2, 1 / w0, 1.0])  # X_b = c_b X̃_b
    pen = 4 * (lam * factors / sf) ** 2  # 4λ̃_b², λ̃_b = λ c_b / s_f (docs/design.md §3)

    # iterate on (S, K): the symmetric and skew parts of the blocks X̃_b, (3, m, m)
    # each; the penalty acts on K exactly (in plain entries it would swamp S)
    def op(S, K):
        Y = (S + K).transpose(1, 0, 2).reshape(m, 3 * m) @ Ht
        Y = Y.reshape(m, 3, m).transpose(1, 0, 2)
        Yt = Y.transpose(0, 2, 1)
        return 0.5 * (Y + Yt), 0.5 * (Y - Yt) + pen[:, None, None] * K

    idx = np.arange(m)
    D = np.stack([[Ht[b * m + idx, c * m + idx] for c in range(3)] for b in range(3)])
    D = D.transpose(2, 0, 1)  # D[k] = the 3×3 diagonals of the blocks at column k
    A = 0.5 * (D[:, None] + D[None, :])  # pair (j, k)
    C = 0.5 * (D[None, :] - D[:, None])
    Ainv = np.linalg.inv(A)
    P6inv = None if symmetric else np.linalg.inv(np.block([[A, C], [C, A + np.diag(pen)]]))

    def precond(S, K):
        # entries (j, k) of the sym/skew coordinates σ, τ (scaled alike: the
        # √2 of the orthonormal basis cancels in a block-diagonal solve)
        s, t = S.transpose(1, 2, 0), K.transpose(1, 2, 0)
        if symmetric:
            zs, zt = np.einsum("jkab,jkb->jka", Ainv, s), np.zeros_like(t)
        else:
            z = np.einsum("jkab,jkb->jka", P6inv, np.concatenate([s, t], axis=2))
            zs, zt = z[..., :3], z[..., 3:]
        # diagonal entries: D(k)⁻¹ (A = D there, C = 0, τ = 0)
        zs[idx, idx] = np.linalg.solve(D, s[idx, idx][..., None])[..., 0]
        zs = 0.5 * (zs + zs.transpose(1, 0, 2))
        zt = 0.5 * (zt - zt.transpose(1, 0, 2))
        return zs.transpose(2, 0, 1), zt.transpose(2, 0, 1)

    def dot(a, b):
        return float(np.vdot(a[0], b[0]) + np.vdot(a[1], b[1]))

    Bb = Bt.reshape(m, 3, m).transpose(1, 0, 2)
    b = (0.5 * (Bb + Bb.transpose(0, 2, 1)), 0.5 * (Bb - Bb.transpose(0, 2, 1)))
    if symmetric:
        b = (b[0], np.zeros_like(b[1]))
    bnorm = np.sqrt(dot(b, b))
    X = (np.zeros_like(b[0]), np.zeros_like(b[1]))
    R = (b[0].copy(), b[1].copy())
    Zr = precond(*R)
    P = Zr
    rz = dot(R, Zr)
    it = 0
    while it < 20_000:
        Qp = op(*P)
        if symmetric:
            Qp = (Qp[0], np.zeros_like(Qp[1]))
        alpha = rz / dot(P, Qp)
        X = (X[0] + alpha * P[0], X[1] + alpha * P[1])
        R = (R[0] - alpha * Qp[0], R[1] - alpha * Qp[1])
        it += 1
        if np.sqrt(dot(R, R)) / bnorm <= tol:
            # judged on the true residual, as the Rust path
            GX = op(*X)
            R = (b[0] - GX[0], b[1] - (0 if symmetric else GX[1]))
            if np.sqrt(dot(R, R)) / bnorm <= tol:
                break
        Zr = precond(*R)
        rz_new = dot(R, Zr)
        P = (Zr[0] + (rz_new / rz) * P[0], Zr[1] + (rz_new / rz) * P[1])
        rz = rz_new
    Xb = X[0] + X[1]
    M, C, K = (factors[b] * (Q @ Xb[b] @ Q.T) for b in range(3))
    return M, C, K, it


def reference_case(case: dict) -> dict:
    m = case["m"]
    lam, sym = MODES[case["mode"]]
    sys_, U, F, omega = chain_problem(m, BANDS[case["band"]], 2 * m)
    load = load_average()
    t = time.perf_counter()
    M, C, K, it = numpy_pcg(U, F, omega, lam, sym)
    secs = time.perf_counter() - t
    errs = [
        float(np.linalg.norm(X - T) / np.linalg.norm(T))
        for X, T in ((M, sys_.M), (C, sys_.C), (K, sys_.K))
    ]
    return {"seconds": secs, "iterations": it, "errs": errs, "load": [load, load_average()]}


# ---------------------------------------------------------------------------


def spread(mid: float, values: list[float]) -> str:
    """``mid``, and the range of ``values`` if there are several: "7.1 (6.2–8.0)"."""
    return f"{mid:.3g}" + (f" ({values[0]:.3g}–{values[-1]:.3g})" if len(values) > 1 else "")


def median_run(runs: list[dict]) -> dict | None:
    """The run of median time (the lower of the middle two for an even count)."""
    return sorted(runs, key=lambda x: x["seconds"])[(len(runs) - 1) // 2] if runs else None


def main_cg(args: argparse.Namespace, me: str) -> str:
    rows, notes, loads, checks = [], [], [], []
    ref_sizes = {int(x) for x in args.ref_sizes.split(",") if x}
    for band in args.bands.split(","):
        for mode in args.modes.split(","):
            for m in [int(x) for x in args.sizes.split(",")]:
                case = {"kind": "solve", "solver": "cg", "m": m, "band": band, "mode": mode}
                runs, refs = [], []
                for _ in range(args.pairs):
                    runs.append(run_worker(me, case))
                    if "error" in runs[-1]:
                        break
                    if m in ref_sizes:
                        refs.append(run_worker(me, {**case, "kind": "reference"}))
                        if "error" in refs[-1]:
                            notes.append(
                                f"NumPy reference {band} {mode} m={m}: {refs[-1]['error']}"
                            )
                            refs = []
                            break
                if "error" in runs[-1]:
                    notes.append(f"{band} {mode} m={m}: {runs[-1]['error']}")
                    print(notes[-1], flush=True)
                    continue
                # the run of median time stands for the case; the ratios are each
                # pair's own (CG and its reference run back to back), median and range
                r, ref = median_run(runs), median_run(refs)
                it, t_it = r["iterations"], r["t_iterate"]
                x_gemms = sorted(x["seconds"] / x["gemm_s"] for x in runs)
                x_gemm = float(np.median(x_gemms))
                x_faers = sorted(x["seconds"] / x["faer_gemm_s"] for x in runs)
                x_faer = float(np.median(x_faers))
                case_loads = [v for x in runs + refs for v in x["load"] if v is not None]
                loads += case_loads
                pairs = zip(refs, runs, strict=True) if refs else []
                ratios = sorted(a["seconds"] / b["seconds"] for a, b in pairs)
                speedup = float(np.median(ratios)) if ratios else None
                rows.append([
                    band, mode, m, r["n"], r["seconds"], r["cpu_s"], it, max(r["errs"]),
                    r["peak_gb"],
                    r["gemm_s"], spread(x_gemm, x_gemms), spread(x_faer, x_faers),
                    t_it / it if it else None,
                    r["t_gram"], r["t_setup"], r.get("t_solves"), r.get("t_residual"),
                    val(ref, "seconds"), val(ref, "iterations"),
                    max(ref["errs"]) if ref else None,
                    spread(speedup, ratios) if ratios else None,
                    f"{min(case_loads):.1f}–{max(case_loads):.1f}" if case_loads else None,
                ])  # fmt: skip
                print(
                    f"{band:6s} {mode} m={m:5d}: {r['seconds']:7.2f}s (CPU {r['cpu_s']:.1f}s)  "
                    f"{it:4d} it  "
                    f"err {max(r['errs']):.1e}  {r['peak_gb']:.2f} GB  "
                    f"{spread(x_gemm, x_gemms)}× GEMM ({spread(x_faer, x_faers)}× faer's)"
                    + (f"  ref {ref['seconds']:.2f}s ({spread(speedup, ratios)}×)" if ref else "")
                    + f"  load {r['load']}",
                    flush=True,
                )
                err = max(x for run in runs for x in run["errs"])
                over = f" (median and range of {len(runs)} runs)" if len(runs) > 1 else ""
                if band == "narrow" and m == 1000:
                    checks.append(
                        f"m = 1000, 20 % band, {mode}: {spread(x_gemm, x_gemms)}× one GEMM{over} "
                        f"(target ≤ 45; {spread(x_faer, x_faers)}× faer's f64 GEMM), error "
                        f"{err:.1e} (target ≤ 1e-8)"
                    )
                if speedup is not None and m == 400:
                    checks.append(
                        f"m = 400, {band}, {mode}: {spread(speedup, ratios)}× the NumPy PCG "
                        f"reference{over} (target ≥ 8)"
                    )
                if band == "wide" and 400 <= m <= 1000:
                    checks.append(f"50–150 Hz, {mode}, m = {m}: {it} iterations (target ≤ 150)")
    header = [
        "band", "mode", "m", "unknowns", "time s", "CPU s", "iterations", "max rel. error",
        "peak GB",
        "NumPy GEMM s", "× GEMM", "× faer GEMM", "s/iteration", "gram s", "setup s",
        "solves s", "residual s",
        "NumPy PCG s",
        "NumPy PCG it", "NumPy PCG error", "ref / CG", "load",
    ]  # fmt: skip
    load_note = (
        f"1-minute load average during the cases: {min(loads):.1f}–{max(loads):.1f} "
        "(2 cores; above 1 means other processes were competing)."
        if loads
        else ""
    )
    return (
        "CG path: full-order chain, noise-free, s = 2m lines, random forces on "
        "every DOF; bands narrow = 102.8–122.8 Hz, wide = 50–150 Hz; modes sym = "
        f"exact-symmetric, pen = penalty λ = 100; tol {TOL:g}. "
        f"NumPy GEMM (n = 4000) {args.numpy_gemm:.1f} GFLOP/s ({args.blas}). First write to "
        f"fresh memory {args.first_touch:.2f} µs per 4 KiB page beyond a rewrite (256 MiB "
        "probe; 0.1–0.2 for pages the kernel freed moments before, 7–13 on a VM that hands "
        "freed memory back to its host).\n"
        "time = the whole identify() call (CPU s: its CPU time, all threads); × GEMM = "
        "time over one NumPy float64 GEMM of the operator's shape (m×3m by 3m×3m) timed "
        "in the same process (the reference), × faer GEMM the same over faer's "
        "float64 GEMM of that shape (the library's own; the machine's f64 rate where "
        "NumPy's BLAS falls short of it); solves = the "
        "preconditioner's triangular solves (most of the iterations), residual = ‖Ax − y‖ "
        "after the solve; NumPy PCG = the plain "
        "NumPy reference (diagonal pair preconditioner, same tol) in its own process; "
        "ref / CG = its time over identify()'s. "
        f"Each case ran {args.pairs} time(s), each run followed by its reference run: the "
        "row is the run of median time; × GEMM and ref / CG are the median over the runs "
        "(each run's own GEMM, each pair's own ratio) and, in brackets, their range.\n"
        + load_note
        + "\n\n"
        + markdown_table(header, rows)
        + ("\n\nTargets:\n" + "\n".join(f"- {c}" for c in checks) if checks else "")
        + ("\n\n" + "\n".join(notes) if notes else "")
    )


def grid(args: argparse.Namespace, sizes: str) -> list[tuple[str, str, int]]:
    """(band, mode, m) of every case: the bands, modes and the given sizes."""
    return [
        (band, mode, int(m))
        for band in args.bands.split(",")
        for mode in args.modes.split(",")
        for m in sizes.split(",")
    ]


def crossover_case(case: dict) -> dict:
    """Direct against CG on one problem, alternating in one process.

    Each solver is called ``repeat`` times after one warm-up call of each, the two
    alternating, so both see the same moments of a shared host; the median of the
    whole ``identify`` calls' wall times is kept (and of the Rust core's), and the
    fastest: on a shared host the median carries the other jobs' moments, the minimum
    the solver's own cost.
    """
    from podid_rs import identify

    m = case["m"]
    lam, sym = MODES[case["mode"]]
    sys_, U, F, omega = chain_problem(m, BANDS[case["band"]], 2 * m)
    load = load_average()
    walls: dict[str, list[float]] = {"direct": [], "cg": []}
    cores: dict[str, list[float]] = {"direct": [], "cg": []}
    res = {}
    for k in range(case["repeat"] + 1):
        for solver in ("direct", "cg"):
            t = time.perf_counter()
            res[solver] = identify(U, F, omega, lam, sym, solver=solver)
            secs = time.perf_counter() - t
            if k:  # the first call of each is a warm-up
                walls[solver].append(secs)
                cores[solver].append(res[solver].info["timings"]["total"])
    d, c = res["direct"], res["cg"]
    diff = max(
        float(np.linalg.norm(a - b) / np.linalg.norm(b))
        for a, b in ((c.M, d.M), (c.C, d.C), (c.K, d.K))
    )
    return {
        "n": d.n_unknowns,
        "direct_s": float(np.median(walls["direct"])),
        "cg_s": float(np.median(walls["cg"])),
        "direct_core_s": float(np.median(cores["direct"])),
        "cg_core_s": float(np.median(cores["cg"])),
        "direct_min_s": min(walls["direct"]),
        "cg_min_s": min(walls["cg"]),
        "iterations": c.iterations,
        "cg_vs_direct": diff,
        "direct_err": max(rel_errors(d, sys_)),
        "load": [load, load_average()],
    }


def main_auto(args: argparse.Namespace, me: str) -> str:
    """Direct against CG by unknowns: where ``solver="auto"`` should switch."""
    from podid_rs.identification.solvers import AUTO_DIRECT_MAX_UNKNOWNS

    rows, loads, cross = [], [], []
    for band in args.bands.split(","):
        for mode in args.modes.split(","):
            faster = []  # (unknowns, CG faster?)
            for m in [int(x) for x in args.auto_sizes.split(",")]:
                base = {"kind": "crossover", "m": m, "band": band, "mode": mode}
                r = run_worker(me, {**base, "repeat": args.auto_repeat})
                if "error" in r:
                    print(f"{band} {mode} m={m}: {r['error']}", flush=True)
                    continue
                loads += [x for x in r["load"] if x is not None]
                speed = r["direct_s"] / r["cg_s"]
                speed_min = r["direct_min_s"] / r["cg_min_s"]
                # judged by the fastest calls: the medians carry other jobs' spikes
                faster.append((r["n"], speed_min > 1))
                rows.append([
                    band, mode, m, r["n"], r["direct_s"], r["cg_s"], speed,
                    r["direct_min_s"], r["cg_min_s"], speed_min, r["direct_core_s"],
                    r["cg_core_s"], r["iterations"], r["cg_vs_direct"],
                    r["direct_err"], "–".join(f"{x:.1f}" for x in r["load"] if x is not None),
                ])  # fmt: skip
                print(
                    f"{band:6s} {mode} m={m:3d} ({r['n']:5d} unknowns): direct "
                    f"{r['direct_s'] * 1e3:8.2f} ms, cg {r['cg_s'] * 1e3:8.2f} ms "
                    f"({r['iterations']} it)  direct/cg {speed:5.2f} (fastest {speed_min:5.2f})  "
                    f"cg-direct {r['cg_vs_direct']:.1e}  load {r['load']}",
                    flush=True,
                )
            # the crossover: the largest size at which direct is still faster, and
            # the smallest from which CG is faster at every larger size measured
            slower = [n for n, f in faster if not f]
            from_on = min((n for n, _ in faster if n > max(slower, default=0)), default=None)
            cross.append(
                f"{band}, {mode}: direct faster up to {max(slower, default='—')} unknowns, "
                f"CG faster from {from_on if from_on is not None else '—'} on"
            )
            print(cross[-1], flush=True)
    header = [
        "band", "mode", "m", "unknowns", "direct s", "cg s", "direct / cg", "direct min s",
        "cg min s", "direct / cg (min)", "direct core s",
        "cg core s", "cg iterations", "cg vs direct", "direct vs truth", "load",
    ]  # fmt: skip
    return (
        "Direct against CG (the `solver='auto'` rule): full-order chain, noise-free, "
        "s = 2m lines; times are the median (and the fastest) whole identify() call over "
        f"{args.auto_repeat} calls of each solver, alternating in one process after one "
        "warm-up call each (core s: the Rust core's own time); cg vs direct = max relative "
        "difference of M, C, K; the crossover is judged by the fastest calls (on a shared "
        "host the medians carry other jobs' spikes). "
        f"AUTO_DIRECT_MAX_UNKNOWNS = {AUTO_DIRECT_MAX_UNKNOWNS} in this build; "
        f"load average {min(loads, default=0):.1f}–{max(loads, default=0):.1f}.\n\n"
        + markdown_table(header, rows)
        + "\n\nCrossover:\n"
        + "\n".join(f"- {c}" for c in cross)
    )


def main_stall(args: argparse.Namespace, me: str) -> str:
    rows = []
    for band, mode, m in grid(args, args.stall_sizes):
        case = {"kind": "stall", "m": m, "band": band, "mode": mode}
        r = run_worker(me, {**case, "max_iter": args.stall_max_iter})
        rows.append([
            band, mode, m, val(r, "iterations"), val(r, "residual"), val(r, "seconds"),
            val(r, "conv_iterations"), val(r, "conv_residual"),
        ])  # fmt: skip
        print(f"{band:6s} {mode} m={m:3d}: {r}", flush=True)
    header = [
        "band", "mode", "m", "iterations (tol 1e-300)", "true residual", "time s",
        "iterations (default tol)", "residual (default tol)",
    ]  # fmt: skip
    return (
        "CG at an unattainable tol (1e-300, max_iter "
        f"{args.stall_max_iter}): the iteration should stop by itself near the attainable "
        f"accuracy (≈ 1e-14), not at max_iter; load average {load_average()}.\n\n"
        + markdown_table(header, rows)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="400,1000")
    ap.add_argument("--bands", default="narrow,wide")
    ap.add_argument("--modes", default="sym,pen")
    ap.add_argument("--ref-sizes", default="400", help="sizes that also run the NumPy PCG")
    ap.add_argument(
        "--pairs",
        type=int,
        default=1,
        help="runs of each case, alternating with its reference: medians and ranges",
    )
    ap.add_argument("--auto", action="store_true", help="time direct against CG instead")
    ap.add_argument("--auto-sizes", default="4,6,8,10,12,14,16,18,20,22,25,30")
    ap.add_argument("--auto-repeat", type=int, default=15, help="calls of each solver")
    ap.add_argument("--stall", action="store_true", help="tol 1e-300: where CG stops")
    ap.add_argument("--stall-sizes", default="20,30,60")
    ap.add_argument("--stall-max-iter", type=int, default=20_000)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    if args.pairs < 1:
        ap.error("--pairs must be at least 1")
    me = str(Path(__file__).resolve())
    args.first_touch = first_touch_us_per_page()
    print(f"first touch of fresh memory: {args.first_touch:.2f} µs per page", flush=True)
    args.numpy_gemm = gemm_gflops()
    args.blas = blas_kernel()
    print(f"NumPy GEMM rate (n = 4000): {args.numpy_gemm:.1f} GFLOP/s", flush=True)
    if args.stall:
        text, name = main_stall(args, me), "cg_stall.md"
    elif args.auto:
        text, name = main_auto(args, me), "cg_auto.md"
    else:
        text, name = main_cg(args, me), "cg.md"
    write_report(text, args.out or Path("bench-results") / name)


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main(
            {
                "solve": solve_case,
                "reference": reference_case,
                "stall": stall_case,
                "crossover": crossover_case,
            }
        )
    else:
        main()
