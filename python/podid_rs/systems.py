"""Linear second-order systems M ü + C u̇ + K u = f and the paper's test chain (Section 6.1)."""

from __future__ import annotations

import numpy as np

from podid_rs._arrays import as_array, as_count, as_omega, as_scalar


def _solve(Z: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched ``Z⁻¹ rhs`` over the leading (frequency) axis."""
    try:
        return np.linalg.solve(Z, rhs)
    except np.linalg.LinAlgError:
        raise ValueError("the dynamic stiffness is singular at one of the given omega") from None


class SecondOrderSystem:
    """A viscously damped linear system ``M ü + C u̇ + K u = f`` (paper eq. 1).

    ``M``, ``C`` and ``K`` are real square matrices of equal shape; they need not be
    symmetric and the damping need not be proportional. They are stored as copies.
    """

    def __init__(self, M: object, C: object, K: object) -> None:
        mats = [as_array(a, name, real=True) for a, name in ((M, "M"), (C, "C"), (K, "K"))]
        for a, name in zip(mats, "MCK", strict=True):
            if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
                raise ValueError(f"{name} must be a non-empty square matrix, got shape {a.shape}")
        if not mats[0].shape == mats[1].shape == mats[2].shape:
            raise ValueError(
                f"M, C and K must have the same shape, got {mats[0].shape}, "
                f"{mats[1].shape} and {mats[2].shape}"
            )
        self.M, self.C, self.K = mats

    @property
    def n(self) -> int:
        """Number of degrees of freedom."""
        return self.M.shape[0]

    def __repr__(self) -> str:
        return f"SecondOrderSystem(n={self.n})"

    def dynamic_stiffness(self, omega: object) -> np.ndarray:
        """``Z(ω) = −ω²M + iωC + K`` for each line, shape ``(s, n, n)`` complex (eq. 19)."""
        w = as_omega(omega)[:, None, None]
        return -(w**2) * self.M + 1j * w * self.C + self.K

    def frf(self, omega: object) -> np.ndarray:
        """Receptance ``H(ω) = Z(ω)⁻¹``, ``(s, n, n)`` complex (the transfer matrix of eq. 4)."""
        Z = self.dynamic_stiffness(omega)
        return _solve(Z, np.broadcast_to(np.eye(self.n), Z.shape))

    def response(self, omega: object, F: object) -> np.ndarray:
        """Steady-state response ``U = Z(ω)⁻¹ F`` per line (eq. 19).

        ``F`` is ``(s, n)`` or ``(s, n, p)`` (p load cases); ``U`` has the same shape.
        """
        Z = self.dynamic_stiffness(omega)
        Fa = as_array(F, "F")
        if Fa.ndim not in (2, 3) or Fa.shape[:2] != Z.shape[:2]:
            raise ValueError(
                f"F must have shape (s, n) or (s, n, p) with s = {Z.shape[0]} lines and "
                f"n = {self.n} DOFs, got {Fa.shape}"
            )
        if Fa.ndim == 2:
            return _solve(Z, Fa[:, :, None])[:, :, 0]
        return _solve(Z, Fa)

    def project(self, R: object) -> SecondOrderSystem:
        """Reduced system ``(RᵀMR, RᵀCR, RᵀKR)`` on the basis ``R`` ``(n, m)`` (eqs. 14–16)."""
        Ra = as_array(R, "R", real=True)
        if Ra.ndim != 2 or Ra.shape[0] != self.n or Ra.shape[1] == 0:
            raise ValueError(f"R must have shape (n, m) with n = {self.n}, got {Ra.shape}")
        return SecondOrderSystem(Ra.T @ self.M @ Ra, Ra.T @ self.C @ Ra, Ra.T @ self.K @ Ra)


def mass_spring_chain(
    n: int = 100,
    m1: float = 0.1,
    m2: float = 1.0,
    ku: float = 4e5,
    a0: float = 0.5,
    a1: float = 3e-5,
) -> SecondOrderSystem:
    """The paper's chain of n masses between two fixed walls (Section 6.1).

    Masses ``m1`` for the first ``n // 2`` DOFs and ``m2`` for the rest (eq. 51),
    ``K = ku · tridiag(−1, 2, −1)`` (eq. 52), Rayleigh damping ``C = a0 M + a1 K``.
    """
    n = as_count(n, "n", 1)
    m1, m2, ku = (as_scalar(v, name) for v, name in ((m1, "m1"), (m2, "m2"), (ku, "ku")))
    a0, a1 = (as_scalar(v, name, allow_zero=True) for v, name in ((a0, "a0"), (a1, "a1")))
    M = np.diag(np.where(np.arange(n) < n // 2, m1, m2))
    K = ku * (2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    return SecondOrderSystem(M, a0 * M + a1 * K, K)
