import re

import numpy as np
import pytest
from scipy import signal

from podid_rs.simulation import add_noise, frf_h1, simulate_white_noise, spectra
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


def test_h1_siso_equals_scipy_csd_over_welch(sim):
    x, y = sim.forces[:, 0], sim.response[:, 1]
    f, Pxy = signal.csd(x, y, fs=1 / DT, nperseg=512, window="hann")
    _, Pxx = signal.welch(x, fs=1 / DT, nperseg=512, window="hann")
    in_band = (f >= BAND[0]) & (f <= BAND[1])
    omega, H = frf_h1(x[:, None], y[:, None], DT, nperseg=512, band_hz=BAND)
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
    for bad in (np.ones((1, 3)), np.ones((4, 0)), np.ones(4)):
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
