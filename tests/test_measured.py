"""MeasuredData's one-step methods: what they pass on, their defaults, their refusals.

``identify`` and ``fit`` chain POD, projection and a fitter; these tests check that
every argument reaches the fitter (a spy records the call and runs the real one) and
that the answer is the fitter's own, on exact FRFs of a small chain.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import podid_rs.measured as measured
from podid_rs import SecondOrderSystem, mass_spring_chain, simulate_white_noise
from podid_rs.identification.order import final_fit, sweep_orders
from podid_rs.measured import from_frf, from_time_histories


@pytest.fixture(scope="module")
def chain_frf():
    """Exact FRFs of the 5-DOF chain driven at DOFs 1 and 4, 60 lines over 20–400 Hz."""
    chain = mass_spring_chain(5)
    omega = 2 * np.pi * np.linspace(20.0, 400.0, 60)
    return from_frf(chain.frf(omega)[:, :, [0, 3]], omega, inputs=[0, 3])


def spy(monkeypatch, name: str) -> list[tuple[tuple, dict, object]]:
    """Replace ``podid_rs.measured.<name>`` by a wrapper recording (args, kwargs, result)."""
    real = getattr(measured, name)
    calls: list[tuple[tuple, dict, object]] = []

    def wrapper(*args, **kwargs):
        out = real(*args, **kwargs)
        calls.append((args, kwargs, out))
        return out

    monkeypatch.setattr(measured, name, wrapper)
    return calls


def test_identify_passes_every_argument_to_the_estimator(chain_frf, monkeypatch):
    calls = spy(monkeypatch, "identify")
    result, R = chain_frf.identify(m=3, lam=(0.5, 0.0, 2.0), symmetric=True, backend="numpy",
                                   threads=1)
    (args, kwargs, out), = calls
    assert out is result
    U_m, F_m = chain_frf.project(R)
    np.testing.assert_array_equal(args[0], U_m)
    np.testing.assert_array_equal(args[1], F_m)
    np.testing.assert_array_equal(args[2], chain_frf.omega)
    assert args[3:] == ((0.5, 0.0, 2.0), True)
    assert kwargs == {"backend": "numpy", "threads": 1}
    np.testing.assert_array_equal(R, chain_frf.pod().basis(3))


def test_identify_chooses_the_order_by_energy(chain_frf):
    pod = chain_frf.pod()
    _, R = chain_frf.identify(symmetric=True)  # neither m nor energy: 99 %
    assert R.shape[1] == pod.order_for_energy(0.99)
    _, R = chain_frf.identify(energy=0.9, symmetric=True)
    assert R.shape[1] == pod.order_for_energy(0.9) < pod.order_for_energy(0.99)
    with pytest.raises(ValueError, match="^give the reduced order m or the energy fraction, "
                                         "not both$"):
        chain_frf.identify(m=2, energy=0.9)


def test_fit_is_the_order_sweep_and_the_final_fit(chain_frf, monkeypatch, capfd):
    sweeps, finals = spy(monkeypatch, "sweep_orders"), spy(monkeypatch, "final_fit")
    model, R, sweep = chain_frf.fit(2, threads=1)
    (s_args, s_kwargs, s_out), = sweeps
    (f_args, f_kwargs, f_out), = finals
    assert sweep is s_out and (model, R) == f_out
    F_n = chain_frf.forces_on_dofs()
    for args in (s_args, f_args[1:]):
        np.testing.assert_array_equal(args[0], chain_frf.U)
        np.testing.assert_array_equal(args[1], F_n)
        np.testing.assert_array_equal(args[2], chain_frf.omega)
        np.testing.assert_array_equal(args[3].eigenvalues, chain_frf.pod().eigenvalues)
    assert f_args[0] is sweep
    assert s_kwargs == {"m": 2, "m_max": None, "threads": 1}
    assert f_kwargs == {"threads": 1, "progress": False}
    assert sweep.chosen == 2 and R.shape == (5, 2)
    assert capfd.readouterr().err == ""  # no progress bar unless asked

    sweeps.clear()
    finals.clear()
    chain_frf.fit(m_max=1, progress=True)
    assert sweeps[0][1] == {"m": None, "m_max": 1, "threads": None}
    assert finals[0][1] == {"threads": None, "progress": True}  # the progress asked for


def test_fit_reproduces_exact_data_like_a_direct_sweep(chain_frf):
    model, R, sweep = chain_frf.fit(2)
    F_n = chain_frf.forces_on_dofs()
    pod = chain_frf.pod()
    direct = sweep_orders(chain_frf.U, F_n, chain_frf.omega, pod, m=2)
    model_d, R_d = final_fit(direct, chain_frf.U, F_n, chain_frf.omega, pod)
    np.testing.assert_array_equal(R, R_d)
    for a, b in ((model.M, model_d.M), (model.C, model_d.C), (model.K, model_d.K)):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())


def test_predict_is_the_models_frf_and_refuses_a_mismatch(chain_frf):
    result, R = chain_frf.identify(m=3, symmetric=True)
    H = chain_frf.predict(result.system(), R)
    F_m = chain_frf.project(R)[1]
    expected = np.einsum("nm,smp->snp", R, result.system().response(chain_frf.omega, F_m))
    np.testing.assert_allclose(H, expected, rtol=1e-13, atol=0)
    with pytest.raises(ValueError, match="^system must be a SecondOrderSystem, got ndarray$"):
        chain_frf.predict(result.M, R)
    three = SecondOrderSystem(np.eye(3), np.eye(3), np.eye(3))
    # (two load cases: the count must be R's columns, not the load cases)
    with pytest.raises(ValueError, match="^the model has 3 DOFs but R has 1 columns$"):
        chain_frf.predict(three, R[:, :1])
    # and a basis of more columns (3) than the model's DOFs (2)
    two = SecondOrderSystem(np.eye(2), np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match="^the model has 2 DOFs but R has 3 columns$"):
        chain_frf.predict(two, R)


def test_predict_takes_complex_forces_as_they_are():
    """Forces that vary in phase (spectra of random excitation, not unit FRF forces): on the
    full basis R = I the prediction is the chain's own ``U = Z(ω)⁻¹ F_n``, solved here by
    hand from ``Z = K − ω² M + iω C`` (eq. 19). A conjugated force would give the response
    to ``conj(F)``, which differs by O(1) for forces with a phase."""
    chain = mass_spring_chain(3)
    omega = 2 * np.pi * np.linspace(5.0, 60.0, 12)
    rng = np.random.default_rng(7)
    F = rng.standard_normal((12, 2, 2)) + 1j * rng.standard_normal((12, 2, 2))
    F_n = np.zeros((12, 3, 2), dtype=complex)
    F_n[:, [0, 2], :] = F
    M, C, K = (np.asarray(x) for x in (chain.M, chain.C, chain.K))
    U = np.stack([np.linalg.solve(K - w**2 * M + 1j * w * C, f) for w, f in zip(omega, F_n,
                                                                              strict=True)])
    data = measured.MeasuredData(omega, U, F, inputs=[0, 2])
    # two solves of the same well-conditioned 3 × 3 systems (cond(Z) < 11 on these lines)
    # agree to rounding (here bit for bit); 1e-10 leaves room for another LAPACK, while
    # the response to conjugated forces is off by a relative 2.0
    np.testing.assert_allclose(data.predict(chain, np.eye(3)), U, rtol=1e-10, atol=0)


# --- from_time_histories: both estimators keep the labels, the band, and name what is wrong


@pytest.fixture(scope="module")
def shaker_records():
    """Forces on DOFs 0 and 2 of the 3-DOF chain, 4096 samples at 1/256 s (seeded)."""
    sim = simulate_white_noise(mass_spring_chain(3), band_hz=(2.0, 100.0), dt=1 / 256,
                               duration=16.0, seed=4)
    return sim.forces[:, [0, 2]], sim.response, sim.dt


@pytest.mark.parametrize("estimator", ["h1", "spectra"])
def test_time_histories_keep_labels_inputs_and_band(shaker_records, estimator):
    forces, responses, dt = shaker_records
    dofs = [(7, 1), (8, -2), (9, 3)]
    data = from_time_histories(forces, responses, dt, inputs=[0, 2], dofs=dofs,
                               estimator=estimator, band_hz=(10.0, 40.0))
    assert data.dofs.tolist() == [[7, 1], [8, -2], [9, 3]]
    assert data.inputs.tolist() == [0, 2]
    assert 10.0 <= data.freq_hz[0] < data.freq_hz[-1] <= 40.0
    assert data.freq_hz[0] < 10.5 and data.freq_hz[-1] > 39.5


def test_time_histories_name_what_is_wrong(shaker_records):
    forces, responses, dt = shaker_records

    def refused(message: str, *args, **kwargs) -> None:
        with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
            from_time_histories(*args, **kwargs)

    refused("estimator must be 'h1' or 'spectra', got 'welch'",
            forces, responses, dt, inputs=[0, 2], estimator="welch")
    # a name before "spectra" in the alphabet as well as one after it
    refused("estimator must be 'h1' or 'spectra', got 'fft'",
            forces, responses, dt, inputs=[0, 2], estimator="fft")
    refused("nperseg applies to estimator='h1' only (Welch segments)",
            forces, responses, dt, inputs=[0, 2], estimator="spectra", nperseg=256)
    refused("forces must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, got (5,)",
            np.ones(5), responses, dt, estimator="spectra")
    refused("responses must have shape (r, n) or (n_rec, r, n) with r >= 2 samples, got (5,)",
            forces, np.ones(5), dt, estimator="spectra")
    refused("forces and responses must have the same number of records and samples, "
            "got (1, 4096, 2) and (1, 4000, 3)",
            forces, responses[:4000], dt, inputs=[0, 2], estimator="spectra")
    refused("forces and responses must have the same number of records and samples, "
            "got (1, 4000, 2) and (1, 4096, 3)",
            forces[:4000], responses, dt, inputs=[0, 2], estimator="spectra")


def test_spectra_of_several_records_mark_every_load_case_measured(shaker_records, tmp_path):
    """With estimator="spectra" each record is a load case: 4 records of 2 forces give
    p = 4, and the mask of measured entries is (n, p) — all measured — so that the data
    survive a save and load (whose mask must match U's load cases)."""
    from podid_rs.io.npz import load_data, save_data

    forces, responses, dt = shaker_records
    data = from_time_histories(forces.reshape(4, -1, 2), responses.reshape(4, -1, 3), dt,
                               inputs=[0, 2], estimator="spectra", band_hz=(10.0, 40.0))
    assert (data.n, data.p, data.F.shape[1]) == (3, 4, 2)
    assert data.measured.shape == (3, 4) and data.measured.all() and data.complete
    back = load_data(save_data(tmp_path / "records.npz", data))
    assert np.array_equal(back.U, data.U) and np.array_equal(back.measured, data.measured)


def test_is_frf_only_for_unit_forces_one_case_per_driven_dof(chain_frf):
    assert chain_frf.is_frf
    rng = np.random.default_rng(0)
    s, n_in = chain_frf.s, chain_frf.F.shape[1]
    # as many load cases as driven DOFs, but random forces: not FRFs
    F = rng.standard_normal((s, n_in, n_in)) + 1j * rng.standard_normal((s, n_in, n_in))
    assert not measured.MeasuredData(chain_frf.omega, chain_frf.U, F, None, [0, 3]).is_frf
    # unit forces on every line but one
    F = np.broadcast_to(np.eye(n_in), (s, n_in, n_in)).copy()
    F[7] *= 2.0
    assert not measured.MeasuredData(chain_frf.omega, chain_frf.U, F, None, [0, 3]).is_frf


def test_a_band_from_zero_is_a_band_and_an_empty_one_is_refused():
    freq = np.arange(0.0, 11.0)
    assert measured.band_lines(freq, (0.0, 3.0)).tolist() == [True] * 4 + [False] * 7
    # a band is a pair: three edges (whose first two would make a band) are refused too,
    # and so are one edge and a bare number
    for band in [(5.0, 5.0), (6.0, 5.0), (-1.0, 5.0), (1.0, 5.0, 8.0), (5.0,), 5.0]:
        # the band as the caller wrote it, not the lines it was to cut
        with pytest.raises(ValueError, match=r"^band_hz must be a pair \(lo, hi\) in Hz with "
                           r"0 <= lo < hi, got " + re.escape(repr(band)) + "$"):
            measured.band_lines(freq, band)


def test_a_band_of_too_few_lines_names_the_lines_there_are():
    freq = np.arange(10.0, 31.0)
    with pytest.raises(ValueError, match=r"^band_hz \(40.0, 50.0\) keeps 0 of the 21 lines "
                                         r"\(10–30 Hz\); at least 2 are needed$"):
        measured.band_lines(freq, (40.0, 50.0))
    with pytest.raises(ValueError, match=r"^band_hz must be real"):
        measured.band_lines(freq, (10.0, 20.0 + 1j))


def test_a_band_of_exactly_two_lines_is_kept():
    """Two lines are the fewest a band may keep, and enough: 10–11 Hz on 1 Hz lines keeps
    10 and 11 (both ends included), and MeasuredData.band returns those two lines."""
    freq = np.arange(10.0, 31.0)
    assert np.flatnonzero(measured.band_lines(freq, (10.0, 11.0))).tolist() == [0, 1]
    chain = mass_spring_chain(3)
    omega = 2 * np.pi * freq
    data = from_frf(chain.frf(omega), omega)
    two = data.band((20.0, 21.0))
    assert two.s == 2 and np.array_equal(two.omega, omega[10:12])


def test_one_load_case_may_be_given_as_two_dimensional_arrays():
    """U (s, n) and F (s, n_in) are one load case, (s, n, 1) and (s, n_in, 1)."""
    chain = mass_spring_chain(3)
    omega = 2 * np.pi * np.linspace(5.0, 100.0, 20)
    H = chain.frf(omega)[:, :, 0]
    F = np.ones((20, 1), dtype=complex)
    flat = measured.MeasuredData(omega, H, F, None, [0])
    assert flat.U.shape == (20, 3, 1)
    np.testing.assert_array_equal(flat.U[:, :, 0], H)
    np.testing.assert_array_equal(flat.F[:, :, 0], F)


def test_projection_names_a_basis_that_is_not_real():
    chain = mass_spring_chain(3)
    omega = 2 * np.pi * np.linspace(5.0, 100.0, 20)
    data = from_frf(chain.frf(omega)[:, :, [0]], omega, inputs=[0])
    with pytest.raises(ValueError, match=r"^R must be real"):
        data.project(np.eye(3, 2) * 1j)
    # an empty basis, and one of 4 rows for the 3 measured DOFs, are named with their shapes
    with pytest.raises(ValueError, match=r"^R must have shape \(n, m\) with n = 3 measured "
                                         r"DOFs, got \(3,\)$"):
        data.project(np.ones(3))  # a vector is no basis
    for R in (np.zeros((3, 0)), np.eye(4, 2)):
        with pytest.raises(ValueError, match=r"^R must have shape \(n, m\) with n = 3 measured "
                                             rf"DOFs, got \({R.shape[0]}, {R.shape[1]}\)$"):
            data.project(R)
    # both sides of each count: 2 rows for the 3 DOFs, and a stack of bases (3 dimensions)
    with pytest.raises(ValueError, match=r"^R must have shape \(n, m\) with n = 3 measured "
                                         r"DOFs, got \(2, 2\)$"):
        data.project(np.eye(2))
    with pytest.raises(ValueError, match=r"^R must have shape \(n, m\) with n = 3 measured "
                                         r"DOFs, got \(3, 2, 1\)$"):
        data.project(np.ones((3, 2, 1)))


def test_a_band_keeps_the_notes_of_the_data(chain_frf):
    """What reading the data assumed still holds for the lines of a band."""
    noted = measured.MeasuredData(chain_frf.omega, chain_frf.U, chain_frf.F, None, [0, 3],
                                  notes=("read by reciprocity",))
    band = noted.band((100.0, 200.0))
    assert band.notes == ("read by reciprocity",)
    assert 100.0 <= band.freq_hz[0] and band.freq_hz[-1] <= 200.0 and band.s < noted.s
