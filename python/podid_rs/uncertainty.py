"""How sure: confidence intervals on the modes, the FRFs and M, C, K of a refined model.

An output-error fit (:func:`podid_rs.refine`, :meth:`podid_rs.MeasuredData.fit`)
is linearised at its optimum: the covariance of M, C, K is the sandwich
N⁺ S N⁺ of :mod:`podid_rs.identification.covariance` (the Gauss–Newton matrix of
the fitted cost around the noise's), with the noise given per entry, from the
coherence and averages of H1 estimates, or estimated from the residuals; entries the
test did not measure (:attr:`podid_rs.MeasuredData.measured`) weigh nothing in it, as
in the fit. It is carried to what a user reads by first-order perturbation:

* eigenvalues of the quadratic problem (λ²M + λC + K)ψ = 0 (M, C, K symmetric):
  dλ = −ψᵀ(λ² dM + λ dC + dK)ψ / ψᵀ(2λM + C)ψ, and from it the natural frequency
  |λ|/2π and the damping ratio −Re λ/|λ|;
* mode shapes on the measured DOFs, R ψ scaled to largest entry 1 (as
  :func:`podid_rs.mode_shapes`): dψ_j = Σ_{r≠j} ψ_r ψ_rᵀ dD(λ_j) ψ_j / (a_r (λ_r − λ_j))
  over all 2m modes of the symmetric first-order form, a_r = ψ_rᵀ(2λ_rM + C)ψ_r,
  dD(λ) = λ² dM + λ dC + dK;
* the model's FRF on the measured DOFs R D(ω)⁻¹ Rᵀ: dH = −R D⁻¹ dD(iω) D⁻¹ Rᵀ, a band
  on |H| per line: |Ĥ| ± z σ of the magnitude, down to 0 where the confidence ellipse
  of Ĥ holds the origin;
* the entries of M, C, K in the basis they are given in — only when they are
  identifiable: with latent coordinates the matrices have a gauge and no entry has a
  variance (:mod:`podid_rs.identification.latent`).

Intervals are estimate ± z·σ at the chosen level, z from the normal distribution for a
given noise level and from Student's t with the residuals' degrees of freedom for an
estimated one. A quantity that depends on a direction the data do not determine has
NaN for its σ and ``determined`` False: it gets no interval rather than a huge one; so
does a mode whose interval would be wider than its value.
Checked by Monte Carlo in ``benches/bench_uncertainty.py``; docs/design.md §12.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.stats

from ._arrays import as_array, as_omega
from ._memory import release_free_memory
from .identification.covariance import (
    DenseCovariance,
    LinearisedFit,
    MatrixFreeCovariance,
    NoiseModel,
    Objective,
    check_variance,
    entry_weights,
    gauss_newton_matrix,
    h1_variance,
    residual_variance,
    sym_gradient,
)
from .identification.holes import check_measured
from .identification.latent import gauge_dimension, observation_matrix, observed_count
from .identification.order import OrderSweep
from .identification.result import IdentificationResult
from .measured import MeasuredData
from .systems import SecondOrderSystem

#: default confidence level
LEVEL = 0.95
#: ``solver="auto"`` forms N densely up to this order (3m(m+1)/2 = 2460 coordinates, as
#: the refinement's dense step) and solves with it matrix-free beyond
AUTO_DENSE_MAX_M = 40
#: gradient entries (lines × entries × parameters) of an FRF band formed at once: on the
#: dense path one pass over the covariance per block; on the matrix-free path (a pass over
#: the draws) fewer, their intermediates (about four times the gradients) beside the draws
#: kept being the band's peak (at m = 100, 200 lines: 0.224 GB with 1 << 19, the
#: refinement's 0.218)
FRF_BLOCK_ELEMENTS = 1 << 19
FRF_BLOCK_ELEMENTS_MATRIX_FREE = 1 << 17


def _check_level(level: object) -> float:
    if isinstance(level, bool) or not isinstance(level, int | float | np.floating):
        raise ValueError(f"level must be a number in (0, 1), got {level!r}")
    if not 0.0 < float(level) < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level!r}")
    return float(level)


@dataclass(frozen=True)
class ModeIntervals:
    """Natural frequencies, damping ratios (and mode shapes) with their intervals.

    Attributes
    ----------
    eigenvalues : numpy.ndarray, complex, (k,)
        One per mode, as :func:`podid_rs.modal_parameters` orders them.
    frequencies_hz, damping_ratios : numpy.ndarray, (k,)
        ``|λ|/2π`` and ``−Re λ/|λ|``.
    std_frequency_hz, std_damping : numpy.ndarray, (k,)
        Their standard deviations (NaN where not determined).
    level : float
        The confidence level of the intervals.
    z : float
        The interval's half-width in standard deviations.
    determined : numpy.ndarray of bool, (k,)
        False for a mode whose frequency or damping depends on what the data do not fix,
        or whose interval would be wider than the value itself (a frequency's reaching 0,
        a damping ratio's spanning more than critical damping).
    shapes : numpy.ndarray, complex, (n, k), or None
        The mode shapes on the measured DOFs, largest entry 1 (with ``shapes=True``).
    std_shapes_real, std_shapes_imag : numpy.ndarray, (n, k), or None
        Standard deviations of their real and imaginary parts (0 at the reference entry).
    why_undetermined : numpy.ndarray of str, (k,), or None
        Why a mode has no interval: ``""`` where it has one; ``"undetermined"`` (it
        depends on a direction the data do not fix: the dense path), ``"wider than the
        value"``, or ``"not converged"`` (a matrix-free solve did not reach its
        tolerance, with a :class:`~podid_rs.ConvergenceWarning`).
    frequency_intervals_hz, damping_intervals : numpy.ndarray, (k, 2)
        Lower and upper ends, estimate ± z·σ (NaN where not determined).
    """

    eigenvalues: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    std_frequency_hz: np.ndarray
    std_damping: np.ndarray
    level: float
    z: float
    determined: np.ndarray
    shapes: np.ndarray | None = None
    std_shapes_real: np.ndarray | None = None
    std_shapes_imag: np.ndarray | None = None
    why_undetermined: np.ndarray | None = None

    @property
    def frequency_intervals_hz(self) -> np.ndarray:
        """``(k, 2)``: estimate ∓ z·σ of each natural frequency."""
        h = self.z * self.std_frequency_hz
        return np.stack([self.frequencies_hz - h, self.frequencies_hz + h], axis=1)

    @property
    def damping_intervals(self) -> np.ndarray:
        """``(k, 2)``: estimate ∓ z·σ of each damping ratio."""
        h = self.z * self.std_damping
        return np.stack([self.damping_ratios - h, self.damping_ratios + h], axis=1)


@dataclass(frozen=True)
class FRFBand:
    """The model's FRF on the measured DOFs with a confidence band per line.

    Each value Ĥ has a 2 × 2 covariance Σ of its real and imaginary parts. The band on
    |H| is |Ĥ| ± z σ_r, σ_r the standard deviation of the magnitude, Re(H̄ δH)/|H|; it
    reaches down to 0 where the confidence ellipse (h − Ĥ)ᵀ Σ⁻¹ (h − Ĥ) ≤ z² holds the
    origin — an FRF below its own uncertainty, e.g. at an anti-resonance, whose
    magnitude the first-order σ_r does not bound from below.

    Attributes
    ----------
    omega : numpy.ndarray, (s,)
        The lines, rad/s.
    rows, cols : numpy.ndarray of int, (r,), (c,)
        The measured DOFs of the entries (response, force).
    values : numpy.ndarray, complex, (s, r, c)
        ``R D(ω)⁻¹ Rᵀ`` at those entries.
    std_real, std_imag, corr : numpy.ndarray, (s, r, c)
        Standard deviations of the real and imaginary parts and their correlation.
    std_db : numpy.ndarray, (s, r, c)
        Standard deviation of 20 log10 |H| (dB), linearised: meaningful where it is
        small (a few dB at most).
    level, z : float
        The confidence level and the half-width in standard deviations.
    lower, upper : numpy.ndarray, (s, r, c)
        The band on |H| (NaN where not determined).
    """

    omega: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    values: np.ndarray
    std_real: np.ndarray
    std_imag: np.ndarray
    corr: np.ndarray
    level: float
    z: float
    lower: np.ndarray
    upper: np.ndarray

    @property
    def std_db(self) -> np.ndarray:
        """Linearised standard deviation of 20 log10 |H| (dB)."""
        H = self.values
        a, b = H.real, H.imag
        var = (a**2 * self.std_real**2 + b**2 * self.std_imag**2
               + 2 * a * b * self.corr * self.std_real * self.std_imag)
        with np.errstate(divide="ignore", invalid="ignore"):
            return 20 / np.log(10) * np.sqrt(np.maximum(var, 0.0)) / np.abs(H) ** 2


def _magnitude_band(
    H: np.ndarray, vr: np.ndarray, vi: np.ndarray, cri: np.ndarray, z: float
) -> tuple[np.ndarray, np.ndarray]:
    """The band on |H|: |Ĥ| ± z σ_r, σ_r the standard deviation of the radial part
    Re(H̄ δH)/|H|; the lower end 0 where the confidence ellipse (h − Ĥ)ᵀ Σ⁻¹ (h − Ĥ) ≤ z²
    (Σ = [[vr, cri], [cri, vi]] per entry, flat arrays) holds the origin, or below 0."""
    a, b = H.real, H.imag
    mag = np.abs(H)
    with np.errstate(divide="ignore", invalid="ignore"):
        var_r = (a**2 * vr + b**2 * vi + 2 * a * b * cri) / mag**2
        det = vr * vi - cri**2
        # aᵀ Σ⁻¹ a for the origin's offset −Ĥ; a singular Σ holds the origin only on its line
        dist2 = np.where(det > 0, (vi * a**2 - 2 * cri * a * b + vr * b**2) / det, np.inf)
    var_r = np.where(mag > 0, var_r, vr + vi)
    half = z * np.sqrt(np.maximum(var_r, 0.0))
    lower = np.where(dist2 <= z**2, 0.0, np.maximum(mag - half, 0.0))
    upper = mag + half
    bad = ~(np.isfinite(vr) & np.isfinite(vi) & np.isfinite(cri))
    return np.where(bad, np.nan, lower), np.where(bad, np.nan, upper)


@dataclass(frozen=True)
class MatrixIntervals:
    """Standard deviations of the entries of M, C and K, in the basis they are given in.

    Attributes
    ----------
    M, C, K : numpy.ndarray, (m, m)
        The estimates.
    std_M, std_C, std_K : numpy.ndarray, (m, m)
        The standard deviations of their entries (NaN where not determined).
    level, z : float
        The confidence level and the half-width in standard deviations.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    std_M: np.ndarray
    std_C: np.ndarray
    std_K: np.ndarray
    level: float
    z: float


def _all_modes(M: np.ndarray, C: np.ndarray, K: np.ndarray):
    """Every eigenvalue of the pencil (2m), its vector ψ (m, 2m) and a_r = ψᵀ(2λM + C)ψ,
    and the indices of the modes :func:`podid_rs.modal_parameters` reports, in order."""
    m = M.shape[0]
    eye, zero = np.eye(m), np.zeros((m, m))
    A = np.block([[zero, eye], [-K, -C]])
    B = np.block([[eye, zero], [zero, M]])
    lam, Z = scipy.linalg.eig(A, B)
    psi = Z[:m]
    a = np.einsum("ir,ij,jr->r", psi, 2 * M, psi) * lam + np.einsum("ir,ij,jr->r", psi, C, psi)
    finite = np.isfinite(lam)
    pick = np.flatnonzero(finite & (lam.imag >= 0))
    pick = pick[np.argsort(np.abs(lam[pick]), kind="stable")]
    return lam, psi, a, pick


class ModelUncertainty:
    """Covariance of a refined model and the intervals it gives (module docstring).

    Made by :func:`model_uncertainty` and :func:`fit_uncertainty`.

    Parameters
    ----------
    model : IdentificationResult or SecondOrderSystem
        The fitted model.
    fit : LinearisedFit
        The fit linearised at the model.
    variance : numpy.ndarray
        ``(s, n, p)`` noise variance of each fitted entry.
    noise : str
        Where the variance came from, in words.
    dof : int or None
        Degrees of freedom of an estimated variance (None when given).
    solver : str
        ``"dense"`` or ``"matrix-free"``.
    seconds : float
        Time to form the covariance.
    cov : DenseCovariance or MatrixFreeCovariance
        The covariance of M, C, K, in the coordinates of ``fit``.
    omega : numpy.ndarray
        ``(s,)`` every line of the data (the FRF band's default lines).
    driven : numpy.ndarray of int
        The measured DOFs where the data have forces (the FRF band's default columns).
    coordinates : numpy.ndarray, optional
        T ``(m, m)`` when ``fit`` is in the coordinates q = T q̂ (the model's undamped
        modes on the matrix-free path): X̂ = Tᵀ X T; None for the model's own.

    Attributes
    ----------
    m : int
        The model's order.
    latent : int
        Latent coordinates (unobserved); M, C, K then have a gauge.
    gauge : int
        Its dimension, l·k + l².
    n_parameters : int
        3 m(m+1)/2.
    rank : int
        Directions of M, C, K the data determine.
    """

    def __init__(self, model, fit: LinearisedFit, variance: np.ndarray, noise: str,
                 dof: int | None, solver: str, seconds: float,
                 cov: DenseCovariance | MatrixFreeCovariance, omega: np.ndarray,
                 driven: np.ndarray, coordinates: np.ndarray | None = None) -> None:
        self.M, self.C, self.K = (np.asarray(X, dtype=np.float64) for X in
                                  (model.M, model.C, model.K))
        # what the intervals need of the fit: the dense path then lets go of its data
        self._m, self._n_params, self._scales = fit.m, fit.n_params, fit.scales
        self._cov = cov
        self.variance = variance
        self.noise = noise
        self.dof = dof
        self.solver = solver
        self.seconds = seconds
        self.R = fit.R if coordinates is None else fit.R @ np.linalg.inv(coordinates)
        self._Tinv = None if coordinates is None else np.linalg.inv(coordinates)
        self.omega = omega
        self.driven = driven
        self._observed = observed_count(self.R)

    @property
    def m(self) -> int:
        """The model's order."""
        return self._m

    @property
    def latent(self) -> int:
        """Latent (unobserved) coordinates of the model."""
        return self.m - self._observed

    @property
    def gauge(self) -> int:
        """Dimension of the gauge of latent coordinates (0 without)."""
        return gauge_dimension(self.m, self._observed)

    @property
    def n_parameters(self) -> int:
        """3 m(m+1)/2: the symmetric M, C, K's free entries."""
        return self._n_params

    @property
    def rank(self) -> int:
        """Directions of M, C, K the data determine (n_parameters less the undetermined)."""
        return self._cov.rank

    def z(self, level: float = LEVEL) -> float:
        """Half-width of a two-sided interval at ``level``, in standard deviations.

        Parameters
        ----------
        level : float
            Confidence level in (0, 1).

        Returns
        -------
        float
            The normal quantile for a given noise variance; Student's t with ``dof``
            degrees of freedom for one estimated from the residuals.
        """
        level = _check_level(level)
        q = 0.5 + level / 2
        if self.dof is None:
            return float(scipy.stats.norm.ppf(q))
        return float(scipy.stats.t.ppf(q, self.dof))

    # --------------------------------------------------------------------- gradients
    def _scaled(self, grads: list[np.ndarray]) -> np.ndarray:
        """Gradients per block (∂g/∂X_b as (..., m, m) for b = M, C, K, the caller's
        units) → the covariance's coordinates (..., n_params)."""
        if self._Tinv is not None:  # X = T⁻ᵀ X̂ T⁻¹: ∂g/∂X̂ = T⁻¹ (∂g/∂X) T⁻ᵀ
            grads = [self._Tinv @ g @ self._Tinv.T for g in grads]
        parts = [sym_gradient(g) * c for g, c in zip(grads, self._scales, strict=True)]
        return np.concatenate(parts, axis=-1)

    def _scaled_multiples(self, A: np.ndarray, coefs: list[np.ndarray]) -> np.ndarray:
        """As :meth:`_scaled` of the gradients coefs[b] · A for b = M, C, K (``coefs``
        broadcasting over A's leading axes), A taken to the coordinates once: a third of
        the memory of the three gradients (an FRF band's block of lines, the modes)."""
        if self._Tinv is not None:
            A = self._Tinv @ A @ self._Tinv.T
        base = sym_gradient(A)
        del A
        nb = base.shape[-1]
        out = np.empty(base.shape[:-1] + (3 * nb,), dtype=np.result_type(base, *coefs))
        for b in range(3):
            out[..., b * nb:(b + 1) * nb] = (coefs[b] * self._scales[b])[..., None] * base
        return out

    def modes(self, level: float = LEVEL, *, shapes: bool = False) -> ModeIntervals:
        """Natural frequencies and damping ratios with intervals (and the mode shapes').

        Parameters
        ----------
        level : float
            Confidence level of the intervals, in (0, 1).
        shapes : bool
            Also the mode shapes on the measured DOFs and their standard deviations.

        Returns
        -------
        ModeIntervals
            One entry per mode of :func:`podid_rs.modal_parameters`, same order.

        Raises
        ------
        ValueError
            For a level outside (0, 1).
        """
        z = self.z(level)
        lam, psi, a, pick = _all_modes(self.M, self.C, self.K)
        sel = lam[pick]
        mag = np.abs(sel)
        var_f, var_z = np.empty(sel.size), np.empty(sel.size)
        # the gradients a block of modes at a time, as many as one solve takes (on the
        # matrix-free path the blocks of the solve bound the memory; the dense: all)
        blocks = max(1, len(self._cov.column_blocks(2 * sel.size)))
        for idx in np.array_split(np.arange(sel.size), blocks):
            if not idx.size:
                continue
            g = self._mode_gradients(sel[idx], psi[:, pick[idx]], a[pick[idx]])
            # one set of solves for both: on the matrix-free path they share a Krylov space
            var_f[idx], var_z[idx] = np.split(self._cov.variances(g), 2)
            del g
        real_root = np.abs(sel.imag) <= 1e-12 * mag
        var_z = np.where(real_root & np.isfinite(var_z), 0.0, var_z)
        # NaN: a direction the data do not fix (dense) or a solve that did not converge
        # (matrix-free, which warned)
        unsolved = ~(np.isfinite(var_f) & np.isfinite(var_z))
        # an interval wider than the value itself — a frequency's reaching 0, a damping
        # ratio's spanning more than critical damping — is no interval: the data do not fix
        # that pole (a fit's residual term far outside the band, first order long invalid)
        loose = (z * np.sqrt(var_f) >= mag / (2 * np.pi)) | (z * np.sqrt(var_z) >= 1.0)
        why = np.full(sel.size, "", dtype=object)
        why[loose] = "wider than the value"
        why[unsolved] = "not converged" if self.solver == "matrix-free" else "undetermined"
        var_f = np.where(loose, np.nan, var_f)
        var_z = np.where(loose, np.nan, var_z)
        determined = np.isfinite(var_f) & np.isfinite(var_z)
        out = dict(
            eigenvalues=sel, frequencies_hz=mag / (2 * np.pi),
            damping_ratios=np.where(mag > 0, -sel.real / np.maximum(mag, 1e-300), 0.0),
            std_frequency_hz=np.sqrt(var_f), std_damping=np.sqrt(var_z), level=_check_level(level),
            z=z, determined=determined, why_undetermined=why.astype(str),
        )
        if shapes:
            out.update(self._shape_std(lam, psi, a, pick))
        return ModeIntervals(**out)

    def _mode_gradients(self, sel: np.ndarray, psi: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Gradients of the natural frequencies (Hz) and damping ratios of the modes of
        eigenvalues ``sel``, vectors ``psi`` (m, k) and a = ψᵀ(2λM + C)ψ: ``(2k, q)``, the
        frequencies' rows first."""
        powers = np.stack([sel**2, sel, np.ones_like(sel)])  # c_b(λ) for b = M, C, K
        outer = psi.T[:, :, None] * psi.T[:, None, :]  # ψψᵀ (k, m, m)
        dlam = self._scaled_multiples(outer, [-(powers[b] / a) for b in range(3)])
        del outer
        mag = np.abs(sel)
        g_f = (np.conj(sel)[:, None] * dlam).real / (2 * np.pi * mag[:, None])
        g_z = (-dlam.real / mag[:, None]
               + sel.real[:, None] * (np.conj(sel)[:, None] * dlam).real / mag[:, None] ** 3)
        return np.concatenate([g_f, g_z])

    def _shape_std(self, lam, psi, a, pick) -> dict[str, np.ndarray]:
        """Mode shapes R ψ (largest entry 1) and the standard deviations of their parts."""
        R = self.R
        y_all = R @ psi  # (n, 2m)
        n, k = R.shape[0], pick.size
        shapes = np.empty((n, k), dtype=complex)
        sd_re, sd_im = np.empty((n, k)), np.empty((n, k))
        for col, j in enumerate(pick):
            lj = lam[j]
            gap = lam - lj
            coef = np.zeros(lam.size, dtype=complex)
            ok = np.arange(lam.size) != j
            near = ok & (np.abs(gap) <= 1e-12 * max(abs(lj), 1.0))
            coef[ok & ~near] = 1.0 / (a[ok & ~near] * gap[ok & ~near])
            # ψ_r ψ_jᵀ per r, then dy = Σ_r (R ψ_r) coef_r c_b(λ_j) ψ_rᵀ dX_b ψ_j
            pr = psi.T[:, :, None] * psi[:, j][None, None, :]  # (2m, m, m)
            blocks = self._scaled([lj**2 * pr, lj * pr, pr])  # (2m, q)
            dy = (y_all * coef[None, :]) @ blocks  # (n, q)
            y = y_all[:, j]
            ref = int(np.argmax(np.abs(y)))
            phi = y / y[ref]
            dphi = (dy - phi[:, None] * dy[ref][None, :]) / y[ref]
            dphi[ref] = 0.0
            var_re = self._cov.variances(dphi.real)
            var_im = self._cov.variances(dphi.imag)
            if np.any(near):
                var_re[:], var_im[:] = np.nan, np.nan  # a repeated eigenvalue: no derivative
            shapes[:, col] = phi
            sd_re[:, col], sd_im[:, col] = np.sqrt(var_re), np.sqrt(var_im)
        return dict(shapes=shapes, std_shapes_real=sd_re, std_shapes_imag=sd_im)

    def frf(
        self,
        omega: object = None,
        rows: object = None,
        cols: object = None,
        level: float = LEVEL,
    ) -> FRFBand:
        """The model's FRF on the measured DOFs with a confidence band per line.

        Parameters
        ----------
        omega : array_like, (s,), optional
            Lines (rad/s); default every line of the data given to
            :func:`model_uncertainty`, also those a fit on part of them (``lines``) left
            out.
        rows, cols : array_like of int, optional
            Measured DOFs (indices into the observation matrix's rows) of the
            responses and of the forces; default every DOF, and every DOF where the
            fitted data have a force.
        level : float
            Confidence level, in (0, 1).

        Returns
        -------
        FRFBand
            Values, standard deviations and the band. On the matrix-free path the
            covariances come from 200 draws of the noise's effect (one solve each, for
            every line at once): each variance to about 10 %.

        Raises
        ------
        ValueError
            For bad lines, indices or level.
        """
        z = self.z(level)
        w = self.omega if omega is None else as_omega(omega)
        n = self.R.shape[0]
        r_idx = np.arange(n) if rows is None else np.atleast_1d(np.asarray(rows))
        c_idx = self.driven if cols is None else np.atleast_1d(np.asarray(cols))
        for name, idx in (("rows", r_idx), ("cols", c_idx)):
            if (idx.ndim != 1 or idx.size == 0 or not np.issubdtype(idx.dtype, np.integer)
                    or idx.min() < 0 or idx.max() >= n):
                raise ValueError(f"{name} must be indices of measured DOFs in [0, {n}), "
                                 f"got {idx!r}")
        Rr, Rc = self.R[r_idx], self.R[c_idx]  # (r, m), (c, m)
        s, r, c = w.size, r_idx.size, c_idx.size
        values = np.empty((s, r, c), dtype=complex)
        var_re, var_im, cov_ri = (np.empty((s, r, c)) for _ in range(3))
        # the gradients of a block of lines at once: one pass over the covariance per
        # block, not per line (on the beam, m = 39: 26 s → 1.9 s for 251 lines, 2 entries)
        elements = FRF_BLOCK_ELEMENTS if self.solver == "dense" else FRF_BLOCK_ELEMENTS_MATRIX_FREE
        block = max(1, elements // max(1, r * c * self.n_parameters))
        draws = getattr(self._cov, "draws", None)
        if draws is not None:  # matrix-free: its solves first, before any gradient is held
            draws()
        for start in range(0, s, block):
            stop = min(s, start + block)
            wb = w[start:stop][:, None, None]  # the block's lines, batched
            Dinv = np.linalg.inv(-(wb**2) * self.M + 1j * wb * self.C + self.K)
            g = Dinv @ Rr.T  # (b, m, r)
            h = Dinv @ Rc.T  # (b, m, c)
            values[start:stop] = Rr @ h
            outer = (np.swapaxes(g, 1, 2)[:, :, None, :, None]
                     * np.swapaxes(h, 1, 2)[:, None, :, None, :])  # (b, r, c, m, m)
            phis = (-(wb**2), 1j * wb, np.ones_like(wb))
            grad = self._scaled_multiples(outer, [-ph for ph in phis])
            del outer
            grad = grad.reshape((stop - start) * r * c, -1)
            moments = self._cov.pair_moments(grad.real, grad.imag)
            var_re[start:stop], var_im[start:stop], cov_ri[start:stop] = (
                v.reshape(-1, r, c) for v in moments)
        lower, upper = _magnitude_band(values.reshape(-1), var_re.reshape(-1),
                                       var_im.reshape(-1), cov_ri.reshape(-1), z)
        sd_re, sd_im = np.sqrt(var_re), np.sqrt(var_im)
        with np.errstate(divide="ignore", invalid="ignore"):
            corr = np.where(sd_re * sd_im > 0, cov_ri / (sd_re * sd_im), 0.0)
        return FRFBand(w, r_idx, c_idx, values, sd_re, sd_im, corr, _check_level(level), z,
                       lower.reshape(s, r, c), upper.reshape(s, r, c))

    def matrices(self, level: float = LEVEL) -> MatrixIntervals:
        """Standard deviations of the entries of M, C and K, in their basis.

        Parameters
        ----------
        level : float
            Confidence level, in (0, 1).

        Returns
        -------
        MatrixIntervals
            The estimates and the standard deviation of every entry.

        Raises
        ------
        ValueError
            When the model has latent coordinates: its M, C, K have a gauge (every
            T = [[I, 0], [T_lp, T_ll]] maps them to TᵀMT, TᵀCT, TᵀKT with the same
            responses) and no entry is determined by the data.
        """
        z = self.z(level)
        if self.latent:
            raise ValueError(
                f"the model has {self.latent} latent coordinate(s): M, C and K have a gauge "
                f"of dimension {self.gauge} (docs/design.md §11) and their entries are not "
                "determined by the data; the modes and FRFs are (modes(), frf())"
            )
        if self.solver != "dense":
            raise ValueError(
                f"every entry of M, C, K is a solve with the Gauss–Newton matrix on the "
                f"matrix-free path ({self.n_parameters} of them at m = {self.m}): use "
                "solver='dense' (its memory: the square of that count in doubles)"
            )
        m = self.m
        rows, cols = np.triu_indices(m)
        E = np.zeros((rows.size, m, m))
        E[np.arange(rows.size), rows, cols] = 1.0  # X_jk as a function of the entries
        zero = np.zeros_like(E)
        out = []
        for b in range(3):
            G = self._scaled([E if k == b else zero for k in range(3)])
            sd = np.sqrt(self._cov.variances(G))
            S = np.empty((m, m))
            S[rows, cols] = sd
            S[cols, rows] = sd
            out.append(S)
        return MatrixIntervals(self.M, self.C, self.K, *out, _check_level(level), z)

    def summary(self, level: float = LEVEL, select: object = None) -> str:
        """One line: how the covariance was made, and the typical interval of the modes.

        Parameters
        ----------
        level : float
            Confidence level, in (0, 1).
        select : array_like of bool, optional
            Which modes (of :meth:`modes`) the typical interval is of, e.g. the
            structure's modes apart from a fit's residual terms; default every
            oscillatory mode.

        Returns
        -------
        str
            The line (no trailing newline).
        """
        modes = self.modes(level)
        chosen = (np.ones(modes.determined.size, dtype=bool) if select is None
                  else np.asarray(select, dtype=bool))
        osc = modes.determined & (np.abs(modes.eigenvalues.imag) > 0) & chosen
        text = (f"{100 * level:g} % intervals from the sandwich covariance at the optimum "
                f"({self.solver}, {self.n_parameters} parameters, rank {self.rank}"
                + (f", gauge {self.gauge}" if self.gauge else "") + f"); noise {self.noise}")
        if np.any(osc):
            hf = modes.z * modes.std_frequency_hz[osc] / modes.frequencies_hz[osc]
            hz = modes.z * modes.std_damping[osc] / np.maximum(modes.damping_ratios[osc], 1e-300)
            text += (f"; median half-width over {int(osc.sum())} mode(s): "
                     f"{100 * np.median(hf):.2g} % of the natural frequency, "
                     f"{100 * np.median(hz):.2g} % of the damping ratio")
        undetermined = int(np.sum(~modes.determined & chosen))
        if undetermined:
            text += f"; {undetermined} mode(s) not determined by the data"
        return text + f"; {self.seconds:.2g} s"


def model_uncertainty(
    model: IdentificationResult | SecondOrderSystem,
    U: object,
    F: object,
    omega: object,
    *,
    basis: object = None,
    weights: object = "relative",
    objective: Objective = "complex",
    lines: object = None,
    measured: object = None,
    noise_variance: object = None,
    coherence: object = None,
    averages: object = None,
    noise: NoiseModel = "channel",
    line_correlation: object = (),
    solver: str = "auto",
) -> ModelUncertainty:
    """The covariance of a model refined to these data, and its intervals.

    Give the data and the options :func:`podid_rs.refine` was given: the
    covariance is that of the cost refine minimised, at ``model`` (its optimum).

    Parameters
    ----------
    model : IdentificationResult or SecondOrderSystem
        The refined model (symmetric M, C, K), order m.
    U, F : array_like, complex, (s, n) or (s, n, p)
        Responses and forces on the n measured DOFs (with ``basis``), or reduced
        ``(s, m[, p])`` — as given to :func:`podid_rs.refine`.
    omega : array_like, (s,)
        Lines, rad/s.
    basis : array_like, (n, k), optional
        The observation matrix (POD modes, then zero columns for latent coordinates).
    weights : {"relative", "uniform"} or array_like
        As given to :func:`podid_rs.refine`.
    objective : {"complex", "log-magnitude"}
        As given to :func:`podid_rs.refine`.
    lines : array_like of bool, (s,), optional
        The lines the model was fitted to (e.g. the order sweep's training lines);
        default all.
    measured : array_like of bool, (n, p), optional
        With ``basis``: True where the response was measured, as given to
        :func:`podid_rs.refine` (:attr:`podid_rs.MeasuredData.measured`). The other
        entries weigh nothing: they add nothing to N or S and no degree of freedom to
        the noise estimated from the residuals. Default: every entry.
    noise_variance : float or array_like, optional
        Variance E|δu|² of the complex noise on each measured entry of U: a scalar,
        per line ``(s,)``, per line and DOF ``(s, n)`` or per entry ``(s, n, p)``.
    coherence : array_like, (s, n) or (s, n, p), optional
        With ``averages``: U are H1 estimates, whose variance is
        |H|²(1 − γ²)/(γ² (n_d − 1)) (Bendat & Piersol's random error, with n_d − 1 as
        for Gaussian data; γ² the coherence).
    averages : float, optional
        The number of independent averages n_d of the H1 estimates, more than 1
        (:func:`podid_rs.h1_coherence` gives what overlapping segments are worth).
    noise : {"channel", "local", "line", "global"}
        Without a variance or coherence: the noise is estimated from the residuals,
        one variance per channel (measured DOF and load case) over the lines; per
        channel and line, a floor plus a part proportional to |ŷ|² fitted to the
        neighbouring lines' residuals (``"local"``: measured FRFs, whose noise grows
        with the response — what ``podid-rs identify`` uses); per line; or one for all.
    line_correlation : float or sequence of float
        The correlation coefficient of the noise of an entry between lines 1, 2, …
        apart (default none: independent lines). H1 estimates from windowed
        segments are correlated between neighbouring lines (Hann: 4/9, then 1/36, for
        white input and noise; :func:`podid_rs.h1_coherence` gives them).
    solver : {"auto", "dense", "matrix-free"}
        ``"dense"`` forms the Gauss–Newton matrix ((3m(m+1)/2)² doubles) and
        eigendecomposes it, which also finds the directions the data do not determine;
        ``"matrix-free"`` solves with it for the variances asked, by block
        preconditioned CG (the right-hand sides share a Krylov space, in blocks whose
        memory is bounded: ``CG_BLOCK_BYTES`` of
        :mod:`podid_rs.identification.covariance`; N applied line by line through its
        per-line m × m matrices, memory O(s·m²) as the refinement's matrix-free step,
        and the 3m × 3m blocks of N on each mode's row of M, C, K, O(m³), as the
        preconditioner), in the model's undamped modal coordinates; a solve that does
        not converge gives NaN with a :class:`~podid_rs.ConvergenceWarning`. ``"auto"``
        dense up to m = 40.

    Returns
    -------
    ModelUncertainty
        The covariance, with :meth:`~ModelUncertainty.modes`,
        :meth:`~ModelUncertainty.frf` and :meth:`~ModelUncertainty.matrices`.

    Raises
    ------
    ValueError
        For malformed data or options, negative, NaN or infinite variances, a coherence
        outside [0, 1], fewer than two averages, both a variance and a coherence, a
        coherence without averages, a line correlation outside (−1, 1), or an unknown
        solver.
    """
    t0 = time.perf_counter()
    if not isinstance(model, IdentificationResult | SecondOrderSystem):
        raise ValueError(f"model must be an IdentificationResult or a SecondOrderSystem, got "
                         f"{type(model).__name__}")
    M, C, K = (np.asarray(X, dtype=np.float64) for X in (model.M, model.C, model.K))
    m = M.shape[0]
    for X, name in ((M, "M"), (C, "C"), (K, "K")):
        if np.linalg.norm(X - X.T) > 1e-10 * np.linalg.norm(X):
            raise ValueError(f"the model's {name} is not symmetric: the covariance is that of a "
                             "refined model (symmetric M, C, K)")
    w = as_omega(omega)
    Ua, Fa = as_array(U, "U"), as_array(F, "F")
    if Ua.ndim == 2:
        Ua = Ua[:, :, None]
    if Fa.ndim == 2:
        Fa = Fa[:, :, None]
    if Ua.ndim != 3 or Ua.shape[0] != w.size or Fa.shape != Ua.shape:
        raise ValueError(f"U and F must be (s, n[, p]) of the same shape with s = {w.size} lines, "
                         f"got {np.shape(U)} and {np.shape(F)}")
    if basis is None:
        if Ua.shape[1] > m:
            raise ValueError(f"U has {Ua.shape[1]} coordinates, more than the model's m = {m}: "
                             "give the basis")
        R = observation_matrix(np.eye(Ua.shape[1]), m)
        on_dofs = Ua.shape[1] < m
    else:
        Rb = as_array(basis, "basis", real=True)
        if Rb.ndim != 2 or Rb.shape[0] != Ua.shape[1]:
            raise ValueError(f"basis must be (n, k) with n = {Ua.shape[1]} measured DOFs, "
                             f"got {Rb.shape}")
        R = observation_matrix(Rb, m)
        on_dofs = True
    if objective not in ("complex", "log-magnitude"):
        raise ValueError(f"objective must be 'complex' or 'log-magnitude', got {objective!r}")
    keep = np.ones(w.size, bool) if lines is None else np.asarray(lines)
    if keep.shape != (w.size,) or keep.dtype != bool or not keep.any():
        raise ValueError(f"lines must be a boolean mask of the {w.size} lines, with a line in it")
    if measured is not None and basis is None:
        raise ValueError("measured (a mask over the measured DOFs) needs basis=")
    mask = check_measured(measured, Ua.shape[1], Ua.shape[2])
    if mask is not None:
        Ua = np.where(mask, Ua, 0.0)  # what the holes hold never enters
    W_all = entry_weights(weights, Ua, objective, on_dofs)
    if mask is not None:
        W_all = W_all * mask  # an entry that was not measured weighs nothing
    if noise_variance is not None and coherence is not None:
        raise ValueError("give noise_variance or coherence (with averages), not both")
    if coherence is None and averages is not None:
        raise ValueError("averages goes with coherence (H1 estimates)")
    rho = np.atleast_1d(np.asarray(line_correlation, dtype=np.float64))
    if rho.ndim != 1 or not np.all(np.abs(rho) < 1):
        raise ValueError(f"line_correlation must be coefficients in (−1, 1), got "
                         f"{line_correlation!r}")
    if solver not in ("auto", "dense", "matrix-free"):
        raise ValueError(f"solver must be 'auto', 'dense' or 'matrix-free', got {solver!r}")
    dense = solver == "dense" or (solver == "auto" and m <= AUTO_DENSE_MAX_M)
    T = None
    if dense:
        fit = LinearisedFit(M, C, K, Ua[keep], Fa[keep], w[keep], R, W_all[keep], objective,
                            grid=np.flatnonzero(keep))
        cov: DenseCovariance | MatrixFreeCovariance = DenseCovariance(
            gauss_newton_matrix(fit, fit.bread()))
    else:
        # what earlier work (a refinement) freed is given back before anything is formed
        release_free_memory()
        # the undamped modes: TᵀMT = I, TᵀKT = Ω² (where N is nearly block diagonal)
        _, T = scipy.linalg.eigh(K, M)
        # without every line's D⁻¹ (the solves' products go through N's per-line matrices)
        fit = LinearisedFit(T.T @ M @ T, T.T @ C @ T, T.T @ K @ T, Ua[keep], Fa[keep], w[keep],
                            R @ T, W_all[keep], objective, grid=np.flatnonzero(keep),
                            keep_inverses=False)
        observed = observed_count(R)
        cov = MatrixFreeCovariance(fit, fit.n_params - gauge_dimension(m, observed))
    dof = None
    if noise_variance is not None:
        variance = check_variance(noise_variance, Ua.shape)[keep]
        source = "given per entry"
    elif coherence is not None:
        if averages is None:
            raise ValueError("coherence needs averages: the number of averages of the H1 "
                             "estimates")
        variance = h1_variance(Ua, coherence, averages)[keep]
        source = f"from the coherence and {averages:g} averages (H1)"
    else:
        variance, dof = residual_variance(fit, cov.rank, noise)
        what = {"local": "per channel (DOF and load case), over the neighbouring lines",
                "channel": "per channel (DOF and load case)", "line": "per line",
                "global": "one for all entries"}[noise]
        source = f"estimated from the residuals, {what}, {dof} degrees of freedom"
    meat = fit.meat(variance, tuple(float(r) for r in rho))
    if dense:
        cov.set_meat(gauss_newton_matrix(fit, meat))
    else:
        cov.set_meat(meat)
        cov.set_noise(variance, tuple(float(r) for r in rho))
    driven = np.flatnonzero(np.any(Fa != 0, axis=(0, 2)))
    return ModelUncertainty(model, fit, variance, source, dof,
                            "dense" if dense else "matrix-free", time.perf_counter() - t0, cov,
                            w, driven, T)


def _refinement_weights(model: IdentificationResult) -> tuple[str, Objective]:
    """The weights and objective the refinement of ``model`` used, from its report."""
    ref = model.info.get("refinement") if isinstance(model, IdentificationResult) else None
    if ref is None:
        raise ValueError("the model is not a refined (output-error) model: its covariance is "
                         "that of the cost refine() minimised; use model_uncertainty with the "
                         "data and options of the fit")
    objective = ref["objective"]
    # the holes of measured data are a mask, not the user's weights (fit_uncertainty
    # passes the data's own)
    label = ref["weights"].removesuffix(", measured entries")
    if label in ("relative", "uniform"):
        return label, objective
    if label == "log-magnitude, uniform per entry":
        return "uniform", objective
    raise ValueError(f"the model was refined with the user's weights ({label!r}): give them to "
                     "model_uncertainty")


def fit_uncertainty(
    data: MeasuredData,
    model: IdentificationResult,
    basis: object,
    sweep: OrderSweep | None = None,
    *,
    noise_variance: object = None,
    coherence: object = None,
    averages: object = None,
    noise: NoiseModel = "channel",
    line_correlation: object = (),
    solver: str = "auto",
) -> ModelUncertainty:
    """The covariance of a model fitted to measured data by :meth:`MeasuredData.fit`.

    The weights, the objective and the lines of the fit are read from the model's
    report (``info["refinement"]``): the final fit keeps a complex refit, a
    log-magnitude refit or the order sweep's fit on its training lines (which then
    needs ``sweep``); on a long test the refits fitted the sweep's informative lines
    (:attr:`OrderSweep.lines`, which then need ``sweep`` too). The entries the data
    did not measure (:attr:`MeasuredData.measured`) weigh nothing, as in the fit.

    Parameters
    ----------
    data : MeasuredData
        The data the model was fitted to (same band).
    model : IdentificationResult
        The fitted model (:meth:`MeasuredData.fit`, :func:`podid_rs.final_fit`).
    basis : array_like, (n, m)
        Its observation matrix.
    sweep : OrderSweep, optional
        The order sweep, when the final fit kept its held-out fit or fitted the
        informative lines of a long test.
    noise_variance, coherence, averages, noise, line_correlation
        The noise, as for :func:`model_uncertainty`.
    solver : {"auto", "dense", "matrix-free"}
        As for :func:`model_uncertainty`.

    Returns
    -------
    ModelUncertainty
        The covariance and its intervals.

    Raises
    ------
    ValueError
        For a model that is not refined, or refined with the user's weights; a held-out
        fit or a fit on part of the lines without its sweep; or as
        :func:`model_uncertainty`.
    """
    if not isinstance(data, MeasuredData):
        raise ValueError(f"data must be a MeasuredData, got {type(data).__name__}")
    weights, objective = _refinement_weights(model)
    lines = None
    final = model.info["refinement"].get("final_refit", {})
    fitted = final.get("lines_fitted", data.s)
    if final.get("kept") == "held-out fit":
        if sweep is None:
            raise ValueError("the final fit kept the order sweep's held-out fit (fitted on its "
                             "training lines): give the sweep")
        lines = np.asarray(sweep.lines) & ~np.asarray(sweep.test_lines)
    elif fitted != data.s:
        if sweep is None or int(np.sum(sweep.lines)) != fitted:
            raise ValueError(f"the final fit fitted {fitted} of the {data.s} lines (the order "
                             "sweep's informative lines): give the sweep")
        lines = np.asarray(sweep.lines)
    return model_uncertainty(
        model, data.U, data.forces_on_dofs(), data.omega, basis=basis, weights=weights,
        objective=objective, lines=lines, measured=None if data.complete else data.measured,
        noise_variance=noise_variance, coherence=coherence,
        averages=averages, noise=noise, line_correlation=line_correlation, solver=solver,
    )
