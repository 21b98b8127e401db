"""Solves of the dynamic stiffness ``Z(ω) = K − ω²M + iωC`` one frequency line at a time.

Large models are sparse: the paper's chain is tridiagonal, a 2-D lattice has
five entries per row. :class:`LineSolver` looks at the sparsity pattern of
M + C + K once and picks, for every line, the cheapest exact (pivoted) solve:

* ``"tridiagonal"`` — LAPACK ``zgtsv``, O(n) per line;
* ``"banded"`` — LAPACK ``zgbsv`` when the half-bandwidth is at most
  :data:`BANDED_MAX`, O(n·b²) per line;
* ``"sparse"`` — SuperLU (``scipy.sparse.linalg.splu``) with a minimum-degree
  ordering of Zᵀ + Z, for everything else (2-D and 3-D meshes);
* ``"dense"`` — LAPACK ``zgesv`` for very small systems.

Z(ω) is assembled per line from M, C, K stored once on the common pattern,
so memory is O(nnz) plus one factorisation per worker; nothing of size
(s, n, n) is ever formed. :func:`map_lines` runs a per-line job over a thread
pool (SuperLU and LAPACK release the GIL while they factorise).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

#: Largest half-bandwidth solved by the banded LU; wider patterns go to SuperLU.
BANDED_MAX = 8
#: Systems with at least this many DOFs solve their lines on several threads.
PARALLEL_MIN_N = 2000


def _assemble(
    w: float, M: np.ndarray, C: np.ndarray, K: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """``K − w²M + i·w·C`` elementwise into a complex array, without temporaries."""
    if out is None:
        out = np.empty(M.shape, dtype=np.complex128)
    np.multiply(M, -w * w, out=out.real)
    out.real += K
    np.multiply(C, w, out=out.imag)
    return out


def _singular(w: float) -> ValueError:
    return ValueError(f"the dynamic stiffness is singular at omega = {w:g} rad/s")


class LineSolver:
    """``X = Z(ω)⁻¹ B`` for a fixed sparse system and any ω (paper eq. 19).

    ``M``, ``C``, ``K`` are scipy.sparse matrices of one shape (n, n), real.
    """

    def __init__(self, M: sp.sparray, C: sp.sparray, K: sp.sparray) -> None:
        n = M.shape[0]
        self.n = n
        coo = [sp.coo_array(X) for X in (M, C, K)]
        rows = np.concatenate([c.row for c in coo]).astype(np.int64)
        cols = np.concatenate([c.col for c in coo]).astype(np.int64)
        kl = int(max((rows - cols).max(initial=0), 0))
        ku = int(max((cols - rows).max(initial=0), 0))
        self.bandwidth = (kl, ku)
        if n < 3:
            self.kind = "dense"
            self._dense = [X.toarray() for X in (M, C, K)]
        elif kl <= 1 and ku <= 1:
            self.kind = "tridiagonal"
            self._diags = [
                (X.diagonal(-1).astype(float), X.diagonal(0).astype(float),
                 X.diagonal(1).astype(float))
                for X in (M, C, K)
            ]
        elif max(kl, ku) <= BANDED_MAX:
            self.kind = "banded"
            # LAPACK band storage: band[ku + i - j, j] = X[i, j]
            self._bands = []
            for c in coo:
                band = np.zeros((kl + ku + 1, n))
                np.add.at(band, (ku + c.row - c.col, c.col), c.data)
                self._bands.append(band)
        else:
            self.kind = "sparse"
            # the union pattern in CSC order (column-major keys), and each matrix's
            # values placed on it
            keys = cols * n + rows
            pattern = np.unique(keys)
            self._indices = (pattern % n).astype(np.int32)
            self._indptr = np.concatenate(
                [[0], np.cumsum(np.bincount(pattern // n, minlength=n))]
            ).astype(np.int32)
            self._values = []
            start = 0
            for c in coo:
                stop = start + c.nnz
                v = np.zeros(pattern.size)
                np.add.at(v, np.searchsorted(pattern, keys[start:stop]), c.data)
                self._values.append(v)
                start = stop

    def solve(self, w: float, B: np.ndarray) -> np.ndarray:
        """``Z(w)⁻¹ B`` for ``B`` ``(n, q)`` complex; returns a fresh ``(n, q)`` array."""
        w = float(w)
        if self.kind == "tridiagonal":
            dl, d, du = (_assemble(w, *parts) for parts in zip(*self._diags, strict=True))
            *_, x, info = scipy.linalg.lapack.zgtsv(
                dl, d, du, B, overwrite_dl=1, overwrite_d=1, overwrite_du=1, overwrite_b=0
            )
        elif self.kind == "banded":
            kl, ku = self.bandwidth
            Mb, Cb, Kb = self._bands
            ab = np.zeros((2 * kl + ku + 1, self.n), dtype=np.complex128)
            _assemble(w, Mb, Cb, Kb, out=ab[kl:])
            *_, x, info = scipy.linalg.lapack.zgbsv(kl, ku, ab, B, overwrite_ab=1)
        elif self.kind == "sparse":
            Mv, Cv, Kv = self._values
            Z = sp.csc_matrix(
                (_assemble(w, Mv, Cv, Kv), self._indices, self._indptr),
                shape=(self.n, self.n),
            )
            try:
                lu = spla.splu(Z, permc_spec="MMD_AT_PLUS_A")
            except RuntimeError:  # "Factor is exactly singular"
                raise _singular(w) from None
            x, info = lu.solve(B), 0
        else:
            Md, Cd, Kd = self._dense
            try:
                x, info = np.linalg.solve((Kd - w * w * Md) + 1j * (w * Cd), B), 0
            except np.linalg.LinAlgError:
                raise _singular(w) from None
        if info > 0 or not np.all(np.isfinite(x)):
            raise _singular(w)
        return x


def default_threads(n: int) -> int:
    """Worker threads for per-line solves of an n-DOF system: all cores when it pays."""
    return (os.cpu_count() or 1) if n >= PARALLEL_MIN_N else 1


def _one_blas_thread():
    """Context in which BLAS runs single-threaded (the lines are the parallel axis).

    SuperLU's and LAPACK's inner BLAS calls are small: OpenBLAS threads only contend
    with the line workers, and on a loaded machine their busy-waiting made a 120-DOF
    lattice's FRF 20× slower (measured). Without threadpoolctl nothing is changed.
    """
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def map_lines(count: int, work: Callable[[int], None], threads: int) -> None:
    """Call ``work(i)`` for i = 0 … count−1, on ``threads`` threads (1 = in this thread).

    BLAS is held to one thread meanwhile. The first exception raised by any call
    is re-raised here.
    """
    with _one_blas_thread():
        if threads <= 1 or count < 2:
            for i in range(count):
                work(i)
            return
        with ThreadPoolExecutor(max_workers=min(threads, count)) as pool:
            for _ in pool.map(work, range(count)):
                pass
