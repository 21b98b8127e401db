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

    The matrices need not be symmetric and the damping need not be proportional.
    They are stored as copies: dense as float64 arrays, and as
    ``scipy.sparse.csr_array`` as soon as any of the three is sparse.

    Parameters
    ----------
    M, C, K : array_like or scipy.sparse matrix, (n, n)
        Mass, damping and stiffness: real, finite, square and of one shape.

    Attributes
    ----------
    M, C, K : numpy.ndarray or scipy.sparse.csr_array
        The stored copies.
    n : int
        Number of degrees of freedom.
    is_sparse : bool
        True when M, C, K are held as scipy.sparse matrices.

    Raises
    ------
    ValueError
        A matrix that is not real, finite and square, or shapes that differ.
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
        """The same system with dense M, C, K.

        Returns
        -------
        SecondOrderSystem
            A dense copy (a plain copy when the system is dense already).

        Raises
        ------
        MemoryError
            When the 3n² doubles of a sparse system's dense copy would not fit.
        """
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
        """The dynamic stiffness ``Z(ω) = −ω²M + iωC + K`` on each line (eq. 19).

        Dense even for a sparse system.

        Parameters
        ----------
        omega : array_like, (s,)
            Angular frequencies in rad/s, all > 0.

        Returns
        -------
        numpy.ndarray, complex, (s, n, n)
            Z at each line.

        Raises
        ------
        ValueError
            For malformed ``omega``.
        MemoryError
            When the dense ``(s, n, n)`` array would not fit.
        """
        w = as_omega(omega)
        require_memory(
            2 * COMPLEX_BYTES * w.size * self.n**2,
            f"the dense dynamic stiffness of {w.size} lines × {self.n} × {self.n} DOFs",
        )
        M, C, K = (x.toarray() for x in (self.M, self.C, self.K)) if self.is_sparse else (
            self.M, self.C, self.K)
        # written into the real and imaginary parts, no complex temporaries: at 46 750
        # lines of a 9-DOF model 19 ms against 107 ms for the complex expression
        Z = np.empty((w.size, self.n, self.n), dtype=np.complex128)
        w3 = w[:, None, None]
        np.multiply(np.square(w3), -M, out=Z.real)
        Z.real += K
        np.multiply(w3, C, out=Z.imag)
        return Z

    def frf(
        self,
        omega: object,
        rows: Sequence[int] | np.ndarray | None = None,
        cols: Sequence[int] | np.ndarray | None = None,
        *,
        threads: int | None = None,
    ) -> np.ndarray:
        """The receptance ``H(ω) = Z(ω)⁻¹`` (the transfer matrix of eq. 4), or some of its entries.

        Only ``len(cols)`` unit loads are solved per line and only the ``rows`` kept, so
        a few entries of a 10⁵-DOF model cost O(n) per line.

        Parameters
        ----------
        omega : array_like, (s,)
            Angular frequencies in rad/s, all > 0.
        rows, cols : sequence of int, optional
            0-based DOF indices of the entries wanted (default: all).
        threads : int, optional
            Worker threads over the lines of a sparse system (default: all cores for
            n ≥ 2000, else 1).

        Returns
        -------
        numpy.ndarray, complex, (s, len(rows), len(cols))
            ``H[i, j, k]`` = response of DOF ``rows[j]`` to a unit force on DOF ``cols[k]``
            at ``omega[i]``.

        Raises
        ------
        ValueError
            For malformed ``omega``, indices outside the DOFs, or a singular Z(ω) on a line.
        MemoryError
            When the result would not fit (ask for the entries you need).
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
        """The steady-state response ``U = Z(ω)⁻¹ F`` on each line (eq. 19).

        Lines are solved in chunks (dense) or one by one on ``threads`` threads
        (sparse), so the memory beyond U stays bounded.

        Parameters
        ----------
        omega : array_like, (s,)
            Angular frequencies in rad/s, all > 0.
        F : array_like, (s, n) or (s, n, p)
            Force amplitudes per line (p load cases).
        threads : int, optional
            Worker threads over the lines of a sparse system (default: all cores for
            n ≥ 2000, else 1).

        Returns
        -------
        numpy.ndarray, complex
            U, of the shape of ``F``.

        Raises
        ------
        ValueError
            For malformed ``omega`` or ``F``, or a singular Z(ω) on a line.
        MemoryError
            When U would not fit.
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
        """The reduced system ``(RᵀMR, RᵀCR, RᵀKR)`` on a basis R (eqs. 14–16).

        Parameters
        ----------
        R : array_like, real, (n, m)
            The basis, e.g. the first m POD modes.

        Returns
        -------
        SecondOrderSystem
            Dense m × m matrices (for a sparse system the products are sparse × dense).

        Raises
        ------
        ValueError
            When R is not a real, finite (n, m) array.
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
    Dense and sparse chains hold the same entries, bit for bit.

    Parameters
    ----------
    n : int
        Number of masses (DOFs), ≥ 1; the paper's is 100.
    m1, m2 : float
        The two masses, > 0.
    ku : float
        Spring stiffness, > 0.
    a0, a1 : float
        Rayleigh coefficients, ≥ 0.
    sparse : bool, optional
        True: ``scipy.sparse.csr_array`` matrices, each line one O(n) tridiagonal
        solve; False: dense arrays (3n² doubles); None (default): sparse above
        :data:`DENSE_CHAIN_MAX` DOFs.

    Returns
    -------
    SecondOrderSystem
        The chain.

    Raises
    ------
    ValueError
        For a count or a parameter out of range.
    MemoryError
        When the matrices would not fit.
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

    Parameters
    ----------
    nx, ny : int
        Masses along x and y, ≥ 1 each.
    mass : float
        Nominal mass, > 0.
    k : float
        Nominal spring stiffness, > 0.
    a0, a1 : float
        Rayleigh coefficients, ≥ 0.
    mass_variation, stiffness_variation : float
        Fractions in [0, 1): every mass and every spring is drawn independently,
        uniform in ``(1 ± variation)`` times its nominal value, which splits the
        repeated modes.
    seed : int, optional
        Seed of those draws (reproducible lattices).

    Returns
    -------
    SecondOrderSystem
        The lattice, sparse (``scipy.sparse.csr_array``), five entries per row.

    Raises
    ------
    ValueError
        For a count or a parameter out of range.
    MemoryError
        When the matrices would not fit.
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
