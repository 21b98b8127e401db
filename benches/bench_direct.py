"""Direct path benchmark: Rust vs NumPy structured vs the Kronecker oracle.

Problem: the full-order chain ``mass_spring_chain(m)`` (R = I), random complex
forces on every DOF, s = 400 lines over 5–200 Hz, λ = 100 (penalty mode, 3m²
unknowns) and the exact-symmetric mode (3m(m+1)/2 unknowns). Every case runs in
its own process (time and peak memory are its own). The machine's limits are
measured in the same run: NumPy's GEMM rate and scipy's Cholesky at the same
order as our penalty-mode normal matrix.

    python benches/bench_direct.py                    # m = 5 … 100 (≈ 10 min)
    python benches/bench_direct.py --sizes 5,10,20,30 # quicker
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    chain_problem,
    gemm_gflops,
    host_line,
    markdown_table,
    ratio,
    run_worker,
    scipy_cholesky,
    timed,
    val,
    worker_main,
)

S_LINES = 400
LAM = 100.0


def max_rel_err(res, sys_) -> float:
    pairs = ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K))
    return max(float(np.linalg.norm(X - T) / np.linalg.norm(T)) for X, T in pairs)


def identify_case(case: dict) -> dict:
    from podid_rs import identify
    from podid_rs.identification.reference import identify_kronecker

    sys_, U, F, omega = chain_problem(case["m"], s=S_LINES)
    sym = case["symmetric"]
    if case["kind"] == "oracle":
        res, secs = timed(lambda: identify_kronecker(U, F, omega, LAM, sym))
        return {"seconds": secs, "err": max_rel_err(res, sys_)}
    res, secs = timed(lambda: identify(U, F, omega, LAM, sym, backend=case["kind"]))
    out = {"seconds": secs, "err": max_rel_err(res, sys_), "n": res.n_unknowns}
    out.update({f"t_{k}": v for k, v in res.info.get("timings", {}).items()})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="5,10,20,30,40,60,80,100")
    ap.add_argument("--oracle-max-m", type=int, default=30)
    ap.add_argument("--numpy-max-m", type=int, default=60)
    ap.add_argument("--out", type=Path, default=Path("bench-results/direct.md"))
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    me = str(Path(__file__).resolve())

    gemm = gemm_gflops()
    print(f"NumPy GEMM rate (n = 4000): {gemm:.1f} GFLOP/s", flush=True)
    rows, notes = [], []
    for m in sizes:
        n_pen, n_sym = 3 * m * m, 3 * m * (m + 1) // 2
        pen = run_worker(me, {"kind": "rust", "m": m, "symmetric": False})
        sym = run_worker(me, {"kind": "rust", "m": m, "symmetric": True})
        npy = ora = None
        if m <= args.numpy_max_m:
            npy = run_worker(me, {"kind": "numpy", "m": m, "symmetric": False})
        if m <= args.oracle_max_m:
            ora = run_worker(me, {"kind": "oracle", "m": m, "symmetric": False})
        chol = run_worker(me, {"kind": "scipy_chol", "n": n_pen})
        for name, r in (("rust", pen), ("rust-sym", sym), ("numpy", npy), ("oracle", ora),
                        ("scipy-chol", chol)):
            if r and "error" in r:
                notes.append(f"m={m} {name}: {r['error']}")
        t = {k: val(r, "seconds") for k, r in
             (("pen", pen), ("sym", sym), ("npy", npy), ("ora", ora), ("chol", chol))}  # fmt: skip
        rust_gf = ratio(n_pen**3 / 3 / 1e9, val(pen, "t_factor"))
        row = [
            m, n_pen, t["pen"], val(pen, "peak_gb"), val(pen, "err"),
            n_sym, t["sym"], val(sym, "peak_gb"),
            t["npy"], val(npy, "peak_gb"), t["ora"], val(ora, "peak_gb"),
            ratio(t["npy"], t["pen"]), ratio(t["ora"], t["pen"]),
            rust_gf, val(chol, "gflops"), ratio(t["pen"], t["chol"]), ratio(rust_gf, gemm),
        ]  # fmt: skip
        rows.append(row)
        print(
            f"m={m:4d}: rust {fmt_s(t['pen'])} sym {fmt_s(t['sym'])} numpy {fmt_s(t['npy'])} "
            f"oracle {fmt_s(t['ora'])} scipy-chol {fmt_s(t['chol'])}",
            flush=True,
        )
    header = [
        "m", "unknowns", "rust s", "rust GB", "rel err", "unknowns (sym)", "rust sym s",
        "sym GB", "numpy s", "numpy GB", "oracle s", "oracle GB", "× numpy", "× oracle",
        "rust chol GF/s", "scipy chol GF/s", "rust total / scipy chol", "chol / GEMM",
    ]  # fmt: skip
    table = markdown_table(header, rows)
    load = os.getloadavg()[0]
    notes.append(f"1-minute load average at the end: {load:.2f} (2 cores; above 1 means "
                 "other processes were competing)")
    text = (
        f"Direct path, s = {S_LINES} lines, λ = {LAM:g}; NumPy GEMM {gemm:.1f} GFLOP/s.\n"
        f"Oracle run for m ≤ {args.oracle_max_m} (beyond, its A alone is "
        f"2·s·m × 3m² doubles and lstsq costs O(s·m·9m⁴)); NumPy structured path for "
        f"m ≤ {args.numpy_max_m} (it needs ~3 copies of the dense normal matrix).\n\n"
        + table
        + ("\n\n" + "\n".join(notes) if notes else "")
    )
    print("\n" + text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text + "\n\n" + host_line() + "\n")
    print(f"\nwritten to {args.out}")


def fmt_s(x: float | None) -> str:
    return "   —   " if x is None else f"{x:7.3f}s"


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main(
            {
                "rust": identify_case,
                "numpy": identify_case,
                "oracle": identify_case,
                "scipy_chol": scipy_cholesky,
            }
        )
    else:
        main()
