"""λ-sweep benchmark: a whole 50-point λ-curve against one direct solve.

Problem: the full-order chain ``mass_spring_chain(m)`` (R = I), random complex
forces on every DOF, s = 400 lines over 5–200 Hz, 1 % noise on the responses (so
the curves are not degenerate). Each case runs in its own process, best of
``--repeat`` calls after nothing else has run in it:

- solve: ``identify(U, F, omega, 100.0)``, one direct solve (3m² unknowns);
- sweep: ``lambda_curve(U, F, omega, n=50)``: the factorisation (Gram, H⁻¹, K̃,
  two-stage tridiagonalisation, QL), exact residual and penalty at 50 λ, and the
  L-curve and GCV searches on the fine grid;
- rule: ``identify(U, F, omega, "lcurve")``, the sweep plus M, C, K at the chosen λ.

    python benches/bench_sweep.py                  # m = 20, 40, 60 (≈ 3 min)
    python benches/bench_sweep.py --sizes 20,40 --repeat 1
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    chain_problem,
    markdown_table,
    ratio,
    run_worker,
    timed,
    val,
    worker_main,
)

S_LINES = 400
NOISE = 0.01
N_POINTS = 50


def sweep_case(case: dict) -> dict:
    from podid_rs import identify, lambda_curve

    _, U, F, omega = chain_problem(case["m"], s=S_LINES, noise=NOISE)
    calls = {
        "solve": lambda: identify(U, F, omega, 100.0),
        "sweep": lambda: lambda_curve(U, F, omega, n=N_POINTS),
        "rule": lambda: identify(U, F, omega, "lcurve"),
    }
    best: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the chain is symmetric: no clear corner
        for _ in range(case["repeat"]):
            out, secs = timed(calls[case["kind"]])
            if secs < best.get("seconds", float("inf")):
                best = {"seconds": secs}
                if case["kind"] == "sweep":
                    best.update({f"t_{k}": v for k, v in out.info["timings"].items()})
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="20,40,60")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("bench-results/sweep.md"))
    args = ap.parse_args()
    me = str(Path(__file__).resolve())
    rows, notes = [], []
    for m in (int(s) for s in args.sizes.split(",")):
        r = {
            kind: run_worker(me, {"kind": kind, "m": m, "repeat": args.repeat})
            for kind in ("solve", "sweep", "rule")
        }
        notes += [f"m={m} {k}: {v['error']}" for k, v in r.items() if "error" in v]
        solve, sweep, rule = (val(r[k], "seconds") for k in ("solve", "sweep", "rule"))
        factor = val(r["sweep"], "t_total")
        rows.append(
            [
                str(m),
                str(3 * m * m),
                str(3 * m * (m - 1) // 2),
                solve,
                val(r["solve"], "peak_gb"),
                sweep,
                val(r["sweep"], "peak_gb"),
                ratio(sweep, solve),
                rule,
                ratio(rule, solve),
                factor,
                val(r["sweep"], "t_band"),
                val(r["sweep"], "t_chase"),
                val(r["sweep"], "t_spectrum"),
                None if sweep is None or factor is None else sweep - factor,
            ]
        )
        print(f"m={m:3d}: solve {solve}  sweep {sweep}  ratio {ratio(sweep, solve)}", flush=True)
    header = [
        "m", "unknowns 3m²", "n_w", "solve s", "solve GB", "sweep s", "sweep GB",
        "sweep / solve", "lam='lcurve' s", "lcurve / solve", "factor s", "band s",
        "chase s", "QL s", f"{N_POINTS} exact points + rules s",
    ]  # fmt: skip
    text = (
        f"λ sweep ({N_POINTS} points) against one direct solve (λ = 100): chain, "
        f"s = {S_LINES} lines, {NOISE:.0%} noise on U, best of {args.repeat}. "
        "GB = peak resident memory of the worker process.\n\n"
        + markdown_table(header, rows)
        + ("\n\n" + "\n".join(notes) if notes else "")
    )
    print("\n" + text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text + "\n")
    print(f"\nwritten to {args.out}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main({"solve": sweep_case, "sweep": sweep_case, "rule": sweep_case})
    else:
        main()
