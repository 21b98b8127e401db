"""Which start reaches a good output-error model on a wide band.

On the real beam at 20–800 Hz and a fixed order m, three starts for the same
refinement (relative weights, the same step budget), in one run:

* **paper's estimator**: exactly symmetric eq. 49, made physical;
* **scalar weights iterated** (Sanathanan–Koerner-like): eq. 49 with one weight per
  line, w_i = ‖x_i‖ / (‖f_i‖ ‖u_i‖) from the previous model's response x — the relative
  output error of a scalar-gain model — repeated ``SK_ITERATIONS`` times (they keep the
  Gram structure, so the fast solvers apply);
* **continuation over the order** (:func:`podid_rs.identification.order.sweep_orders` with the
  order given): orders 1 … m, each from the one before.

Printed: the median |dB| error over every line and measured DOF of each start and of
its refined model, stability, time.

    python3 benches/bench_starts.py [--band LO HI] [--m M]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import podid_rs as pr  # noqa: E402
from _common import load_average, markdown_table, write_report  # noqa: E402
from podid_rs.identification.order import sweep_orders  # noqa: E402
from podid_rs.identification.refinement import db_errors, refine  # noqa: E402

BEAM = HERE.parent / "tests" / "data" / "ufsc_beam" / "beam_roving_hammer.uff"
SK_ITERATIONS = 8
STEPS = 300


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--band", nargs=2, type=float, default=(20.0, 800.0))
    ap.add_argument("--m", type=int, default=20)
    ap.add_argument("--out", default="bench-results/starts.md")
    args = ap.parse_args(argv)
    data = pr.read_uff(BEAM, band_hz=tuple(args.band))
    P = data.pod()
    R = P.basis(args.m)
    U, F = data.project(R)
    F_n = data.forces_on_dofs()
    w = data.omega

    def err(model) -> float:
        X = np.einsum("nm,smp->snp", R, model.system().response(w, F))
        return float(np.median(db_errors(X, data.U)))

    def refined(start):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return refine(start, data.U, F_n, w, basis=R, max_iter=STEPS)

    rows = []
    load = load_average()

    t0 = time.perf_counter()
    paper = pr.identify(U, F, w, symmetric=True)
    r = refined(paper)
    rows.append(["paper's estimator", err(paper), pr.modal_parameters(paper).stable, err(r),
                 r.iterations, time.perf_counter() - t0])

    t0 = time.perf_counter()
    model = paper
    u_norm, f_norm = np.linalg.norm(data.U, axis=1), np.linalg.norm(F, axis=1)
    history = []
    for _ in range(SK_ITERATIONS):
        gain = np.linalg.norm(model.system().response(w, F), axis=1) / f_norm
        weight = gain / u_norm
        weight /= np.median(weight)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = pr.identify(U * weight[:, None, :], F * weight[:, None, :], w,
                                symmetric=True)
        history.append(err(model))
    r = refined(model)
    rows.append([f"scalar weights × {SK_ITERATIONS} (errors "
                 + ", ".join(f"{e:.1f}" for e in history) + ")", err(model),
                 pr.modal_parameters(model).stable, err(r), r.iterations,
                 time.perf_counter() - t0])

    t0 = time.perf_counter()
    sweep = sweep_orders(data.U, F_n, w, P, m=args.m)
    start = sweep.fit(args.m).model
    r = refined(start)
    rows.append([f"continuation over orders 1…{args.m}", err(start),
                 pr.modal_parameters(start).stable, err(r), r.iterations,
                 time.perf_counter() - t0])

    header = ["start", "start median dB", "start stable", "refined median dB",
              "refinement steps", "time (s)"]
    table = markdown_table(header, [[c if not isinstance(c, bool) else ("yes" if c else "no")
                                     for c in row] for row in rows])
    text = (f"# Starts for the output-error refinement: beam, {args.band[0]:g}–"
            f"{args.band[1]:g} Hz, m = {args.m}\n\n{table}\n\nLoad average {load:.1f}; "
            f"{STEPS} refinement steps at most; command `python3 benches/bench_starts.py`.\n")
    write_report(text, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
