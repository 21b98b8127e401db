"""The fixed-λ solvers of eq. 49: M, C, K from frequency-domain data at a given λ (§3–4).

:func:`identify_fixed` is what :func:`podid_rs.identify` runs for a number or a
triple λ; the rules that choose λ (:mod:`.regularisation`) call it too, and
nothing here knows them. It never forms the Kronecker matrix A of eq. 25:
the least-squares data term only needs the Gram products H = Re(V Vᴴ) and
B = Re(F Vᴴ) (docs/design.md §2), and the normal equations are written in each block's
orthonormal symmetric/skew basis, where the symmetry penalty of eq. 40 is a
diagonal 4λ² on the skew coordinates (docs/design.md §3). Two backends solve the same
equations: ``"rust"`` (default: faer, parallel, in place) and ``"numpy"``
(scipy.sparse + LAPACK, for comparison). :mod:`.reference` keeps the
paper's literal Kronecker formulation as the oracle both are tested against.

For large orders the Rust backend also solves the same equations matrix-free
(``solver="cg"``, docs/design.md §4): preconditioned conjugate gradients with O(m²)
memory and one m×3m by 3m×3m GEMM per iteration.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from .._memory import fits_in_memory, require_memory
from .._validation import FrequencyData, Triple, check_frequency_data, check_lam, count_equations
from .result import (
    ConvergenceWarning,
    IdentificationResult,
    RankDeficientWarning,
    _check_threads,
    _skew_norm,
    residual_norm,
)

if TYPE_CHECKING:
    from .._core import Identified

Backend = Literal["rust", "numpy"]
Solver = Literal["auto", "direct", "cg"]

#: default relative-residual tolerance of ``solver="cg"``: on the full-order chain
#: at m = 10…60 (noise-free and 5 % noise; 20 %, 50–150 Hz and 5–200 Hz bands;
#: exact-symmetric and penalty modes, λ = 1e-3 and 100) it kept CG within 3e-9 of
#: the direct answer, where 1e-10 left up to 2.6e-8 and 1e-12 bought little (1.2e-9).
CG_TOL = 1e-11
#: default iteration limit of ``solver="cg"``
CG_MAX_ITER = 10_000
#: ``solver="auto"`` takes the direct path up to this many unknowns (3m² or
#: 3m(m+1)/2), CG beyond (see ``identify``; measured by ``benches/bench_cg.py --auto``).
AUTO_DIRECT_MAX_UNKNOWNS = 300
#: a CG run of ``solver="auto"`` that stops by itself above ``tol`` (singular
#: normal equations, e.g. too few load cases, or an unattainable tol) is redone by
#: the direct path up to this many unknowns (m = 40 with a penalty: 0.7 s in the
#: direct-path table of benches/README.md), which reports the rank and returns the
#: minimum-norm answer where CG can only stall.
AUTO_FALLBACK_MAX_UNKNOWNS = 4800
#: what a ``MemoryError`` of the solvers suggests
MEMORY_HINT = "reduce the order m, or use symmetric=True (3m(m+1)/2 unknowns instead of 3m²)"


# ---------------------------------------------------------------------------
# helpers shared by the backends


def gram_numpy(U: np.ndarray, F: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H = Re(V Vᴴ), B = Re(F Vᴴ) with v_i = [−ω_i² u_i; iω_i u_i; u_i] (docs/design.md §2).

    U, F are (N, m) rows u_i, f_i; omega (N,). Literal, O(N·9m²); the Rust core
    computes the same by GEMMs on the real stacked data.
    """
    w = omega[:, None]
    V = np.concatenate([-(w**2) * U, 1j * w * U, U], axis=1)  # (N, 3m), rows v_iᵀ
    H = np.real(V.T @ V.conj())
    B = np.real(F.T @ V.conj())
    return H, B


def _scales(U: np.ndarray, F: np.ndarray, omega: np.ndarray) -> tuple[float, float, float]:
    """ω0 = RMS ω, s_u = RMS |U|, s_f = RMS |F| (docs/design.md §3); 1 where a scale is 0."""

    def nz(x: float) -> float:
        return x if x > 0 and np.isfinite(x) else 1.0

    def rms(a: np.ndarray) -> float:
        """RMS of |a|, computed on a / max|a| so that it cannot overflow or underflow."""
        top = float(np.max(np.abs(a)))
        return top * float(np.sqrt(np.mean(np.abs(a / top) ** 2))) if top > 0 else 0.0

    return nz(rms(omega)), nz(rms(U)), nz(rms(F))


def symskew_basis(m: int, symmetric: bool) -> tuple[sp.csc_matrix, np.ndarray, np.ndarray]:
    """Orthonormal basis T of the unknowns in row-major vec(Z), Z = [M C K] (m × 3m).

    Columns: per block the diagonal E_jj and (E_jk + E_kj)/√2 (j < k), then (unless
    ``symmetric``) per block (E_jk − E_kj)/√2. Returns T (3m² × n), the block of each
    column, and a mask of the skew columns.
    """
    r2 = 1.0 / np.sqrt(2.0)
    rows, cols, vals, blocks, skew = [], [], [], [], []

    def put(b: int, j: int, k: int, sign: float | None) -> None:
        c = len(blocks)
        if sign is None:
            rows.append(j * 3 * m + b * m + j)
            cols.append(c)
            vals.append(1.0)
        else:
            rows.extend([j * 3 * m + b * m + k, k * 3 * m + b * m + j])
            cols.extend([c, c])
            vals.extend([r2, sign * r2])
        blocks.append(b)
        skew.append(sign == -1.0)

    for b in range(3):
        for j in range(m):
            for k in range(j, m):
                put(b, j, k, None if j == k else 1.0)
    if not symmetric:
        for b in range(3):
            for j in range(m):
                for k in range(j + 1, m):
                    put(b, j, k, -1.0)
    T = sp.csc_matrix((vals, (rows, cols)), shape=(3 * m * m, len(blocks)))
    return T, np.asarray(blocks), np.asarray(skew)


def _solve_spd(G: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, str, int, float]:
    """Cholesky, or the minimum-norm eigen solve if G is numerically singular."""
    n = G.shape[0]
    tol = n * np.finfo(float).eps
    d = np.diag(G).copy()
    if np.all(d > 0):
        try:
            L, _ = scipy.linalg.cho_factor(G, lower=True, check_finite=False)
            ratio = float(np.min(np.diag(L) ** 2 / d))
            if ratio > tol:
                x = scipy.linalg.cho_solve((L, True), b, check_finite=False)
                return x, "cholesky", n, ratio
        except np.linalg.LinAlgError:
            pass
    s, Q = np.linalg.eigh(G)
    keep = s > tol * max(float(s.max()), 0.0)
    inv = 1.0 / s[keep]
    x = Q[:, keep] @ (inv.reshape((-1,) + (1,) * (b.ndim - 1)) * (Q[:, keep].T @ b))
    ratio = float(max(s.min(), 0.0) / s.max()) if s.max() > 0 else 0.0
    return x, "eigen-min-norm", int(keep.sum()), ratio


@dataclass(frozen=True)
class _SolvedByNumpy:
    """The NumPy backend's answer, with the attributes of the Rust core's
    :class:`podid_rs._core.Identified` that it has: no timings and no CG; the
    caller computes the residual norm."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    method: str
    rank: int
    n_unknowns: int
    min_pivot_ratio: float
    scaling: tuple[float, float, float]
    residual_norm: float | None = None
    timings: dict[str, float] = field(default_factory=dict)
    iterations: int | None = None
    relative_residual: float | None = None
    converged: bool | None = None


def _identify_numpy(data: FrequencyData, lam: Triple, symmetric: bool) -> _SolvedByNumpy:
    """The structured normal equations of docs/design.md §2–3 in NumPy/SciPy."""
    U, F, w = data.columns()
    m = data.m
    w0, su, sf = _scales(U, F, w)
    H, B = gram_numpy(U / su, F / sf, w / w0)
    factors = np.array([sf / (su * w0**2), sf / (su * w0), sf / su])
    if not symmetric and not any(lam):
        require_memory(8 * (3 * m) ** 2, "the 3m×3m Gram matrix", MEMORY_HINT)
        Zt, method, rank, ratio = _solve_spd(H, B.T.copy())
        Z = Zt.T
        rank *= m
    else:
        T, blocks, skew = symskew_basis(m, symmetric)
        n = T.shape[1]
        require_memory(3 * 8 * n * n, f"the {n}×{n} normal matrix (NumPy backend)", MEMORY_HINT)
        KH = sp.kron(sp.identity(m, format="csr"), sp.csr_matrix(H), format="csr")
        G = (T.T @ (KH @ T)).toarray()
        lam_s = np.asarray(lam) * factors / sf
        G[np.flatnonzero(skew), np.flatnonzero(skew)] += 4.0 * lam_s[blocks[skew]] ** 2
        x, method, rank, ratio = _solve_spd(G, T.T @ B.ravel())
        Z = (T @ x).reshape(m, 3 * m)
    M, C, K = (factors[b] * Z[:, b * m : (b + 1) * m] for b in range(3))
    return _SolvedByNumpy(
        M=M,
        C=C,
        K=K,
        method=method,
        rank=rank,
        n_unknowns=3 * m * m if not symmetric else 3 * m * (m + 1) // 2,
        min_pivot_ratio=ratio,
        scaling=(w0, su, sf),
    )


def _identify_rust(
    data: FrequencyData, lam: Triple, symmetric: bool, threads: int
) -> Identified:
    from .. import _core

    need = int(_core.direct_memory_bytes(data.m, lam, symmetric))
    require_memory(need, "the direct solve", MEMORY_HINT)
    U, F, w = data.columns()
    return _core.identify_direct(U, F, w, lam, symmetric, threads=threads)


class _ProgressBar:
    """CG progress as a tqdm bar on stderr: the fraction done is log(residual)/log(tol)."""

    def __init__(self, tol: float) -> None:
        from .._progress import progress_bar

        self.tol = tol
        self.bar = progress_bar(100, desc="CG", unit="%", leave=True)

    def __call__(self, iteration: int, residual: float) -> None:
        done = 0.0
        if residual > 0 and math.isfinite(residual):
            done = min(max(math.log(residual) / math.log(self.tol), 0.0), 1.0)
        self.bar.n = round(100 * done)
        self.bar.set_postfix_str(
            f"iteration {iteration}, relative residual {residual:.2e} (tol {self.tol:.0e})",
            refresh=False,
        )
        self.bar.refresh()

    def close(self, iteration: int, residual: float) -> None:
        self(iteration, residual)
        self.bar.close()


def _identify_cg(
    data: FrequencyData,
    lam: Triple,
    symmetric: bool,
    threads: int,
    tol: float,
    max_iter: int,
    progress: bool | Callable[[int, float], object],
) -> Identified:
    from .. import _core

    need = int(_core.cg_memory_bytes(data.m, symmetric))
    require_memory(need, "the matrix-free CG solver", MEMORY_HINT)
    U, F, w = data.columns()
    bar = _ProgressBar(tol) if progress is True else None
    callback = bar if bar is not None else (progress if callable(progress) else None)
    try:
        out = _core.identify_cg(
            U, F, w, lam, symmetric, tol, max_iter, progress=callback, threads=threads
        )
    except BaseException:
        if bar is not None:
            bar.bar.close()
        raise
    if bar is not None:
        bar.close(out.iterations, out.relative_residual)
    return out


def _direct_fits(m: int, lam: Triple, symmetric: bool, max_unknowns: int) -> bool:
    """At most ``max_unknowns`` unknowns, and the dense matrix takes at most half the
    available memory."""
    from .. import _core

    n = 3 * m * (m + 1) // 2 if symmetric else 3 * m * m
    dense = int(_core.direct_memory_bytes(m, lam, symmetric))
    return n <= max_unknowns and fits_in_memory(dense, 0.5)


def choose_solver(m: int, lam: Triple, symmetric: bool) -> str:
    """The path ``solver="auto"`` takes (see :func:`podid_rs.identify`)."""
    if not symmetric and not any(lam):
        return "direct"  # one 3m×3m factorisation: always cheap
    return "direct" if _direct_fits(m, lam, symmetric, AUTO_DIRECT_MAX_UNKNOWNS) else "cg"


def _check_cg_options(tol: object, max_iter: object, progress: object) -> tuple[float, int]:
    try:
        t = float(tol)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"tol must be a number in (0, 1), got {tol!r}") from None
    if not (0.0 < t < 1.0):
        raise ValueError(f"tol must lie in (0, 1), got {tol!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, int | np.integer) or max_iter < 1:
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}")
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(
            f"progress must be a bool or a callable(iteration, residual), got {progress!r}"
        )
    return t, int(max_iter)


# ---------------------------------------------------------------------------


def identify_fixed(
    U: np.ndarray,
    F: np.ndarray,
    omega: np.ndarray,
    lam: float | tuple[float, float, float] = 0.0,
    symmetric: bool = False,
    *,
    backend: Backend = "rust",
    threads: int | None = None,
    solver: Solver = "auto",
    tol: float = CG_TOL,
    max_iter: int = CG_MAX_ITER,
    progress: bool | Callable[[int, float], object] = False,
    stacklevel: int = 2,
) -> IdentificationResult:
    """M, C, K at a fixed λ (eq. 49): :func:`podid_rs.identify` for a number or a triple.

    Arguments, result, warnings and errors as for :func:`podid_rs.identify`;
    ``stacklevel`` places its warnings (2: the caller of this function).
    """
    data = check_frequency_data(U, F, omega)
    lam_t = check_lam(lam)
    if not isinstance(symmetric, bool | np.bool_):
        raise ValueError(f"symmetric must be True or False, got {symmetric!r}")
    symmetric = bool(symmetric)
    threads = _check_threads(threads)
    n_eq, n_unk = count_equations(data, lam_t, symmetric)
    if n_eq < n_unk:
        need = (
            ""
            if symmetric or all(lam_t)
            else (" (a positive lam on every block, or symmetric=True, reduces the unknowns)")
        )
        raise ValueError(
            f"too few equations: {data.s} frequency line(s) × {data.p} load case(s) give "
            f"{n_eq} real equations for {n_unk} unknowns at order m = {data.m}{need}"
        )
    if backend not in ("rust", "numpy"):
        raise ValueError(f"backend must be 'rust' or 'numpy', got {backend!r}")
    if solver not in ("auto", "direct", "cg"):
        raise ValueError(f"solver must be 'auto', 'direct' or 'cg', got {solver!r}")
    tol, max_iter = _check_cg_options(tol, max_iter, progress)
    if backend == "numpy":
        if solver == "cg":
            raise ValueError("solver='cg' needs backend='rust'; the numpy backend is direct only")
        solver = "direct"
    auto = solver == "auto"
    if auto:
        solver = choose_solver(data.m, lam_t, symmetric)
    stalled_cg = None
    out: Identified | _SolvedByNumpy
    if solver == "cg":
        out = _identify_cg(data, lam_t, symmetric, threads, tol, max_iter, progress)
        stalled = not out.converged and out.iterations < max_iter
        if auto and stalled and _direct_fits(data.m, lam_t, symmetric, AUTO_FALLBACK_MAX_UNKNOWNS):
            stalled_cg = {"iterations": out.iterations, "relative_residual": out.relative_residual}
            out = _identify_rust(data, lam_t, symmetric, threads)
    elif backend == "rust":
        out = _identify_rust(data, lam_t, symmetric, threads)
    else:
        out = _identify_numpy(data, lam_t, symmetric)

    M, C, K = (np.asarray(X, dtype=np.float64) for X in (out.M, out.C, out.K))
    if out.method == "cg" and not out.converged:
        warnings.warn(
            f"CG stopped after {out.iterations} iterations at relative residual "
            f"{out.relative_residual:.2e}, above tol = {tol:.1e}; the answer is "
            "returned as it stands. Raise max_iter, loosen tol, or use solver='direct' "
            "where the dense system fits",
            ConvergenceWarning,
            stacklevel=stacklevel,
        )
    if out.method == "eigen-min-norm":
        warnings.warn(
            f"the normal equations are numerically singular (rank {out.rank} of "
            f"{out.n_unknowns} unknowns); returned the minimum-norm solution. More "
            "frequency lines or load cases, a lower order m, or symmetry regularisation "
            "would make the problem well posed",
            RankDeficientWarning,
            stacklevel=stacklevel,
        )
    pen = tuple(_skew_norm(X) for X in (M, C, K))
    return IdentificationResult(
        M=M,
        C=C,
        K=K,
        lam=lam_t,
        symmetric=symmetric,
        residual_norm=(
            float(out.residual_norm)
            if out.residual_norm is not None
            else residual_norm(M, C, K, data)
        ),
        penalty_norms=(pen[0], pen[1], pen[2]),
        method=str(out.method),
        rank=int(out.rank),
        n_unknowns=int(out.n_unknowns),
        min_pivot_ratio=float(out.min_pivot_ratio),
        backend=backend,
        info={
            "scaling": tuple(out.scaling),
            "timings": dict(out.timings),
            **({"converged": bool(out.converged), "tol": tol} if out.converged is not None else {}),
            **({"stalled_cg": stalled_cg} if stalled_cg else {}),
        },
        iterations=int(out.iterations) if out.iterations is not None else None,
        relative_residual=(
            float(out.relative_residual) if out.iterations is not None else None
        ),
    )
