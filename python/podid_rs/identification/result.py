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
import scipy.signal

from .._validation import FrequencyData, Triple
from ..statespace import state_space
from ..systems import SecondOrderSystem


class RankDeficientWarning(UserWarning):
    """The normal equations were numerically singular; a minimum-norm answer was returned.

    Parameters
    ----------
    message : str
        The rank found and what would make the problem well posed.
    """


class ConvergenceWarning(UserWarning):
    """An iterative solver stopped before reaching its tolerance; see the achieved residual.

    Issued by the CG solver of :func:`podid_rs.identify` and by :func:`podid_rs.refine`.

    Parameters
    ----------
    message : str
        Where it stopped, and what to change.
    """


@dataclass(frozen=True)
class IdentificationResult:
    """Identified reduced matrices and what the solver saw.

    What :func:`podid_rs.identify`, :func:`podid_rs.refine` and the order sweep return.

    Attributes
    ----------
    M, C, K : numpy.ndarray, (m, m)
        The identified matrices, float64, in the caller's units.
    lam : tuple of float
        (λ_M, λ_C, λ_K) in the paper's units (eq. 40); ∞ for a refined model.
    symmetric : bool
        True for the exact λ → ∞ solution (M, C, K exactly symmetric).
    residual_norm : float
        ‖Ax − y‖ (eq. 28) over all frequency lines and load cases.
    penalty_norms : tuple of float
        ‖X − Xᵀ‖_F = ‖L_X x‖ for X = M, C, K.
    method : str
        ``"cholesky"`` or ``"eigen-min-norm"`` (direct), ``"cg"``,
        ``"spectral-sweep"`` (λ chosen by a rule) or ``"output-error"`` (refined).
    rank : int
        Rank of the normal matrix (for ``"cg"`` not measured: ``n_unknowns``).
    n_unknowns : int
        3m², or 3m(m+1)/2 for the exactly symmetric form.
    min_pivot_ratio : float
        How near singular the factorised matrix was: min L_ii²/G_ii of its Cholesky
        factor, or for ``"eigen-min-norm"`` its smallest over its largest eigenvalue;
        NaN for ``"cg"`` and ``"output-error"``.
    backend : str
        ``"rust"`` or ``"numpy"``.
    info : dict
        Scaling, timings and what each path adds (``"lambda_curve"``,
        ``"refinement"``, ``"physical"``, ``"stalled_cg"``, …).
    iterations : int or None
        CG or Levenberg–Marquardt iterations; None for the direct path.
    relative_residual : float or None
        For ``"cg"``, ‖b − Gx‖/‖b‖ of the scaled normal equations; for
        ``"output-error"`` (:func:`~podid_rs.refine`), √(cost / cost_start), the
        weighted output error's norm relative to the start's (0 when the start's is 0);
        None for the direct path.
    penalty_norm : float
        The root sum of squares of ``penalty_norms``.
    m : int
        The reduced order.
    well_posed : bool
        True when the normal matrix had full rank.
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
        """The relative skew part of each matrix.

        Returns
        -------
        tuple of float
            ‖X − Xᵀ‖_F / ‖X‖_F for X = M, C, K (0 for exactly symmetric or zero matrices).
        """
        out = []
        for X in (self.M, self.C, self.K):
            nx = _frobenius(X)
            out.append(_skew_norm(X) / nx if nx > 0 else 0.0)
        return (out[0], out[1], out[2])

    def system(self) -> SecondOrderSystem:
        """The identified model as a second-order system.

        Returns
        -------
        SecondOrderSystem
            ``(M, C, K)`` of this result.
        """
        return SecondOrderSystem(self.M, self.C, self.K)

    def to_state_space(self, basis: np.ndarray | None = None) -> scipy.signal.StateSpace:
        """The model as a continuous ``scipy.signal.StateSpace``, state x = [q; q̇].

        See :mod:`podid_rs.statespace`.

        Parameters
        ----------
        basis : array_like, (n, m), optional
            A basis R: the inputs are then forces on the n measured DOFs and the outputs
            their displacements R q, so the transfer function is ``R H_m(ω) Rᵀ``
            (eq. 19). Without it, reduced forces and displacements q.

        Returns
        -------
        scipy.signal.StateSpace
            The model.

        Raises
        ------
        ValueError
            For a basis of the wrong shape or a singular M.
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
    if not 1 <= threads <= MAX_THREADS:
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
