"""Input checks shared by every identification path.

Every identification path passes its data through here, so that bad input gives
the same clear ``ValueError`` whichever backend runs, and the caller's arrays are
never modified (fresh copies, or read-only views of U and F).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._arrays import as_array_nocopy, as_omega

Triple = tuple[float, float, float]


@dataclass(frozen=True)
class FrequencyData:
    """Validated frequency-domain data, frequency-first.

    ``U`` and ``F`` are read-only C-contiguous complex128 arrays shaped ``(s, m, p)``
    (p load cases per frequency line); ``omega`` is a fresh float64 array ``(s,)``.
    """

    U: np.ndarray
    F: np.ndarray
    omega: np.ndarray

    @property
    def s(self) -> int:
        return self.U.shape[0]

    @property
    def m(self) -> int:
        return self.U.shape[1]

    @property
    def p(self) -> int:
        return self.U.shape[2]

    @property
    def n_columns(self) -> int:
        """Number of complex response vectors, N = s * p."""
        return self.s * self.p

    def columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Data as N stacked vectors: U (N, m), F (N, m), omega (N,)."""
        U = np.ascontiguousarray(self.U.transpose(0, 2, 1).reshape(-1, self.m))
        F = np.ascontiguousarray(self.F.transpose(0, 2, 1).reshape(-1, self.m))
        w = np.repeat(self.omega, self.p)
        return U, F, w


def _read_only(a: np.ndarray) -> np.ndarray:
    """A C-contiguous complex128 view of ``a`` that cannot be written through
    (copied only if its dtype or layout must change): no defensive copy of large
    spectra (0.25 s at s = 2000, m = 1000), and no path can modify the caller's data.
    """
    v = np.ascontiguousarray(a, dtype=np.complex128).view()
    v.flags.writeable = False
    return v


def check_frequency_data(U: object, F: object, omega: object) -> FrequencyData:
    """Validate responses ``U``, forces ``F`` and angular frequencies ``omega``.

    Accepted shapes: ``U``/``F`` ``(s, m)`` or ``(s, m, p)``, ``omega`` ``(s,)`` in
    rad/s, all finite, ``omega > 0``. U and F are read-only views (copies where
    their dtype or layout must change), omega a copy; inputs are untouched.
    """
    Ua = _read_only(as_array_nocopy(U, "U"))
    Fa = _read_only(as_array_nocopy(F, "F"))
    w = as_omega(omega)
    if Ua.ndim not in (2, 3):
        raise ValueError(f"U must have shape (s, m) or (s, m, p); got shape {Ua.shape}")
    if Fa.ndim not in (2, 3):
        raise ValueError(f"F must have shape (s, m) or (s, m, p) like U; got shape {Fa.shape}")
    if Ua.ndim == 2:
        Ua = Ua[:, :, None]
    if Fa.ndim == 2:
        Fa = Fa[:, :, None]
    if Fa.shape != Ua.shape:
        squeeze = lambda a: a.shape[:2] if a.shape[2] == 1 else a.shape  # noqa: E731
        raise ValueError(
            "F must have the same shape as U (frequency-first (s, m) or (s, m, p)); "
            f"got U {squeeze(Ua)} and F {squeeze(Fa)}"
        )
    if w.shape[0] != Ua.shape[0]:
        raise ValueError(
            f"omega must be 1-D with one entry per frequency line (s = {Ua.shape[0]}); "
            f"got shape {w.shape}"
        )
    if 0 in Ua.shape:
        raise ValueError(f"empty data: U has shape {Ua.shape}")
    if not np.any(Ua):
        raise ValueError("U is identically zero: there is nothing to identify from")
    return FrequencyData(Ua, Fa, w)


def check_lam(lam: object) -> Triple:
    """Normalise a regularisation parameter to a (λ_M, λ_C, λ_K) triple (paper eq. 40)."""
    if isinstance(lam, str):
        raise ValueError(
            f"lam={lam!r} is a selection rule, not a number; "
            "pass a float or a (lam_M, lam_C, lam_K) triple here"
        )
    try:
        arr = np.asarray(lam, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"lam must be a float or a triple of floats, got {lam!r}") from None
    if arr.ndim == 0:
        arr = np.repeat(arr, 3)
    if arr.shape != (3,):
        raise ValueError(f"lam must be a float or a triple (lam_M, lam_C, lam_K), got {lam!r}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"lam values must be finite and non-negative, got {lam!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def count_equations(data: FrequencyData, lam: Triple, symmetric: bool) -> tuple[int, int]:
    """Real equations available and real unknowns, for the well-posedness check.

    Each complex response vector gives 2m real equations; a positive λ on a block
    adds m(m-1)/2 equations pinning its skew part. Unknowns: 3m² (penalty form) or
    3m(m+1)/2 (exact-symmetric form).
    """
    m = data.m
    eq = 2 * data.n_columns * m
    if symmetric:
        return eq, 3 * m * (m + 1) // 2
    eq += sum(m * (m - 1) // 2 for v in lam if v > 0)
    return eq, 3 * m * m
