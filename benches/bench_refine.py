"""Output-error refinement benchmark: podid_rs against SciPy, and large m.

Problem: ``mass_spring_chain(m)`` at full order (R = I), random complex forces on
every DOF at s lines over 5–200 Hz, complex noise of 0.1 % RMS of |U| on the
responses; the start is the paper's estimator ``identify(U, F, omega,
symmetric=True)``, relative weights (the default), stopping ``ftol`` = 1e-5.

* ``scipy`` (default part, m = 20, s = 800): ``refine()`` against
  ``scipy.optimize.least_squares`` (trust-region reflective, exact steps: SciPy's
  best on a dense problem of this size) on the same residual, parametrisation and
  analytic Jacobian written in NumPy (``_oe_numpy.py``), from the same start θ₀,
  ``ftol`` the same, ``xtol`` = 1e-12. Time per converged fit and the final cost.
* ``large`` (m = 100, s = 2000): ``refine()`` with the automatic (matrix-free)
  step: time, steps, peak memory; the dense normal matrix would be
  (3m(m+1)/2)² doubles.
* ``metric``: the matrix-free step with ``metric="diagonal"`` and ``"modal"``
  (``refine``'s default for a matrix-free step) at the m:s pairs of
  ``--metric-sizes`` (and dense up to ``--metric-dense-max``).
* ``--crossover``: dense against matrix-free steps over m at s = 800 (the rule of
  ``solver="auto"``).

Every case runs in its own process (its time and peak memory are its own).

    python benches/bench_refine.py                      # scipy + large (≈ 10 min)
    python benches/bench_refine.py --parts scipy
    python benches/bench_refine.py --parts large --curvature   # refine(curvature=True)
    python benches/bench_refine.py --crossover --sizes 10,20,30,40,50
    python benches/bench_refine.py --parts metric           # metric='diagonal' vs 'modal'
    python benches/bench_refine.py --parts large --metric diagonal  # (default: auto = modal)
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    chain_problem,
    load_average,
    markdown_table,
    ratio,
    rel_errors,
    run_worker,
    timed,
    val,
    worker_main,
    write_report,
)

BAND_HZ = (5.0, 200.0)
NOISE = 1e-3
FTOL = 1e-5
XTOL = 1e-12


def problem(m: int, s: int):
    """The chain data and the paper's estimator as the start."""
    from podid_rs import identify

    sys_, U, F, omega = chain_problem(m, BAND_HZ, s, noise=NOISE, seed=1)
    start = identify(U, F, omega, symmetric=True)
    return sys_, U, F, omega, start


def podid_case(case: dict) -> dict:
    from podid_rs.identification.refinement import refine

    sys_, U, F, omega, start = problem(case["m"], case["s"])
    load = load_average()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res, secs = timed(
            lambda: refine(
                start, U, F, omega, ftol=FTOL, solver=case.get("solver", "auto"),
                max_iter=case.get("max_iter") or 200, curvature=case.get("curvature", False),
                metric=case.get("metric", "auto"),
            )
        )  # fmt: skip
    rep = res.info["refinement"]
    return {
        "seconds": secs,
        "core": rep["timings"]["total"],
        "iterations": res.iterations,
        "accepted": rep["accepted"],
        "stop": rep["stop"],
        "cost_start": rep["cost_start"],
        "cost": rep["cost"],
        "db_before": rep["db_before"][0],
        "db_after": rep["db_after"][0],
        "solver": rep["solver"],
        "cg": rep["solver_stats"].get("cg_iterations"),
        "timings": rep["timings"],
        "errs": rel_errors(res, sys_),
        "mck": [X.tolist() for X in (res.M, res.C, res.K)] if case.get("keep") else None,
        "load": [load, load_average()],
    }


def scipy_case(case: dict) -> dict:
    from scipy.optimize import least_squares

    from _oe_numpy import OutputError
    from podid_rs.identification.refinement import physical_start

    sys_, U, F, omega, start = problem(case["m"], case["s"])
    (M1, C1, K1), _ = physical_start(start.M, start.C, start.K)
    w = 1.0 / np.linalg.norm(U, axis=1)  # the "relative" weights of refine()
    pb = OutputError(U[:, :, None], F[:, :, None], omega, w[:, None])
    theta0 = pb.theta_from_model(M1, C1, K1)
    load = load_average()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        res, secs = timed(
            lambda: least_squares(
                pb.residual, theta0, jac=pb.jacobian, method="trf", ftol=FTOL, xtol=XTOL,
                max_nfev=case.get("max_nfev"),
            )
        )  # fmt: skip
    M, C, K = pb.model(res.x)

    class _R:  # rel_errors wants .M, .C, .K
        pass

    r = _R()
    r.M, r.C, r.K = M, C, K
    return {
        "seconds": secs,
        "nfev": int(res.nfev),
        "njev": int(res.njev),
        "status": int(res.status),
        "cost_start": pb.cost(theta0),
        "cost": pb.cost(res.x),
        "errs": rel_errors(r, sys_),
        "load": [load, load_average()],
    }


def loads_of(*rs: dict | None) -> list[float]:
    return [x for r in rs if r and "load" in r for x in r["load"] if x is not None]


def main_scipy(args: argparse.Namespace, me: str) -> str:
    m, s = args.m, args.s
    pod = run_worker(me, {"kind": "podid", "m": m, "s": s, "solver": "auto"})
    print(f"podid_rs m={m} s={s}: {pod}", flush=True)
    sci = run_worker(me, {"kind": "scipy", "m": m, "s": s, "max_nfev": args.max_nfev})
    print(f"scipy    m={m} s={s}: {sci}", flush=True)
    header = [
        "", "time s", "steps (Jacobians)", "stop", "cost start", "final cost",
        "err M", "err C", "err K", "peak GB",
    ]  # fmt: skip
    rows = [
        ["podid_rs refine()", val(pod, "seconds"),
         f"{val(pod, 'iterations')} ({val(pod, 'accepted')} accepted)", val(pod, "stop"),
         val(pod, "cost_start"), val(pod, "cost"), *(val(pod, "errs") or [None] * 3),
         val(pod, "peak_gb")],
        ["SciPy least_squares (trf, analytic J)", val(sci, "seconds"),
         f"{val(sci, 'nfev')} ({val(sci, 'njev')})", f"status {val(sci, 'status')}",
         val(sci, "cost_start"), val(sci, "cost"), *(val(sci, "errs") or [None] * 3),
         val(sci, "peak_gb")],
    ]  # fmt: skip
    speed = ratio(val(sci, "seconds"), val(pod, "seconds"))
    per_jac = ratio(
        ratio(val(sci, "seconds"), val(sci, "njev")),
        ratio(val(pod, "seconds"), (val(pod, "accepted") or 0) + 1),
    )
    loads = loads_of(pod, sci)
    return (
        f"Output error against SciPy: chain m = {m} at full order, s = {s} lines over "
        f"{BAND_HZ[0]:g}–{BAND_HZ[1]:g} Hz, {NOISE:g} noise, start = identify(symmetric=True), "
        f"relative weights, ftol = {FTOL:g}, xtol = {XTOL:g}; podid_rs solver "
        f"'{val(pod, 'solver')}'. SciPy is given the same residual, parametrisation and "
        "analytic Jacobian (benches/_oe_numpy.py) and the same θ₀; costs are Σ‖W(x − u)‖² "
        "in the caller's units; err = ‖X − X_true‖/‖X_true‖ (noise keeps it above 0).\n"
        + (
            f"1-minute load average during the cases: {min(loads):.1f}–{max(loads):.1f} "
            "(2 cores).\n"
            if loads
            else ""
        )  # fmt: skip
        + "\n"
        + markdown_table(header, rows)
        + "\n\n"
        + f"**Speed-up per converged fit: {speed:.1f}×** (SciPy time / podid_rs time, whole "
        "calls); per Jacobian (SciPy time / njev against podid_rs time / (accepted + 1)): "
        + (f"{per_jac:.0f}×." if per_jac else "—.")
        if speed
        else markdown_table(header, rows)
    )


def main_large(args: argparse.Namespace, me: str) -> str:
    m, s = args.large_m, args.large_s
    case = {"kind": "podid", "m": m, "s": s, "solver": "auto", "max_iter": args.large_max_iter,
            "curvature": args.curvature, "metric": args.metric}  # fmt: skip
    r = run_worker(me, case, timeout=7200)
    print(f"podid_rs m={m} s={s}: {r}", flush=True)
    n = 3 * m * (m + 1) // 2
    header = [
        "m", "s", "solver", "time s", "core s", "steps", "CG products", "stop",
        "cost start", "final cost", "median dB before", "after", "peak GB",
        "dense N_θ GB", "s per step", "s per product", "diagonal s",
    ]  # fmt: skip
    t = val(r, "timings") or {}
    row = [
        m, s, val(r, "solver"), val(r, "seconds"), val(r, "core"),
        f"{val(r, 'iterations')} ({val(r, 'accepted')} accepted)", val(r, "cg"),
        val(r, "stop"), val(r, "cost_start"), val(r, "cost"), val(r, "db_before"),
        val(r, "db_after"), val(r, "peak_gb"), n * n * 8 / 1e9,
        ratio(val(r, "core"), val(r, "iterations")),
        ratio(t.get("matfree_products"), val(r, "cg")), t.get("matfree_diagonal"),
    ]  # fmt: skip
    loads = loads_of(r)
    return (
        f"Large m: the same problem at m = {m}, s = {s} ({n} unknowns); solver='auto', "
        f"curvature={args.curvature}, metric={args.metric!r}. "
        "Time = the whole refine() call, 2 cores.\n"
        + (f"1-minute load average: {min(loads):.1f}–{max(loads):.1f}.\n" if loads else "")
        + "\n"
        + markdown_table(header, [row])
        + ("" if "error" not in r else f"\n\n{r['error']}")
    )


def main_metric(args: argparse.Namespace, me: str) -> str:
    """The matrix-free step with metric='diagonal' and 'modal', and the dense step."""
    rows, loads = [], []
    for spec in args.metric_sizes.split(","):
        m, s = (int(x) for x in spec.split(":"))
        base = {"kind": "podid", "m": m, "s": s}
        runs = [("matrix-free, diagonal", {**base, "solver": "matrix-free", "metric": "diagonal"}),
                ("matrix-free, modal", {**base, "metric": "modal"})]  # fmt: skip
        if m <= args.metric_dense_max:
            runs.append(("dense", {**base, "solver": "dense"}))
        for name, case in runs:
            r = run_worker(me, case, timeout=7200)
            loads += loads_of(r)
            rows.append([
                m, s, name, val(r, "seconds"), f"{val(r, 'iterations')} ({val(r, 'accepted')})",
                val(r, "cg"), val(r, "stop"), val(r, "cost_start"), val(r, "cost"),
                val(r, "peak_gb"),
            ])  # fmt: skip
            print(f"m={m} s={s} {name}: {val(r, 'seconds')} s, cost {val(r, 'cost')}", flush=True)
    header = ["m", "s", "step", "time s", "steps (accepted)", "CG products", "stop",
              "cost start", "final cost", "peak GB"]  # fmt: skip
    return (
        "The matrix-free step's metric (LM damping and CG preconditioner): μ·diag N_θ "
        "against the modal metric with steps in X (the default); the dense step for "
        "reference. Whole refine() calls, max_iter 200.\n"
        + (f"1-minute load average: {min(loads):.1f}–{max(loads):.1f} (2 cores).\n"
           if loads else "")  # fmt: skip
        + "\n"
        + markdown_table(header, rows)
    )


def main_crossover(args: argparse.Namespace, me: str) -> str:
    rows, loads = [], []
    for m in [int(x) for x in args.sizes.split(",")]:
        base = {"kind": "podid", "m": m, "s": args.s, "keep": True}
        d = run_worker(me, {**base, "solver": "dense"})
        f = run_worker(me, {**base, "solver": "matrix-free"})
        loads += loads_of(d, f)
        diff = None
        if "error" not in d and "error" not in f:
            diff = max(
                float(np.linalg.norm(np.subtract(a, b)) / np.linalg.norm(a))
                for a, b in zip(d["mck"], f["mck"], strict=True)
            )
        rows.append([
            m, args.s, val(d, "seconds"), val(f, "seconds"),
            ratio(val(d, "seconds"), val(f, "seconds")), val(d, "iterations"),
            val(f, "iterations"), val(f, "cg"), val(d, "cost"), val(f, "cost"), diff,
            val(d, "peak_gb"), val(f, "peak_gb"),
        ])  # fmt: skip
        print(f"m={m:3d}: dense {val(d, 'seconds')} s, matrix-free {val(f, 'seconds')} s",
              flush=True)  # fmt: skip
    header = [
        "m", "s", "dense s", "matrix-free s", "dense / mf", "dense steps", "mf steps",
        "CG products", "dense cost", "mf cost", "max rel. diff M,C,K", "dense GB", "mf GB",
    ]  # fmt: skip
    return (
        f"Dense against matrix-free steps (the solver='auto' rule): the problem above at "
        f"s = {args.s}, whole refine() calls.\n"
        + (
            f"1-minute load average: {min(loads):.1f}–{max(loads):.1f} (2 cores).\n"
            if loads
            else ""
        )  # fmt: skip
        + "\n"
        + markdown_table(header, rows)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", default="scipy,large", help="scipy, large, metric")
    ap.add_argument("--metric", default="auto", choices=("auto", "diagonal", "modal"),
                    help="the large case's metric (auto: refine()'s default)")  # fmt: skip
    ap.add_argument("--metric-sizes", default="40:1000,60:1200",
                    help="m:s pairs of the metric part")  # fmt: skip
    ap.add_argument("--metric-dense-max", type=int, default=40,
                    help="the metric part runs the dense step up to this m")  # fmt: skip
    ap.add_argument("--m", type=int, default=20)
    ap.add_argument("--s", type=int, default=800)
    ap.add_argument("--max-nfev", type=int, default=None, help="cap SciPy's evaluations")
    ap.add_argument("--large-m", type=int, default=100)
    ap.add_argument("--large-s", type=int, default=2000)
    ap.add_argument("--large-max-iter", type=int, default=None, help="cap the large case's steps")
    ap.add_argument("--curvature", action="store_true",
                    help="the large case with refine(curvature=True)")  # fmt: skip
    ap.add_argument("--crossover", action="store_true", help="dense vs matrix-free over m")
    ap.add_argument("--sizes", default="10,20,30,40,50")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    me = str(Path(__file__).resolve())
    if args.crossover:
        text = main_crossover(args, me)
        name = "refine_crossover.md"
    else:
        parts = args.parts.split(",")
        texts = []
        if "scipy" in parts:
            texts.append(main_scipy(args, me))
        if "large" in parts:
            texts.append(main_large(args, me))
        if "metric" in parts:
            texts.append(main_metric(args, me))
        text = "\n\n".join(texts)
        name = "refine.md"
    write_report(text, args.out or Path("bench-results") / name)


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main({"podid": podid_case, "scipy": scipy_case})
    else:
        main()
