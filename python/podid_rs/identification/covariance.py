"""Covariance of an output-error fit: the Gauss–Newton matrix, the noise, the sandwich.

:func:`~podid_rs.refine` minimises, over symmetric M, C, K,

    c = Σ_ce W_ce² ρ_ce²,    ρ_ce = ŷ_ce − u_ce            (objective "complex")
                             ρ_ce = ln|ŷ_ce| − ln|u_ce|    (objective "log-magnitude")

over the measured entries e (DOF) of every column c (line and load case), with
ŷ_c = R D(ω)⁻¹ Rᵀ f_c the model's response on the measured DOFs and W the weights
(a scalar per column, 1/‖u_c‖ for ``"relative"``, or one per entry). Noise δu on the
data moves the optimum, to first order, by

    δθ = N⁻¹ Jᵣᵀ (∂r/∂u) δu,      N = Jᵣᵀ Jᵣ (the Gauss–Newton matrix),

so cov θ̂ = N⁻¹ S N⁻¹ with S = Jᵣᵀ (∂r/∂u) Σ_u (∂r/∂u)ᵀ Jᵣ: the **sandwich**. It
reduces to N⁻¹/2 only when W² is the inverse noise variance; relative weights on
additive noise need the sandwich. Both N and S are Gauss–Newton matrices of the
same residual with other weights (:class:`EntryWeights`): for circular complex
noise of variance σ² per entry,

    complex:        N ← W²,                 S ← W⁴ σ² / 2
    log-magnitude:  N ← W² (exact Re(J)ᵀRe(J)),   S ← W⁴ σ² / (2 |u|²).

**Coordinates.** The covariance is taken in M, C, K themselves — the coordinates of
each symmetric block in the orthonormal basis {E_jj} ∪ {(E_jk + E_kj)/√2} (the
symmetric half of docs/design.md §3), on data scaled as there (ω by its RMS, u and
f by theirs) — not in the refinement's Cholesky factors: the covariance of
anything computed from M, C, K is the same in every parametrisation that maps onto
them locally one-to-one, and the factors' map is nearly singular where the fit puts
C at the edge of positive semidefiniteness (the usual case on measured data). With
latent coordinates the matrices have a gauge (:mod:`.latent`): N is singular along
it, and only quantities it leaves unchanged have a variance.

**The noise.** Given per entry (``noise_variance``), from the coherence γ² and the
number of averages n_d of H1 estimates (Bendat & Piersol: the normalised random
error of |Ĥ| and the error of its phase in radians are each
√(1 − γ²)/(|γ|√(2n_d)), so E|δĤ|² ≈ |Ĥ|²(1 − γ²)/(γ² n_d); n_d − 1 in place of n_d,
exact for Gaussian data, :func:`h1_variance`), or estimated from the
residuals ŷ − u of the fit: one variance per channel (measured DOF and load case)
over the lines, by default, or per channel and line from the neighbouring lines
(a floor plus a part proportional to |ŷ|², for measured FRFs), or per line, or one for
all; the residuals have 2·entries − rank real degrees of freedom, and the variances
are scaled by their ratio.

:func:`gauss_newton_matrix` forms N (or S) densely from five moment sums of
Kronecker products (O(columns · m⁴)); :class:`LinearisedFit` holds the point, and
its ``jacobian`` is the explicit (small-problem) oracle the fast paths are tested
against; ``product`` applies N or S to vectors line by line (O(columns · m²)
memory-light products) for the matrix-free path; ``gram_product`` applies N through
its per-line m × m matrices, and ``star_blocks`` forms N's blocks on the stars of
coordinates, the matrix-free solves' preconditioner.
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
import scipy.linalg.blas

from .._arrays import as_array
from .._linesolve import _one_blas_thread
from .._memory import release_free_memory
from .refinement import LOG_DYNAMIC_RANGE
from .result import ConvergenceWarning

Objective = Literal["complex", "log-magnitude"]
NoiseModel = Literal["local", "channel", "line", "global"]

#: elements of Rᵀ diag(h) R's intermediate (lines × p × n × m) formed at once
PAIR_CHUNK_ELEMENTS = 1 << 18
#: stars of coordinates whose blocks of N are formed at once (their memory: 9 m² doubles
#: each, and m² complex numbers per power of ω), and the entries of the per-line matrices
#: (columns × m × m) read at once for them
STAR_GROUP = 8
STAR_CHUNK_ELEMENTS = 1 << 18
#: elements of D(ω) (lines × m × m) factorised at once once the inverses are released
LINE_SOLVE_ELEMENTS = 1 << 18
#: a coherence below this is taken as this (the variance of that entry is then huge)
COHERENCE_FLOOR = 1e-12
#: the noise model "local" fits a channel's residuals on this many fitted lines on each
#: side of a line (25 lines, 50 real degrees of freedom)
LOCAL_HALF_WIDTH = 12
#: Fisher-scoring steps of the noise model "local"
LOCAL_ITERATIONS = 8
#: window entries (lines × entries × window) of the noise model "local" formed at once
LOCAL_CHUNK_ELEMENTS = 1 << 16


@functools.lru_cache(maxsize=64)
def sym_pairs(m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row, column (j ≤ k, row-major) and the factor f of each symmetric coordinate.

    The coordinate p = (j, k) is the coefficient of E_jj (j = k) or
    (E_jk + E_kj)/√2 (j < k); ``f`` is 1/√2 off the diagonal and 1/2 on it, so
    that the coordinate of the gradient A (∂g/∂X_ij = A_ij) is f·(A + Aᵀ)_jk.
    Computed once per m (a gradient per line calls it per line) and read-only.
    """
    rows, cols = np.triu_indices(m)
    f = np.where(rows == cols, 0.5, 1.0 / np.sqrt(2.0))
    for a in (rows, cols, f):
        a.flags.writeable = False
    return rows, cols, f


def sym_gradient(A: np.ndarray) -> np.ndarray:
    """Coordinates of a gradient with respect to a symmetric matrix.

    ``A`` is ``(..., m, m)``: ∂g/∂X_ij for the entries of X taken as independent;
    the result ``(..., m(m+1)/2)`` is ∂g/∂θ_p for the orthonormal symmetric
    coordinates θ of :func:`sym_pairs`.
    """
    m = A.shape[-1]
    rows, cols, f = sym_pairs(m)
    S = A + np.swapaxes(A, -1, -2)
    return f * S[..., rows, cols]


def sym_matrix(theta: np.ndarray, m: int) -> np.ndarray:
    """The symmetric matrices ``(..., m, m)`` of coordinates ``(..., m(m+1)/2)``."""
    rows, cols, _ = sym_pairs(m)
    diag = rows == cols
    X = np.zeros(theta.shape[:-1] + (m, m), dtype=theta.dtype)
    off = theta[..., ~diag] / np.sqrt(2.0)
    X[..., rows[~diag], cols[~diag]] = off
    X[..., cols[~diag], rows[~diag]] = off
    X[..., rows[diag], cols[diag]] = theta[..., diag]
    return X


def _rms(z: np.ndarray) -> float:
    a = np.abs(z[np.isfinite(z)])
    top = float(a.max()) if a.size else 0.0
    if top == 0.0:
        return 1.0
    return top * float(np.sqrt(np.mean((a / top) ** 2)))


@dataclass(frozen=True)
class EntryWeights:
    """Weights of a Gauss–Newton-type matrix over pairs of lines.

    The matrix is Σ_P (A_P + A_Pᵀ)/(1 + [left = right]) with
    A_P = Re J_lᴴ diag(h) J_r + Re J_lᵀ diag(t) J_r over the entries of the columns
    of line l = ``left[P]`` and line r = ``right[P]`` (same load case, same DOF); J is
    the Jacobian of the model's (scaled) responses on the measured entries. Pairs
    with l = r give the usual Re Σ Jᴴ diag(h) J; pairs of neighbouring lines carry
    noise that is correlated between lines (H1 estimates from overlapping windows).

    ``left``, ``right`` ``(P,)`` fitted-line indices; ``hermitian`` ``(P, n, p)``;
    ``symmetric`` ``(P, n, p)`` or None.
    """

    left: np.ndarray
    right: np.ndarray
    hermitian: np.ndarray
    symmetric: np.ndarray | None = None

    @property
    def diagonal(self) -> np.ndarray:
        """Which pairs are a line with itself."""
        return self.left == self.right


class LinearisedFit:
    """An output-error fit linearised at its optimum: the point, the scales, the weights.

    Parameters
    ----------
    M, C, K : numpy.ndarray
        The fitted model (m × m, symmetric), the caller's units.
    U, F : numpy.ndarray
        ``(s, n, p)`` measured responses and the forces on the measured DOFs (zero
        off the driven ones), on the lines the fit used.
    omega : numpy.ndarray
        ``(s,)`` rad/s.
    R : numpy.ndarray
        ``(n, m)`` observation matrix (the identity for reduced data).
    W : numpy.ndarray
        ``(s, n, p)`` the weight of each entry in the fitted cost.
    objective : {"complex", "log-magnitude"}
        What was minimised.
    grid : numpy.ndarray of int, optional
        ``(s,)`` the index of each line on the data's grid of lines (the fit may have
        used a subset), for noise correlated between neighbouring lines; default
        0 … s − 1.
    keep_inverses : bool
        Keep every line's D(ω)⁻¹ (s·m² complex; :meth:`jacobian` and the dense matrices
        need them); without, the products solve per line (:meth:`solve_lines`).

    Attributes
    ----------
    m, s, n, p : int
        Order, lines, measured entries per column, load cases.
    n_params : int
        3 m(m+1)/2 coordinates of M, C, K.
    scales : numpy.ndarray
        ``(3,)`` c_M, c_C, c_K: X = c_X · X̃ (docs/design.md §3).
    """

    def __init__(self, M, C, K, U, F, omega, R, W, objective: Objective,
                 grid: np.ndarray | None = None, keep_inverses: bool = True) -> None:
        self.objective = objective
        self.m = M.shape[0]
        self.s, self.n, self.p = U.shape
        self.n_params = 3 * self.m * (self.m + 1) // 2
        self.R = R
        self.omega = omega
        self.U = U
        self.W = W
        self.w0 = float(np.sqrt(np.mean(omega**2)))
        self.su = _rms(U)
        self.sf = _rms(F)
        self.scales = np.array([self.sf / (self.su * self.w0**2), self.sf / (self.su * self.w0),
                                self.sf / self.su])  # fmt: skip
        self.w = omega / self.w0
        self.phi = np.stack([-(self.w**2) + 0j, 1j * self.w, np.ones_like(self.w) + 0j])  # (3, s)
        self.X = [np.asarray(X, dtype=np.float64) / c for X, c in zip((M, C, K), self.scales,
                                                                       strict=True)]
        self.f = np.einsum("nm,snp->smp", R, F) / self.sf  # scaled reduced forces
        self.Dinv: np.ndarray | None = None
        if keep_inverses:
            # (s, m, m), a chunk of lines at a time: no second array of every line's D
            self.Dinv = np.empty((self.s, self.m, self.m), dtype=np.complex128)
            for sl in self._line_chunks():
                self.Dinv[sl] = np.linalg.inv(self.dynamic_stiffness(sl))
        # (s, m, p) scaled responses of the coordinates
        self.x = self.solve_lines(self.f.astype(np.complex128))
        self.y = np.einsum("nm,smp->snp", R, self.x)  # scaled responses on the measured DOFs
        self.u = U / self.su
        self.grid = np.arange(self.s) if grid is None else np.asarray(grid)

    # ------------------------------------------------------------------ the cost's weights
    def bread(self) -> EntryWeights:
        """The weights whose Gauss–Newton matrix is N (the fitted cost's)."""
        idx = np.arange(self.s)
        W2 = self.W**2
        if self.objective == "complex":
            return EntryWeights(idx, idx, W2)
        y = np.where(self.W > 0, self.y, 1.0)
        return EntryWeights(idx, idx, 0.5 * W2 / np.abs(y) ** 2, 0.5 * W2 / y**2)

    def meat(self, variance: np.ndarray, correlation: tuple[float, ...] = ()) -> EntryWeights:
        """The weights whose matrix is S, the noise's: ``variance`` E|δu|² per entry
        ``(s, n, p)`` (data units; circular complex noise), and ``correlation[ℓ − 1]``
        the correlation coefficient of the noise of lines ℓ apart (same entry) on the
        data's grid of lines (``self.grid``)."""
        v = variance / self.su**2
        idx = np.arange(self.s)
        left, right, rho = [idx], [idx], [np.ones(self.s)]
        for lag, r in enumerate(correlation, start=1):
            # pairs of fitted lines that are `lag` apart on the data's grid
            pos = np.searchsorted(self.grid, self.grid + lag)
            ok = (pos < self.s) & (self.grid[np.minimum(pos, self.s - 1)] == self.grid + lag)
            left.append(idx[ok])
            right.append(pos[ok])
            rho.append(np.full(int(ok.sum()), float(r)))
        lft, rgt, rho = (np.concatenate(x) for x in (left, right, rho))
        sd = np.sqrt(v)
        c = rho[:, None, None] * sd[lft] * sd[rgt]  # E δu_l δū_r, per entry
        Wl2, Wr2 = self.W[lft] ** 2, self.W[rgt] ** 2
        if self.objective == "complex":
            # E[Re(aᴴ e_l) Re(bᴴ e_r)] = ½ Re(aᴴ E[e_l ē_rᵀ] b) for circular noise
            return EntryWeights(lft, rgt, 0.5 * Wl2 * Wr2 * c)
        used = (self.W[lft] > 0) & (self.W[rgt] > 0)
        ul = np.where(used, self.u[lft], 1.0)
        ur = np.where(used, self.u[rgt], 1.0)
        yl = np.where(used, self.y[lft], 1.0)
        yr = np.where(used, self.y[rgt], 1.0)
        # r = W ln|u| ⇒ δr = W Re(δu/u): E = ½ W_l W_r Re(c / (u_l ū_r)); then
        # Re(a_l)ᵀRe(a_r) = ½ Re(a_lᴴ a_r) + ½ Re(a_lᵀ a_r) with a = J/ŷ
        h = np.where(used, Wl2 * Wr2 * 0.5 * np.real(c / (ul * np.conj(ur))), 0.0)
        return EntryWeights(lft, rgt, 0.5 * h / (np.conj(yl) * yr), 0.5 * h / (yl * yr))

    def residuals(self) -> np.ndarray:
        """ŷ − u on the measured entries ``(s, n, p)``, in the data's units."""
        return (self.y - self.u) * self.su

    # ------------------------------------------------------------------ explicit Jacobian
    def jacobian(self) -> np.ndarray:
        """∂ŷ/∂θ ``(s, n, p, n_params)`` complex, scaled units: the oracle (small problems).

        δŷ_c = −R D⁻¹ (Σ_b φ_b(ω) δX_b) x_c with φ = (−ω², iω, 1); θ the orthonormal
        symmetric coordinates of M̃, C̃, K̃ (block-major).
        """
        rows, cols, f = sym_pairs(self.m)
        # D⁻¹ E^p x for every coordinate p: f·(D⁻¹[:, j] x_k + D⁻¹[:, k] x_j), (s, m, p, q)
        t = (self.Dinv[:, :, None, rows] * self.x[:, None, cols, :].transpose(0, 1, 3, 2)
             + self.Dinv[:, :, None, cols] * self.x[:, None, rows, :].transpose(0, 1, 3, 2))
        t = t * f
        t = np.einsum("nm,smpq->snpq", self.R, t)
        return np.concatenate([-self.phi[b][:, None, None, None] * t for b in range(3)], axis=3)

    # ------------------------------------------------------------------ matrix-free products
    @functools.cached_property
    def _stacked_responses(self) -> np.ndarray:
        """[φ_0 x; φ_1 x; φ_2 x] of every column, real and imaginary parts side by side:
        ``(3m, 2·s·p)`` real, so that δZ = [δX̃_M δX̃_C δX̃_K] (m × 3m) gives
        Σ_b φ_b δX̃_b x for every column by one real matrix product."""
        m, s, p = self.m, self.s, self.p
        X = self.x.transpose(1, 0, 2)  # (m, s, p)
        Xs = np.concatenate([self.phi[b][None, :, None] * X for b in range(3)], axis=0)
        Xs = Xs.reshape(3 * m, s * p)
        return np.ascontiguousarray(np.concatenate([Xs.real, Xs.imag], axis=1))

    def apply_load(self, theta: np.ndarray) -> np.ndarray:
        """L·θ = Σ_b φ_b δX̃_b x_c for every column: ``(n_params, k)`` → ``(s, m, p, k)``
        complex (the Jacobian is −R D⁻¹ L)."""
        nb, m, s, p = self.n_params // 3, self.m, self.s, self.p
        k = theta.shape[1]
        dZ = np.concatenate([sym_matrix(theta[b * nb:(b + 1) * nb].T, m) for b in range(3)],
                            axis=2)  # (k, m, 3m)
        y = (dZ.reshape(k * m, 3 * m) @ self._stacked_responses).reshape(k, m, 2, s, p)
        del dZ
        out = np.empty((k, m, s, p), dtype=np.complex128)  # no complex temporary
        out.real, out.imag = y[:, :, 0], y[:, :, 1]
        return out.transpose(2, 1, 3, 0)

    def apply_load_adjoint(self, w: np.ndarray) -> np.ndarray:
        """Re Lᴴ w: ``(s, m, p, k)`` complex → ``(n_params, k)``, the coordinates of
        A_b = Re Σ_c w̄_c (φ_b x_c)ᵀ."""
        s, m, p = self.s, self.m, self.p
        k = w.shape[3]
        # Re(w̄ a) = Re w Re a + Im w Im a: the parts side by side, without a complex copy
        Wr = np.empty((k, m, 2, s, p))
        Wt = w.transpose(3, 1, 0, 2)
        Wr[:, :, 0], Wr[:, :, 1] = Wt.real, Wt.imag
        A = (Wr.reshape(k * m, 2 * s * p) @ self._stacked_responses.T).reshape(k, m, 3, m)
        del Wr
        return np.concatenate([sym_gradient(A[:, :, b]).T for b in range(3)], axis=0)

    def apply_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """J·θ: ``(n_params, k)`` → δŷ ``(s, n, p, k)``.

        δX x for every column by one real matrix product, then per line
        −D⁻¹(Σ_b φ_b δX_b x): memory O(s·m·p·k).
        """
        s, m, p = self.s, self.m, self.p
        k = theta.shape[1]
        y = np.ascontiguousarray(self.apply_load(theta)).reshape(s, m, p * k)
        y = self.solve_lines(y, out=y if self.Dinv is None else None).reshape(s, m, p, k)
        y *= -1.0
        return np.einsum("nm,smpk->snpk", self.R, y, optimize=True)

    def apply_adjoint(self, t: np.ndarray) -> np.ndarray:
        """Re(Jᴴ t): ``(s, n, p, k)`` complex → ``(n_params, k)``."""
        s, m, p = self.s, self.m, self.p
        k = t.shape[3]
        z = np.ascontiguousarray(np.einsum("nm,snpk->smpk", self.R, t, optimize=True))
        z = z.reshape(s, m, p * k)
        # −D⁻ᴴ Rᵀ t as −conj(D⁻ᵀ conj(z)): no conjugate copy of every line's D⁻¹ (and,
        # solving per line, none of z)
        np.conjugate(z, out=z)
        z = self.solve_lines(z, transpose=True, out=z if self.Dinv is None else None)
        np.conjugate(z, out=z)
        z *= -1.0
        return self.apply_load_adjoint(z.reshape(s, m, p, k))

    def solve_lines(self, y: np.ndarray, transpose: bool = False,
                    out: np.ndarray | None = None) -> np.ndarray:
        """D(ω)⁻¹ y (or D(ω)⁻ᵀ y) on every line: ``(s, m, k)`` complex.

        By the per-line inverses while they are held; after :meth:`release_inverses` by
        an LU solve per line, ``LINE_SOLVE_ELEMENTS`` of D's entries at a time (the
        matrix-free covariance's products with the meat and its noise draws: a few per
        solve, where the inverses would be the memory of its solves' blocks). ``out``
        may be ``y`` itself (solving per line: each chunk is read before it is written).
        """
        if self.Dinv is not None:
            return np.matmul(self.Dinv.transpose(0, 2, 1) if transpose else self.Dinv, y,
                             out=out)
        if out is None:
            out = np.empty_like(y)
        for sl in self._line_chunks():
            D = self.dynamic_stiffness(sl)
            out[sl] = np.linalg.solve(D.transpose(0, 2, 1) if transpose else D, y[sl])
        return out

    def _line_chunks(self) -> list[slice]:
        """The lines ``LINE_SOLVE_ELEMENTS`` of D's entries at a time."""
        chunk = max(1, LINE_SOLVE_ELEMENTS // (self.m * self.m))
        return [slice(i, i + chunk) for i in range(0, self.s, chunk)]

    def dynamic_stiffness(self, lines: slice = slice(None)) -> np.ndarray:
        """D(ω) = −ω²M̃ + iωC̃ + K̃ (scaled) on ``lines``: ``(lines, m, m)`` complex."""
        D = self.phi[0][lines, None, None] * self.X[0]
        D += self.phi[1][lines, None, None] * self.X[1]
        D += self.X[2]
        return D

    def release_inverses(self) -> None:
        """Let go of the per-line inverses D(ω)⁻¹ (s·m² complex, the refinement's largest
        array): the products solve per line from here on (:meth:`solve_lines`), and
        :meth:`jacobian`, :meth:`line_grams` and the dense matrices need them."""
        self.Dinv = None

    def sample_noise_gradients(
        self, variance: np.ndarray, correlation: tuple[float, ...], k: int,
        rng: np.random.Generator,
    ) -> np.ndarray:
        """k draws of the gradient's perturbation Jᵣᵀ (∂r/∂u) δu by the noise itself:
        ``(n_params, k)`` whose covariance is the meat S of :meth:`meat`.

        δu is circular complex Gaussian of ``variance`` per entry, correlated along the
        data's grid of lines by ``correlation`` (a stationary sequence: white noise
        filtered by the square root of its spectrum 1 + 2 Σ_ℓ ρ_ℓ cos ℓθ, which must
        not be negative).
        """
        n, p = self.n, self.p
        length = int(self.grid.max()) + 1 + 2 * len(correlation) + 8
        white = np.empty((length, n, p, k), dtype=np.complex128)  # the same draws, in place
        white.real = rng.standard_normal((length, n, p, k))
        white.imag = rng.standard_normal((length, n, p, k))
        white /= np.sqrt(2.0)
        if correlation:
            theta = 2 * np.pi * np.fft.fftfreq(length)
            spectrum = 1 + 2 * sum(r * np.cos((lag + 1) * theta)
                                   for lag, r in enumerate(correlation))
            if np.any(spectrum < -1e-12):
                raise ValueError(f"line_correlation {correlation!r} is not a correlation "
                                 "sequence (its spectrum is negative somewhere)")
            white = np.fft.ifft(np.sqrt(np.maximum(spectrum, 0.0))[:, None, None, None]
                                * np.fft.fft(white, axis=0), axis=0)
        white = white[self.grid]  # (s, n, p, k)
        white *= np.sqrt(variance / self.su**2)[..., None]  # δu
        W2 = (self.W**2)[..., None]
        if self.objective == "complex":
            white *= W2
            t = white
        else:
            used = (self.W > 0)[..., None]
            u = np.where(used, self.u[..., None], 1.0)
            y = np.where(used, self.y[..., None], 1.0)
            t = np.where(used, W2 * np.real(white / u) / np.conj(y), 0.0)
        del white
        # the adjoint a few draws at a time (its intermediates: s·m·p of them each)
        out = np.empty((self.n_params, k))
        step = self.product_columns()
        for i in range(0, k, step):
            out[:, i:i + step] = self.apply_adjoint(t[..., i:i + step])
        return out

    def product_columns(self) -> int:
        """Columns per product with N, S or Jᵀ: their per-line intermediates (s·m·p
        complex numbers each) within ``PRODUCT_ELEMENTS``."""
        return max(1, PRODUCT_ELEMENTS // max(1, self.s * self.m * self.p))

    def line_grams(self, weights: EntryWeights, packed: bool = False
                   ) -> tuple[np.ndarray, np.ndarray | None] | None:
        """Per column, the m × m matrices through which lag-0 ``weights`` act on L·θ:
        G_c = D⁻ᴴ Rᵀ diag(h_c) R D⁻¹ (Hermitian) and G̃_c = D⁻ᵀ Rᵀ diag(t_c) R D⁻¹ (or
        None), ``(s, p, m, m)``, so that the matrix of ``weights`` is
        θ ↦ Re Lᴴ (G L θ + conj(G̃ L θ)) (:meth:`gram_product`); with ``packed`` G as
        :func:`pack_hermitian` keeps it, formed a chunk of lines at a time (never whole
        and complex). None unless the weights pair every line with itself once, in order
        (the Gauss–Newton matrix N). Without the inverses (``keep_inverses=False``)
        each chunk's are formed and dropped."""
        if not (weights.left.size == self.s and np.array_equal(weights.left, np.arange(self.s))
                and np.all(weights.diagonal)):
            return None
        s, n, p, m = self.s, self.n, self.p, self.m
        chunk = max(1, min(PAIR_CHUNK_ELEMENTS // max(1, p * n * m),
                           LINE_SOLVE_ELEMENTS // (m * m)))
        out = []
        for h, conj in ((weights.hermitian, True), (weights.symmetric, False)):
            if h is None:
                out.append(None)
                continue
            pack = packed and conj
            G = np.empty((s, p, m, m), dtype=np.float64 if pack else complex)
            for i in range(0, s, chunk):
                sl = slice(i, i + chunk)
                Dinv = (self.Dinv[sl] if self.Dinv is not None
                        else np.linalg.inv(self.dynamic_stiffness(sl)))
                Q = self.R.T @ (h[sl].transpose(0, 2, 1)[..., None] * self.R)  # (P, p, m, m)
                left = Dinv.conj() if conj else Dinv
                Gc = left.transpose(0, 2, 1)[:, None] @ Q @ Dinv[:, None]
                G[sl] = pack_hermitian(Gc) if pack else Gc
            out.append(G)
        return out[0], out[1]

    def gram_product(self, grams: tuple[np.ndarray, np.ndarray | None],
                     theta: np.ndarray) -> np.ndarray:
        """The matrix of :meth:`line_grams`' ``grams`` times ``theta`` ``(n_params, k)``:
        Re Lᴴ (G L θ + conj(G̃ L θ)), one m × m product per column and line.

        G may also be given packed, as the real matrices P = Re G + Im G
        (:func:`pack_hermitian`: half the memory): Re G = (P + Pᵀ)/2 and Im G = (P − Pᵀ)/2,
        so with u = P y and v = Pᵀ y, G y = (u + v)/2 + i (u − v)/2 — as many flops.
        """
        G, Gt = grams
        s, m, p = self.s, self.m, self.p
        k = theta.shape[1]
        y = np.ascontiguousarray(self.apply_load(theta).transpose(0, 2, 1, 3))  # (s, p, m, k)
        w = G @ y if np.iscomplexobj(G) else None
        if Gt is not None:
            gt = np.conj(Gt @ y)
        if w is None:
            # real and imaginary parts side by side: real products, no complex copy of P
            yr = y.view(np.float64)  # (s, p, m, 2k)
            w = (G @ yr).view(np.complex128)  # u = P y
            del y
            v = (np.swapaxes(G, -1, -2) @ yr).view(np.complex128)
            del yr
            w += v  # u + v
            v *= -2.0
            v += w  # u − v
            w.real -= v.imag  # (u + v) + i (u − v), in place
            w.imag += v.real
            del v
            w *= 0.5
        if Gt is not None:
            w += gt
            del gt
        return self.apply_load_adjoint(w.transpose(0, 2, 1, 3).reshape(s, m, p, k))

    def star_blocks(self, grams: tuple[np.ndarray, np.ndarray | None]) -> np.ndarray:
        """N's blocks on the stars of coordinates: star j holds the symmetric coordinates
        (j, k) of M, C and K for every k, ``(m, 3m, 3m)`` (rows and columns block-major,
        k within a block; :meth:`star_index`), from :meth:`line_grams`' ``grams``: the
        groups of :meth:`star_block_groups` side by side."""
        return np.concatenate([blocks for _, blocks in self.star_block_groups(grams)])

    def star_block_groups(self, grams: tuple[np.ndarray, np.ndarray | None],
                          size: int = STAR_GROUP):
        """N's blocks on the stars of coordinates (:meth:`star_blocks`), ``size`` stars at
        a time: yields (the first star's index, their blocks ``(size, 3m, 3m)``), so that
        the preconditioner can take each group and drop it. ``grams`` as
        :meth:`gram_product` takes them (G packed or not), read ``STAR_CHUNK_ELEMENTS``
        of G's entries at a time.

        With v = φ_b f′(e_j x_k + e_k x_j) the direction of coordinate (b, j, k) in L·θ
        (f′ = 1/√2 off the diagonal, 1/2 on it) the entry is
        Re Σ_c v̄ᵀ G v′ + vᵀ G̃ v′: per power ω^P of φ̄_b φ_b′ four sums over the columns,
        x̄_k x_k′ G_jj + x̄_k x_j G_jk′ + x̄_j x_k′ G_kj + |x_j|² G_kk′ (products over the
        columns; the symmetric part unconjugated).
        """
        G, Gt = grams
        m, s, p = self.m, self.s, self.p
        fp = np.where(np.arange(m)[:, None] == np.arange(m)[None, :], 0.5, 1 / np.sqrt(2))
        c = np.array([-1.0, 1j, 1.0])
        d = (2, 1, 0)
        x_all = self.x.transpose(0, 2, 1).reshape(s * p, m)  # (columns, m)
        w_all = np.repeat(self.w, p)
        parts = [(H.reshape(s * p, m, m), conj) for H, conj in ((G, True), (Gt, False))
                 if H is not None]
        step = max(1, STAR_CHUNK_ELEMENTS // (m * m))
        for j0 in range(0, m, size):
            js = np.arange(j0, min(m, j0 + size))
            g = js.size
            out = np.zeros((g, 3, m, 3, m))
            for Hall, conj in parts:
                for lo in range(0, s * p, step):
                    cs = slice(lo, lo + step)
                    H = Hall[cs]
                    if not np.iscomplexobj(H):  # packed: G = (P + Pᵀ)/2 + i (P − Pᵀ)/2
                        Ht = np.swapaxes(H, 1, 2)
                        H = 0.5 * (H + Ht) + 0.5j * (H - Ht)
                    x, w = x_all[cs], w_all[cs]
                    xl = x.conj() if conj else x
                    Hjj = np.einsum("cjj->cj", H)[:, js]  # (columns, g)
                    cols = x.shape[0]
                    for power in range(5):
                        wp = w**power
                        # |x_j|² G_kk′ (or x_j² G̃_kk′): one product over the columns
                        T = ((wp[:, None] * xl[:, js] * x[:, js]).T
                             @ H.reshape(cols, m * m)).reshape(g, m, m)
                        # x̄_k x_k′ G_jj
                        a = (wp[:, None] * Hjj)[:, :, None] * xl[:, None, :]  # (cols, g, m)
                        T += (a.reshape(cols, g * m).T @ x).reshape(g, m, m)
                        del a
                        # x̄_k x_j G_jk′ and its transpose (conjugate): one product per j
                        for i, j in enumerate(js):
                            T2 = (xl * (wp * x[:, j])[:, None]).T @ H[:, j, :]  # [k, k′]
                            T[i] += T2 + (T2.conj() if conj else T2).T
                        for b in range(3):
                            for bb in range(3):
                                if d[b] + d[bb] == power:
                                    coef = (c[b].conj() if conj else c[b]) * c[bb]
                                    out[:, b, :, bb, :] += (coef * T).real
                    del H
            out *= fp[js][:, None, :, None, None] * fp[js][:, None, None, None, :]
            yield j0, out.reshape(g, 3 * m, 3 * m)

    def star_index(self) -> np.ndarray:
        """``(m, 3m)``: the coordinates of star j (:meth:`star_blocks`), block-major."""
        m, nb = self.m, self.n_params // 3
        pair = np.empty((m, m), dtype=np.intp)
        rows, cols, _ = sym_pairs(m)
        pair[rows, cols] = np.arange(nb)
        pair[cols, rows] = np.arange(nb)
        return np.concatenate([pair + b * nb for b in range(3)], axis=1)

    def product(self, weights: EntryWeights, theta: np.ndarray) -> np.ndarray:
        """The matrix of ``weights`` times ``theta`` ``(n_params,)`` or ``(n_params, k)``."""
        vec = theta.ndim == 1
        th = theta[:, None] if vec else theta
        u = self.apply_jacobian(th)  # (s, n, p, k)
        lft, rgt, diag = weights.left, weights.right, weights.diagonal
        hH = weights.hermitian[..., None]
        hS = None if weights.symmetric is None else weights.symmetric[..., None]
        if lft.size == self.s and np.all(diag) and np.array_equal(lft, np.arange(self.s)):
            # every line with itself once, in order: the weights act line by line
            t = hH * u
            if hS is not None:
                t += np.conj(hS * u)
            del u
            out = self.apply_adjoint(t)
            return out[:, 0] if vec else out
        t = np.zeros_like(u)
        # A v = Re J_lᴴ (h J_r v + conj(t J_r v)); Aᵀ v = Re J_rᴴ (h̄ J_l v + conj(t J_l v))
        np.add.at(t, lft, hH * u[rgt] + (0 if hS is None else np.conj(hS * u[rgt])))
        off = ~diag
        np.add.at(t, rgt[off], np.conj(hH[off]) * u[lft[off]]
                  + (0 if hS is None else np.conj(hS[off] * u[lft[off]])))
        out = self.apply_adjoint(t)
        return out[:, 0] if vec else out


def _pair_sum(fit: LinearisedFit, weights: EntryWeights) -> np.ndarray:
    """Σ_P A_P (unsymmetrised) of :class:`EntryWeights`, dense, ``(n_params,)²``."""
    m, nb = fit.m, fit.n_params // 3
    p = fit.p
    rows, cols, f = sym_pairs(m)
    lft, rgt = weights.left, weights.right
    P = lft.size
    A = np.zeros((3, 3, m, m, m, m))

    def add(h: np.ndarray, conj: bool) -> None:
        # Rᵀ diag(h) R per column, (P, p, m, m), in chunks of lines: (chunk, p, n, m)
        # at a time, never one of every line (n is every measured DOF of a scan)
        ht = h.transpose(0, 2, 1)
        if np.all(ht.imag == 0):
            ht = ht.real
        Q = np.empty((P, p, m, m), dtype=ht.dtype)
        chunk = max(1, PAIR_CHUNK_ELEMENTS // max(1, p * fit.n * m))
        for i in range(0, P, chunk):
            Q[i:i + chunk] = fit.R.T @ (ht[i:i + chunk, ..., None] * fit.R)
        left = fit.Dinv[lft].conj() if conj else fit.Dinv[lft]
        G = left.transpose(0, 2, 1)[:, None] @ Q @ fit.Dinv[rgt][:, None]  # D_l⁻ᴴ Q D_r⁻¹
        xl = fit.x[lft].transpose(0, 2, 1)  # (P, p, m)
        xr = fit.x[rgt].transpose(0, 2, 1)
        XX = (xl.conj() if conj else xl)[:, :, :, None] * xr[:, :, None, :]  # (P, p, j, l)
        Gm = G.reshape(P * p, m * m)
        Xm = XX.reshape(P * p, m * m)
        # φ_b(ω) = c_b ω^d_b: c = (−1, i, 1), d = (2, 1, 0); the coefficient of block
        # pair (b, b′) is c̄_b c_b′ ω_l^d_b ω_r^d_b′ (c_b unconjugated without conj)
        c = np.array([-1.0, 1j, 1.0])
        d = (2, 1, 0)
        cl = c.conj() if conj else c
        wl, wr = np.repeat(fit.w[lft], p), np.repeat(fit.w[rgt], p)
        same = bool(np.all(lft == rgt))
        sums: dict[tuple[int, int], np.ndarray] = {}
        for b in range(3):
            for bb in range(3):
                # on a line with itself only the total power matters: five sums
                key = (0, d[b] + d[bb]) if same else (d[b], d[bb])
                if key not in sums:
                    coef = wl ** key[0] * wr ** key[1]
                    T = (Gm * coef[:, None]).T @ Xm  # [ik, jl]
                    sums[key] = T.reshape(m, m, m, m).transpose(0, 2, 1, 3)  # [i, j, k, l]
                A[b, bb] += (cl[b] * c[bb] * sums[key]).real

    add(weights.hermitian.astype(np.complex128), conj=True)
    if weights.symmetric is not None:
        add(weights.symmetric.astype(np.complex128), conj=False)
    N = np.empty((3 * nb, 3 * nb))
    ff = f[:, None] * f[None, :]
    for b in range(3):
        for bb in range(3):
            S = A[b, bb] + A[b, bb].transpose(1, 0, 2, 3)
            S = S + S.transpose(0, 1, 3, 2)
            N[b * nb:(b + 1) * nb, bb * nb:(bb + 1) * nb] = ff * S[rows, cols][:, rows, cols]
    return N


def gauss_newton_matrix(fit: LinearisedFit, weights: EntryWeights) -> np.ndarray:
    """The matrix of ``weights`` (:class:`EntryWeights`), dense, ``(n_params,)²``.

    In the entries of Z = [M̃ C̃ K̃] each pair's term is a Kronecker product,
    A[(b, i, j), (b′, k, l)] = Re Σ_P φ̄_b(ω_l) φ_b′(ω_r) G_P[i, k] x̄_{l,j} x_{r,l}
    with G_P = D_l⁻ᴴ Rᵀ diag(h_P) R D_r⁻¹ (and Re Σ_P φ_b φ_b′ G̃_P[i, k] x_j x_l with
    G̃_P = D_l⁻ᵀ Rᵀ diag(t_P) R D_r⁻¹): for each of the nine block pairs one matrix
    product of (m² × columns) by (columns × m²); then each block is taken to the
    symmetric coordinates. Pairs of distinct lines count as (l, r) and (r, l).
    """
    diag = weights.diagonal

    def part(keep: np.ndarray) -> np.ndarray:
        return _pair_sum(fit, EntryWeights(
            weights.left[keep], weights.right[keep], weights.hermitian[keep],
            None if weights.symmetric is None else weights.symmetric[keep]))

    N = part(diag)
    N = 0.5 * (N + N.T)
    if not np.all(diag):
        off = part(~diag)
        N = N + off + off.T
    return N


# ---------------------------------------------------------------------- the noise


def check_variance(v: object, shape: tuple[int, int, int]) -> np.ndarray:
    """``noise_variance`` as ``(s, n, p)``: a scalar, per line ``(s,)``, per line and DOF
    ``(s, n)`` or per entry ``(s, n, p)``; finite and non-negative."""
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"noise_variance must be a real array, got {v!r}") from None
    if np.any(np.isnan(a)):
        raise ValueError("noise_variance contains NaN")
    if np.any(~np.isfinite(a)):
        raise ValueError("noise_variance contains inf")
    if np.any(a < 0):
        raise ValueError(f"noise_variance must be non-negative (found {a.min():.3g})")
    s, n, p = shape
    if a.ndim == 0:
        return np.full(shape, float(a))
    if a.shape == (s,):
        return np.broadcast_to(a[:, None, None], shape).copy()
    if a.shape == (s, n):
        return np.broadcast_to(a[:, :, None], shape).copy()
    if a.shape == (s, n, p):
        return a.copy()
    raise ValueError(
        f"noise_variance must be a scalar, (s,) = ({s},), (s, n) = ({s}, {n}) or "
        f"(s, n, p) = ({s}, {n}, {p}), got shape {a.shape}"
    )


def h1_variance(H: np.ndarray, coherence: object, averages: object) -> np.ndarray:
    """Variance E|δĤ|² of H1 estimates from their coherence and number of averages.

    Bendat & Piersol (*Random Data*, §9.2.2): the normalised random error of |Ĥ| and
    the random error of its phase (radians) are each ε = √(1 − γ²)/(|γ|√(2 n_d)), so
    the complex estimate scatters by 2ε²|Ĥ|² = |Ĥ|²(1 − γ²)/(γ² n_d) — a large-n_d
    form: for Gaussian data, conditional on the input the error's variance is
    G_nn / Σ|X|², and the mean of the inverse of n_d averaged input powers is
    1/((n_d − 1) G_xx), so |Ĥ|²(1 − γ²)/(γ² (n_d − 1)) is used (n_d > 1; one average
    has coherence 1 and says nothing of the noise). Exact for one input (ordinary
    coherence); with several, give each entry's partial coherence. ``H`` and
    ``coherence`` are ``(s, n, p)`` (or ``(s, n)`` for coherence).

    Raises ``ValueError`` for a coherence outside [0, 1] or NaN, or averages ≤ 1.
    """
    g = np.asarray(coherence, dtype=np.float64)
    if np.any(np.isnan(g)):
        raise ValueError("coherence contains NaN")
    if np.any((g < 0) | (g > 1)):
        bad = g[(g < 0) | (g > 1)]
        raise ValueError(f"coherence must lie in [0, 1] (γ², found {bad.flat[0]:.3g})")
    if g.shape == H.shape[:2]:
        g = np.broadcast_to(g[:, :, None], H.shape)
    if g.shape != H.shape:
        raise ValueError(f"coherence must have shape (s, n) or (s, n, p) = {H.shape}, "
                         f"got {g.shape}")
    if isinstance(averages, bool) or not np.isscalar(averages):
        raise ValueError(f"averages must be a number, got {averages!r}")
    nd = float(averages)
    if not np.isfinite(nd) or nd <= 1:
        raise ValueError(f"averages must be more than 1 (the number of averaged segments; one "
                         f"has coherence 1 whatever the noise), got {averages!r}")
    g = np.maximum(g, COHERENCE_FLOOR)
    return np.abs(H) ** 2 * (1 - g) / (g * (nd - 1))


def _local_floor_and_proportional(
    e2: np.ndarray, y2: np.ndarray, used: np.ndarray, half: int
) -> np.ndarray:
    """Per entry ``(s, n, p)``, the variance a + b|ŷ|² fitted to the squared residuals
    ``e2`` of the ``half`` lines on each side (fewer at the ends), a, b ≥ 0.

    A complex Gaussian residual's |e|² has mean v and standard deviation v: a and b
    are the maximum-likelihood fit of v = a + b|ŷ|² (``y2``) to the window's |e|² by
    Fisher scoring — least squares weighted by 1/v², ``LOCAL_ITERATIONS`` times, from a
    constant v. Where |ŷ|² barely changes over the window (a quiet stretch) a and b are
    not told apart and the window's weighted mean is taken (b = 0).
    """
    s, shape = e2.shape[0], e2.shape
    entries = int(np.prod(shape[1:]))
    block = max(1, LOCAL_CHUNK_ELEMENTS // (2 * half + 1))  # one line of a block fits
    if entries > block:  # entries are independent: a block of them at a time
        flat = [a.reshape(s, entries) for a in (e2, y2, used)]
        out = np.empty((s, entries))
        for lo in range(0, entries, block):
            cols = slice(lo, lo + block)
            out[:, cols] = _local_floor_and_proportional(*(a[:, cols] for a in flat), half)
        return out.reshape(shape)
    out = np.empty_like(e2)
    rest = int(np.prod(e2.shape[1:]))
    chunk = max(1, LOCAL_CHUNK_ELEMENTS // max(1, rest * (2 * half + 1)))
    pad = [(half, half)] + [(0, 0)] * (e2.ndim - 1)
    # |ŷ|² over its channel's RMS: the sums below then stay near 1 whatever the units
    ref = np.sqrt(np.mean(np.where(used, y2, 0.0) ** 2, axis=0, keepdims=True))
    x_all = np.pad(np.where(used, y2, 0.0) / np.where(ref > 0, ref, 1.0), pad)
    y_all = np.pad(np.where(used, e2, 0.0), pad)
    u_all = np.pad(used.astype(float), pad)
    for start in range(0, s, chunk):
        stop = min(s, start + chunk)
        win = slice(start, stop + 2 * half)
        # (lines, n, p, 2·half + 1): each line's window, a view
        x = np.lib.stride_tricks.sliding_window_view(x_all[win], 2 * half + 1, axis=0)
        y = np.lib.stride_tricks.sliding_window_view(y_all[win], 2 * half + 1, axis=0)
        u = np.lib.stride_tricks.sliding_window_view(u_all[win], 2 * half + 1, axis=0)
        x0 = x_all[start + half:stop + half]
        n_used = np.maximum(u.sum(axis=-1), 1.0)
        a = (u * y).sum(axis=-1) / n_used
        b = np.zeros_like(a)
        for _ in range(LOCAL_ITERATIONS):
            v = a[..., None] + b[..., None] * x
            scale = np.where(v > 0, v, 1.0)
            w = u / scale**2
            s0, s1, s2 = w.sum(-1), (w * x).sum(-1), (w * x * x).sum(-1)
            t0, t1 = (w * y).sum(-1), (w * x * y).sum(-1)
            det = s0 * s2 - s1 * s1
            tied = det <= 1e-9 * s0 * s2  # |ŷ|² about constant over the window
            safe = np.where(tied, 1.0, det)
            a_new = np.where(tied, t0 / np.maximum(s0, 1e-300), (s2 * t0 - s1 * t1) / safe)
            b_new = np.where(tied, 0.0, (s0 * t1 - s1 * t0) / safe)
            # a boundary optimum: the floor alone or the proportional part alone
            only_b = (t1 / np.maximum(s2, 1e-300))
            only_a = t0 / np.maximum(s0, 1e-300)
            a_new, b_new = (np.where(a_new < 0, 0.0, np.where(b_new < 0, only_a, a_new)),
                            np.where(a_new < 0, only_b, np.where(b_new < 0, 0.0, b_new)))
            a, b = np.maximum(a_new, 0.0), np.maximum(b_new, 0.0)
        out[start:stop] = a + b * x0
    return out


def residual_variance(
    fit: LinearisedFit, rank: int, model: NoiseModel = "channel"
) -> tuple[np.ndarray, int]:
    """Noise variance per entry ``(s, n, p)`` estimated from the residuals ŷ − u.

    ``"local"``: per measured DOF and load case, and per line from its neighbours: a floor
    and a part proportional to the response, v = a + b|ŷ|² (a, b ≥ 0), fitted to the
    squared residuals of the ``LOCAL_HALF_WIDTH`` fitted lines on each side
    (:func:`_local_floor_and_proportional`) — the two parts of H1's random error, the
    output noise's (G_nn/G_xx: no |H| in it) and a steady coherence's (∝ |H|²), each
    free to change along the band. One variance per channel would take a resonance's
    squared residuals, 10⁴–10⁸ times a quiet stretch's at light damping, as the noise
    of every line. ``"channel"``: one variance per measured DOF and load case over the lines;
    ``"line"``: one per line over the entries; ``"global"``: one for all. Entries of
    weight 0 did not take part in the fit and are left out. The residuals have
    2·entries − ``rank`` real degrees of freedom: every mean square is scaled by
    2·entries / (2·entries − rank). Returns the variances and those degrees of
    freedom.
    """
    e2 = np.abs(fit.residuals()) ** 2
    used = fit.W > 0
    n_used = int(used.sum())
    dof = 2 * n_used - rank
    if dof <= 0:
        raise ValueError(
            f"the residuals have no degrees of freedom left ({n_used} complex entries, "
            f"{rank} parameters): give noise_variance or coherence"
        )
    scale = 2 * n_used / dof
    e2 = np.where(used, e2, 0.0)
    if model == "local":
        y2 = np.abs(fit.y * fit.su) ** 2
        v = _local_floor_and_proportional(e2, y2, used, LOCAL_HALF_WIDTH)
    elif model == "channel":
        count = np.maximum(used.sum(axis=0, keepdims=True), 1)
        v = e2.sum(axis=0, keepdims=True) / count
    elif model == "line":
        count = np.maximum(used.sum(axis=(1, 2), keepdims=True), 1)
        v = e2.sum(axis=(1, 2), keepdims=True) / count
    elif model == "global":
        v = np.array(e2.sum() / max(n_used, 1)).reshape(1, 1, 1)
    else:
        raise ValueError(f"noise must be 'local', 'channel', 'line' or 'global', got {model!r}")
    return np.broadcast_to(v * scale, e2.shape).copy(), dof


def entry_weights(
    weights: object, U: np.ndarray, objective: Objective, observed_basis: bool
) -> np.ndarray:
    """Per-entry weights ``(s, n, p)`` of the cost :func:`~podid_rs.refine` minimised.

    ``"relative"``: 1/‖u_c‖ per column (complex objective), 1 per entry
    (log-magnitude); ``"uniform"``: 1; an array ``(s,)``, ``(s, p)``, ``(s, n)`` or
    ``(s, n, p)`` (the last two only on measured DOFs, ``observed_basis``). The
    log-magnitude objective leaves out entries with u = 0 or beyond its dynamic range
    (:data:`~podid_rs.identification.refinement.LOG_DYNAMIC_RANGE`).
    """
    s, n, p = U.shape
    if isinstance(weights, str):
        if weights not in ("relative", "uniform"):
            raise ValueError(f"weights must be 'relative', 'uniform' or an array, got {weights!r}")
        if weights == "relative" and objective == "complex":
            norms = np.linalg.norm(U, axis=1)  # (s, p)
            w = np.zeros_like(norms)
            w[norms > 0] = 1.0 / norms[norms > 0]
            W = np.broadcast_to(w[:, None, :], U.shape).copy()
        else:
            W = np.ones(U.shape)
    else:
        a = as_array(weights, "weights", real=True)
        if np.any(a < 0):
            raise ValueError(f"weights must be non-negative (found {a.min():.3g})")
        if a.shape == (s,):
            W = np.broadcast_to(a[:, None, None], U.shape).copy()
        elif a.shape == (s, p) and (a.shape != (s, n) or not observed_basis):
            W = np.broadcast_to(a[:, None, :], U.shape).copy()
        elif observed_basis and a.shape == (s, n):
            W = np.broadcast_to(a[:, :, None], U.shape).copy()
        elif observed_basis and a.shape == (s, n, p):
            W = a
        else:
            raise ValueError(f"weights must have shape (s,), (s, p), or per measured entry "
                             f"(s, n) / (s, n, p), got {a.shape}")
    if objective == "log-magnitude":
        # as refine: entries beyond any dynamic range (LOG_DYNAMIC_RANGE below the largest
        # of their line and load case) and zeros are left out
        A = np.abs(U)
        W = np.where(A > LOG_DYNAMIC_RANGE * A.max(axis=1, keepdims=True), W, 0.0)
    if not np.any(W > 0):
        raise ValueError("weights are all zero: there is nothing fitted")
    return W


# ---------------------------------------------------------------------- the covariance

#: directions of the Gauss–Newton matrix (scaled to unit diagonal) whose eigenvalue is
#: below this fraction of the largest are not determined by the data
RANK_RTOL = 1e-11
#: a derived quantity has no variance when its component along the undetermined directions,
#: were they determined at the rank threshold, would add more than this fraction to the
#: variance its determined part gives: it depends on what the data do not fix
UNDETERMINED_SHARE = 1.0


class DenseCovariance:
    """cov θ̂ = N⁺ S N⁺ from dense N and S, with the undetermined directions found.

    N is scaled to unit diagonal and eigendecomposed; eigenvalues at or below
    ``rtol`` times the largest span the directions the data do not determine (the
    gauge of latent coordinates, or a rank deficiency), on which N⁺ is zero. The
    meat S is given after (:meth:`set_meat`): estimating the noise from the residuals
    needs the rank first.

    Parameters
    ----------
    N : numpy.ndarray
        The Gauss–Newton matrix of the fitted cost, ``(q, q)``.
    rtol : float
        The rank threshold.

    Attributes
    ----------
    rank : int
        The number of determined directions.
    covariance : numpy.ndarray
        ``(q, q)`` N⁺ S N⁺ (after :meth:`set_meat`).
    """

    def __init__(self, N: np.ndarray, rtol: float = RANK_RTOL) -> None:
        d = np.sqrt(np.maximum(np.diag(N), 0.0))
        d[d == 0] = 1.0
        lam, V = np.linalg.eigh(N / d[:, None] / d[None, :])
        top = max(float(lam[-1]), np.finfo(float).tiny)
        keep = lam > rtol * top
        self.rank = int(keep.sum())
        self.eigenvalues = lam / top
        self._scale = d
        self._null = V[:, ~keep]  # undetermined directions (unit-diagonal coordinates)
        self._floor = rtol * top  # the rank threshold, in the eigenvalues' units
        # N⁺ = B Bᵀ with B = V_k Λ_k^-½ in the original coordinates
        self._half = V[:, keep] / np.sqrt(lam[keep]) / d[:, None]
        self.covariance = np.zeros_like(N)

    def column_blocks(self, count: int) -> list[np.ndarray]:
        """The right-hand sides of ``count`` to give at once: all (the covariance is
        formed)."""
        return [np.arange(count)]

    def set_meat(self, S: np.ndarray) -> None:
        """Form N⁺ S N⁺ for the meat S ``(q, q)``."""
        B = self._half
        core = B.T @ S @ B
        self.covariance = B @ core @ B.T
        self.covariance = 0.5 * (self.covariance + self.covariance.T)

    def undetermined(self, G: np.ndarray) -> np.ndarray:
        """Whether each row g of ``G`` ``(k, q)`` depends on an undetermined direction.

        Its component along them, were they determined at the rank threshold (they are
        less), would add Σ (vᵀg)²/threshold to gᵀN⁺g; undetermined when that exceeds
        ``UNDETERMINED_SHARE`` times gᵀN⁺g. Not the component's bare size: where N's
        eigenvalues fall off without a gap (a measured beam: 683 of 2340 below 10⁻¹¹ of
        the largest, 1075 below 10⁻⁹) the computed null vectors mix with their
        neighbours above the threshold at 10⁻⁵–10⁻⁴ of a structural mode's gradient,
        which then adds 0.4–20 % of its variance (median 1 %, the imaginary parts of
        its eigenvalues) — and a gauge (an eigenvalue 0) or a rank deficiency still
        adds without bound."""
        G = np.atleast_2d(G)
        if not self._null.shape[1]:
            return np.zeros(G.shape[0], dtype=bool)
        Gs = G / self._scale  # the gradient in unit-diagonal coordinates
        bound = np.sum((Gs @ self._null) ** 2, axis=1) / self._floor
        determined = np.sum((G @ self._half) ** 2, axis=1)
        return bound > UNDETERMINED_SHARE * determined

    def covariances(self, G: np.ndarray, H: np.ndarray) -> np.ndarray:
        """gᵀ cov h of the rows of ``G`` and ``H`` ``(k, q)``; NaN where either has a
        component along an undetermined direction."""
        G, H = np.atleast_2d(G), np.atleast_2d(H)
        out = np.sum((G @ self.covariance) * H, axis=1)  # a product, not einsum's loops
        return np.where(self.undetermined(G) | self.undetermined(H), np.nan, out)

    def variances(self, G: np.ndarray) -> np.ndarray:
        """Variances gᵀ cov g of the rows of ``G`` ``(k, q)``; NaN for a row with a
        component along an undetermined direction."""
        return np.maximum(self.covariances(G, G), 0.0)

    def pair_moments(self, G: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, ...]:
        """(var g, var h, cov(g, h)) of the rows of ``G`` and ``H``, e.g. the real and
        imaginary parts of complex quantities — as :meth:`variances` and
        :meth:`covariances` give them, with each product and each test for undetermined
        directions done once."""
        G, H = np.atleast_2d(G), np.atleast_2d(H)
        GC = G @ self.covariance
        var_g = np.maximum(np.sum(GC * G, axis=1), 0.0)
        var_h = np.maximum(np.sum((H @ self.covariance) * H, axis=1), 0.0)
        cov = np.sum(GC * H, axis=1)
        und_g, und_h = self.undetermined(G), self.undetermined(H)
        return (np.where(und_g, np.nan, var_g), np.where(und_h, np.nan, var_h),
                np.where(und_g | und_h, np.nan, cov))


#: relative residual (unit-diagonal coordinates) at which the matrix-free solves stop, and
#: their iteration cap. A variance's error goes as its square: on a chain at m = 40 the
#: modes' standard deviations moved by 3e-8 / 4e-9 / 4e-10 relative at 1e-5 / 1e-6 / 1e-7
#: against 1e-8, in 20 / 22 / 24 / 26 iterations
CG_TOL = 1e-6
CG_MAX_ITER = 2000
#: restarts of block CG from the true residual when the recurrence's has drifted
CG_RESTARTS = 3
#: memory (bytes) of block CG's blocks: the right-hand sides that share one block Krylov
#: space are as many as make CG_LIVE_BLOCKS blocks of n_params × them in this, at least
#: CG_BLOCK_MIN (the right-hand sides, the solution, the residual, the search block, N
#: times it and the preconditioned residual are alive at once). A larger block needs
#: fewer products per right-hand side (chain, m = 60, the modes' 120 gradients: 33
#: iterations in one block, 46 in two, 55 in three — 5.5, 7.9 and 9.0 s) but its memory
#: grows with it: at m = 100, 200 lines, this is 5 blocks of 40 of the modes' 200
#: gradients (and 7 of 29 of the band's draws, beside the draws kept), within the
#: refinement's peak memory
CG_BLOCK_BYTES = 32 << 20
CG_LIVE_BLOCKS = 6
CG_BLOCK_MIN = 16
#: a search direction of block CG whose Rayleigh quotient of N (unit diagonal) is below
#: this fraction of the largest seen lies along N's null space (a gauge) and is dropped
NULL_RTOL = 1e-14
#: added to the stars' blocks of N (unit diagonal) before they are inverted: a gauge
#: leaves them singular, and its directions must not dominate their inverse (1e-10
#: did, and CG stalled; 1e-6 takes as few iterations as 1e-8 on a chain at m = 40)
STAR_RIDGE = 1e-6
#: complex numbers of each per-line intermediate of a product with N or S (s·m·p per
#: column): the columns of one product (:meth:`LinearisedFit.product_columns`; 6 at
#: m = 100, 200 lines, where 16 columns' intermediates had held 40 MB at once)
PRODUCT_ELEMENTS = 1 << 17
#: draws of the matrix-free path's sampled covariance (FRF bands), and their seed
SAMPLES = 200
SAMPLES_SEED = 20261125
#: draws of the noise formed at once (its memory: lines × n × p of them)
SAMPLE_CHUNK = 16


def _orthonormal(Y: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """An orthonormal basis of the columns of ``Y`` (pivoted QR), without the directions
    below ``rtol`` of the largest: the search block of breakdown-free block CG. (Unpivoted
    QR is twice as fast on 15 150 × 200, but a small diagonal entry of R there does not
    mark a direction the later columns do without.) ``Y`` is overwritten: when it is
    Fortran-ordered, the basis is formed in its memory."""
    if Y.shape[1] == 0:
        return Y
    Q, Rf, _ = scipy.linalg.qr(Y, mode="economic", pivoting=True, overwrite_a=True)
    d = np.abs(np.diag(Rf))
    if d.size == 0 or d[0] == 0:
        return Y[:, :0]
    return Q[:, :int(np.sum(d > rtol * d[0]))]


def _column_norms(A: np.ndarray) -> np.ndarray:
    """The 2-norm of each column of ``A``, without a temporary of A's size."""
    return np.sqrt(np.einsum("ij,ij->j", A, A))


def _add_product(C: np.ndarray, A: np.ndarray, B: np.ndarray, alpha: float) -> None:
    """C += alpha · A B in place: BLAS's gemm with beta = 1 when C is Fortran-ordered, so
    that no block of C's size is formed (A B would be one)."""
    if C.flags.f_contiguous and C.dtype == np.float64 and C.size:
        out = scipy.linalg.blas.dgemm(alpha, A, B, beta=1.0, c=C, overwrite_c=True)
        if out is not C and not np.shares_memory(out, C):  # pragma: no cover - f2py copied
            C[...] = out
    else:
        C += alpha * (A @ B)


def _inverse_factor(block: np.ndarray) -> np.ndarray:
    """F lower triangular with Fᵀ F = (B + STAR_RIDGE·I)⁻¹, B the block scaled to unit
    diagonal: F = C⁻¹ for the Cholesky factor C of B + ridge (more ridge, tenfold at a time,
    where it is not numerically positive definite). Kept in single precision, Fᵀ F stays
    symmetric positive definite whatever its rounding: the preconditioner CG needs."""
    d = np.sqrt(np.maximum(np.diagonal(block), np.finfo(float).tiny))
    scaled = block / d[:, None] / d[None, :]
    scaled = 0.5 * (scaled + scaled.T)
    eye = np.eye(scaled.shape[0])
    ridge = STAR_RIDGE
    while True:
        try:
            C = np.linalg.cholesky(scaled + ridge * eye)
            break
        except np.linalg.LinAlgError:
            ridge *= 10.0
    return scipy.linalg.solve_triangular(C, eye, lower=True)


def pack_hermitian(G: np.ndarray) -> np.ndarray:
    """Hermitian matrices ``(..., m, m)`` as the real P = Re G + Im G (half the memory):
    Re G = (P + Pᵀ)/2, Im G = (P − Pᵀ)/2 (:meth:`LinearisedFit.gram_product`)."""
    return G.real + G.imag


class MatrixFreeCovariance:
    """cov θ̂ = N⁻¹ S N⁻¹ applied by solves with N: only the variances asked for.

    Every variance gᵀ N⁻¹ S N⁻¹ g is a solve N a = g and one product S a. The
    solves are breakdown-free block preconditioned CG (Ji & Li 2017): right-hand
    sides share one Krylov space, as many as ``CG_BLOCK_BYTES`` holds (:meth:`column_blocks`),
    whose search block is re-orthonormalised every iteration (directions below 1e-10 of
    the largest dropped). The products apply N line by line through its per-line m × m
    matrices (:meth:`LinearisedFit.line_grams`, Hermitian: formed packed, half the memory
    of D⁻¹); the per-line inverses D⁻¹ are not kept (a fit made with
    ``keep_inverses=False`` never holds them, another's are released here): the products
    with the meat and the noise's draws solve per line instead. The preconditioner is
    additive Schwarz on the stars of coordinates: star j holds the symmetric coordinates
    (j, k) of M, C and K for every k, 3m of them, and N's block there
    (:meth:`LinearisedFit.star_block_groups`) is inverted — in the model's undamped modal
    coordinates, where a mode's data bear mostly on its own row of M, C, K; every
    coordinate lies in two stars. Each inverse is kept as a triangular factor F (Fᵀ F, the
    inverse; :func:`_inverse_factor`) in single precision, two to a (3m + 1) × 3m array,
    one in its lower triangle and one in its upper, applied by BLAS's trmm (a quarter of
    the inverses' memory; Fᵀ F is positive definite whatever F's rounding, and the
    solves' accuracy is the tolerance's). All of it in coordinates scaled to N's unit
    diagonal, where the tolerance is taken. Measured on chains (random forces, 200
    lines, the modes' 2m gradients): at m = 40 one CG per right-hand side with the
    inverted 3 × 3 (M, C, K) blocks per coordinate needed 254 iterations (median; up
    to 330), block CG 40 with them and 26 with the stars; at m = 100, 281 and 152 per
    block of 100.

    N is singular along a gauge (latent coordinates); g orthogonal to it (every
    gauge-invariant quantity) lies in N's range, and S shares N's null space, so
    aᵀ S a does not depend on which solution CG finds. Search directions along which
    N vanishes are dropped, and where the recurrence's residual has drifted from the
    true one CG restarts from the latter. A solve that does not reach ``tol`` gives
    NaN, with a :class:`~podid_rs.ConvergenceWarning`.

    Parameters
    ----------
    fit : LinearisedFit
        The linearised fit (its inverses D⁻¹, if it holds them, are released here).
    rank : int
        The determined directions (n_params less the gauge): not measured here.
    tol : float
        Relative residual of the solves.

    Attributes
    ----------
    rank : int
        As given.
    iterations : list of int
        Block CG iterations of every block solved so far.
    """

    def __init__(self, fit: LinearisedFit, rank: int, tol: float = CG_TOL) -> None:
        self.fit = fit
        self.rank = int(rank)
        self.tol = float(tol)
        self.bread = fit.bread()
        m, q = fit.m, fit.n_params
        release_free_memory()  # what earlier work (a refinement) freed: not held meanwhile
        with _one_blas_thread():  # as the solves: OpenBLAS's threads only contend
            # N is the cost's: line by line, packed as it is formed
            self._grams = fit.line_grams(self.bread, packed=True)
            fit.release_inverses()
            # additive Schwarz on the stars, in coordinates scaled to N's unit diagonal:
            # a group of stars' blocks at a time, each factored and stored in its half
            self._star_index = fit.star_index()
            n3 = 3 * m
            self._star_pairs = np.zeros(((m + 1) // 2, n3 + 1, n3), dtype=np.float32)
            lower = np.tri(n3, dtype=bool)
            diag = np.zeros(q)
            for j0, blocks in fit.star_block_groups(self._grams):
                for j, block in enumerate(blocks, start=j0):
                    diag[self._star_index[j]] = np.diagonal(block)
                    factor = _inverse_factor(block)
                    pair = self._star_pairs[j // 2]
                    if j % 2 == 0:
                        np.copyto(pair[1:], factor, where=lower)
                    else:
                        np.copyto(pair[:-1], factor.T, where=lower.T)
                del blocks
        self._diag_scale = np.sqrt(np.maximum(diag, np.finfo(float).tiny))
        release_free_memory()  # the setup's: D⁻¹, G unpacked, the stars' blocks
        self.meat: EntryWeights | None = None
        self.iterations: list[int] = []

    def set_meat(self, meat: EntryWeights) -> None:
        """The noise's weights (the sandwich's meat)."""
        self.meat = meat

    def column_blocks(self, count: int, held: int = 0) -> list[np.ndarray]:
        """The right-hand sides of ``count`` that one block CG solves together: blocks of
        equal size (a small remainder would share a poor Krylov space), each within
        ``CG_BLOCK_BYTES`` less ``held`` bytes (what the caller keeps meanwhile, e.g. the
        draws solved so far). Callers that form right-hand sides (the modes' gradients,
        the noise's draws) form one block at a time."""
        most = max(CG_BLOCK_MIN, (CG_BLOCK_BYTES - held)
                   // (CG_LIVE_BLOCKS * 8 * self.fit.n_params))
        parts = np.array_split(np.arange(count), max(1, -(-count // most)))
        return [cols for cols in parts if cols.size]

    def _precondition(self, r: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The preconditioner on residuals ``(n_params, k)`` in the unit-diagonal
        coordinates: the sum over the stars of the inverse of N's block on star j
        (additive Schwarz). Fortran-ordered; into ``out`` when given."""
        if out is None:
            z = np.zeros(r.shape, order="F")
        else:
            z = out
            z[...] = 0.0
        trmm = scipy.linalg.blas.dtrmm
        for j in range(self.fit.m):
            idx = self._star_index[j]
            pair = self._star_pairs[j // 2]
            # star 2i's factor F in the lower triangle of pair[1:], star 2i + 1's Fᵀ in the
            # upper of pair[:-1]; transposed (Fortran-ordered) the triangles swap. The
            # block's inverse is Fᵀ F: z = Fᵀ (F r), two triangular products
            if j % 2 == 0:
                a = pair[1:].T.astype(np.float64)  # upper: Fᵀ
                y = trmm(1.0, a, r[idx], lower=0, trans_a=1)
                z[idx] += trmm(1.0, a, y, lower=0, trans_a=0, overwrite_b=1)
            else:
                a = pair[:-1].T.astype(np.float64)  # lower: F
                y = trmm(1.0, a, r[idx], lower=1, trans_a=0)
                z[idx] += trmm(1.0, a, y, lower=1, trans_a=1, overwrite_b=1)
        return z

    def _apply(self, weights: EntryWeights, V: np.ndarray) -> np.ndarray:
        """The matrix of ``weights`` times ``V`` ``(n_params, k)``, a few columns at a time
        (:meth:`LinearisedFit.product_columns`; Fortran-ordered)."""
        out = np.empty(V.shape, order="F")
        step = self.fit.product_columns()
        for i in range(0, V.shape[1], step):
            cols = V[:, i:i + step]
            if weights is self.bread:
                out[:, i:i + step] = self.fit.gram_product(self._grams, cols)
            else:
                out[:, i:i + step] = self.fit.product(weights, cols)
        return out

    def _apply_scaled(self, V: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """N in the unit-diagonal coordinates times ``V``: D⁻¹ N D⁻¹ V (D the diagonal
        scale), a few columns at a time (no scaled copy of V); into ``out`` when given."""
        d = self._diag_scale[:, None]
        if out is None:
            out = np.empty(V.shape, order="F")
        step = self.fit.product_columns()
        for i in range(0, V.shape[1], step):
            cols = slice(i, i + step)
            out[:, cols] = self.fit.gram_product(self._grams, V[:, cols] / d)
            out[:, cols] /= d
        return out

    def solve(self, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """N X = B for ``B`` ``(n_params, k)`` by block preconditioned CG, in the blocks
        of :meth:`column_blocks`; returns X and whether each column reached the
        tolerance (a :class:`~podid_rs.ConvergenceWarning` for those that did not)."""
        blocks = self.column_blocks(B.shape[1])
        with _one_blas_thread():  # small products: OpenBLAS's threads only contend
            if len(blocks) == 1:  # (no second copy of the solution)
                X, ok, res = self._solve(B)
            else:
                X = np.empty(B.shape, order="F")
                ok = np.zeros(B.shape[1], dtype=bool)
                res = np.zeros(B.shape[1])
                for cols in blocks:
                    X[:, cols], ok[cols], res[cols] = self._solve(B[:, cols])
        self._warn_unsolved(ok, res, "their variances are NaN")
        return X, ok

    def _warn_unsolved(self, ok: np.ndarray, res: np.ndarray, what: str) -> None:
        if not ok.all():
            bad = ~ok
            worst = float(np.max(res[bad]))  # NaN where the solve itself gave NaN
            warnings.warn(ConvergenceWarning(
                f"{int(bad.sum())} of {ok.size} matrix-free solves with the Gauss–Newton "
                f"matrix did not reach the relative residual {10 * self.tol:g} in "
                f"{CG_MAX_ITER} iterations and {CG_RESTARTS} restarts (the worst at "
                f"{worst:.2g}): {what}"), stacklevel=3)

    def _solve(self, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # in coordinates scaled to N's unit diagonal (d): there N's eigenvalues span what
        # the data determine (the dense path's rank threshold is taken there too), not
        # the ω⁴ between M and K as well. Every block n_params × k is Fortran-ordered:
        # the QR of the search block and the updates are then done in place
        d = self._diag_scale[:, None]
        R = np.divide(B, d, out=np.empty(B.shape, order="F"))
        norm_b = _column_norms(R)
        scale = np.where(norm_b > 0, norm_b, 1.0)
        R /= scale  # unit columns: one tolerance and one rank threshold for all
        X = np.zeros(B.shape, order="F")
        # the search block, N times it and the preconditioned residual: three blocks
        # allocated once and reused by every iteration (no churn of the heap)
        work = [np.empty(B.shape, order="F") for _ in range(3)]
        it = 0
        for _ in range(CG_RESTARTS + 1):
            it = self._iterate(X, R, it, work)
            # the recurrence's residual drifts from the true one where the search
            # directions are large along N's null space (a gauge): restart from the latter
            self._apply_scaled(X, out=R)
            R *= -1.0
            for i in range(0, B.shape[1], self.fit.product_columns()):
                cols = slice(i, i + self.fit.product_columns())
                R[:, cols] += B[:, cols] / d / scale[cols]
            res = _column_norms(R)
            if np.all(res <= 10 * self.tol) or it >= CG_MAX_ITER:
                break
        del R, work
        release_free_memory()  # the block's: the next block's are taken anew
        self.iterations.append(it)
        X /= d
        X *= scale
        return X, (res <= 10 * self.tol) & np.all(np.isfinite(X), axis=0), res

    def _iterate(self, X: np.ndarray, R: np.ndarray, it: int, work: list[np.ndarray]) -> int:
        """Block CG from X with residual R (both updated in place), unit-diagonal
        coordinates, in the three blocks ``work`` (X's shape, Fortran-ordered); returns
        the iteration count so far."""
        here, there, image = work  # the search block is formed in place of Z: they swap
        P = _orthonormal(self._precondition(R, out=here))
        top = 0.0
        while P.shape[1] and it < CG_MAX_ITER:
            it += 1
            Q = self._apply_scaled(P, out=image[:, :P.shape[1]])
            PQ = P.T @ Q
            lam, V = np.linalg.eigh(0.5 * (PQ + PQ.T))
            top = max(top, float(lam[-1]) if lam.size else 0.0)
            # (PᵀNP)⁺ without the directions along which N vanishes (a gauge); not P
            # rotated, which would hold two more blocks at once
            keep = lam > NULL_RTOL * top
            if not keep.any():
                break
            inverse = (V[:, keep] / lam[keep]) @ V[:, keep].T
            alpha = inverse @ (P.T @ R)
            _add_product(X, P, alpha, 1.0)
            _add_product(R, Q, alpha, -1.0)
            if np.all(_column_norms(R) <= self.tol):
                break
            Z = self._precondition(R, out=there)
            _add_product(Z, P, inverse @ (Q.T @ Z), -1.0)
            del P, Q
            P = _orthonormal(Z)  # in Z's memory
            del Z
            here, there = there, here
        return it

    def undetermined(self, G: np.ndarray) -> np.ndarray:
        """Not measured on this path: all False."""
        return np.zeros(np.atleast_2d(G).shape[0], dtype=bool)

    def covariances(self, G: np.ndarray, H: np.ndarray) -> np.ndarray:
        """gᵀ N⁻¹ S N⁻¹ h of the rows of ``G`` and ``H`` ``(k, q)``; NaN where a solve
        did not converge (with a :class:`~podid_rs.ConvergenceWarning`)."""
        G, H = np.atleast_2d(G), np.atleast_2d(H)
        same = G is H or (G.shape == H.shape and np.array_equal(G, H))
        a, ok_a = self.solve(G.T)
        b, ok_b = (a, ok_a) if same else self.solve(H.T)
        with _one_blas_thread():
            Sb = self._apply(self.meat, b)
        return np.where(ok_a & ok_b, np.einsum("ij,ij->j", a, Sb), np.nan)

    def variances(self, G: np.ndarray) -> np.ndarray:
        """Variances gᵀ cov g of the rows of ``G`` ``(k, q)`` (NaN where not solved)."""
        return np.maximum(self.covariances(G, G), 0.0)

    def set_noise(self, variance: np.ndarray, correlation: tuple[float, ...]) -> None:
        """The noise the meat came from, for :meth:`pair_moments`' draws."""
        self._noise = (variance, correlation)
        self._draws: np.ndarray | None = None

    def draws(self) -> np.ndarray:
        """``SAMPLES`` draws z = N⁻¹ ξ, ξ the noise's perturbation of the gradient:
        ``(n_params, SAMPLES)`` single precision, whose covariance is N⁻¹ S N⁻¹ (seeded:
        reproducible).
        A draw whose solve did not converge is left out, with a
        :class:`~podid_rs.ConvergenceWarning`."""
        if self._draws is None:
            rng = np.random.default_rng(SAMPLES_SEED)
            q = self.fit.n_params
            # kept in single precision (half the memory, for every band asked after): the
            # band's standard deviations move by 7e-8 relative (chain, m = 40), against
            # the draws' own √(2/SAMPLES)
            Z = np.empty((q, SAMPLES), dtype=np.float32)
            ok = np.zeros(SAMPLES, dtype=bool)
            res = np.zeros(SAMPLES)
            made, spare = 0, np.empty((q, 0))
            with _one_blas_thread():
                for cols in self.column_blocks(SAMPLES, held=Z.nbytes):
                    # the noise SAMPLE_CHUNK draws at a time (lines × n × p × draws), in
                    # the same order whatever the blocks: a block takes what it needs
                    B = np.empty((q, cols.size), order="F")
                    filled = 0
                    while filled < cols.size:
                        if not spare.shape[1]:
                            spare = self.fit.sample_noise_gradients(
                                *self._noise, min(SAMPLE_CHUNK, SAMPLES - made), rng)
                            made += spare.shape[1]
                        take = min(spare.shape[1], cols.size - filled)
                        B[:, filled:filled + take] = spare[:, :take]
                        spare = spare[:, take:]
                        filled += take
                    Z[:, cols], ok[cols], res[cols] = self._solve(B)
                    del B
            self._warn_unsolved(ok, res, "those draws are left out of the FRF band's "
                                "covariance")
            self._draws = Z if ok.all() else Z[:, ok]
        return self._draws

    def pair_moments(self, G: np.ndarray, H: np.ndarray) -> tuple[np.ndarray, ...]:
        """(var g, var h, cov(g, h)) of the rows of ``G`` and ``H`` from :meth:`draws`:
        for many quantities at once (an FRF band over every line), at the cost of
        ``SAMPLES`` solves instead of one per quantity; each variance is then known to
        √(2/SAMPLES) relative (10 % at 200)."""
        Z = self.draws()
        if Z.shape[1] == 0:
            nan = np.full(np.atleast_2d(G).shape[0], np.nan)
            return nan, nan, nan
        # contiguous (the real and imaginary parts of complex gradients are not): BLAS
        G, H = np.ascontiguousarray(np.atleast_2d(G)), np.ascontiguousarray(np.atleast_2d(H))
        k = Z.shape[1]
        a, b = np.empty((G.shape[0], k)), np.empty((H.shape[0], k))
        for i in range(0, k, SAMPLE_CHUNK):  # a few draws in double precision at a time
            draws = Z[:, i:i + SAMPLE_CHUNK].astype(np.float64)
            a[:, i:i + SAMPLE_CHUNK], b[:, i:i + SAMPLE_CHUNK] = G @ draws, H @ draws
        return (np.sum(a * a, axis=1) / k, np.sum(b * b, axis=1) / k, np.sum(a * b, axis=1) / k)
