"""Are the confidence intervals right? Monte Carlo coverage and sharpness of ``model_uncertainty``.

On systems whose model class contains the truth — the full-order chain, observed at every
DOF on its POD basis (m = n) — over many noise seeds, for every natural frequency, every
damping ratio and the FRF band at every line and entry:

* **coverage**: the fraction of seeds whose interval (95 % unless ``--level``) holds the
  true value (the noise-free FRF for the band); its sampling error over N seeds is
  ±2√(0.95·0.05/N) (±3.1 % at 200);
* **sharpness**: the median half-width over 1.96 × the standard deviation of the
  estimate over the seeds (ideal 1).

Cases:

* **additive**: FRFs plus circular complex Gaussian noise of known variance, per
  channel (response DOF and input) σ² = mean |H|² / 10^(SNR/10), SNR 20 and 10 dB; the
  maximum-likelihood fit (weights 1/σ) with σ² given, and with σ² estimated per channel
  from the residuals; and the refinement's default relative weights 1/‖u‖, which are
  computed from the noisy data themselves;
* **H1**: the chain driven at one end by band-limited white noise, responses with white
  output noise (SNR per channel of the histories), H1 by Welch averaging with
  :func:`podid_rs.frf_h1` (Hann, half overlap) and uniform weights; the variance from
  the coherence and the effective number of averages, with and without the correlation
  of neighbouring lines (:func:`podid_rs.h1_coherence`).

Every fit starts from the true model, so that what is measured is the interval around
the optimum, not the search for it.

``--cases beam``: ``podid-rs identify``'s run on the shared roving-hammer beam
(``tests/data/ufsc_beam``) in each band, timed, with the time the intervals take in it
(the covariance, the modes' intervals and the overlays' bands), and the structure's modes
with their intervals beside sdypy-EMA's natural frequencies and damping ratios for the
same modes (its best LSCF + LSFD fit, ``bench_measured.py``'s harness, the same run).

    python3 benches/bench_uncertainty.py                  # 200 seeds (13 min under load)
    python3 benches/bench_uncertainty.py --seeds 40       # a quicker look
    python3 benches/bench_uncertainty.py --cases beam     # the beam against sdypy-EMA
    python3 benches/bench_uncertainty.py --cases cost     # what the intervals cost

``--cases cost``: (1) ``podid-rs identify``'s run (``run_identify``) on a full-order chain
of m = 10, 20, 40 DOFs (FRFs at two inputs, 400 lines, 1 % noise) at that m, timed, with the
time of what the intervals add to it: the covariance, the modes' intervals and the bands of
the FRF overlays; (2) at m = 100 (``--large-m``), matrix-free: the chain's responses to
random forces on every DOF at 1000 lines (``--large-s``; ``_common.chain_problem``, 0.1 %
noise), refined from the truth, then ``model_uncertainty(solver="matrix-free")``, every
mode's interval and the band of two FRF entries at every line — in a fresh process, its
peak resident memory after the refinement, then (the peak reset to the resident size,
Linux's ``clear_refs``) the intervals' own after each phase, the reasons of the modes
without an interval and the ConvergenceWarnings.
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
from _common import (  # noqa: E402
    chain_problem,
    host_line,
    load_average,
    markdown_table,
    peak_rss_gb,
    run_worker,
    worker_main,
    write_report,
)

#: the additive case: chain, lines, inputs (0-based DOFs)
ADDITIVE_N = 8
ADDITIVE_LINES = 300
#: the H1 case: chain, sampling, segment length (frequency resolution), segments, SNR
H1_N = 6
H1_FS = 128.0
H1_DF = 0.0125
H1_SEGMENTS = 25
H1_SNR_DB = 10.0


def chain(n: int, a0: float, a1: float) -> pr.SecondOrderSystem:
    """A chain of n unit masses (springs 10⁴ N/m, both ends fixed), Rayleigh damping."""
    return pr.mass_spring_chain(n, m1=1.0, m2=1.0, ku=1e4, a0=a0, a1=a1)


def band_of(system: pr.SecondOrderSystem) -> tuple[float, float]:
    f = pr.modal_parameters(system).frequencies_hz
    return 0.7 * f[0], 1.15 * f[-1]


class Tally:
    """Estimates, standard deviations and FRF bands of one row over the seeds."""

    def __init__(self) -> None:
        self.f, self.z, self.sf, self.sz = [], [], [], []
        self.H, self.lo, self.up = [], [], []
        self.seconds: list[float] = []

    def add(self, unc: pr.ModelUncertainty, level: float, seconds: float) -> None:
        modes = unc.modes(level)
        band = unc.frf(level=level)
        self.z_value = modes.z
        self.f.append(modes.frequencies_hz)
        self.z.append(modes.damping_ratios)
        self.sf.append(modes.std_frequency_hz)
        self.sz.append(modes.std_damping)
        self.H.append(band.values)
        self.lo.append(band.lower)
        self.up.append(band.upper)
        self.seconds.append(seconds)

    def summary(self, truth: pr.SecondOrderSystem, H_true: np.ndarray) -> dict:
        modes = pr.modal_parameters(truth)
        f, z, sf, sz = (np.array(v) for v in (self.f, self.z, self.sf, self.sz))
        zq = self.z_value
        out = {}
        for name, est, sd, true in (("f", f, sf, modes.frequencies_hz),
                                    ("zeta", z, sz, modes.damping_ratios)):
            cover = np.mean(np.abs(est - true) <= zq * sd, axis=0)
            sharp = np.median(zq * sd, axis=0) / (1.96 * est.std(axis=0))
            out[name] = (cover, sharp)
            out[name + "_bias"] = (est.mean(axis=0) - true) / est.std(axis=0)
        H, lo, up = (np.array(v) for v in (self.H, self.lo, self.up))
        true = np.abs(H_true)
        inside = (true >= lo) & (true <= up)
        per_line = inside.mean(axis=0)
        sharp = np.median((up - lo) / 2, axis=0) / (1.96 * np.abs(H).std(axis=0))
        out["frf"] = (float(inside.mean()), per_line, sharp)
        out["seconds"] = float(np.median(self.seconds))
        return out


def additive_case(snr_db: float, seeds: int, level: float) -> tuple[list, dict]:
    n = ADDITIVE_N
    system = chain(n, 2.0, 1e-4)
    lo, hi = band_of(system)
    omega = 2 * np.pi * np.linspace(lo, hi, ADDITIVE_LINES)
    inputs = [0, n // 2]
    H = system.frf(omega)[:, :, inputs]
    F = np.zeros_like(H)
    for k, i in enumerate(inputs):
        F[:, i, k] = 1.0
    var = np.broadcast_to(np.mean(np.abs(H) ** 2, axis=0) / 10 ** (snr_db / 10), H.shape).copy()
    ml = 1 / np.sqrt(var)
    rows = {"ML, σ² given": Tally(), "ML, σ² from residuals": Tally(),
            "relative 1/‖u‖, σ² given": Tally()}
    t_fit = []
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        e = rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)
        U = H + np.sqrt(var / 2) * e
        R = pr.pod_from_frf(U, omega).basis(n)
        start = tuple(R.T @ X @ R for X in (system.M, system.C, system.K))
        for weights, names in ((ml, ("ML, σ² given", "ML, σ² from residuals")),
                               ("relative", ("relative 1/‖u‖, σ² given",))):
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = pr.refine(start, U, F, omega, basis=R, weights=weights, max_iter=300)
            t_fit.append(time.perf_counter() - t0)
            for name in names:
                t0 = time.perf_counter()
                kw = {} if "residuals" in name else {"noise_variance": var}
                unc = pr.model_uncertainty(model, U, F, omega, basis=R, weights=weights, **kw)
                rows[name].add(unc, level, time.perf_counter() - t0)
    setup = (f"chain n = m = {n}, {ADDITIVE_LINES} lines {lo:.2f}–{hi:.2f} Hz, inputs at DOFs "
             f"{inputs[0] + 1} and {inputs[1] + 1}, SNR {snr_db:g} dB per channel")
    return [(setup, name, t.summary(system, H)) for name, t in rows.items()], {
        "refine_s": float(np.median(t_fit))}


def h1_case(seeds: int, level: float) -> tuple[list, dict]:
    n = H1_N
    system = chain(n, 6.0, 3e-4)
    lo, hi = band_of(system)
    dt = 1 / H1_FS
    nperseg = round(H1_FS / H1_DF)
    step = nperseg - nperseg // 2
    r = step * (H1_SEGMENTS - 1) + nperseg
    freq = np.fft.rfftfreq(r, dt)
    forced = (freq >= 0.8 * lo) & (freq <= 1.2 * hi)
    H_forced = system.frf(2 * np.pi * freq[forced])
    rows = {"uniform, H1 variance, neighbouring lines correlated": Tally(),
            "uniform, H1 variance, lines taken independent": Tally()}
    H_true = None
    t_fit = []
    for seed in range(seeds):
        rng = np.random.default_rng(10_000 + seed)
        X = np.zeros(freq.size, complex)
        X[forced] = rng.standard_normal(forced.sum()) + 1j * rng.standard_normal(forced.sum())
        x = np.fft.irfft(X, n=r)
        Y = np.zeros((freq.size, n), complex)
        Y[forced] = H_forced[:, :, 0] * X[forced][:, None]
        y = np.fft.irfft(Y, n=r, axis=0)
        y = y + rng.standard_normal(y.shape) * np.sqrt(y.var(axis=0) / 10 ** (H1_SNR_DB / 10))
        omega, H1 = pr.frf_h1(x[:, None], y, dt, nperseg=nperseg, band_hz=(lo, hi))
        stats = pr.h1_coherence(x[:, None], y, dt, nperseg=nperseg, band_hz=(lo, hi))
        if H_true is None:
            H_true = system.frf(omega)[:, :, [0]]
        F = np.zeros_like(H1)
        F[:, 0, 0] = 1.0
        R = pr.pod_from_frf(H1, omega).basis(n)
        start = tuple(R.T @ M @ R for M in (system.M, system.C, system.K))
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = pr.refine(start, H1, F, omega, basis=R, weights="uniform", max_iter=300)
        t_fit.append(time.perf_counter() - t0)
        for name, rho in zip(rows, (stats.line_correlation, ()), strict=True):
            t0 = time.perf_counter()
            unc = pr.model_uncertainty(model, H1, F, omega, basis=R, weights="uniform",
                                       coherence=stats.coherence, averages=stats.averages,
                                       line_correlation=rho)
            rows[name].add(unc, level, time.perf_counter() - t0)
    setup = (f"chain n = m = {n}, force at DOF 1, {H_true.shape[0]} lines {lo:.2f}–{hi:.2f} Hz "
             f"({H1_DF:g} Hz apart), {H1_SEGMENTS} Hann segments half overlapping "
             f"(worth {stats.averages:.1f} averages), output noise SNR {H1_SNR_DB:g} dB")
    return [(setup, name, t.summary(system, H_true)) for name, t in rows.items()], {
        "refine_s": float(np.median(t_fit))}


def beam_case(bands: list[tuple[float, float]], out_dir: Path) -> str:
    """identify on the beam, timed, its structural modes' intervals beside sdypy-EMA's."""
    from bench_measured import BEAM, run_sdypy
    from podid_rs.apps.identify import pole_kinds, run_identify
    from podid_rs.modes import STRUCTURAL

    parts = []
    for band in bands:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run = run_identify(BEAM, out_dir / f"beam_{band[0]:g}_{band[1]:g}", band_hz=band,
                               progress=False)
        t_identify = time.perf_counter() - t0
        d = run.data
        # what identify spends on the intervals: the covariance, the modes', the overlays'
        unc = run.uncertainty
        modes = unc.modes()
        t_intervals = run.timings["covariance"] + intervals_time(run, unc)
        structural = np.flatnonzero(pole_kinds(run.result, run.basis, d) == STRUCTURAL)
        t0 = time.perf_counter()
        sd = run_sdypy(d, band)
        t_sdypy = time.perf_counter() - t0
        rows = []
        for k in structural:
            f, z = modes.frequencies_hz[k], modes.damping_ratios[k]
            j = int(np.argmin(np.abs(sd["freqs_hz"] - f)))
            fs, zs = sd["freqs_hz"][j], sd["zetas"][j]
            close = abs(fs - f) <= 0.02 * f
            rows.append([str(k + 1), f"{f:.3f} ± {modes.z * modes.std_frequency_hz[k]:.3f}",
                         f"{100 * z:.3f} ± {100 * modes.z * modes.std_damping[k]:.3f}",
                         f"{fs:.3f}" if close else "—", f"{100 * zs:.3f}" if close else "—",
                         f"{(fs - f) / (modes.z * modes.std_frequency_hz[k]):+.1f}"
                         if close else "—"])
        parts += [
            f"### {band[0]:g}–{band[1]:g} Hz: m = {run.result.m}, {d.s} lines", "",
            f"- `podid-rs identify`'s run {t_identify:.1f} s, of which the intervals "
            f"{t_intervals:.1f} s ({100 * t_intervals / (t_identify - t_intervals):.0f} % "
            f"added to the rest); sdypy-EMA {t_sdypy:.1f} s ({sd['note']})",
            f"- {unc.summary(select=np.isin(np.arange(modes.frequencies_hz.size), structural))}",
            "",
            markdown_table(["mode", "podid_rs f (Hz) ± 95 %", "ζ (%) ± 95 %", "sdypy-EMA f (Hz)",
                            "sdypy-EMA ζ (%)", "(f_sdypy − f) / half-width"], rows), "",
        ]
    return "\n".join(parts)


def intervals_time(run, unc: pr.ModelUncertainty) -> float:
    """What ``run_identify`` spends on the intervals beyond the covariance: the modes'
    (the table and the summary line) and the bands of the FRF overlays, timed again."""
    from podid_rs.apps.identify import MAX_OVERLAYS

    d = run.data
    t0 = time.perf_counter()
    unc.modes()
    unc.modes()
    for k in range(min(d.inputs.size, MAX_OVERLAYS)):
        col = int(d.inputs[k])
        distance = np.where(d.measured[:, k], np.abs(d.dofs[:, 0] - d.dofs[col, 0]), -1)
        unc.frf(d.omega, rows=[col, int(np.argmax(distance))], cols=[col])
    return time.perf_counter() - t0


def cost_identify(sizes: list[int], out_dir: Path) -> str:
    """identify at m = n on chains of each size: its time and the intervals' share."""
    from podid_rs.apps.identify import run_identify
    from podid_rs.io.npz import save_data
    from podid_rs.measured import from_frf

    rows = []
    for m in sizes:
        system = chain(m, 2.0, 1e-4)
        lo, hi = band_of(system)
        omega = 2 * np.pi * np.linspace(lo, hi, 400)
        inputs = [0, m // 2]
        H = system.frf(omega)[:, :, inputs]
        rng = np.random.default_rng(m)
        U = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
                 / np.sqrt(2))
        path = save_data(out_dir / f"chain{m}.npz", from_frf(U, omega, inputs=inputs))
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            run = run_identify(path, out_dir / f"chain{m}", band_hz=(lo * 0.99, hi * 1.01),
                               m=m, progress=False)
        total = time.perf_counter() - t0
        unc = run.uncertainty
        covariance = run.timings["covariance"]
        extra = intervals_time(run, unc)
        added = covariance + extra
        rows.append([str(m), unc.solver, f"{total:.1f}", f"{run.timings['final fit']:.1f}",
                     f"{covariance:.2f}", f"{extra:.2f}",
                     f"{100 * added / (total - added):.1f} %"])
    return markdown_table(["m", "solver", "identify s", "of which the final fit s",
                           "covariance s", "modes' intervals and bands s",
                           "added to identify"], rows)


def resident_gb() -> float:
    """This process's resident size now (VmRSS), GB; NaN where /proc cannot be read."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024 / 1e9
    except OSError:
        pass
    return float("nan")


def large_worker(case: dict) -> dict:
    """Refine the chain at m from the truth, then the matrix-free intervals: times and the
    peak resident memory after each (also written to ``case["progress"]`` as they come, for
    a run cut short)."""
    import json

    m, s = case["m"], case["s"]
    out: dict = {}

    def done(**values) -> None:
        out.update(values, peak_gb=peak_rss_gb())
        Path(case["progress"]).write_text(json.dumps(out))

    system, U, F, omega = chain_problem(m, s=s, noise=1e-3, seed=1)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = pr.refine(system, U, F, omega, max_iter=200)
    done(refine_s=time.perf_counter() - t0, steps=model.iterations, peak_refine_gb=peak_rss_gb())
    # the intervals' own peak from here: Linux resets VmHWM to the current resident size
    # on "5" written to clear_refs (the peaks below would otherwise be at least the
    # refinement's)
    try:
        Path("/proc/self/clear_refs").write_text("5")
        out["peak_reset"] = True
    except OSError:
        out["peak_reset"] = False
    out["resident_at_reset_gb"] = resident_gb()
    t0 = time.perf_counter()
    unc = pr.model_uncertainty(model, U, F, omega, solver="matrix-free")
    done(covariance_s=time.perf_counter() - t0, peak_covariance_gb=peak_rss_gb())
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", pr.ConvergenceWarning)
        modes = unc.modes()
    reasons = {str(r): int(c) for r, c in zip(*np.unique(modes.why_undetermined[
        ~modes.determined], return_counts=True), strict=True)}
    done(modes_s=time.perf_counter() - t0, determined=int(np.sum(modes.determined)),
         modes=int(modes.determined.size), why_undetermined=reasons,
         convergence_warnings=len(caught), peak_modes_gb=peak_rss_gb(),
         median_rel_f=float(np.nanmedian(modes.std_frequency_hz / modes.frequencies_hz)),
         cg_iterations=[int(v) for v in unc._cov.iterations])
    blocks = len(unc._cov.iterations)
    t0 = time.perf_counter()
    band = unc.frf(omega, rows=[0, m - 1], cols=[0])
    done(band_s=time.perf_counter() - t0, finite_band=bool(np.all(np.isfinite(band.upper))),
         band_iterations=[int(v) for v in unc._cov.iterations[blocks:]])
    return out


def cost_large(m: int, s: int, progress: Path, timeout: float) -> str:
    import json
    import subprocess

    try:
        r = run_worker(str(Path(__file__).resolve()),
                       {"kind": "large", "m": m, "s": s, "progress": str(progress)},
                       timeout=timeout)
    except subprocess.TimeoutExpired:
        r = {"error": f"not finished in {timeout:g} s"}
    if "error" in r:
        got = json.loads(progress.read_text()) if progress.exists() else {}
        return f"- m = {m}, s = {s}, matrix-free: {r['error']}; what had finished: {got}"
    its, band_its = r["cg_iterations"], r["band_iterations"]
    added = r["covariance_s"] + r["modes_s"] + r["band_s"]
    why = ", ".join(f"{c} {w}" for w, c in r["why_undetermined"].items()) or "none"
    return (f"- m = {m}, s = {s}, matrix-free: refine {r['refine_s']:.1f} s ({r['steps']} "
            f"steps, from the truth), peak {r['peak_refine_gb']:.3f} GB; the intervals "
            f"{added:.0f} s (covariance {r['covariance_s']:.1f} s, peak "
            f"{r['peak_covariance_gb']:.3f} GB; {r['modes']} modes' intervals "
            f"{r['modes_s']:.0f} s in {len(its)} blocks of CG, {min(its)}–{max(its)} "
            f"iterations each, {r['determined']} determined (without an interval: {why}; "
            f"{r['convergence_warnings']} ConvergenceWarning), their median σ_f/f "
            f"{r['median_rel_f']:.1e}, peak {r['peak_modes_gb']:.3f} GB; the band of 2 "
            f"entries at {s} lines {r['band_s']:.0f} s, its draws in {len(band_its)} blocks, "
            f"{min(band_its, default=0)}–{max(band_its, default=0)} iterations each, "
            f"finite: {'yes' if r['finite_band'] else 'no'}); peak after them "
            f"{r['peak_gb']:.3f} GB ({'their own' if r['peak_reset'] else 'the process'}'s; "
            f"resident when they began {r['resident_at_reset_gb']:.3f} GB) "
            f"— {added / r['refine_s']:.1f}× the refinement's time, "
            f"{r['peak_gb'] / r['peak_refine_gb']:.2f}× its peak memory")


def table(results: list, seeds: int) -> str:
    header = ["case", "fit and noise", "f coverage: all modes (min–max)",
              "f sharpness", "ζ coverage: all modes (min–max)", "ζ sharpness",
              "FRF band coverage (all / lines 5–95 %)",
              "FRF sharpness (5 / 50 / 95 %)", "s per interval set"]
    rows = []
    for setup, name, s in results:
        (cf, hf), (cz, hz) = s["f"], s["zeta"]
        frf_all, per_line, sharp = s["frf"]
        q = np.percentile(sharp[np.isfinite(sharp)], [5, 50, 95])
        pl = np.percentile(per_line, [5, 95])
        rows.append([setup, name, f"{cf.mean():.3f} ({cf.min():.3f}–{cf.max():.3f})",
                     f"{hf.min():.2f}–{hf.max():.2f}",
                     f"{cz.mean():.3f} ({cz.min():.3f}–{cz.max():.3f})",
                     f"{hz.min():.2f}–{hz.max():.2f}",
                     f"{frf_all:.3f} ({pl[0]:.2f}–{pl[1]:.2f})",
                     f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f}", f"{s['seconds']:.2f}"])
    return markdown_table(header, rows)


def per_mode(results: list) -> str:
    lines = []
    for setup, name, s in results:
        (cf, hf), (cz, hz) = s["f"], s["zeta"]
        lines.append(f"- {setup}; {name}: f coverage " + " ".join(f"{v:.3f}" for v in cf)
                     + "; ζ coverage " + " ".join(f"{v:.3f}" for v in cz)
                     + "; f sharpness " + " ".join(f"{v:.2f}" for v in hf)
                     + "; ζ sharpness " + " ".join(f"{v:.2f}" for v in hz)
                     + "; bias of f / its standard deviation "
                     + " ".join(f"{v:+.2f}" for v in s["f_bias"])
                     + "; of ζ " + " ".join(f"{v:+.2f}" for v in s["zeta_bias"]))
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--level", type=float, default=0.95)
    ap.add_argument("--cases", default="additive,h1")
    ap.add_argument("--out", default="bench-results/uncertainty.md")
    ap.add_argument("--sizes", default="10,20,40", help="orders of the cost case's identify")
    ap.add_argument("--large-m", type=int, default=100, help="0: no matrix-free case")
    ap.add_argument("--large-s", type=int, default=1000)
    ap.add_argument("--large-timeout", type=float, default=7200.0)
    ap.add_argument("--beam-bands", default="50-300,20-800", help="the beam's bands, Hz")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    load = [load_average()]
    results, notes = [], []
    cases = args.cases.split(",")
    if "additive" in cases:
        for snr in (20.0, 10.0):
            rows, info = additive_case(snr, args.seeds, args.level)
            results += rows
            notes.append(f"- additive, SNR {snr:g} dB: refine {info['refine_s']:.2f} s per fit "
                         "(median)")
            load.append(load_average())
            print(table(results, args.seeds), flush=True)
    if "h1" in cases:
        rows, info = h1_case(args.seeds, args.level)
        results += rows
        notes.append(f"- H1: refine {info['refine_s']:.2f} s per fit (median)")
        load.append(load_average())
    if "beam" in cases or "cost" in cases:
        parts = []
        if "beam" in cases:
            bands = [tuple(float(v) for v in b.split("-")) for b in args.beam_bands.split(",")]
            parts += ["## Intervals on the beam beside sdypy-EMA", "",
                      beam_case(bands, Path(args.out).parent)]
            load.append(load_average())
        if "cost" in cases:
            sizes = [int(v) for v in args.sizes.split(",") if v]
            parts += ["## What the intervals cost", ""]
            if sizes:
                parts += [cost_identify(sizes, Path(args.out).parent), ""]
            if args.large_m > 0:
                parts += [cost_large(args.large_m, args.large_s,
                                     Path(args.out).with_suffix(".large.json"),
                                     args.large_timeout)]
            load.append(load_average())
        loads = [v for v in load if v is not None]
        parts += ["", f"Command: `python3 benches/bench_uncertainty.py --cases {args.cases}`; "
                  f"total {time.perf_counter() - t0:.0f} s"
                  + (f"; load average {min(loads):.1f}–{max(loads):.1f}" if loads else "")]
        if not results:
            write_report("\n".join(parts), args.out)
            return 0
        notes += parts
    se = 2 * np.sqrt(0.95 * 0.05 / args.seeds)
    loads = [v for v in load if v is not None]
    text = "\n".join([
        "# Confidence intervals: Monte-Carlo coverage and sharpness", "",
        host_line(), "",
        f"{args.seeds} noise seeds per row, {100 * args.level:g} % intervals; coverage's sampling "
        f"error ±{se:.3f} (two standard errors); sharpness = median half-width / (1.96 × the "
        "estimates' standard deviation over the seeds). Command: "
        f"`python3 benches/bench_uncertainty.py --seeds {args.seeds}`.", "",
        table(results, args.seeds), "", "Per mode:", "", per_mode(results), "", *notes,
        f"- total {time.perf_counter() - t0:.0f} s"
        + (f"; load average {min(loads):.1f}–{max(loads):.1f}" if loads else ""),
    ])
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")
    print(text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        worker_main({"large": large_worker})
    else:
        raise SystemExit(main())
