"""Dense Kronecker-product identification exactly as the paper writes it (Sections 3–5).

This is the correctness oracle for the fast solvers: it builds the matrix ``A`` of
eq. 25 and the symmetry operators of eqs. 37–39 explicitly and solves eq. 49 as a
single stacked least-squares problem. Memory grows like ``N m · 3m²``, so it is
meant for reduced orders up to about m = 30.

Unknowns are ``x = vec([M; C; K])`` (eq. 24): the 3m×m stacked matrix, vectorised
column by column (Appendix A.2), so ``x[r + 3m·j] = [M; C; K][r, j]``.

The solver is LAPACK's QR with column pivoting (``gelsy``), with the penalty
rows on top. Both choices matter: the columns of A differ in scale by about
ω²·|U| against |U| (10⁶ and more on the paper's chain), and λ = 100 in the
paper's units weighs the penalty some 10⁸ times above data rows of size |U|.
The SVD driver ``gelsd`` is only normwise backward stable: on the chain at full
order (n = 6…10, noise-free, 5–200 Hz) it recovers C only to 1e-7…1e-6 relative,
with λ = 0 or 100. Pivoted QR with the heavy rows first, being column-wise
stable, recovers M, C and K to 1e-10 or better.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .._arrays import as_count
from .._validation import FrequencyData, check_frequency_data, check_lam

MAX_BYTES = 2 * 1024**3


@dataclass(frozen=True)
class ReferenceResult:
    """Identified ``M``, ``C``, ``K`` ``(m, m)`` with diagnostics of the solve.

    ``residual_norm`` = ‖A x − y‖ (complex 2-norm, eq. 28); ``penalty_norm`` =
    ‖[L_M; L_C; L_K] x‖ (unweighted); ``rank`` = effective rank of the stacked
    matrix found by the pivoted QR (relative cut-off: machine epsilon).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    residual_norm: float
    penalty_norm: float
    rank: int


def _check_size(nbytes: int, what: str) -> None:
    if nbytes > MAX_BYTES:
        raise ValueError(
            f"{what} would take {nbytes / 1024**3:.1f} GiB (limit {MAX_BYTES / 1024**3:.0f} GiB); "
            "the dense reference is for small reduced orders: use fewer lines or a smaller m"
        )


def vec_permutation(p: int, q: int) -> np.ndarray:
    """The (pq × pq) vec-permutation matrix with ``U vec(X) = vec(Xᵀ)`` for X ``(p, q)``.

    ``vec`` stacks columns (Appendix A.2); used in eq. B.7.
    """
    p = as_count(p, "p", 1)
    q = as_count(q, "q", 1)
    # vec(X)[i + p j] = X[i, j] must land at vec(Xᵀ)[j + q i].
    source = np.arange(p * q).reshape((p, q), order="F").T.ravel(order="F")
    return np.eye(p * q)[source]


def _kronecker_system(data: FrequencyData) -> tuple[np.ndarray, np.ndarray]:
    m = data.m
    U, F, w = data.columns()
    _check_size(16 * U.shape[0] * m * 3 * m * m, f"A ({U.shape[0] * m} x {3 * m * m} complex)")
    coef = np.stack([-(w**2), 1j * w, np.ones_like(w)], axis=1)  # (N, 3)
    # W_n = [−ω²I, iωI, I]  (m × 3m) for each column n.
    W = (coef[:, None, :, None] * np.eye(m)[None, :, None, :]).reshape(-1, m, 3 * m)
    # Block row n is U_nᵀ ⊗ W_n: entry (a, j·3m + c) = U_n[j] W_n[a, c]   (eq. 25).
    A = (U[:, None, :, None] * W[:, :, None, :]).reshape(-1, 3 * m * m)
    return A, F.reshape(-1)


def kronecker_system(U: object, F: object, omega: object) -> tuple[np.ndarray, np.ndarray]:
    """The paper's ``A x = y`` (eqs. 22–26).

    ``U``, ``F`` are ``(s, m)`` or ``(s, m, p)``; every (line, load case) pair, line
    by line, gives one block row ``U(ω_i)ᵀ ⊗ [−ω_i² I, iω_i I, I]`` of ``A``
    ``(N·m, 3m²)`` and one block ``F(ω_i)`` of ``y`` ``(N·m,)``, with N = s·p.
    """
    return _kronecker_system(check_frequency_data(U, F, omega))


def symmetry_constraints(m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(L_M, L_C, L_K)``, each ``(m², 3m²)``, with ``L_M x = vec(M − Mᵀ)`` etc. (eqs. 37–39, 48).

    ``L_b = I_m ⊗ E_b − (E_b ⊗ I_m) U`` with ``E_M = [I 0 0]``, ``E_C = [0 I 0]``,
    ``E_K = [0 0 I]`` and ``U`` the vec-permutation matrix of the 3m×m stack (eq. B.11).
    """
    m = as_count(m, "m", 1)
    _check_size(3 * 8 * m * m * 3 * m * m, f"L_M, L_C, L_K (3 x {m * m} x {3 * m * m})")
    Im = np.eye(m)
    P = vec_permutation(3 * m, m)
    blocks = []
    for b in range(3):
        E = np.zeros((m, 3 * m))
        E[:, b * m : (b + 1) * m] = Im
        blocks.append(np.kron(Im, E) - np.kron(E, Im) @ P)
    return blocks[0], blocks[1], blocks[2]


def _duplication(m: int) -> np.ndarray:
    """D ``(3m², 3·m(m+1)/2)``: ``x = D θ`` for symmetric M, C, K, θ their upper triangles."""
    i, j = np.triu_indices(m)
    t = i.size
    D = np.zeros((3 * m * m, 3 * t))
    for b in range(3):
        cols = b * t + np.arange(t)
        D[(b * m + i) + 3 * m * j, cols] = 1.0
        D[(b * m + j) + 3 * m * i, cols] = 1.0
    return D


def identify_kronecker(
    U: object,
    F: object,
    omega: object,
    lam: float | tuple[float, float, float] = 0.0,
    symmetric: bool = False,
) -> ReferenceResult:
    """Identify ``M, C, K`` ``(m, m)`` from reduced responses and forces (eqs. 23–27, 40, 49).

    ``U``, ``F`` ``(s, m)`` or ``(s, m, p)``, ``omega`` ``(s,)`` rad/s. Minimises
    ``‖Re(Ax − y)‖² + ‖Im(Ax − y)‖² + Σ_b λ_b² ‖L_b x‖²`` as one stacked real
    least-squares problem ``[λ_M L_M; λ_C L_C; λ_K L_K; Re A; Im A] x ≈ [0; Re y; Im y]``;
    ``lam`` is one λ or a ``(λ_M, λ_C, λ_K)`` triple. ``symmetric=True`` solves the
    λ → ∞ limit exactly: least squares over symmetric M, C, K only, ``[Re A; Im A] D θ ≈
    [Re y; Im y]`` with D the duplication matrix (``lam`` is then unused).
    """
    data = check_frequency_data(U, F, omega)
    lams = check_lam(lam)
    m = data.m
    n_unknowns = 3 * m * m
    _check_size(
        8 * (2 * data.n_columns * m + n_unknowns) * n_unknowns,
        f"the stacked least-squares matrix ({2 * data.n_columns * m + n_unknowns} x {n_unknowns})",
    )
    A, y = _kronecker_system(data)
    L = np.vstack(symmetry_constraints(m))
    rhs = np.concatenate([y.real, y.imag])
    if symmetric:
        D = _duplication(m)
        theta, _, rank, _ = scipy.linalg.lstsq(
            np.vstack([A.real @ D, A.imag @ D]), rhs, lapack_driver="gelsy"
        )
        x = D @ theta
    else:
        weights = np.repeat(lams, m * m)[:, None]
        stacked = np.vstack([weights * L, A.real, A.imag])
        x, _, rank, _ = scipy.linalg.lstsq(
            stacked, np.concatenate([np.zeros(n_unknowns), rhs]), lapack_driver="gelsy"
        )
    S = x.reshape((3 * m, m), order="F")
    return ReferenceResult(
        M=S[:m].copy(),
        C=S[m : 2 * m].copy(),
        K=S[2 * m :].copy(),
        residual_norm=float(np.linalg.norm(A @ x - y)),
        penalty_norm=float(np.linalg.norm(L @ x)),
        rank=int(rank),
    )
