"""Real tests at full resolution: ``podid-rs identify`` at ~47 000 lines against sdypy-EMA.

A hammer or shaker test at fine line spacing has tens of thousands of frequency lines.
This benchmark writes such a test — a roving-hammer file in the layout real ones have
(one accelerometer, nine hammer points, dataset 58, accelerance) — and runs, in one
process and on the same file:

* ``podid-rs identify FILE --band-hz 65 1000`` as a user would (``run_identify``: the
  order sweep, the final fit on every line, every output file), timed phase by phase;
* sdypy-EMA's LSCF + LSFD at four model orders (10, 20, 30, 40) with poles picked at
  the peaks of the summed FRF — the time a user of the peer waits for the same band.

The test: a cantilever (Euler–Bernoulli, first natural frequency 17 Hz) seen at nine
equally spaced points, force at the tip, the accelerometer at the tip; its first six
modes (17 – 1443 Hz), four of them in 65–1000 Hz, damping ratios 0.3–0.6 %; lines every
0.02 Hz from 0 to 1200 Hz (46 750 of them in the band); 1 % complex noise on every FRF
value plus a floor of 10⁻⁴ of each FRF's largest value (H1 estimates of a good test).

Reported: wall time of each phase and in all, the peer's time and the ratio, the
median |dB| error over every line of the band, and how many of the 4 modes the modal
table marks structural (f within 0.1 %, ζ within 10 % of the truth).

    python3 benches/bench_resolution.py             # writes bench-results/resolution.md
    python3 benches/bench_resolution.py --keep DIR  # keep the UFF and identify's outputs
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import io
import pstats
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import podid_rs as pr  # noqa: E402
from _common import load_average, markdown_table, write_report  # noqa: E402

BAND = (65.0, 1000.0)
DF_HZ = 0.02
F_MAX = 1200.0
BETA_L = np.array([1.875104, 4.694091, 7.854757, 10.995541, 14.137168, 17.278760])
F1_HZ = 17.0
ZETAS = np.array([0.006, 0.005, 0.004, 0.003, 0.003, 0.003])
POINTS = np.arange(1, 10) / 9.0  # x / L of the nine hammer points; the tip is the last
NOISE, FLOOR = 0.01, 1e-4
PEER_ORDERS = (10, 20, 30, 40)


def cantilever_modes() -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (Hz) and mode shapes at POINTS ``(9, 6)`` of a unit cantilever."""
    f = F1_HZ * (BETA_L / BETA_L[0]) ** 2
    shapes = np.empty((POINTS.size, BETA_L.size))
    for k, b in enumerate(BETA_L):
        sigma = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
        x = b * POINTS
        shapes[:, k] = np.cosh(x) - np.cos(x) - sigma * (np.sinh(x) - np.sin(x))
    return f, shapes


def true_receptance(freq_hz: np.ndarray, zetas: np.ndarray = ZETAS) -> np.ndarray:
    """The noise-free receptance H(tip, j) ``(s, 9)`` at ``freq_hz`` (the file's units)."""
    f_n, phi = cantilever_modes()
    w, wn = 2 * np.pi * np.asarray(freq_hz, dtype=float), 2 * np.pi * f_n
    tip = POINTS.size - 1
    # receptance H(tip, j) = Σ φ_tip φ_j / (ω_k² − ω² + 2iζω_kω), ~ m/N · 10⁻³ scale
    den = wn[None, :] ** 2 - w[:, None] ** 2 + 2j * zetas * wn[None, :] * w[:, None]
    return (phi[tip][None, None, :] * phi[None, :, :] / den[:, None, :]).sum(axis=2) * 1e3


def write_test(path: Path, seed: int = 0, zetas: np.ndarray = ZETAS,
               floor: float = FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """The roving-hammer UFF (damping ratios ``zetas``, noise floor ``floor`` of each
    FRF's largest value); returns the true in-band (f, ζ)."""
    import pyuff

    f_n, _ = cantilever_modes()
    freq = np.arange(0.0, F_MAX + DF_HZ / 2, DF_HZ)
    w = 2 * np.pi * freq
    tip = POINTS.size - 1
    A = -(w**2)[:, None] * true_receptance(freq, zetas)  # accelerance, ~ (m/s²)/N scale
    rng = np.random.default_rng(seed)
    noise = (rng.standard_normal(A.shape) + 1j * rng.standard_normal(A.shape)) / np.sqrt(2)
    A = A + (NOISE * np.abs(A) + floor * np.abs(A).max(axis=0)) * noise
    A[0] = 0.0
    uff = pyuff.UFF(str(path))
    for j in range(POINTS.size):
        uff.write_sets(pyuff.prepare_58(
            binary=1, func_type=4, rsp_node=tip + 1, rsp_dir=3, ref_node=j + 1, ref_dir=3,
            data=A[:, j].astype(complex), x=freq, abscissa_spacing=1,
            abscissa_spec_data_type=18, ordinate_spec_data_type=12,
            orddenom_spec_data_type=13,
        ), "add")
    keep = (f_n >= BAND[0]) & (f_n <= BAND[1])
    return f_n[keep], zetas[keep]


def run_podid(path: Path, out: Path, profile: bool) -> dict:
    # modules are imported outside both timings: sdypy.EMA's import (1.6 s, matplotlib
    # with it) is outside the peer's, so matplotlib, which podid_rs loads at its first
    # figure, is loaded before this clock starts
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401

    from podid_rs.apps.identify import run_identify

    prof = cProfile.Profile() if profile else None
    t0 = time.perf_counter()
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        if prof is not None:
            prof.enable()
        run = run_identify(path, out, band_hz=BAND, progress=False)
        if prof is not None:
            prof.disable()
    seconds = time.perf_counter() - t0
    phases = dict(run.timings)
    top = ""
    if prof is not None:
        buf = io.StringIO()
        pstats.Stats(prof, stream=buf).sort_stats("cumulative").print_stats(25)
        top = buf.getvalue()
    med, p95 = run.frf_errors(run.result)
    return dict(seconds=seconds, phases=phases, median=med, p95=p95, run=run, profile=top)


def run_peer(path: Path) -> dict:
    import sdypy.EMA as EMA
    from scipy.signal import find_peaks

    data = pr.read_uff(path)
    freq = data.freq_hz
    H_acc = -(data.omega**2)[:, None] * data.U[:, :, 0]
    t0 = time.perf_counter()
    inband = (freq >= BAND[0]) & (freq <= BAND[1])
    summed = np.abs(H_acc[inband]).sum(axis=1)
    peaks = freq[inband][find_peaks(np.log(summed), prominence=1.0)[0]]
    best = None
    for order in PEER_ORDERS:
        with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            model = EMA.Model(frf=H_acc.T, freq=freq, lower=BAND[0], upper=BAND[1],
                              pol_order_high=order, frf_form="accelerance")
            model.get_poles(show_progress=False)
            model.select_closest_poles(list(peaks), f_window=10)
            H_rec, _ = model.get_constants(f_lower=BAND[0], f_upper=BAND[1])
        keep = (model.freq >= BAND[0]) & (model.freq <= BAND[1])
        measured = H_acc[np.isin(freq, model.freq[keep])].T
        e = np.abs(20 * np.log10(np.abs(H_rec[:, keep]) / np.abs(measured)))
        med = float(np.median(e))
        if best is None or med < best[0]:
            best = (med, float(np.percentile(e, 95)), np.asarray(model.nat_freq),
                    np.asarray(model.nat_xi), H_rec[:, keep], model.freq[keep], order)
    return dict(seconds=time.perf_counter() - t0, median=best[0], p95=best[1],
                f=best[2], z=best[3], H_acc=best[4], freq=best[5], order=best[6])


def recovered(f: np.ndarray, z: np.ndarray, f_true: np.ndarray, z_true: np.ndarray) -> int:
    ok = 0
    for ft, zt in zip(f_true, z_true, strict=True):
        if f.size:
            j = int(np.argmin(np.abs(f - ft)))
            ok += int(abs(f[j] - ft) <= 1e-3 * ft and abs(z[j] - zt) <= 0.1 * zt)
    return ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="bench-results/resolution.md")
    ap.add_argument("--keep", help="folder for the UFF and identify's outputs (kept)")
    ap.add_argument("--profile", action="store_true", help="append the cProfile top 25")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.keep) if args.keep else Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        path = folder / "cantilever_roving_hammer.uff"
        f_true, z_true = write_test(path)
        load = [load_average()]
        ours = run_podid(path, folder / "identify", args.profile)
        load.append(load_average())
        peer = run_peer(path)
        load.append(load_average())
    run = ours["run"]
    shapes = pr.mode_shapes(run.result, run.basis, run.data.dofs)
    from podid_rs.modes import mode_kinds

    kinds = mode_kinds(shapes, run.data.omega, run.data.U, run.data.inputs)
    structural = kinds == "structural"
    ok = recovered(shapes.frequencies_hz[structural], shapes.damping_ratios[structural],
                   f_true, z_true)
    peer_ok = recovered(peer["f"], peer["z"], f_true, z_true)
    header = ["method", "time (s)", "median dB", "95th pct dB", "structural modes",
              "true modes found (0.1 % / 10 %)"]
    rows = [
        ["podid-rs identify (all outputs)", f"{ours['seconds']:.1f}", f"{ours['median']:.3f}",
         f"{ours['p95']:.2f}", str(int(structural.sum())), f"{ok} / {f_true.size}"],
        [f"sdypy-EMA LSCF + LSFD, orders {', '.join(map(str, PEER_ORDERS))}",
         f"{peer['seconds']:.1f}", f"{peer['median']:.3f}", f"{peer['p95']:.2f}",
         str(len(peer["f"])), f"{peer_ok} / {f_true.size}"],
    ]
    phases = [[k, f"{v:.1f}"] for k, v in ours["phases"].items()]
    loads = [v for v in load if v is not None]
    text = "\n".join([
        "# Real resolution: 46 750 lines in 65–1000 Hz", "",
        "Command: `python3 benches/bench_resolution.py`.", "",
        markdown_table(header, rows), "",
        f"- podid-rs identify / sdypy-EMA time: {ours['seconds'] / peer['seconds']:.1f}",
        f"- order chosen: {run.sweep.reason if run.sweep else run.result.m}",
        f"- load average during the run: {min(loads):.1f}–{max(loads):.1f}" if loads else "",
        "", markdown_table(["phase", "seconds"], phases) if phases else "",
        "", ("```\n" + ours["profile"] + "\n```") if ours["profile"] else "",
    ])
    write_report(text, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
