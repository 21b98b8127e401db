"""The modal start (podid_rs.identification.modal_start): a model rebuilt from its
poles in the band, with its shapes fitted linearly.

Asserted: on exact FRFs of a proportionally damped 4-DOF system whose modes all lie
in the band, the start rebuilt from the system's own poles reproduces the FRFs to
round-off — observed at every DOF, with a hole in the grid, and from one driving
point through latent coordinates; with only two modes in the band it keeps those two
poles exactly, stands in for the others with one pole below and one above the band
(none below a band from 0 rad/s, where a rigid-body pole at 0 is not kept either), and
stays physical, also from a model with an unstable pole, which it leaves out; a pole
exactly on the band's edge is in the band, and an undamped one (ζ = 0) is kept; forces that
are not unit forces at one DOF (no FRFs, a force with a phase or a second DOF pulled the
other way among them) give no start, nor does a change of coordinates near singular (a
mode seen only through FILL_SEEN cancelling a weak direction), and forces of another shape
than the responses are refused;
and the final fit starts from it when it fits better than the held-out fit —
never reading a hole, and judging the first pass against the held-out fit — and says
nothing of it otherwise; it keeps the held-out fit when the refit raises the median
error over every line, and quotes the medians it decided on.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
import scipy.linalg

import podid_rs as pr
from podid_rs.identification.latent import observation_matrix
from podid_rs.identification.modal_start import FILL_FACTOR, modal_start
from podid_rs.identification.order import _relative_cost

M4 = np.diag([1.0, 2.0, 1.5, 1.0])
K4 = 1e4 * np.array([[2, -1, 0, 0], [-1, 2, -1, 0], [0, -1, 2, -1], [0, 0, -1, 1.0]])
C4 = 0.2 * M4 + 2e-5 * K4  # proportional: real normal modes


def natural(M, C, K):
    """Natural frequencies (rad/s) and damping ratios of the underdamped poles, sorted."""
    m = M.shape[0]
    state = np.block([[np.zeros((m, m)), np.eye(m)],
                      [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(state)
    lam = lam[lam.imag > 0]
    order = np.argsort(np.abs(lam))
    return np.abs(lam)[order], (-lam.real / np.abs(lam))[order]


def frf_data(omega, observed, inputs):
    """Exact receptances (s, len(observed), len(inputs)) and unit forces on those DOFs."""
    H = pr.SecondOrderSystem(M4, C4, K4).frf(omega)
    U = H[:, observed][:, :, inputs]
    F = np.zeros_like(U)
    for j, dof in enumerate(inputs):
        F[:, observed.index(dof), j] = 1.0
    return U, F


def assert_physical(start):
    M, C, K = start
    for X in start:
        np.testing.assert_array_equal(X, X.T)
    assert np.linalg.eigvalsh(M).min() > 0 and np.linalg.eigvalsh(K).min() > 0
    assert np.linalg.eigvalsh(C).min() > -1e-12 * np.linalg.norm(C, 2)


@pytest.fixture
def omega_all():
    wn, _ = natural(M4, C4, K4)
    return np.linspace(0.5 * wn[0], 1.3 * wn[-1], 600)


def test_every_mode_in_band_observed_everywhere_is_reproduced(omega_all):
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    R = np.linalg.qr(np.random.default_rng(1).standard_normal((4, 4)))[0]
    # the true system written in R's coordinates: x = R q
    model = pr.SecondOrderSystem(R.T @ M4 @ R, R.T @ C4 @ R, R.T @ K4 @ R)
    start = modal_start(model, R, U, F, omega_all)
    assert_physical(start)
    assert _relative_cost(start, R, U, F, omega_all) < 1e-18
    np.testing.assert_allclose(natural(*start)[0], natural(M4, C4, K4)[0], rtol=1e-12)


def test_an_unsymmetric_model_s_poles_are_read_from_m_inverse_k_and_m_inverse_c(omega_all):
    """A user's unsymmetric model M = S, C = S diag(2ζω), K = S diag(ω²) (S upper
    triangular, its symmetric part positive definite): M⁻¹K = diag(ω²) and M⁻¹C =
    diag(2ζω), so its poles are the 4-DOF system's, and the start keeps them; M read
    transposed (S⁻ᵀ S diag(ω²)), or C or K (S⁻¹ diag · Sᵀ), would move them."""
    wn, zeta = natural(M4, C4, K4)
    S = np.eye(4) + np.diag([0.5, -0.4, 0.3], k=1) + np.diag([0.2, 0.1], k=2)
    model = pr.SecondOrderSystem(S, S @ np.diag(2 * zeta * wn), S @ np.diag(wn**2))
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    w_start, z_start = natural(*modal_start(model, np.eye(4), U, F, omega_all))
    # 1e-12, 1e-9: the rebuilt matrices' round-off, as for the in-band poles below
    # (M⁻¹K and M⁻¹C of the triangular S are the diagonals to round-off too)
    np.testing.assert_allclose(w_start, wn, rtol=1e-12)
    np.testing.assert_allclose(z_start, zeta, rtol=1e-9)


def test_a_hole_in_the_grid_weighs_nothing(omega_all):
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    measured = np.ones((4, 2), dtype=bool)
    measured[1, 1] = False
    U[:, 1, 1] = 1e3  # garbage where nothing was measured
    R = np.eye(4)
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega_all, measured)
    assert _relative_cost(start, R, U, F, omega_all, measured) < 1e-18


def test_one_driving_point_through_latent_coordinates(omega_all):
    U, F = frf_data(omega_all, [0], [0])
    R = observation_matrix(np.ones((1, 1)), 4)  # one observed coordinate, three latent
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega_all)
    assert_physical(start)
    assert _relative_cost(start, R, U, F, omega_all) < 1e-18


def test_modes_outside_the_band_become_residual_poles():
    wn, zeta = natural(M4, C4, K4)
    omega = np.linspace(0.5 * (wn[0] + wn[1]), 0.5 * (wn[2] + wn[3]), 400)  # modes 2, 3
    U, F = frf_data(omega, [0, 1, 2, 3], [0])
    R = np.eye(4)
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega)
    assert_physical(start)
    w_start, z_start = natural(*start)
    # the two in-band poles exactly; one pole below the band and one above it
    np.testing.assert_allclose(w_start[1:3], wn[1:3], rtol=1e-12)
    np.testing.assert_allclose(z_start[1:3], zeta[1:3], rtol=1e-9)
    assert w_start[0] < omega[0] and w_start[3] > omega[-1]
    # it explains the band far better than the in-band modes alone would: a few %
    assert _relative_cost(start, R, U, F, omega) < 0.05 * omega.size


def test_poles_on_the_band_s_edges_are_in_the_band():
    """The band [ω_lo, ω_hi] is closed: lines from exactly mode 2's natural frequency to
    exactly mode 3's (the same eigenvalues as the start reads them, so equal to the
    last bit) keep both poles exactly, and the residual poles go below and above them."""
    wn, zeta = natural(M4, C4, K4)
    omega = np.linspace(wn[1], wn[2], 400)
    assert omega[0] == wn[1] and omega[-1] == wn[2]  # the edges are the poles, bit for bit
    U, F = frf_data(omega, [0, 1, 2, 3], [0])
    w_start, z_start = natural(*modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4),
                                            U, F, omega))
    # 1e-12, 1e-9: the rebuilt matrices' round-off, as for the in-band poles above
    np.testing.assert_allclose(w_start[1:3], wn[1:3], rtol=1e-12)
    np.testing.assert_allclose(z_start[1:3], zeta[1:3], rtol=1e-9)
    assert w_start[0] < omega[0] and w_start[3] > omega[-1]


def test_the_residual_poles_sit_at_the_band_s_edges_not_at_the_model_s_poles_outside():
    """The band of modes 2 and 3 again: the model's own poles outside it (modes 1 and 4)
    are not kept — the start's poles are exactly the modal ones it is written from, the
    two in-band poles and the residual poles at ω_lo / RESIDUAL_FACTOR and
    ω_hi · RESIDUAL_FACTOR with RESIDUAL_ZETA."""
    from podid_rs.identification.modal_start import RESIDUAL_FACTOR, RESIDUAL_ZETA

    wn, zeta = natural(M4, C4, K4)
    omega = np.linspace(0.5 * (wn[0] + wn[1]), 0.5 * (wn[2] + wn[3]), 400)
    U, F = frf_data(omega, [0, 1, 2, 3], [0])
    w_start, z_start = natural(*modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4),
                                            U, F, omega))
    residual = [omega[0] / RESIDUAL_FACTOR, omega[-1] * RESIDUAL_FACTOR]
    assert abs(wn[3] - residual[1]) > 0.1 * wn[3]  # mode 4 is not where the pole goes
    np.testing.assert_allclose(w_start[[0, 3]], residual, rtol=1e-9)
    np.testing.assert_allclose(z_start[[0, 3]], RESIDUAL_ZETA, rtol=1e-9)


def test_a_band_below_one_radian_per_second_keeps_its_residual_pole_below():
    """The same structure 1000 times slower (C / 10³, K / 10⁶: the same damping ratios),
    its band of modes 2 and 3 below 1 rad/s: still the two in-band poles exactly, one
    pole below the band and one above it."""
    Cs, Ks = 1e-3 * C4, 1e-6 * K4
    wn, zeta = natural(M4, Cs, Ks)
    omega = np.linspace(0.5 * (wn[0] + wn[1]), 0.5 * (wn[2] + wn[3]), 400)
    assert omega[-1] < 1.0
    U = pr.SecondOrderSystem(M4, Cs, Ks).frf(omega)[:, :, [0]]
    F = np.zeros_like(U)
    F[:, 0, 0] = 1.0
    start = modal_start(pr.SecondOrderSystem(M4, Cs, Ks), np.eye(4), U, F, omega)
    assert_physical(start)
    w_start, z_start = natural(*start)
    np.testing.assert_allclose(w_start[1:3], wn[1:3], rtol=1e-12)
    np.testing.assert_allclose(z_start[1:3], zeta[1:3], rtol=1e-9)
    assert w_start[0] < omega[0] and w_start[3] > omega[-1]


def test_an_unstable_pole_of_the_model_is_left_out_and_the_start_stays_physical(omega_all):
    """The 4-DOF system with its third mode's damping ratio negated (ζ₃ = −0.0021: an
    unstable pole, as an estimate without the physical constraints can have): the start
    keeps the three stable in-band poles exactly and not the unstable one — kept, its
    negative 2ζω would make C indefinite — and fills the fourth coordinate with a pole
    above the band; C ⪰ 0 as always."""
    lam, phi = scipy.linalg.eigh(K4, M4)  # mass-normalised modes, φᵀ C4 φ diagonal
    w = np.sqrt(lam)
    zeta = np.diag(phi.T @ C4 @ phi) / (2 * w)
    zeta[2] = -zeta[2]
    C_unstable = M4 @ phi @ np.diag(2 * zeta * w) @ phi.T @ M4  # Φᵀ C Φ = diag(2ζω)
    assert np.sum(natural(M4, C_unstable, K4)[1] < 0) == 1
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    start = modal_start(pr.SecondOrderSystem(M4, C_unstable, K4), np.eye(4), U, F, omega_all)
    assert_physical(start)
    w_start, z_start = natural(*start)
    # the kept poles are the model's own, rebuilt through A: round-off, as above
    np.testing.assert_allclose(w_start[:3], w[[0, 1, 3]], rtol=1e-12)
    np.testing.assert_allclose(z_start[:3], zeta[[0, 1, 3]], rtol=1e-9)
    assert w_start[3] > omega_all[-1] and np.all(z_start > 0)


def band_from_zero():
    """Lines from 0 rad/s up to between modes 2 and 3 of the 4-DOF system, driven at DOF 0:
    (omega, U, F), U its receptances (the static one, K⁻¹, at the first line)."""
    wn, _ = natural(M4, C4, K4)
    omega = np.linspace(0.0, 0.5 * (wn[1] + wn[2]), 400)
    U = np.empty((omega.size, 4, 1), dtype=complex)
    U[1:] = pr.SecondOrderSystem(M4, C4, K4).frf(omega[1:])[:, :, [0]]  # frf refuses 0
    U[0] = np.linalg.inv(K4)[:, [0]]
    F = np.zeros_like(U)
    F[:, 0, 0] = 1.0
    return omega, U, F


def test_a_band_from_zero_has_no_residual_pole_below_it():
    """Lines from 0 rad/s (the static receptance K⁻¹ at the first) up to between modes 2
    and 3: no pole fits below the band — one at 0 rad/s would divide the first line by
    zero — so the two in-band poles are kept exactly, the residual pole above sits at
    ω_hi · RESIDUAL_FACTOR (ζ = RESIDUAL_ZETA) and the last coordinate is completed at
    FILL_FACTOR · ω_hi."""
    from podid_rs.identification.modal_start import RESIDUAL_FACTOR, RESIDUAL_ZETA

    wn, zeta = natural(M4, C4, K4)
    omega, U, F = band_from_zero()
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega)
    assert_physical(start)
    w_start, z_start = natural(*start)
    np.testing.assert_allclose(w_start[:2], wn[:2], rtol=1e-12)
    above = np.array([RESIDUAL_FACTOR, FILL_FACTOR]) * omega[-1]
    np.testing.assert_allclose(w_start[2:], above, rtol=1e-9)
    np.testing.assert_allclose(z_start[2:], RESIDUAL_ZETA, rtol=1e-9)


def test_a_rigid_body_pole_at_zero_is_not_kept_in_a_band_from_zero():
    """The 4-DOF chain and a fifth, free coordinate of its own (no stiffness: a rigid-body
    mode, poles 0 and −0.2 — both real), not measured, on the band from 0 rad/s of the
    test above: the pole at 0 lies on the band's lower edge but is not an underdamped
    pole (λ = 0 is real) and is left out, so the start is the one above with the fifth
    coordinate completed: the two in-band poles, the residual pole at
    ω_hi · RESIDUAL_FACTOR and completing modes at FILL_FACTOR · ω_hi times 1 and 2.
    Kept, the pole at 0 would divide the first line by zero."""
    from podid_rs.identification.modal_start import RESIDUAL_FACTOR

    M5, C5, K5 = np.zeros((5, 5)), np.zeros((5, 5)), np.zeros((5, 5))
    M5[:4, :4], C5[:4, :4], K5[:4, :4] = M4, C4, K4
    M5[4, 4], C5[4, 4] = 1.0, 0.2
    state = np.block([[np.zeros((5, 5)), np.eye(5)],
                      [-np.linalg.solve(M5, K5), -np.linalg.solve(M5, C5)]])
    assert 0.0 in np.linalg.eigvals(state)  # the rigid-body pole, exactly, as the start reads it
    wn, _ = natural(M4, C4, K4)
    omega, U, F = band_from_zero()
    start = modal_start(pr.SecondOrderSystem(M5, C5, K5), np.eye(5)[:4], U, F, omega)
    assert start is not None
    assert_physical(start)
    w_start, _ = natural(*start)
    # 1e-12, 1e-9: the rebuilt matrices' round-off, as in the tests above
    np.testing.assert_allclose(w_start[:2], wn[:2], rtol=1e-12)
    above = np.array([RESIDUAL_FACTOR, FILL_FACTOR, 2 * FILL_FACTOR]) * omega[-1]
    np.testing.assert_allclose(w_start[2:], above, rtol=1e-9)


def test_an_undamped_pole_in_the_band_is_kept():
    """ζ = 0 is underdamped: an undamped oscillator (m = 2, k = 8e4: ω_n = 200 rad/s,
    C = 0; its poles ±200i, with a real part of exactly 0 as the start reads them) on
    a band round its pole is rebuilt exactly — the residue of 1/(k − ω²m) at the pole
    is 1/m, so φ = 1/√m and M = 1/φ² = m, K = ω_n² M = k, C = 2ζω_n M = 0. Left out,
    a residual pole would stand in for it."""
    M, C, K = np.array([[2.0]]), np.zeros((1, 1)), np.array([[8e4]])
    state = np.array([[0.0, 1.0], [-4e4, 0.0]])
    assert np.all(np.linalg.eigvals(state).real == 0)
    omega = np.linspace(100.0, 300.0, 400)  # 200 falls between two lines
    U = (1.0 / (8e4 - 2.0 * omega**2))[:, None, None].astype(complex)
    F = np.ones_like(U)
    M_s, C_s, K_s = modal_start(pr.SecondOrderSystem(M, C, K), np.eye(1), U, F, omega)
    # 1e-12: the residue's least squares and A's inverse, round-off only
    np.testing.assert_allclose(M_s, M, rtol=1e-12)
    np.testing.assert_allclose(K_s, K, rtol=1e-12)
    np.testing.assert_array_equal(C_s, 0.0)  # 2ζω with ζ = 0 is 0 exactly


def test_the_completing_modes_lie_at_multiples_of_fill_factor_times_the_top_line(omega_all):
    """A driving point of the 4-DOF chain on an order-8 basis (one observed coordinate,
    seven latent): the four in-band modes are kept exactly, the residual poles take no
    shape from these exact data, and the four coordinates left are completed at
    FILL_FACTOR · ω_hi times 1, 2, 3, 4 (ζ = RESIDUAL_ZETA: |λ| is their natural
    frequency)."""
    U, F = frf_data(omega_all, [0], [0])
    R = observation_matrix(np.ones((1, 1)), 8)
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega_all)
    w_start, _ = natural(*start)
    np.testing.assert_allclose(w_start[:4], natural(M4, C4, K4)[0], rtol=1e-9)
    fill = w_start[w_start > 2 * omega_all[-1]]
    np.testing.assert_allclose(fill / (FILL_FACTOR * omega_all[-1]), [1, 2, 3, 4], rtol=1e-9)


def test_data_that_give_no_mode_a_shape_get_completing_modes_alone(omega_all):
    """−H: every residue has the wrong sign at the driving point (φ[inputs]² < 0), so no
    mode gets a shape; the start is still made, of completing modes only, at
    FILL_FACTOR · ω_hi times 1 … m."""
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), -U, F, omega_all)
    assert start is not None
    w_start, _ = natural(*start)
    np.testing.assert_allclose(w_start, FILL_FACTOR * omega_all[-1] * np.arange(1, 5),
                               rtol=1e-9)


def test_a_completing_mode_is_seen_slightly_at_a_measured_dof(omega_all):
    """The completing modes of a driving point on an order-8 basis would not show at the
    one measured DOF; each is seen there, at FILL_SEEN times the shapes' scale, so every
    mode of the start has a shape on the measured DOFs."""
    U, F = frf_data(omega_all, [0], [0])
    R = observation_matrix(np.ones((1, 1)), 8)
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega_all)
    shapes = pr.mode_shapes(pr.SecondOrderSystem(*start), R)
    assert shapes.n_modes == 8


def test_the_rank_one_shape_with_holes_does_not_depend_on_the_units():
    """φ φ[inputs]ᵀ ≈ residue on the known entries, by alternating least squares round a
    hole: scaling the residue by c scales φ by √c, so residues of FRFs in m/N (1e-8)
    converge as far as those of mm/N do."""
    from podid_rs.identification.modal_start import _shape

    rng = np.random.default_rng(2)
    phi = rng.uniform(0.5, 1.5, 6)
    inputs = np.array([0, 2, 4])
    residue = np.outer(phi, phi[inputs]) + 0.1 * rng.standard_normal((6, 3))
    known = np.ones((6, 3), dtype=bool)
    known[1, 0] = known[5, 2] = False
    shape = _shape(residue, inputs, known)
    assert np.all(shape != 0)
    for c in (1e-8, 1e4):
        np.testing.assert_allclose(_shape(c * residue, inputs, known), np.sqrt(c) * shape,
                                   rtol=1e-9)


def test_the_rank_one_shape_with_holes_reads_nothing_at_a_hole():
    """φ φ[inputs]ᵀ is fitted on the known entries only, its start too: residues exactly
    of rank one there give back φ (up to its sign, which residues do not fix) whatever a
    hole holds — garbage 50 at one, where the residues are of order 1."""
    from podid_rs.identification.modal_start import _shape

    phi = np.array([1.0, 0.7, -0.4, 1.3, 0.9])
    inputs = np.array([0, 3])
    residue = np.outer(phi, phi[inputs])
    known = np.ones((5, 2), dtype=bool)
    known[2, 1] = False
    residue[2, 1] = 50.0
    shape = _shape(residue, inputs, known)
    # exact rank-one data on the known entries: the sweeps' fixed point is φ to round-off
    # (they stop at a relative change of 1e-15); 1e-9 leaves room for their last step
    np.testing.assert_allclose(np.sign(shape[0]) * shape, phi, rtol=1e-9, atol=1e-12)


def test_the_start_does_not_depend_on_the_units_of_the_data(omega_all):
    """Receptances c times larger are those of a structure with matrices c times smaller
    (H = (−ω²M + iωC + K)⁻¹): the start from c·U is the start from U divided by c — in
    m/N (1e-8 of mm/N: shapes of order 1e-4) as in mm/N. Every step (residues, rank-one
    shapes, the rank of A) is linear or relative to the scale, so only round-off
    differs: rtol 1e-9 is far above it (1e-15 here). (Observed at every DOF: with latent coordinates
    the completion's basis of the empty directions is the SVD's, any rotation of it as
    good, and a residual pole's near-zero residue takes its sign from round-off.)"""
    model = pr.SecondOrderSystem(M4, C4, K4)
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    start = modal_start(model, np.eye(4), U, F, omega_all)
    for c in (1e-8, 1e4):
        scaled = modal_start(model, np.eye(4), c * U, F, omega_all)
        for X, Y in zip(scaled, start, strict=True):
            np.testing.assert_allclose(c * X, Y, rtol=1e-9, atol=1e-9 * np.abs(Y).max())


def test_no_start_without_unit_forces(omega_all):
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    F[:, 1, 0] = 0.5  # a force spread over two DOFs: not FRF data
    assert modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega_all) is None
    F[:, 1, 0] = -0.5  # nor when the second DOF is pulled the other way
    assert modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega_all) is None
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    F[::2, 0, 0] = 2.0  # not a unit force on every line
    assert modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega_all) is None
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    F[:, :, 1] = 0.0  # a load case without a force: no FRF either
    assert modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega_all) is None
    # a force of modulus one with a phase (complex forces, as the "spectra" estimator
    # gives; i: a quarter period, of modulus exactly 1): the responses are H f, not H,
    # so residues fitted to them as an FRF's would be H's turned by 90°
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    F[:, 0, 0] = 1j
    assert modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U * F[:, :1],
                       F, omega_all) is None


def test_forces_of_another_shape_than_the_responses_are_refused(omega_all):
    """F_n is read against U_n's lines, DOFs and load cases: forces with fewer or more
    of any are refused with both shapes, by modal_start and so by the final fit, which
    builds the modal start before any refinement checks its data."""
    from podid_rs.identification.order import final_fit
    from podid_rs.measured import from_frf

    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    system = pr.SecondOrderSystem(M4, C4, K4)
    for G in (F[:300], F[:, :3], F[:, :, :1], np.concatenate([F, F[:, :, :1]], axis=2),
              np.concatenate([F, F[:, :1]], axis=1)):
        with pytest.raises(ValueError, match=rf"^F_n must have the shape of U_n \(600, 4, 2\), "
                                             rf"got {re.escape(str(G.shape))}$"):
            modal_start(system, np.eye(4), U, G, omega_all)
    data = from_frf(U, omega_all, inputs=[0, 2])
    U, F, P = data.U, data.forces_on_dofs(), data.pod()
    sweep, _, _ = sweep_holding(U, F, omega_all, P, the_truth)
    with pytest.raises(ValueError, match=r"^F_n must have the shape of U_n \(600, 4, 2\), "
                                         r"got \(600, 4, 1\)$"):
        final_fit(sweep, U, F[:, :, :1], omega_all, P, log_magnitude=False)


def test_a_model_whose_matrices_are_not_square_of_one_shape_is_refused(omega_all):
    """An identified model built by hand is not checked on construction: a stack of one
    matrix (which numpy's stacked solve would read as that matrix), a vector, non-square
    matrices and matrices of different shapes (C's or K's, or both C's and K's against
    M's; a scalar or a vector among them) are refused with every shape as it is."""
    from dataclasses import replace

    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    identified = pr.identify(U, F, omega_all, symmetric=True)
    for M, C, K in ((M4[None], C4[None], K4[None]), (M4[0], C4, K4),
                    (M4[:, :3], C4[:, :3], K4[:, :3]), (M4, C4[:, :3], K4[:3]),
                    (M4, C4, K4[:3, :3]), (M4, C4[:3, :3], K4), (M4, C4[:3, :3], K4[:3, :3]),
                    (M4, C4[0, 0], K4[0]), (M4, C4[0], K4[0, 0])):
        model = replace(identified, M=M, C=C, K=K)
        with pytest.raises(ValueError, match=re.escape(
                f"the model's M, C and K must be square matrices of one shape, got "
                f"{M.shape}, {C.shape} and {K.shape}")):
            modal_start(model, np.eye(4), U, F, omega_all)


def test_one_line_is_no_band_and_gives_no_start(omega_all):
    """A band needs two lines: on one, the poles in it and the residues fitted there
    mean nothing, so no start is made; on the first two lines of the same data, one is."""
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0])
    system = pr.SecondOrderSystem(M4, C4, K4)
    assert modal_start(system, np.eye(4), U[:1], F[:1], omega_all[:1]) is None
    assert modal_start(system, np.eye(4), U[:2], F[:2], omega_all[:2]) is not None


def test_no_start_where_the_change_of_coordinates_is_nearly_singular():
    """Three modes at 10, 20, 30 rad/s driven at DOF 2 of three measured DOFs, seen
    through two observed coordinates (DOFs 0 and 1) and a latent one. The first shows
    at the observed coordinates along (1, 1)/√2 with norm 1, the second along
    (−1, 1)/√2 with norm 2·10⁻³ (just above the rank threshold, 10⁻³ of the largest),
    the third along (−1, 1)/√2 with norm t ≤ 5·10⁻⁴ — below 10⁻³ of the shapes'
    scale, so it is seen at DOF 0 with FILL_SEEN times that scale, and at one t that
    cancels the weak direction: the change of coordinates A passes through singular,
    where M = A⁻ᵀA⁻¹ has no bound. A golden-section search for the largest
    ‖M‖₂ = ‖A⁻¹‖² closes in on that t and must meet no start there (cond A >
    MAX_CONDITION = 10¹²) rather than a model no arithmetic can hold; every start it
    meets keeps ‖A⁻¹‖ ≤ 10¹³ (‖A‖ ≥ 1 by the first mode's column; 10× for the
    round-off of a condition number near 10¹²)."""
    wk, zeta = np.array([10.0, 20.0, 30.0]), 0.01
    omega = np.linspace(5.0, 40.0, 50)
    model = pr.SecondOrderSystem(np.eye(3), np.diag(2 * zeta * wk), np.diag(wk**2))
    R = observation_matrix(np.eye(3)[:, :2], 3)
    h = np.sqrt(0.5)
    den = wk**2 - omega[:, None] ** 2 + 2j * zeta * wk * omega[:, None]  # (s, modes)
    F = np.zeros((omega.size, 3, 1), dtype=complex)
    F[:, 2, 0] = 1.0

    def largest_mass(t: float) -> float:
        phi = np.array([[h, -2e-3 * h, -t * h], [h, 2e-3 * h, t * h], [1.0, 1.0, 1.0]])
        U = np.einsum("nk,sk->sn", phi * phi[2], 1 / den)[:, :, None]  # Σ φ φ[2] / d
        start = modal_start(model, R, U, F, omega)
        return np.inf if start is None else float(np.linalg.norm(start[0], 2))

    # ‖M‖ on a coarse grid peaks near t = 1.1·10⁻⁴ (finite at both ends of the bracket)
    a, b = 7.5e-5, 1.5e-4
    assert np.isfinite(largest_mass(a)) and np.isfinite(largest_mass(b))
    g = (np.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = largest_mass(c), largest_mass(d)
    met = [fc, fd]
    while b - a > 1e-18:
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = largest_mass(c)
            met.append(fc)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = largest_mass(d)
            met.append(fd)
    assert np.isinf(met).any()
    assert max(x for x in met if np.isfinite(x)) <= 1e26


def test_the_inputs_are_not_modified(omega_all):
    U, F = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    system = pr.SecondOrderSystem(M4, C4, K4)
    copies = [U.copy(), F.copy(), omega_all.copy()]
    modal_start(system, np.eye(4), U, F, omega_all)
    for before, after in zip(copies, [U, F, omega_all], strict=True):
        np.testing.assert_array_equal(before, after)


def sweep_holding(U, F, omega, P, matrices, measured=None):
    """The order sweep to m = 4 with its order-4 fit replaced by ``matrices(R)`` — M, C, K
    in the coordinates of the sweep's basis R. Returns the sweep, R and that fit."""
    from dataclasses import replace

    from podid_rs.identification.order import sweep_orders

    sweep = sweep_orders(U, F, omega, P, m=4, measured=measured)
    R = sweep.basis(4, P)
    held = replace(sweep.fit(4).model, **dict(zip("MCK", matrices(R), strict=True)))
    fits = tuple(replace(f, model=held) if f.m == 4 else f for f in sweep.fits)
    return replace(sweep, fits=fits), R, held


def the_truth(R):
    """The true M, C, K in the coordinates of R (x = R q)."""
    return [R.T @ X @ R for X in (M4, C4, K4)]


def wrong_shapes(R):
    """The true matrices under a congruence q = T q': the same poles, other mode shapes
    on the measured DOFs."""
    T = np.eye(4) + 0.3 * np.random.default_rng(2).standard_normal((4, 4))
    return [T.T @ X @ T for X in the_truth(R)]


def one_bad_line_in_eight():
    """Exact FRFs (two forces) over every mode, one line in eight off by a factor 5 (a
    bad line the relative cost can trade the others for): U, F, their POD and omega."""
    from podid_rs.measured import from_frf

    wn, _ = natural(M4, C4, K4)
    omega = np.linspace(0.5 * wn[0], 1.3 * wn[-1], 400)
    U, _ = frf_data(omega, [0, 1, 2, 3], [0, 2])
    U[::8] *= 5.0
    data = from_frf(U, omega, inputs=[0, 2])
    return data.U, data.forces_on_dofs(), data.pod(), omega


def test_final_fit_starts_from_it_when_it_fits_better(omega_all):
    """A held-out fit with the right poles and wrong shapes (the true matrices under a
    congruence: the same poles, other mode shapes on the measured DOFs): the modal
    start rebuilds the shapes, and the final fit starts from it and ends at the truth."""

    from podid_rs.identification.order import final_fit
    from podid_rs.measured import from_frf

    U, _ = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    data = from_frf(U, omega_all, inputs=[0, 2])
    U, F, P = data.U, data.forces_on_dofs(), data.pod()
    sweep, _, held = sweep_holding(U, F, omega_all, P, wrong_shapes)
    model, R = final_fit(sweep, U, F, omega_all, P, log_magnitude=False)
    assert "modal start" in model.info["refinement"]["final_refit"]["reason"]
    assert _relative_cost(model, R, U, F, omega_all) < 1e-12
    # the reason quotes the modal start's weighted cost, then the held-out fit's: the
    # held-out fit's by hand, Σ ‖R x − u‖² / ‖u‖² over lines and load cases (to the 4
    # digits quoted); the modal start's at round-off (it reproduces the exact FRFs)
    X = np.einsum("nm,smp->snp", R,
                  held.system().response(omega_all, np.einsum("nm,snp->smp", R, F)))
    by_hand = float(np.sum(np.sum(np.abs(X - U) ** 2, axis=1) / np.sum(np.abs(U) ** 2, axis=1)))
    quoted = re.search(r"weighted cost (\S+) against (\S+)\)",
                       model.info["refinement"]["final_refit"]["reason"])
    assert float(quoted[2]) == pytest.approx(by_hand, rel=1e-3)
    assert float(quoted[1]) < 1e-12 * by_hand


def test_the_final_fit_with_a_hole_never_reads_it_and_judges_the_modal_start_fairly(omega_all):
    """The same bad held-out fit, with a hole in the grid (DOF 3 not measured under the
    second input) that holds the truth or garbage (10³ × the truth, phase turned): the
    final fit — the choice of start, both costs, the refit, the errors it reports — is
    the same either way (1e-10: the same arithmetic on the same measured entries, on one
    thread). The
    modal start is taken, and the first pass's error before is the held-out fit's, the
    start the user had, not the rebuilt one's (1e-9)."""

    from podid_rs.identification.order import _all_lines_db, final_fit
    from podid_rs.measured import from_frf

    U, _ = frf_data(omega_all, [0, 1, 2, 3], [0, 2])
    data = from_frf(U, omega_all, inputs=[0, 2])
    U, F, P = data.U, data.forces_on_dofs(), data.pod()
    measured = np.ones((4, 2), dtype=bool)
    measured[3, 1] = False
    garbage = U.copy()
    garbage[:, 3, 1] *= 1e3j
    sweep, R, bad = sweep_holding(garbage, F, omega_all, P, wrong_shapes, measured=measured)
    fits = [final_fit(sweep, data_, F, omega_all, P, log_magnitude=False, max_iter=20,
                      measured=measured, threads=1)[0] for data_ in (U, garbage)]
    for k in "MCK":
        assert np.linalg.norm(getattr(fits[1], k) - getattr(fits[0], k)) <= 1e-10 * np.linalg.norm(
            getattr(fits[0], k))
    kept = [f.info["refinement"]["final_refit"] for f in fits]
    assert kept[1]["reason"] == kept[0]["reason"]
    assert "modal start" in kept[0]["reason"]
    assert kept[1]["passes"][0]["db_before"] == pytest.approx(kept[0]["passes"][0]["db_before"],
                                                              rel=1e-10)
    assert kept[0]["passes"][0]["db_before"] == pytest.approx(
        _all_lines_db(bad, R, U, F, omega_all, measured), rel=1e-9)


def test_the_final_fit_from_the_held_out_fit_says_nothing_of_a_modal_start():
    """A held-out fit that is the truth, on a band holding two of the four modes: the
    modal start, which stands in for the other two, cannot fit better, and the reason is
    the complex refit's sentence alone."""

    from podid_rs.identification.order import final_fit
    from podid_rs.measured import from_frf

    wn, _ = natural(M4, C4, K4)
    omega = np.linspace(0.5 * wn[0], 0.5 * (wn[1] + wn[2]), 300)
    U, _ = frf_data(omega, [0, 1, 2, 3], [0, 2])
    data = from_frf(U, omega, inputs=[0, 2])
    U, F, P = data.U, data.forces_on_dofs(), data.pod()
    sweep, _, _ = sweep_holding(U, F, omega, P, the_truth)
    model, _ = final_fit(sweep, U, F, omega, P, log_magnitude=False, max_iter=5)
    reason = model.info["refinement"]["final_refit"]["reason"]
    assert reason.startswith(("the complex refit lowered", "the complex refit on every line"))
    assert reason.endswith(" dB)") and "; " not in reason


def test_the_final_fit_keeps_the_held_out_fit_when_the_refit_raises_the_median():
    """The truth as held-out fit, on data where one line in eight is off by a factor 5
    (a bad line the relative cost can trade the others for): the complex refit lowers
    its weighted cost but raises the median error over every line, so the held-out fit
    is kept — the model returned is it, and the reason quotes the medians before and
    after (to its two decimals)."""

    from podid_rs.identification.order import final_fit

    U, F, P, omega = one_bad_line_in_eight()
    sweep, _, truth = sweep_holding(U, F, omega, P, the_truth)
    model, _ = final_fit(sweep, U, F, omega, P, log_magnitude=False, max_iter=20)
    kept = model.info["refinement"]["final_refit"]
    before, after = kept["passes"][0]["db_before"], kept["passes"][0]["db_after"]
    assert after[0] > before[0]
    assert kept["kept"] == "held-out fit"
    for k in "MCK":
        np.testing.assert_array_equal(getattr(model, k), getattr(truth, k))
    assert f"every line ({before[0]:.2f} → {after[0]:.2f} dB)" in kept["reason"]
    # … and the weighted costs: the pass started from the modal start (the relative cost
    # trades the bad lines for the rest: it lies below the truth's), so its cost before
    # is the modal start's, and the start's note sets it against the truth's — each by
    # hand, Σ ‖R x − u‖² / ‖u‖² over lines and load cases (to the 4 digits quoted; R is
    # square here, so nothing lies outside its span); the cost after is lower
    R = sweep.basis(4, P)

    def relative_cost(matrices):
        x = pr.SecondOrderSystem(*matrices).response(omega, np.einsum("nm,snp->smp", R, F))
        X = np.einsum("nm,smp->snp", R, x)
        return float(np.sum(np.sum(np.abs(X - U) ** 2, axis=1) / np.sum(np.abs(U) ** 2, axis=1)))

    held = relative_cost((truth.M, truth.C, truth.K))
    rebuilt = relative_cost(modal_start(truth, R, U, F, omega))
    assert rebuilt < held
    cost = re.search(r"lowered the weighted cost \((\S+) → (\S+)\)", kept["reason"])
    note = re.search(r"weighted cost (\S+) against (\S+)\)$", kept["reason"])
    assert float(cost[1]) == pytest.approx(rebuilt, rel=1e-3)
    assert float(cost[2]) < float(cost[1])
    assert float(note[1]) == pytest.approx(rebuilt, rel=1e-3)
    assert float(note[2]) == pytest.approx(held, rel=1e-3)


def test_the_final_fit_quotes_the_medians_it_decided_on():
    """The same data (one line in eight off by a factor 5) from a bad held-out fit: the
    complex refit lowers the median error over every line, is kept, and the reason
    quotes the medians before and after — not the 95th percentiles beside them."""

    from podid_rs.identification.order import final_fit

    U, F, P, omega = one_bad_line_in_eight()
    sweep, _, _ = sweep_holding(U, F, omega, P, wrong_shapes)
    model, _ = final_fit(sweep, U, F, omega, P, log_magnitude=False, max_iter=20)
    kept = model.info["refinement"]["final_refit"]
    before, after = kept["passes"][0]["db_before"], kept["passes"][0]["db_after"]
    assert kept["kept"] == "complex refit" and after[0] <= before[0]
    assert f"over every line ({before[0]:.2f} → {after[0]:.2f} dB)" in kept["reason"]
    assert f"{before[1]:.2f}" != f"{before[0]:.2f}" and f"{after[1]:.2f}" != f"{after[0]:.2f}"


def test_residues_at_the_poles_are_exact_and_a_line_without_response_weighs_nothing():
    # U = Σ_k r_k / (w_k² − ω² + 2i ζ_k w_k ω) on one DOF and load case, with one line lost
    # (zero, a drop-out): the least-squares residues are r_k (1e-10), the lost line weighs
    # nothing — relative weights would make it infinite
    from podid_rs.identification.modal_start import _residues

    omega = 2 * np.pi * np.linspace(5.0, 100.0, 60)
    wk, zk, r = 2 * np.pi * np.array([20.0, 60.0]), np.array([0.02, 0.01]), np.array([3.0, -1.5])
    den = wk[None, :] ** 2 - omega[:, None] ** 2 + 2j * (zk * wk)[None, :] * omega[:, None]
    U = (r[None, :] / den).sum(axis=1)[:, None, None]
    U[17] = 0.0
    got = _residues(U, omega, wk, zk, None)
    assert got.shape == (2, 1, 1) and np.all(np.isfinite(got))
    assert np.max(np.abs(got[:, 0, 0] - r)) < 1e-10 * np.max(np.abs(r))


@pytest.mark.parametrize("unit", [1.0, 1e9])  # displacements in metres, in nanometres
def test_a_line_of_exact_zeros_in_a_load_case_weighs_nothing_in_any_units(unit):
    """Where every measured response of a load case is exactly zero at a line (a drop-out),
    that line's weight is 0, not 1/0 nor whatever memory held: each load case's residues
    are those of the same least squares without its lost line. The data are noisy, so the
    modal sum does not pass through the zeros and any weight on them would move the fit —
    the more so in small units, where the relative weights of the other lines are small."""
    from podid_rs.identification.modal_start import _residues

    rng = np.random.default_rng(7)
    omega = 2 * np.pi * np.linspace(5.0, 100.0, 60)
    wk, zk = 2 * np.pi * np.array([20.0, 60.0]), np.array([0.02, 0.01])
    r = unit * rng.standard_normal((2, 3, 2))  # residues (N, n, p): 3 DOFs, 2 load cases
    den = wk[None, :] ** 2 - omega[:, None] ** 2 + 2j * (zk * wk)[None, :] * omega[:, None]
    U = np.einsum("sk,knp->snp", 1.0 / den, r)
    U *= 1.0 + 0.05 * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape))
    lost = (40, 17)  # the line lost in load case 0, in load case 1
    for j, line in enumerate(lost):
        U[line, :, j] = 0.0
    got = _residues(U, omega, wk, zk, None)
    assert np.all(np.isfinite(got))
    for j, line in enumerate(lost):
        keep = np.arange(omega.size) != line
        without = _residues(U[keep][:, :, j:j + 1], omega[keep], wk, zk, None)
        # the same problem solved twice, once with an extra row of zeros: equal to
        # rounding, ~1e-15 times the design's condition number (two poles 40 Hz apart:
        # their columns are far from parallel), many decades below 1e-10
        np.testing.assert_allclose(got[:, :, j:j + 1], without, rtol=0,
                                   atol=1e-10 * np.max(np.abs(without)))


def test_completing_modes_are_seen_at_the_observed_coordinates_in_turn(omega_all):
    """A driving point with two measured DOFs on an order-8 model: four in-band modes and
    the two residual poles leave two completing modes (at FILL_FACTOR · ω_hi times 1 and
    2), which no measured DOF would see; the first is seen at the first observed
    coordinate only, the second at the second — not both at the first."""
    U, F = frf_data(omega_all, [0, 1], [0])
    R = observation_matrix(np.eye(2), 8)
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), R, U, F, omega_all)
    assert_physical(start)
    M, _, K = start
    # C = A⁻ᵀ diag(2ζω) A⁻¹ with M, K alike: the modes are A's columns, x = A e_k
    lam, V = scipy.linalg.eigh(K, M)
    w = np.sqrt(lam)
    for k, dof in ((1, 0), (2, 1)):
        i = int(np.argmin(np.abs(w - k * FILL_FACTOR * omega_all[-1])))
        assert w[i] == pytest.approx(k * FILL_FACTOR * omega_all[-1], rel=1e-9)
        at_sensors = np.abs(R @ V[:, i])
        assert at_sensors[dof] > 0 and at_sensors[1 - dof] < 1e-9 * at_sensors[dof]


def test_room_for_one_residual_pole_keeps_the_one_below_the_band():
    """A band over modes 2–4 of the 4-DOF system (mode 1 below it): three in-band
    poles leave room for one residual pole in an order-4 start, and it is the one
    below the band, at ω_lo / RESIDUAL_FACTOR, standing in for mode 1 — not the one
    above, where nothing is left out. The kept poles exactly (round-off through A)."""
    from podid_rs.identification.modal_start import RESIDUAL_FACTOR

    wn, zeta = natural(M4, C4, K4)
    omega = np.linspace(0.5 * (wn[0] + wn[1]), 1.3 * wn[3], 400)
    U, F = frf_data(omega, [0, 1, 2, 3], [0])
    start = modal_start(pr.SecondOrderSystem(M4, C4, K4), np.eye(4), U, F, omega)
    assert_physical(start)
    w_start, _ = natural(*start)
    assert w_start[0] == pytest.approx(omega[0] / RESIDUAL_FACTOR, rel=1e-9)
    np.testing.assert_allclose(w_start[1:], wn[1:], rtol=1e-12)


def test_a_pole_damped_beyond_zeta_max_is_not_kept(omega_all):
    """The 4-DOF system with its third mode's damping ratio raised to 0.3 (above
    ZETA_MAX = 0.2: a pole too broad for its frequency to be read off a band): the
    start keeps the other three in-band poles exactly and none at the third mode's
    (ω₃, 0.3) — kept, it would be rebuilt exactly, to round-off."""
    from podid_rs.identification.modal_start import ZETA_MAX

    lam, phi = scipy.linalg.eigh(K4, M4)  # mass-normalised modes, φᵀ C4 φ diagonal
    w = np.sqrt(lam)
    zeta = np.diag(phi.T @ C4 @ phi) / (2 * w)
    zeta[2] = 0.3
    assert zeta[2] > ZETA_MAX and omega_all[0] < w[2] < omega_all[-1]
    C_broad = M4 @ phi @ np.diag(2 * zeta * w) @ phi.T @ M4  # Φᵀ C Φ = diag(2ζω)
    U = pr.SecondOrderSystem(M4, C_broad, K4).frf(omega_all)[:, :, [0, 2]]
    F = np.zeros_like(U)
    F[:, 0, 0] = F[:, 2, 1] = 1.0
    start = modal_start(pr.SecondOrderSystem(M4, C_broad, K4), np.eye(4), U, F, omega_all)
    assert_physical(start)
    w_start, z_start = natural(*start)
    for k in (0, 1, 3):
        assert np.min(np.abs(w_start / w[k] - 1)) < 1e-12
    broad = (np.abs(w_start / w[2] - 1) < 1e-6) & (np.abs(z_start - 0.3) < 1e-6)
    assert not np.any(broad)


def test_the_start_on_data_in_other_units_is_the_same_model_in_those_units(omega_all):
    """FRFs times c (another unit of displacement per force) are the same structure with
    M, C, K divided by c: residues scale by c, shapes by √c, and the coordinates'
    completion and the slight sighting of the completing modes must scale with the
    shapes. A driving point on two measured DOFs with an order-8 model (two completing
    modes, four latent coordinates to complete). c = 2⁻²⁰, a power of two, so every
    product scales exactly and the two starts agree to round-off (1e-12)."""
    U, F = frf_data(omega_all, [0, 1], [0])
    R = observation_matrix(np.eye(2), 8)
    system = pr.SecondOrderSystem(M4, C4, K4)
    c = 2.0**-20
    base = modal_start(system, R, U, F, omega_all)
    scaled = modal_start(system, R, c * U, F, omega_all)
    for X, Y in zip(base, scaled, strict=True):
        np.testing.assert_allclose(c * Y, X, rtol=1e-12, atol=1e-12 * np.abs(X).max())
