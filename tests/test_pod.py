import re
import warnings

import numpy as np
import pytest

from podid_rs.pod import (
    PODResult,
    correlation_from_frf,
    correlation_from_snapshots,
    pod,
    pod_from_correlation,
    pod_from_frf,
    pod_from_spectra,
)
from podid_rs.simulation import simulate_white_noise
from podid_rs.systems import SecondOrderSystem, mass_spring_chain


def snapshots(r: int = 500, n: int = 6, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal((r, n)) @ rng.standard_normal((n, n))


def test_correlation_from_snapshots_is_the_time_average_of_outer_products():
    u = snapshots(50, 4)
    before = u.copy()
    R = correlation_from_snapshots(u)
    np.testing.assert_array_equal(u, before)
    np.testing.assert_allclose(R, np.mean([np.outer(x, x) for x in u], axis=0), rtol=1e-13)
    np.testing.assert_array_equal(R, R.T)


def test_pod_modes_are_orthonormal_and_eigenvalues_sorted():
    u = snapshots()
    result = pod(u)
    lam, phi = result.eigenvalues, result.modes
    assert phi.shape == (6, 6)
    np.testing.assert_allclose(phi.T @ phi, np.eye(6), atol=1e-13)
    assert np.all(np.diff(lam) <= 0) and np.all(lam >= 0)
    R = correlation_from_snapshots(u)
    np.testing.assert_allclose(phi @ np.diag(lam) @ phi.T, R, atol=1e-12 * np.abs(R).max())


def test_by_default_pod_takes_the_smaller_side_of_the_snapshots():
    """method="auto": the r × r Gram matrix with fewer snapshots r than DOFs n, the
    n × n correlation otherwise (r = n included). (A long record decomposed on the
    snapshot side would form an r × r matrix of its samples.)"""
    assert pod(snapshots(r=5, n=8)).method == "snapshots"
    assert pod(snapshots(r=8, n=8)).method == "correlation"
    assert pod(snapshots(r=50, n=4)).method == "correlation"


def test_mode_signs_are_deterministic():
    result = pod(snapshots())
    lead = result.modes[np.argmax(np.abs(result.modes), axis=0), np.arange(6)]
    assert np.all(lead > 0)
    flipped = pod(-snapshots())
    np.testing.assert_allclose(flipped.modes, result.modes, atol=1e-12)


def test_rank_deficient_correlation_gives_non_negative_eigenvalues():
    u = snapshots(3, 8)  # rank 3 of 8: five eigenvalues are zero up to round-off
    result = pod(u)
    assert np.all(result.eigenvalues >= 0)
    assert np.all(result.eigenvalues[3:] < 1e-12 * result.eigenvalues[0])


def test_energy_fraction_and_order_for_energy():
    result = PODResult(eigenvalues=np.array([4.0, 3.0, 2.0, 1.0]), modes=np.eye(4))
    np.testing.assert_allclose(result.energy_fraction, [0.4, 0.7, 0.9, 1.0])
    assert result.energy_fraction[-1] == 1.0
    expected = {0.1: 1, 0.4: 1, 0.41: 2, 0.7: 2, 0.9: 3, 0.95: 4, 1.0: 4}
    for k, m in expected.items():
        assert result.order_for_energy(k) == m


def test_order_for_energy_is_at_most_the_modes_available():
    # eigenvalues of 3 modes but only the first 2 kept as modes (a truncated POD): the
    # energy fractions are 3/6, 5/6 and 1, so a fraction above 5/6 needs the third mode,
    # which is not there. The order returned must be one basis() accepts: 2, not 3.
    result = PODResult(eigenvalues=np.array([3.0, 2.0, 1.0]), modes=np.eye(3)[:, :2])
    assert result.n_modes == 2
    assert result.order_for_energy(0.8) == 2  # 5/6 >= 0.8: reached with the modes there
    for k in (0.9, 1.0):
        m = result.order_for_energy(k)
        assert m == 2
        assert result.basis(m).shape == (3, 2)


@pytest.mark.parametrize("k", [0.0, -0.5, 1.01, np.nan, [0.5, 0.9]])
def test_order_for_energy_rejects_bad_fraction(k):
    result = PODResult(eigenvalues=np.array([2.0, 1.0]), modes=np.eye(2))
    with pytest.raises(ValueError, match="k"):
        result.order_for_energy(k)


def test_basis_and_projection():
    result = pod(snapshots())
    R = result.basis(3)
    np.testing.assert_array_equal(R, result.modes[:, :3])
    R[0, 0] = 123.0
    assert result.modes[0, 0] != 123.0
    rng = np.random.default_rng(1)
    X = rng.standard_normal((5, 6)) + 1j * rng.standard_normal((5, 6))
    Xp = rng.standard_normal((5, 6, 2))
    before = X.copy()
    P = result.project(X, 3)
    np.testing.assert_array_equal(X, before)
    assert P.shape == (5, 3)
    np.testing.assert_allclose(P, np.stack([result.basis(3).T @ x for x in X]), rtol=1e-13)
    Pp = result.project(Xp, 2)
    assert Pp.shape == (5, 2, 2)
    np.testing.assert_allclose(Pp[:, :, 1], Xp[:, :, 1] @ result.basis(2), rtol=1e-13)
    # complex load cases (FRF columns): each column projected as it is, not conjugated
    Xc = Xp + 1j * rng.standard_normal((5, 6, 2))
    Pc = result.project(Xc, 2)
    for j in range(2):
        np.testing.assert_allclose(Pc[:, :, j], Xc[:, :, j] @ result.basis(2), rtol=1e-13)


def test_the_basis_of_every_mode_is_the_modes():
    """m = n, the top of the documented range 1 ≤ m ≤ the modes available: the full
    basis, every mode in order."""
    result = pod(snapshots(), method="correlation")  # 6 DOFs of full rank: 6 modes
    np.testing.assert_array_equal(result.basis(6), result.modes)


def test_a_basis_from_the_snapshot_side_is_a_copy_too():
    """On the snapshot side the modes are formed on first use and kept: the basis handed
    out is a copy of them, so writing into it leaves the next basis alone."""
    P = pod(snapshots(r=4, n=10), method="snapshots")
    R = P.basis(2)
    before = R.copy()
    R[:] = 0.0
    np.testing.assert_array_equal(P.basis(2), before)


def test_basis_and_projection_reject_bad_input():
    result = pod(snapshots())
    for m in (0, 7, 2.0):
        with pytest.raises(ValueError, match="m must be"):
            result.basis(m)
    with pytest.raises(ValueError, match="X must have shape"):
        result.project(np.ones((5, 4)), 2)


def test_correlation_from_frf_is_trapezoid_of_re_h_hh():
    rng = np.random.default_rng(2)
    H = rng.standard_normal((7, 3, 2)) + 1j * rng.standard_normal((7, 3, 2))
    omega = np.sort(rng.uniform(1.0, 10.0, 7))
    before = H.copy()
    R = correlation_from_frf(H, omega)
    np.testing.assert_array_equal(H, before)
    f = np.real([h @ h.conj().T for h in H])
    expected = sum(0.5 * (omega[i + 1] - omega[i]) * (f[i] + f[i + 1]) for i in range(6))
    np.testing.assert_allclose(R, expected, rtol=1e-13)


def test_correlation_from_frf_equals_papers_form_for_reciprocal_systems():
    system = mass_spring_chain(5)
    omega = 2 * np.pi * np.linspace(5.0, 100.0, 50)
    H = system.frf(omega)
    papers = np.trapezoid(np.real(H.conj().transpose(0, 2, 1) @ H), omega, axis=0)
    np.testing.assert_allclose(correlation_from_frf(H, omega), papers, rtol=1e-12)


# A soft 4-DOF chain (modes 7.7–55 Hz) and a non-reciprocal version of it
# (skew-symmetric circulatory stiffness; still stable).
CHAIN = mass_spring_chain(4, ku=4e3, a0=2.0, a1=1e-3)
SKEW = np.triu(np.ones((4, 4)), 1) - np.triu(np.ones((4, 4)), 1).T
NON_RECIPROCAL = SecondOrderSystem(CHAIN.M, CHAIN.C, CHAIN.K + 1000.0 * SKEW)


@pytest.mark.parametrize("system", [CHAIN, NON_RECIPROCAL], ids=["chain", "non-reciprocal"])
def test_correlation_from_frf_matches_simulated_time_average(system):
    band, intensity = (1.0, 40.0), 3.0
    sims = [simulate_white_noise(system, band, 0.005, 800.0, intensity, seed=k) for k in range(16)]
    R_time = np.mean([correlation_from_snapshots(sim.response) for sim in sims], axis=0)
    omega = sims[0].omega
    factor = intensity / (2 * np.pi * (band[1] - band[0]))
    R_frf = factor * correlation_from_frf(system.frf(omega), omega)
    # R_time is a random estimate: over 20 independent sets of 16 records its relative
    # Frobenius error was 0.5–0.7 % on average and at most 2 %, so 4 % is safe.
    assert np.linalg.norm(R_time - R_frf) < 0.04 * np.linalg.norm(R_frf)
    if system is NON_RECIPROCAL:  # the paper's Re(HᴴH) is not the correlation here
        H = system.frf(omega)
        papers = factor * np.trapezoid(np.real(H.conj().transpose(0, 2, 1) @ H), omega, axis=0)
        assert np.linalg.norm(R_time - papers) > 0.5 * np.linalg.norm(R_frf)


def test_pod_from_frf_equals_pod_of_its_correlation():
    system = mass_spring_chain(6)
    omega = 2 * np.pi * np.linspace(5.0, 60.0, 40)
    H = system.frf(omega)
    a = pod_from_frf(H, omega)
    b = pod_from_correlation(correlation_from_frf(H, omega))
    np.testing.assert_array_equal(a.eigenvalues, b.eigenvalues)
    np.testing.assert_array_equal(a.modes, b.modes)


def test_pod_from_frf_by_snapshots_has_the_energy_of_its_correlation():
    """A 30-mass chain at 5 lines, one input: 10 real snapshot rows for 30 DOFs, so
    ``method="auto"`` takes the snapshot side. Its eigenvalues are those of Ruu (eq. 4):
    they sum to its trace, ∫ Σ|H|² dω by the trapezoid rule over the lines (worked out
    here from H), and equal the correlation side's. Both to 1e-12 of the largest: the
    two sides differ by round-off of products of 10 and 30 terms."""
    chain = mass_spring_chain(30)
    w = 2 * np.pi * np.array([10.0, 25.0, 40.0, 55.0, 70.0])
    H = chain.frf(w)[:, :, :1]
    P = pod_from_frf(H, w)
    assert P.method == "snapshots"
    energy = np.sum(np.abs(H) ** 2, axis=(1, 2))
    trace = np.sum(0.5 * np.diff(w) * (energy[:-1] + energy[1:]))
    lam = P.eigenvalues
    assert lam.sum() == pytest.approx(trace, rel=1e-12)
    lam_c = pod_from_frf(H, w, method="correlation").eigenvalues
    np.testing.assert_allclose(lam, lam_c, rtol=0, atol=1e-12 * lam_c[0])


@pytest.mark.parametrize(
    ("Ruu", "message"),
    [
        (np.ones((2, 3)), "square"),
        # more rows than columns, a stack of squares, a vector: each refused by its shape
        (np.ones((3, 2)), r"^Ruu must be a non-empty square matrix, got shape \(3, 2\)$"),
        (np.ones((2, 2, 2)), r"^Ruu must be a non-empty square matrix, got shape \(2, 2, 2\)$"),
        (np.ones(2), r"^Ruu must be a non-empty square matrix, got shape \(2,\)$"),
        (np.array([[1.0, 0.5], [0.0, 1.0]]), "symmetric"),
        (np.diag([1.0, -1.0]), "positive semi-definite"),
        # the whole message: the most negative eigenvalue against the largest
        (np.diag([-1e-3, 4.0, 2.0]), "^Ruu is not positive semi-definite: eigenvalue -0.001 "
                                     "against largest 4$"),
        (np.zeros((3, 3)), "identically zero"),
        (np.diag([1.0, np.nan]), "non-finite"),
        (np.eye(2) * (1 + 1j), "real"),
    ],
)
def test_pod_from_correlation_rejects_bad_input(Ruu, message):
    with pytest.raises(ValueError, match=message):
        pod_from_correlation(Ruu)


def test_an_unknown_method_is_named_with_the_known_ones():
    for f in (lambda m: pod(snapshots(), method=m),
              lambda m: pod_from_frf(np.ones((3, 2, 1)), [1.0, 2.0, 3.0], method=m)):
        with pytest.raises(ValueError, match=r"^method must be one of \('auto', 'correlation', "
                                             r"'snapshots'\), got 'svd'$"):
            f("svd")


@pytest.mark.parametrize("scale", [1e-12, 1e6])
def test_the_symmetry_of_a_correlation_is_judged_relative_to_its_size(scale):
    """Receptances squared are tiny (1e-12 here) and accelerances squared large (1e6):
    the same matrix, a quarter of its largest entry away from symmetric, is refused at
    either size, and a symmetric one with round-off asymmetry of 1e-14 of its size (a
    product formed in two orders differs by about that) is accepted at either."""
    skew = scale * np.array([[2.0, 1.0], [0.5, 2.0]])
    with pytest.raises(ValueError, match="symmetric"):
        pod_from_correlation(skew)
    near = scale * np.array([[2.0, 1.0], [1.0 + 1e-14, 2.0]])
    result = pod_from_correlation(near)
    np.testing.assert_allclose(result.eigenvalues, scale * np.array([3.0, 1.0]), rtol=1e-12)


def test_a_correlation_asymmetric_within_the_tolerance_is_decomposed_as_its_symmetric_part():
    """eigh reads one triangle only. Ruu off symmetric by 2·2⁻³⁴ ≈ 1.2e-10 (accepted: the
    tolerance is 1e-10 × its largest entry 2) is decomposed as ½(Ruu + Ruuᵀ), here
    [[2, 1], [1, 2]] exactly (1 ± 2⁻³⁴ are doubles and sum to 2), of eigenvalues 3 and 1;
    either triangle alone would give 3 ∓ 2⁻³⁴ and 1 ± 2⁻³⁴, 5.8e-11 off."""
    e = 2.0**-34
    result = pod_from_correlation(np.array([[2.0, 1.0 + e], [1.0 - e, 2.0]]))
    # eigh of a symmetric 2 × 2 is accurate to a few eps of its largest eigenvalue (~1e-15)
    np.testing.assert_allclose(result.eigenvalues, [3.0, 1.0], rtol=1e-13)


def test_a_rank_one_correlation_has_no_negative_energy():
    """vvᵀ of six DOFs: eigh gives its five zero eigenvalues as round-off of either sign
    (−1.9e-15 here); the POD reports them as 0 — energy is never negative — and the one
    that is not as v·v."""
    v = np.random.default_rng(3).standard_normal(6)
    assert np.linalg.eigvalsh(np.outer(v, v)).min() < 0
    P = pod_from_correlation(np.outer(v, v))
    assert np.all(P.eigenvalues >= 0) and np.all(P.eigenvalues[1:] < 1e-14 * P.eigenvalues[0])
    assert P.eigenvalues[0] == pytest.approx(v @ v, rel=1e-12)


@pytest.mark.parametrize("scale", [1e-12, 1e6])
def test_a_negative_eigenvalue_is_judged_relative_to_the_largest(scale):
    """Positive semi-definite to round-off means relative to λ_max (1e-8 of it): at a
    receptance-sized (1e-12) or an accelerance-sized (1e6) scale alike, an eigenvalue of
    −1e-3 λ_max is refused and one of −1e-10 λ_max (round-off of a correlation formed
    from data) is accepted as zero energy."""
    with pytest.raises(ValueError, match="not positive semi-definite"):
        pod_from_correlation(scale * np.diag([4.0, 2.0, -4e-3]))
    result = pod_from_correlation(scale * np.diag([4.0, 2.0, -4e-10]))
    np.testing.assert_allclose(result.eigenvalues[:2], scale * np.array([4.0, 2.0]), rtol=1e-14)
    assert result.eigenvalues[2] == 0.0  # clipped: no negative energy


def test_pod_from_correlation_does_not_modify_input():
    R = correlation_from_snapshots(snapshots())
    before = R.copy()
    pod_from_correlation(R)
    np.testing.assert_array_equal(R, before)


def test_bad_snapshots_and_frf_raise():
    with pytest.raises(ValueError, match="snapshots must have shape"):
        correlation_from_snapshots(np.ones(5))
    H = np.ones((3, 2, 2))
    with pytest.raises(ValueError, match="H must have shape"):
        correlation_from_frf(H, [1.0, 2.0])
    with pytest.raises(ValueError, match="increasing"):
        correlation_from_frf(H, [1.0, 3.0, 2.0])
    with pytest.raises(ValueError, match="strictly positive"):
        correlation_from_frf(H, [0.0, 1.0, 2.0])
    # a NaN in the FRFs is named as H, by the correlation and by the POD alike
    H = np.ones((3, 2, 2), dtype=complex)
    H[1, 0, 1] = np.nan
    for f in (correlation_from_frf, pod_from_frf):
        with pytest.raises(ValueError, match=r"^H contains non-finite values"):
            f(H, [1.0, 2.0, 3.0])


@pytest.mark.parametrize("omega", [[1.0], [1.0, 3.0, 2.0], [1.0, 2.0, 2.0]])
def test_frequency_lines_that_cannot_be_integrated_over_are_named(omega):
    """One line, or lines not strictly increasing: the trapezoid rule has no band."""
    H = np.ones((len(omega), 2, 2))
    for f in (correlation_from_frf, pod_from_frf):
        with pytest.raises(ValueError, match=r"^omega must hold at least 2 strictly "
                                             r"increasing lines to integrate over$"):
            f(H, omega)


# --- noise-corrected POD (Ruu − diag(noise_variance)) --------------------------------


def _signal_and_noise(r: int = 4000, n: int = 30, seed: int = 1):
    """A rank-3 signal plus independent noise whose variance grows 400× across the DOFs
    (the paper's eq. 53 noise is of this kind: a fixed fraction of each channel)."""
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((n, 3))
    signal = (rng.standard_normal((r, 3)) * [3.0, 2.0, 1.0]) @ B.T
    sd = np.linspace(0.1, 2.0, n)
    return signal, signal + rng.standard_normal((r, n)) * sd, sd**2


def _largest_angle_deg(X: np.ndarray, Y: np.ndarray) -> float:
    """Largest principal angle between the column spans of X and Y."""
    Qx, Qy = np.linalg.qr(X)[0], np.linalg.qr(Y)[0]
    c = np.linalg.svd(Qx.T @ Qy, compute_uv=False).min()
    return float(np.degrees(np.arccos(min(c, 1.0))))


@pytest.mark.parametrize("method", ["correlation", "auto"])
def test_noise_corrected_pod_recovers_the_signal_subspace(method):
    # Plain POD of the noisy data turns the 3-mode subspace 4.4° away from the clean
    # data's POD; removing the known noise variance brings it within 1.6° (measured,
    # this seed; the rest is the noise's sampling error, ~1/√r). The bound 0.5×
    # leaves room for BLAS rounding, not for a correction that does nothing.
    clean, noisy, var = _signal_and_noise()
    target = pod(clean).basis(3)
    plain = _largest_angle_deg(pod(noisy, method=method).basis(3), target)
    corrected_pod = pod(noisy, method=method, noise_variance=var)
    corrected = _largest_angle_deg(corrected_pod.basis(3), target)
    assert corrected < 0.5 * plain
    # the energies too: within 3 % of the clean ones (the plain POD's third is 17 % high)
    np.testing.assert_allclose(corrected_pod.eigenvalues[:3], pod(clean).eigenvalues[:3],
                               rtol=0.03)
    assert np.all(corrected_pod.eigenvalues >= 0)
    assert np.all(np.diff(corrected_pod.eigenvalues) <= 0)
    R = corrected_pod.basis(3)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)


def test_noise_corrected_snapshots_equal_the_correlation_when_the_data_span_every_dof():
    _, noisy, var = _signal_and_noise(r=60, n=30)  # 60 snapshots ≥ 30 DOFs: Q complete
    a = pod(noisy, method="correlation", noise_variance=0.01 * var)
    b = pod(noisy, method="snapshots", noise_variance=0.01 * var)
    scale = a.eigenvalues[0]
    np.testing.assert_allclose(b.eigenvalues[:30], a.eigenvalues[:30], atol=1e-12 * scale)
    np.testing.assert_allclose(b.basis(5), a.basis(5), atol=1e-9)


@pytest.mark.parametrize("method", ["correlation", "snapshots"])
def test_zero_noise_variance_changes_nothing(method):
    X = snapshots(r=8, n=12) if method == "snapshots" else snapshots()
    plain, zero = pod(X, method=method), pod(X, method=method, noise_variance=0.0)
    k = min(X.shape)
    np.testing.assert_allclose(zero.eigenvalues[:k], plain.eigenvalues[:k],
                               atol=1e-12 * plain.eigenvalues[0])
    np.testing.assert_allclose(zero.basis(3), plain.basis(3), atol=1e-10)
    assert "noise-corrected" in repr(zero)
    assert zero.method == plain.method == method


def test_noise_corrected_pod_from_spectra_equals_that_of_the_history():
    # Parseval: the spectra's POD is the history's, with or without the noise term
    sim = simulate_white_noise(mass_spring_chain(12), (2.0, 30.0), 1 / 200, 10.0, 1.0, seed=3)
    var = 0.05 * np.mean(sim.response**2, axis=0)
    a = pod(sim.response, noise_variance=var)
    b = pod_from_spectra(sim.response_spectrum, sim.n_samples, noise_variance=var)
    np.testing.assert_allclose(b.eigenvalues, a.eigenvalues, rtol=1e-8,
                               atol=1e-10 * a.eigenvalues[0])
    np.testing.assert_allclose(b.basis(4), a.basis(4), atol=1e-7)


@pytest.mark.parametrize(
    "noise_variance, message",
    [
        (-1.0, "non-negative"),
        (np.ones(5), r"shape \(6,\)"),
        (np.ones(7), r"^noise_variance must be a number or have shape \(6,\) \(one per DOF\), "
                     r"got \(7,\)$"),
        (np.nan, "noise_variance"),
        (1e9, "more than twice the measured mean square"),
    ],
)
def test_bad_noise_variance_is_refused(noise_variance, message):
    with pytest.raises(ValueError, match=message):
        pod(snapshots(), noise_variance=noise_variance)


def test_noise_variance_just_above_a_channels_mean_square_is_clipped_with_a_warning():
    X = snapshots()
    measured = np.mean(X**2, axis=0)
    var = 0.1 * measured
    var[2] = 1.2 * measured[2]  # a channel with little signal: sampling error
    with pytest.warns(UserWarning, match="1 DOF"):
        P = pod(X, noise_variance=var)
    np.testing.assert_allclose(P.noise_variance[2], measured[2], rtol=1e-12)
    assert np.all(P.eigenvalues >= 0)


def test_noise_correction_leaves_its_input_alone_and_is_not_applied_twice():
    X = snapshots()
    var = np.full(6, 0.01)
    X0, var0 = X.copy(), var.copy()
    P = pod(X, noise_variance=var)
    np.testing.assert_array_equal(X, X0)
    np.testing.assert_array_equal(var, var0)
    P.noise_variance[0] = 5.0  # the result holds its own copy
    np.testing.assert_array_equal(var, var0)
    with pytest.raises(ValueError, match="already noise-corrected"):
        P.without_noise(var)


def test_noise_corrected_snapshots_are_the_rayleigh_ritz_pairs_on_the_data_span():
    # fewer snapshots than DOFs: the corrected modes are orthonormal, lie in the span
    # of the data, and diagonalise Ruu − D there with the reported eigenvalues
    _, noisy, var = _signal_and_noise(r=20, n=50)
    var = 0.2 * var
    P = pod(noisy, method="snapshots", noise_variance=var)
    Phi = P.basis(P.n_modes)
    assert P.n_modes == 20
    np.testing.assert_allclose(Phi.T @ Phi, np.eye(20), atol=1e-10)
    in_span = np.linalg.lstsq(noisy.T, Phi, rcond=None)[0]
    np.testing.assert_allclose(noisy.T @ in_span, Phi, atol=1e-9)
    R = noisy.T @ noisy / noisy.shape[0] - np.diag(var)
    T = Phi.T @ R @ Phi
    positive = P.eigenvalues[:20] > 0
    np.testing.assert_allclose(np.diag(T)[positive], P.eigenvalues[:20][positive],
                               rtol=1e-9, atol=1e-12 * P.eigenvalues[0])
    off = T - np.diag(np.diag(T))
    assert np.abs(off).max() < 1e-10 * P.eigenvalues[0]
    # one eigenvalue per DOF, as the uncorrected POD has: the 30 past the data's rank are
    # zero, and the energy fraction runs over all 50 DOFs to 1
    assert P.eigenvalues.shape == pod(noisy, method="snapshots").eigenvalues.shape == (50,)
    assert P.eigenvalues[20:].tolist() == [0.0] * 30
    assert P.energy_fraction.shape == (50,) and P.energy_fraction[-1] == 1.0


def test_repr_says_the_side_and_the_noise_correction():
    X = snapshots()
    r, n = X.shape
    plain = pod(X, method="correlation")
    assert repr(plain) == f"PODResult(n={n}, n_modes={plain.n_modes}, from the correlation)"
    corrected = pod(X, method="snapshots", noise_variance=0.0)
    assert repr(corrected) == (
        f"PODResult(n={n}, n_modes={corrected.n_modes}, from the snapshots, noise-corrected)"
    )
    # 3 snapshots of 8 DOFs: rank 3, so 3 modes carry energy, not 8
    few = pod(snapshots(3, 8), method="snapshots")
    assert repr(few) == "PODResult(n=8, n_modes=3, from the snapshots)"


def test_pod_takes_one_snapshot_or_one_channel_and_refuses_empty_or_complex():
    one = pod(np.array([[3.0, 4.0]]))  # a single snapshot: one mode, along it
    assert one.eigenvalues[0] == pytest.approx(25.0) and one.order_for_energy(1.0) == 1
    np.testing.assert_allclose(np.abs(one.basis(1)[:, 0]), [0.6, 0.8], rtol=1e-12)
    single = pod(np.array([[1.0], [-3.0]]))  # one channel: ⟨u²⟩ = 5
    assert single.eigenvalues.tolist() == pytest.approx([5.0]) and single.n == 1
    # refused the same way whichever side is asked for (the snapshot side would see a
    # zero Gram matrix of no DOFs, not an empty array)
    for bad in (np.zeros((0, 3)), np.zeros((3, 0)), np.ones(3), np.ones((2, 3, 4))):
        message = f"snapshots must have shape (r, n), time first, got {bad.shape}"
        for method in ("auto", "correlation", "snapshots"):
            with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
                pod(bad, method=method)
    for method in ("correlation", "snapshots"):
        with pytest.raises(ValueError, match="^snapshots must be real"):
            pod(np.ones((3, 2)) + 1j, method=method)


# --- noise_variance against the measured mean squares: exact limits and messages -----


def diagonal_pod(mean_squares) -> PODResult:
    """A POD whose modes are the unit vectors: diag(Ruu) is exactly ``mean_squares``."""
    lam = np.asarray(mean_squares, dtype=float)
    return PODResult(eigenvalues=lam, modes=np.eye(lam.size))


def too_noisy(j: int, d: float, measured: float) -> str:
    return "^" + re.escape(
        f"noise_variance of DOF {j} ({d:.3g}) is more than twice the measured mean square of "
        f"that channel ({measured:.3g}): check its units (the variance of the noise in the "
        "history, in the correlation's units)"
    ) + "$"


def test_noise_variance_limits_are_the_mean_square_and_twice_it():
    P = diagonal_pod([4.0, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exact = P.without_noise([4.0, 0.0])  # equal to a channel's mean square: no warning
    assert exact.noise_variance.tolist() == [4.0, 0.0]
    with pytest.warns(UserWarning) as caught:
        twice = P.without_noise([8.0, 0.0])  # twice it: clipped to it, not refused
    assert str(caught[0].message) == (
        "noise_variance reaches the measured mean square on 1 DOF(s) (DOF 0: 8 against 4; "
        "sampling error in a channel with little signal): taken as all noise there"
    )
    assert twice.noise_variance.tolist() == [4.0, 0.0]
    assert twice.eigenvalues.tolist() == [1.0, 0.0]
    with pytest.raises(ValueError, match=too_noisy(1, 2.5, 1.0)):
        P.without_noise([0.0, 2.5])


def test_a_scalar_noise_variance_is_that_variance_on_every_dof():
    # one number is each channel's variance, not a total shared out over the DOFs: on
    # diag(4, 3, 2) a variance of 1 leaves diag(3, 2, 1), exactly (a diagonal eigenproblem)
    corrected = diagonal_pod([4.0, 3.0, 2.0]).without_noise(1.0)
    assert corrected.noise_variance.tolist() == [1.0, 1.0, 1.0]
    assert corrected.eigenvalues.tolist() == [3.0, 2.0, 1.0]
    # on the snapshot side too: the same POD as the variance given per DOF
    X = snapshots(r=8, n=12)
    v = 1e-3 * float(np.min(np.mean(X**2, axis=0)))  # below every channel's mean square
    one = pod(X, method="snapshots", noise_variance=v)
    each = pod(X, method="snapshots", noise_variance=np.full(12, v))
    np.testing.assert_array_equal(one.noise_variance, each.noise_variance)
    np.testing.assert_array_equal(one.eigenvalues, each.eigenvalues)


@pytest.mark.parametrize(
    ("mean_squares", "d"),
    # the offending DOF is 1 in both; DOF 0 is within twice its mean square
    [([100.0, 1.0], [150.0, 3.0]), ([1.0, 100.0], [2.0, 201.0])],
)
def test_the_dof_named_is_the_one_over_twice_its_mean_square(mean_squares, d):
    with pytest.raises(ValueError, match=too_noisy(1, d[1], mean_squares[1])):
        diagonal_pod(mean_squares).without_noise(d)


def test_negative_or_complex_noise_variance_is_named():
    P = diagonal_pod([1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="^noise_variance must be non-negative, DOF 2 has -1$"):
        P.without_noise([0.0, 0.5, -1.0])
    with pytest.raises(ValueError, match="^noise_variance must be real"):
        P.without_noise([0.1, 0.1, 0.1 + 0j])
    with pytest.raises(ValueError, match="^this POD is already noise-corrected$"):
        P.without_noise(0.0).without_noise(0.0)


@pytest.mark.parametrize("method", ["correlation", "snapshots"])
def test_the_measured_mean_square_in_the_refusal_is_the_channels(method):
    X = snapshots(r=5, n=8) if method == "snapshots" else snapshots(r=50, n=4)
    measured = np.mean(X**2, axis=0)
    d = np.zeros(X.shape[1])
    d[2] = 3 * measured[2]
    with pytest.raises(ValueError, match=too_noisy(2, d[2], measured[2])):
        pod(X, method=method, noise_variance=d)


def test_the_warning_points_at_the_callers_line():
    X = snapshots()
    var = np.zeros(6)
    var[1] = 1.5 * np.mean(X[:, 1] ** 2)
    with pytest.warns(UserWarning, match="1 DOF") as caught:
        pod(X, noise_variance=var)
    assert caught[0].filename == __file__


def test_noise_correction_over_many_column_blocks_is_the_rayleigh_ritz_on_the_data_span():
    # 5000 DOFs, 6 snapshots: the snapshot side forms Aᵀ D A block by block of columns.
    # The oracle: an orthonormal basis Q of the data's span, the eigenvalues of
    # Qᵀ (Ruu − D) Q = Qᵀ Ruu Q − (Q·d)ᵀ Q.
    rng = np.random.default_rng(3)
    X = rng.standard_normal((6, 5000))
    d = np.where(np.arange(5000) < 2500, 0.05, 0.4) * np.mean(X**2, axis=0)
    P = pod(X, method="snapshots", noise_variance=d)
    Q = np.linalg.qr(X.T)[0]
    XQ = X @ Q
    T = XQ.T @ XQ / X.shape[0] - (Q * d[:, None]).T @ Q
    expected = np.clip(np.sort(np.linalg.eigvalsh(T))[::-1], 0.0, None)
    np.testing.assert_allclose(P.eigenvalues[:6], expected, rtol=1e-10,
                               atol=1e-12 * expected[0])


# --- pod_from_spectra: shapes, the side it takes ----------------------------------------


def test_pod_from_spectra_shapes_and_the_side_auto_takes():
    rng = np.random.default_rng(4)

    def X(s, n, p):
        return rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))

    # auto: the snapshot side when its 2·s·p real rows are fewer than the n DOFs
    assert pod_from_spectra(X(2, 12, 3), 100).method == "correlation"  # 12 rows, 12 DOFs
    assert pod_from_spectra(X(2, 13, 3), 100).method == "snapshots"
    # the smallest record, r = 2: ⟨u uᵀ⟩ = (2/r²) Σ Re(X Xᴴ)
    Y = X(3, 2, 1)
    P = pod_from_spectra(Y, 2)
    R = 0.5 * np.einsum("snp,smp->nm", Y, Y.conj()).real
    np.testing.assert_allclose(P.eigenvalues, np.linalg.eigvalsh(R)[::-1], rtol=1e-12)
    with pytest.raises(ValueError, match="^n_samples must be >= 2, got 1$"):
        pod_from_spectra(Y, 1)
    # (s, n) is read as (s, n, 1): the message gives the shape it checked
    for bad, shape in ((np.ones(5), (5,)), (np.ones((0, 3)), (0, 3, 1)),
                       (np.ones((4, 2, 0)), (4, 2, 0)), (np.ones((2, 2, 2, 2)), (2, 2, 2, 2))):
        message = f"X must have shape (s, n) or (s, n, p), got {shape}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            pod_from_spectra(bad, 10)
    with pytest.raises(ValueError, match="^X contains non-finite"):
        pod_from_spectra(np.full((3, 2), np.nan), 10)


def test_rank_one_snapshots_give_one_mode_and_no_negative_energy():
    # 20 multiples of one vector: the Gram matrix has rank 1; its other 19 eigenvalues
    # are round-off of either sign, which is neither a mode nor negative energy
    v = np.random.default_rng(1).standard_normal(40)
    X = np.outer(np.arange(1.0, 21.0), v)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P = pod(X, method="snapshots")
    assert P.method == "snapshots" and P.n_modes == 1
    assert P.eigenvalues[0] == pytest.approx(np.sum(np.arange(1.0, 21.0) ** 2) / 20 * v @ v,
                                             rel=1e-12)
    assert np.all(P.eigenvalues >= 0)
    np.testing.assert_allclose(np.abs(P.basis(1)[:, 0]), np.abs(v) / np.linalg.norm(v),
                               rtol=1e-10)
    # two snapshots, one of them zero: exactly rank 1, the zero eigenvalue is not refused
    two = pod(np.vstack([v, np.zeros(40)]), method="snapshots")
    assert two.n_modes == 1 and two.eigenvalues[0] == pytest.approx(v @ v / 2, rel=1e-12)
    with pytest.raises(ValueError, match="^the snapshots are identically zero: there is no "
                                         "energy to decompose$"):
        pod(np.zeros((3, 40)), method="snapshots")


def test_snapshot_modes_of_little_energy_are_orthonormal_and_the_rest_zero():
    """Exact FRFs of a 30-mass chain at 5 lines: 10 snapshots, rank 9, the ninth
    eigenvalue 3e-13 of the first. Formed as Aᵀv/σ its mode was off orthonormal by 6e-7
    (the modes' check in the refinement allows 1e-8); they are orthonormal to round-off,
    the first eight agree with the correlation method's to 1e-12 (the ninth, of so
    little energy, is only known to ~1e-8 by either), each basis is the first columns
    of the next (to round-off), and the eigenvalues past the rank are exactly 0, not round-off."""
    chain = mass_spring_chain(30)
    w = 2 * np.pi * np.array([10.0, 25.0, 40.0, 55.0, 70.0])
    F = np.zeros((w.size, 30, 1), dtype=complex)
    F[:, 0, 0] = 1.0
    H = chain.response(w, F)
    P = pod_from_frf(H, w)
    assert P.method == "snapshots" and P.n_modes == 9
    assert P.eigenvalues[8] < 1e-12 * P.eigenvalues[0] and np.all(P.eigenvalues[9:] == 0)
    Q = P.modes
    np.testing.assert_allclose(Q.T @ Q, np.eye(9), rtol=0, atol=1e-14)
    Pc = pod_from_frf(H, w, method="correlation")
    for i in range(8):
        assert abs(abs(Q[:, i] @ Pc.modes[:, i]) - 1) < 1e-12
    B4 = pod_from_frf(H, w).basis(4)
    np.testing.assert_allclose(B4, pod_from_frf(H, w).basis(9)[:, :4], rtol=0, atol=1e-14)


def test_project_names_a_bad_x():
    P = pod(snapshots(r=50, n=4))
    np.testing.assert_allclose(P.project(np.eye(4)[None], 2)[0], P.basis(2).T, rtol=1e-15)
    with pytest.raises(ValueError, match="^X contains non-finite"):
        P.project(np.full((3, 4), np.nan), 2)
    with pytest.raises(ValueError, match=r"^X must have shape \(s, n\) or \(s, n, p\) with n = 4, "
                                         r"got \(3, 5\)$"):
        P.project(np.ones((3, 5)), 2)
    # a 4-D X is refused, also one whose third axis happens to be n (it would multiply
    # through as a stack of (n, q) matrices)
    with pytest.raises(ValueError, match=r"^X must have shape \(s, n\) or \(s, n, p\) with n = 4, "
                                         r"got \(3, 4, 4, 2\)$"):
        P.project(np.ones((3, 4, 4, 2)), 2)


def test_order_for_energy_names_a_bad_fraction():
    P = pod(snapshots(r=50, n=4))
    assert P.order_for_energy(1.0) == 4 and P.order_for_energy(1e-12) == 1
    for k in (0.0, 1.5, [0.5, 0.9]):
        message = f"the energy fraction k must satisfy 0 < k <= 1, got {k!r}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            P.order_for_energy(k)
    with pytest.raises(ValueError, match="^k must be real"):
        P.order_for_energy(0.5 + 0j)


def test_correlation_from_snapshots_refusals():
    for bad in (np.zeros((0, 3)), np.zeros((3, 0)), np.ones(3), np.ones((2, 3, 4))):
        message = f"snapshots must have shape (r, n), time first, got {bad.shape}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            correlation_from_snapshots(bad)
    with pytest.raises(ValueError, match="^snapshots must be real"):
        correlation_from_snapshots(np.ones((3, 2)) + 1j)
    np.testing.assert_array_equal(correlation_from_snapshots(np.array([[1.0, 2.0]])),
                                  [[1.0, 2.0], [2.0, 4.0]])


def test_pod_from_correlation_names_its_argument():
    with pytest.raises(ValueError, match=r"^Ruu is identically zero: there is no energy to "
                       r"decompose$"):
        pod_from_correlation(np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"^Ruu "):
        pod_from_correlation(np.full((3, 3), np.nan))


# --- the refusals' and the warning's numbers, and pod_from_frf's side --------------------


def test_an_frf_refusal_gives_omegas_line_count_and_hs_shape():
    """H of 3 lines (or 1) against 2 frequencies: the message gives s as the lines of
    omega (2) and H's shape as it is; an H without responses or without inputs is refused
    the same way (nothing to correlate), not decomposed as a zero correlation, and so is
    an H of two or four axes whose first matches omega."""
    for bad in (np.ones((3, 2, 2)), np.ones((1, 2, 2)), np.ones((2, 0, 1)), np.ones((2, 2, 0)),
                np.ones((2, 2)), np.ones((2, 2, 1, 1))):
        message = f"H must have shape (s, n, n_in) with s = 2 lines (len(omega)), got {bad.shape}"
        for f in (correlation_from_frf, pod_from_frf):
            with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
                f(bad, [1.0, 2.0])


def test_an_empty_correlation_matrix_is_refused_by_its_shape():
    for bad in (np.zeros((0, 0)), np.ones((2, 3))):
        message = f"Ruu must be a non-empty square matrix, got shape {bad.shape}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            pod_from_correlation(bad)


def test_basis_beyond_the_snapshots_rank_names_the_m_asked_for():
    # 20 multiples of one vector: rank 1, so m = 2 is one mode too many
    v = np.random.default_rng(1).standard_normal(40)
    P = pod(np.outer(np.arange(1.0, 21.0), v), method="snapshots")
    message = "only 1 POD modes carry energy (the snapshots have rank 1), m = 2 asked for"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        P.basis(2)


def test_the_warning_counts_every_clipped_dof_and_names_the_first():
    """Mean squares 4, 1, 2 and variances 8, 0, 3: DOFs 0 and 2 exceed their channel's
    (each within twice it), both are clipped to it, and the warning names the first."""
    P = diagonal_pod([4.0, 1.0, 2.0])
    with pytest.warns(UserWarning) as caught:
        clipped = P.without_noise([8.0, 0.0, 3.0])
    assert str(caught[0].message) == (
        "noise_variance reaches the measured mean square on 2 DOF(s) (DOF 0: 8 against 4; "
        "sampling error in a channel with little signal): taken as all noise there"
    )
    assert clipped.noise_variance.tolist() == [4.0, 0.0, 2.0]
    assert clipped.eigenvalues.tolist() == [1.0, 0.0, 0.0]  # DOF 1 keeps its 1 − 0


def test_pod_from_frf_takes_the_snapshot_side_by_its_real_rows():
    """Each complex FRF column gives two real rows (real and imaginary parts): 2 lines ×
    1 input are 4 rows, so 4 DOFs take the correlation side and 5 the snapshot side;
    with 3 inputs, 12 rows: 12 DOFs the correlation side, 13 the snapshot side."""
    rng = np.random.default_rng(5)
    omega = [1.0, 2.0]
    for n, n_in, side in ((4, 1, "correlation"), (5, 1, "snapshots"),
                          (12, 3, "correlation"), (13, 3, "snapshots")):
        H = rng.standard_normal((2, n, n_in)) + 1j * rng.standard_normal((2, n, n_in))
        assert pod_from_frf(H, omega).method == side
