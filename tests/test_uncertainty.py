"""Confidence intervals of a refined model: the Jacobian oracle, the sandwich, the propagation,
the gauge, a small Monte Carlo and the refusals."""

from __future__ import annotations

import copy
import dataclasses
import re
import warnings

import numpy as np
import pytest
import scipy.stats

import podid_rs as pr
from podid_rs.identification import covariance
from podid_rs.identification.covariance import (
    LOCAL_HALF_WIDTH,
    DenseCovariance,
    LinearisedFit,
    _local_floor_and_proportional,
    entry_weights,
    gauss_newton_matrix,
    sym_gradient,
    sym_matrix,
)
from podid_rs.measured import from_frf
from podid_rs.uncertainty import _magnitude_band


def _chain(n: int = 4):
    """A chain with unequal masses and a dashpot at its first DOF: complex modes, no two
    shape entries alike (so the largest entry of each shape is clear)."""
    c = pr.mass_spring_chain(n, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-4)
    M = np.diag(np.linspace(0.8, 1.4, n))
    C = 2.0 * M + 1e-4 * c.K
    C[0, 0] += 3.0
    return pr.SecondOrderSystem(M, C, c.K)


def _frf_data(n: int = 4, s: int = 40, inputs=(0, 2), snr_db: float = 30.0, seed: int = 0):
    """FRFs of the chain at s lines over its modes, with complex noise of known variance
    per channel (SNR per channel), and the unit forces on the measured DOFs."""
    system = _chain(n)
    f = pr.modal_parameters(system).frequencies_hz
    omega = 2 * np.pi * np.linspace(0.7 * f[0], 1.2 * f[-1], s)
    H = system.frf(omega)[:, :, list(inputs)]
    F = np.zeros_like(H)
    for k, i in enumerate(inputs):
        F[:, i, k] = 1.0
    var = np.broadcast_to(np.mean(np.abs(H) ** 2, axis=0) / 10 ** (snr_db / 10), H.shape).copy()
    rng = np.random.default_rng(seed)
    U = H + np.sqrt(var / 2) * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    return system, omega, H, U, F, var


def _fit(objective="complex", grid=None, s=40):
    system, omega, H, U, F, var = _frf_data(s=s)
    rng = np.random.default_rng(3)
    R, _ = np.linalg.qr(rng.standard_normal((4, 4)))
    M, C, K = (R.T @ X @ R for X in (system.M, system.C, system.K))
    W = entry_weights("relative", U, objective, True)
    return LinearisedFit(M, C, K, U, F, omega, R, W, objective, grid=grid), var


def _responses(fit: LinearisedFit, theta: np.ndarray) -> np.ndarray:
    nb = fit.n_params // 3
    X = [fit.X[b] + sym_matrix(theta[b * nb:(b + 1) * nb], fit.m) for b in range(3)]
    D = fit.phi[0][:, None, None] * X[0] + fit.phi[1][:, None, None] * X[1] + X[2]
    return np.einsum("nm,smp->snp", fit.R, np.linalg.solve(D, fit.f))


def test_symmetric_coordinates_are_orthonormal_and_gradients_match():
    rng = np.random.default_rng(0)
    theta = rng.standard_normal(10)
    X = sym_matrix(theta, 4)
    assert np.allclose(X, X.T)
    assert np.isclose(np.sum(X * X), np.sum(theta * theta))  # an isometry
    A = rng.standard_normal((4, 4))  # g(X) = Σ A_ij X_ij
    assert np.isclose(np.sum(A * X), sym_gradient(A) @ theta)


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_jacobian_matches_central_differences(objective):
    fit, _ = _fit(objective)
    J = fit.jacobian()
    rng = np.random.default_rng(1)
    h = 1e-4
    for q in rng.choice(fit.n_params, 8, replace=False):
        e = np.zeros(fit.n_params)
        e[q] = h
        fd = (_responses(fit, e) - _responses(fit, -e)) / (2 * h)
        assert np.linalg.norm(fd - J[..., q]) <= 1e-6 * np.linalg.norm(fd)


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_gauss_newton_matrices_equal_the_explicit_jacobians(objective):
    """The Kronecker moment sums and the line-by-line products against Jᴴ diag(h) J
    formed from the explicit Jacobian, with and without correlated neighbouring lines
    (on a grid with gaps: the fit used a subset of the lines)."""
    grid = np.array(sorted(np.random.default_rng(2).choice(50, 40, replace=False)))
    fit, var = _fit(objective, grid=grid)
    J = fit.jacobian().reshape(fit.s, -1, fit.n_params)
    rng = np.random.default_rng(4)
    # the last: a variance that changes along the lines, so that a correlated pair's
    # E δu_l δū_r = ρ σ_l σ_r differs from σ_l² (the meat of H1 estimates)
    ramp = np.linspace(1.0, 3.0, fit.s)[:, None, None]
    for weights in (fit.bread(), fit.meat(var), fit.meat(var, (0.44, 0.03)),
                    fit.meat(var * ramp, (0.44, 0.03))):
        ref = np.zeros((fit.n_params, fit.n_params))
        for k in range(weights.left.size):
            lft, rgt = weights.left[k], weights.right[k]
            A = (J[lft].conj().T @ (weights.hermitian[k].reshape(-1)[:, None] * J[rgt])).real
            if weights.symmetric is not None:
                A += (J[lft].T @ (weights.symmetric[k].reshape(-1)[:, None] * J[rgt])).real
            ref += A if lft == rgt else A + A.T
        N = gauss_newton_matrix(fit, weights)
        assert np.abs(N - ref).max() <= 1e-12 * np.abs(ref).max()
        v = rng.standard_normal((fit.n_params, 2))
        assert np.allclose(fit.product(weights, v), ref @ v, rtol=0,
                           atol=1e-12 * np.abs(ref @ v).max())


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_the_per_line_matrices_and_the_stars_give_the_dense_gauss_newton_matrix(objective):
    """N through its per-line m × m matrices, and its blocks on the stars of coordinates
    (the matrix-free preconditioner's), against the dense N: two load cases, a weight
    per entry, an observation matrix that is not the identity."""
    system, omega, H, U, F, var = _frf_data(s=30)
    U = np.concatenate([U, 0.5 * U[..., :1] + 0.1], axis=2)
    F = np.concatenate([F, F[..., :1].conj()], axis=2)
    rng = np.random.default_rng(3)
    R, _ = np.linalg.qr(rng.standard_normal((4, 4)))
    W = entry_weights("relative", U, objective, True) * rng.uniform(0.5, 1.5, U.shape)
    M, C, K = (R.T @ X @ R for X in (system.M, system.C, system.K))
    fit = LinearisedFit(M, C, K, U, F, omega, R, W, objective)
    N = gauss_newton_matrix(fit, fit.bread())
    grams = fit.line_grams(fit.bread())
    v = rng.standard_normal((fit.n_params, 3))
    assert np.allclose(fit.gram_product(grams, v), N @ v, rtol=0,
                       atol=1e-12 * np.abs(N @ v).max())
    stars, index = fit.star_blocks(grams), fit.star_index()
    assert stars.shape == (4, 12, 12) and sorted(set(index.ravel())) == list(range(30))
    for j in range(4):
        assert np.abs(stars[j] - N[np.ix_(index[j], index[j])]).max() <= 1e-12 * np.abs(N).max()
    var = np.concatenate([var, var[..., :1]], axis=2)
    assert fit.line_grams(fit.meat(var, (0.4,))) is None  # pairs of lines: not per line


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_noise_draws_have_the_meat_as_covariance(objective):
    """Jᵣᵀ(∂r/∂u)δu drawn with the noise itself (correlated lines, a grid with gaps) has
    the sandwich's meat as its covariance, to the draws' sampling error."""
    grid = np.array(sorted(np.random.default_rng(2).choice(50, 40, replace=False)))
    fit, var = _fit(objective, grid=grid)
    S = gauss_newton_matrix(fit, fit.meat(var, (0.44, 0.03)))
    xi = fit.sample_noise_gradients(var, (0.44, 0.03), 4000, np.random.default_rng(0))
    emp = xi @ xi.T / xi.shape[1]
    d = np.sqrt(np.diag(S))
    assert np.abs((emp - S) / np.outer(d, d)).max() < 0.1  # 4000 draws: ±2/√4000 ≈ 0.03


def test_log_magnitude_bread_is_the_exact_gauss_newton_matrix():
    fit, _ = _fit("log-magnitude")
    J = fit.jacobian().reshape(-1, fit.n_params)
    W = fit.W.reshape(-1)
    a = (J / np.where(W > 0, fit.y.reshape(-1), 1.0)[:, None]).real  # ∂ ln|ŷ| / ∂θ
    exact = (W[:, None] ** 2 * a).T @ a
    assert np.allclose(gauss_newton_matrix(fit, fit.bread()), exact, rtol=0,
                       atol=1e-12 * np.abs(exact).max())


def _uncertainty_with_covariance(unc: pr.ModelUncertainty, v: np.ndarray) -> None:
    """Replace the covariance by v vᵀ: then σ(g) = |∇g · v|."""
    unc._cov.covariance = np.outer(v, v)
    unc._cov._null = np.zeros((v.size, 0))


def _perturbed(unc: pr.ModelUncertainty, v: np.ndarray, h: float):
    nb = unc.n_parameters // 3
    return tuple(X + c * sym_matrix(h * v[b * nb:(b + 1) * nb], unc.m)
                 for b, (X, c) in enumerate(zip((unc.M, unc.C, unc.K), unc._scales,
                                                strict=True)))


def test_propagation_to_modes_shapes_and_frfs_matches_differences():
    """Every gradient (natural frequency, damping ratio, mode shape, FRF) against
    central differences of the quantity along one direction v of M, C, K."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    v = np.random.default_rng(5).standard_normal(unc.n_parameters)
    _uncertainty_with_covariance(unc, v)
    modes = unc.modes(shapes=True)
    h = 1e-4
    plus = pr.SecondOrderSystem(*_perturbed(unc, v, h))
    minus = pr.SecondOrderSystem(*_perturbed(unc, v, -h))
    mp, mm = pr.modal_parameters(plus), pr.modal_parameters(minus)
    df = (mp.frequencies_hz - mm.frequencies_hz) / (2 * h)
    dz = (mp.damping_ratios - mm.damping_ratios) / (2 * h)
    assert np.allclose(modes.std_frequency_hz, np.abs(df), rtol=1e-5)
    assert np.allclose(modes.std_damping, np.abs(dz), rtol=1e-5)
    sp, sm = pr.mode_shapes(plus).shapes, pr.mode_shapes(minus).shapes
    ds = (sp - sm) / (2 * h)
    scale = np.abs(ds).max()
    assert np.allclose(modes.std_shapes_real, np.abs(ds.real), rtol=1e-4, atol=1e-7 * scale)
    assert np.allclose(modes.std_shapes_imag, np.abs(ds.imag), rtol=1e-4, atol=1e-7 * scale)
    band = unc.frf(omega[::7], rows=[0, 3], cols=[0, 2])
    Hp = plus.frf(omega[::7])[:, [0, 3]][:, :, [0, 2]]
    Hm = minus.frf(omega[::7])[:, [0, 3]][:, :, [0, 2]]
    dH = (Hp - Hm) / (2 * h)
    assert np.allclose(band.values, system.frf(omega[::7])[:, [0, 3]][:, :, [0, 2]])
    assert np.allclose(band.std_real, np.abs(dH.real), rtol=1e-5)
    assert np.allclose(band.std_imag, np.abs(dH.imag), rtol=1e-5)
    dl = (np.log(np.abs(Hp)) - np.log(np.abs(Hm))) / (2 * h) * 20 / np.log(10)
    assert np.allclose(band.std_db, np.abs(dl), rtol=1e-5)


def test_matrix_intervals_in_the_caller_units():
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    v = np.random.default_rng(6).standard_normal(unc.n_parameters)
    _uncertainty_with_covariance(unc, v)
    mats = unc.matrices()
    moved = _perturbed(unc, v, 1.0)
    for std, X, Y in zip((mats.std_M, mats.std_C, mats.std_K), (unc.M, unc.C, unc.K), moved,
                         strict=True):
        assert np.allclose(std, np.abs(Y - X))


def test_the_band_is_radial_and_reaches_zero_where_the_ellipse_holds_the_origin():
    H = np.array([10.0 + 0j, 0.5 + 0.5j, 3j, 1.0 + 1j])
    vr = np.array([1.0, 1.0, 0.04, 0.3])
    vi = np.array([4.0, 1.0, 25.0, 0.3])
    c = np.array([0.0, 0.0, 0.0, -0.29])
    lo, hi = _magnitude_band(H, vr, vi, c, 1.96)
    assert np.allclose([lo[0], hi[0]], [10 - 1.96, 10 + 1.96])  # the radial σ only
    assert lo[1] == 0.0 and np.isclose(hi[1], np.sqrt(0.5) + 1.96)  # the origin inside
    # radial σ² = 25 along Im: |3j| ± 1.96·5, the lower end clipped at 0
    assert lo[2] == 0.0 and np.isclose(hi[2], 3 + 1.96 * 5)
    # long along the tangent (1, −1), short (σ = 0.1) along the radius: a narrow band
    assert np.allclose([lo[3], hi[3]], [np.sqrt(2) - 0.196, np.sqrt(2) + 0.196])


def test_a_band_narrower_than_one_standard_deviation_is_the_radial_one():
    # z = 0.5 (a level of 38 %): the origin at Mahalanobis distance² 0.4 lies outside the
    # ellipse (0.4 > z² = 0.25), and the band is |H| ∓ 0.5 σ, above 0
    a = np.sqrt(0.4)
    lo, hi = _magnitude_band(np.array([a + 0j]), np.ones(1), np.ones(1), np.zeros(1), 0.5)
    assert np.allclose([lo[0], hi[0]], [a - 0.5, a + 0.5], rtol=1e-14)


def test_mode_intervals_are_the_estimate_plus_minus_z_standard_deviations():
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    modes = unc.modes(level=0.9)
    z = 1.6448536269514722  # the standard normal's 95th percentile: a two-sided 90 %
    assert modes.z == pytest.approx(z, rel=1e-12)
    f, sf = modes.frequencies_hz, modes.std_frequency_hz
    zeta, sz = modes.damping_ratios, modes.std_damping
    assert np.all(sf > 0) and np.all(sz > 0)
    assert np.allclose(modes.frequency_intervals_hz, np.stack([f - z * sf, f + z * sf], 1),
                       rtol=1e-14, atol=0)
    assert np.allclose(modes.damping_intervals, np.stack([zeta - z * sz, zeta + z * sz], 1),
                       rtol=1e-14, atol=0)


def test_latent_coordinates_have_a_gauge_and_no_matrix_intervals():
    system, omega, H, U, F, var = _frf_data(n=4)
    # the chain's first three coordinates observed, the fourth latent
    unc = pr.model_uncertainty(system, U[:, :3], F[:, :3], omega, basis=np.eye(3),
                               noise_variance=var[:, :3])
    assert unc.latent == 1 and unc.gauge == 1 * 3 + 1
    assert unc.rank == unc.n_parameters - unc.gauge
    with pytest.raises(ValueError, match=r"has 1 latent coordinate\(s\).*gauge of dimension 4"):
        unc.matrices()
    modes = unc.modes(shapes=True)
    assert np.all(modes.determined) and np.all(np.isfinite(modes.std_frequency_hz))
    assert np.all(np.isfinite(unc.frf(omega[::5]).upper))


@pytest.mark.parametrize("latent", [False, True])
def test_the_matrix_free_path_gives_the_dense_variances(latent):
    """Solves by preconditioned CG in the undamped modal coordinates against the dense
    covariance: the modes, the shapes and the FRF band, with correlated lines; with a
    latent coordinate (a gauge: N singular) too."""
    system, omega, H, U, F, var = _frf_data(s=60)
    k = 3 if latent else 4
    args = (system, U[:, :k], F[:, :k], omega)
    kw = dict(basis=np.eye(k), noise_variance=var[:, :k], line_correlation=(0.4, 0.05))
    dense = pr.model_uncertainty(*args, solver="dense", **kw)
    free = pr.model_uncertainty(*args, solver="matrix-free", **kw)
    assert free.solver == "matrix-free" and free.rank == dense.rank
    a, b = dense.modes(shapes=True), free.modes(shapes=True)
    assert np.allclose(b.std_frequency_hz, a.std_frequency_hz, rtol=1e-5)
    assert np.allclose(b.std_damping, a.std_damping, rtol=1e-5)
    assert np.allclose(b.std_shapes_real, a.std_shapes_real, rtol=1e-4, atol=1e-9)
    # the band from 200 draws of the noise's effect: each σ to about 5 %
    fa, fb = dense.frf(omega[::3]), free.frf(omega[::3])
    ratio = np.concatenate([(fb.std_real / fa.std_real).ravel(),
                            (fb.std_imag / fa.std_imag).ravel()])
    assert 0.95 < np.median(ratio) < 1.05 and np.all((ratio > 0.7) & (ratio < 1.35))
    if not latent:
        with pytest.raises(ValueError, match="matrix-free"):
            free.matrices()


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_block_cg_with_the_stars_gives_the_dense_variances_of_a_larger_chain(objective):
    """A 12-DOF chain driven by random forces on every DOF, its upper modes above the
    band (the weakly determined coordinates that made one CG per variance stall): every
    mode's variances as the dense covariance's, the noise estimated from the residuals."""
    n, s = 12, 80
    system = pr.mass_spring_chain(n)
    f = pr.modal_parameters(system).frequencies_hz
    omega = 2 * np.pi * np.linspace(0.5 * f[0], 0.6 * f[-1], s)
    rng = np.random.default_rng(5)
    F = rng.standard_normal((s, n)) + 1j * rng.standard_normal((s, n))
    U = np.einsum("sij,sj->si", system.frf(omega), F)
    U = U * (1 + 1e-3 * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)))
    kw = dict(objective=objective, weights="uniform" if objective != "complex" else "relative")
    dense = pr.model_uncertainty(system, U, F, omega, solver="dense", **kw)
    free = pr.model_uncertainty(system, U, F, omega, solver="matrix-free", **kw)
    a, b = dense.modes(), free.modes()
    assert np.all(np.isfinite(a.std_frequency_hz))
    assert np.allclose(b.std_frequency_hz, a.std_frequency_hz, rtol=1e-5)
    assert np.allclose(b.std_damping, a.std_damping, rtol=1e-5)
    assert len(free._cov.iterations) == 1  # the 24 gradients in one block


def test_rank_deficiency_gives_no_interval_rather_than_a_huge_one():
    """Two parameters the data see only through their sum: their sum and a third one have
    variances, either alone has none (NaN), however small its share of the null direction."""
    N = np.array([[1.0, 1.0, 0.0], [1.0, 1.0 + 1e-14, 0.0], [0.0, 0.0, 2.0]])
    cov = DenseCovariance(N)
    cov.set_meat(N)
    assert cov.rank == 2
    var = cov.variances(np.array([[1.0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0], [1.0, 1.001, 0]]))
    assert var[0] == pytest.approx(1.0) and var[1] == pytest.approx(0.5)
    assert np.isnan(var[2]) and np.isnan(var[3])


def test_pair_moments_are_the_variances_and_the_covariance():
    """(var g, var h, cov(g, h)) in one pass equal the three asked one at a time, NaN
    where either row leans on the undetermined direction (the sum above: g alone)."""
    N = np.array([[1.0, 1.0, 0.0], [1.0, 1.0 + 1e-14, 0.0], [0.0, 0.0, 2.0]])
    cov = DenseCovariance(N)
    cov.set_meat(np.diag([3.0, 1.0, 5.0]) + 0.5)
    G = np.array([[1.0, 1.0, 0.5], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [2.0, 2.0, -1.0]])
    H = np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    var_g, var_h, cov_gh = cov.pair_moments(G, H)
    np.testing.assert_array_equal(var_g, cov.variances(G))
    np.testing.assert_array_equal(var_h, cov.variances(H))
    np.testing.assert_array_equal(cov_gh, cov.covariances(G, H))
    assert np.isnan(cov_gh[1]) and np.isnan(cov_gh[2]) and np.isfinite(cov_gh[[0, 3]]).all()


def test_monte_carlo_coverage_of_a_small_chain():
    """40 noise seeds, maximum-likelihood weights and the known variance: the 95 %
    intervals of the natural frequencies and damping ratios hold the truth in most
    seeds, and their width matches the scatter of the estimates."""
    system = _chain(3)
    truth = pr.modal_parameters(system)
    est_f, est_z, sd_f, sd_z, inside = [], [], [], [], []
    for seed in range(40):
        _, omega, H, U, F, var = _frf_data(n=3, s=60, inputs=(0,), snr_db=20, seed=seed)
        w = 1 / np.sqrt(var)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = pr.refine(system, U, F, omega, weights=w, basis=np.eye(3))
        unc = pr.model_uncertainty(model, U, F, omega, weights=w, basis=np.eye(3),
                                   noise_variance=var)
        modes = unc.modes()
        est_f.append(modes.frequencies_hz)
        est_z.append(modes.damping_ratios)
        sd_f.append(modes.std_frequency_hz)
        sd_z.append(modes.std_damping)
        band = unc.frf()
        inside.append((np.abs(H) >= band.lower) & (np.abs(H) <= band.upper))
    est_f, est_z, sd_f, sd_z = map(np.array, (est_f, est_z, sd_f, sd_z))
    cover_f = np.mean(np.abs(est_f - truth.frequencies_hz) <= 1.96 * sd_f)
    cover_z = np.mean(np.abs(est_z - truth.damping_ratios) <= 1.96 * sd_z)
    assert 0.88 <= cover_f <= 1.0 and 0.88 <= cover_z <= 1.0
    assert 0.88 <= np.mean(inside) <= 1.0
    for est, sd in ((est_f, sd_f), (est_z, sd_z)):
        ratio = np.median(sd, axis=0) / est.std(axis=0)
        assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio


def test_noise_from_the_residuals_matches_the_known_noise():
    system, omega, H, U, F, var = _frf_data(s=200, snr_db=20)
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4))
    ratio = unc.variance / var
    assert np.all((ratio > 0.75) & (ratio < 1.3))
    assert unc.dof == 2 * U.size - unc.rank
    assert "per channel" in unc.noise
    known = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    assert known.dof is None and known.z() == pytest.approx(1.959964, abs=1e-5)
    assert unc.z() > known.z()  # Student's t
    assert unc.z() == pytest.approx(scipy.stats.t.ppf(0.975, 2 * U.size - unc.rank), rel=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"noise_variance": -1.0}, "noise_variance must be non-negative"),
        ({"noise_variance": np.nan}, "noise_variance contains NaN"),
        ({"noise_variance": np.ones(7)}, "noise_variance must be a scalar"),
        ({"coherence": 1.5, "averages": 10}, r"coherence must lie in \[0, 1\]"),
        ({"coherence": -0.1, "averages": 10}, r"coherence must lie in \[0, 1\]"),
        ({"coherence": np.nan, "averages": 10}, "coherence contains NaN"),
        ({"coherence": 0.9, "averages": 0}, "averages must be more than 1"),
        ({"coherence": 0.9, "averages": 1}, "averages must be more than 1"),
        ({"coherence": 0.9}, "coherence needs averages"),
        ({"averages": 10}, "averages goes with coherence"),
        ({"noise_variance": 1.0, "coherence": 0.9, "averages": 3}, "not both"),
        ({"line_correlation": 1.0}, "line_correlation"),
        ({"noise": "typo"}, "noise must be"),
        ({"lines": np.zeros(40, bool)}, "lines must be a boolean mask"),
    ],
)
def test_bad_noise_input_is_refused_by_name(kwargs, message):
    system, omega, H, U, F, var = _frf_data()
    if "coherence" in kwargs and np.ndim(kwargs["coherence"]) == 0:
        kwargs = {**kwargs, "coherence": np.full(U.shape, kwargs["coherence"])}
    with pytest.raises(ValueError, match=message):
        pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), **kwargs)


def test_bad_level_and_a_model_that_is_not_refined():
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    for level in (0.0, 1.0, 1.5, True):
        with pytest.raises(ValueError, match="level"):
            unc.modes(level)
    data = from_frf(U, omega, inputs=[0, 2])
    plain = pr.identify(U, F, omega, symmetric=True)
    with pytest.raises(ValueError, match="not a refined"):
        pr.fit_uncertainty(data, plain, np.eye(4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        user = pr.refine(system, U, F, omega, basis=np.eye(4), weights=np.ones(40))
    with pytest.raises(ValueError, match="user's weights"):
        pr.fit_uncertainty(data, user, np.eye(4))


def _escaped(text: str) -> str:
    return "^" + re.escape(text) + "$"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        # the smallest variance is quoted, not the largest (1)
        ({"noise_variance": np.r_[1.0, -2.0, np.ones(38)]},
         "noise_variance must be non-negative (found -2)"),
        ({"noise_variance": np.inf}, "noise_variance contains inf"),
        ({"noise_variance": np.ones(7)},
         "noise_variance must be a scalar, (s,) = (40,), (s, n) = (40, 4) or "
         "(s, n, p) = (40, 4, 2), got shape (7,)"),
        # the first coherence outside [0, 1] is quoted, not the first coherence (0.5)
        ({"coherence": np.where(np.arange(40 * 4 * 2).reshape(40, 4, 2) == 25, 1.5, 0.5),
          "averages": 10}, "coherence must lie in [0, 1] (γ², found 1.5)"),
        ({"coherence": np.full((40, 2), 0.9), "averages": 10},
         "coherence must have shape (s, n) or (s, n, p) = (40, 4, 2), got (40, 2)"),
        ({"coherence": np.full((40, 4), 0.9), "averages": True},
         "averages must be a number, got True"),
        ({"coherence": np.full((40, 4), 0.9), "averages": 1},
         "averages must be more than 1 (the number of averaged segments; one has coherence 1 "
         "whatever the noise), got 1"),
        ({"noise": "typo"}, "noise must be 'local', 'channel', 'line' or 'global', got 'typo'"),
        ({"weights": np.r_[1.0, -3.0, np.ones(38)]}, "weights must be non-negative (found -3)"),
        ({"line_correlation": (0.5, 1.0)},
         "line_correlation must be coefficients in (−1, 1), got (0.5, 1.0)"),
        ({"lines": np.ones(39, bool)},
         "lines must be a boolean mask of the 40 lines, with a line in it"),
        ({"objective": "cmplx"},
         "objective must be 'complex' or 'log-magnitude', got 'cmplx'"),
        ({"solver": "fast"}, "solver must be 'auto', 'dense' or 'matrix-free', got 'fast'"),
    ],
)
def test_refusals_quote_the_value_they_refuse(kwargs, message):
    """The whole message, with the value, shape or count it names (s = 40 lines, n = 4
    DOFs, p = 2 load cases)."""
    system, omega, H, U, F, var = _frf_data()
    with pytest.raises(ValueError, match=_escaped(message)):
        pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), **kwargs)


def test_refusals_of_the_data_and_the_model_name_what_they_got():
    system, omega, H, U, F, var = _frf_data()
    with pytest.raises(ValueError, match=_escaped(
            "U and F must be (s, n[, p]) of the same shape with s = 40 lines, got (40, 4, 2) "
            "and (40, 4, 1)")):
        pr.model_uncertainty(system, U, F[:, :, :1], omega)
    # four measured coordinates, three in the model: the coordinates counted along axis 1
    with pytest.raises(ValueError, match=_escaped(
            "U has 4 coordinates, more than the model's m = 3: give the basis")):
        pr.model_uncertainty(_chain(3), U, F, omega)
    # three measured DOFs with a basis of four rows: n is the data's, not the model's m = 4
    with pytest.raises(ValueError, match=_escaped(
            "basis must be (n, k) with n = 3 measured DOFs, got (4, 4)")):
        pr.model_uncertainty(system, U[:, :3], F[:, :3], omega, basis=np.eye(4))
    C = system.C.copy()
    C[0, 1] += 1.0
    with pytest.raises(ValueError, match="^the model's C is not symmetric"):
        pr.model_uncertainty(pr.SecondOrderSystem(system.M, C, system.K), U, F, omega)
    with pytest.raises(ValueError, match=_escaped("data must be a MeasuredData, got ndarray")):
        pr.fit_uncertainty(U, system, np.eye(4))
    data = from_frf(U, omega, inputs=[0, 2])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        user = pr.refine(system, U, F, omega, basis=np.eye(4), weights=np.ones(40))
    with pytest.raises(ValueError, match=r"refined with the user's weights \('user'\)"):
        pr.fit_uncertainty(data, user, np.eye(4))
    # one line: 4 · 2 = 8 complex entries, 16 real numbers; the matrix-free path takes the
    # rank as the 3 · 10 parameters less the gauge (none): 30, more than 16
    with pytest.raises(ValueError, match=_escaped(
            "the residuals have no degrees of freedom left (8 complex entries, 30 parameters): "
            "give noise_variance or coherence")):
        pr.model_uncertainty(system, U[:1], F[:1], omega[:1], basis=np.eye(4),
                             solver="matrix-free")


def test_frf_rows_and_columns_outside_the_measured_dofs_are_refused():
    """n = 4 measured DOFs: index 4 is one past the last, 3 the last."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    for name in ("rows", "cols"):
        with pytest.raises(ValueError, match=_escaped(
                f"{name} must be indices of measured DOFs in [0, 4), got array([4])")):
            unc.frf(omega[:3], **{name: [4]})
    assert unc.frf(omega[:3], rows=[3], cols=[3]).values.shape == (3, 1, 1)


def test_the_matrix_free_refusal_of_matrices_counts_the_parameters():
    system, omega, H, U, F, var = _frf_data()
    free = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var,
                                solver="matrix-free")
    # m = 4: three symmetric 4 × 4 matrices, 3 · 10 entries
    with pytest.raises(ValueError, match=r"matrix-free path \(30 of them at m = 4\)"):
        free.matrices()


def test_the_noise_variance_per_line_and_per_line_and_dof_is_broadcast():
    """(s,) and (s, n) variances are those of every entry of the line (and DOF)."""
    system, omega, H, U, F, var = _frf_data()
    per_line = np.linspace(1.0, 2.0, 40) * np.mean(var)
    per_dof = per_line[:, None] * np.array([1.0, 2.0, 3.0, 4.0])
    a = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=per_line)
    b = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=per_dof)
    assert np.array_equal(a.variance, np.repeat(np.repeat(per_line[:, None, None], 4, 1), 2, 2))
    assert np.array_equal(b.variance, np.repeat(per_dof[:, :, None], 2, 2))
    assert a.noise == b.noise == "given per entry"


def test_h1_variance_from_the_coherence_and_the_averages():
    """|Ĥ|²(1 − γ²)/(γ² (n_d − 1)) per entry, a coherence per line and DOF standing for
    all the DOF's load cases; the report names the averages."""
    system, omega, H, U, F, var = _frf_data()
    g = np.linspace(0.5, 0.95, 40)[:, None] * np.array([1.0, 0.9, 0.8, 1.0])
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), coherence=g, averages=11)
    gamma = np.repeat(g[:, :, None], 2, 2)
    # the same few roundings in another order (every γ² is above the coherence floor)
    np.testing.assert_allclose(unc.variance, np.abs(U) ** 2 * (1 - gamma) / (gamma * 10),
                               rtol=1e-13)
    assert unc.noise == "from the coherence and 11 averages (H1)"
    assert unc.dof is None


@pytest.mark.parametrize("noise", ["line", "global"])
def test_noise_per_line_and_global_leave_the_holes_out(noise):
    """The mean square of the residuals ŷ − u over the measured entries only (ŷ the chain's
    FRF: the model is the chain), scaled by 2·entries/dof; the report names the model."""
    system, omega, H, U, F, var = _frf_data()
    mask = np.ones((4, 2), dtype=bool)
    mask[3, 0] = mask[1, 1] = False
    unc = pr.model_uncertainty(system, np.where(mask, U, 1e3), F, omega, basis=np.eye(4),
                               measured=mask, noise=noise)
    used = 40 * int(mask.sum())
    assert unc.dof == 2 * used - unc.rank
    e2 = np.where(mask, np.abs(U - H) ** 2, 0.0)
    if noise == "line":
        mean = e2.sum(axis=(1, 2)) / mask.sum()
        what = "per line"
    else:
        mean = np.full(40, e2.sum() / used)
        what = "one for all entries"
    expected = np.broadcast_to(mean[:, None, None], U.shape) * 2 * used / unc.dof
    # ŷ is the fit's D⁻¹F against the chain's own FRF: equal to ~1e-13 of |H|, the noise
    # 30 dB (a factor 30) below it, so the squared residuals agree to ~1e-11
    np.testing.assert_allclose(unc.variance, expected, rtol=1e-8)
    assert unc.noise == f"estimated from the residuals, {what}, {unc.dof} degrees of freedom"


def test_summary_of_a_model_with_latent_coordinates_names_rank_and_gauge():
    """m = 4 with one latent coordinate: 3 · 10 parameters, a gauge of 1 · 3 + 1 = 4, so
    rank 26."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U[:, :3], F[:, :3], omega, basis=np.eye(3),
                               noise_variance=var[:, :3])
    assert "(dense, 30 parameters, rank 26, gauge 4); noise given per entry" in unc.summary()


def test_weights_per_line_and_dof_are_those_of_every_load_case():
    system, omega, H, U, F, var = _frf_data()
    w = np.linspace(1.0, 2.0, 40)[:, None] * np.array([1.0, 0.5, 2.0, 1.0])
    kw = dict(basis=np.eye(4), noise_variance=var)
    a = pr.model_uncertainty(system, U, F, omega, weights=w, **kw).modes()
    b = pr.model_uncertainty(system, U, F, omega, weights=np.repeat(w[:, :, None], 2, 2),
                             **kw).modes()
    np.testing.assert_array_equal(a.std_frequency_hz, b.std_frequency_hz)
    # the weights change the intervals (else the comparison above would prove nothing)
    c = pr.model_uncertainty(system, U, F, omega, weights="uniform", **kw).modes()
    assert not np.allclose(c.std_frequency_hz, a.std_frequency_hz, rtol=1e-3)


def test_log_magnitude_weights_leave_out_entries_below_the_range_of_their_line():
    """LOG_DYNAMIC_RANGE = 1e-12 below the largest entry of the same line and load case is
    out: on line 0 (largest 1) 1e-13 and 1e-12 itself (not above the limit); on line 1
    (largest 1e-12, the limit 1e-24) every entry is in, its 1e-12 too though it is at the
    limit of DOF 0's largest over the lines."""
    U = np.array([[1.0, 1e-12, 1e-13], [1e-12, 1e-13, 1e-13]], dtype=complex)[:, :, None]
    W = entry_weights("uniform", U, "log-magnitude", True)
    np.testing.assert_array_equal(W[:, :, 0], [[1.0, 0.0, 0.0], [1.0, 1.0, 1.0]])


def test_a_level_that_is_not_a_number_is_refused_as_such():
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    with pytest.raises(ValueError, match=_escaped("level must be a number in (0, 1), got True")):
        unc.modes(True)
    with pytest.raises(ValueError, match=_escaped("level must lie in (0, 1), got 1")):
        unc.modes(1)


def test_line_correlation_that_is_no_correlation_is_refused_with_its_coefficients():
    """ρ = (0.9, 0.9): the spectrum 1 + 1.8 cos θ + 1.8 cos 2θ is −1.025 at cos θ = −1/4."""
    system, omega, H, U, F, var = _frf_data()
    with pytest.raises(ValueError, match=re.escape(
            "line_correlation (0.9, 0.9) is not a correlation sequence")):
        pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var,
                             line_correlation=(0.9, 0.9), solver="matrix-free").frf(omega[:3])


def test_h1_coherence_of_hann_segments():
    rng = np.random.default_rng(0)
    r, dt = 8192, 1e-2
    x = rng.standard_normal((r, 1))
    y = np.concatenate([2 * x, 2 * x + rng.standard_normal((r, 1))], axis=1)
    stats = pr.h1_coherence(x, y, dt, nperseg=512)
    omega, H = pr.frf_h1(x, y, dt, nperseg=512)
    assert np.allclose(stats.omega, omega)
    assert np.allclose(stats.coherence[:, 0], 1.0)
    assert 0.5 < np.median(stats.coherence[:, 1]) < 0.9  # |2|² / (|2|² + 1) = 0.8, biased up
    assert stats.line_correlation == pytest.approx((4 / 9, 1 / 36))
    segments = (r - 512) // 256 + 1
    expected = segments / (1 + 2 * (1 - 1 / segments) / 36)
    assert stats.averages == pytest.approx(expected)
    with pytest.raises(ValueError, match="one input"):
        pr.h1_coherence(np.stack([x[:, 0], x[:, 0]], 1), y, dt, nperseg=512)


def test_h1_coherence_of_independent_records_adds_their_averages():
    """Two records of the same length, each cut into the same segments, are twice the
    averages of one (the records are independent: no overlap correlates them)."""
    rng = np.random.default_rng(1)
    x = rng.standard_normal((2, 4096, 1))
    y = 2 * x + rng.standard_normal((2, 4096, 1))
    one = pr.h1_coherence(x[0], y[0], 1e-2, nperseg=512)
    both = pr.h1_coherence(x, y, 1e-2, nperseg=512)
    assert both.averages == pytest.approx(2 * one.averages, rel=1e-12)


def test_h1_coherence_of_a_noise_free_channel_is_at_most_one():
    """γ² ≤ 1 (Cauchy–Schwarz) at every line, also where round-off of |Syx|² / (Sxx Syy)
    gives 1 + 1e-15 for a response proportional to the force (seeds 0–2 all do at some
    line): fit_uncertainty refuses a coherence above 1."""
    for seed in range(3):
        x = np.random.default_rng(seed).standard_normal((8192, 1))
        stats = pr.h1_coherence(x, np.concatenate([2 * x, 0.3 * x], axis=1), 1e-2, nperseg=512)
        assert np.all(stats.coherence <= 1.0)
        assert np.allclose(stats.coherence, 1.0, rtol=0, atol=1e-12)


def test_h1_coherence_of_a_dead_channel_is_zero_not_nan():
    """A response channel that reads exactly zero has S_yx = S_yy = 0: γ² is 0/0, taken
    as 0 (nothing of it is explained by the input), so that model_uncertainty, which
    refuses a NaN coherence, takes it; the live channel's coherence is the one it has
    alone."""
    rng = np.random.default_rng(2)
    x = rng.standard_normal((4096, 1))
    live = 2 * x + rng.standard_normal((4096, 1))
    stats = pr.h1_coherence(x, np.concatenate([live, np.zeros_like(x)], axis=1), 1e-2,
                            nperseg=512)
    assert np.all(stats.coherence[:, 1] == 0.0)
    alone = pr.h1_coherence(x, live, 1e-2, nperseg=512)
    # the same up to round-off (the FFT of two channels at once differs by ~1e-15)
    np.testing.assert_allclose(stats.coherence[:, :1], alone.coherence, rtol=1e-12)


def test_holes_weigh_nothing_in_the_covariance():
    """Entries a test did not measure enter neither N nor S nor the noise's degrees of
    freedom: whatever the holes hold, the intervals are the same."""
    system, omega, H, U, F, var = _frf_data(s=60)
    mask = np.ones((4, 2), dtype=bool)
    mask[3, 0] = mask[1, 1] = False
    garbage = U.copy()
    garbage[:, 3, 0] = 1e3
    garbage[:, 1, 1] = -7e2j
    kw = dict(basis=np.eye(4), measured=mask)
    a = pr.model_uncertainty(system, np.where(mask, U, 0.0), F, omega, **kw)
    b = pr.model_uncertainty(system, garbage, F, omega, **kw)
    assert a.dof == b.dof == 2 * U[:, mask].size - a.rank
    ma, mb = a.modes(), b.modes()
    assert np.all(np.isfinite(ma.std_frequency_hz))
    np.testing.assert_allclose(mb.std_frequency_hz, ma.std_frequency_hz, rtol=1e-12)
    np.testing.assert_allclose(mb.std_damping, ma.std_damping, rtol=1e-12)
    # the holes' garbage read as data would move them
    c = pr.model_uncertainty(system, garbage, F, omega, basis=np.eye(4))
    assert not np.allclose(c.modes().std_damping, ma.std_damping, rtol=0.1)
    with pytest.raises(ValueError, match="needs basis"):
        pr.model_uncertainty(system, U, F, omega, measured=mask)
    # a complex refit on them: its report names the mask, fit_uncertainty passes the data's
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = pr.refine(system, garbage, F, omega, basis=np.eye(4), measured=mask)
    assert model.info["refinement"]["weights"] == "relative, measured entries"
    data = from_frf(np.where(mask, U, 0.0), omega, inputs=[0, 2], measured=mask)
    unc = pr.fit_uncertainty(data, model, np.eye(4))
    direct = pr.model_uncertainty(model, garbage, F, omega, **kw)
    np.testing.assert_allclose(unc.modes().std_damping, direct.modes().std_damping, rtol=1e-12)


def test_fit_uncertainty_on_data_with_holes():
    chain = pr.mass_spring_chain(6, m1=1.0, m2=1.0, a0=3.0, a1=1e-4)
    w = 2 * np.pi * np.arange(5.0, 250.0, 1.0)
    H = chain.frf(w)[:, :, [1, 4]]
    mask = np.ones((6, 2), dtype=bool)
    mask[0, 0] = mask[2, 1] = False
    rng = np.random.default_rng(1)
    U = H * (1 + 0.01 * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)))
    data = from_frf(U, w, inputs=[1, 4], measured=mask)
    model, R, sweep = data.fit(m=6, threads=1)
    unc = pr.fit_uncertainty(data, model, R, sweep)
    assert unc.dof == 2 * int(mask.sum()) * w.size - unc.rank
    modes = unc.modes()
    assert np.all(modes.determined) and np.all(np.isfinite(modes.std_frequency_hz))


def _final_fit_on_informative_lines():
    """A 5-DOF chain driven at DOF 1, 120 lines with 1 % noise, swept on 40 informative
    lines and fitted finally on them: the lines, forces, responses, sweep, model and basis."""
    chain = pr.mass_spring_chain(5)
    w = 2 * np.pi * np.linspace(10.0, 200.0, 120)
    F_n = np.zeros((w.size, 5, 1), dtype=complex)
    F_n[:, 1, 0] = 1.0
    rng = np.random.default_rng(2)
    U_n = chain.response(w, F_n)
    U_n = U_n * (1 + 0.01 * rng.standard_normal(U_n.shape))
    P = pr.pod_from_frf(U_n, w)
    sweep = pr.sweep_orders(U_n, F_n, w, P, m=5, sweep_lines=40, threads=1)
    model, R = pr.final_fit(sweep, U_n, F_n, w, P, threads=1)
    return w, F_n, U_n, sweep, model, R


def test_fit_uncertainty_on_the_informative_lines_of_a_long_test():
    """A final fit on the order sweep's informative lines: its covariance is that of those
    lines, and without the sweep it is refused, naming why."""
    w, F_n, U_n, sweep, model, R = _final_fit_on_informative_lines()
    fitted = model.info["refinement"]["final_refit"]["lines_fitted"]
    assert fitted == int(sweep.lines.sum()) < w.size
    data = from_frf(U_n, w, inputs=[1])
    with pytest.raises(ValueError, match=f"fitted {fitted} of the {w.size} lines"):
        pr.fit_uncertainty(data, model, R)
    unc = pr.fit_uncertainty(data, model, R, sweep)
    weights, objective = ("relative", model.info["refinement"]["objective"])
    if objective == "log-magnitude":
        weights = "uniform"
    direct = pr.model_uncertainty(model, U_n, F_n, w, basis=R, weights=weights,
                                  objective=objective, lines=sweep.lines)
    assert unc.dof == direct.dof
    np.testing.assert_allclose(unc.modes().std_frequency_hz, direct.modes().std_frequency_hz,
                               rtol=1e-12)


def test_local_noise_is_a_floor_and_a_part_proportional_to_the_response():
    """Squared residuals |e|² ~ v·Exp(1) with v = a + b|ŷ|² across a resonance (|ŷ|²
    spans 4·10⁵) over a floor that grows fourfold along the band: the local estimate
    follows v to its 50 degrees of freedom (±20 %) on both flanks and at the peak, where
    one variance for all lines is 10 times v on a flank and 1/200 of it at the peak."""
    rng = np.random.default_rng(0)
    s = 4000
    r = np.linspace(0.5, 1.5, s)
    y2 = 1 / ((1 - r**2) ** 2 + (2e-3 * r) ** 2)
    v = 1e-2 * (1 + 3 * np.linspace(0, 1, s)) + 1e-4 * y2
    e2 = v * rng.exponential(size=s)
    used = np.ones((s, 1, 1), dtype=bool)
    ratio = _local_floor_and_proportional(e2[:, None, None], y2[:, None, None], used,
                                          LOCAL_HALF_WIDTH)[:, 0, 0] / v
    assert 0.95 < np.median(ratio) < 1.05
    low, high = np.percentile(ratio, [5, 95])
    assert low > 0.6 and high < 1.5, (low, high)
    peak = int(np.argmax(y2))
    assert np.all(np.abs(ratio[peak - 3:peak + 4] - 1) < 0.25), ratio[peak - 3:peak + 4]
    constant = np.mean(e2) / v
    assert constant[0] > 5 and constant[peak] < 0.01  # what one variance per channel does

def test_band_follows_noise_that_grows_with_the_response():
    """Measured FRFs' noise grows with the response (1 % of every value, as H1's random
    error at a steady coherence) over a floor: at light damping a resonance's squared
    residuals are 10⁴ times a quiet stretch's. Estimated as ``podid-rs identify`` does,
    per channel over the neighbouring lines, the band covers the noise-free FRF at about
    95 % of the lines (94.9 % when written) and its half-width is 1.96 standard
    deviations of the fitted |H| over 30 noise seeds (median 1.13×, 0.89–1.36× at 80 %
    of the lines); one variance per channel takes the resonances' noise for every line's
    (coverage 100 %, 5.8× too wide)."""
    from podid_rs.apps.identify import NOISE_MODEL

    n, s, seeds = 4, 240, 30
    chain = pr.mass_spring_chain(n, m1=1.0, m2=1.0, ku=1e4, a0=0.05, a1=1e-6)  # ζ 2–4e-4
    f = pr.modal_parameters(chain).frequencies_hz
    omega = 2 * np.pi * np.linspace(0.6 * f[0], 1.3 * f[-1], s)
    H = chain.frf(omega)[:, :, [0]]
    F = np.zeros_like(H)
    F[:, 0, 0] = 1.0
    sd = 0.01 * np.abs(H) + 1e-4 * np.abs(H).max(axis=0, keepdims=True)
    values, bands = [], {NOISE_MODEL: [], "channel": []}
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        U = H + sd * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = pr.refine(chain, U, F, omega, basis=np.eye(n))
        data = from_frf(U, omega, inputs=[0])
        for noise, out in bands.items():
            band = pr.fit_uncertainty(data, model, np.eye(n), noise=noise).frf()
            out.append((band.lower, band.upper))
        values.append(np.abs(band.values))
    scatter = 1.96 * np.std(values, axis=0, ddof=1)
    for noise, out in bands.items():
        lower, upper = (np.array(x) for x in zip(*out, strict=True))
        covered = np.mean((lower <= np.abs(H)) & (np.abs(H) <= upper))
        sharpness = np.median((upper - lower) / 2, axis=0) / scatter
        if noise == NOISE_MODEL:
            assert 0.9 <= covered <= 0.99, covered
            assert 0.8 <= np.median(sharpness) <= 1.3, np.median(sharpness)
            low, high = np.percentile(sharpness, [10, 90])
            assert low > 0.7 and high < 1.6, (low, high)
        else:  # the case tells the two apart: one variance per channel is far too wide
            assert np.median(sharpness) > 3, np.median(sharpness)


def test_the_modes_with_intervals_are_those_of_modal_parameters_real_roots_too():
    """An overdamped pair (two real roots) besides an oscillating mode: the intervals are
    given for every mode modal_parameters reports, in its order."""
    from podid_rs.uncertainty import _all_modes

    M, K = np.diag([1.0, 2.0]), np.array([[300.0, -100.0], [-100.0, 100.0]])
    C = np.diag([80.0, 0.1])  # DOF 0 far beyond critical damping
    system = pr.SecondOrderSystem(M, C, K)
    lam, _, _, pick = _all_modes(M, C, K)
    want = pr.modal_parameters(system).eigenvalues
    assert np.sum(np.abs(want.imag) == 0) >= 1  # the case has a real root
    assert np.allclose(lam[pick], want, rtol=1e-12)


def _with_variances(unc: pr.ModelUncertainty, var_f: np.ndarray, var_z: np.ndarray) -> None:
    """The covariance's variances replaced: every mode gets the given σ_f² and σ_ζ²."""
    unc._cov.variances = lambda g: np.concatenate([var_f[: g.shape[0] // 2],
                                                   var_z[: g.shape[0] // 2]])


def test_an_interval_wider_than_the_value_in_hz_is_no_interval():
    """z·σ_f = 2 f (in Hz, the frequency's own unit — below 2π f, the value in rad/s) is
    wider than the value; z·σ_ζ = 0.01 is not. The summary counts the undetermined modes
    among those selected, and its half-width is z·σ over the value."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    z = unc.z()
    f = pr.modal_parameters(system).frequencies_hz
    zeta = pr.modal_parameters(system).damping_ratios
    var_f = (f / z) ** 2 * np.r_[4.0, np.full(f.size - 1, 1e-4)]  # mode 0: ±2 f; others ±1 %
    var_z = np.full(f.size, (0.01 / z) ** 2)
    _with_variances(unc, var_f, var_z)
    modes = unc.modes()
    assert list(modes.determined) == [False] + [True] * (f.size - 1)
    assert modes.why_undetermined[0] == "wider than the value"
    text = unc.summary()
    assert "; 1 mode(s) not determined by the data" in text
    assert "not determined" not in unc.summary(select=np.arange(f.size) > 0)
    hz = 100 * np.median(0.01 / zeta[1:])
    assert f"over {f.size - 1} mode(s): 1 % of the natural frequency, {hz:.2g} % of the damping" \
        in text


def test_the_band_at_an_exact_zero_of_the_frf_is_the_whole_scatter():
    """Where Ĥ = 0 (an entry the model does not couple) the radial direction is none: the
    band is [0, z √(σ_re² + σ_im²)], the scatter of |δH| itself, not NaN."""
    H = np.array([0j, 1.0 + 0j])
    vr, vi, c = np.array([0.09, 1.0]), np.array([0.16, 1.0]), np.zeros(2)
    lo, hi = _magnitude_band(H, vr, vi, c, 2.0)
    assert lo[0] == 0.0 and np.isclose(hi[0], 2.0 * 0.5)  # √(0.09 + 0.16) = 0.5
    # the origin 1 σ from Ĥ = 1, inside z = 2: down to 0, up by the radial σ (the real part's)
    assert lo[1] == 0.0 and np.isclose(hi[1], 1.0 + 2.0)


def test_summary_takes_the_typical_interval_of_the_selected_modes_only():
    """select= restricts the median half-width to those modes: one mode selected, its own
    z·σ_f/f and z·σ_ζ/ζ."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    f = pr.modal_parameters(system).frequencies_hz
    zeta = pr.modal_parameters(system).damping_ratios
    z = unc.z()
    # mode 1 ±1 % in frequency and ±0.002 in damping, the others ±5 % and ±0.004
    var_f = (f / z) ** 2 * np.r_[25e-4, 1e-4, 25e-4, 25e-4]
    var_z = (np.r_[0.004, 0.002, 0.004, 0.004] / z) ** 2
    _with_variances(unc, var_f, var_z)
    text = unc.summary(select=np.arange(f.size) == 1)
    assert (f"over 1 mode(s): 1 % of the natural frequency, {100 * 0.002 / zeta[1]:.2g} % "
            "of the damping ratio") in text


def test_the_band_defaults_to_the_driven_dofs_not_the_load_cases():
    """Forces at DOFs 0 and 2 (two load cases): frf()'s default columns are DOFs 0 and 2."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    assert list(unc.driven) == [0, 2]
    band = unc.frf(omega[:2])
    assert list(band.cols) == [0, 2]
    np.testing.assert_allclose(band.values, system.frf(omega[:2])[:, :, [0, 2]], rtol=1e-10)


def test_a_coherence_of_one_is_a_noise_free_entry():
    """γ² = 1 (a noise-free channel, the top of [0, 1]) gives variance 0, not a refusal."""
    system, omega, H, U, F, var = _frf_data()
    g = np.full((40, 4), 0.9)
    g[:, 1] = 1.0
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), coherence=g, averages=5)
    assert np.all(unc.variance[:, 1] == 0.0)
    np.testing.assert_allclose(unc.variance[:, 0], np.abs(U[:, 0]) ** 2 * 0.1 / (0.9 * 4),
                               rtol=1e-13)


def test_an_unconverged_matrix_free_solve_names_its_tolerance(monkeypatch):
    """One CG iteration (no restart) leaves the solves short of the relative residual
    10 · CG_TOL they are held to: the warning names that tolerance and the modes have no
    interval, "not converged"."""
    monkeypatch.setattr(covariance, "CG_MAX_ITER", 1)
    monkeypatch.setattr(covariance, "CG_RESTARTS", 0)
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var,
                               solver="matrix-free")
    tol = f"relative residual {10 * covariance.CG_TOL:g} in 1 iterations and 0 restarts"
    with pytest.warns(pr.ConvergenceWarning, match=re.escape(tol)):
        modes = unc.modes()
    assert "not converged" in list(modes.why_undetermined)


def test_fit_uncertainty_of_a_kept_held_out_fit_leaves_out_the_test_lines():
    """A final fit that kept the sweep's held-out fit was fitted on the training lines,
    the informative lines less the test lines: its covariance is that of those lines.
    (The report is the one thing fit_uncertainty reads: here it is set to say so.)"""
    w, F_n, U_n, sweep, model, R = _final_fit_on_informative_lines()
    info = copy.deepcopy(model.info)
    info["refinement"].setdefault("final_refit", {})["kept"] = "held-out fit"
    held_out = dataclasses.replace(model, info=info)
    data = from_frf(U_n, w, inputs=[1])
    with pytest.raises(ValueError, match="held-out fit"):
        pr.fit_uncertainty(data, held_out, R)
    training = sweep.lines & ~sweep.test_lines
    assert 0 < training.sum() < sweep.lines.sum()
    unc = pr.fit_uncertainty(data, held_out, R, sweep)
    weights, objective = ("relative", model.info["refinement"]["objective"])
    if objective == "log-magnitude":
        weights = "uniform"
    direct = pr.model_uncertainty(model, U_n, F_n, w, basis=R, weights=weights,
                                  objective=objective, lines=training)
    assert unc.dof == direct.dof
    np.testing.assert_allclose(unc.modes().std_frequency_hz, direct.modes().std_frequency_hz,
                               rtol=1e-12)


def test_the_meat_of_correlated_lines_is_rho_times_both_lines_deviations():
    """Complex objective: the pair of fitted lines l, r = l + 1 on the grid carries
    E δu_l δū_r = ρ σ_l σ_r, weighted ½ W_l² W_r² (scaled units: σ² / su²) — the geometric
    mean of the two lines' variances, which here differ by a factor of 4 from l to r."""
    fit, var = _fit("complex")
    v = var * np.linspace(1.0, 4.0, fit.s)[:, None, None] ** 2  # σ grows 1 → 4 over the band
    meat = fit.meat(v, (0.44,))
    pairs = ~meat.diagonal
    assert np.array_equal(meat.left[pairs], np.arange(fit.s - 1))
    assert np.array_equal(meat.right[pairs], np.arange(1, fit.s))
    lft, rgt = meat.left[pairs], meat.right[pairs]
    sd = np.sqrt(v) / fit.su
    expected = 0.5 * fit.W[lft] ** 2 * fit.W[rgt] ** 2 * 0.44 * sd[lft] * sd[rgt]
    np.testing.assert_allclose(meat.hermitian[pairs], expected, rtol=1e-13)


# ------------------------------------------------------------------ second hardening pass
# Coincidences of the fixtures broken (a layout with n = p, a channel fitted on part of its
# lines, a rank below the parameters, uniform weights in fit_uncertainty, several blocks of
# lines), degenerate but valid inputs (an undamped model, a repeated eigenvalue, real roots,
# an empty selection, a coherence of 0, a column without response, a coordinate no data
# touch, an exact zero under the log-magnitude objective) and options that reach more than
# one output (level, lines, the noise options and the solver of fit_uncertainty).


def test_the_summary_at_another_level_takes_that_levels_z():
    """summary(level=0.9): the text names 90 % and the median half-width is z σ_f / f with
    the 90 % z = 1.645 (σ_f = 1 % of f: 1.6 %; at 95 % it would read 2 %)."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    modal = pr.modal_parameters(system)
    f, zeta = modal.frequencies_hz, modal.damping_ratios
    _with_variances(unc, (0.01 * f) ** 2, np.full(f.size, 1e-6))  # σ_ζ = 0.001
    z = scipy.stats.norm.ppf(0.95)
    text = unc.summary(level=0.9)
    assert text.startswith("90 % intervals from the sandwich covariance")
    hz = 100 * np.median(z * 1e-3 / zeta)
    assert (f"over {f.size} mode(s): {100 * z * 0.01:.2g} % of the natural frequency, "
            f"{hz:.2g} % of the damping ratio") in text


def test_the_band_and_the_matrix_intervals_at_another_level_take_its_z():
    """level=0.9 reaches the band (its z, its level, its upper end |Ĥ| + z σ_r with σ_r the
    radial deviation from the band's own parts) and the matrices' intervals."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    z = scipy.stats.norm.ppf(0.95)  # a two-sided 90 %
    band = unc.frf(omega[::10], level=0.9)
    assert band.level == 0.9 and band.z == pytest.approx(z, rel=1e-12)
    a, b = band.values.real, band.values.imag
    sr = np.sqrt(a**2 * band.std_real**2 + b**2 * band.std_imag**2
                 + 2 * a * b * band.corr * band.std_real * band.std_imag) / np.abs(band.values)
    # the same few roundings in another order
    np.testing.assert_allclose(band.upper, np.abs(band.values) + z * sr, rtol=1e-12)
    mats = unc.matrices(level=0.9)
    assert mats.level == 0.9 and mats.z == pytest.approx(z, rel=1e-12)


def test_a_fit_on_part_of_the_lines_takes_their_noise_and_bands_every_line():
    """lines = every other line: the given variance (per line) and the H1 variance are those
    of the fitted lines; the band's default lines are still all the data's."""
    system, omega, H, U, F, var = _frf_data()
    lines = np.arange(40) % 2 == 0
    per_line = np.linspace(1.0, 2.0, 40) * np.mean(var)
    kw = dict(basis=np.eye(4), lines=lines)
    a = pr.model_uncertainty(system, U, F, omega, noise_variance=per_line, **kw)
    np.testing.assert_array_equal(
        a.variance, np.broadcast_to(per_line[lines][:, None, None], (20, 4, 2)))
    np.testing.assert_array_equal(a.frf().omega, omega)
    g = np.linspace(0.5, 0.95, 40)[:, None] * np.array([1.0, 0.9, 0.8, 1.0])
    b = pr.model_uncertainty(system, U, F, omega, coherence=g, averages=11, **kw)
    gamma = g[lines][:, :, None]
    # the same few roundings in another order (every γ² above the coherence floor)
    np.testing.assert_allclose(b.variance, np.abs(U[lines]) ** 2 * (1 - gamma) / (gamma * 10),
                               rtol=1e-13)


@pytest.mark.parametrize("solver", ["dense", "matrix-free"])
def test_fitted_lines_apart_on_the_data_grid_are_no_neighbours(solver):
    """Fitted on every other line, no two fitted lines are neighbours on the data's grid: a
    correlation of neighbouring lines (lag 1) pairs none of them and the intervals are those
    of independent lines; a lag of 2 pairs them and moves the intervals."""
    system, omega, H, U, F, var = _frf_data()
    kw = dict(basis=np.eye(4), noise_variance=var, lines=np.arange(40) % 2 == 0, solver=solver)
    a = pr.model_uncertainty(system, U, F, omega, line_correlation=(0.4,), **kw).modes()
    b = pr.model_uncertainty(system, U, F, omega, **kw).modes()
    # the same sums (the lag-1 pairs are none): equal to round-off
    np.testing.assert_allclose(a.std_frequency_hz, b.std_frequency_hz, rtol=1e-10)
    np.testing.assert_allclose(a.std_damping, b.std_damping, rtol=1e-10)
    c = pr.model_uncertainty(system, U, F, omega, line_correlation=(0.0, 0.4), **kw).modes()
    assert not np.allclose(c.std_frequency_hz, b.std_frequency_hz, rtol=1e-3)


def test_noise_from_the_residuals_of_a_model_with_latent_coordinates_counts_its_rank():
    """Three of four coordinates observed: rank 30 − 4 (the gauge), so the 40 · 3 · 2 = 240
    complex residuals (480 real numbers) leave 454 degrees of freedom, not 450."""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U[:, :3], F[:, :3], omega, basis=np.eye(3))
    assert unc.rank == 26 and unc.dof == 454
    assert unc.noise.endswith(", 454 degrees of freedom")


def test_fit_uncertainty_of_a_fit_with_uniform_weights_takes_them():
    """The report of a complex refit with uniform weights says "uniform": fit_uncertainty
    then weighs as model_uncertainty with weights="uniform", not "relative"."""
    system, omega, H, U, F, var = _frf_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = pr.refine(system, U, F, omega, basis=np.eye(4), weights="uniform")
    assert model.info["refinement"]["weights"] == "uniform"
    data = from_frf(U, omega, inputs=[0, 2])
    got = pr.fit_uncertainty(data, model, np.eye(4), noise_variance=var).modes()
    kw = dict(basis=np.eye(4), noise_variance=var)
    uniform = pr.model_uncertainty(model, U, F, omega, weights="uniform", **kw).modes()
    relative = pr.model_uncertainty(model, U, F, omega, weights="relative", **kw).modes()
    np.testing.assert_allclose(got.std_frequency_hz, uniform.std_frequency_hz, rtol=1e-12)
    assert not np.allclose(relative.std_frequency_hz, uniform.std_frequency_hz, rtol=1e-3)


def test_fit_uncertainty_passes_the_noise_and_the_solver_on():
    """Each noise option and the solver given to fit_uncertainty reach model_uncertainty:
    the same report and intervals as model_uncertainty given the same."""
    system, omega, H, U, F, var = _frf_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = pr.refine(system, U, F, omega, basis=np.eye(4))
    data = from_frf(U, omega, inputs=[0, 2])
    g = np.linspace(0.5, 0.95, 40)[:, None] * np.array([1.0, 0.9, 0.8, 1.0])
    cases = [dict(noise_variance=var), dict(coherence=g, averages=11),
             dict(noise_variance=var, line_correlation=(0.4,)),
             dict(noise_variance=var, solver="matrix-free")]
    for options in cases:
        got = pr.fit_uncertainty(data, model, np.eye(4), **options)
        direct = pr.model_uncertainty(model, U, F, omega, basis=np.eye(4), **options)
        assert (got.noise, got.solver, got.dof) == (direct.noise, direct.solver, direct.dof)
        # the same computation twice (block CG too is deterministic)
        np.testing.assert_allclose(got.modes().std_frequency_hz,
                                   direct.modes().std_frequency_hz, rtol=1e-12)
    assert got.solver == "matrix-free"
    # the correlation moves the intervals (else its case above would prove nothing)
    plain = pr.model_uncertainty(model, U, F, omega, basis=np.eye(4), noise_variance=var)
    assert not np.allclose(
        pr.fit_uncertainty(data, model, np.eye(4), noise_variance=var,
                           line_correlation=(0.4,)).modes().std_frequency_hz,
        plain.modes().std_frequency_hz, rtol=1e-3)


def _overdamped_pair_and_a_mode():
    """Two real roots (DOF 0 far beyond critical damping) and one oscillating mode."""
    M, K = np.diag([1.0, 2.0]), np.array([[300.0, -100.0], [-100.0, 100.0]])
    return pr.SecondOrderSystem(M, np.diag([80.0, 0.1]), K)


def test_the_summary_leaves_out_real_roots_and_an_empty_selection():
    """An overdamped pair (damping ratio 1) besides an oscillating mode: the typical interval
    is the oscillating mode's alone; a selection of no mode has none, and nothing undetermined."""
    system = _overdamped_pair_and_a_mode()
    omega = 2 * np.pi * np.linspace(0.5, 3.0, 30)
    U = system.frf(omega)
    F = np.broadcast_to(np.eye(2), U.shape).astype(complex)
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(2), noise_variance=1e-12)
    modal = pr.modal_parameters(system)
    f, zeta = modal.frequencies_hz, modal.damping_ratios
    oscillating = np.abs(modal.eigenvalues.imag) > 0
    assert f.size == 3 and oscillating.sum() == 1
    _with_variances(unc, (0.01 * f) ** 2, np.full(3, 1e-6))  # σ_f = 1 % of f, σ_ζ = 0.001
    z = unc.z()
    hz = 100 * z * 1e-3 / zeta[oscillating][0]
    assert (f"over 1 mode(s): {100 * z * 0.01:.2g} % of the natural frequency, {hz:.2g} % "
            "of the damping ratio") in unc.summary()
    text = unc.summary(select=np.zeros(3, dtype=bool))
    assert "median" not in text and "not determined" not in text


def test_the_shapes_of_a_repeated_eigenvalue_have_no_interval():
    """Two identical uncoupled oscillators share an eigenvalue: their shapes (any mix of the
    two) have no derivative and get NaN; the third mode's shape has its σ."""
    M, C, K = np.eye(3), 0.5 * np.eye(3), np.diag([100.0, 100.0, 400.0])
    system = pr.SecondOrderSystem(M, C, K)
    omega = 2 * np.pi * np.linspace(1.0, 4.0, 30)
    U = system.frf(omega)
    F = np.broadcast_to(np.eye(3), U.shape).astype(complex)
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(3), noise_variance=1e-12)
    _uncertainty_with_covariance(unc, np.random.default_rng(8).standard_normal(unc.n_parameters))
    modes = unc.modes(shapes=True)
    assert np.isclose(modes.eigenvalues[0], modes.eigenvalues[1], rtol=1e-12)
    assert np.all(np.isnan(modes.std_shapes_real[:, :2]))
    assert np.all(np.isnan(modes.std_shapes_imag[:, :2]))
    assert np.all(np.isfinite(modes.std_shapes_real[:, 2]))
    assert np.any(modes.std_shapes_real[:, 2] > 0)


def test_an_undamped_model_is_symmetric():
    """C = 0 exactly (an undamped model) is symmetric, not refused: its covariance is
    formed, its modes are modal_parameters' with damping ratio 0."""
    system, omega, H, U, F, var = _frf_data()
    undamped = pr.SecondOrderSystem(system.M, np.zeros((4, 4)), system.K)
    unc = pr.model_uncertainty(undamped, U, F, omega, basis=np.eye(4), noise_variance=var)
    modes = unc.modes()
    np.testing.assert_allclose(modes.frequencies_hz,
                               pr.modal_parameters(undamped).frequencies_hz, rtol=1e-12)
    assert np.all(np.abs(modes.damping_ratios) < 1e-12)


def test_a_coordinate_no_data_touch_has_no_variance_and_leaves_the_others_theirs():
    """N with a zero row and column (a coordinate no data touch: its diagonal 0, nothing to
    scale by): that coordinate has no variance, the others N⁺ S N⁺'s (S = N: 1/2, 1/0.5)."""
    N = np.diag([2.0, 0.0, 0.5])
    cov = DenseCovariance(N)
    cov.set_meat(N)
    assert cov.rank == 2
    var = cov.variances(np.eye(3))
    assert var[0] == pytest.approx(0.5) and np.isnan(var[1]) and var[2] == pytest.approx(2.0)


def test_a_coherence_of_zero_is_taken_at_the_floor():
    """γ² = 0 (the bottom of [0, 1]): the variance of COHERENCE_FLOOR, huge but finite."""
    system, omega, H, U, F, var = _frf_data()
    g = np.full((40, 4), 0.9)
    g[:, 3] = 0.0
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), coherence=g, averages=5)
    floor = covariance.COHERENCE_FLOOR
    np.testing.assert_allclose(unc.variance[:, 3],
                               np.abs(U[:, 3]) ** 2 * (1 - floor) / (floor * 4), rtol=1e-13)


def test_relative_weights_of_a_column_without_response_are_zero():
    """1/‖u_c‖ per column (line and load case): 1/5 and 1/√3 here; a column that is all
    zero (no response at that line) weighs 0, not 1/0."""
    U = np.zeros((2, 3, 2), dtype=complex)
    U[0, :, 0] = [3.0, 4.0j, 0.0]
    U[1] = 1.0
    W = entry_weights("relative", U, "complex", True)
    np.testing.assert_allclose(W[0, :, 0], 0.2, rtol=1e-15)
    np.testing.assert_array_equal(W[0, :, 1], 0.0)
    np.testing.assert_allclose(W[1], 1 / np.sqrt(3), rtol=1e-15)


def test_relative_weights_under_the_log_magnitude_objective_are_one_per_entry():
    """refine's log-magnitude objective takes "relative" as 1 per entry (ln|u| is already
    relative), not 1/‖u_c‖: so does the covariance, whose default weights are "relative" —
    an entry exactly 0 (no ln of it) still weighs nothing."""
    U = np.zeros((2, 3, 2), dtype=complex)
    U[0, :, 0] = [3.0, 4.0j, 0.0]
    U[1] = 2.0
    W = entry_weights("relative", U, "log-magnitude", True)
    np.testing.assert_array_equal(W[0, :, 0], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(W[0, :, 1], 0.0)
    np.testing.assert_array_equal(W[1], 1.0)
    # the model's intervals by default are those of uniform weights ...
    system, omega, H, U, F, var = _frf_data()
    kw = dict(basis=np.eye(4), objective="log-magnitude", noise_variance=var)
    default = pr.model_uncertainty(system, U, F, omega, **kw).modes()
    uniform = pr.model_uncertainty(system, U, F, omega, weights="uniform", **kw).modes()
    np.testing.assert_array_equal(default.std_frequency_hz, uniform.std_frequency_hz)
    np.testing.assert_array_equal(default.std_damping, uniform.std_damping)
    # ... and 1/‖u_c‖ per column would change them (else the comparison proves nothing)
    per_column = np.broadcast_to(1 / np.linalg.norm(U, axis=1)[:, None, :], U.shape)
    other = pr.model_uncertainty(system, U, F, omega, weights=per_column, **kw).modes()
    assert not np.allclose(other.std_damping, uniform.std_damping, rtol=1e-3)


def test_weights_of_a_square_layout_are_per_dof_on_measured_dofs():
    """n = p = 2: an (s, n) array on measured DOFs weighs each DOF, as refine takes it; on
    reduced coordinates (no measured DOFs) the same array weighs each load case."""
    U = np.ones((3, 2, 2), dtype=complex)
    a = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    np.testing.assert_array_equal(entry_weights(a, U, "complex", True),
                                  np.repeat(a[:, :, None], 2, 2))
    np.testing.assert_array_equal(entry_weights(a, U, "complex", False),
                                  np.repeat(a[:, None, :], 2, 1))


def test_noise_per_channel_is_the_mean_over_the_lines_it_was_fitted_on():
    """Weight 0 on the first ten lines of DOF 1, load case 0: that channel's variance is the
    mean square of its residuals over its other 30 lines (scaled by 2·entries/dof)."""
    system, omega, H, U, F, var = _frf_data()
    w = np.ones(U.shape)
    w[:10, 1, 0] = 0.0
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), weights=w, noise="channel")
    used = w > 0
    n_used = int(used.sum())
    assert unc.dof == 2 * n_used - unc.rank
    mean = np.where(used, np.abs(U - H) ** 2, 0.0).sum(axis=0) / used.sum(axis=0)
    # ŷ = the chain's own FRF to ~1e-13 of |H|, the noise 30 dB below it (as above)
    np.testing.assert_allclose(unc.variance, np.broadcast_to(mean, U.shape) * 2 * n_used
                               / unc.dof, rtol=1e-8)


def test_local_noise_leaves_out_the_lines_of_weight_zero():
    """Squared residuals 2 on the fitted lines, every third line not fitted (weight 0, its
    residual set to 0 as residual_variance does): the local estimate is 2 on every line —
    a line left out is no zero residual."""
    s = 90
    used = np.ones((s, 1, 1), dtype=bool)
    used[::3] = False
    e2 = np.where(used, 2.0, 0.0)
    y2 = np.linspace(1.0, 5.0, s)[:, None, None]
    out = _local_floor_and_proportional(e2, y2, used, LOCAL_HALF_WIDTH)
    # a constant fitted exactly (b = 0) by a few weighted sums: round-off
    np.testing.assert_allclose(out, 2.0, rtol=1e-10)


def test_an_exact_zero_under_the_log_magnitude_objective_weighs_nothing_on_correlated_lines():
    """Log-magnitude objective: an entry exactly 0 (no ln of it) is left out like one below
    the dynamic range, also from the pairs of neighbouring lines of correlated noise: the
    same finite intervals as with 1e-30 there."""
    system, omega, H, U, F, var = _frf_data()
    kw = dict(basis=np.eye(4), objective="log-magnitude", weights="uniform",
              noise_variance=var, line_correlation=(0.4,))
    zero, tiny = U.copy(), U.copy()
    zero[10, 1, 0] = 0.0
    tiny[10, 1, 0] = 1e-30  # 1e-12 of the line's largest is the limit
    a = pr.model_uncertainty(system, zero, F, omega, **kw).modes()
    b = pr.model_uncertainty(system, tiny, F, omega, **kw).modes()
    assert np.all(np.isfinite(a.std_frequency_hz)) and np.all(np.isfinite(a.std_damping))
    np.testing.assert_allclose(a.std_frequency_hz, b.std_frequency_hz, rtol=1e-12)
    np.testing.assert_allclose(a.std_damping, b.std_damping, rtol=1e-12)


def test_the_band_in_blocks_of_lines_is_the_band_in_one_block(monkeypatch):
    """Three lines per block (40 lines: 14 blocks, the last of one line) give the band of
    one block of every line: every line computed, each in its place. (The blocks first: a
    line they missed cannot then hold the one block's leftovers.)"""
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var)
    with monkeypatch.context() as patch:
        # r · c = 4 · 2 entries per line
        patch.setattr(pr.uncertainty, "FRF_BLOCK_ELEMENTS", 3 * 4 * 2 * unc.n_parameters)
        parts = unc.frf()
    whole = unc.frf()
    for name in ("values", "std_real", "std_imag", "corr", "lower", "upper"):
        # the same products per line, batched otherwise: round-off
        np.testing.assert_allclose(getattr(parts, name), getattr(whole, name), rtol=1e-12,
                                   err_msg=name)


def test_the_convergence_warning_counts_the_solves_that_missed(monkeypatch):
    """One CG iteration, no restart: a gradient's solve misses the tolerance, a zero
    gradient's (X = 0 solves it) does not — "1 of 2", and only the first variance is NaN."""
    monkeypatch.setattr(covariance, "CG_MAX_ITER", 1)
    monkeypatch.setattr(covariance, "CG_RESTARTS", 0)
    system, omega, H, U, F, var = _frf_data()
    unc = pr.model_uncertainty(system, U, F, omega, basis=np.eye(4), noise_variance=var,
                               solver="matrix-free")
    G = np.zeros((2, unc.n_parameters))
    G[0] = np.random.default_rng(9).standard_normal(unc.n_parameters)
    with pytest.warns(pr.ConvergenceWarning, match=re.escape("1 of 2 matrix-free solves")):
        v = unc._cov.variances(G)
    assert np.isnan(v[0]) and v[1] == 0.0
