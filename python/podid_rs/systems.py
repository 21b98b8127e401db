"""Linear second-order systems M ü + C u̇ + K u = f, the paper's chain (Section 6.1)
and a 2-D lattice with the dense modes of the mid-frequency range.

A :class:`SecondOrderSystem` holds dense NumPy arrays or scipy.sparse matrices.
Sparse systems are solved one frequency line at a time by a tridiagonal, banded
or sparse LU (:mod:`podid_rs._linesolve`), in parallel over lines, so that a
response or a few FRF entries cost O(n) per line for the chain; nothing of size
(s, n, n) is formed unless the full FRF is asked for, and then only after
checking that it fits in memory.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

from podid_rs._arrays import as_array, as_count, as_omega, as_scalar
from podid_rs._linesolve import LineSolver, default_threads, map_lines
from podid_rs._memory import COMPLEX_BYTES, FLOAT_BYTES, require_memory

#: ``mass_spring_chain(n)`` is dense up to this many DOFs (3n² doubles, 24 MB), sparse above.
DENSE_CHAIN_MAX = 1000
#: Dense per-line solves are batched in chunks of at most this many bytes of Z.
DENSE_CHUNK_BYTES = 1 << 27


def _solve(Z: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched ``Z⁻¹ rhs`` over the leading (frequency) axis."""
    try:
        return np.linalg.solve(Z, rhs)
    except np.linalg.LinAlgError:
        raise ValueError("the dynamic stiffness is singular at one of the given omega") from None


def _as_sparse(x: object, name: str) -> sp.csr_array:
    """Fresh real float64 CSR copy of a sparse or dense square matrix, checked finite."""
    if sp.issparse(x):
        if x.dtype == np.bool_ or not np.issubdtype(x.dtype, np.number):
            raise ValueError(f"{name} must be a numeric matrix, got dtype {x.dtype}")
        if np.issubdtype(x.dtype, np.complexfloating):
            raise ValueError(f"{name} must be real, got complex dtype {x.dtype}")
        a = sp.csr_array(x, dtype=np.float64, copy=True)
        a.sum_duplicates()
        if not np.all(np.isfinite(a.data)):
            raise ValueError(f"{name} contains non-finite values (NaN or inf)")
        return a
    return sp.csr_array(as_array(x, name, real=True))


def _indices(idx: object, n: int, name: str) -> np.ndarray:
    """0-based DOF indices: all n for None, else a 1-D integer array in [0, n)."""
    if idx is None:
        return np.arange(n)
    a = np.asarray(idx)
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1 or a.size == 0 or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must be a non-empty 1-D sequence of integer DOF indices")
    if a.min() < 0 or a.max() >= n:
        raise ValueError(f"{name} must index the {n} DOFs (0 … {n - 1}), got {idx!r}")
    return a.astype(np.int64)


class SecondOrderSystem:
    """A viscously damped linear system ``M ü + C u̇ + K u = f`` (paper eq. 1).

    ``M``, ``C`` and ``K`` are real square matrices of equal shape, NumPy arrays
    or scipy.sparse matrices; they need not be symmetric and the damping need not
    be proportional. They are stored as copies: dense as float64 arrays, and as
    ``scipy.sparse.csr_array`` as soon as any of the three is sparse.
    """

    def __init__(self, M: object, C: object, K: object) -> None:
        sparse = any(sp.issparse(a) for a in (M, C, K))
        convert = _as_sparse if sparse else (lambda a, name: as_array(a, name, real=True))
        mats = [convert(a, name) for a, name in ((M, "M"), (C, "C"), (K, "K"))]
        for a, name in zip(mats, "MCK", strict=True):
            if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
                raise ValueError(f"{name} must be a non-empty square matrix, got shape {a.shape}")
        if not mats[0].shape == mats[1].shape == mats[2].shape:
            raise ValueError(
                f"M, C and K must have the same shape, got {mats[0].shape}, "
                f"{mats[1].shape} and {mats[2].shape}"
            )
        self.M, self.C, self.K = mats
        self._solver: LineSolver | None = None

    @property
    def n(self) -> int:
        """Number of degrees of freedom."""
        return self.M.shape[0]

    @property
    def is_sparse(self) -> bool:
        """True when M, C, K are held as scipy.sparse matrices."""
        return sp.issparse(self.M)

    def __repr__(self) -> str:
        return f"SecondOrderSystem(n={self.n}{', sparse' if self.is_sparse else ''})"

    def todense(self) -> SecondOrderSystem:
        """The same system with dense M, C, K (``MemoryError`` if 3n² doubles do not fit)."""
        if not self.is_sparse:
            return SecondOrderSystem(self.M, self.C, self.K)
        require_memory(3 * FLOAT_BYTES * self.n**2, f"a dense copy of a {self.n}-DOF system")
        return SecondOrderSystem(self.M.toarray(), self.C.toarray(), self.K.toarray())

    def _line_solver(self) -> LineSolver:
        if self._solver is None:
            self._solver = LineSolver(self.M, self.C, self.K)
        return self._solver

    def _threads(self, threads: int | None) -> int:
        if threads is None:
            return default_threads(self.n)
        return as_count(threads, "threads", 1, 1024)

    def dynamic_stiffness(self, omega: object) -> np.ndarray:
        """``Z(ω) = −ω²M + iωC + K`` for each line, shape ``(s, n, n)`` complex (eq. 19).

        Dense even for a sparse system (``MemoryError`` if it does not fit).
        """
        w = as_omega(omega)
        require_memory(
            2 * COMPLEX_BYTES * w.size * self.n**2,
            f"the dense dynamic stiffness of {w.size} lines × {self.n} × {self.n} DOFs",
        )
        w = w[:, None, None]
        if self.is_sparse:
            return -(w**2) * self.M.toarray() + 1j * w * self.C.toarray() + self.K.toarray()
        return -(w**2) * self.M + 1j * w * self.C + self.K

    def frf(
        self,
        omega: object,
        rows: Sequence[int] | np.ndarray | None = None,
        cols: Sequence[int] | np.ndarray | None = None,
        *,
        threads: int | None = None,
    ) -> np.ndarray:
        """Receptance ``H(ω) = Z(ω)⁻¹`` (the transfer matrix of eq. 4), ``(s, n_rows, n_cols)``.

        ``rows`` and ``cols`` (0-based DOF indices, default all) pick the entries:
        only ``len(cols)`` unit loads are solved per line and only the ``rows``
        kept, so a few entries of a 10⁵-DOF model cost O(n) per line. The full
        ``(s, n, n)`` array is refused with ``MemoryError`` when it would not fit.
        ``threads``: worker threads over lines (default: all cores for n ≥ 2000).
        """
        w = as_omega(omega)
        r = _indices(rows, self.n, "rows")
        c = _indices(cols, self.n, "cols")
        full = rows is None and cols is None
        out_bytes = COMPLEX_BYTES * w.size * r.size * c.size
        what = f"the FRF of {w.size} lines × {r.size} × {c.size} entries"
        hint = "ask for the entries you need with frf(omega, rows=..., cols=...)"
        if not self.is_sparse:
            if full:
                require_memory(3 * out_bytes, what, hint)
                Z = self.dynamic_stiffness(w)
                return _solve(Z, np.broadcast_to(np.eye(self.n), Z.shape))
            require_memory(out_bytes, what, hint)
            loads = np.zeros((self.n, c.size))
            loads[c, np.arange(c.size)] = 1.0
            out = np.empty((w.size, r.size, c.size), dtype=np.complex128)
            for sl in self._dense_chunks(w.size):
                out[sl] = _solve(self.dynamic_stiffness(w[sl]), loads)[:, r, :]
            return out
        require_memory(out_bytes, what, hint)
        loads = np.zeros((self.n, c.size), dtype=np.complex128, order="F")
        loads[c, np.arange(c.size)] = 1.0
        out = np.empty((w.size, r.size, c.size), dtype=np.complex128)
        solver = self._line_solver()

        def line(i: int) -> None:
            out[i] = solver.solve(w[i], loads)[r]

        map_lines(w.size, line, self._threads(threads))
        return out

    def _dense_chunks(self, s: int):
        """Slices of at most DENSE_CHUNK_BYTES of dense dynamic stiffness each."""
        step = max(1, DENSE_CHUNK_BYTES // (COMPLEX_BYTES * self.n**2))
        return [slice(i, min(i + step, s)) for i in range(0, s, step)]

    def response(self, omega: object, F: object, *, threads: int | None = None) -> np.ndarray:
        """Steady-state response ``U = Z(ω)⁻¹ F`` per line (eq. 19).

        ``F`` is ``(s, n)`` or ``(s, n, p)`` (p load cases); ``U`` has the same shape.
        Lines are solved in chunks (dense) or one by one on ``threads`` threads
        (sparse), so memory beyond U stays bounded.
        """
        w = as_omega(omega)
        shape = np.shape(F)
        if len(shape) not in (2, 3) or tuple(shape[:2]) != (w.size, self.n):
            raise ValueError(
                f"F must have shape (s, n) or (s, n, p) with s = {w.size} lines and "
                f"n = {self.n} DOFs, got {shape}"
            )
        require_memory(
            2 * COMPLEX_BYTES * int(np.prod(shape)),
            f"the response to forces of shape {shape}",
        )
        Fa = as_array(F, "F")
        F3 = Fa[:, :, None] if Fa.ndim == 2 else Fa
        U = np.empty(F3.shape, dtype=np.complex128)
        if not self.is_sparse:
            for sl in self._dense_chunks(w.size):
                U[sl] = _solve(self.dynamic_stiffness(w[sl]), F3[sl])
        else:
            solver = self._line_solver()

            def line(i: int) -> None:
                U[i] = solver.solve(w[i], np.asfortranarray(F3[i], dtype=np.complex128))

            map_lines(w.size, line, self._threads(threads))
        return U[:, :, 0] if Fa.ndim == 2 else U

    def project(self, R: object) -> SecondOrderSystem:
        """Reduced system ``(RᵀMR, RᵀCR, RᵀKR)`` on the basis ``R`` ``(n, m)`` (eqs. 14–16).

        Dense m × m matrices; for a sparse system the products are sparse × dense.
        """
        Ra = as_array(R, "R", real=True)
        if Ra.ndim != 2 or Ra.shape[0] != self.n or Ra.shape[1] == 0:
            raise ValueError(f"R must have shape (n, m) with n = {self.n}, got {Ra.shape}")
        if self.is_sparse:
            return SecondOrderSystem(*(Ra.T @ (X @ Ra) for X in (self.M, self.C, self.K)))
        return SecondOrderSystem(Ra.T @ self.M @ Ra, Ra.T @ self.C @ Ra, Ra.T @ self.K @ Ra)


def _check_chain_parameters(
    m1: float, m2: float, ku: float, a0: float, a1: float
) -> tuple[float, ...]:
    m1, m2, ku = (as_scalar(v, name) for v, name in ((m1, "m1"), (m2, "m2"), (ku, "ku")))
    a0, a1 = (as_scalar(v, name, allow_zero=True) for v, name in ((a0, "a0"), (a1, "a1")))
    return m1, m2, ku, a0, a1


def _require_sparse_memory(n: int, per_row: int, what: str) -> None:
    """Refuse a generated system whose M, C, K (and the temporaries that build them,
    about three times as much) would not fit: ``per_row`` entries per row, 12 bytes
    each (value and column index)."""
    require_memory(3 * 3 * 12 * per_row * n, what, "ask for fewer DOFs")


def mass_spring_chain(
    n: int = 100,
    m1: float = 0.1,
    m2: float = 1.0,
    ku: float = 4e5,
    a0: float = 0.5,
    a1: float = 3e-5,
    *,
    sparse: bool | None = None,
) -> SecondOrderSystem:
    """The paper's chain of n masses between two fixed walls (Section 6.1).

    Masses ``m1`` for the first ``n // 2`` DOFs and ``m2`` for the rest (eq. 51),
    ``K = ku · tridiag(−1, 2, −1)`` (eq. 52), Rayleigh damping ``C = a0 M + a1 K``.
    ``sparse=True``: M, C, K are ``scipy.sparse.csr_array`` and every line is one
    O(n) tridiagonal solve; ``False``: dense arrays (3n² doubles); ``None``
    (default): sparse above :data:`DENSE_CHAIN_MAX` DOFs. Both hold the same
    entries, bit for bit.
    """
    n = as_count(n, "n", 1)
    m1, m2, ku, a0, a1 = _check_chain_parameters(m1, m2, ku, a0, a1)
    if sparse is None:
        sparse = n > DENSE_CHAIN_MAX
    if not sparse:
        require_memory(3 * 3 * FLOAT_BYTES * n**2, f"a dense chain of {n} masses",
                       "pass sparse=True")
        M = np.diag(np.where(np.arange(n) < n // 2, m1, m2))
        K = ku * (2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
        return SecondOrderSystem(M, a0 * M + a1 * K, K)
    _require_sparse_memory(n, 3, f"a chain of {n} masses")
    M = sp.diags_array(np.where(np.arange(n) < n // 2, m1, m2), format="csr")
    off = -ku * np.ones(n - 1)
    K = sp.diags_array([off, 2.0 * ku * np.ones(n), off], offsets=[-1, 0, 1], format="csr")
    return SecondOrderSystem(M, a0 * M + a1 * K, K)


def mass_spring_lattice(
    nx: int = 100,
    ny: int = 100,
    mass: float = 1.0,
    k: float = 4e5,
    a0: float = 0.5,
    a1: float = 3e-5,
    *,
    mass_variation: float = 0.0,
    stiffness_variation: float = 0.0,
    seed: int | None = None,
) -> SecondOrderSystem:
    """A 2-D lattice of ``nx × ny`` masses, each joined to its four neighbours, edges fixed.

    Mass (i, j), 0 ≤ i < nx along x and 0 ≤ j < ny along y, is DOF ``j·nx + i``
    and moves out of plane; springs of stiffness ``k`` join neighbours along x and
    y, and the masses on the edges are joined to fixed ground by springs of the
    same kind (the 2-D counterpart of the chain's walls), so K is the 5-point
    Laplacian ``k (I ⊗ T_nx + T_ny ⊗ I)``, T = tridiag(−1, 2, −1), and
    ``C = a0 M + a1 K`` (Rayleigh). With uniform properties the natural
    frequencies are ``√(k/mass) · 2 √(sin²(pπ/2(nx+1)) + sin²(qπ/2(ny+1)))`` —
    many close, often repeated, modes in any band: the mid-frequency regime.
    ``mass_variation`` and ``stiffness_variation`` (fractions in [0, 1)) make
    every mass and every spring independently uniform in ``(1 ± variation)``
    times its nominal value (reproducibly with ``seed``), which splits the
    repeated modes. Sparse (``scipy.sparse.csr_array``), five entries per row.
    """
    nx, ny = as_count(nx, "nx", 1), as_count(ny, "ny", 1)
    mass, k = as_scalar(mass, "mass"), as_scalar(k, "k")
    a0, a1 = (as_scalar(v, name, allow_zero=True) for v, name in ((a0, "a0"), (a1, "a1")))
    dm = as_scalar(mass_variation, "mass_variation", allow_zero=True)
    dk = as_scalar(stiffness_variation, "stiffness_variation", allow_zero=True)
    if dm >= 1 or dk >= 1:
        raise ValueError(
            f"mass_variation and stiffness_variation must be in [0, 1), got {dm:g} and {dk:g}"
        )
    rng = np.random.default_rng(seed)
    n = nx * ny
    _require_sparse_memory(n, 5, f"a lattice of {nx} × {ny} masses")
    idx = np.arange(n).reshape(ny, nx)  # idx[j, i] = j·nx + i
    # springs between neighbours (a, b), and to ground from the edge masses (a, -1)
    pairs = [
        (idx[:, :-1].ravel(), idx[:, 1:].ravel()),
        (idx[:-1, :].ravel(), idx[1:, :].ravel()),
    ]
    ground = np.concatenate(
        [idx[:, 0], idx[:, -1], idx[0, :], idx[-1, :]]
    )  # a corner mass has two springs to ground
    a = np.concatenate([p[0] for p in pairs] + [ground])
    b = np.concatenate([p[1] for p in pairs] + [np.full(ground.size, -1)])
    ks = k * (1.0 + dk * rng.uniform(-1.0, 1.0, a.size)) if dk else np.full(a.size, k)
    inner = b >= 0
    rows = np.concatenate([a, b[inner], a[inner], b[inner]])
    cols = np.concatenate([a, b[inner], b[inner], a[inner]])
    vals = np.concatenate([ks, ks[inner], -ks[inner], -ks[inner]])
    K = sp.csr_array(sp.coo_array((vals, (rows, cols)), shape=(n, n)))
    masses = mass * (1.0 + dm * rng.uniform(-1.0, 1.0, n)) if dm else np.full(n, mass)
    M = sp.diags_array(masses, format="csr")
    return SecondOrderSystem(M, a0 * M + a1 * K, K)
