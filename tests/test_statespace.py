"""``IdentificationResult.to_state_space``: the transfer function is R H_m(ω) Rᵀ.

Tolerance: the state-space transfer function C (iωI − A)⁻¹ B goes through M⁻¹,
so it differs from the direct solve of (−ω²M + iωC + K) by a few units of
cond(M)·eps (cond(M) ≈ 10 here); 1e-8 relative per line is the bound
and leaves five orders of margin.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from podid_rs import mass_spring_chain, modal_parameters
from podid_rs.measured import from_frf
from podid_rs.statespace import MAX_MASS_CONDITION, state_space, state_space_matrices


@pytest.fixture(scope="module")
def reduced():
    """An order-4 model identified from exact FRFs of the 8-DOF chain driven at DOFs 1, 6."""
    chain = mass_spring_chain(8)
    omega = 2 * np.pi * np.linspace(2.0, 120.0, 300)
    data = from_frf(chain.frf(omega)[:, :, [0, 5]], omega, inputs=[0, 5])
    result, R = data.identify(m=4, symmetric=True)
    return result, R, omega


def transfer(ss, omega):
    """C (iωI − A)⁻¹ B + D per line, ``(s, n_out, n_in)``."""
    eye = np.eye(ss.A.shape[0])
    return np.stack([ss.C @ np.linalg.solve(1j * w * eye - ss.A, ss.B) + ss.D for w in omega])


def rel_error(X, Y):
    return float(np.max(np.linalg.norm(X - Y, axis=(1, 2)) / np.linalg.norm(Y, axis=(1, 2))))


def test_transfer_function_is_R_Hm_Rt(reduced):
    result, R, omega = reduced
    ss = result.to_state_space(R)
    assert isinstance(ss, scipy.signal.StateSpace) and ss.dt is None
    assert (ss.A.shape, ss.B.shape, ss.C.shape, ss.D.shape) == ((8, 8), (8, 8), (8, 8), (8, 8))
    H_n = np.einsum("am,smk,bk->sab", R, result.system().frf(omega), R)
    assert rel_error(transfer(ss, omega), H_n) < 1e-8


def test_without_basis_inputs_and_outputs_are_reduced(reduced):
    result, _, omega = reduced
    ss = result.to_state_space()
    assert ss.B.shape == (8, 4) and ss.C.shape == (4, 8)
    assert rel_error(transfer(ss, omega), result.system().frf(omega)) < 1e-8
    poles = np.linalg.eigvals(ss.A)
    lam = modal_parameters(result).eigenvalues
    upper = np.sort_complex(poles[poles.imag > 0])
    assert np.allclose(upper, np.sort_complex(lam[lam.imag > 0]), rtol=1e-10)


def test_python_control_and_lsim_accept_it(reduced):
    control = pytest.importorskip("control")
    result, R, omega = reduced
    ss = result.to_state_space(R)
    sys = control.ss(ss.A, ss.B, ss.C, ss.D)
    w = omega[::50]
    H = np.moveaxis(sys(1j * w), -1, 0)
    assert rel_error(H, transfer(ss, w)) < 1e-10
    # a static load settles to K⁻¹ on the measured DOFs: R K⁻¹ Rᵀ f
    f = np.zeros(8)
    f[0] = 1.0
    t = np.linspace(0.0, 20.0, 4001)
    _, y, _ = scipy.signal.lsim(ss, np.tile(f, (t.size, 1)), t)
    static = R @ np.linalg.solve(result.K, R.T @ f)
    assert np.allclose(y[-1], static, rtol=1e-4, atol=1e-6 * np.abs(static).max())


def test_bad_basis_and_singular_mass_are_named(reduced):
    result, R, _ = reduced
    with pytest.raises(ValueError, match=r"basis must have shape \(n, m\) with m = 4"):
        result.to_state_space(R[:, :3])
    with pytest.raises(ValueError, match="basis must be real"):
        result.to_state_space(R + 0j)
    with pytest.raises(ValueError, match="basis contains non-finite"):
        result.to_state_space(np.full_like(R, np.nan))
    from dataclasses import replace

    singular = replace(result, M=np.zeros((4, 4)))
    with pytest.raises(ValueError, match="M is singular"):
        singular.to_state_space(R)


def test_one_dof_oscillator_by_hand():
    # 2 q̈ + 0.8 q̇ + 50 q = f:  q̈ = −25 q − 0.4 q̇ + f/2
    A, B, C, D = state_space_matrices([[2.0]], [[0.8]], [[50.0]])
    np.testing.assert_allclose(A, [[0.0, 1.0], [-25.0, -0.4]], rtol=1e-15, atol=0)
    np.testing.assert_allclose(B, [[0.0], [0.5]], rtol=1e-15, atol=0)
    assert C.tolist() == [[1.0, 0.0]]
    assert isinstance(D, np.ndarray) and D.tolist() == [[0.0]]


def test_basis_maps_inputs_and_outputs():
    # R (3, 2): forces on 3 DOFs enter as Rᵀ f, outputs are R q; D is a (3, 3) zero
    R = np.array([[1.0, 0.0], [0.5, 1.0], [0.0, 2.0]])
    M, Cd, K = np.diag([1.0, 4.0]), np.diag([0.1, 0.2]), np.diag([9.0, 16.0])
    A, B, C, D = state_space_matrices(M, Cd, K, R)
    assert (A.shape, B.shape, C.shape, D.shape) == ((4, 4), (4, 3), (3, 4), (3, 3))
    np.testing.assert_array_equal(B[:2], 0.0)
    np.testing.assert_allclose(B[2:], np.linalg.solve(M, R.T), rtol=1e-15, atol=0)
    np.testing.assert_array_equal(C, np.hstack([R, np.zeros((3, 2))]))
    np.testing.assert_array_equal(D, np.zeros((3, 3)))


def test_malformed_matrices_are_named():
    ok = np.eye(2)
    for k, name in enumerate("MCK"):
        mats = [ok, ok, ok]
        mats[k] = ok + 1j
        with pytest.raises(ValueError, match=f"^{name} must be real"):
            state_space_matrices(*mats)
    with pytest.raises(ValueError, match=r"^C must be a non-empty \(2, 2\) matrix, got \(3, 3\)$"):
        state_space_matrices(ok, np.eye(3), ok)
    # the order is M's: a K of another size is named, not M
    with pytest.raises(ValueError, match=r"^K must be a non-empty \(2, 2\) matrix, got \(3, 3\)$"):
        state_space_matrices(ok, ok, np.eye(3))
    # and one of fewer lines or columns than M's: the check is two-sided
    with pytest.raises(ValueError, match=r"^C must be a non-empty \(2, 2\) matrix, got \(1, 1\)$"):
        state_space_matrices(ok, np.eye(1), ok)
    with pytest.raises(ValueError, match=r"^K must be a non-empty \(2, 2\) matrix, got \(2, 1\)$"):
        state_space_matrices(ok, ok, np.ones((2, 1)))
    with pytest.raises(ValueError, match=r"^M must be a non-empty \(2, 2\) matrix, got \(2, 3\)$"):
        state_space_matrices(np.ones((2, 3)), ok, ok)
    with pytest.raises(ValueError, match=r"^M must be a non-empty \(0, 0\) matrix, got \(0, 0\)$"):
        state_space_matrices(np.zeros((0, 0)), np.zeros((0, 0)), np.zeros((0, 0)))


def test_mass_condition_limit_is_inclusive():
    # cond₂(diag(1e14, 1)) is exactly MAX_MASS_CONDITION: still accepted ("exceeds" refuses)
    assert np.linalg.cond(np.diag([MAX_MASS_CONDITION, 1.0])) == MAX_MASS_CONDITION
    A, *_ = state_space_matrices(np.diag([MAX_MASS_CONDITION, 1.0]), np.eye(2), np.eye(2))
    assert A[3, 1] == -1.0 and A[2, 0] == -1.0 / MAX_MASS_CONDITION
    message = (r"^M is singular \(condition number 1e\+14\): the model has no state-space "
               r"form with state \[q; q̇\]$")
    with pytest.raises(ValueError, match=message):
        state_space_matrices(np.diag([1.0000001 * MAX_MASS_CONDITION, 1.0]), np.eye(2), np.eye(2))


def test_a_singular_mass_is_refused_with_its_condition_number():
    # cond₂(diag(1e16, 1)) = 1e16, two orders past the limit: the message quotes it
    with pytest.raises(ValueError, match=r"^M is singular \(condition number 1e\+16\)"):
        state_space_matrices(np.diag([1e16, 1.0]), np.eye(2), np.eye(2))


def test_a_model_that_is_not_symmetric_keeps_its_matrices_as_they_are():
    """identify(..., symmetric=False) gives M, C, K that are not symmetric: the transfer
    function is still (s²M + sC + K)⁻¹, not of a transpose. At s = 0 it is K⁻¹, here by
    hand: K = [[2, 1], [0, 3]] has K⁻¹ = [[1/2, −1/6], [0, 1/3]] (Kᵀ's inverse would have
    the −1/6 below the diagonal). cond(M), cond(K) < 10: 1e-12 relative."""
    M = np.array([[1.0, 0.2], [0.0, 1.0]])
    C = np.array([[0.1, 0.05], [0.0, 0.2]])
    K = np.array([[2.0, 1.0], [0.0, 3.0]])
    A, B, Cout, D = state_space_matrices(M, C, K)
    static = Cout @ np.linalg.solve(-A, B) + D  # C (0·I − A)⁻¹ B
    np.testing.assert_allclose(static, [[0.5, -1 / 6], [0.0, 1 / 3]], rtol=1e-12, atol=1e-15)
    omega = np.array([0.3, 1.0, 1.7, 4.0])
    ss = scipy.signal.StateSpace(A, B, Cout, D)
    direct = np.stack([np.linalg.inv(-(w**2) * M + 1j * w * C + K) for w in omega])
    assert rel_error(transfer(ss, omega), direct) < 1e-12
    # the public StateSpace passes the three on as they are too
    assert rel_error(transfer(state_space(M, C, K), omega), direct) < 1e-12


def test_a_mass_that_is_not_symmetric_is_inverted_not_transposed():
    # identify(symmetric=False) gives non-symmetric matrices. M = [[1, 1], [0, 1]] has
    # M⁻¹ = [[1, −1], [0, 1]] (its transpose's inverse is [[1, 0], [−1, 1]]); with
    # K = diag(4, 9), C = 0: A's lower left is −M⁻¹K = [[−4, 9], [0, −9]], B's lower
    # rows M⁻¹. Small integers: the LU solve is exact, the tolerance is round-off only.
    M, K = np.array([[1.0, 1.0], [0.0, 1.0]]), np.diag([4.0, 9.0])
    A, B, _, _ = state_space_matrices(M, np.zeros((2, 2)), K)
    np.testing.assert_allclose(A[2:, :2], [[-4.0, 9.0], [0.0, -9.0]], rtol=0, atol=1e-15)
    np.testing.assert_allclose(B[2:], [[1.0, -1.0], [0.0, 1.0]], rtol=0, atol=1e-15)
    # and the transfer function is the dynamic stiffness's inverse on every line
    # (cond(M) ≈ 2.6: the bound of the module's docstring holds with room to spare)
    C = np.array([[0.3, 0.1], [0.0, 0.2]])
    omega = np.array([0.5, 2.0, 2.9, 7.0])
    ss = scipy.signal.StateSpace(*state_space_matrices(M, C, K))
    direct = np.stack([np.linalg.inv(K - w**2 * M + 1j * w * C) for w in omega])
    assert rel_error(transfer(ss, omega), direct) < 1e-8
