"""Matrix-free CG benchmark (issue 5): large reduced orders on the full-order chain.

Problem: ``mass_spring_chain(n)`` identified at full order (R = I, so m = n),
noise-free, random complex forces on every DOF, s = 2n lines evenly spaced in a
band: the paper's 20 % band 102.8–122.8 Hz ("narrow") and 50–150 Hz ("wide").
Modes: exact-symmetric (``symmetric=True``) and the penalty form at the paper's
λ = 100. Every case runs in its own process (time and peak memory are its own);
the floor of an iteration — 18m³ flops of the operator's GEMM at the rate faer
reaches on an m×3m by 3m×3m product — is measured in the same process right
after the solve.

    python benches/bench_cg.py                          # m = 100 … 1000 (≈ 30 min)
    python benches/bench_cg.py --sizes 100,200 --modes sym
    python benches/bench_cg.py --auto                   # direct vs CG, m = 10 … 60
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    chain_problem,
    gemm_gflops,
    load_average,
    markdown_table,
    rel_errors,
    run_worker,
    timed,
    worker_main,
)

BANDS = {"narrow": (102.8, 122.8), "wide": (50.0, 150.0)}
MODES = {"sym": (0.0, True), "pen": (100.0, False)}


def solve_case(case: dict) -> dict:
    from podid_rs import _core, identify

    m = case["m"]
    lam, sym = MODES[case["mode"]]
    sys_, U, F, omega = chain_problem(m, BANDS[case["band"]], 2 * m)
    load = load_average()
    res, secs = timed(lambda: identify(U, F, omega, lam, sym, solver=case["solver"]))
    out = {"seconds": secs, "errs": rel_errors(res, sys_), "n": res.n_unknowns}
    out.update({f"t_{k}": v for k, v in res.info.get("timings", {}).items()})
    if case["solver"] == "cg":
        out["iterations"] = res.iterations
        out["residual"] = res.relative_residual
        out["gflops"] = _core.operator_gemm_gflops(m, max(3, int(1e10 / (18 * m**3))))
    out["load"] = [load, load_average()]
    return out


def val(r: dict | None, key: str) -> object:
    return r.get(key) if r and "error" not in r else None


def main_cg(args: argparse.Namespace, me: str) -> str:
    rows, notes, loads = [], [], []
    for band in args.bands.split(","):
        for mode in args.modes.split(","):
            for m in [int(x) for x in args.sizes.split(",")]:
                r = run_worker(me, {"kind": "solve", "solver": "cg", "m": m,
                                    "band": band, "mode": mode})  # fmt: skip
                if "error" in r:
                    notes.append(f"{band} {mode} m={m}: {r['error']}")
                    print(notes[-1], flush=True)
                    continue
                it, t_it = r["iterations"], r["t_iterate"]
                per_it = t_it / it if it else None
                floor = 18 * m**3 / (r["gflops"] * 1e9)
                loads += [x for x in r["load"] if x is not None]
                row = [
                    band, mode, m, r["n"], r["seconds"], r["t_total"], it, r["residual"],
                    *r["errs"], r["peak_gb"], per_it, floor,
                    per_it / floor if per_it else None, t_it / r["t_gemm"], r["gflops"],
                ]  # fmt: skip
                rows.append(row)
                print(
                    f"{band:6s} {mode} m={m:5d}: {r['seconds']:7.2f}s  {it:5d} it  "
                    f"err {max(r['errs']):.1e}  {r['peak_gb']:.2f} GB  "
                    f"{per_it * 1e3:.1f} ms/it vs floor {floor * 1e3:.1f} ms  "
                    f"load {r['load']}",
                    flush=True,
                )
    header = [
        "band", "mode", "m", "unknowns", "time s", "core s", "iterations", "rel. residual",
        "err M", "err C", "err K", "peak GB", "s/iteration", "floor s/it", "× floor",
        "× in-loop GEMM", "GEMM GF/s",
    ]  # fmt: skip
    load_note = (
        f"1-minute load average during the cases: {min(loads):.1f}–{max(loads):.1f} "
        "(2 cores; above 1 means other processes were competing)."
        if loads
        else ""
    )
    return (
        "CG path (issue 5): full-order chain, noise-free, s = 2m lines, random forces on "
        "every DOF; bands narrow = 102.8–122.8 Hz, wide = 50–150 Hz; modes sym = "
        "exact-symmetric, pen = penalty λ = 100; default tol "
        f"(1e-11). NumPy GEMM {args.numpy_gemm:.1f} GFLOP/s.\n"
        "time = the whole identify() call; core = the Rust solve (Gram products, "
        "preconditioner setup, iterations); floor = 18m³ flops per iteration at the "
        "GEMM rate faer reached on the operator's m×3m by 3m×3m product in the same "
        "process (best of several); s/iteration includes the preconditioner, packing, "
        "vector updates and the true-residual checks; × in-loop GEMM = iteration time over "
        "the time the same iterations spent inside the GEMM (robust to other processes' "
        "load, which the standalone floor is not).\n"
        + load_note
        + "\n\n"
        + markdown_table(header, rows)
        + ("\n\n" + "\n".join(notes) if notes else "")
    )


def main_auto(args: argparse.Namespace, me: str) -> str:
    rows = []
    for band in args.bands.split(","):
        for mode in args.modes.split(","):
            for m in [int(x) for x in args.auto_sizes.split(",")]:
                base = {"kind": "solve", "m": m, "band": band, "mode": mode}
                d = run_worker(me, {**base, "solver": "direct"})
                c = run_worker(me, {**base, "solver": "cg"})
                td, tc = val(d, "t_total"), val(c, "t_total")
                rows.append([
                    band, mode, m, val(c, "n"), td, tc, val(c, "iterations"),
                    td / tc if td and tc else None, val(d, "peak_gb"), val(c, "peak_gb"),
                ])  # fmt: skip
                print(f"{band:6s} {mode} m={m:3d}: direct {td} s, cg {tc} s", flush=True)
    header = [
        "band", "mode", "m", "unknowns", "direct core s", "cg core s", "cg iterations",
        "direct / cg", "direct GB", "cg GB",
    ]  # fmt: skip
    return (
        "Direct vs CG (the `solver='auto'` rule): same problems as the CG table, "
        "Rust core time of each solver.\n\n" + markdown_table(header, rows)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100,200,400,800,1000")
    ap.add_argument("--bands", default="narrow,wide")
    ap.add_argument("--modes", default="sym,pen")
    ap.add_argument("--auto", action="store_true", help="time direct against CG instead")
    ap.add_argument("--auto-sizes", default="10,15,20,25,30,40,50,60")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    me = str(Path(__file__).resolve())
    args.numpy_gemm = gemm_gflops()
    print(f"NumPy GEMM rate (n = 4000): {args.numpy_gemm:.1f} GFLOP/s", flush=True)
    text = main_auto(args, me) if args.auto else main_cg(args, me)
    out = args.out or Path("bench-results") / ("cg_auto.md" if args.auto else "cg.md")
    print("\n" + text)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")
    print(f"\nwritten to {out}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main({"solve": solve_case})
    else:
        main()
