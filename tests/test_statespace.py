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
