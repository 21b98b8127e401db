"""Synthetic measurements: band-limited white-noise forcing, noise, spectra and H1 FRFs.

Spectra here are NumPy's unnormalised real FFT along time,
``X_k = Σ_j x(t_j) exp(−iω_k t_j)``, kept on the lines inside the band. Multiply
by ``dt`` for an approximation of the continuous Fourier transform; responses
and forces carry the same factor, so it cancels in the identification.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import get_window

from podid_rs._arrays import as_array, as_count, as_scalar
from podid_rs._memory import require_memory
from podid_rs.systems import SecondOrderSystem


@dataclass(frozen=True)
class Simulation:
    """Steady-state response of a system to band-limited white noise.

    What :func:`simulate_white_noise` returns. Time histories are time-first.
    Without histories (large n, ``histories=False``) ``forces`` and ``response``
    are None and the spectra are the synthesised ones themselves; everything the
    POD needs is in them (:meth:`pod`, Parseval).

    Attributes
    ----------
    t : numpy.ndarray, (r,)
        Sample times (s).
    forces, response : numpy.ndarray, (r, n), or None
        The force and response histories, if kept.
    omega : numpy.ndarray, (s,)
        The FFT lines inside ``band_hz`` (rad/s).
    force_spectrum, response_spectrum : numpy.ndarray, complex, (s, n)
        The real FFT of the histories on those lines, exactly as :func:`spectra`
        returns them (``F_n(ω)``, ``U_n(ω)`` of eqs. 45–46).
    dt : float
        Sampling interval (s).
    band_hz : tuple of float
        The forcing band (lo, hi) in Hz.
    n_samples : int
        Samples r of the record (the histories' length, kept or not).
    """

    t: np.ndarray
    forces: np.ndarray | None
    response: np.ndarray | None
    omega: np.ndarray
    force_spectrum: np.ndarray
    response_spectrum: np.ndarray
    dt: float
    band_hz: tuple[float, float]

    @property
    def n_samples(self) -> int:
        """Samples r of the record (the histories' length, kept or not)."""
        return self.t.size

    def pod(self, method: str = "auto"):
        """POD of the response correlation ``⟨u uᵀ⟩`` over the record (eqs. 3, 5).

        Computed from the in-band response spectrum (:func:`podid_rs.pod_from_spectra`),
        equal by Parseval to ``pod(self.response)`` but without the r × n history.

        Parameters
        ----------
        method : {"auto", "correlation", "snapshots"}
            As for :func:`podid_rs.pod`.

        Returns
        -------
        PODResult
            The POD.

        Raises
        ------
        ValueError
            For an unknown ``method``.
        MemoryError
            When the chosen side's matrix would not fit.
        """
        from .pod import pod_from_spectra

        return pod_from_spectra(self.response_spectrum, self.n_samples, method=method)


#: ``histories=None`` keeps the time histories when both take at most this many bytes.
HISTORY_BYTES = 1 << 30


def white_noise_spectrum(rng: np.random.Generator, shape: tuple[int, int], scale: float,
                         block: int = 64) -> np.ndarray:
    """``scale · (x + i y)``, x and y standard normal ``shape`` draws from ``rng`` in turn.

    Bit for bit ``scale * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))``,
    drawn ``block`` rows at a time so that no real temporary of the full shape is made.
    """
    out = np.empty(shape, dtype=np.complex128)
    for part in (out.real, out.imag):
        for i in range(0, shape[0], block):
            part[i : i + block] = rng.standard_normal((min(block, shape[0] - i), shape[1]))
    out *= scale
    return out


def _band_lines(r: int, dt: float, band_hz: object) -> np.ndarray:
    """Indices of the real-FFT lines of an r-sample record that lie in ``band_hz``.

    ``band_hz=None`` keeps every line above 0 Hz. A band must satisfy
    ``0 < lo < hi < Nyquist`` and contain at least one line (ends inclusive).
    """
    f = np.fft.rfftfreq(r, dt)
    if band_hz is None:
        return np.flatnonzero(f > 0)
    band = as_array(band_hz, "band_hz", real=True)
    if band.shape != (2,):
        raise ValueError(f"band_hz must be a pair (lo, hi) in Hz, got {band_hz!r}")
    lo, hi = band
    nyquist = 0.5 / dt
    if not 0 < lo < hi < nyquist:
        raise ValueError(
            f"band_hz must satisfy 0 < lo < hi < Nyquist = {nyquist:g} Hz, got {band_hz!r}"
        )
    lines = np.flatnonzero((f >= lo) & (f <= hi))
    if lines.size == 0:
        raise ValueError(
            f"band_hz {band_hz!r} contains no frequency line; the resolution is {f[1]:g} Hz "
            "(lengthen the record or widen the band)"
        )
    return lines


def simulate_white_noise(
    system: SecondOrderSystem,
    band_hz: tuple[float, float],
    dt: float,
    duration: float,
    intensity: float = 1.0,
    seed: int | None = None,
    *,
    histories: bool | None = None,
    threads: int | None = None,
) -> Simulation:
    """Periodic steady-state response to incoherent band-limited white noise on every DOF.

    The "rain on the roof" loading of the paper (Sections 2.1 and 6.2). Every DOF
    gets an independent force whose real-FFT coefficients are circular complex
    Gaussian with equal expected power on each line inside ``band_hz`` and zero
    outside; the response is synthesised exactly, ``U_k = H(ω_k) F_k`` (eq. 19),
    and both are brought back to time by the inverse real FFT, so there is no
    transient and no leakage. The one-sided force PSD is about
    ``intensity / (hi − lo)`` per Hz, and the response correlation
    ``⟨u uᵀ⟩ ≈ intensity / (2π (hi − lo)) · Ruu`` with ``Ruu`` from
    :func:`podid_rs.pod.correlation_from_frf`.

    Parameters
    ----------
    system : SecondOrderSystem
        The structure.
    band_hz : tuple of float
        The forcing band (lo, hi) in Hz, ``0 < lo < hi <`` Nyquist, holding a line.
    dt : float
        Sampling interval (s), > 0.
    duration : float
        Record length (s): ``r = round(duration / dt)`` samples, at least 2; the line
        spacing is ``1 / (r dt)`` Hz.
    intensity : float
        Expected variance (mean square) of each force history, in force units
        squared; the paper's "unit variance" is 1.
    seed : int, optional
        Seed of the random forces.
    histories : bool, optional
        Keep the r × n time histories (True), or only the in-band spectra (False:
        memory O(s·n), the way to simulate 10⁵ DOFs); None (default) keeps them when
        they take at most 1 GB. The forces and the response are the same either way
        (the same random draws; spectra equal to round-off).
    threads : int, optional
        Worker threads for the per-line solves of a sparse system.

    Returns
    -------
    Simulation
        The record, its in-band spectra and lines.

    Raises
    ------
    ValueError
        For a system that is not a :class:`SecondOrderSystem`, a missing or empty band,
        a non-positive ``dt``, ``duration`` or ``intensity``, or fewer than 2 samples.
    MemoryError
        Before any work, when the result would not fit.
    """
    if not isinstance(system, SecondOrderSystem):
        raise ValueError(f"system must be a SecondOrderSystem, got {type(system).__name__}")
    if band_hz is None:
        raise ValueError("band_hz is required: the (lo, hi) band of the forcing in Hz")
    dt = as_scalar(dt, "dt")
    duration = as_scalar(duration, "duration")
    intensity = as_scalar(intensity, "intensity")
    r = round(duration / dt)
    if r < 2:
        raise ValueError(f"duration / dt gives {r} samples; at least 2 are needed")
    lines = _band_lines(r, dt, band_hz)
    omega = 2 * np.pi * np.fft.rfftfreq(r, dt)[lines]

    shape = (lines.size, system.n)
    history_bytes = 2 * 8 * r * system.n
    keep = history_bytes <= HISTORY_BYTES if histories is None else bool(histories)
    spectra_bytes = 3 * 16 * lines.size * system.n  # F, U and the solver's copy of F
    require_memory(
        spectra_bytes + (history_bytes + 16 * (r // 2 + 1) * system.n if keep else 0),
        f"simulating {system.n} DOFs over {lines.size} lines"
        + (f" with {r}-sample histories" if keep else ""),
        "pass histories=False to keep only the in-band spectra" if keep else "",
    )

    # Parseval: mean_t x² = (2 / r²) Σ_k |X_k|², so E|X_k|² = intensity · r² / (2 s).
    rng = np.random.default_rng(seed)
    scale = r * np.sqrt(intensity / (4 * lines.size))
    F = white_noise_spectrum(rng, shape, scale)
    if not keep:
        return Simulation(
            t=dt * np.arange(r),
            forces=None,
            response=None,
            omega=omega,
            force_spectrum=F,
            response_spectrum=system.response(omega, F, threads=threads),
            dt=dt,
            band_hz=(float(band_hz[0]), float(band_hz[1])),
        )
    full = np.zeros((r // 2 + 1, system.n), dtype=np.complex128)
    full[lines] = F
    forces = np.fft.irfft(full, n=r, axis=0)
    full[lines] = system.response(omega, F, threads=threads)
    response = np.fft.irfft(full, n=r, axis=0)
    return Simulation(
        t=dt * np.arange(r),
        forces=forces,
        response=response,
        omega=omega,
        force_spectrum=np.fft.rfft(forces, axis=0)[lines],
        response_spectrum=np.fft.rfft(response, axis=0)[lines],
        dt=dt,
        band_hz=(float(band_hz[0]), float(band_hz[1])),
    )


def add_noise(x: object, snr_db: float, seed: int | None = None, axis: int = 0) -> np.ndarray:
    """A copy of ``x`` plus independent Gaussian noise at signal-to-noise ratio ``snr_db`` (eq. 53).

    Every channel (every index other than ``axis``) gets noise of variance
    ``σ_s² / 10^(snr_db / 10)``, with ``σ_s²`` that channel's own variance along
    ``axis``. Real input gets real noise, complex input circular complex noise.

    Parameters
    ----------
    x : array_like
        The signal, real or complex, non-empty.
    snr_db : float
        Signal-to-noise ratio in dB.
    seed : int, optional
        Seed of the noise.
    axis : int
        The axis along which each channel's variance is taken (time or frequency).

    Returns
    -------
    numpy.ndarray
        ``x`` with noise, float64 or complex128.

    Raises
    ------
    ValueError
        For non-numeric or non-finite ``x``, an empty ``x``, a non-scalar ``snr_db``
        or an ``axis`` out of range.
    """
    a = as_array(x, "x")
    snr = as_array(snr_db, "snr_db", real=True)
    if snr.ndim != 0:
        raise ValueError(f"snr_db must be a number, got {snr_db!r}")
    if (
        isinstance(axis, bool)
        or not isinstance(axis, int | np.integer)
        or not (-a.ndim <= axis < a.ndim)
    ):
        raise ValueError(f"axis {axis!r} is out of range for x of shape {a.shape}")
    if a.size == 0:
        raise ValueError(f"x is empty (shape {a.shape}): no signal variance to scale noise to")
    sigma = np.sqrt(np.var(a, axis=axis, keepdims=True) / 10 ** (snr / 10))
    rng = np.random.default_rng(seed)
    if np.iscomplexobj(a):
        # = a + sigma / √2 · (x + i y), x, y ~ N(0, 1) drawn in turn, without temporaries
        # of the full size (bit for bit the same numbers)
        noise = white_noise_spectrum(rng, (a.shape[0], a[0].size), 1.0).reshape(a.shape)
        c = sigma / np.sqrt(2)
        noise.real *= c
        noise.imag *= c
        noise += a
        return noise
    return a + sigma * rng.standard_normal(a.shape)


def spectra(
    x: object, dt: float, band_hz: tuple[float, float] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Real FFT of time histories along time, on the lines of a band.

    The same lines :func:`simulate_white_noise` uses, so that
    ``spectra(sim.response, sim.dt, sim.band_hz)[1]`` equals ``sim.response_spectrum``.
    These are the ``U_n(ω)``, ``F_n(ω)`` of eqs. 45–46.

    Parameters
    ----------
    x : array_like, real, (r, n)
        Time histories, time first, r ≥ 2.
    dt : float
        Sampling interval (s), > 0.
    band_hz : tuple of float, optional
        The lines kept, (lo, hi) in Hz; None keeps every line above 0 Hz.

    Returns
    -------
    omega : numpy.ndarray, (s,)
        The lines kept (rad/s).
    X : numpy.ndarray, complex, (s, n)
        ``numpy.fft.rfft(x, axis=0)`` on those lines (unnormalised).

    Raises
    ------
    ValueError
        For malformed ``x`` or ``dt``, or a band outside (0, Nyquist) or without a line.
    """
    a = as_array(x, "x", real=True)
    if a.ndim != 2 or a.shape[0] < 2 or a.shape[1] == 0:
        raise ValueError(f"x must have shape (r, n) with r >= 2 samples, got {a.shape}")
    dt = as_scalar(dt, "dt")
    lines = _band_lines(a.shape[0], dt, band_hz)
    omega = 2 * np.pi * np.fft.rfftfreq(a.shape[0], dt)[lines]
    return omega, np.fft.rfft(a, axis=0)[lines]


def _records(x: object, name: str) -> np.ndarray:
    a = as_array(x, name, real=True)
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or a.shape[1] < 2 or a.shape[2] == 0:
        raise ValueError(
            f"{name} must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, got {a.shape}"
        )
    return a


@dataclass(frozen=True)
class _Welch:
    """Welch segmentation shared by :func:`frf_h1` and :func:`h1_coherence`."""

    x: np.ndarray
    y: np.ndarray
    nperseg: int
    step: int
    n_avg: int
    lines: np.ndarray
    window: np.ndarray
    omega: np.ndarray

    def spectra(self, a: np.ndarray) -> np.ndarray:
        """Windowed spectra of every segment of every record, ``(s, channels, n_avg)``."""
        seg = np.lib.stride_tricks.sliding_window_view(a, self.nperseg, axis=1)[:, :: self.step]
        seg = seg - seg.mean(axis=-1, keepdims=True)
        X = np.fft.rfft(seg * self.window, axis=-1)[..., self.lines]  # (n_rec, n_seg, ch, s)
        return X.reshape(self.n_avg, a.shape[2], self.lines.size).transpose(2, 1, 0)


def _welch(forces, responses, dt, nperseg, band_hz, window) -> _Welch:
    x = _records(forces, "forces")
    y = _records(responses, "responses")
    if x.shape[:2] != y.shape[:2]:
        raise ValueError(
            f"forces and responses must have the same number of records and samples, "
            f"got {x.shape} and {y.shape}"
        )
    dt = as_scalar(dt, "dt")
    r = x.shape[1]
    nperseg = min(r, 256) if nperseg is None else as_count(nperseg, "nperseg", 2, r)
    step = nperseg - nperseg // 2
    n_avg = x.shape[0] * ((r - nperseg) // step + 1)
    n_in = x.shape[2]
    if n_avg < n_in:
        raise ValueError(
            f"{n_avg} averaged segments cannot resolve {n_in} inputs (S_xx would be "
            "singular); use longer or more records or a smaller nperseg"
        )
    lines = _band_lines(nperseg, dt, band_hz)
    omega = 2 * np.pi * np.fft.rfftfreq(nperseg, dt)[lines]
    return _Welch(x, y, nperseg, step, n_avg, lines, get_window(window, nperseg), omega)


def frf_h1(
    forces: object,
    responses: object,
    dt: float,
    nperseg: int | None = None,
    band_hz: tuple[float, float] | None = None,
    window: str = "hann",
) -> tuple[np.ndarray, np.ndarray]:
    """H1 estimate of the FRF, ``H1(ω) = S_yx(ω) S_xx(ω)⁻¹``, by Welch averaging.

    Segments of ``nperseg`` samples overlap by half, are mean-removed and windowed,
    as in ``scipy.signal.csd``; several records are averaged together.

    Parameters
    ----------
    forces : array_like, real, (r, n_in) or (n_rec, r, n_in)
        Force histories.
    responses : array_like, real, (r, n_out) or (n_rec, r, n_out)
        Response histories, with the forces' records and samples.
    dt : float
        Sampling interval (s), > 0.
    nperseg : int, optional
        Samples per segment, 2 … r (default ``min(r, 256)``).
    band_hz : tuple of float, optional
        The lines kept, (lo, hi) in Hz; None keeps every line above 0 Hz.
    window : str
        A ``scipy.signal.get_window`` name (default ``"hann"``).

    Returns
    -------
    omega : numpy.ndarray, (s,)
        The lines (rad/s).
    H : numpy.ndarray, complex, (s, n_out, n_in)
        The FRF estimate.

    Raises
    ------
    ValueError
        For malformed histories, records or samples that differ, fewer averaged
        segments than inputs, or a band outside (0, Nyquist) or without a line.
    """
    welch = _welch(forces, responses, dt, nperseg, band_hz, window)
    X = welch.spectra(welch.x)
    Y = welch.spectra(welch.y)
    Xh = X.conj().transpose(0, 2, 1)
    Sxx = X @ Xh  # (s, n_in, n_in)
    Syx = Y @ Xh  # (s, n_out, n_in)
    # H Sxx = Syx  ⇔  Sxxᵀ Hᵀ = Syxᵀ
    H = np.linalg.solve(Sxx.transpose(0, 2, 1), Syx.transpose(0, 2, 1)).transpose(0, 2, 1)
    return welch.omega, H


@dataclass(frozen=True)
class H1Coherence:
    """What the variance of H1 estimates needs: coherence, averages, line correlation.

    What :func:`h1_coherence` returns, for :func:`podid_rs.model_uncertainty`
    (``coherence=``, ``averages=``, ``line_correlation=``).

    Attributes
    ----------
    omega : numpy.ndarray, (s,)
        The lines (rad/s), those of :func:`frf_h1` with the same arguments.
    coherence : numpy.ndarray, (s, n_out)
        The ordinary coherence γ² = |S_yx|² / (S_xx S_yy) of each response with the
        input.
    averages : float
        The number of independent averages the overlapping segments are worth
        (Welch): K / (1 + 2 Σ_j (1 − j/K) ρ_j²) per record, ρ_j the window's overlap
        correlation at j segment steps.
    line_correlation : tuple of float
        The correlation of the H1 errors of lines 1 and 2 apart, for white input and
        noise: |Σ w² e^{2πiℓn/N}|² / (Σ w²)² (Hann: 4/9 and 1/36).
    """

    omega: np.ndarray
    coherence: np.ndarray
    averages: float
    line_correlation: tuple[float, ...]


def h1_coherence(
    forces: object,
    responses: object,
    dt: float,
    nperseg: int | None = None,
    band_hz: tuple[float, float] | None = None,
    window: str = "hann",
) -> H1Coherence:
    """Coherence, effective averages and line correlation of the H1 estimates of :func:`frf_h1`.

    Bendat & Piersol's random error of an H1 estimate from n_d averages with
    coherence γ² (the normalised error of |Ĥ| and the error of its phase, each
    √(1 − γ²)/(|γ|√(2 n_d))) needs γ² and n_d; overlapping windowed segments are
    fewer independent averages than segments, and their spectra correlate
    neighbouring lines. One input only (ordinary coherence).

    Parameters
    ----------
    forces : array_like, real, (r, 1) or (n_rec, r, 1)
        The force history (one input).
    responses : array_like, real, (r, n_out) or (n_rec, r, n_out)
        Response histories, with the force's records and samples.
    dt : float
        Sampling interval (s), > 0.
    nperseg : int, optional
        Samples per segment, as for :func:`frf_h1`.
    band_hz : tuple of float, optional
        The lines kept, as for :func:`frf_h1`.
    window : str
        A ``scipy.signal.get_window`` name, as for :func:`frf_h1`.

    Returns
    -------
    H1Coherence
        Coherence per line and response, the effective number of averages and the
        correlation between lines.

    Raises
    ------
    ValueError
        As :func:`frf_h1`, and for more than one input.
    """
    welch = _welch(forces, responses, dt, nperseg, band_hz, window)
    if welch.x.shape[2] != 1:
        raise ValueError(f"h1_coherence takes one input (ordinary coherence), got "
                         f"{welch.x.shape[2]}; with several, give the noise variance instead")
    X = welch.spectra(welch.x)[:, 0, :]  # (s, n_avg)
    Y = welch.spectra(welch.y)  # (s, n_out, n_avg)
    Sxx = np.sum(np.abs(X) ** 2, axis=1)
    Syy = np.sum(np.abs(Y) ** 2, axis=2)
    Syx = np.einsum("sok,sk->so", Y, X.conj())
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma2 = np.abs(Syx) ** 2 / (Sxx[:, None] * Syy)
    gamma2 = np.clip(np.nan_to_num(gamma2), 0.0, 1.0)
    w, N, step = welch.window, welch.nperseg, welch.step
    w2 = w * w
    per_record = welch.n_avg // welch.x.shape[0]
    rho = [float(np.sum(w[: N - j * step] * w[j * step:]) / np.sum(w2))
           for j in range(1, per_record) if j * step < N]
    k = per_record
    effective = k / (1 + 2 * sum((1 - j / k) * r * r for j, r in enumerate(rho, start=1)))
    n = np.arange(N)
    corr = tuple(float(abs(np.sum(w2 * np.exp(2j * np.pi * lag * n / N))) ** 2 / np.sum(w2) ** 2)
                 for lag in (1, 2))
    return H1Coherence(welch.omega, gamma2, effective * welch.x.shape[0], corr)
