"""The reduced order m on measured data, chosen by what fits (docs/design.md §9).

The paper picks m by the energy the POD modes capture (eq. 43). On a real test that
says little about the model: it is the frequency response the model reproduces
that matters. :func:`sweep_orders` fits output-error models
(:func:`podid_rs.identification.refinement.refine`) of order m = 1, 2, … on the first m POD modes
and scores each on frequency lines it was not fitted to:

* **continuation over orders** — the model of order m starts from the one of
  order m − 1 (the POD bases are nested), extended by one decoupled degree of
  freedom: the single mode that best fits the new coordinate's own data. Every
  order therefore starts from a model that already reproduces what the previous
  one did, which is what lets the refinement reach good models on wide bands,
  where a start from the paper's estimator stalls in poor local minima. More
  starts are tried beside it — the best earlier order (by its training error)
  extended the same way, when it is not the previous one (an order that went astray
  does not drag the next ones with it); one mode added at the largest peak of the
  previous model's residual; the paper's estimator made physical (which wins on clean
  data) — each for ``TRIAL_ITER`` steps, and the best continues;
* **the parametrisation's curvature** — every refinement here runs with
  ``curvature=True``: on measured data the optimum puts C at the edge of positive
  semidefiniteness, where Gauss–Newton alone crawls (the beam: 0.82 → 0.39 dB at
  50–300 Hz, 0.94 → 0.58 dB at 20–800 Hz, ``benches/bench_measured.py``);
* **held-out lines** — every ``holdout``-th line is left out of the fit; the
  median |dB| error of the model's FRFs on the measured DOFs over those lines is
  the order's score. A model that fits noise or puts a spurious resonance between
  the lines it was fitted to pays on the held-out ones;
* **latent coordinates against a converged fit** — past the measured DOFs every order
  adds a latent coordinate (:mod:`~podid_rs.identification.latent`); before the first,
  the last observed order is run to convergence, from its modal start where that ends
  lower (:func:`_converged`), and a latent order counts only where it lowers the best
  held-out error by ``PROGRESS_STEP`` (:func:`counted_orders`). Weighed against an
  unconverged fit, latent orders gained a few per cent each by their extra steps alone;
* **the choice** — the counted order with the lowest held-out error (``tolerance`` > 0
  takes the smallest order within that fraction of it instead); the sweep stops
  once ``patience`` (10) orders in a row have not improved the best held-out error
  by ``PROGRESS_STEP`` (3 %): past that point more orders buy little and cost much
  (O(m⁴) per step). On the beam at 20–800 Hz a 2 % tolerance chose m = 20 (1.61 dB
  after the final fit) where the best held-out order, m = 26, gave 1.48 dB.

The chosen order is then refitted on every line, starting from its held-out fit.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .._arrays import as_omega
from ..physical import modal_parameters
from ..pod import PODResult
from ..systems import SecondOrderSystem
from .estimator import identify
from .holes import check_measured
from .latent import free_parameters, latent_starts, observation_matrix
from .lines import SWEEP_LINES, informative_lines
from .modal_start import modal_start
from .refinement import StartWarning, db_errors, refine
from .result import ConvergenceWarning, IdentificationResult

#: held-out lines: every HOLDOUT-th line (starting at the middle of the first group)
HOLDOUT = 4
#: orders within this fraction of the best held-out error count as equally good (0: the best)
TOLERANCE = 0.0
#: the sweep stops after PATIENCE orders without a PROGRESS_STEP better held-out error
PATIENCE = 10
PROGRESS_STEP = 0.03
#: past the measured DOFs the sweep stops sooner: each latent order costs more than the
#: last, and at the data's noise floor they only fit noise (on a 46 750-line test, ten
#: latent orders past the last 3 % gain took 58 of the sweep's 64 s and moved the
#: held-out error from 0.072 to 0.070 dB)
LATENT_PATIENCE = 6
#: … and after LATENT_FLAT latent orders in a row that lower not even the training error by
#: a third of PROGRESS_STEP: the latent coordinates have nothing left to fit (on the
#: high-resolution case each latent order past a converged m = 9 moved it by under 1 %; on
#: the beam seen at three points the held-out error stalled for four latent orders while the
#: training error fell 1–4 % per order, then fell from 0.40 to 0.22 dB)
LATENT_FLAT = 2
#: Levenberg–Marquardt steps per order in the sweep, and for the last observed order run
#: to convergence before the latent ones (the high-resolution case of
#: benches/bench_measured.py ends it by the cost test in 217–300 steps; the beam at
#: 50–300 Hz, m = 30, reaches the cap)
SWEEP_MAX_ITER = 40
CONVERGE_MAX_ITER = 500
#: … and per pass of the final fit, whose complex pass takes the geodesic acceleration:
#: with it the beam's passes end by the cost test after 888 steps (m = 35, 50–300 Hz) and
#: 639 (m = 37, 20–800 Hz), where the plain step needed 1 912 and 845 to lower costs
#: (0.602 against 0.589, 7.61 against 7.20; median error 0.188 / 0.400 dB against
#: 0.183 / 0.383)
FINAL_MAX_ITER = 1500
#: steps of the final fit's log-magnitude pass before it is judged: it goes on only where
#: they lowered the median error over every line (the high-resolution case of
#: benches/bench_measured.py: 0.116 → 0.164 dB after 25 steps, 0.159 at its end after 192;
#: the beam's driving point at 50–300 Hz: 0.288 → 0.222 dB, then 0.159 at its end)
LOG_MAGNITUDE_PROBE = 25
#: largest order tried by default
DEFAULT_M_MAX = 40
#: steps every start of an order gets before the best one takes the rest of the budget
TRIAL_ITER = 10


@dataclass(frozen=True)
class OrderFit:
    """One order of the sweep: its refined model (fitted on the training lines) and scores.

    Attributes
    ----------
    m : int
        The order.
    model : IdentificationResult
        The refined model of order m, fitted on the training lines.
    train_db, test_db : float
        Median |20 log10(|H_model|/|H_measured|)| over the training / held-out lines
        and every measured DOF and input (physical coordinates, R H_m Rᵀ).
    start : str
        Which start won (``"continuation"``, ``"residual peak"``, ``"paper
        estimator"``, ``"latent DOF at … Hz"``, …).
    stable : bool
        Whether every mode has Re λ < 0.
    seconds : float
        Wall time of the order.
    observed : int
        How many of the m coordinates are POD coordinates; the other m − observed
        (``latent``) are latent coordinates (:mod:`podid_rs.identification.latent`).
    """

    m: int
    model: IdentificationResult
    train_db: float
    test_db: float
    start: str
    stable: bool
    seconds: float
    observed: int

    @property
    def latent(self) -> int:
        """Latent coordinates of the order: m − observed."""
        return self.m - self.observed


@dataclass(frozen=True)
class OrderSweep:
    """What :func:`sweep_orders` tried and chose.

    Attributes
    ----------
    fits : tuple of OrderFit
        Every order fitted, ascending.
    chosen : int
        The chosen order m.
    reason : str
        Why, in words.
    test_lines : numpy.ndarray of bool, (s,)
        The held-out lines (a mask over the data's lines).
    lines : numpy.ndarray of bool, (s,)
        The lines the sweep used, held-out ones included (every line, unless the data
        had more than ``sweep_lines``: :func:`~.lines.informative_lines`).
    """

    fits: tuple[OrderFit, ...]
    chosen: int
    reason: str
    test_lines: np.ndarray = field(repr=False)
    lines: np.ndarray = field(repr=False)

    def fit(self, m: int) -> OrderFit:
        """The fit of one order.

        Parameters
        ----------
        m : int
            The order.

        Returns
        -------
        OrderFit
            Its model and scores.

        Raises
        ------
        KeyError
            When order m was not fitted.
        """
        for f in self.fits:
            if f.m == m:
                return f
        raise KeyError(f"order {m} was not fitted (orders {[f.m for f in self.fits]})")

    def basis(self, m: int, pod_result: PODResult) -> np.ndarray:
        """The observation matrix of order m: its POD modes, then a zero column per
        latent coordinate.

        Parameters
        ----------
        m : int
            An order the sweep fitted.
        pod_result : PODResult
            The POD the sweep was given.

        Returns
        -------
        numpy.ndarray
            ``(n, m)``: ``[R_p, 0]`` with R_p the first ``fit(m).observed`` POD modes.

        Raises
        ------
        KeyError
            If order m was not fitted.
        """
        return observation_matrix(pod_result.basis(self.fit(m).observed), m)

    def table(self) -> str:
        """The sweep as a Markdown table.

        Returns
        -------
        str
            One row per order (held-out and training median dB, start, stability, time),
            the chosen one marked.
        """
        lines = [
            "| m | latent DOFs | held-out median dB | training median dB | start | stable "
            "| seconds |",
            "|---:|---:|---:|---:|:---|:---|---:|",
        ]
        for f in self.fits:
            mark = " **(chosen)**" if f.m == self.chosen else ""
            lines.append(
                f"| {f.m}{mark} | {f.latent} | {f.test_db:.3f} | {f.train_db:.3f} | {f.start} "
                f"| {'yes' if f.stable else 'no'} | {f.seconds:.2f} |"
            )
        return "\n".join(lines) + "\n"


def _check_forces(U_n: np.ndarray, F_n: np.ndarray) -> None:
    """Refuse forces whose shape is not the responses' ``(s, n, p)``: every step pairs
    them line by line, DOF by DOF and load case by load case (as :func:`refine` does)."""
    if np.shape(F_n) != np.shape(U_n):
        raise ValueError(f"F_n must have the shape of U_n {np.shape(U_n)}, got {np.shape(F_n)}")


def _column_weights(U_n: np.ndarray) -> np.ndarray:
    """Relative weights per (line, load case): 1/‖U‖ over the measured DOFs (0 where ‖U‖ = 0)."""
    norms = np.linalg.norm(U_n, axis=1)  # (s, p)
    w = np.zeros_like(norms)
    w[norms > 0] = 1.0 / norms[norms > 0]
    return w


def _decoupled_mode(
    U: np.ndarray, F: np.ndarray, omega: np.ndarray, w: np.ndarray
) -> tuple[float, float, float] | None:
    """The single mode (μ, γ, κ) that best fits the last reduced coordinate on its own.

    Candidate natural frequencies on a log grid from a third of the lowest line to
    three times the highest (so that a mass- or stiffness-like residual term can be
    represented too), damping ratios 0.3 % and 2 %; for each, the modal mass by
    linear least squares. None when no candidate fits with a positive mass.
    """
    u, f = U[:, -1, :], F[:, -1, :]
    w2 = w**2
    best = None
    for wc in np.geomspace(omega[0] / 3, omega[-1] * 3, 60):
        for zeta in (0.003, 0.02):
            g = f / (wc**2 - omega**2 + 2j * zeta * wc * omega)[:, None]  # response per 1/μ
            num = float(np.sum(w2 * np.real(np.conj(g) * u)))
            den = float(np.sum(w2 * np.abs(g) ** 2))
            if den <= 0 or num <= 0:
                continue
            a = num / den
            cost = float(np.sum(w2 * np.abs(a * g - u) ** 2))
            if best is None or cost < best[0]:
                best = (cost, 1.0 / a, wc, zeta)
    if best is None:
        return None
    _, mu, wc, zeta = best
    return mu, 2 * zeta * wc * mu, wc**2 * mu


def _extend(model: tuple[np.ndarray, ...] | None, dof: tuple[float, float, float]):
    """(M, C, K) of order m − 1 with one decoupled degree of freedom appended."""
    out = []
    for k, v in enumerate(dof):
        old = np.zeros((0, 0)) if model is None else model[k]
        n = old.shape[0]
        X = np.zeros((n + 1, n + 1))
        X[:n, :n] = old
        X[n, n] = v
        out.append(X)
    return tuple(out)


#: damping ratios tried for a mode added at a peak of the residual
_PEAK_ZETAS = (0.002, 0.005, 0.01, 0.03)
#: residual peaks tried per order
_PEAKS = 3


def _residual_modes(model, U, F, omega, w):
    """Starts of order m that add, to the model of order m − 1, one mode at a peak of
    its residual, with the residual's shape there — modal superposition written as a
    symmetric model of order m: x = T y, y the old coordinates and the new mode's,
    T = [[I; 0], φ], so M = T⁻ᵀ diag(M_old, μ) T⁻¹ (the same for C, K). The modal mass
    μ by linear least squares; candidates at the ``_PEAKS`` largest residual peaks
    and ``_PEAK_ZETAS``. Returns [(cost, (M, C, K))].
    """
    s, m, p = U.shape
    X = np.zeros_like(U)  # the old model's response, zero in the new coordinate
    X[:, : m - 1] = SecondOrderSystem(*model).response(omega, F[:, : m - 1])
    r = U - X
    w2 = w**2
    energy = np.einsum("sp,smp->s", w2, np.abs(r) ** 2)
    inner = np.flatnonzero((energy[1:-1] >= energy[:-2]) & (energy[1:-1] >= energy[2:])) + 1
    peaks = inner[np.argsort(energy[inner])[::-1][:_PEAKS]]
    out = []
    for i in peaks:
        lam, V = np.linalg.eigh(np.real(r[i] @ r[i].conj().T))
        phi = V[:, -1]
        if abs(phi[-1]) < 0.05:  # T must stay well conditioned
            phi[-1] = 0.05 if phi[-1] >= 0 else -0.05
            phi /= np.linalg.norm(phi)
        proj = np.einsum("m,smp->sp", phi, F)  # φᵀ f
        for zeta in _PEAK_ZETAS:
            wc = omega[i]
            d = wc**2 - omega**2 + 2j * zeta * wc * omega
            g = phi[None, :, None] * (proj / d[:, None])[:, None, :]  # (s, m, p) per 1/μ
            num = float(np.sum(w2[:, None, :] * np.real(np.conj(g) * r)))
            den = float(np.sum(w2[:, None, :] * np.abs(g) ** 2))
            if den <= 0 or num <= 0:
                continue
            a = num / den
            cost = float(np.sum(w2[:, None, :] * np.abs(a * g - r) ** 2))
            T = np.eye(m)
            T[:, -1] = phi
            Ti = np.linalg.inv(T)
            mu = 1.0 / a
            dof = (mu, 2 * zeta * wc * mu, wc**2 * mu)
            mats = [Ti.T @ Y @ Ti for Y in _extend(model, dof)]
            out.append((cost, tuple(0.5 * (Y + Y.T) for Y in mats)))
    return out


def _median_db(model: IdentificationResult, R: np.ndarray, F: np.ndarray, omega, U_n, mask,
               measured=None):
    X = model.system().response(omega[mask], F[mask])
    return float(np.median(db_errors(np.einsum("nm,smp->snp", R, X), U_n[mask], measured)))


def _on_dofs(model, R: np.ndarray, F_n, omega) -> np.ndarray:
    """The responses R x ``(s, n, p)`` on the measured DOFs of a fitted model or of a
    start ``(M, C, K)`` to the forces ``F_n`` on those DOFs."""
    system = model.system() if hasattr(model, "system") else SecondOrderSystem(*model)
    return np.einsum("nm,smp->snp", R, system.response(omega, np.einsum("nm,snp->smp", R, F_n)))


def _all_lines_db(model: IdentificationResult, R: np.ndarray, U_n, F_n, omega,
                  measured=None) -> tuple:
    """(median, 95th percentile) |dB| error of ``model`` over every line and measured entry."""
    e = db_errors(_on_dofs(model, R, F_n, omega), U_n, measured)
    return float(np.median(e)), float(np.percentile(e, 95))


def _relative_cost(model, R: np.ndarray, U_n, F_n, omega, measured=None) -> float:
    """The relative weighted output error Σ ‖x_c − u_c‖² / ‖u_c‖² over every line and
    load case c, on the measured entries: the cost the final fit's passes lower."""
    X = _on_dofs(model, R, F_n, omega)
    mask = np.ones(U_n.shape[1:], dtype=bool) if measured is None else measured
    diff = np.sum(np.abs(X - U_n) ** 2 * mask, axis=1)
    norm = np.sum(np.abs(U_n) ** 2 * mask, axis=1)
    return float(np.sum(diff[norm > 0] / norm[norm > 0]))


def _refine_quietly(start, U_n, F_n, omega, R, max_iter, threads, measured=None):
    """refine() on the measured DOFs with relative weights, its warnings silenced (the
    sweep reports what matters: the errors of every order)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StartWarning)
        warnings.simplefilter("ignore", ConvergenceWarning)
        return refine(start, U_n, F_n, omega, basis=R, weights="relative",
                      max_iter=max_iter, threads=threads, curvature=True, measured=measured)


def _observed_starts(order, previous, fits, Ut, Ft, wt, w):
    """Starts of an order whose new coordinate is the next POD mode (order ≤ the POD
    modes with energy): the previous model continued by one decoupled DOF, the best
    earlier order continued the same way, one mode at a residual peak, the paper's
    estimator. Returns [(name, start)]."""
    starts = []
    dof = _decoupled_mode(Ut, Ft, wt, w)
    if dof is not None:
        starts.append(("continuation", _extend(previous, dof)))
    if len(fits) > 1:
        # an order that went astray does not drag the next ones with it: the best
        # earlier order (on its training lines) is extended as well
        best = min(fits[:-1], key=lambda f: f.train_db)
        if best.train_db < fits[-1].train_db:
            model = (best.model.M, best.model.C, best.model.K)
            for j in range(best.m + 1, order + 1):
                extra = _decoupled_mode(Ut[:, :j], Ft[:, :j], wt, w)
                if extra is None:
                    break
                model = _extend(model, extra)
            else:
                starts.append((f"continuation from m = {best.m}", model))
    if previous is not None:
        peaks = _residual_modes(previous, Ut, Ft, wt, w)
        if peaks:
            starts.append(("residual peak", min(peaks, key=lambda c: c[0])[1]))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            starts.append(("paper estimator", identify(Ut, Ft, wt, symmetric=True)))
    except ValueError:
        pass
    return starts


def _converged(model, name: str, U_n, F_n, omega, R, threads, measured):
    """The fit of the last observed order run to convergence (``CONVERGE_MAX_ITER`` steps) —
    the fit the latent orders are weighed against.

    With ``SWEEP_MAX_ITER`` steps the observed order is not converged on a lightly damped
    test, and every latent order then gains a few per cent by its extra steps alone: on
    24 noise seeds of the high-resolution case of ``benches/bench_measured.py`` the sweep
    went to m = 10–28 on 18 (the median error against the noise-free FRFs up to 0.064 dB
    where m = 9 gave 0.010–0.012). The modal start (:mod:`~.modal_start`) is run to
    convergence first and kept where it ends below the sweep's fit; only otherwise is that
    fit run on. Judged by the starts' costs instead, the sweep's fit often won and ended in
    a poorer minimum (four seeds: 0.023–0.039 dB from the noise-free FRFs, against
    0.011–0.015 from the modal start). Returns (model, the start's name)."""
    rebuilt = modal_start(model, R, U_n, F_n, omega, measured)
    if rebuilt is not None:
        fit = _refine_quietly(rebuilt, U_n, F_n, omega, R, CONVERGE_MAX_ITER, threads, measured)
        if fit.info["refinement"]["cost"] <= model.info["refinement"]["cost"]:
            return fit, "modal start, to convergence"
    fit = _refine_quietly(model, U_n, F_n, omega, R, CONVERGE_MAX_ITER, threads, measured)
    return fit, f"{name}, to convergence"


def order_limit(lines: int, n: int, p: int, observed: int, entries: int | None = None) -> int:
    """The highest order m whose free parameters the data can determine.

    An order-m model with k = min(m, ``observed``) observed coordinates has
    :func:`~podid_rs.identification.latent.free_parameters` (3m(m+1)/2 less the gauge
    of its m − k latent coordinates); ``lines`` frequency lines of ``entries``
    measured responses (n·p: ``n`` measured DOFs in ``p`` load cases, less the holes)
    give 2·lines·entries real equations.

    Parameters
    ----------
    lines, n, p : int
        Frequency lines fitted, measured DOFs, load cases.
    observed : int
        POD coordinates available (the POD modes with energy, at most n).
    entries : int, optional
        The measured entries of the n × p grid (default n·p: no holes).

    Returns
    -------
    int
        The largest m with at most as many free parameters as equations (0 if none).
    """
    equations = 2 * lines * (n * p if entries is None else entries)
    m = 0
    while free_parameters(m + 1, min(m + 1, observed)) <= equations:
        m += 1
        if m >= 10 * DEFAULT_M_MAX:
            break
    return m


def counted_orders(fits: list[OrderFit] | tuple[OrderFit, ...]) -> list[OrderFit]:
    """The orders the choice weighs: every observed order, and a latent order only where
    it lowers the best held-out error of the orders counted before it by
    ``PROGRESS_STEP`` — a latent coordinate must pay its way; at the data's noise floor
    it fits noise (on the high-resolution case of ``benches/bench_measured.py`` four
    latent orders past a converged m = 9 each moved the held-out error by under 1 %).

    Parameters
    ----------
    fits : sequence of OrderFit
        The sweep's fits, ascending in m.

    Returns
    -------
    list of OrderFit
        Those counted, ascending.
    """
    counted: list[OrderFit] = []
    for f in fits:
        best = min((g.test_db for g in counted), default=np.inf)
        if not f.latent or f.test_db < best * (1 - PROGRESS_STEP):
            counted.append(f)
    return counted


def sweep_orders(
    U_n: np.ndarray,
    F_n: np.ndarray,
    omega: np.ndarray,
    pod_result: PODResult,
    *,
    m: int | None = None,
    m_max: int | None = None,
    holdout: int = HOLDOUT,
    tolerance: float = TOLERANCE,
    patience: int = PATIENCE,
    max_iter: int = SWEEP_MAX_ITER,
    progress: Callable[[int, OrderFit], object] | None = None,
    threads: int | None = None,
    sweep_lines: int | None = SWEEP_LINES,
    measured: np.ndarray | None = None,
) -> OrderSweep:
    """Fit output-error models of order 1, 2, … and choose m by held-out lines.

    Every ``holdout``-th line is left out of the fits (module docstring); order m
    starts from order m − 1 by continuation, and the sweep stops early after
    ``patience`` orders without progress (unless ``m`` is given). Order m ≤ k (k the
    POD modes with energy, at most n) is fitted on the first m POD modes; past k every
    order adds a latent coordinate (:mod:`podid_rs.identification.latent`), started at
    a peak of the previous order's residual.

    Parameters
    ----------
    U_n : array_like, complex, (s, n, p)
        The measured responses on the n DOFs.
    F_n : array_like, complex, (s, n, p)
        The forces on them, zero off the driven DOFs.
    omega : array_like, (s,)
        Angular frequencies (rad/s).
    pod_result : PODResult
        The POD of the responses: its first modes are the observed coordinates.
    m : int, optional
        The order to reach and choose; 1 ≤ m ≤ :func:`order_limit` (the data's
        equations bound the free parameters, latent coordinates included).
    m_max : int, optional
        Largest order tried without ``m`` (default 40, at most :func:`order_limit`).
    holdout : int
        Every ``holdout``-th line is held out, ≥ 2.
    tolerance : float
        Orders within this fraction of the best held-out error count as equally
        good: the smallest of them is chosen (0: the best).
    patience : int
        Orders in a row without a 3 % better held-out error before the sweep stops.
    max_iter : int
        Levenberg–Marquardt steps per order.
    progress : callable, optional
        Called as ``progress(m, fit)`` after every order.
    threads : int, optional
        Worker threads of the refinement (None = all cores).
    sweep_lines : int or None
        With more lines than this, the sweep fits and scores the lines that carry the
        data's information (:func:`~.lines.informative_lines`; default
        ``SWEEP_LINES`` = 1000); None: every line.
    measured : array_like of bool, (n, p), optional
        The entries that were measured (:attr:`podid_rs.MeasuredData.measured`); the
        others (zeros in ``U_n``) weigh nothing in the fits, the starts and the
        scores (:mod:`~podid_rs.identification.holes`). Default: every entry.

    Returns
    -------
    OrderSweep
        Every order's fit and scores, the chosen m and why.

    Raises
    ------
    ValueError
        For forces ``F_n`` not of the shape of ``U_n``, lines (``omega``) not positive
        or not one per line of ``U_n``, ``holdout``
        < 2, ``m_max`` or ``max_iter`` not a positive integer, too few
        lines to hold some out, ``m`` out of range (an
        order with more free parameters than the data's equations: the message names
        the limit), or when no order could be fitted.
    """
    _check_forces(U_n, F_n)
    s, n, p = U_n.shape
    omega = as_omega(omega)
    if omega.size != s:
        raise ValueError(f"omega must hold the {s} lines of U_n, got {omega.size}")
    measured = check_measured(measured, n, p)
    if holdout < 2:
        raise ValueError(
            f"holdout must be at least 2 (every holdout-th line is left out), got {holdout}"
        )
    for name, value in (("m_max", m_max), ("max_iter", max_iter)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | np.integer)
                                  or value < 1):
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    used = np.ones(s, dtype=bool) if sweep_lines is None else informative_lines(U_n, sweep_lines)
    picked = np.flatnonzero(used)
    test = np.zeros(s, dtype=bool)
    test[picked[(np.arange(picked.size) % holdout) == holdout // 2]] = True
    train = used & ~test
    if train.sum() < 2 or test.sum() < 1:
        raise ValueError(f"{s} lines are too few to hold one line in {holdout} out")
    observed = min(int(np.sum(pod_result.eigenvalues > 0)), n)
    entries = n * p if measured is None else int(measured.sum())
    limit = order_limit(int(train.sum()), n, p, observed, entries)
    if m is not None:
        if not 1 <= m <= limit:
            k = min(m, observed)
            grid = (f"{n} measured DOF(s) × {p} load case(s)" if measured is None else
                    f"{entries} measured entries of the {n} × {p} grid")
            raise ValueError(
                f"m must be in [1, {limit}]: an order-{m} model with {k} observed "
                f"(POD) and {m - k} latent coordinates has {free_parameters(m, k)} free "
                f"parameters, more than the {2 * int(train.sum()) * entries} real equations "
                f"of the {int(train.sum())} fitted lines × {grid}, got m = {m}"
                if m > limit
                else f"m must be in [1, {limit}], got {m}"
            )
        m_max = m
    elif m_max is None:
        m_max = min(limit, DEFAULT_M_MAX)
    else:
        m_max = min(m_max, limit)
    w_all = _column_weights(U_n)
    w = w_all[train]
    fits: list[OrderFit] = []
    previous = None
    filled = U_n
    best_test, since_best, flat = np.inf, 0, 0
    stop = ""  # why the sweep stopped before m_max, for the reason
    for order in range(1, m_max + 1):
        t0 = time.perf_counter()
        k = min(order, observed)
        R = observation_matrix(pod_result.basis(k), order)
        # the reduced data the starts see: Rᵀ U_n, its holes (if any) filled with the
        # previous order's prediction — the fit itself never sees the holes
        U = np.einsum("nm,snp->smp", R, U_n if measured is None else filled)
        F = np.einsum("nm,snp->smp", R, F_n)
        Ut, Ft, wt = U[train], F[train], omega[train]
        if order <= observed:
            starts = _observed_starts(order, previous, fits, Ut, Ft, wt, w)
        else:
            R_previous = observation_matrix(pod_result.basis(k), order - 1)
            starts = [(name, start) for _, start, name in latent_starts(
                previous, U_n[train], F_n[train], wt, R_previous, w, measured)]
        # every start gets a few steps, the best of them the rest of the budget
        trials = []
        for name, start in starts:
            try:
                model = _refine_quietly(
                    start, U_n[train], F_n[train], wt, R, min(TRIAL_ITER, max_iter), threads,
                    measured,
                )
            except ValueError:
                continue  # a start that cannot be made physical, or with a pole on a line
            trials.append((model.info["refinement"]["cost"], name, model))
        if not trials:
            stop = f"; order {order} could not be started (no start of it could be fitted)"
            break
        _, name, model = min(trials, key=lambda t: t[0])
        if max_iter > TRIAL_ITER and not model.info["refinement"]["converged"]:
            model = _refine_quietly(
                model, U_n[train], F_n[train], wt, R, max_iter - TRIAL_ITER, threads, measured
            )
        if order == observed < m_max:
            # latent coordinates are weighed against a converged fit of the observed ones
            model, name = _converged(model, name, U_n[train], F_n[train], wt, R, threads,
                                     measured)
        fit = OrderFit(
            m=order,
            model=model,
            train_db=_median_db(model, R, F, omega, U_n, train, measured),
            test_db=_median_db(model, R, F, omega, U_n, test, measured),
            start=name,
            stable=modal_parameters(model).stable,
            seconds=time.perf_counter() - t0,
            observed=k,
        )
        fits.append(fit)
        previous = (model.M, model.C, model.K)
        if measured is not None:
            X = model.system().response(omega, np.einsum("nm,snp->smp", R, F_n))
            filled = np.where(measured, U_n, np.einsum("nm,smp->snp", R, X))
        if progress is not None:
            progress(order, fit)
        flat = (flat + 1 if order > observed and len(fits) > 1
                and fit.train_db > (1 - PROGRESS_STEP / 3) * fits[-2].train_db else 0)
        if fit.test_db < best_test * (1 - PROGRESS_STEP):
            best_test, since_best = fit.test_db, 0
        else:
            best_test = min(best_test, fit.test_db)
            since_best += 1
            if m is None and since_best >= (patience if order <= observed
                                            else min(patience, LATENT_PATIENCE)):
                stop = (f"; the sweep stopped after {since_best} orders without a "
                        f"{100 * PROGRESS_STEP:g} % gain")
                break
            if m is None and flat >= LATENT_FLAT:
                stop = (f"; the sweep stopped after {flat} latent orders that lowered the "
                        f"training error by less than {100 * PROGRESS_STEP / 3:g} % each")
                break
    if not fits:
        raise ValueError("no order could be fitted: the data give no physical start")
    counted = counted_orders(fits)
    best_fit = min(counted, key=lambda f: f.test_db)
    if m is not None:
        chosen = fits[-1].m
        reason = (
            f"m = {chosen} as asked"
            if chosen == m
            else f"m = {chosen}: order {chosen + 1} could not be started (m = {m} was asked; "
            "the model of order "
            f"{chosen} leaves no residual a new degree of freedom can fit)"
        )
    else:
        f = next(f for f in counted if f.test_db <= (1 + tolerance) * best_fit.test_db)
        chosen = f.m
        how = (
            "the lowest"
            if chosen == best_fit.m
            else f"within {100 * tolerance:g} % of the lowest ({best_fit.test_db:.2f} dB at "
            f"m = {best_fit.m})"
        )
        reason = (
            f"m = {chosen}: held-out median error {f.test_db:.2f} dB, {how} over "
            f"m = 1…{fits[-1].m}; one line in {holdout} held out"
            + ("" if picked.size == s else
               f" of the {picked.size} of {s} lines that carry the data's information")
            + ("" if len(counted) == len(fits) else
               f"; a latent order counts only where it lowers the best held-out error of the "
               f"smaller orders by {100 * PROGRESS_STEP:g} %")
            + stop
        )
    return OrderSweep(tuple(fits), chosen, reason, test, used)


def final_fit(
    sweep: OrderSweep,
    U_n: np.ndarray,
    F_n: np.ndarray,
    omega: np.ndarray,
    pod_result: PODResult,
    *,
    max_iter: int = FINAL_MAX_ITER,
    threads: int | None = None,
    progress: bool | Callable[[int, float], object] = False,
    log_magnitude: bool = True,
    every_line: bool = False,
    measured: np.ndarray | None = None,
) -> tuple[IdentificationResult, np.ndarray]:
    """The chosen order refitted on every line from its held-out fit.

    On a long test whose sweep used the informative lines (:attr:`OrderSweep.lines`)
    the passes fit those lines too — on a 46 750-line test the all-line refit
    changed the median by 4·10⁻⁵ dB for three times the time — and every decision
    below is taken on the median error over every line; ``every_line=True`` fits
    every line.

    The first pass starts from the held-out fit, or from the **modal start**
    (:mod:`podid_rs.identification.modal_start`: its poles in the band kept, one
    below and one above standing in for the modes outside, shapes fitted linearly)
    when that has the lower weighted cost on the lines fitted. On a structure with
    damping ratios of 10⁻⁴ the held-out fit held every in-band mode but stood in for
    the modes outside the band with damped poles inside it; from the modal start the
    median error against the noise-free FRFs went 0.17 → 0.013 dB
    (``benches/bench_measured.py``, the high-resolution case).

    Two passes, each kept only if it lowers the median |dB| error over every line:

    1. the complex output error with relative weights, each step with its geodesic
       acceleration (``refine(..., acceleration=True)``) — the relative weighted cost can
       fall by fixing a few lines that are far off (an anti-resonance or a narrow peak
       the order cannot hold) at the expense of the rest (measured on the beam at
       50–300 Hz, m = 24: cost 230 → 12.5 while the median went 0.74 → 0.94 dB);
    2. with ``log_magnitude``, the log-magnitude output error (``refine(...,
       objective="log-magnitude")``) from the better of the two: the dB error itself,
       every entry alike (the beam at 20–800 Hz: median 1.48 → 1.33 dB, 95th percentile
       8.7 → 6.2 dB). Its first ``LOG_MAGNITUDE_PROBE`` steps are judged: the pass goes
       on only where they lowered the median, and the better of the two ends counts. An
       optional pass: where its data cannot be fitted in log magnitude (``ValueError``)
       the better fit so far is kept and the reason says why.

    Parameters
    ----------
    sweep : OrderSweep
        The sweep whose ``chosen`` order is refitted.
    U_n, F_n, omega : array_like
        The data the sweep saw (as for :func:`sweep_orders`).
    pod_result : PODResult
        The POD the sweep used.
    max_iter : int
        Levenberg–Marquardt steps per pass.
    threads : int, optional
        Worker threads of the refinement (None = all cores).
    progress : bool or callable
        As for :func:`podid_rs.refine`.
    log_magnitude : bool
        Run the second, log-magnitude pass.
    every_line : bool
        Fit every line even where the sweep used the informative ones.
    measured : array_like of bool, (n, p), optional
        The entries that were measured, as for :func:`sweep_orders`: the others weigh
        nothing in the passes and in the medians that decide between them.

    Returns
    -------
    model : IdentificationResult
        The refined model; ``info["refinement"]["final_refit"]`` says what was kept
        and why, and each pass's errors before and after, steps and why it stopped
        (``passes``).
    R : numpy.ndarray, (n, m)
        Its basis, the first m POD modes.

    Raises
    ------
    ValueError
        For forces ``F_n`` not of the shape of ``U_n``; as for :func:`podid_rs.refine`
        (e.g. data that do not match the sweep's).
    """
    _check_forces(U_n, F_n)
    m = sweep.chosen
    measured = check_measured(measured, *U_n.shape[1:])
    R = sweep.basis(m, pod_result)
    start = sweep.fit(m).model
    # the lines the sweep used: every line, or the informative ones of a long test
    lines = np.ones(omega.shape[0], dtype=bool) if every_line else sweep.lines
    thinned = not np.all(lines)
    judged: dict[int, tuple] = {}  # id → (model, its error over every line): each once

    def all_lines_db(model: IdentificationResult) -> tuple:
        if id(model) not in judged:
            judged[id(model)] = (model, _all_lines_db(model, R, U_n, F_n, omega, measured))
        return judged[id(model)][1]

    def refit(model, objective: str, judged_against=None, steps: int = max_iter
              ) -> IdentificationResult:
        """A pass of up to ``steps`` steps from ``model``, its errors before (of
        ``judged_against``, default the start) and after over every line."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StartWarning)
            warnings.simplefilter("ignore", ConvergenceWarning)  # the summary states the stop
            fit = refine(
                model, U_n[lines], F_n[lines], omega[lines], basis=R, weights="relative",
                objective=objective, max_iter=steps, threads=threads, progress=progress,
                curvature=True, measured=measured, acceleration=True,
            )  # fmt: skip
        if thinned:  # judge by every line, not the ones fitted
            ref = fit.info["refinement"]
            ref["db_before"] = all_lines_db(model if judged_against is None else judged_against)
            ref["db_after"] = all_lines_db(fit)
        return fit

    # the complex refit starts from the held-out fit or from the modal start built on
    # its in-band poles, whichever has the lower weighted cost on the lines fitted
    first, start_note = start, ""
    rebuilt = modal_start(start, R, U_n[lines], F_n[lines], omega[lines], measured)
    if rebuilt is not None:
        held_cost = _relative_cost(start, R, U_n[lines], F_n[lines], omega[lines], measured)
        modal_cost = _relative_cost(rebuilt, R, U_n[lines], F_n[lines], omega[lines], measured)
        if modal_cost < held_cost:
            first = rebuilt
            start_note = (f"; the complex refit started from the modal start (the held-out "
                          f"fit's poles in the band, shapes by linear least squares: weighted "
                          f"cost {modal_cost:.4g} against {held_cost:.4g})")
    # judged against the held-out fit, not the rebuilt start
    model = refit(first, "complex", judged_against=start)
    ref = model.info["refinement"]
    if first is not start and not thinned:
        ref["db_before"] = all_lines_db(start)
    steps = [("complex refit", ref["db_before"], ref["db_after"], model.iterations, ref["stop"])]
    if ref["db_after"][0] <= ref["db_before"][0]:
        best, best_db = model, ref["db_after"]
        why = (
            f"the complex refit lowered the median error over every line "
            f"({ref['db_before'][0]:.2f} → {ref['db_after'][0]:.2f} dB)"
        )
    else:
        best, best_db = start, ref["db_before"]
        why = (
            f"the complex refit on every line lowered the weighted cost "
            f"({ref['cost_start']:.4g} → {ref['cost']:.4g}) but raised the median error over "
            f"every line ({ref['db_before'][0]:.2f} → {ref['db_after'][0]:.2f} dB)"
        )
    kept_name = "complex refit" if best is model else "held-out fit"
    logm = None
    log_steps, probe_note = 0, ""
    if log_magnitude:
        try:
            # a first LOG_MAGNITUDE_PROBE steps, judged; the rest only where they helped
            logm = refit(best, "log-magnitude", steps=min(LOG_MAGNITUDE_PROBE, max_iter))
            log_steps = logm.iterations
            probe_db = logm.info["refinement"]["db_after"]
            if probe_db[0] >= best_db[0]:
                probe_note = f" in its first {log_steps} steps, and stopped there"
            elif not logm.info["refinement"]["converged"] and max_iter > log_steps:
                more = refit(logm, "log-magnitude", judged_against=best,
                             steps=max_iter - log_steps)
                log_steps += more.iterations
                if more.info["refinement"]["db_after"][0] <= probe_db[0]:
                    logm = replace(more, iterations=log_steps)  # the pass's steps, both parts
        except ValueError as exc:  # an optional pass: the better fit so far stands
            why += f"; the log-magnitude refit could not run ({exc})"
    if logm is not None:
        lref = logm.info["refinement"]
        steps.append(("log-magnitude refit", tuple(best_db), lref["db_after"], log_steps,
                      lref["stop"]))
        if lref["db_after"][0] < best_db[0]:
            why = (
                f"the log-magnitude refit lowered the median error over every line "
                f"({best_db[0]:.2f} → {lref['db_after'][0]:.2f} dB; 95th percentile "
                f"{best_db[1]:.2f} → {lref['db_after'][1]:.2f}) from the {kept_name}"
            )
            best, best_db, kept_name = logm, lref["db_after"], "log-magnitude refit"
        else:
            why += (
                f"; the log-magnitude refit did not lower it ({best_db[0]:.2f} → "
                f"{lref['db_after'][0]:.2f} dB){probe_note}"
            )
    why += start_note
    if thinned:
        why += (f"; both passes fitted the {int(lines.sum())} informative lines of "
                f"{lines.size} (the median is over every line)")
    kept = {
        "kept": kept_name,
        "reason": why,
        "lines_fitted": int(lines.sum()),
        "db_all_lines": tuple(best_db),
        "passes": [
            {"pass": name, "db_before": tuple(b), "db_after": tuple(a), "iterations": it,
             "stop": stop}
            for name, b, a, it, stop in steps
        ],
    }
    info = {**best.info, "refinement": {**best.info["refinement"], "final_refit": kept}}
    return replace(best, info=info), R
