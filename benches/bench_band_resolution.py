"""Is the FRF band right on the high-resolution test? Monte Carlo over noise seeds.

``podid-rs identify`` draws a 95 % band on the refined model's FRFs from the sandwich
covariance of the output-error fit (:func:`podid_rs.fit_uncertainty`). This benchmark
writes the simulated high-resolution test of ``bench_measured.py --only high-resolution``
(``bench_resolution.write_test``: a 9-point cantilever, 46 750 lines in 65–1000 Hz, every
damping ratio 10⁻⁴, noise 1 % of each FRF value plus a floor of 10⁻⁵ of each FRF's
largest value) with many noise seeds, identifies each as ``run_identify`` does (order
sweep, final fit, covariance with the noise estimated from the residuals), and compares

* the band's half-width at a few lines between the resonances with the spread of the
  fitted FRF over the seeds there (``sharpness``: the band's median half-width over
  1.96 × the standard deviation of |Ĥ| over the seeds; 1 is ideal);
* how often the band covers the noise-free FRF, at those lines and over every 20th
  line of the band, per entry;

for the band as identify draws it and for the band with the true noise variance given
(``noise_variance``), which separates the estimate of the noise from the rest.
The model order each seed's sweep chose is recorded (m = 9 on all 24 seeds since the sweep
weighs latent orders against a converged fit; 9–28 before), and the spread is over every
seed's fit, whatever its order.

    python3 benches/bench_band_resolution.py --seeds 24
    python3 benches/bench_band_resolution.py --seeds 24 --cache DIR   # resumable
"""

from __future__ import annotations

import argparse
import contextlib
import io
import pickle
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_resolution as res  # noqa: E402
from _common import markdown_table, write_report  # noqa: E402

#: the high-resolution case's damping ratio (every mode) and noise floor, as bench_measured
ZETA = 1e-4
FLOOR = 1e-5
#: lines (Hz) between the resonances where the band is compared with the spread
PROBES_HZ = (200.0, 400.0, 500.0, 700.0, 800.0)
#: the entries compared: (response node, force node) of the cantilever's points
ENTRIES = ((9, 9), (1, 9), (5, 9))
#: every this-many-th line of the band for the coverage over the band
STRIDE = 20
#: the bands compared: the noise estimated from the residuals, one variance per channel
#: and over the neighbouring lines ("local", what identify uses), and the true variance
LABELS = {"channel": dict(noise="channel"), "local": dict(noise="local"), "true": {}}


def true_variance(freq_hz: np.ndarray) -> np.ndarray:
    """E|δH|² of the receptance noise of write_test, ``(s, 9)`` per point."""
    zetas = np.full(res.BETA_L.size, ZETA)
    full = np.arange(0.0, res.F_MAX + res.DF_HZ / 2, res.DF_HZ)
    A_full = -((2 * np.pi * full) ** 2)[:, None] * res.true_receptance(full, zetas)
    peak = np.abs(A_full).max(axis=0)
    w = 2 * np.pi * np.asarray(freq_hz)
    A = -(w**2)[:, None] * res.true_receptance(freq_hz, zetas)
    sd_acc = res.NOISE * np.abs(A) + FLOOR * peak[None, :]
    return (sd_acc / w[:, None] ** 2) ** 2


def one_seed(seed: int, folder: Path) -> dict:
    """Identify seed ``seed``'s test as run_identify does (the fit is kept in ``folder``:
    a second pass only forms the bands); the bands at the probes."""
    from podid_rs.identification.order import final_fit, sweep_orders
    from podid_rs.io.npz import load_data
    from podid_rs.uncertainty import fit_uncertainty

    zetas = np.full(res.BETA_L.size, ZETA)
    path = folder / f"seed{seed}.uff"
    f_true, _ = res.write_test(path, seed=seed, zetas=zetas, floor=FLOOR)
    data = load_data(path, band_hz=res.BAND)
    path.unlink()
    kept = folder / f"fit{seed}.pickle"
    if kept.exists():
        model, R, sweep = pickle.loads(kept.read_bytes())
    else:
        pod = data.pod()
        F_n = data.forces_on_dofs()
        with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            sweep = sweep_orders(data.U, F_n, data.omega, pod)
            model, R = final_fit(sweep, data.U, F_n, data.omega, pod)
        kept.write_bytes(pickle.dumps((model, R, sweep)))
    nodes = data.dofs[:, 0]
    rows = [int(np.flatnonzero(nodes == r)[0]) for r, _ in ENTRIES]
    col = int(np.flatnonzero(nodes == ENTRIES[0][1])[0])
    freq = data.freq_hz
    probe_idx = np.array([int(np.argmin(np.abs(freq - f))) for f in PROBES_HZ])
    grid = np.unique(np.concatenate([np.arange(0, freq.size, STRIDE), probe_idx]))
    truth = res.true_receptance(freq[grid], zetas)[:, nodes[rows] - 1]
    out = dict(seed=seed, m=model.m, f_true=f_true, freq=freq[grid],
               probe=np.searchsorted(grid, probe_idx), truth=truth)
    v_true = true_variance(freq)[:, nodes - 1][:, :, None]  # (s, n, 1)
    lines = np.asarray(sweep.lines)
    if model.info["refinement"]["final_refit"]["kept"] == "held-out fit":
        lines = lines & ~np.asarray(sweep.test_lines)  # the lines that fit saw
    for label, kw in LABELS.items():
        unc = fit_uncertainty(data, model, R, sweep,
                              **(kw if label != "true" else dict(noise_variance=v_true)))
        band = unc.frf(data.omega[grid], rows=rows, cols=[col])
        out[f"{label}_values"] = band.values[:, :, 0]
        out[f"{label}_lower"] = band.lower[:, :, 0]
        out[f"{label}_upper"] = band.upper[:, :, 0]
        out[f"{label}_rank"] = unc.rank
        # the poles nearest the true modes in the band, with their standard deviations
        modes = unc.modes()
        near = [int(np.argmin(np.abs(modes.frequencies_hz - f))) for f in f_true]
        out[f"{label}_f"] = modes.frequencies_hz[near]
        out[f"{label}_z"] = modes.damping_ratios[near]
        out[f"{label}_sf"] = modes.std_frequency_hz[near]
        out[f"{label}_sz"] = modes.std_damping[near]
        out[f"{label}_zq"] = modes.z
        # the noise variance against the true one on the fitted lines: median per DOF
        out[f"{label}_variance_ratio"] = np.median(
            unc.variance[:, :, 0] / v_true[lines, :, 0], axis=0)
    return out


def summarise(runs: list[dict]) -> str:
    ms = np.array([int(r["m"]) for r in runs])
    orders, counts = np.unique(ms, return_counts=True)
    same = runs  # the order varies by seed: the spread is over every seed's fit
    freq, probe, truth = same[0]["freq"], same[0]["probe"], same[0]["truth"]
    names = {"channel": "channel", "local": "local", "true": "true noise"}
    out = [f"{len(runs)} seeds; orders chosen: "
           + ", ".join(f"m = {o} ({c})" for o, c in zip(orders, counts, strict=True))
           + "; the spread and the coverage are over every seed (each seed's coverage "
           "in the last table).", "",
           "Estimated over true noise variance on the fitted lines (median over the lines "
           "and the seeds), points 1–9:", ""]
    for label in ("channel", "local"):
        ratio = np.median([r[f"{label}_variance_ratio"] for r in runs], axis=0)
        out.append(f"- {names[label]}: " + ", ".join(f"{v:.3g}" for v in ratio))
    out.append("")

    def band(group, label, idx, e):
        lo = np.array([r[f"{label}_lower"][idx, e] for r in group])
        hi = np.array([r[f"{label}_upper"][idx, e] for r in group])
        return lo, hi

    header = ["entry", "f (Hz)", "|H| true", "sd |Ĥ| (seeds)", "mean |Ĥ| − |H|"]
    for label in LABELS:
        header += [f"half-width {names[label]}", "/ 1.96 sd", "covers"]
    rows = []
    for e, (r_node, c_node) in enumerate(ENTRIES):
        for fi in probe:
            mag = np.abs([r["local_values"][fi, e] for r in same])
            sd = float(np.std(mag, ddof=1))
            t = abs(truth[fi, e])
            row = [f"H({r_node}Z,{c_node}Z)", f"{freq[fi]:.0f}", f"{t:.3g}", f"{sd:.3g}",
                   f"{np.mean(mag) - t:+.2g}"]
            for label in LABELS:
                lo, hi = band(same, label, fi, e)
                half = np.nanmedian((hi - lo) / 2)
                row += [f"{half:.3g}", f"{half / (1.96 * sd):.3g}",
                        f"{100 * np.mean((lo <= t) & (t <= hi)):.0f} %"]
            rows.append(row)
    cov_header = ["seeds", "entry"]
    for label in LABELS:
        cov_header += [f"covers ({names[label]})", "half-width / 1.96 sd: median",
                       "10–90 %", "lower edge 0", "no band"]
    cov_rows = []
    everything = slice(None)
    m_common = int(orders[np.argmax(counts)])
    groups = [(f"all {len(runs)}", runs),
              (f"the {int(counts.max())} of m = {m_common}",
               [r for r in runs if int(r["m"]) == m_common]),
              (f"the {int(np.sum(ms != m_common))} of other m",
               [r for r in runs if int(r["m"]) != m_common])]
    for name, group in groups:
        if len(group) < 3:
            continue
        for e, (r_node, c_node) in enumerate(ENTRIES):
            t = np.abs(truth[:, e])
            sd = np.std(np.abs([r["local_values"][:, e] for r in group]), axis=0, ddof=1)
            row = [name, f"H({r_node}Z,{c_node}Z)"]
            for label in LABELS:
                lo, hi = band(group, label, everything, e)
                ok = np.isfinite(lo) & np.isfinite(hi)
                cover = np.sum(ok & (lo <= t) & (t <= hi)) / max(int(ok.sum()), 1)
                ratio = np.nanmedian((hi - lo) / 2, axis=0) / (1.96 * sd)
                row += [f"{100 * cover:.1f} %", f"{np.nanmedian(ratio):.3g}",
                        f"{np.nanpercentile(ratio, 10):.3g}–{np.nanpercentile(ratio, 90):.3g}",
                        f"{100 * np.mean(lo == 0):.1f} %", f"{100 * np.mean(~ok):.1f} %"]
            cov_rows.append(row)
    seed_rows = []
    for r in runs:
        row = [str(int(r["seed"])), str(int(r["m"]))]
        for label in LABELS:
            t = np.abs(r["truth"])
            lo, hi = r[f"{label}_lower"], r[f"{label}_upper"]
            ok = np.isfinite(lo) & np.isfinite(hi)
            row.append(f"{100 * np.sum(ok & (lo <= t) & (t <= hi)) / max(int(ok.sum()), 1):.1f} %")
        seed_rows.append(row)
    mode_rows = []
    for k, ft in enumerate(runs[0]["f_true"]):
        f_est = np.array([r["true_f"][k] for r in same])
        z_est = np.array([r["true_z"][k] for r in same])
        row = [f"{ft:.1f}", f"{np.std(f_est, ddof=1):.3g}", f"{np.std(z_est, ddof=1):.3g}"]
        for label in LABELS:
            sf = np.array([r[f"{label}_sf"][k] for r in same])
            sz = np.array([r[f"{label}_sz"][k] for r in same])
            zq = np.array([r[f"{label}_zq"] for r in same])
            cf = np.mean(np.abs(f_est - ft) <= zq * sf)
            cz = np.mean(np.abs(z_est - ZETA) <= zq * sz)
            row += [f"{np.nanmedian(sf) / np.std(f_est, ddof=1):.3g}",
                    f"{np.nanmedian(sz) / np.std(z_est, ddof=1):.3g}",
                    f"{100 * cf:.0f} / {100 * cz:.0f} %"]
        mode_rows.append(row)
    mode_header = ["f true (Hz)", "sd f (seeds)", "sd ζ (seeds)"]
    for label in LABELS:
        mode_header += [f"σ_f / sd ({names[label]})", "σ_ζ / sd", "covers f / ζ"]
    return "\n".join(out + [
        "The modes (σ: the median standard deviation the covariance gives; covers: the "
        "interval ± z σ holds the true f, ζ):", "", markdown_table(mode_header, mode_rows), "",
        "At lines between the resonances (half-width: median over the seeds):", "",
        markdown_table(header, rows), "",
        f"Over every {STRIDE}-th line of the band ({freq.size} lines), per entry; the "
        "spread over all seeds, over those of the most common order, and over the rest "
        "(of many orders):", "",
        markdown_table(cov_header, cov_rows), "",
        "Coverage of the noise-free FRF per seed (the three entries, every "
        f"{STRIDE}-th line):", "",
        markdown_table(["seed", "m"] + [f"covers ({names[k]})" for k in LABELS], seed_rows)])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--first", type=int, default=0, help="the first seed")
    ap.add_argument("--cache", help="folder keeping each seed's fit and bands (resumable)")
    ap.add_argument("--bands-again", action="store_true",
                    help="form the bands again from the kept fits (after a change to them)")
    ap.add_argument("--out", default="bench-results/band_resolution.md")
    args = ap.parse_args(argv)
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        cache = Path(args.cache) if args.cache else Path(tmp)
        cache.mkdir(parents=True, exist_ok=True)
        for seed in range(args.first, args.first + args.seeds):
            f = cache / f"seed{seed}.npz"
            if f.exists() and not args.bands_again:
                runs.append(dict(np.load(f)))
                continue
            r = one_seed(seed, cache)
            np.savez(f, **r)
            runs.append(r)
            print(f"seed {seed}: m = {r['m']}, estimated / true noise variance: channel "
                  f"{np.median(r['channel_variance_ratio']):.3g}, local "
                  f"{np.median(r['local_variance_ratio']):.3g}", flush=True)
    text = "# The FRF band on the high-resolution test, by Monte Carlo\n\n" + summarise(runs)
    write_report(text, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
