import re

import numpy as np
import pytest
from scipy import signal

from podid_rs.pod import pod
from podid_rs.simulation import add_noise, frf_h1, h1_coherence, simulate_white_noise, spectra
from podid_rs.systems import SecondOrderSystem, mass_spring_chain

# A soft, well-damped 4-DOF chain: modes at 7.7, 16.4, 32.7 and 55.3 Hz.
SYSTEM = mass_spring_chain(4, ku=4e3, a0=2.0, a1=1e-3)
BAND = (0.5, 20.0)
DT = 0.01


@pytest.fixture(scope="module")
def sim():
    return simulate_white_noise(SYSTEM, BAND, DT, 400.0, intensity=2.0, seed=1)


def test_shapes_and_time_axis(sim):
    r = 40000
    assert sim.t.shape == (r,) and sim.forces.shape == (r, 4) and sim.response.shape == (r, 4)
    assert sim.forces.dtype == np.float64 and sim.response.dtype == np.float64
    np.testing.assert_allclose(sim.t, DT * np.arange(r))
    s = sim.omega.size
    assert sim.force_spectrum.shape == (s, 4) and sim.response_spectrum.shape == (s, 4)
    assert sim.dt == DT and sim.band_hz == BAND


def test_response_spectrum_is_frf_times_force_on_every_line(sim):
    expected = np.einsum("sij,sj->si", SYSTEM.frf(sim.omega), sim.force_spectrum)
    err = np.linalg.norm(sim.response_spectrum - expected, axis=1)
    assert np.all(err <= 1e-10 * np.linalg.norm(expected, axis=1))


def test_band_is_respected(sim):
    f = sim.omega / (2 * np.pi)
    assert f.min() >= BAND[0] and f.max() <= BAND[1]
    lines = np.fft.rfftfreq(sim.t.size, DT)
    assert sim.omega.size == np.count_nonzero((lines >= BAND[0]) & (lines <= BAND[1]))
    outside = (lines < BAND[0]) | (lines > BAND[1])
    for x in (sim.forces, sim.response):
        X = np.abs(np.fft.rfft(x, axis=0))
        assert X[outside].max() <= 1e-10 * X.max()


def test_spectra_reproduce_the_simulation_exactly(sim):
    omega, U = spectra(sim.response, sim.dt, sim.band_hz)
    _, F = spectra(sim.forces, sim.dt, sim.band_hz)
    np.testing.assert_array_equal(omega, sim.omega)
    np.testing.assert_array_equal(U, sim.response_spectrum)
    np.testing.assert_array_equal(F, sim.force_spectrum)


def test_spectra_without_band_keeps_every_positive_line():
    x = np.random.default_rng(0).standard_normal((64, 2))
    omega, X = spectra(x, 0.5)
    np.testing.assert_allclose(omega, 2 * np.pi * np.fft.rfftfreq(64, 0.5)[1:])
    np.testing.assert_allclose(X, np.fft.rfft(x, axis=0)[1:])


def test_intensity_is_the_force_variance_per_dof(sim):
    # Each channel's mean square is a chi-square average over s in-band lines:
    # relative standard deviation 1/sqrt(s) ≈ 1.1 % here, so 5 % is > 4 sigma.
    assert sim.omega.size > 7000
    np.testing.assert_allclose(np.mean(sim.forces**2, axis=0), 2.0, rtol=0.05)
    np.testing.assert_allclose(np.mean(sim.forces**2), 2.0, rtol=0.02)


def test_seed_makes_simulation_reproducible():
    a = simulate_white_noise(SYSTEM, BAND, DT, 20.0, seed=7)
    b = simulate_white_noise(SYSTEM, BAND, DT, 20.0, seed=7)
    c = simulate_white_noise(SYSTEM, BAND, DT, 20.0, seed=8)
    np.testing.assert_array_equal(a.response, b.response)
    assert not np.allclose(a.forces, c.forces)


@pytest.mark.parametrize(
    ("band", "dt", "duration", "intensity", "message"),
    [
        ((1.0, 60.0), 0.01, 10.0, 1.0, "Nyquist"),
        ((0.0, 10.0), 0.01, 10.0, 1.0, "Nyquist"),
        ((10.0, 5.0), 0.01, 10.0, 1.0, "Nyquist"),
        ((1.0,), 0.01, 10.0, 1.0, "pair"),
        # too many ends as well as too few: the pair's message, not a failed unpacking
        ((1.0, 5.0, 10.0), 0.01, 10.0, 1.0,
         r"^band_hz must be a pair \(lo, hi\) in Hz, got \(1.0, 5.0, 10.0\)$"),
        ((5.01, 5.02), 0.01, 10.0, 1.0, "no frequency line"),
        (None, 0.01, 10.0, 1.0, "band_hz is required"),
        ((1.0, 10.0), -0.01, 10.0, 1.0, "dt"),
        ((1.0, 10.0), 0.01, 0.01, 1.0, "samples"),
        ((1.0, 10.0), 0.01, 10.0, 0.0, "intensity"),
        ((1.0, 10.0), 0.01, np.nan, 1.0, "duration"),
    ],
)
def test_invalid_simulation_input_raises(band, dt, duration, intensity, message):
    with pytest.raises(ValueError, match=message):
        simulate_white_noise(SYSTEM, band, dt, duration, intensity=intensity)


def test_simulation_needs_a_system():
    with pytest.raises(ValueError, match="SecondOrderSystem"):
        simulate_white_noise(np.eye(2), BAND, DT, 10.0)


def realised_snr_db(clean: np.ndarray, noisy: np.ndarray, axis: int) -> np.ndarray:
    return 10 * np.log10(np.var(clean, axis=axis) / np.var(noisy - clean, axis=axis))


@pytest.mark.parametrize("snr_db", [20.0, 10.0, 0.0])
def test_add_noise_real_snr(snr_db):
    rng = np.random.default_rng(0)
    x = rng.standard_normal((200_000, 3)) * np.array([1.0, 10.0, 1e-4]) + 5.0
    before = x.copy()
    noisy = add_noise(x, snr_db, seed=1)
    np.testing.assert_array_equal(x, before)
    assert noisy.dtype == np.float64
    # The noise variance estimate over 2e5 samples has 0.3 % relative spread (0.014 dB).
    np.testing.assert_allclose(realised_snr_db(x, noisy, 0), snr_db, atol=0.1)


def test_add_noise_complex_is_circular_and_per_channel_along_axis():
    rng = np.random.default_rng(2)
    x = (rng.standard_normal((2, 100_000)) + 1j * rng.standard_normal((2, 100_000))) * np.array(
        [[1.0], [50.0]]
    )
    before = x.copy()
    noisy = add_noise(x, 10.0, seed=3, axis=1)
    np.testing.assert_array_equal(x, before)
    assert np.iscomplexobj(noisy)
    np.testing.assert_allclose(realised_snr_db(x, noisy, 1), 10.0, atol=0.1)
    noise = noisy - x
    np.testing.assert_allclose(np.var(noise.real, axis=1), np.var(noise.imag, axis=1), rtol=0.03)


def test_add_noise_seed_and_invalid_input():
    x = np.arange(10.0)
    np.testing.assert_array_equal(add_noise(x, 5.0, seed=4), add_noise(x, 5.0, seed=4))
    with pytest.raises(ValueError, match="axis"):
        add_noise(x, 5.0, axis=1)
    with pytest.raises(ValueError, match="non-finite"):
        add_noise([1.0, np.nan], 5.0)
    with pytest.raises(ValueError, match="snr_db"):
        add_noise(x, [5.0, 6.0])


@pytest.mark.parametrize("snr_db", [np.float32(13.0), np.float16(13.0), np.int64(13), 13,
                                    np.array(13.0)])
def test_an_snr_of_any_numeric_type_is_the_number_it_holds(snr_db):
    # 13 dB is exact in every one of these types, so each is the float64 13.0 and the same
    # seed gives the same noise bit for bit; 10^1.3 worked out in float32 or float16
    # (19.952621, 19.94) instead of float64 (19.952623...) would scale it differently
    x = np.random.default_rng(0).standard_normal((100, 2))
    np.testing.assert_array_equal(add_noise(x, snr_db, seed=1), add_noise(x, 13.0, seed=1))


def test_spectra_invalid_input():
    with pytest.raises(ValueError, match=r"\(r, n\)"):
        spectra(np.ones(10), 0.1)
    with pytest.raises(ValueError, match="real"):
        spectra(np.ones((10, 2)) * 1j, 0.1)
    with pytest.raises(ValueError, match="Nyquist"):
        spectra(np.ones((10, 2)), 0.1, (1.0, 6.0))


def test_h1_recovers_the_frf_from_long_multi_record_simulation():
    records = [simulate_white_noise(SYSTEM, BAND, DT, 400.0, seed=k) for k in range(4)]
    forces = np.stack([rec.forces for rec in records])
    responses = np.stack([rec.response for rec in records])
    omega, H = frf_h1(forces, responses, DT, nperseg=2048, band_hz=BAND)
    assert H.shape == (omega.size, 4, 4)
    true = SYSTEM.frf(omega)
    err = np.linalg.norm(H - true, axis=(1, 2)) / np.linalg.norm(true, axis=(1, 2))
    # 4 records x 38 segments of 20.48 s: bias (leakage at the 7.7 Hz resonance,
    # half-power width 0.7 Hz against 0.05 Hz lines) and variance both stay small.
    assert err.max() < 0.04
    assert np.median(err) < 0.005


@pytest.mark.parametrize("nperseg", [512, 511])  # odd: the hop is 256 too (scipy's overlap 255)
def test_h1_siso_equals_scipy_csd_over_welch(sim, nperseg):
    x, y = sim.forces[:, 0], sim.response[:, 1]
    f, Pxy = signal.csd(x, y, fs=1 / DT, nperseg=nperseg, window="hann")
    _, Pxx = signal.welch(x, fs=1 / DT, nperseg=nperseg, window="hann")
    in_band = (f >= BAND[0]) & (f <= BAND[1])
    omega, H = frf_h1(x[:, None], y[:, None], DT, nperseg=nperseg, band_hz=BAND)
    np.testing.assert_allclose(omega, 2 * np.pi * f[in_band])
    np.testing.assert_allclose(H[:, 0, 0], (Pxy / Pxx)[in_band], rtol=1e-10)


def test_h1_mimo_equals_csd_matrix_formula(sim):
    x, y = sim.forces[:, :2], sim.response[:, 1:4]
    f, _ = signal.welch(x[:, 0], fs=1 / DT, nperseg=256)
    in_band = (f >= BAND[0]) & (f <= BAND[1])

    def csd(a, b):  # E[conj(A) B]
        return signal.csd(a, b, fs=1 / DT, nperseg=256)[1][in_band]

    s = np.count_nonzero(in_band)
    Sxx = np.empty((s, 2, 2), dtype=complex)  # E[X Xᴴ]
    Syx = np.empty((s, 3, 2), dtype=complex)  # E[Y Xᴴ]
    for i in range(2):
        for j in range(2):
            Sxx[:, i, j] = csd(x[:, j], x[:, i])
        for o in range(3):
            Syx[:, o, i] = csd(x[:, i], y[:, o])
    expected = Syx @ np.linalg.inv(Sxx)
    _, H = frf_h1(x, y, DT, band_hz=BAND)
    np.testing.assert_allclose(H, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())


def test_h1_single_record_equals_one_stacked_record(sim):
    a = frf_h1(sim.forces, sim.response, DT, band_hz=BAND)
    b = frf_h1(sim.forces[None], sim.response[None], DT, band_hz=BAND)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_h1_does_not_modify_input(sim):
    f, r = sim.forces.copy(), sim.response.copy()
    frf_h1(sim.forces, sim.response, DT)
    np.testing.assert_array_equal(f, sim.forces)
    np.testing.assert_array_equal(r, sim.response)


def test_h1_invalid_input():
    x = np.random.default_rng(0).standard_normal((1000, 3))
    with pytest.raises(ValueError, match="same number"):
        frf_h1(x, x[:999], DT)
    with pytest.raises(ValueError, match="nperseg"):
        frf_h1(x, x, DT, nperseg=2000)
    with pytest.raises(ValueError, match="segments cannot resolve 3 inputs"):
        frf_h1(x[:20], x[:20], DT, nperseg=16)
    with pytest.raises(ValueError, match="Nyquist"):
        frf_h1(x, x, DT, band_hz=(1.0, 80.0))
    with pytest.raises(ValueError, match=r"\(r, n\)"):
        frf_h1(x[:, 0], x[:, 0], DT)
    with pytest.raises(ValueError):
        frf_h1(x, x, DT, window="no-such-window")


def test_h1_names_the_history_of_the_wrong_shape():
    x = np.random.default_rng(0).standard_normal((1000, 3))
    with pytest.raises(ValueError, match=r"^forces must have shape \(r, n\)"):
        frf_h1(x[:, 0], x, DT)
    with pytest.raises(ValueError, match=r"^responses must have shape \(r, n\)"):
        frf_h1(x, x[:, 0], DT)
    # an axis too many is refused too, not averaged over as if it were more channels
    four_axes = x[None, :, :, None]
    for name, args in (("forces", (four_axes, x)), ("responses", (x, four_axes))):
        with pytest.raises(ValueError, match=exactly(
                f"{name} must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, "
                "got (1, 1000, 3, 1)")):
            frf_h1(*args, DT)


def test_h1_needs_only_as_many_segments_as_inputs():
    # responses y = G x sample by sample: every segment's spectra satisfy Y = G X, so
    # H1 = S_yx S_xx⁻¹ = G on every line once S_xx has full rank — two segments (12
    # samples, nperseg 8, step 4) for two inputs
    rng = np.random.default_rng(1)
    x = rng.standard_normal((12, 2))
    G = np.array([[1.0, -2.0], [0.5, 3.0], [4.0, 0.0]])
    omega, H = frf_h1(x, x @ G.T, DT, nperseg=8)
    assert omega.size == 4 and H.shape == (4, 3, 2)
    assert np.max(np.abs(H - G)) < 1e-10 * np.max(np.abs(G))


def test_non_reciprocal_system_simulates():
    S = np.triu(np.ones((4, 4)), 1)
    system = SecondOrderSystem(SYSTEM.M, SYSTEM.C, SYSTEM.K + 1000 * (S - S.T))
    sim = simulate_white_noise(system, BAND, DT, 50.0, seed=0)
    expected = np.einsum("sij,sj->si", system.frf(sim.omega), sim.force_spectrum)
    assert np.linalg.norm(sim.response_spectrum - expected) < 1e-10 * np.linalg.norm(expected)


def test_spectra_edge_shapes_and_refusals():
    # the smallest records: two samples, one channel
    omega, X = spectra(np.array([[1.0], [-1.0]]), 0.5)
    assert omega.tolist() == [2 * np.pi * 1.0] and X.tolist() == [[2.0 + 0j]]
    for bad in (np.ones((1, 3)), np.ones((4, 0)), np.ones(4), np.ones((4, 2, 3))):
        message = f"x must have shape (r, n) with r >= 2 samples, got {bad.shape}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            spectra(bad, 0.1)
    with pytest.raises(ValueError, match="^x must be real"):
        spectra(np.ones((4, 2)) + 1j, 0.1)
    with pytest.raises(ValueError, match="^dt must be a positive number"):
        spectra(np.ones((4, 2)), 0.0)


def test_simulation_pod_passes_the_method_on():
    sim = simulate_white_noise(mass_spring_chain(4), band_hz=(5.0, 60.0), dt=1 / 256,
                               duration=4.0, seed=0)
    assert sim.pod().method == "correlation"  # auto: n = 4 ≪ r
    snap = sim.pod(method="snapshots")
    assert snap.method == "snapshots"
    np.testing.assert_allclose(snap.eigenvalues[:4], sim.pod().eigenvalues, rtol=1e-10)


def test_simulation_pod_is_the_pod_of_the_response_history(sim):
    # Parseval (pod_from_spectra): the in-band response spectrum gives ⟨u uᵀ⟩ of the response
    # history itself, so sim.pod() is pod(sim.response) — not a POD of the forces. Both are
    # sums of r = 40 000 samples or 2·s lines: round-off ~ r·eps ≈ 1e-11 relative at most
    P, direct = sim.pod(), pod(sim.response)
    np.testing.assert_allclose(P.eigenvalues, direct.eigenvalues, rtol=1e-10)
    # the total energy by hand: the sum of every channel's mean square
    total = np.mean(sim.response**2, axis=0).sum()
    assert P.eigenvalues.sum() == pytest.approx(total, rel=1e-10)
    # the eigenvalues are at least 3.9× apart, so each mode is fixed to round-off too
    np.testing.assert_allclose(np.abs(P.modes.T @ direct.modes), np.eye(4), atol=1e-10)


def test_add_noise_axis_limits_and_refusals():
    x = np.random.default_rng(0).standard_normal((50, 3, 2))
    add_noise(x, 10.0, seed=1, axis=-3)  # the first axis counted from the end
    for axis in (3, -4, True, 1.0):
        message = f"axis {axis!r} is out of range for x of shape (50, 3, 2)"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            add_noise(x, 10.0, axis=axis)
    with pytest.raises(ValueError, match="^snr_db must be real"):
        add_noise(x, 10.0 + 1j)
    with pytest.raises(ValueError, match="^x contains non-finite"):
        add_noise(np.array([1.0, np.nan]), 10.0)


def test_add_noise_on_complex_spectra_of_any_rank():
    rng = np.random.default_rng(2)
    X = rng.standard_normal((4000, 2, 3)) * np.array([1.0, 10.0, 100.0]) * (1 + 1j)
    noisy = add_noise(X, 20.0, seed=3)
    assert noisy.shape == X.shape and np.iscomplexobj(noisy)
    ratio = np.var(noisy - X, axis=0) / np.var(X, axis=0)  # 10^(−20/10) per channel
    np.testing.assert_allclose(ratio, 0.01, rtol=0.1)
    # one line: no variance along the axis, so no noise
    one = X[:1]
    np.testing.assert_array_equal(add_noise(one, 20.0, seed=3), one)


def exactly(text: str) -> str:
    return "^" + re.escape(text) + "$"


def test_simulation_refusals_word_for_word():
    def refused(message, *args, **kwargs):
        with pytest.raises(ValueError, match=exactly(message)):
            simulate_white_noise(*args, **kwargs)

    refused("system must be a SecondOrderSystem, got ndarray", np.eye(2), BAND, DT, 10.0)
    refused("band_hz is required: the (lo, hi) band of the forcing in Hz", SYSTEM, None, DT, 10.0)
    refused("dt must be a positive number, got 0", SYSTEM, BAND, 0, 10.0)
    refused("duration must be a positive number, got 0", SYSTEM, BAND, DT, 0)
    refused("intensity must be a positive number, got -1", SYSTEM, BAND, DT, 10.0, -1)
    refused("duration / dt gives 1 samples; at least 2 are needed", SYSTEM, BAND, DT, 0.012)
    # two samples pass the count; their only positive line is Nyquist, outside any band
    refused("band_hz (0.5, 20.0) contains no frequency line; the resolution is 50 Hz "
            "(lengthen the record or widen the band)", SYSTEM, BAND, DT, 0.02)


@pytest.mark.parametrize("histories", [True, False])
def test_a_duration_not_a_whole_multiple_of_dt_in_floating_point_rounds(histories):
    """2.3 s at 10 ms is 230 samples, though 2.3 / 0.01 = 229.99999999999997 in floating
    point: the record is round(duration / dt) samples, its lines 1 / 2.3 Hz apart."""
    sim = simulate_white_noise(SYSTEM, BAND, DT, 2.3, seed=0, histories=histories)
    assert sim.n_samples == 230 and sim.t.size == 230
    if histories:
        assert sim.forces.shape == (230, 4)
    f = sim.omega / (2 * np.pi)
    np.testing.assert_allclose(np.diff(f), 1 / 2.3, rtol=1e-12)


def test_default_intensity_is_one():
    a = simulate_white_noise(SYSTEM, BAND, DT, 20.0, seed=5)
    b = simulate_white_noise(SYSTEM, BAND, DT, 20.0, intensity=1.0, seed=5)
    np.testing.assert_array_equal(a.forces, b.forces)


@pytest.mark.parametrize("histories", [True, False])
def test_odd_records_up_to_nyquist_with_or_without_histories(histories):
    # 1023 samples (odd) at 1/256 s: lines every 256/1023 Hz; the band reaches the last
    # line below Nyquist (127.87 Hz), index r // 2
    r, dt, band = 1023, 1 / 256, (5.0, 127.9)
    sim = simulate_white_noise(SYSTEM, band, dt, r * dt, seed=2, histories=histories)
    assert sim.n_samples == r and sim.dt == dt and sim.band_hz == band
    np.testing.assert_array_equal(sim.t, dt * np.arange(r))
    assert sim.omega[-1] == pytest.approx(2 * np.pi * (r // 2) / (r * dt), rel=1e-15)
    np.testing.assert_allclose(sim.response_spectrum,
                               SYSTEM.response(sim.omega, sim.force_spectrum), rtol=1e-10)
    if histories:
        assert sim.forces.shape == sim.response.shape == (r, 4)
        # the histories are the spectra's: their FFT gives them back on the band's lines
        np.testing.assert_allclose(spectra(sim.response, dt, band)[1], sim.response_spectrum,
                                   rtol=1e-9, atol=1e-12 * np.abs(sim.response_spectrum).max())


@pytest.mark.parametrize("histories", [True, False])
def test_threads_reach_the_per_line_solves_with_or_without_histories(histories, monkeypatch):
    """threads is the per-line solver's (system.response's): a spy on the response records
    what it is given, on both paths (histories kept and spectra only)."""
    received = []
    real = SecondOrderSystem.response

    def response(self, omega, F, *, threads=None):
        received.append(threads)
        return real(self, omega, F, threads=threads)

    monkeypatch.setattr(SecondOrderSystem, "response", response)
    simulate_white_noise(SYSTEM, BAND, DT, 2.0, seed=0, histories=histories, threads=1)
    assert received == [1]


def test_histories_are_kept_up_to_one_gib(monkeypatch):
    # histories=None keeps them when the r × n forces and responses take at most
    # HISTORY_BYTES = 2³⁰ bytes (2 · 8 · r · n); the memory guard's message tells
    import podid_rs._memory as memory
    from podid_rs.simulation import HISTORY_BYTES

    n = 64
    chain = mass_spring_chain(n)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1)
    r = HISTORY_BYTES // (16 * n)  # exactly 1 GiB of histories
    for samples, kept in ((r, True), (r + 2, False)):
        with pytest.raises(MemoryError) as err:
            simulate_white_noise(chain, (1.0, 2.0), 1 / 256, samples / 256)
        assert (f"with {samples}-sample histories" in str(err.value)) == kept


def test_h1_removes_each_segments_mean_and_takes_its_limits():
    # offsets (different per channel) change nothing: each segment's mean is removed
    rng = np.random.default_rng(6)
    x = rng.standard_normal((2048, 2))
    y = np.stack([np.convolve(x[:, 0], [1.0, 0.5], "same"), x[:, 1] - x[:, 0]], axis=1)
    w, H = frf_h1(x, y, DT, nperseg=128)
    w2, H2 = frf_h1(x + [3.0, -7.0], y + [100.0, 0.25], DT, nperseg=128)
    np.testing.assert_array_equal(w2, w)
    np.testing.assert_allclose(H2, H, rtol=1e-9, atol=1e-12)
    # one segment resolves one input; two samples are the smallest record and segment
    assert frf_h1(x[:128, :1], y[:128], DT, nperseg=128)[1].shape == (64, 2, 1)
    assert frf_h1(x[:2, :1], y[:2, :1], DT)[1].shape == (1, 1, 1)
    with pytest.raises(ValueError, match=exactly("nperseg must be in [2, 2048], got 2049")):
        frf_h1(x, y, DT, nperseg=2049)
    with pytest.raises(ValueError, match=exactly(
            "1 averaged segments cannot resolve 2 inputs (S_xx would be singular); use longer "
            "or more records or a smaller nperseg")):
        frf_h1(x[:128], y[:128], DT, nperseg=128)
    # (r, n) is read as one record (1, r, n): the message gives the shape it checked
    for name, args in (("forces", (x[:1], y)), ("responses", (x, y[:1]))):
        message = (f"{name} must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, "
                   "got (1, 1, 2)")
        with pytest.raises(ValueError, match=exactly(message)):
            frf_h1(*args, DT)
    with pytest.raises(ValueError, match="^forces must be real"):
        frf_h1(x + 0j, y, DT)
    with pytest.raises(ValueError, match="^dt must be a positive number, got -1"):
        frf_h1(x, y, -1)


def test_band_ends_are_inclusive_and_its_limits_exclusive():
    # 1000 samples at 0.01 s: lines every 0.1 Hz, exactly k / 10; Nyquist 50 Hz
    sim = simulate_white_noise(SYSTEM, (5.0, 7.0), DT, 10.0, seed=0, histories=False)
    np.testing.assert_allclose(sim.omega / (2 * np.pi), np.arange(50, 71) / 10, rtol=1e-14)
    for band in ((5.0, 5.0), (1.0, 50.0), (0.0, 1.0)):
        with pytest.raises(ValueError, match=exactly(
                f"band_hz must satisfy 0 < lo < hi < Nyquist = 50 Hz, got {band!r}")):
            simulate_white_noise(SYSTEM, band, DT, 10.0)
    with pytest.raises(ValueError, match=exactly(
            "band_hz (5.01, 5.09) contains no frequency line; the resolution is 0.1 Hz "
            "(lengthen the record or widen the band)")):
        simulate_white_noise(SYSTEM, (5.01, 5.09), DT, 10.0)
    with pytest.raises(ValueError, match="^band_hz must be real"):
        simulate_white_noise(SYSTEM, (5.0 + 0j, 7.0), DT, 10.0)


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= np.finfo(np.float64).eps,
                    reason="long double is float64 here: no band above a line rounds onto it")
def test_a_band_of_another_dtype_is_read_as_its_float64_ends():
    # the band is compared with the lines in float64, as every other frequency: a long-double
    # lower end 2^-58 Hz above the 5 Hz line is 5.0 in float64 (half its ulp there is 2^-51),
    # so the 5 Hz line is the band's first, as for (5.0, 7.0); 1000 samples at 0.01 s put a
    # line at every k / 10 Hz
    if np.finfo(np.longdouble).eps >= np.finfo(np.float64).eps:
        pytest.skip("long double is float64 here (as on Windows and Apple silicon)")
    band = np.array([5.0, 7.0], dtype=np.longdouble) + np.array([2.0**-58, 0.0],
                                                                dtype=np.longdouble)
    assert band[0] > 5.0 and float(band[0]) == 5.0
    sim = simulate_white_noise(SYSTEM, band, DT, 10.0, seed=0, histories=False)
    np.testing.assert_allclose(sim.omega / (2 * np.pi), np.arange(50, 71) / 10, rtol=1e-14)


def test_refusals_quote_the_argument_as_given_and_both_shapes():
    # the band and the SNR as the caller wrote them, not as the arrays they were read into
    with pytest.raises(ValueError, match=exactly("band_hz must be a pair (lo, hi) in Hz, "
                                                 "got (1.0,)")):
        simulate_white_noise(SYSTEM, (1.0,), DT, 10.0)
    with pytest.raises(ValueError, match=exactly("snr_db must be a number, got [5.0, 6.0]")):
        add_noise(np.arange(10.0), [5.0, 6.0])
    # forces and responses that differ in samples, or in records: both shapes named
    x = np.random.default_rng(0).standard_normal((1000, 3))
    # more samples or records on either side
    for forces, responses, shapes in ((x, x[:999], "(1, 1000, 3) and (1, 999, 3)"),
                                      (np.stack([x, x]), x, "(2, 1000, 3) and (1, 1000, 3)"),
                                      (x[:999], x, "(1, 999, 3) and (1, 1000, 3)"),
                                      (x, np.stack([x, x]), "(1, 1000, 3) and (2, 1000, 3)")):
        with pytest.raises(ValueError, match=exactly(
                "forces and responses must have the same number of records and samples, "
                f"got {shapes}")):
            frf_h1(forces, responses, DT)


def test_an_empty_signal_or_history_without_channels_is_refused():
    with pytest.raises(ValueError, match=exactly(
            "x is empty (shape (0, 3)): no signal variance to scale noise to")):
        add_noise(np.zeros((0, 3)), 10.0)
    for name, args in (("forces", (np.ones((10, 0)), np.ones((10, 2)))),
                       ("responses", (np.ones((10, 2)), np.ones((10, 0))))):
        with pytest.raises(ValueError, match=exactly(
                f"{name} must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, "
                "got (1, 10, 0)")):
            frf_h1(*args, DT)


def test_h1_coherence_names_the_number_of_inputs():
    rng = np.random.default_rng(1)
    x, y = rng.standard_normal((1024, 2)), rng.standard_normal((1024, 3))
    with pytest.raises(ValueError, match=exactly(
            "h1_coherence takes one input (ordinary coherence), got 2; with several, give "
            "the noise variance instead")):
        h1_coherence(x, y, DT, nperseg=256)


def test_h1_coherence_takes_the_band_it_is_given():
    """fs = 100 Hz, 256-sample segments: lines every 100/256 Hz, those in 5–20 Hz are
    k = 13 … 51 (5 · 2.56 = 12.8, 20 · 2.56 = 51.2) — the lines frf_h1 gives for the
    same band, with a coherence for each."""
    rng = np.random.default_rng(2)
    x = rng.standard_normal((4096, 1))
    y = np.concatenate([2 * x, x + rng.standard_normal((4096, 1))], axis=1)
    stats = h1_coherence(x, y, DT, nperseg=256, band_hz=(5.0, 20.0))
    np.testing.assert_allclose(stats.omega / (2 * np.pi), np.arange(13, 52) / 2.56, rtol=1e-12)
    np.testing.assert_array_equal(stats.omega, frf_h1(x, y, DT, nperseg=256,
                                                      band_hz=(5.0, 20.0))[0])
    assert stats.coherence.shape == (39, 2)


def test_h1_coherence_takes_the_window_it_is_given():
    """A rectangular window ("boxcar") at half overlap: its neighbouring lines do not
    correlate (Σ_n e^{2πiℓn/N} = 0 for ℓ = 1, 2), and consecutive segments share half
    their samples, ρ₁ = 1/2, none beyond: K / (1 + 2 (1 − 1/K) ρ₁²) averages from K
    segments (Hann's would be 4/9 and 1/36, and ρ₁ = 1/6)."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((4096, 1))
    y = 2 * x + rng.standard_normal((4096, 1))
    stats = h1_coherence(x, y, DT, nperseg=512, window="boxcar")
    K = (4096 - 512) // 256 + 1  # 15 segments, a hop of 256
    # the sums of unit phasors are zero to round-off (7e-33 and 8e-34 here)
    assert stats.line_correlation == pytest.approx((0.0, 0.0), abs=1e-12)
    assert stats.averages == pytest.approx(K / (1 + 2 * (1 - 1 / K) * 0.25), rel=1e-12)


def test_h1_coherence_of_two_overlapping_segments_per_record():
    """A 400-sample record at the default nperseg = 256 is cut into K = 2 Hann segments
    (hop 128, (400 − 256) // 128 + 1), which share half their samples. For the periodic
    Hann window w_n = sin²(πn/N), Σ w² = 3N/8 and the overlap Σ w_n w_{n+N/2} =
    Σ_{n<N/2} sin²(2πn/N) / 4 = N/16, so ρ₁ = 1/6 and the pair is worth
    K / (1 + 2 (1 − 1/K) ρ₁²) = 2 / (1 + 1/36) = 72/37 averages, not 2; two such records
    twice that. (Sums of 256 terms: round-off of 1e-15, hence rel=1e-12.)"""
    rng = np.random.default_rng(4)
    x = rng.standard_normal((2, 400, 1))
    y = 2 * x + rng.standard_normal((2, 400, 1))
    assert h1_coherence(x[0], y[0], DT).averages == pytest.approx(72 / 37, rel=1e-12)
    assert h1_coherence(x, y, DT).averages == pytest.approx(144 / 37, rel=1e-12)
