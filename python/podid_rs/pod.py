"""Proper orthogonal decomposition of responses (paper Sections 2.1–2.2 and 5, steps 1–5).

Every correlation matrix here has the form ``Ruu = c · AᵀA`` for a real
"snapshot" matrix A ``(k, n)``: time samples (eq. 3), or the real and imaginary
parts of spectra or FRF columns, weighted by the quadrature over the band
(eq. 4). Its POD is computed from whichever side is smaller:

* ``method="correlation"`` — the n × n matrix Ruu and its eigendecomposition
  (eq. 5), as the paper writes it; all n modes;
* ``method="snapshots"`` — the k × k Gram matrix A Aᵀ (Sirovich's method of
  snapshots): the same non-zero eigenvalues, and modes ``φ_j = Aᵀ v_j / √μ_j``;
  no n × n array, so a 10⁵-DOF model or a 10⁴-point scan costs O(k² n). Only the
  (at most k) modes with non-zero energy exist; they are formed when asked for.

``method="auto"`` (the default) takes the snapshot side when k < n. The two
agree to round-off in the eigenvalues and in every mode whose eigenvalue is
separated from the others (tested to 1e-10).

Noise on the responses adds its own covariance to ``Ruu``. Independent noise of
unequal variance per channel (the paper's eq. 53: each channel's noise is a fixed
fraction of its own signal) is a diagonal ``Rnn`` that turns the POD modes away
from the signal's; given its variances (``noise_variance``), :func:`pod` and
:func:`pod_from_spectra` decompose ``Ruu − Rnn`` instead — on the snapshot side
restricted to the span of the data (the Rayleigh–Ritz step), which is exact when
the data span every DOF.
"""

from __future__ import annotations

import warnings

import numpy as np

from podid_rs._arrays import as_array, as_array_nocopy, as_count, as_omega
from podid_rs._memory import FLOAT_BYTES, require_memory

METHODS = ("auto", "correlation", "snapshots")
_COLUMN_BLOCK = 4096  # DOFs per block when a product over all n is formed piecewise


def correlation_from_snapshots(snapshots: object) -> np.ndarray:
    """Time-averaged correlation ``Ruu = ⟨u uᵀ⟩`` of snapshots (eqs. 3, 41).

    The average is over the r snapshots (rows); the mean is not removed.

    Parameters
    ----------
    snapshots : array_like, real, (r, n)
        Responses, time first.

    Returns
    -------
    numpy.ndarray, (n, n)
        Ruu, exactly symmetric.

    Raises
    ------
    ValueError
        For a non-numeric, non-finite or empty array.
    MemoryError
        When the n × n matrix would not fit.
    """
    u = as_array(snapshots, "snapshots", real=True)
    if u.ndim != 2 or u.shape[0] == 0 or u.shape[1] == 0:
        raise ValueError(f"snapshots must have shape (r, n), time first, got {u.shape}")
    _require_correlation(u.shape[1])
    R = u.T @ u / u.shape[0]
    return 0.5 * (R + R.T)


def _check_frf(H: object, omega: object) -> tuple[np.ndarray, np.ndarray]:
    Ha = as_array_nocopy(H, "H")
    w = as_omega(omega)
    if Ha.ndim != 3 or Ha.shape[0] != w.size or Ha.shape[1] == 0 or Ha.shape[2] == 0:
        raise ValueError(
            f"H must have shape (s, n, n_in) with s = {w.size} lines (len(omega)), got {Ha.shape}"
        )
    if w.size < 2 or np.any(np.diff(w) <= 0):
        raise ValueError("omega must hold at least 2 strictly increasing lines to integrate over")
    return Ha, w


def _trapezoid_weights(w: np.ndarray) -> np.ndarray:
    """Weights q with ``Σ q_k f_k`` = the trapezoid rule of f over the lines w."""
    q = np.zeros(w.size)
    d = 0.5 * np.diff(w)
    q[:-1] += d
    q[1:] += d
    return q


def _stacked_rows(X: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Real snapshot rows ``[Re x; Im x]`` ``(2·s·p, n)`` of complex ``X`` ``(s, n, p)``.

    ``Σ Re(x xᴴ)`` over the columns x = X[k, :, j] (times ``weights[k]``) is AᵀA.
    """
    s, n, p = X.shape
    require_memory(2 * 2 * FLOAT_BYTES * s * n * p, f"the POD snapshots of {s} × {p} × {n} values")
    Y = X.transpose(0, 2, 1)  # (s, p, n)
    if weights is not None:
        Y = Y * np.sqrt(weights)[:, None, None]
    A = np.empty((2, s, p, n))
    A[0], A[1] = Y.real, Y.imag
    return A.reshape(2 * s * p, n)


def correlation_from_frf(H: object, omega: object) -> np.ndarray:
    """``Ruu = ∫_B Re(H(ω) H(ω)ᴴ) dω`` by the trapezoid rule over the given lines (eq. 4).

    The response correlation under incoherent white noise of unit one-sided PSD
    (per rad/s) on every input over the band B. The paper writes ``Re(HᴴH)``; for
    reciprocal (symmetric) H the two agree, and ``H Hᴴ`` is the form that is right
    in general. Under :func:`podid_rs.simulate_white_noise` with variance ``σ²`` per
    DOF, ``⟨u uᵀ⟩ ≈ σ² / (ω_hi − ω_lo) · Ruu``. Formed as one product AᵀA of the
    weighted real and imaginary FRF columns (no (s, n, n) array).

    Parameters
    ----------
    H : array_like, complex, (s, n, n_in)
        FRFs, frequency first.
    omega : array_like, (s,)
        Strictly increasing angular frequencies (rad/s), all > 0.

    Returns
    -------
    numpy.ndarray, (n, n)
        Ruu, exactly symmetric.

    Raises
    ------
    ValueError
        For malformed ``H`` or ``omega``.
    MemoryError
        When the n × n matrix would not fit.
    """
    Ha, w = _check_frf(H, omega)
    _require_correlation(Ha.shape[1])
    A = _stacked_rows(Ha, _trapezoid_weights(w))
    R = A.T @ A
    return 0.5 * (R + R.T)


def _require_correlation(n: int) -> None:
    require_memory(
        3 * FLOAT_BYTES * n**2,
        f"the {n} × {n} correlation matrix and its eigenvectors",
        "use method='snapshots' (POD from the snapshots' Gram matrix)",
    )


class PODResult:
    """POD of a correlation matrix: ``Ruu = Σ λ_i φ_i φ_iᵀ`` (eqs. 5, 42).

    From the correlation matrix every mode is kept; by the method of snapshots only
    the k modes of non-zero energy exist (the eigenvalues after them are zero), and
    they are formed on first use — ``basis(m)`` forms only m. Made by :func:`pod`,
    :func:`pod_from_frf`, :func:`pod_from_spectra` and :func:`pod_from_correlation`.

    Parameters
    ----------
    eigenvalues : array_like, (n,)
        Descending, non-negative.
    modes : array_like, (n, n_modes)
        The orthonormal POD modes as columns, each signed so that its
        largest-magnitude component is positive.

    Attributes
    ----------
    eigenvalues : numpy.ndarray, (n,)
        The eigenvalues λ_i, descending, non-negative.
    modes : numpy.ndarray, (n, n_modes)
        The POD modes as columns (formed on first use).
    n : int
        Number of DOFs of the full response.
    n_modes : int
        Number of modes available (n, or the rank of the snapshots).
    method : str
        ``"correlation"`` or ``"snapshots"``: the side the POD was computed from.
    energy_fraction : numpy.ndarray, (n,)
        Cumulative energy fraction ``Σ_{i≤m} λ_i / Σ λ_i`` for m = 1…n (eqs. 7, 43).
    noise_variance : numpy.ndarray, (n,), or None
        The per-DOF noise variances removed from ``Ruu`` before the decomposition
        (:meth:`without_noise`), if any.
    """

    noise_variance: np.ndarray | None = None
    """The per-DOF noise variances removed from ``Ruu`` before the decomposition, if any."""

    def __init__(self, eigenvalues: np.ndarray, modes: np.ndarray) -> None:
        self._eigenvalues = np.asarray(eigenvalues)
        self._modes: np.ndarray | None = np.asarray(modes)
        self._n = self._modes.shape[0]
        self._snapshots: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._formed: np.ndarray | None = None

    @classmethod
    def _from_snapshots(
        cls, eigenvalues: np.ndarray, A: np.ndarray, V: np.ndarray, sigma: np.ndarray
    ) -> PODResult:
        """Modes ``Aᵀ V[:, j] / sigma[j]``, formed lazily from the snapshot rows A (k, n)."""
        self = cls.__new__(cls)
        self._eigenvalues = eigenvalues
        self._modes = None
        self._n = A.shape[1]
        self._snapshots = (A, V, sigma)
        self._formed = None
        return self

    def __repr__(self) -> str:
        noise = "" if self.noise_variance is None else ", noise-corrected"
        return f"PODResult(n={self.n}, n_modes={self.n_modes}, from the {self.method}{noise})"

    @property
    def method(self) -> str:
        """``"correlation"`` or ``"snapshots"``: the side the POD was computed from."""
        return "snapshots" if self._snapshots is not None else "correlation"

    @property
    def eigenvalues(self) -> np.ndarray:
        """The eigenvalues λ_i ``(n,)``, descending, non-negative."""
        return self._eigenvalues

    @property
    def n(self) -> int:
        """Number of DOFs of the full response."""
        return self._n

    @property
    def n_modes(self) -> int:
        """Number of modes available (n, or the rank of the snapshots)."""
        if self._modes is not None:
            return self._modes.shape[1]
        return self._snapshots[1].shape[1]

    @property
    def modes(self) -> np.ndarray:
        """The POD modes ``(n, n_modes)`` as columns (formed on first use)."""
        if self._modes is None:
            self._modes = self._snapshot_modes(self.n_modes)
            self._formed = None
        return self._modes

    def _snapshot_modes(self, m: int) -> np.ndarray:
        """The first m modes from the snapshots; the widest set formed so far is kept."""
        formed = self._formed
        if formed is None or formed.shape[1] < m:
            A, V, sigma = self._snapshots
            require_memory(FLOAT_BYTES * self.n * m, f"{m} POD modes of {self.n} DOFs")
            phi = A.T @ (V[:, :m] / sigma[:m])
            # Aᵀv/σ is orthonormal only to eps·λ₁/λ_i: a mode of relative energy 3e-13
            # was off by 6e-7. Gram–Schmidt (QR) makes them orthonormal and leaves the
            # first j spanning the same space for every j; each column's sign is set next
            phi = np.linalg.qr(phi)[0]
            formed = self._formed = phi * _lead_signs(phi)
        return formed[:, :m]

    @property
    def energy_fraction(self) -> np.ndarray:
        """Cumulative energy fraction ``Σ_{i≤m} λ_i / Σ λ_i`` for m = 1…n (eqs. 7, 43)."""
        cum = np.cumsum(self.eigenvalues)
        return cum / cum[-1]

    def order_for_energy(self, k: float) -> int:
        """The smallest m whose modes capture at least the fraction ``k`` of the energy (eq. 43).

        Parameters
        ----------
        k : float
            Energy fraction, 0 < k ≤ 1.

        Returns
        -------
        int
            m, at most the number of modes available.

        Raises
        ------
        ValueError
            For k outside (0, 1].
        """
        ka = as_array(k, "k", real=True)
        if ka.ndim != 0 or not 0 < ka <= 1:
            raise ValueError(f"the energy fraction k must satisfy 0 < k <= 1, got {k!r}")
        m = int(np.searchsorted(self.energy_fraction, ka, side="left")) + 1
        return min(m, self.n_modes)

    def basis(self, m: int) -> np.ndarray:
        """``R = [φ_1 … φ_m]``, the first m POD modes (eqs. 11, 44).

        Parameters
        ----------
        m : int
            The reduced order, 1 ≤ m ≤ the number of modes available.

        Returns
        -------
        numpy.ndarray, (n, m)
            A fresh copy of the modes.

        Raises
        ------
        ValueError
            For m out of range (beyond the modes that carry energy on the snapshot side).
        MemoryError
            When m modes of n DOFs would not fit.
        """
        m = as_count(m, "m", 1, self.n)
        if m > self.n_modes:
            raise ValueError(
                f"only {self.n_modes} POD modes carry energy (the snapshots have rank "
                f"{self.n_modes}), m = {m} asked for"
            )
        if self._modes is None:
            return self._snapshot_modes(m).copy()
        return self._modes[:, :m].copy()

    def without_noise(self, noise_variance: object) -> PODResult:
        """The POD of ``Ruu − diag(noise_variance)``: the correlation less that of
        independent noise on each DOF.

        Rayleigh–Ritz on the span Q of these modes — ``QᵀRuuQ = diag(λ)``, so a
        k × k eigenproblem of ``diag(λ) − Qᵀ D Q`` — exact from the correlation
        matrix (Q is complete); by the method of snapshots Q is the span of the
        data, ``Q = Aᵀ V Σ⁻¹``, and no n × n array is formed (cost: one more
        product of the snapshots' size, as much as the POD itself). Eigenvalues the
        noise drives negative count as zero energy. (Restricting the step to a few
        leading modes is not enough: on the paper's chain, band 3 at 10 dB, the
        corrected 10-mode subspace still moves 7° with the leading 50 of 100 modes.)

        What it removes is the noise's *bias*, which dominates when the record has
        many more snapshots than DOFs; with fewer (the snapshot side) the modes' error
        is sampling error, and the correction changes them little (measured on a
        rank-3 signal, 200–800 snapshots of 400–1000 DOFs: 3.37° → 3.37°, 1.60° →
        1.59°, even with the exact n × n correction).

        Parameters
        ----------
        noise_variance : float or array_like, (n,)
            The noise variance of each DOF, in ``Ruu``'s units, ≥ 0. Where it exceeds a
            channel's measured mean square (``diag(Ruu)``, sampling error) it is clipped
            there with a warning.

        Returns
        -------
        PODResult
            The corrected POD, with ``noise_variance`` set.

        Raises
        ------
        ValueError
            When this POD is already noise-corrected, or for a variance that is negative,
            of the wrong shape, or more than twice a channel's mean square.
        """
        if self.noise_variance is not None:
            raise ValueError("this POD is already noise-corrected")
        d = _check_noise_variance(noise_variance, self._measured_mean_squares())
        if self._snapshots is None:
            Q, lam = self._modes, self._eigenvalues
            QtDQ = Q.T @ (Q * d[:, None])
        else:
            A, V, sigma = self._snapshots
            lam = self._eigenvalues[: sigma.size]
            Q = V / sigma  # the modes are Aᵀ Q
            ADA = np.zeros((A.shape[0], A.shape[0]))
            for j in range(0, self.n, _COLUMN_BLOCK):  # by column blocks: no copy of A
                B = A[:, j : j + _COLUMN_BLOCK] * np.sqrt(d[j : j + _COLUMN_BLOCK])
                ADA += B @ B.T
            QtDQ = Q.T @ ADA @ Q
        theta, W = _descending_eigh(np.diag(lam) - QtDQ)
        if self._snapshots is None:
            phi = Q @ W
            out = PODResult(eigenvalues=theta, modes=phi * _lead_signs(phi))
        else:
            eigenvalues = np.zeros(self.n)
            eigenvalues[: theta.size] = theta
            out = PODResult._from_snapshots(eigenvalues, A, Q @ W, np.ones(theta.size))
        out.noise_variance = d
        return out

    def _measured_mean_squares(self) -> np.ndarray:
        """``diag(Ruu)``: each DOF's mean square."""
        if self._snapshots is None:
            return (self._modes * self._modes) @ self._eigenvalues
        A, _, sigma = self._snapshots
        scale = self._eigenvalues[0] / sigma[0] ** 2  # Ruu = scale · AᵀA
        return scale * np.einsum("ij,ij->j", A, A)

    def project(self, X: object, m: int) -> np.ndarray:
        """Reduced coordinates ``Rᵀ X`` on each line (eqs. 12, 17–18, 45–46).

        Parameters
        ----------
        X : array_like, (s, n) or (s, n, p)
            Responses or forces, frequency- (or time-) first.
        m : int
            The reduced order: R is :meth:`basis` (m).

        Returns
        -------
        numpy.ndarray, (s, m) or (s, m, p)
            The reduced coordinates.

        Raises
        ------
        ValueError
            For m out of range or X of the wrong shape.
        """
        R = self.basis(m)
        Xa = as_array_nocopy(X, "X")
        if Xa.ndim not in (2, 3) or Xa.shape[1] != self.n:
            raise ValueError(
                f"X must have shape (s, n) or (s, n, p) with n = {self.n}, got {Xa.shape}"
            )
        # GEMMs (one per line for p load cases), not einsum's loop: 20× faster at n = 10⁵
        return Xa @ R if Xa.ndim == 2 else np.matmul(R.T, Xa)


def _lead_signs(phi: np.ndarray) -> np.ndarray:
    """+1/−1 per column: the sign that makes its largest-magnitude component positive."""
    return np.sign(phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])])


def pod_from_correlation(Ruu: object) -> PODResult:
    """Eigendecomposition of a symmetric positive semi-definite correlation matrix (eq. 5).

    Negative eigenvalues within round-off (above ``−1e-8 λ_max``) are set to zero.

    Parameters
    ----------
    Ruu : array_like, real, (n, n)
        The correlation matrix.

    Returns
    -------
    PODResult
        Every mode, from the correlation matrix.

    Raises
    ------
    ValueError
        For a matrix that is not square, is zero, is not symmetric (to 1e-10
        relative) or has an eigenvalue below ``−1e-8 λ_max``.
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
    return PODResult(eigenvalues=np.clip(lam, 0.0, None), modes=phi * _lead_signs(phi))


def _pod_of_snapshots(A: np.ndarray, scale: float) -> PODResult:
    """POD of ``Ruu = scale · AᵀA`` from the Gram matrix ``A Aᵀ`` (method of snapshots)."""
    k, n = A.shape
    require_memory(
        3 * FLOAT_BYTES * k**2, f"the {k} × {k} Gram matrix of the POD snapshots",
        "use fewer snapshots (lines, load cases) or method='correlation'",
    )
    G = A @ A.T
    mu, V = np.linalg.eigh(0.5 * (G + G.T))
    mu, V = mu[::-1], V[:, ::-1]
    if mu[0] <= 0:
        raise ValueError("the snapshots are identically zero: there is no energy to decompose")
    rank = int(np.count_nonzero(mu > max(k, n) * np.finfo(float).eps * mu[0]))
    # past the rank the eigenvalues are zero: what eigh gives there is round-off (some of
    # it positive), and no mode goes with it
    lam = np.zeros(n)
    lam[:rank] = scale * mu[:rank]
    return PODResult._from_snapshots(lam, A, V[:, :rank], np.sqrt(mu[:rank]))


def _choose(method: str, k: int, n: int) -> str:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "auto":
        return "snapshots" if k < n else "correlation"
    return method


def pod(
    snapshots: object, method: str = "auto", noise_variance: object | None = None
) -> PODResult:
    """POD of time snapshots: eigendecomposition of ``⟨u uᵀ⟩`` (eqs. 3, 5).

    Parameters
    ----------
    snapshots : array_like, real, (r, n)
        Responses, time first.
    method : {"auto", "correlation", "snapshots"}
        ``"correlation"`` (n × n), ``"snapshots"`` (r × r Gram matrix), or
        ``"auto"``: the smaller of the two.
    noise_variance : float or array_like, (n,), optional
        The variance of independent noise on each response channel (e.g. from a
        noise-floor record); the POD is then that of ``⟨u uᵀ⟩ − diag(noise_variance)``,
        the noise-free correlation's estimate (:meth:`PODResult.without_noise`).

    Returns
    -------
    PODResult
        The POD.

    Raises
    ------
    ValueError
        For malformed snapshots, an unknown ``method``, zero snapshots or a bad
        ``noise_variance``.
    MemoryError
        When the chosen side's matrix would not fit.
    """
    u = as_array(snapshots, "snapshots", real=True)
    if u.ndim != 2 or u.shape[0] == 0 or u.shape[1] == 0:
        raise ValueError(f"snapshots must have shape (r, n), time first, got {u.shape}")
    if _choose(method, *u.shape) == "correlation":
        P = pod_from_correlation(correlation_from_snapshots(u))
    else:
        P = _pod_of_snapshots(u, 1.0 / u.shape[0])
    return P if noise_variance is None else P.without_noise(noise_variance)


def pod_from_frf(H: object, omega: object, method: str = "auto") -> PODResult:
    """POD of the band-limited white-noise correlation built from an FRF (eqs. 4, 5).

    With more DOFs than the 2·s·n_in real snapshot columns (a scan of many points)
    ``method="auto"`` uses the method of snapshots and never forms an n × n (or
    (s, n, n)) array.

    Parameters
    ----------
    H : array_like, complex, (s, n, n_in)
        FRFs, frequency first.
    omega : array_like, (s,)
        Strictly increasing angular frequencies (rad/s), all > 0.
    method : {"auto", "correlation", "snapshots"}
        As for :func:`pod`.

    Returns
    -------
    PODResult
        The POD of :func:`correlation_from_frf`'s Ruu.

    Raises
    ------
    ValueError
        For malformed ``H`` or ``omega``, an unknown ``method`` or an FRF of zeros.
    MemoryError
        When the chosen side's matrix would not fit.
    """
    Ha, w = _check_frf(H, omega)
    s, n, p = Ha.shape
    if _choose(method, 2 * s * p, n) == "correlation":
        return pod_from_correlation(correlation_from_frf(Ha, w))
    return _pod_of_snapshots(_stacked_rows(Ha, _trapezoid_weights(w)), 1.0)


def pod_from_spectra(
    X: object, n_samples: int, method: str = "auto", noise_variance: object | None = None
) -> PODResult:
    """POD of ``⟨u uᵀ⟩`` over an r-sample record from its in-band real-FFT spectrum (Parseval).

    For the lines ``X`` of ``numpy.fft.rfft`` of a history ``u`` ``(r, n)`` whose
    other lines are zero (a band-limited record, as :func:`podid_rs.simulate_white_noise`
    makes), strictly between 0 Hz and Nyquist,
    ``⟨u uᵀ⟩ = (1/r) Σ_t u uᵀ = (2/r²) Σ_k Re(X_k X_kᴴ)``, so this equals
    ``pod(u)`` without the r × n history, from 2·s rows instead of r.

    Parameters
    ----------
    X : array_like, complex, (s, n) or (s, n, p)
        The in-band lines (p records).
    n_samples : int
        r, the record's samples, ≥ 2.
    method : {"auto", "correlation", "snapshots"}
        As for :func:`pod`.
    noise_variance : float or array_like, (n,), optional
        As for :func:`pod`: the variance of each channel's noise in the history (by
        Parseval, ``(2/r²) Σ_k E|N_k|²`` over its lines).

    Returns
    -------
    PODResult
        The POD.

    Raises
    ------
    ValueError
        For malformed ``X`` or ``n_samples``, an unknown ``method``, a zero spectrum
        or a bad ``noise_variance``.
    MemoryError
        When the chosen side's matrix would not fit.
    """
    Xa = as_array_nocopy(X, "X")
    if Xa.ndim == 2:
        Xa = Xa[:, :, None]
    if Xa.ndim != 3 or 0 in Xa.shape:
        raise ValueError(f"X must have shape (s, n) or (s, n, p), got {Xa.shape}")
    r = as_count(n_samples, "n_samples", 2)
    s, n, p = Xa.shape
    scale = 2.0 / r**2
    if _choose(method, 2 * s * p, n) == "correlation":
        _require_correlation(n)
        A = _stacked_rows(Xa)
        R = scale * (A.T @ A)
        P = pod_from_correlation(0.5 * (R + R.T))
    else:
        P = _pod_of_snapshots(_stacked_rows(Xa), scale)
    return P if noise_variance is None else P.without_noise(noise_variance)


def _descending_eigh(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenpairs of the symmetric part of T, descending, negative eigenvalues as zero."""
    theta, W = np.linalg.eigh(0.5 * (T + T.T))
    return np.clip(theta[::-1], 0.0, None), W[:, ::-1]


def _check_noise_variance(noise_variance: object, measured: np.ndarray) -> np.ndarray:
    """``noise_variance`` as a fresh ``(n,)`` array, checked against the measured
    mean squares ``diag(Ruu)``: finite and non-negative; above a channel's mean square
    (sampling error) it is clipped there with a warning, above twice it is refused."""
    n = measured.size
    d = as_array(noise_variance, "noise_variance", real=True)
    if d.ndim == 0:
        d = np.full(n, float(d))
    if d.shape != (n,):
        raise ValueError(
            f"noise_variance must be a number or have shape ({n},) (one per DOF), got {d.shape}"
        )
    if np.any(d < 0):
        j = int(np.argmin(d))
        raise ValueError(f"noise_variance must be non-negative, DOF {j} has {d[j]:.3g}")
    if np.any(d > 2 * measured):
        j = int(np.argmax(d - 2 * measured))
        raise ValueError(
            f"noise_variance of DOF {j} ({d[j]:.3g}) is more than twice the measured mean "
            f"square of that channel ({measured[j]:.3g}): check its units (the variance of "
            "the noise in the history, in the correlation's units)"
        )
    over = d > measured
    if np.any(over):
        j = int(np.flatnonzero(over)[0])
        warnings.warn(
            f"noise_variance reaches the measured mean square on {int(over.sum())} DOF(s) "
            f"(DOF {j}: {d[j]:.3g} against {measured[j]:.3g}; sampling error in a channel "
            "with little signal): taken as all noise there",
            stacklevel=4,
        )
        d = np.minimum(d, measured)
    return d.astype(float, copy=True)
