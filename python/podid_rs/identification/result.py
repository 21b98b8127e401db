"""What every fitter returns and shares: :class:`IdentificationResult`, the warnings,
the data misfit ‖Ax − y‖ (eq. 28) and the worker-thread check.

The paper's estimator (:mod:`.solvers`, :mod:`.regularisation`), the output-error
refinement (:mod:`.refinement`) and the order sweep (:mod:`.order`) all return an
:class:`IdentificationResult`; the data modules above them (measured data,
physical corrections, modes, files) read it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from .._validation import FrequencyData, Triple
from ..statespace import state_space
from ..systems import SecondOrderSystem


class RankDeficientWarning(UserWarning):
    """The normal equations were numerically singular; a minimum-norm answer was returned."""


class ConvergenceWarning(UserWarning):
    """The iterative solver stopped before reaching its tolerance; see the achieved residual."""


@dataclass(frozen=True)
class IdentificationResult:
    """Identified reduced matrices and what the solver saw.

    ``M, C, K`` are float64 (m, m) in the caller's units; ``lam`` is the
    (λ_M, λ_C, λ_K) triple in the paper's units (eq. 40); ``symmetric`` marks the
    exact λ → ∞ solution. ``residual_norm`` is ‖Ax − y‖ (eq. 28) over all
    frequency lines and load cases; ``penalty_norms`` are ‖X − Xᵀ‖_F = ‖L_X x‖ for
    X = M, C, K and ``penalty_norm`` their root sum of squares.

    ``method`` is ``"cholesky"`` or ``"eigen-min-norm"`` (direct) or ``"cg"``. For
    ``"cg"``, ``iterations`` and ``relative_residual`` (‖b − Gx‖/‖b‖ of the scaled
    normal equations) say what the iteration achieved; the rank is not measured
    (``rank`` = ``n_unknowns``) and ``min_pivot_ratio`` is NaN. Both are None for
    the direct path.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    lam: Triple
    symmetric: bool
    residual_norm: float
    penalty_norms: Triple
    method: str
    rank: int
    n_unknowns: int
    min_pivot_ratio: float
    backend: str
    info: dict = field(default_factory=dict, repr=False)
    iterations: int | None = None
    relative_residual: float | None = None

    @property
    def penalty_norm(self) -> float:
        return float(np.sqrt(sum(v * v for v in self.penalty_norms)))

    @property
    def m(self) -> int:
        return self.M.shape[0]

    @property
    def well_posed(self) -> bool:
        """True when the normal matrix had full rank."""
        return self.rank == self.n_unknowns

    def symmetry_defect(self) -> Triple:
        """‖X − Xᵀ‖_F / ‖X‖_F for X = M, C, K (0 for exactly symmetric matrices)."""
        out = []
        for X in (self.M, self.C, self.K):
            nx = _frobenius(X)
            out.append(_skew_norm(X) / nx if nx > 0 else 0.0)
        return (out[0], out[1], out[2])

    def system(self):
        """The identified model as a :class:`podid_rs.SecondOrderSystem`."""
        return SecondOrderSystem(self.M, self.C, self.K)

    def to_state_space(self, basis: np.ndarray | None = None):
        """The model as a continuous ``scipy.signal.StateSpace``, state x = [q; q̇].

        With a basis R ``(n, m)`` the inputs are forces on the n measured DOFs and
        the outputs their displacements R q, so the transfer function is
        ``R H_m(ω) Rᵀ`` (eq. 19); without it, reduced forces and displacements q.
        See :mod:`podid_rs.statespace`; ``ValueError`` for a basis of the wrong
        shape or a singular M.
        """
        return state_space(self.M, self.C, self.K, basis)


def _frobenius(A: np.ndarray) -> float:
    """‖A‖_F by NumPy's own loops, not BLAS: ``np.linalg.norm`` of an m×m array
    is an OpenBLAS ddot, whose threads then busy-wait for about 0.1 s on the
    cores that the next solve wants (m = 400, back-to-back CG calls: median
    0.607 s against 0.578 s; pen 0.674 against 0.617 s)."""
    return math.sqrt(float(np.einsum("ij,ij->", A, A)))


def _skew_norm(X: np.ndarray) -> float:
    """‖X − Xᵀ‖_F (:func:`_frobenius`)."""
    return _frobenius(X - X.T)


MAX_THREADS = 1024  # as the Rust core's bound


def _check_threads(threads: object) -> int:
    """Worker-thread count for the Rust core: None → 0 (all cores), else 1…MAX_THREADS."""
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, int | np.integer):
        raise ValueError(f"threads must be None or a positive integer, got {threads!r}")
    if not 0 <= threads <= MAX_THREADS:
        raise ValueError(f"threads must be between 1 and {MAX_THREADS}, got {threads}")
    return int(threads)


def residual_norm(M: np.ndarray, C: np.ndarray, K: np.ndarray, data: FrequencyData) -> float:
    """‖Ax − y‖ (eq. 28): the misfit of (−ω²M + iωC + K)u − f over all lines and loads.

    Row form R = −ω²·U Mᵀ + iω·U Cᵀ + U Kᵀ − F on the (N, m) columns: six real
    GEMMs (O(N·m²) at BLAS speed; at m = 1000 the einsum form took 10 s); the norm
    by BLAS nrm2, which cannot overflow.
    """
    U, F, w = data.columns()
    Ur, Ui = np.ascontiguousarray(U.real), np.ascontiguousarray(U.imag)

    def times(X: np.ndarray) -> np.ndarray:
        return Ur @ X.T + 1j * (Ui @ X.T)

    R = -(w**2)[:, None] * times(M) + 1j * w[:, None] * times(C) + times(K) - F
    return float(scipy.linalg.norm(R.ravel(), check_finite=False))
