"""Proper orthogonal decomposition of responses (paper Sections 2.1–2.2 and 5, steps 1–5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from podid_rs._arrays import as_array, as_count, as_omega


def correlation_from_snapshots(snapshots: object) -> np.ndarray:
    """Time-averaged correlation ``Ruu = ⟨u uᵀ⟩`` of snapshots ``(r, n)`` (eqs. 3, 41).

    The average is over the r snapshots (rows); the mean is not removed.
    """
    u = as_array(snapshots, "snapshots", real=True)
    if u.ndim != 2 or u.shape[0] == 0 or u.shape[1] == 0:
        raise ValueError(f"snapshots must have shape (r, n), time first, got {u.shape}")
    R = u.T @ u / u.shape[0]
    return 0.5 * (R + R.T)


def correlation_from_frf(H: object, omega: object) -> np.ndarray:
    """``Ruu = ∫_B Re(H(ω) H(ω)ᴴ) dω`` by the trapezoid rule over the given lines (eq. 4).

    ``H`` is ``(s, n, n_in)``, ``omega`` ``(s,)`` strictly increasing (rad/s). This is
    the response correlation under incoherent white noise of unit one-sided PSD
    (per rad/s) on every input over the band B. The paper writes ``Re(HᴴH)``; for
    reciprocal (symmetric) H the two agree, and ``H Hᴴ`` is the form that is right
    in general. Under :func:`podid_rs.simulation.simulate_white_noise` with
    variance ``σ²`` per DOF, ``⟨u uᵀ⟩ ≈ σ² / (ω_hi − ω_lo) · Ruu``.
    """
    Ha = as_array(H, "H")
    w = as_omega(omega)
    if Ha.ndim != 3 or Ha.shape[0] != w.size or Ha.shape[1] == 0 or Ha.shape[2] == 0:
        raise ValueError(
            f"H must have shape (s, n, n_in) with s = {w.size} lines (len(omega)), got {Ha.shape}"
        )
    if w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError("omega must hold at least 2 strictly increasing lines to integrate over")
    HHh = np.real(Ha @ Ha.conj().transpose(0, 2, 1))
    R = np.trapezoid(HHh, w, axis=0)
    return 0.5 * (R + R.T)


@dataclass(frozen=True)
class PODResult:
    """POD of a correlation matrix: ``Ruu = Σ λ_i φ_i φ_iᵀ`` (eqs. 5, 42).

    ``eigenvalues`` ``(n,)`` descending and non-negative; ``modes`` ``(n, n)`` with
    the orthonormal POD modes as columns, each signed so that its largest-magnitude
    component is positive.
    """

    eigenvalues: np.ndarray
    modes: np.ndarray

    @property
    def n(self) -> int:
        """Number of DOFs of the full response."""
        return self.eigenvalues.size

    @property
    def energy_fraction(self) -> np.ndarray:
        """Cumulative energy fraction ``Σ_{i≤m} λ_i / Σ λ_i`` for m = 1…n (eqs. 7, 43)."""
        cum = np.cumsum(self.eigenvalues)
        return cum / cum[-1]

    def order_for_energy(self, k: float) -> int:
        """Smallest m whose modes capture at least the fraction ``k`` of the energy (eq. 43)."""
        ka = as_array(k, "k", real=True)
        if ka.ndim != 0 or not 0 < ka <= 1:
            raise ValueError(f"the energy fraction k must satisfy 0 < k <= 1, got {k!r}")
        return int(np.searchsorted(self.energy_fraction, ka, side="left")) + 1

    def basis(self, m: int) -> np.ndarray:
        """``R = [φ_1 … φ_m]`` ``(n, m)``, the first m POD modes (eqs. 11, 44)."""
        m = as_count(m, "m", 1, self.n)
        return self.modes[:, :m].copy()

    def project(self, X: object, m: int) -> np.ndarray:
        """Reduced coordinates ``Rᵀ X`` on each line (eqs. 12, 17–18, 45–46).

        ``X`` is frequency- (or time-) first, ``(s, n)`` or ``(s, n, p)``; the result
        is ``(s, m)`` or ``(s, m, p)``.
        """
        R = self.basis(m)
        Xa = as_array(X, "X")
        if Xa.ndim not in (2, 3) or Xa.shape[1] != self.n:
            raise ValueError(
                f"X must have shape (s, n) or (s, n, p) with n = {self.n}, got {Xa.shape}"
            )
        return np.einsum("nm,sn...->sm...", R, Xa)


def pod_from_correlation(Ruu: object) -> PODResult:
    """Eigendecomposition of a symmetric positive semi-definite correlation matrix (eq. 5).

    Negative eigenvalues within round-off (above ``−1e-8 λ_max``) are set to zero.
    """
    R = as_array(Ruu, "Ruu", real=True)
    if R.ndim != 2 or R.shape[0] != R.shape[1] or R.shape[0] == 0:
        raise ValueError(f"Ruu must be a non-empty square matrix, got shape {R.shape}")
    scale = np.abs(R).max()
    if scale == 0:
        raise ValueError("Ruu is identically zero: there is no energy to decompose")
    if np.abs(R - R.T).max() > 1e-10 * scale:
        raise ValueError("Ruu must be symmetric (a correlation matrix)")
    lam, phi = np.linalg.eigh(0.5 * (R + R.T))
    lam, phi = lam[::-1], phi[:, ::-1]
    if lam[-1] < -1e-8 * lam[0]:
        raise ValueError(
            f"Ruu is not positive semi-definite: eigenvalue {lam[-1]:.3g} "
            f"against largest {lam[0]:.3g}"
        )
    lead = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    return PODResult(eigenvalues=np.clip(lam, 0.0, None), modes=phi * np.sign(lead))


def pod(snapshots: object) -> PODResult:
    """POD of time snapshots ``(r, n)``: eigendecomposition of ``⟨u uᵀ⟩`` (eqs. 3, 5)."""
    return pod_from_correlation(correlation_from_snapshots(snapshots))


def pod_from_frf(H: object, omega: object) -> PODResult:
    """POD of the band-limited white-noise correlation built from an FRF (eqs. 4, 5)."""
    return pod_from_correlation(correlation_from_frf(H, omega))
