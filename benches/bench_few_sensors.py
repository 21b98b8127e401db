"""More modes than sensors: podid_rs's latent-DOF models against sdypy-EMA, in one run.

A test that measures fewer points than there are modes in its band gets, on the POD
basis alone, at most as many modes as points. The default ``podid-rs identify`` fit
(:meth:`podid_rs.MeasuredData.fit`: the order sweep, latent coordinates past the
measured DOFs, the final fit on every line) is run beside sdypy-EMA's LSCF + LSFD
(given its best shot, as in ``bench_measured.py``: orders 10–80, three peak-picking
prominences, the best median kept) on the same data:

* **simulated** — a uniform 12-mass chain (6 modes in 5–150 Hz) and a 4 × 3 lattice
  with 10 % random mass and stiffness (6 modes in 90–200 Hz, two of them 7 Hz apart),
  force at DOF 0, observed at 1, 2 and 3 points, 0.25 Hz lines, 2 % complex noise on
  every FRF value (measurement level). Every in-band mode of the truth must be found:
  natural frequency within 0.1 %, damping ratio within 10 %;
* **real** — the shared beam (``tests/data/ufsc_beam``, roving hammer, force at point
  3 by reciprocity) cut to its driving point alone and to three points (3, 10, 27),
  in 50–300 and 80–400 Hz; every mode sdypy-EMA finds in the band must be among
  podid_rs's structural modes (:func:`podid_rs.modes.mode_kinds`) within 1 %.

Reported per case: median and 95th percentile |20 log10(|H_model| / |H_measured|)| over
every line and measured DOF (simulated: also against the noise-free truth), the
chosen order and its latent DOFs, the in-band modes recovered to the tolerances
(simulated), stability and time; and the ratio of podid_rs's median to sdypy-EMA's
(target ≤ 0.5).

    python3 benches/bench_few_sensors.py                  # every case (~10 min on 2 cores)
    python3 benches/bench_few_sensors.py --only chain     # cases whose name contains it
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
from bench_measured import BEAM, errors, run_sdypy  # noqa: E402
from podid_rs.modes import mode_kinds  # noqa: E402

F_TOL = 1e-3
ZETA_TOL = 0.10
#: a peer's mode is present among podid_rs's structural modes within this fraction in f
PRESENT_TOL = 0.01
NOISE = 0.02
DF_HZ = 0.25


def simulated_case(system: pr.SecondOrderSystem, points: list[int], band: tuple[float, float],
                   seed: int) -> tuple[pr.MeasuredData, np.ndarray, pr.physical.ModalParameters]:
    """FRFs of ``system`` for a force at DOF 0, at ``points``, with 2 % complex noise."""
    system = system.todense() if system.is_sparse else system
    f = np.arange(band[0], band[1] + DF_HZ / 2, DF_HZ)
    w = 2 * np.pi * f
    F = np.zeros((w.size, system.n, 1))
    F[:, 0, 0] = 1.0
    exact = system.response(w, F)[:, points, :]
    rng = np.random.default_rng(seed)
    noise = (rng.standard_normal(exact.shape) + 1j * rng.standard_normal(exact.shape)) / np.sqrt(2)
    data = pr.MeasuredData(w, exact * (1 + NOISE * noise), np.ones((w.size, 1, 1)),
                           inputs=[points.index(0)])
    return data, exact, pr.modal_parameters(system)


def beam_case(points: list[int], band: tuple[float, float]) -> pr.MeasuredData:
    """The shared beam cut to ``points`` (the driving point 3 among them)."""
    data = pr.read_uff(BEAM, band_hz=band)
    idx = [int(np.flatnonzero(data.dofs[:, 0] == p)[0]) for p in points]
    return pr.MeasuredData(data.omega, data.U[:, idx], data.F, dofs=data.dofs[idx],
                           inputs=[idx.index(int(data.inputs[0]))], notes=data.notes)


def recovered(found_f: np.ndarray, found_z: np.ndarray, truth, band) -> tuple[int, int, str]:
    """(modes found within F_TOL / ZETA_TOL, in-band modes of the truth, worst errors)."""
    keep = (truth.frequencies_hz >= band[0]) & (truth.frequencies_hz <= band[1])
    ok, worst_f, worst_z = 0, 0.0, 0.0
    for f, z in zip(truth.frequencies_hz[keep], truth.damping_ratios[keep], strict=True):
        if found_f.size == 0:
            worst_f = worst_z = np.inf
            continue
        j = int(np.argmin(np.abs(found_f - f)))
        df, dz = abs(found_f[j] - f) / f, abs(found_z[j] - z) / z
        worst_f, worst_z = max(worst_f, df), max(worst_z, dz)
        ok += int(df <= F_TOL and dz <= ZETA_TOL)
    return ok, int(keep.sum()), f"worst Δf {100 * worst_f:.3f} %, Δζ {100 * worst_z:.1f} %"


def run_podid(data: pr.MeasuredData) -> dict:
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model, R, sweep = data.fit()
    X = data.predict(model.system(), R)
    med, p95 = errors(X, data.U)
    modes = pr.modal_parameters(model)
    shapes = pr.mode_shapes(model, R, data.dofs)
    structural = mode_kinds(shapes, data.omega, data.U, data.inputs) == "structural"
    return dict(method="podid_rs (default fit)", model=model, X=X, median=med, p95=p95,
                m=f"{sweep.chosen} ({sweep.fit(sweep.chosen).latent} latent)",
                stable=modes.stable and pr.is_physical(model), seconds=time.perf_counter() - t0,
                f=modes.frequencies_hz, z=modes.damping_ratios,
                structural=shapes.frequencies_hz[structural])


def run_peer(data: pr.MeasuredData, band: tuple[float, float]) -> dict:
    out = run_sdypy(data, band)
    out["m"] = f"{out['m']} modes"
    out["f"], out["z"] = out.pop("nat_freq"), out.pop("nat_xi")
    return out


def cases(only: str | None):
    chain = pr.mass_spring_chain(12, m1=1.0, m2=1.0)
    lattice = pr.mass_spring_lattice(4, 3, mass_variation=0.1, stiffness_variation=0.1, seed=1)
    out = []
    for name, system, band, pts in (
        ("chain", chain, (5.0, 150.0), ([0], [0, 4], [0, 4, 7])),
        ("lattice", lattice, (90.0, 200.0), ([0], [0, 5], [0, 5, 10])),
    ):
        for k, p in enumerate(pts):
            out.append((f"{name}, {len(p)} point{'s' * (len(p) > 1)}", "simulated", band,
                        lambda s=system, p=p, b=band, seed=k: simulated_case(s, p, b, seed)))
    for band in ((50.0, 300.0), (80.0, 400.0)):
        for pts in ([3], [3, 10, 27]):
            label = "driving point" if len(pts) == 1 else "3 points"
            out.append((f"beam, {label}", "real", band, lambda p=pts, b=band: beam_case(p, b)))
    return [c for c in out if only is None or only in c[0]]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="run the cases whose name contains this")
    ap.add_argument("--out", default="bench-results/few_sensors.md")
    args = ap.parse_args(argv)
    rows, summary, load = [], [], [load_average()]
    for name, kind, band, make in cases(args.only):
        made = make()
        data, exact, truth = made if kind == "simulated" else (made, None, None)
        results = [run_podid(data), run_peer(data, band)]
        load.append(load_average())
        ours, peer = results
        in_band = [f for f in np.asarray(peer["f"]) if band[0] <= f <= band[1]]
        present = sum(bool(np.any(np.abs(ours["structural"] - f) <= PRESENT_TOL * f))
                      for f in in_band)
        for r in results:
            vs_truth = ""
            modes = ""
            if exact is not None:
                if "X" in r:
                    vs_truth = f"{errors(r['X'], exact)[0]:.3f}"
                ok, total, worst = recovered(np.asarray(r["f"]), np.asarray(r["z"]), truth, band)
                modes = f"{ok} / {total} ({worst})"
            elif r is ours:
                modes = f"sdypy-EMA's {present} / {len(in_band)} in band among its structural modes"
            rows.append([name, f"{band[0]:g}–{band[1]:g}", r["method"], r["m"],
                         f"{r['median']:.3f}", f"{r['p95']:.2f}", vs_truth, modes,
                         "yes" if r["stable"] else "no", f"{r['seconds']:.1f}"])
            print(" | ".join(rows[-1]), flush=True)
        ratio = results[0]["median"] / results[1]["median"]
        summary.append(f"- {name}, {band[0]:g}–{band[1]:g} Hz: podid_rs median / sdypy-EMA's = "
                       f"{ratio:.2f} (target ≤ 0.5)")
        print(summary[-1], flush=True)
    header = ["case", "band (Hz)", "method", "m / modes", "median dB", "95th pct dB",
              "median dB vs truth", "modes: truth's within 0.1 % / 10 % (simulated), "
              "the peer's within 1 % (real)", "stable, physical", "time (s)"]
    loads = [v for v in load if v is not None]
    write_report("\n".join([
        "# More modes than sensors", "",
        "Errors: |20 log10(|H_model|/|H_measured|)| over every line of the band and every "
        "measured DOF. Command: `python3 benches/bench_few_sensors.py`.", "",
        markdown_table(header, rows), "", *summary,
        f"- load average during the run: {min(loads):.1f}–{max(loads):.1f}" if loads else "",
    ]), args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
