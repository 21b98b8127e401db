"""The paper's numerical study (Section 6) end to end: figures and a results table.

:func:`run_paper_study` repeats Khalil, Adhikari & Sarkar (2007), Section 6, on
the 100-DOF chain (:func:`podid_rs.mass_spring_chain`), for each of the four
frequency bands:

1. simulate unit-variance band-limited white noise on every DOF and the
   response (:func:`podid_rs.simulate_white_noise`: exact frequency-domain
   synthesis, periodic steady state, no transient, no leakage);
2. build the response correlation matrix and its POD (eqs. 3–7, 41–44);
3. project the measured spectra on the first m POD modes (eqs. 45–46);
4. identify the reduced M, C, K with symmetry regularisation λ (eq. 40), from
   noise-free responses and from responses with noise at SNR 20 dB and 10 dB;
5. refine that model to the least output error (:mod:`podid_rs.identification.refinement`:
   M, C, K positive definite, the model stable; noise on the responses biases
   the paper's estimator, not this one);
6. compare the driving-point FRF H(50,50) and the cross-FRF H(60,40) (1-based,
   as in the paper) of the original model, of the POD-projected model
   (RᵀMR, RᵀCR, RᵀKR; eqs. 14–16), of the identified and of the refined model,
   mapped back to physical coordinates as H_n ≈ R H_m(ω) Rᵀ.

It writes one PNG per paper figure group (Figs. 2–19), ``results.csv`` and
``results.md``. Choices the paper leaves open, made here:

* Record. dt = 2.5 ms (Nyquist 200 Hz, above every band) and 100 s, so the
  FFT lines are 0.01 Hz apart, well inside the narrowest half-power bandwidth
  of the chain (about 0.066 Hz, first mode at 3.95 Hz, ζ ≈ 0.8 %). Band 1 then
  has 1001 lines, the others 2001. ``quick`` uses 20 s (0.05 Hz lines) and
  coarser plotting grids; the code path is the same. (At 10 s the POD basis
  of band 4 is occasionally poor: 4 seeds in 200 gave a projected-model error
  above 4 dB; at 20 s none in 100 did.)
* Response noise (Section 6.2.2, eq. 53). The paper models it as
  "uncorrelated Gaussian band-limited white noise"; we add to every response
  channel independent Gaussian noise confined to the forcing band, of variance
  σ_s²/10^(SNR/10) with σ_s² that channel's own signal variance, to the time
  history; the spectra are then taken of the noisy history. (Noise over the
  whole Nyquist range would leave only a band-width/Nyquist fraction of itself
  in the band, so the in-band SNR would depend on dt.) The forces are the
  known inputs and stay noise-free.
* POD basis under noise. It is taken from the noisy measured response, as a
  user would have to. Noise at a fixed SNR per channel is not isotropic (its
  variance follows each channel's signal variance), so it does rotate the
  trailing POD modes: in band 3 at 10 dB the basis moves far enough that the
  projected model's H(50,50) error grows from about 2 to 8 dB (see the
  "projected" columns of the table, which use the same basis as the
  identified model in each row).
* Reduced order. m is the paper's (2, 4, 10, 13), or with ``energy`` the
  smallest m whose modes capture that energy fraction of the noise-free
  response (eq. 43); it is then kept for the noisy cases, as the paper keeps it
  for Figs. 12–19 (noise spreads energy over all modes, so the criterion on a
  noisy response would ask for dozens of modes).
* λ is in the paper's units on this library's spectra (unnormalised real FFT,
  see :mod:`podid_rs.simulation`). The data term grows with the square of the
  data scale and the penalty does not, so how strictly a given λ enforces
  symmetry depends on that scaling; the table reports the symmetry defect
  ‖X − Xᵀ‖/‖X‖ of every identified matrix.
* Errors. dB error = |20 log10(|H_model| / |H_original|)| on the in-band FFT
  lines of the record, summarised by its median and 95th percentile.
"""

from __future__ import annotations

import csv
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from .._progress import Progress
from .._validation import check_lam
from ..identification.estimator import identify
from ..identification.refinement import StartWarning, refine
from ..identification.regularisation import RULES, LambdaSelectionWarning
from ..identification.result import ConvergenceWarning
from ..physical import modal_parameters
from ..plotting import (
    Curve,
    plot_frf_comparison,
    plot_full_frf,
    plot_lambda_curve,
    plot_pod_eigenvalues,
)
from ..pod import PODResult, pod_from_spectra
from ..simulation import Simulation, add_noise, simulate_white_noise
from ..systems import SecondOrderSystem, mass_spring_chain
from ..uncertainty import LEVEL, model_uncertainty

#: The four frequency bands of Section 6.1 (Hz).
BANDS_HZ: tuple[tuple[float, float], ...] = (
    (1.5, 11.5),
    (1.5, 21.5),
    (53.5, 73.5),
    (102.8, 122.8),
)
#: Reduced orders the paper identifies in each band (Figs. 8–19).
PAPER_ORDERS: tuple[int, ...] = (2, 4, 10, 13)
#: Response noise levels: None = noise-free, else SNR in dB (eq. 53).
NOISE_LEVELS: tuple[float | None, ...] = (None, 20.0, 10.0)
#: FRF entries compared, 1-based (row, column): driving point and cross.
ENTRIES: tuple[tuple[int, int], ...] = ((50, 50), (60, 40))
#: Masses of the paper's chain; ``n`` of :func:`run_paper_study` changes it.
PAPER_N = 100
#: The paper's regularisation parameter λ_M = λ_C = λ_K (Section 6.2.1).
PAPER_LAMBDA = 100.0


def chain_entries(n: int) -> tuple[tuple[int, int], ...]:
    """The compared entries of an n-mass chain, 1-based, at the paper's relative places:
    H(n/2, n/2) and H(0.6n, 0.4n) — :data:`ENTRIES` at n = 100."""
    return ((max(1, n // 2),) * 2, (max(1, round(0.6 * n)), max(1, round(0.4 * n))))


@dataclass(frozen=True)
class StudySettings:
    """Record, grids and parameters of one study run."""

    quick: bool
    seed: int
    #: λ triple (eq. 40), or the name of a rule that chooses one λ per row (§4.2)
    lam: tuple[float, float, float] | str
    energy: float | None
    dt: float
    duration: float
    plot_points: int
    full_points: int
    n: int = PAPER_N

    @property
    def line_spacing_hz(self) -> float:
        """Spacing of the FFT lines of the record, 1/duration."""
        return 1.0 / self.duration


def _settings(
    quick: bool, seed: int, lam: tuple[float, float, float] | str, energy: float | None,
    n: int = PAPER_N,
):
    if quick:
        return StudySettings(quick, seed, lam, energy, dt=1 / 400, duration=20.0,
                             plot_points=300, full_points=1200, n=n)
    return StudySettings(quick, seed, lam, energy, dt=1 / 400, duration=100.0,
                         plot_points=2000, full_points=6000, n=n)


@dataclass(frozen=True)
class StudyRow:
    """One band at one noise level: the numbers of ``results.csv``.

    ``energy`` is the energy fraction of the m retained modes (eq. 43) of that
    row's (possibly noisy) response; ``sym_*`` are ‖X − Xᵀ‖_F/‖X‖_F of the
    identified matrices; ``id_*``/``proj_*`` are the median and 95th percentile
    over the in-band lines of |20 log10(|H_model|/|H_original|)| (dB) for the
    identified and the POD-projected model, ``refined_*`` the same for the
    identified model refined to the least output error (:func:`podid_rs.refine`,
    relative then uniform weights, the latter the maximum-likelihood fit for white
    noise on the responses; M, C, K positive definite, ``refined_stable`` whether
    every mode has Re λ < 0, ``refined_iterations`` its Levenberg–Marquardt steps;
    on noisy rows it is identified and refined on the noise-corrected POD basis,
    :func:`_refine_noisy_row`, when the POD is from the correlation matrix);
    ``refined_modes`` its in-band modes, each natural frequency and damping ratio with
    the half-width of its 95 % interval (:func:`podid_rs.model_uncertainty`, the noise
    estimated from the residuals), ``"f ± h Hz, ζ ± h %"`` joined by ``"; "``.
    Times are seconds; ``t_simulate_s`` (forward simulation of the band and the
    original model's FRFs) is shared
    by a band's three rows and is given on its noise-free row only (NaN on the
    others).
    """

    band: int
    f_lo_hz: float
    f_hi_hz: float
    noise: str
    snr_db: float
    m: int
    n_lines: int
    energy: float
    sym_M: float
    sym_C: float
    sym_K: float
    id_h50_50_median_db: float
    id_h50_50_p95_db: float
    id_h60_40_median_db: float
    id_h60_40_p95_db: float
    proj_h50_50_median_db: float
    proj_h50_50_p95_db: float
    proj_h60_40_median_db: float
    proj_h60_40_p95_db: float
    refined_h50_50_median_db: float
    refined_h50_50_p95_db: float
    refined_h60_40_median_db: float
    refined_h60_40_p95_db: float
    refined_stable: bool
    refined_iterations: int
    refined_modes: str
    lam: float
    lam_rule: str
    t_simulate_s: float
    t_pod_s: float
    t_identify_s: float
    t_frf_s: float
    t_refine_s: float


@dataclass(frozen=True)
class PaperStudy:
    """What :func:`run_paper_study` produced: table rows, file paths, settings."""

    out_dir: Path
    rows: tuple[StudyRow, ...]
    figures: tuple[Path, ...]
    csv_path: Path
    md_path: Path
    settings: StudySettings
    elapsed_s: float

    def row(self, band: int, snr_db: float | None = None) -> StudyRow:
        """The row of ``band`` (1-based) at ``snr_db`` (None = noise-free)."""
        want = _noise_label(snr_db)
        for r in self.rows:
            if r.band == band and r.noise == want:
                return r
        raise KeyError(f"no row for band {band}, {want}")

    def summary(self) -> str:
        """A few lines for the terminal: median dB errors per band and noise level."""
        s = self.settings
        (i, j), (k, q) = chain_entries(s.n)
        lines = [
            f"Section 6 of Khalil, Adhikari & Sarkar (2007): n = {s.n} chain, "
            f"λ = {_lam_text(s.lam)}, {s.duration:g} s record"
            f"{' (quick)' if s.quick else ''}, seed {s.seed}",
            "median |dB error| vs the original FRF: paper's estimator, refined (projected):",
            f"  {'band':<18} {'noise':<10} {'m':>3} {'energy':>7}"
            f"  {f'H({i},{j})':>22}  {f'H({k},{q})':>22}",
        ]
        for r in self.rows:
            lines.append(
                f"  {r.band}: {_band_text(r) + ' Hz':<15} {r.noise:<10} {r.m:>3} {r.energy:>7.4f}"
                f"  {r.id_h50_50_median_db:6.2f} {r.refined_h50_50_median_db:6.2f}"
                f" ({r.proj_h50_50_median_db:5.2f})"
                f"  {r.id_h60_40_median_db:6.2f} {r.refined_h60_40_median_db:6.2f}"
                f" ({r.proj_h60_40_median_db:5.2f})"
            )
        lines.append(
            f"wrote {len(self.figures)} figures, {self.csv_path.name} and {self.md_path.name} "
            f"to {self.out_dir} in {self.elapsed_s:.1f} s"
        )
        return "\n".join(lines)


def _band_text(r: StudyRow) -> str:
    return f"{r.f_lo_hz:g}–{r.f_hi_hz:g}"


def _noise_label(snr_db: float | None) -> str:
    return "noise-free" if snr_db is None else f"SNR {snr_db:g} dB"


def _noise_slug(snr_db: float | None) -> str:
    return "noisefree" if snr_db is None else f"snr{snr_db:g}dB"


def _lam_text(lam: tuple[float, float, float] | str) -> str:
    if isinstance(lam, str):
        return f"chosen by {lam}"
    if lam[0] == lam[1] == lam[2]:
        return f"{lam[0]:g}"
    return "(" + ", ".join(f"{v:g}" for v in lam) + ")"


def _sub_seed(seed: int, *keys: int) -> int:
    """An independent, reproducible seed for one (band, noise level) from the study seed."""
    return int(np.random.SeedSequence([seed, *keys]).generate_state(1)[0])


def frf_entries(
    system: SecondOrderSystem,
    omega: np.ndarray,
    entries: Sequence[tuple[int, int]] = ENTRIES,
    basis: np.ndarray | None = None,
    chunk: int = 128,
) -> np.ndarray:
    """Selected receptance entries H(i, j)(ω), 1-based, shape ``(s, len(entries))``.

    Without ``basis`` the dynamic stiffness (eq. 19) is solved for the unit
    loads at the needed columns only, line by line
    (:meth:`~podid_rs.SecondOrderSystem.frf` with ``rows``/``cols``: O(n) per
    line for the sparse chain). With a
    basis R ``(n, m)`` the system is a reduced model and its FRF is mapped back
    to physical coordinates, H_n(ω) ≈ R H_m(ω) Rᵀ (eqs. 10, 17–19).
    """
    omega = np.asarray(omega, dtype=float)
    rows = np.array([i - 1 for i, _ in entries])
    cols = np.array([j - 1 for _, j in entries])
    out = np.empty((omega.size, len(entries)), dtype=np.complex128)
    if basis is None:
        need_r, row_of = np.unique(rows, return_inverse=True)
        need_c, col_of = np.unique(cols, return_inverse=True)
        return system.frf(omega, rows=need_r, cols=need_c)[:, row_of, col_of]
    R = np.asarray(basis, dtype=float)
    for start in range(0, omega.size, chunk):
        Hm = system.frf(omega[start : start + chunk])
        out[start : start + chunk] = np.einsum("km,smp,kp->sk", R[rows], Hm, R[cols])
    return out


def db_error(H: np.ndarray, H_ref: np.ndarray) -> np.ndarray:
    """|20 log10(|H| / |H_ref|)| elementwise, in dB."""
    return np.abs(20.0 * np.log10(np.abs(H) / np.abs(H_ref)))


def _band_limited_noisy_spectrum(sim: Simulation, snr_db: float, seed: int) -> np.ndarray:
    """The measured response plus band-limited white noise at ``snr_db`` (eq. 53), as its
    in-band spectrum ``(s, n)``.

    The noise lives on the same FFT lines as the forcing band; per channel its
    variance is the channel's signal variance over 10^(SNR/10) (``add_noise``
    applied to the in-band spectrum, whose per-line power is proportional to the
    variance by Parseval). The noisy history is never formed: its spectrum is
    this, to round-off.
    """
    return add_noise(sim.response_spectrum, snr_db, seed=seed, axis=0)


def _plot_window(band: tuple[float, float], points: int) -> np.ndarray:
    """Frequencies (Hz) for a band's figures: the band and 35 % of its width each side."""
    lo, hi = band
    pad = 0.35 * (hi - lo)
    return np.linspace(max(lo - pad, 0.5), hi + pad, points)


def _errors(H: np.ndarray, H_ref: np.ndarray) -> list[float]:
    """Median and 95th percentile of the dB error, for each entry in turn."""
    out = []
    for k in range(H.shape[1]):
        e = db_error(H[:, k], H_ref[:, k])
        out += [float(np.median(e)), float(np.percentile(e, 95))]
    return out


def _figure_name(number: int, band: int, what: str) -> str:
    return f"fig{number:02d}_band{band}_{what}.png"


def _identify_row(U, F, omega, lam, noise_sigma, path, title):
    """identify() with a fixed λ, or with λ chosen by a rule of §4.2 (then the λ curve
    is plotted to ``path``). Returns the result, the λ used, the rule and any warning.

    The discrepancy principle needs the noise level: ``noise_sigma`` (RMS of the
    projected response noise that was added); noise-free rows have none, so GCV
    chooses there instead.
    """
    if not isinstance(lam, str):
        return identify(U, F, omega, lam=lam), lam[0], "fixed", ""
    rule = "gcv" if lam == "discrepancy" and noise_sigma is None else lam
    kw = {"noise": noise_sigma} if rule == "discrepancy" else {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LambdaSelectionWarning)
        result = identify(U, F, omega, lam=rule, **kw)
    plot_lambda_curve(result.info["lambda_curve"], path, title=title)
    notes = "; ".join(
        str(w.message) for w in caught if issubclass(w.category, LambdaSelectionWarning)
    )
    return result, result.lam[0], rule, notes


def _refine_row(result, U, F, omega):
    """The paper's estimator refined to the least output error: first with relative
    weights (each line alike: robust from a start many dB off), then with uniform
    weights, the maximum-likelihood fit for the white in-band noise on the responses.
    From a poor start the uniform fit alone can stall (band 2 at 10 dB, quick mode: a
    cost 55 times higher). The warnings are the table's."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StartWarning)
        warnings.simplefilter("ignore", ConvergenceWarning)
        relative = refine(result, U, F, omega, weights="relative")
        final = refine(relative, U, F, omega, weights="uniform")
    final.info["refinement"]["steps_total"] = relative.iterations + final.iterations
    final.info["refinement"]["modes_in_band"] = _modes_with_intervals(final, U, F, omega)
    return final


def _modes_with_intervals(model, U, F, omega) -> str:
    """The in-band modes of a model refined with uniform weights, each with the half-width
    of its 95 % interval: ``"f ± h Hz, ζ ± h %"`` joined by ``"; "``."""
    try:
        modes = model_uncertainty(model, U, F, omega, weights="uniform").modes(LEVEL)
    except ValueError as exc:  # e.g. no degrees of freedom left for the noise
        return f"(no intervals: {exc})"
    lo, hi = omega.min() / (2 * np.pi), omega.max() / (2 * np.pi)
    f, z = modes.frequencies_hz, modes.damping_ratios
    keep = (f >= lo) & (f <= hi) & (np.abs(modes.eigenvalues.imag) > 0)
    parts = []
    for k in np.flatnonzero(keep):
        if not modes.determined[k]:
            parts.append(f"{f[k]:.4g} Hz, ζ {100 * z[k]:.3g} % (not determined)")
            continue
        hf, hz = modes.z * modes.std_frequency_hz[k], modes.z * modes.std_damping[k]
        parts.append(f"{f[k]:.4g} ± {hf:.2g} Hz, ζ {100 * z[k]:.3g} ± {100 * hz:.2g} %")
    return "; ".join(parts) if parts else "(no mode in the band)"


def _noise_variance(U_n: np.ndarray, n_samples: int, snr_db: float) -> np.ndarray:
    """Each channel's noise variance in the history when its SNR is ``snr_db`` (eq. 53):
    the fraction ρ/(1 + ρ), ρ = 10^(−SNR/10), of its measured mean square
    ``(2/r²) Σ_k |U_k|²`` (Parseval). Known from the noisy data and the SNR alone."""
    rho = 10 ** (-snr_db / 10)
    mean_square = 2.0 / n_samples**2 * np.einsum("kj,kj->j", U_n.real, U_n.real)
    mean_square += 2.0 / n_samples**2 * np.einsum("kj,kj->j", U_n.imag, U_n.imag)
    return mean_square * rho / (1 + rho)


def _refine_noisy_row(sim: Simulation, P_noisy: PODResult, U_n: np.ndarray, snr_db: float,
                      m: int, lam: float):
    """The refined model of a noisy row, on the noise-corrected POD basis.

    Noise of a fixed SNR per channel (eq. 53) adds a non-uniform diagonal to the
    response correlation and turns the paper's POD modes away from the signal's
    (``benches/bench_noise_basis.py``: band 3's projected model 1.9 → 8.1 dB). The
    refinement therefore starts from the paper's estimator (the same λ) on the basis
    of the correlation less the noise's (:func:`pod_from_spectra` with
    ``noise_variance``, the variance the SNR implies: :meth:`PODResult.without_noise`
    of the paper's POD ``P_noisy``). Returns (basis, refined). Used when the POD came
    from the correlation matrix (more snapshot rows than DOFs): with fewer, the
    correction costs another product of the snapshots' size and changes little
    (:meth:`PODResult.without_noise`), so a large chain refines on the paper's basis.
    """
    P = P_noisy.without_noise(_noise_variance(U_n, sim.n_samples, snr_db))
    R = P.basis(m)
    U, F = P.project(U_n, m), P.project(sim.force_spectrum, m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        start = identify(U, F, sim.omega, lam=lam)
    return R, _refine_row(start, U, F, sim.omega)


def run_paper_study(
    out_dir: str | Path = "podid-results",
    quick: bool = False,
    seed: int = 0,
    lam: float | tuple[float, float, float] | str = PAPER_LAMBDA,
    energy: float | None = None,
    progress: bool = True,
    n: int = PAPER_N,
) -> PaperStudy:
    """Run the paper's Section 6 study and write its figures and tables to ``out_dir``.

    ``lam`` is λ or (λ_M, λ_C, λ_K) of eq. 40 (the paper's 100 by default), or a
    rule of §4.2 — ``"lcurve"``, ``"gcv"`` or ``"discrepancy"`` — that chooses one
    common λ for every row (then ``lambda_band{b}_{noise}.png`` shows the curves;
    noise-free rows use GCV when the rule is the discrepancy principle);
    ``energy`` replaces the paper's orders (2, 4, 10, 13) by the smallest m
    capturing that energy fraction (eq. 43); ``seed`` makes the run
    reproducible; ``quick`` shortens the record and the plotting grids (same
    code path, seconds instead of minutes); ``progress`` writes a progress
    line to stderr. Files: ``fig02_full_frf.png``, ``fig03_pod_eigenvalues.png``,
    ``fig04``–``fig07`` (POD-reduced), ``fig08``–``fig19`` (identified: noise-free,
    SNR 20 dB, SNR 10 dB), ``results.csv``, ``results.md``.

    ``n`` is the number of masses of the chain (the paper's 100); the compared
    entries are at the same relative places, :func:`chain_entries`. A large chain
    is sparse and simulated without time histories (POD from the in-band spectra,
    which equals the time correlation by Parseval), so n = 10⁵ runs in minutes.

    Raises ``ValueError`` for a bad ``lam``, ``energy``, ``seed`` or ``n`` (before
    any work).
    """
    t_start = time.perf_counter()
    if isinstance(lam, str):
        if lam not in RULES:
            raise ValueError(f"lam must be a number, a triple or one of {RULES}, got {lam!r}")
        lam_t: tuple[float, float, float] | str = lam
    else:
        lam_t = check_lam(lam)
    if energy is not None and not (isinstance(energy, int | float) and 0 < energy <= 1):
        raise ValueError(f"energy must be a fraction in (0, 1], got {energy!r}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
        raise ValueError(f"n must be an integer >= 2 (masses of the chain), got {n!r}")
    cfg = _settings(bool(quick), int(seed), lam_t, None if energy is None else float(energy),
                    int(n))
    entries = chain_entries(cfg.n)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    system = mass_spring_chain(cfg.n, sparse=True)
    bar = Progress(2 + len(BANDS_HZ) * (2 + len(NOISE_LEVELS)), enabled=progress)
    figures: list[Path] = []
    rows: list[StudyRow] = []
    eigen_plots: list[dict[str, np.ndarray]] = []
    orders: list[int] = []
    lam_notes: list[str] = []

    bar.step("full model FRFs (Fig. 2)")
    f_full = np.geomspace(0.5, 160.0, cfg.full_points)
    H_full = frf_entries(system, 2 * np.pi * f_full, entries)
    figures.append(plot_full_frf(f_full, H_full, BANDS_HZ, out / "fig02_full_frf.png",
                                 n=system.n, entries=entries))

    for b, band in enumerate(BANDS_HZ, start=1):
        bar.step(f"band {b} ({band[0]:g}–{band[1]:g} Hz): simulate the n = {system.n} chain")
        t0 = time.perf_counter()
        sim = simulate_white_noise(system, band, cfg.dt, cfg.duration, 1.0,
                                   seed=_sub_seed(cfg.seed, b), histories=False)
        f_plot = _plot_window(band, cfg.plot_points)
        H_orig_lines = frf_entries(system, sim.omega, entries)
        H_orig_plot = frf_entries(system, 2 * np.pi * f_plot, entries)
        t_sim = time.perf_counter() - t0

        band_eigs: dict[str, np.ndarray] = {}
        curves: dict[float | None, tuple[list[Curve], list[Curve]]] = {}
        lam_label: dict[float | None, str] = {}
        m = 0
        for k, snr in enumerate(NOISE_LEVELS):
            bar.step(f"band {b}, {_noise_label(snr)}: POD, identification, FRFs")
            t0 = time.perf_counter()
            if snr is None:
                U_n = sim.response_spectrum
            else:
                U_n = _band_limited_noisy_spectrum(sim, snr, _sub_seed(cfg.seed, b, k))
            P = None  # let the previous basis go before the next is built
            P = pod_from_spectra(U_n, sim.n_samples)  # = POD of the history (Parseval)
            if snr is None:
                m = PAPER_ORDERS[b - 1] if cfg.energy is None else P.order_for_energy(cfg.energy)
                if 3 * m > 2 * sim.omega.size:  # 3m² unknowns, 2m equations per line
                    raise ValueError(
                        f"energy {cfg.energy:g} needs m = {m} POD modes in band {b}, but its "
                        f"{sim.omega.size} lines determine at most m = {2 * sim.omega.size // 3}; "
                        "ask for a smaller energy fraction (or drop --quick for more lines)"
                    )
            band_eigs[_noise_label(snr)] = P.eigenvalues
            R = P.basis(m)
            U, F = P.project(U_n, m), P.project(sim.force_spectrum, m)
            t_pod = time.perf_counter() - t0

            t0 = time.perf_counter()
            sigma = None
            if snr is not None:
                noise = P.project(U_n - sim.response_spectrum, m)
                sigma = float(np.sqrt(np.mean(np.abs(noise) ** 2)))
            result, lam_used, rule, notes = _identify_row(
                U, F, sim.omega, lam_t, sigma,
                out / f"lambda_band{b}_{_noise_slug(snr)}.png",
                f"λ for band {b} ({band[0]:g}–{band[1]:g} Hz), {_noise_label(snr)}, m = {m}",
            )
            if notes:
                lam_notes.append(f"band {b}, {_noise_label(snr)}: {notes}")
            if isinstance(lam_t, str):
                figures.append(out / f"lambda_band{b}_{_noise_slug(snr)}.png")
            t_id = time.perf_counter() - t0

            t0 = time.perf_counter()
            if snr is None or P.method == "snapshots":
                R_ref, refined = R, _refine_row(result, U, F, sim.omega)
            else:
                R_ref, refined = _refine_noisy_row(sim, P, U_n, snr, m, lam_used)
            t_ref = time.perf_counter() - t0

            t0 = time.perf_counter()
            projected = system.project(R)
            identified = result.system()
            err_id = _errors(frf_entries(identified, sim.omega, entries, basis=R), H_orig_lines)
            err_ref = _errors(frf_entries(refined.system(), sim.omega, entries, basis=R_ref),
                              H_orig_lines)
            err_proj = _errors(frf_entries(projected, sim.omega, entries, basis=R), H_orig_lines)
            w_plot = 2 * np.pi * f_plot
            lam_label[snr] = f"λ = {lam_used:.3g}" + ("" if rule == "fixed" else f" ({rule})")
            curves[snr] = (
                [Curve(f"original FRF, n = {system.n}", H_orig_plot, "original"),
                 Curve(f"POD-projected (RᵀMR, RᵀCR, RᵀKR), m = {m}",
                       frf_entries(projected, w_plot, entries, basis=R), "projected")],
                [Curve(f"identified POD-reduced (paper's estimator), m = {m}",
                       frf_entries(identified, w_plot, entries, basis=R), "identified"),
                 Curve(f"refined (output error), m = {m}",
                       frf_entries(refined.system(), w_plot, entries, basis=R_ref), "refined")],
            )
            t_frf = time.perf_counter() - t0

            rows.append(StudyRow(
                b, band[0], band[1], _noise_label(snr), math.nan if snr is None else snr,
                m, sim.omega.size, float(P.energy_fraction[m - 1]), *result.symmetry_defect(),
                *err_id, *err_proj, *err_ref, modal_parameters(refined).stable,
                int(refined.info["refinement"]["steps_total"]),
                refined.info["refinement"]["modes_in_band"], lam_used, rule,
                t_sim if snr is None else math.nan, t_pod, t_id, t_frf, t_ref,
            ))
        eigen_plots.append(band_eigs)
        orders.append(m)

        bar.step(f"band {b}: figures")
        label = f"band {b} ({band[0]:g}–{band[1]:g} Hz)"
        base, ident = curves[None]
        figures.append(plot_frf_comparison(
            f_plot, base, out / _figure_name(3 + b, b, "pod_reduced"), band_hz=band,
            title=f"Fig. {3 + b} — original and POD-reduced FRFs, {label}", entries=entries,
        ))
        for k, snr in enumerate(NOISE_LEVELS):
            base, ident = curves[snr]
            number = 7 + 4 * k + b
            figures.append(plot_frf_comparison(
                f_plot, base + ident,
                out / _figure_name(number, b, f"identified_{_noise_slug(snr)}"), band_hz=band,
                title=f"Fig. {number} — original and identified POD-reduced FRFs, {label}, "
                f"{_noise_label(snr)}, {lam_label[snr]}", entries=entries,
            ))

    bar.step("POD eigenvalues (Fig. 3) and tables")
    figures.insert(1, plot_pod_eigenvalues(eigen_plots, BANDS_HZ, orders,
                                           out / "fig03_pod_eigenvalues.png"))
    csv_path = _write_csv(rows, out / "results.csv")
    elapsed = time.perf_counter() - t_start
    md_path = _write_markdown(rows, cfg, elapsed, out / "results.md", lam_notes)
    bar.close()
    return PaperStudy(out, tuple(rows), tuple(figures), csv_path, md_path, cfg, elapsed)


def _write_csv(rows: Sequence[StudyRow], path: Path) -> Path:
    names = [f.name for f in fields(StudyRow)]
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=names)
        writer.writeheader()
        for r in rows:
            writer.writerow({k: ("" if isinstance(v, float) and math.isnan(v) else v)
                             for k, v in asdict(r).items()})
    return path


def _write_markdown(rows: Sequence[StudyRow], cfg: StudySettings, elapsed: float,
                    path: Path, lam_notes: Sequence[str] = ()) -> Path:
    if cfg.energy is None:
        orders = "the paper's m = " + ", ".join(map(str, PAPER_ORDERS))
    else:
        orders = f"smallest m reaching energy fraction {cfg.energy:g} (noise-free response)"
    head = [
        "# Section 6 of Khalil, Adhikari & Sarkar (2007), reproduced by `podid-rs paper`",
        "",
        f"{cfg.n}-DOF chain, unit-variance band-limited white noise on every DOF, "
        f"{cfg.duration:g} s record at dt = {cfg.dt * 1e3:g} ms "
        f"(lines {cfg.line_spacing_hz:g} Hz apart){', quick mode' if cfg.quick else ''}; "
        f"{orders}; λ_M, λ_C, λ_K = {_lam_text(cfg.lam)}; seed {cfg.seed}; "
        f"total run time {elapsed:.1f} s.",
        "",
        "- **m**: retained POD modes; **energy**: fraction of the response energy they "
        "capture (eq. 43), of that row's (noisy) response.",
        "- **sym M / C / K**: ‖X − Xᵀ‖/‖X‖ of the identified matrices (0 = symmetric).",
        "- **identified** / **refined** / **projected**: |20 log10(|H_model| / "
        "|H_original|)| in dB over the in-band frequency lines, median / 95th percentile, "
        "for the paper's estimator (eq. 49), for it refined to the least output error "
        "(M, C, K positive definite; relative, then uniform weights, the maximum-likelihood "
        "fit for white noise on the responses; † marks a refined model that is not "
        "stable; on noisy rows identified and refined on the noise-corrected POD basis — "
        "the correlation less the noise variance the SNR implies) and for the "
        "POD-projected model (RᵀMR, RᵀCR, RᵀKR) on the paper's basis.",
        "- **λ**: the common λ used, and the rule that chose it (eq. 40, §4.2).",
        "- **time**: seconds for simulate (shared by a band's rows) / POD / identify / "
        "refine / FRFs.",
        "",
        "| band | Hz | noise | m | lines | energy | λ | sym M / C / K "
        "| identified {0} | identified {1} | refined {0} | refined {1} | projected {0} "
        "| projected {1} | time (s) |".format(
            *(f"H({i},{j})" for i, j in chain_entries(cfg.n))),
        "|---:|:---|:---|---:|---:|---:|:---|:---|---:|---:|---:|---:|---:|---:|:---|",
    ]
    body = []
    for r in rows:
        t_sim = "—" if math.isnan(r.t_simulate_s) else f"{r.t_simulate_s:.1f}"
        dagger = "" if r.refined_stable else " †"
        body.append(
            f"| {r.band} | {_band_text(r)} | {r.noise} | {r.m} | {r.n_lines} | {r.energy:.4f} "
            f"| {r.lam:.3g}{'' if r.lam_rule == 'fixed' else f' ({r.lam_rule})'} "
            f"| {r.sym_M:.1e} / {r.sym_C:.1e} / {r.sym_K:.1e} "
            f"| {r.id_h50_50_median_db:.2f} / {r.id_h50_50_p95_db:.1f} "
            f"| {r.id_h60_40_median_db:.2f} / {r.id_h60_40_p95_db:.1f} "
            f"| {r.refined_h50_50_median_db:.2f} / {r.refined_h50_50_p95_db:.1f}{dagger} "
            f"| {r.refined_h60_40_median_db:.2f} / {r.refined_h60_40_p95_db:.1f}{dagger} "
            f"| {r.proj_h50_50_median_db:.2f} / {r.proj_h50_50_p95_db:.1f} "
            f"| {r.proj_h60_40_median_db:.2f} / {r.proj_h60_40_p95_db:.1f} "
            f"| {t_sim} / {r.t_pod_s:.2f} / {r.t_identify_s:.3f} / {r.t_refine_s:.2f} / "
            f"{r.t_frf_s:.2f} |"
        )
    tail = ["", "Warnings from the λ rules:", ""] + [f"- {n}" for n in lam_notes]
    truth = modal_parameters(mass_spring_chain(cfg.n))
    modes = ["", f"## In-band modes of the refined models, with {100 * LEVEL:g} % intervals", "",
             "Natural frequency ± the half-width of its interval, damping ratio likewise, from "
             "the refined model's covariance (the noise estimated from the residuals). The "
             "reduced model of order m is not the chain: its modes approximate the chain's in "
             "the band, and the intervals say how well the data fix the model's own modes, not "
             "how near they are to the chain's.", ""]
    for b, band in enumerate(BANDS_HZ, start=1):
        f = truth.frequencies_hz
        inside = (f >= band[0]) & (f <= band[1])
        modes.append(f"- band {b} ({band[0]:g}–{band[1]:g} Hz), the chain's modes: "
                     + ("; ".join(f"{f[k]:.4g} Hz, ζ {100 * truth.damping_ratios[k]:.3g} %"
                                  for k in np.flatnonzero(inside)) or "none"))
        for r in rows:
            if r.band == b:
                modes.append(f"  - {r.noise}, m = {r.m}: {r.refined_modes}")
    path.write_text("\n".join(head + body + (tail if lam_notes else []) + modes) + "\n",
                    encoding="utf-8")
    return path
