"""Latent coordinates: models with more degrees of freedom than measured points
(podid_rs.identification.latent, refine and the order sweep past the POD basis).

Asserted: the observation matrix is [R_p, 0] and malformed bases (unit columns that are
not orthogonal among them, columns orthonormal only to a few digits, an
empty basis, a 3-D array) and orders that are not integers are refused;
an order at or below the observed coordinates has no gauge; a latent start
seen at two sensors takes the residual's dominant direction, and a residual no candidate
mode can be driven to gets none; a common factor of the weights changes no start (only
their costs); the starts are symmetric
bit for bit, and the mass cap of a non-symmetric M is its symmetric part's; the
latent gauge leaves the FRF on the measured DOFs unchanged; from ONE driving-point FRF
of a 4-mass chain the refinement recovers all four modes (noise-free: to 1e-6); the
order sweep goes past the single sensor, recovers every in-band mode of a 6-mode chain
from a noisy driving-point FRF (f within 0.1 %, ζ within 10 %); the last observed order
is run to convergence before latent orders are weighed, a latent order counts only where it
gains ``PROGRESS_STEP``, and a chain measured at every DOF keeps its order; an order the data
cannot determine is refused with the limit named; what is written downstream (mode
shapes, state space, UFF) is the model's response on the measured DOFs.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import podid_rs as pr
from podid_rs.identification.latent import (
    free_parameters,
    gauge_dimension,
    latent_starts,
    observed_count,
)
from podid_rs.identification.order import (
    PROGRESS_STEP,
    OrderFit,
    counted_orders,
    order_limit,
    sweep_orders,
)


def chain_data(n_mass: int, points: list[int], f_hz: np.ndarray, noise: float = 0.0, seed=0):
    """Receptances of a uniform chain (1 kg, 4e5 N/m) at ``points``, force at DOF 0."""
    chain = pr.mass_spring_chain(n_mass, m1=1.0, m2=1.0)
    w = 2 * np.pi * f_hz
    F = np.zeros((w.size, n_mass, 1))
    F[:, 0, 0] = 1.0
    X = chain.response(w, F)[:, points, :]
    if noise:
        rng = np.random.default_rng(seed)
        X = X * (1 + noise * (rng.standard_normal(X.shape) + 1j * rng.standard_normal(X.shape))
                 / np.sqrt(2))
    data = pr.MeasuredData(w, X, np.ones((w.size, 1, 1)), inputs=[points.index(0)])
    return chain, data


def test_observation_matrix_is_the_basis_then_zero_columns():
    Q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((5, 3)))
    R = pr.observation_matrix(Q, 7)
    assert R.shape == (5, 7) and np.array_equal(R[:, :3], Q) and not np.any(R[:, 3:])
    # an observation matrix given back keeps its observed columns
    assert np.array_equal(pr.observation_matrix(R, 9)[:, :7], R)
    assert observed_count(R) == 3
    with pytest.raises(ValueError, match="below the 3 observed coordinates"):
        pr.observation_matrix(Q, 2)
    # given back with its four zero columns, the basis still has 3 observed coordinates
    with pytest.raises(ValueError, match="order m = 2 is below the 3 observed coordinates"):
        pr.observation_matrix(R, 2)
    with pytest.raises(ValueError, match="orthonormal"):
        pr.observation_matrix(2 * Q, 4)
    bad = R.copy()
    bad[:, [2, 4]] = bad[:, [4, 2]]  # a zero column among the observed ones
    with pytest.raises(ValueError, match="zero \\(latent\\) columns last"):
        pr.observation_matrix(bad, 7)


def test_a_column_below_zero_column_is_latent():
    """A latent column that picked up round-off (norm 1e-14, below ZERO_COLUMN = 1e-12) is
    still latent: three observed coordinates, and the observation matrix built from it
    has an exact zero there; one at 1e-11 (above it) is no latent column but a fourth
    column that is not orthonormal to the others, refused."""
    Q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((5, 3)))
    R = pr.observation_matrix(Q, 5)
    R[:, 3] = 1e-14 / np.sqrt(5)
    assert observed_count(R) == 3
    assert not np.any(pr.observation_matrix(R, 6)[:, 3:])
    R[:, 3] = 1e-11 / np.sqrt(5)
    with pytest.raises(ValueError, match="orthonormal columns"):
        observed_count(R)


def test_an_empty_basis_is_refused():
    """No measured DOF, or no column: there is no basis to observe anything through —
    refused, not turned into an observation matrix of zero rows or of latent columns
    only; a 1-D array is no (n, k) basis either, nor a 3-D one (a stack of bases)."""
    for shape in ((0, 2), (3, 0), (3,), (3, 2, 2)):
        with pytest.raises(ValueError, match=rf"non-empty \(n, k\) array, got shape "
                                             rf"{re.escape(str(shape))}"):
            pr.observation_matrix(np.zeros(shape), 2)


def test_unit_columns_that_are_not_orthogonal_are_no_basis():
    """Two unit columns at 45° (RᵀR has 1/√2 off its diagonal): unit norms alone do not
    make POD modes, and the reduced data Rᵀu assume RᵀR = I."""
    c = np.sqrt(0.5)
    skew = np.array([[1.0, c], [0.0, c], [0.0, 0.0]])
    assert np.allclose(np.linalg.norm(skew, axis=0), 1.0)
    with pytest.raises(ValueError, match="orthonormal columns"):
        observed_count(skew)
    with pytest.raises(ValueError, match="orthonormal columns"):
        pr.observation_matrix(skew, 3)


def test_a_basis_orthonormal_only_to_a_few_digits_is_refused():
    """POD modes written out with four decimals (as a text file might hold them) are
    orthonormal only to about 1e-5 — far outside the check's 1e-8, and the reduced data
    Rᵀu would be off by as much: refused. The same modes with round-off (1e-13) pass."""
    Q, _ = np.linalg.qr(np.random.default_rng(0).standard_normal((5, 3)))
    rounded = np.round(Q, 4)
    off = np.abs(rounded.T @ rounded - np.eye(3)).max()
    assert 1e-6 < off < 1e-3  # rounding to 4 decimals: errors of order 5e-5 per entry
    with pytest.raises(ValueError, match="orthonormal columns"):
        observed_count(rounded)
    with pytest.raises(ValueError, match="orthonormal columns"):
        pr.observation_matrix(rounded, 4)
    nearly = Q + 1e-13 * np.random.default_rng(1).standard_normal(Q.shape)
    assert observed_count(nearly) == 3


def test_an_order_that_is_not_an_integer_is_refused_as_such():
    """True is an int to Python (and equals the one observed coordinate here) but no
    order; 2.0 is no integer: each is refused with what is wrong, not as an order below
    the observed coordinates."""
    Q = np.eye(3)[:, :1]
    for m in (True, 2.0):
        with pytest.raises(ValueError, match=rf"order m must be an integer, got {m!r}"):
            pr.observation_matrix(Q, m)
    assert pr.observation_matrix(Q, np.int64(2)).shape == (3, 2)


def test_the_latent_gauge_leaves_the_measured_response_unchanged():
    """Every q = T q' with T = [[I, 0], [T_lp, T_ll]] gives the same R H(ω) Rᵀ: the
    gauge has l·k + l² directions."""
    rng = np.random.default_rng(1)
    m, k = 5, 2
    A = [rng.standard_normal((m, m)) for _ in range(3)]
    M, C, K = (a @ a.T + m * np.eye(m) for a in A)
    R = pr.observation_matrix(np.linalg.qr(rng.standard_normal((4, k)))[0], m)
    T = np.eye(m)
    T[k:, :] += 0.5 * rng.standard_normal((m - k, m))
    M2, C2, K2 = (T.T @ X @ T for X in (M, C, K))
    w = np.linspace(0.5, 5.0, 40)
    H1 = np.einsum("am,smk,bk->sab", R, pr.SecondOrderSystem(M, C, K).frf(w), R)
    H2 = np.einsum("am,smk,bk->sab", R, pr.SecondOrderSystem(M2, C2, K2).frf(w), R)
    assert np.max(np.abs(H1 - H2)) < 1e-12 * np.max(np.abs(H1))
    assert gauge_dimension(m, k) == 3 * 2 + 3 * 3
    assert free_parameters(m, k) == 3 * m * (m + 1) // 2 - 15
    # no latent coordinate, no gauge: also for an order below the observed coordinates
    for m_low in (k, k - 1):
        assert gauge_dimension(m_low, k) == 0
        assert free_parameters(m_low, k) == 3 * m_low * (m_low + 1) // 2


def test_one_frf_determines_every_mode_of_a_four_mass_chain():
    chain, data = chain_data(4, [0], np.linspace(5, 220, 400))
    rng = np.random.default_rng(2)
    T = np.eye(4)
    T[1:, :] += 0.1 * rng.standard_normal((3, 4))  # a start in another gauge, 5 % off
    start = tuple(1.05 * (T.T @ X @ T) for X in (chain.M, chain.C, chain.K))
    fit = pr.refine(start, data.U, data.forces_on_dofs(), data.omega, basis=np.ones((1, 1)),
                    max_iter=300)
    ref = fit.info["refinement"]
    assert ref["coordinates"] == {"observed": 1, "latent": 3, "gauge": 12}
    assert fit.rank == 30 - 12 and np.isnan(fit.residual_norm)
    truth, got = pr.modal_parameters(chain), pr.modal_parameters(fit)
    np.testing.assert_allclose(got.frequencies_hz, truth.frequencies_hz, rtol=1e-6)
    np.testing.assert_allclose(got.damping_ratios, truth.damping_ratios, rtol=1e-5)
    assert ref["db_after"][0] < 1e-6 and pr.is_physical(fit)
    # reduced data of order 1 below the start's order 4 mean the same (R = I_1)
    same = pr.refine(start, data.U[:, :, 0], data.forces_on_dofs()[:, :, 0], data.omega,
                     max_iter=300)
    np.testing.assert_allclose(pr.modal_parameters(same).frequencies_hz,
                               truth.frequencies_hz, rtol=1e-6)


def test_latent_starts_add_the_mode_the_model_lacks():
    """From the 3-mode fit of a 4-mode chain's driving point, the best latent start
    puts its new mode at the missing resonance."""
    chain, data = chain_data(4, [0], np.linspace(5, 220, 400))
    truth = pr.modal_parameters(chain).frequencies_hz
    # the chain without its third mode, as a modal model with the driving point observed
    lam, V = np.linalg.eigh(np.linalg.solve(chain.M, chain.K))
    keep = [0, 1, 3]
    phi = V[:, keep] / np.sqrt(np.diag(V[:, keep].T @ chain.M @ V[:, keep]))
    model3 = (np.eye(3), phi.T @ chain.C @ phi, np.diag(lam[keep]))
    # observed coordinate: the driving point's displacement x_0 = φ_0ᵀ η; change to it
    T = np.eye(3)
    T[0] = phi[0]
    Ti = np.linalg.inv(T)
    model3 = tuple(Ti.T @ X @ Ti for X in model3)
    R = pr.observation_matrix(np.ones((1, 1)), 3)
    w = np.ones((data.s, 1))
    starts = latent_starts(model3, data.U, data.forces_on_dofs(), data.omega, R, w)
    best = min(starts, key=lambda c: c[0])
    added = float(re.search(r"at ([0-9.]+) Hz", best[2]).group(1))
    assert abs(added - truth[2]) < 0.01 * truth[2] and best[1][0].shape == (4, 4)
    # model3's C, computed as T⁻ᵀ C T⁻¹, is symmetric only to round-off; every start is
    # symmetric bit for bit, as the module promises M, C, K, and keeps the model on its
    # coordinates: T⁻ᵀ diag(X, μ) T⁻¹ with T⁻¹ = [[I, −φ], [0, 1]] has X in that block
    # (1e-12: the symmetric part of X, to a few roundings of its entries)
    assert not np.array_equal(model3[1], model3[1].T)
    for _, start, _ in starts:
        for X, S in zip(model3, start, strict=True):
            assert np.array_equal(S, S.T)
            np.testing.assert_allclose(S[:3, :3], 0.5 * (X + X.T), rtol=1e-12,
                                       atol=1e-12 * np.abs(X).max())
    # nothing to add to a model that reproduces the data exactly
    exact = tuple(np.asarray(X) for X in (chain.M, chain.C, chain.K))
    R4 = pr.observation_matrix(np.ones((1, 1)), 4)
    assert latent_starts(exact, data.U, data.forces_on_dofs(), data.omega, R4, w) == []


@pytest.mark.parametrize("f1_hz, mu", [(10.0, 0.25), (1.0, 0.75e8)])
def test_a_latent_mode_on_a_candidate_is_found_exactly(f1_hz, mu):
    """One observed DOF (unit mass, its mode at ``f1_hz``, 2 % damping) driven at itself,
    and data with one more mode of modal mass ``mu`` on a latent coordinate: 1 % damping at
    0.3 % above the 50 Hz line, one of the frequencies and dampings the starts try
    (PEAK_OFFSETS, PEAK_ZETAS). The residual is exactly that mode's response, so the best
    start fits the data to round-off, with the mode's frequency, damping and mass — the
    mass also when it is 0.75e8 times the model's, below the limit of 1e8."""
    from podid_rs.identification.latent import MAX_MASS_RATIO, PEAK_OFFSETS, PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    i = int(np.flatnonzero(np.isclose(omega, 2 * np.pi * 50.0))[0])
    wc, zeta = omega[i] * (1 + PEAK_OFFSETS[2]), PEAK_ZETAS[2]
    assert mu <= MAX_MASS_RATIO
    w1 = 2 * np.pi * f1_hz
    model = (np.eye(1), np.array([[2 * 0.02 * w1]]), np.array([[w1**2]]))
    U = (1 / (w1**2 - omega**2 + 2j * 0.02 * w1 * omega)
         + 1 / (mu * (wc**2 - omega**2 + 2j * zeta * wc * omega)))[:, None, None]
    F = np.ones_like(U)
    R = np.eye(1)
    starts = latent_starts(model, U, F, omega, R, np.ones((omega.size, 1)))
    cost, start, name = min(starts, key=lambda c: c[0])
    base = float(np.sum(np.abs(U - model_response(model, omega)) ** 2))
    assert cost < 1e-12 * base
    assert name == f"latent DOF at {wc / (2 * np.pi):.4g} Hz"
    # the start's response at the observed DOF is the data's
    F2 = np.zeros((omega.size, 2, 1))
    F2[:, 0, 0] = 1.0
    X = pr.SecondOrderSystem(*start).response(omega, F2)[:, :1, :]
    assert np.max(np.abs(X - U)) < 1e-8 * np.max(np.abs(U))
    assert np.max(np.abs(X - U)) < 1e-6 * np.max(np.abs(U - model_response(model, omega)))
    # the starts tried: the peak, and the residual term above the band (the one below
    # would need a negative modal mass: its response has the other sign in the band)
    assert [n for _, _, n in starts] == [name, "latent DOF: residual term above the band"]


def test_a_mode_past_the_mass_cap_gets_no_start_and_a_light_one_does():
    """The cap is on the modal mass μ = 1/a, not on a: data with one more mode of mass
    2 or 10 × MAX_MASS_RATIO times the model's (1 kg) get no start at all (the mode on
    its own candidate needs that mass, and a candidate off its frequency or damping
    explains less of it, so needs more; at 2 × the cap, a cap taken from twice or three
    times the mass matrix would let it through), while a mode 10⁻⁹ times as heavy — a
    large residual, far inside the cap — is started at its line (the candidate of the
    setup above)."""
    from podid_rs.identification.latent import MAX_MASS_RATIO, PEAK_OFFSETS, PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    i = int(np.flatnonzero(np.isclose(omega, 2 * np.pi * 50.0))[0])
    wc, zeta = omega[i] * (1 + PEAK_OFFSETS[2]), PEAK_ZETAS[2]
    w1 = 2 * np.pi * 1.0
    model = (np.eye(1), np.array([[2 * 0.02 * w1]]), np.array([[w1**2]]))

    def starts(mu):
        U = (1 / (w1**2 - omega**2 + 2j * 0.02 * w1 * omega)
             + 1 / (mu * (wc**2 - omega**2 + 2j * zeta * wc * omega)))[:, None, None]
        return latent_starts(model, U, np.ones_like(U), omega, np.eye(1),
                             np.ones((omega.size, 1)))

    assert starts(2 * MAX_MASS_RATIO) == [] and starts(10 * MAX_MASS_RATIO) == []
    names = [name for _, _, name in starts(1e-9)]
    assert f"latent DOF at {wc / (2 * np.pi):.4g} Hz" in names


def test_the_mass_cap_of_a_non_symmetric_mass_matrix_is_that_of_its_symmetric_part():
    """The cap weighs a mode's modal mass against the largest mass xᵀMx a unit
    displacement of the model sees: the largest eigenvalue of M's symmetric part. Two
    observed DOFs (modes at 10 and 15 Hz, each driven in its own load case) with a mass
    matrix that is not symmetric (SecondOrderSystem takes one), I + 3 [[0, 1], [−1, 0]]:
    xᵀMx = xᵀx, so the cap is MAX_MASS_RATIO; its lower triangle read as a symmetric
    matrix, [[1, −3], [−3, 1]] (eigenvalues −2 and 4), would make it 4 × that. Data with
    one more mode on a latent coordinate, on a candidate (seen with shape (0.6, 0.8)):
    at half the cap it gets its start; at 3 × the cap it gets none, as at 2 × and 10 ×
    in the test of the cap above, where a cap of 4 × would let it through."""
    from podid_rs.identification.latent import MAX_MASS_RATIO, PEAK_OFFSETS, PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    i = int(np.flatnonzero(np.isclose(omega, 2 * np.pi * 50.0))[0])
    wc, zeta = omega[i] * (1 + PEAK_OFFSETS[1]), PEAK_ZETAS[1]
    w_obs = 2 * np.pi * np.array([10.0, 15.0])
    model = (np.array([[1.0, 3.0], [-3.0, 1.0]]), np.diag(2 * 0.02 * w_obs), np.diag(w_obs**2))
    # the model's own response, line by line, independently of the package
    H = np.linalg.inv(model[2][None] - omega[:, None, None] ** 2 * model[0][None]
                      + 1j * omega[:, None, None] * model[1][None])
    phi = np.array([0.6, 0.8])
    d = wc**2 - omega**2 + 2j * zeta * wc * omega
    peak = f"latent DOF at {wc / (2 * np.pi):.4g} Hz"

    def names(mu):
        U = H + np.outer(phi, phi)[None] / (mu * d)[:, None, None]
        F = np.broadcast_to(np.eye(2), U.shape).copy()
        return [n for _, _, n in latent_starts(model, U, F, omega, np.eye(2),
                                               np.ones((omega.size, 2)))]

    assert peak in names(0.5 * MAX_MASS_RATIO)
    assert names(3 * MAX_MASS_RATIO) == []


def test_a_latent_mode_seen_at_two_sensors_takes_the_residual_s_direction():
    """Two observed DOFs (uncoupled, modes at 10 and 15 Hz), each driven in its own load
    case, and data with one more mode on a latent coordinate seen with shape φ = (0.6, 0.8)
    at the two sensors: the residual at every line is φ φᵀ / (μ d(ω)), so the dominant
    direction of Re(r rᴴ) is φ and the best start reproduces the data to round-off. The
    other direction, orthogonal to φ, sees none of the residual."""
    from podid_rs.identification.latent import PEAK_OFFSETS, PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    i = int(np.flatnonzero(np.isclose(omega, 2 * np.pi * 50.0))[0])
    wc, zeta, mu = omega[i] * (1 + PEAK_OFFSETS[1]), PEAK_ZETAS[1], 0.5
    w_obs = 2 * np.pi * np.array([10.0, 15.0])
    model = (np.eye(2), np.diag(2 * 0.02 * w_obs), np.diag(w_obs**2))
    phi = np.array([0.6, 0.8])
    d = wc**2 - omega**2 + 2j * zeta * wc * omega
    H = np.zeros((omega.size, 2, 2), dtype=complex)
    H[:, [0, 1], [0, 1]] = 1 / (w_obs**2 - omega[:, None] ** 2
                                + 2j * 0.02 * w_obs * omega[:, None])
    U = H + np.outer(phi, phi)[None] / (mu * d)[:, None, None]
    F = np.broadcast_to(np.eye(2), U.shape).copy()
    starts = latent_starts(model, U, F, omega, np.eye(2), np.ones((omega.size, 2)))
    cost, start, name = min(starts, key=lambda c: c[0])
    base = float(np.sum(np.abs(U - H) ** 2))
    assert cost < 1e-12 * base and name == f"latent DOF at {wc / (2 * np.pi):.4g} Hz"
    F3 = np.zeros((omega.size, 3, 2))
    F3[:, :2] = np.eye(2)
    X = pr.SecondOrderSystem(*start).response(omega, F3)[:, :2, :]
    assert np.max(np.abs(X - U)) < 1e-8 * np.max(np.abs(U))


def test_a_residual_no_candidate_mode_can_be_driven_to_gets_no_start():
    """The two uncoupled observed DOFs again, each driven in its own load case, with data
    that are the model's own response (the package's, so the residual is exactly 0 there)
    but for a mode seen at DOF 0 in the load case that drives DOF 1 only. The residual's
    direction is DOF 0 at every line, so each candidate mode has the shape (1, 0): the
    force of that load case (on DOF 1) does not drive it, and in the load case whose force
    does, there is nothing to fit. Its amplitude is 0 exactly — no modal mass fits, however
    large — so no candidate gets a start, rather than a division by zero."""
    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    w_obs = 2 * np.pi * np.array([10.0, 15.0])
    model = (np.eye(2), np.diag(2 * 0.02 * w_obs), np.diag(w_obs**2))
    F = np.broadcast_to(np.eye(2), (omega.size, 2, 2)).copy()
    U = pr.SecondOrderSystem(*model).response(omega, F)
    wc = 2 * np.pi * 50.0
    U[:, 0, 1] += 1 / (0.5 * (wc**2 - omega**2 + 2j * 0.01 * wc * omega))
    assert latent_starts(model, U, F, omega, np.eye(2), np.ones((omega.size, 2))) == []


@pytest.mark.parametrize("side", ["above", "below"])
def test_a_residual_term_is_a_mode_at_its_factor_beyond_the_bands_edge(side):
    """Data with a mode beyond the band (lines 20–80 Hz; the other mode at 50 Hz, above,
    or at 5 Hz, below) beside the model's (10 Hz or 50 Hz). The start "residual term
    above the band" adds one mode at RESIDUAL_FACTOR × the band's highest line, "below
    the band" one at its lowest line over RESIDUAL_FACTOR, and keeps the model's: the
    start's undamped frequencies are those two to round-off (the latent coordinate is a
    congruence of diag(model, mode))."""
    from podid_rs.identification.latent import RESIDUAL_FACTOR

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    w1, wc, added = ((2 * np.pi * 10.0, 2 * np.pi * 50.0, RESIDUAL_FACTOR * omega[-1])
                     if side == "above" else
                     (2 * np.pi * 50.0, 2 * np.pi * 5.0, omega[0] / RESIDUAL_FACTOR))
    model = (np.eye(1), np.array([[2 * 0.02 * w1]]), np.array([[w1**2]]))
    U = (1 / (w1**2 - omega**2 + 2j * 0.02 * w1 * omega)
         + 1 / (0.25 * (wc**2 - omega**2 + 2j * 0.01 * wc * omega)))[:, None, None]
    starts = latent_starts(model, U, np.ones_like(U), omega, np.eye(1),
                           np.ones((omega.size, 1)))
    M, _, K = next(s for _, s, n in starts if n == f"latent DOF: residual term {side} the band")
    undamped = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    np.testing.assert_allclose(undamped, sorted([w1, added]), rtol=1e-10)


def test_a_peak_fitted_only_by_its_widest_damping_still_gets_a_start():
    """The residual at 50 Hz: a 3 %-damped mode of unit modal mass less a 0.2 %-damped one
    of 0.3. At every candidate frequency the dampings below the widest fit it only with a
    negative modal mass and are skipped; the widest (PEAK_ZETAS[-1], 3 %) fits it with a
    positive one, so the peak still gets its start, at that damping."""
    from podid_rs.identification.latent import PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.25)
    w1, wc = 2 * np.pi * 10.0, 2 * np.pi * 50.0

    def mode(w0, zeta):
        return 1 / (w0**2 - omega**2 + 2j * zeta * w0 * omega)

    model = (np.eye(1), np.array([[2 * 0.02 * w1]]), np.array([[w1**2]]))
    U = (mode(w1, 0.02) + mode(wc, PEAK_ZETAS[-1]) - 0.3 * mode(wc, 0.002))[:, None, None]
    starts = latent_starts(model, U, np.ones_like(U), omega, np.eye(1),
                           np.ones((omega.size, 1)))
    peaks = [s for _, s, n in starts if n.startswith("latent DOF at")]
    assert len(peaks) == 1
    zetas = pr.modal_parameters(pr.SecondOrderSystem(*peaks[0])).damping_ratios
    np.testing.assert_allclose(np.sort(zetas), [0.02, PEAK_ZETAS[-1]], rtol=1e-8)


def test_the_latent_starts_of_a_sweep_leave_out_the_holes(monkeypatch):
    """A 6-DOF chain measured at 2 DOFs under two load cases, one response of the second
    not measured (zeros in U_n, as sweep_orders takes holes): every latent order's
    starts are built on the measured entries, as its fits and scores are."""
    from podid_rs.identification import order

    seen = []
    real = order.latent_starts

    def spy(*args):
        seen.append(args[-1])  # measured, the last argument
        return real(*args)

    monkeypatch.setattr(order, "latent_starts", spy)
    chain = pr.mass_spring_chain(6)
    w = 2 * np.pi * np.linspace(5.0, 200.0, 150)
    F = np.zeros((w.size, 6, 2), dtype=complex)
    F[:, 1, 0] = F[:, 4, 1] = 1.0
    U_n, F_n = chain.response(w, F)[:, [1, 4]], F[:, [1, 4]]
    measured = np.array([[True, False], [True, True]])
    U_n[:, ~measured] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sweep = sweep_orders(U_n, F_n, w, pr.pod_from_frf(U_n, w), m_max=4, threads=1,
                             max_iter=5, measured=measured)
    assert [f.latent for f in sweep.fits] == [0, 0, 1, 2]
    assert len(seen) == 2 and all(np.array_equal(m, measured) for m in seen)


def test_no_start_for_a_model_that_reproduces_the_data_to_round_off():
    """Data 1e-11 off the model (a cost 1e-22 of the data's): nothing is left to add,
    although the model's heavy latent DOF (10⁶ kg) makes a mode of mass 10¹¹ — enough to
    fit such a residual — acceptable (below MAX_MASS_RATIO × 10⁶)."""
    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    w1 = 2 * np.pi * 1.0
    model = (np.diag([1.0, 1e6]), np.diag([2 * 0.02 * w1, 1e3]), np.diag([w1**2, 1e9]))
    R = np.array([[1.0, 0.0]])  # the second coordinate is latent
    U = model_response(model, omega) * (1 + 1e-11)
    assert latent_starts(model, U, np.ones_like(U), omega, R, np.ones((omega.size, 1))) == []

def spiked_data():
    """One observed DOF (its mode at 0.5 rad/s, below the band) and data that differ
    from the model's response x at five lines only, each by a term in phase with a mode
    on that line: by 1 where |x| = 1 at 20, 40, 60 and 80 rad/s (excess |U − x|² / |x|²
    = 1), by 2 where |x| = 2.1 at 100 rad/s (excess 4 / 4.41 = 0.91, the smallest of the
    five; ranked by |U − x|³ it would be the largest, 8 / 4.41). The forces are chosen
    line by line to give x those magnitudes."""
    omega = np.arange(1.0, 121.0)
    w1 = 0.5
    model = (np.eye(1), np.array([[2 * 0.02 * w1]]), np.array([[w1**2]]))
    H = 1 / (w1**2 - omega**2 + 2j * 0.02 * w1 * omega)
    x = np.ones(omega.size, dtype=complex)
    x[99] = 2.1
    F = x / H
    U = x.copy()
    for i, size in zip([19, 39, 59, 79, 99], [1.0, 1.0, 1.0, 1.0, 2.0], strict=True):
        g = F[i] / (2j * 0.01 * omega[i] ** 2)  # a mode on the line, 1 % damping
        U[i] += size * g / abs(g)
    return model, U[:, None, None], F[:, None, None], omega


def test_the_latent_peaks_are_the_largest_excess_of_the_squared_residual():
    """Of five local maxima of the excess, the PEAKS = 4 largest become peak starts:
    the lines at 20, 40, 60 and 80 rad/s, not the one at 100 rad/s."""
    model, U, F, omega = spiked_data()
    starts = latent_starts(model, U, F, omega, np.eye(1), np.ones((omega.size, 1)))
    hz = [float(found.group(1)) for _, _, name in starts
          if (found := re.search(r"at ([0-9.]+) Hz", name))]
    assert sorted(int(np.argmin(np.abs(omega - 2 * np.pi * f))) for f in hz) == [19, 39, 59, 79]


def test_a_latent_start_reports_its_weighted_squared_output_error():
    """Each start's cost is Σ w² |U − x|² of the start's own response x at the observed
    DOF (to round-off: the new mode's response adds to the model's), with weights that
    vary from line to line."""
    model, U, F, omega = spiked_data()
    w = np.linspace(0.5, 2.0, omega.size)[:, None]
    starts = latent_starts(model, U, F, omega, np.eye(1), w)
    assert len(starts) >= 4
    F2 = np.zeros((omega.size, 2, 1), dtype=complex)
    F2[:, 0, 0] = F[:, 0, 0]
    for cost, start, _ in starts:
        X = pr.SecondOrderSystem(*start).response(omega, F2)[:, :1, :]
        expected = float(np.sum(w[:, :, None] ** 2 * np.abs(U - X) ** 2))
        assert cost == pytest.approx(expected, rel=1e-8)


def test_the_latent_starts_do_not_depend_on_the_scale_of_the_weights():
    """Weights 2⁴⁰ times larger (the relative weights 1/‖u‖ of receptances in m/N of a
    stiff structure are of that order) give the same starts, their costs 2⁸⁰ times larger:
    only the weights' ratios matter, in the fit and in the test for a residual at
    round-off alike. A power of two scales every product and sum exactly, so the starts
    are equal bit for bit."""
    model, U, F, omega = spiked_data()
    w = np.ones((omega.size, 1))
    plain = latent_starts(model, U, F, omega, np.eye(1), w)
    heavy = latent_starts(model, U, F, omega, np.eye(1), 2.0**40 * w)
    assert len(plain) >= 4 and len(heavy) == len(plain)
    for (cost, start, name), (cost_h, start_h, name_h) in zip(plain, heavy, strict=True):
        assert name_h == name and cost_h == 2.0**80 * cost
        for X, Y in zip(start, start_h, strict=True):
            assert np.array_equal(X, Y)


def model_response(model, omega):
    """The receptance of the model's first DOF driven at itself (uncoupled DOFs), (s, 1, 1)."""
    M, C, K = (float(X[0, 0]) for X in model)
    return (1 / (K - M * omega**2 + 1j * omega * C))[:, None, None]


def test_the_sweep_goes_past_one_sensor_and_finds_every_mode():
    chain, data = chain_data(12, [0], np.arange(5.0, 150.25, 0.25), noise=0.02)
    truth = pr.modal_parameters(chain)
    band = (truth.frequencies_hz >= 5) & (truth.frequencies_hz <= 150)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model, R, sweep = data.fit()
    assert sweep.chosen > 1 and sweep.fit(sweep.chosen).latent == sweep.chosen - 1
    # the reason names the rule of the latent orders with its step, PROGRESS_STEP = 3 %
    assert ("; a latent order counts only where it lowers the best held-out error of the "
            "smaller orders by 3 %;") in sweep.reason
    assert R.shape == (1, sweep.chosen) and np.count_nonzero(np.abs(R) > 0) == 1
    got = pr.modal_parameters(model)
    assert got.stable and pr.is_physical(model)
    for f, z in zip(truth.frequencies_hz[band], truth.damping_ratios[band], strict=True):
        j = int(np.argmin(np.abs(got.frequencies_hz - f)))
        assert abs(got.frequencies_hz[j] - f) < 1e-3 * f
        assert abs(got.damping_ratios[j] - z) < 0.1 * z
    # the model's FRF is within the noise of the truth: 2 % noise is about 0.17 dB
    X = data.predict(model.system(), R)
    exact = chain.response(data.omega, np.eye(12)[None, :, [0]].repeat(data.s, 0))[:, [0], :]
    err = np.abs(20 * np.log10(np.abs(X) / np.abs(exact)))
    assert np.median(err) < 0.05


def test_latent_orders_do_not_win_where_every_dof_is_measured():
    # a 4-mass chain seen at all four DOFs: the model class holds the truth, so latent
    # coordinates have nothing to add but noise. Weighed against an unconverged m = 4
    # this seed's sweep chose m = 7 (each latent order gained by its extra steps alone)
    _, data = chain_data(4, [0, 1, 2, 3], np.arange(5.0, 150.25, 0.25), noise=0.02)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sweep = sweep_orders(data.U, data.forces_on_dofs(), data.omega, data.pod(), m_max=8)
    assert [f.m for f in sweep.fits][-1] > 4  # latent orders were tried
    observed = sweep.fit(4)
    assert observed.start.endswith("to convergence")
    assert observed.model.info["refinement"]["converged"]
    assert sweep.chosen == 4


def test_the_observed_order_takes_the_modal_start_where_it_ends_lower_and_says_so(
        monkeypatch):
    """A 5-mass chain seen at its two ends, exact data: the observed order (m = 2) is run
    to convergence from the modal start and from the sweep's own fit; the modal start's
    run ends lower and is kept, under its own name. That start is the one the training
    lines' responses and forces give: rebuilt here from the sweep's own fit and basis
    (seen by a spy) on those lines, it is the same bit for bit (the same arithmetic on
    the same arrays)."""
    from podid_rs.identification import order

    _, data = chain_data(5, [0, 4], np.arange(5.0, 150.25, 0.5))
    F_n = data.forces_on_dofs()
    real, built = order.modal_start, []

    def spy(model, R, U_n, F_n, omega, measured=None):
        start = real(model, R, U_n, F_n, omega, measured)
        built.append((model, R, start))
        return start

    monkeypatch.setattr(order, "modal_start", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sweep = sweep_orders(data.U, F_n, data.omega, data.pod(), m_max=4, threads=1)
    observed = sweep.fit(2)
    assert observed.start == "modal start, to convergence"
    assert observed.model.info["refinement"]["converged"]
    train = sweep.lines & ~sweep.test_lines
    [(model, R, start)] = built  # the sweep builds one: the observed order's
    again = real(model, R, data.U[train], F_n[train], data.omega[train])
    for X, Y in zip(start, again, strict=True):
        np.testing.assert_array_equal(X, Y)


def _order(m: int, test_db: float, observed: int) -> OrderFit:
    return OrderFit(m=m, model=None, train_db=test_db, test_db=test_db, start="",
                    stable=True, seconds=0.0, observed=min(m, observed))


def test_a_latent_order_counts_only_where_it_gains_the_progress_step():
    gain = 1 - PROGRESS_STEP
    fits = [_order(1, 1.0, 2), _order(2, 0.99, 2),  # observed: any gain counts
            _order(3, 0.99 * gain * 1.001, 2),      # latent, just short of the step
            _order(4, 0.99 * gain * 0.999, 2),      # latent, just past it
            _order(5, 0.99 * gain * 0.999 * 0.99, 2)]  # latent, 1 % past the last counted
    assert [f.m for f in counted_orders(fits)] == [1, 2, 4]
    # an observed order counts even where it is worse
    assert [f.m for f in counted_orders([_order(1, 1.0, 3), _order(2, 1.5, 3)])] == [1, 2]
    # a latent order that gains exactly the step does not count: it must lower the error
    # by more (1.0 · (1 − step) is the bound itself, exactly)
    assert [f.m for f in counted_orders([_order(1, 1.0, 1), _order(2, gain, 1)])] == [1]
    assert [f.m for f in counted_orders([_order(1, 1.0, 1), _order(2, np.nextafter(gain, 0), 1)])
            ] == [1, 2]


def test_an_order_the_data_cannot_determine_is_refused():
    _, data = chain_data(6, [0], np.linspace(5, 150, 40))
    lines = int(np.sum(np.arange(40) % 4 != 2))
    limit = order_limit(lines, 1, 1, 1)
    assert free_parameters(limit, 1) <= 2 * lines < free_parameters(limit + 1, 1)
    with pytest.raises(ValueError, match=rf"m must be in \[1, {limit}\]: an order-{limit + 1} "
                       rf"model with 1 observed \(POD\) and {limit} latent coordinates has "
                       rf"{free_parameters(limit + 1, 1)} free parameters, more than the "
                       rf"{2 * lines} real equations"):
        sweep_orders(data.U, data.forces_on_dofs(), data.omega, data.pod(), m=limit + 1)


def test_without_m_max_the_sweep_goes_no_further_than_the_order_limit():
    """Six lines of the 6-mass chain at one sensor, every fourth held out: five fitted
    lines, 2·5 = 10 real equations, which determine the 7 free parameters of order 2
    (3·2·3/2 less a gauge of 1·1 + 1²) but not the 12 of order 3 (18 less 2 + 4). With
    neither m nor m_max the sweep stops at that limit, not at the default of 40 — the
    patience (100) is larger than every order, so only the limit ends it."""
    _, data = chain_data(6, [0], np.linspace(5, 150, 6))
    assert int(np.sum(np.arange(6) % 4 != 2)) == 5
    assert free_parameters(2, 1) == 7 <= 10 < free_parameters(3, 1) == 12
    assert order_limit(5, 1, 1, 1) == 2
    sweep = sweep_orders(data.U, data.forces_on_dofs(), data.omega, data.pod(), patience=100,
                         max_iter=5, threads=1)
    assert [f.m for f in sweep.fits] == [1, 2]


def test_downstream_outputs_see_the_model_on_the_measured_dofs(tmp_path):
    """Mode shapes, the state space and the UFF FRFs of a latent model are its
    response on the measured DOFs, R H(ω) Rᵀ."""
    chain, data = chain_data(4, [0, 2], np.linspace(5, 220, 300))
    start = tuple(1.02 * np.asarray(X) for X in (chain.M, chain.C, chain.K))
    P = data.pod()
    Rp = P.basis(2)
    # the chain in coordinates whose first two are the POD coordinates of DOFs 0 and 2
    T = np.eye(4)
    T[:2, :] = 0
    T[np.ix_([0, 1], [0, 2])] = Rp.T
    T[2:, [1, 3]] = np.eye(2)
    Ti = np.linalg.inv(T)
    start = tuple(Ti.T @ X @ Ti for X in start)
    fit = pr.refine(start, data.U, data.forces_on_dofs(), data.omega, basis=Rp, max_iter=300)
    R = pr.observation_matrix(Rp, 4)
    H = data.predict(fit.system(), R)[:, :, 0]
    assert np.median(np.abs(20 * np.log10(np.abs(H) / np.abs(data.U[:, :, 0])))) < 1e-6
    shapes = pr.mode_shapes(fit, R, data.dofs)
    assert shapes.shapes.shape == (2, 4)
    truth = pr.mode_shapes(chain, np.eye(4)[[0, 2]])
    mac = pr.mac(shapes.shapes, truth.shapes)
    assert np.allclose(np.diag(mac), 1.0, atol=1e-6)
    ss = fit.to_state_space(R)
    s = 1j * data.omega[::50]
    G = np.array([ss.C @ np.linalg.solve(x * np.eye(8) - ss.A, ss.B) for x in s])
    F = np.zeros((2, 1))
    F[data.inputs[0]] = 1
    np.testing.assert_allclose((G @ F)[:, :, 0], H[::50], rtol=1e-8)
    path = pr.write_uff(tmp_path / "latent.uff", fit, R, data)
    back = pr.read_uff(path)
    np.testing.assert_allclose(back.U[:, :, 0], H[data.omega > 0], rtol=1e-5)


def test_a_second_latent_mode_shows_at_the_sensor_not_at_the_first_latent_coordinate():
    """A model that has a latent coordinate already (order 2: one observed DOF, 2 % at
    10 Hz, and a decoupled latent one at 500 Hz that nothing sees), and data with one
    more mode at the 50 Hz candidate: the new mode's shape goes on the observed
    coordinate (T = [[I, φ̂], [0, 1]], φ̂ zero on the latent ones), so the start's
    response at the sensor is the data's (1e-8: round-off of the congruence), not the
    old model's as it would be with the mode on the latent coordinate."""
    from podid_rs.identification.latent import PEAK_OFFSETS, PEAK_ZETAS

    omega = 2 * np.pi * np.arange(20.0, 80.25, 0.5)
    i = int(np.flatnonzero(np.isclose(omega, 2 * np.pi * 50.0))[0])
    wc, zeta = omega[i] * (1 + PEAK_OFFSETS[1]), PEAK_ZETAS[1]
    w1, w_latent = 2 * np.pi * 10.0, 2 * np.pi * 500.0
    model = (np.eye(2), np.diag([2 * 0.02 * w1, 2 * 0.01 * w_latent]),
             np.diag([w1**2, w_latent**2]))
    R = np.array([[1.0, 0.0]])  # the second coordinate is latent
    U = model_response(model, omega) + (1 / (wc**2 - omega**2 + 2j * zeta * wc * omega)
                                        )[:, None, None]
    starts = latent_starts(model, U, np.ones_like(U), omega, R, np.ones((omega.size, 1)))
    _, start, name = min(starts, key=lambda c: c[0])
    assert name == f"latent DOF at {wc / (2 * np.pi):.4g} Hz"
    F3 = np.zeros((omega.size, 3, 1))
    F3[:, 0, 0] = 1.0
    X = pr.SecondOrderSystem(*start).response(omega, F3)[:, :1, :]
    assert np.max(np.abs(X - U)) < 1e-8 * np.max(np.abs(U))
