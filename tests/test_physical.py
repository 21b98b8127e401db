"""Physical structure: nearest SPD/PSD correction, modal parameters, stability, truth comparison."""

from __future__ import annotations

import re
import warnings
from dataclasses import replace

import numpy as np
import pytest

from podid_rs import (
    IdentificationResult,
    SecondOrderSystem,
    add_noise,
    identify,
    mass_spring_chain,
    simulate_white_noise,
)
from podid_rs.measured import from_time_histories
from podid_rs.physical import (
    ModalParameters,
    companion_modes,
    compare_modes,
    make_physical,
    modal_parameters,
    modal_table,
    nearest_psd,
    table_csv,
    table_markdown,
)


def test_nearest_psd_is_the_frobenius_projection():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 6))
    P = nearest_psd(A)
    S = 0.5 * (A + A.T)
    d = np.linalg.eigvalsh(S)
    assert np.array_equal(P, P.T)
    assert np.linalg.eigvalsh(P).min() > -1e-12
    # ‖A − P‖² = ‖skew A‖² + Σ (negative eigenvalues of sym A)²  (Higham 1988)
    expected = np.linalg.norm(A - S) ** 2 + np.sum(np.minimum(d, 0.0) ** 2)
    assert np.isclose(np.linalg.norm(A - P) ** 2, expected, rtol=1e-12)
    # no PSD matrix nearby is closer
    for _ in range(20):
        B = rng.standard_normal((6, 6))
        Q = P + 0.05 * (B @ B.T)
        assert np.linalg.norm(A - Q) >= np.linalg.norm(A - P)
    # a floor lifts every eigenvalue to at least it; an SPD input is kept
    assert np.linalg.eigvalsh(nearest_psd(A, floor=0.5)).min() > 0.5 - 1e-12
    spd = S @ S.T + np.eye(6)
    assert np.allclose(nearest_psd(spd), spd, rtol=1e-13, atol=0)


@pytest.fixture(scope="module")
def noisy_band3():
    """The chain's band 3 at 10 dB, identified exactly symmetric at m = 10 (C indefinite)."""
    chain = mass_spring_chain(100)
    band = (53.5, 73.5)
    sim = simulate_white_noise(chain, band_hz=band, dt=1 / 256, duration=20.0, seed=1)
    noisy = add_noise(sim.response, 10.0, seed=2)
    data = from_time_histories(sim.forces, noisy, sim.dt, estimator="spectra", band_hz=band)
    result, R = data.identify(m=10, symmetric=True)
    return chain, data, result, R


def _data_residual(model, U, F, omega) -> float:
    """‖(−ω²M + iωC + K) u − f‖ over every line and load case (eq. 28), written out."""
    w = np.asarray(omega)[:, None, None]
    Z = -(w**2) * model.M + 1j * w * model.C + model.K
    return float(np.linalg.norm(np.einsum("sij,sjp->sip", Z, U) - F))


def test_make_physical_on_noisy_chain(noisy_band3):
    chain, data, result, R = noisy_band3
    U, F = data.project(R)
    assert np.linalg.eigvalsh(result.C).min() < 0  # least squares left C indefinite
    phys = make_physical(result, U, F, data.omega)
    for X in (phys.M, phys.C, phys.K):
        assert np.array_equal(X, X.T)
    assert np.linalg.eigvalsh(phys.M).min() > 0 and np.linalg.eigvalsh(phys.K).min() > 0
    assert np.linalg.eigvalsh(phys.C).min() >= -1e-12 * np.abs(phys.C).max()
    assert modal_parameters(phys).stable
    rep = phys.info["physical"]
    assert rep["residual_before"] == pytest.approx(result.residual_norm, rel=1e-12)
    assert rep["residual_after"] == phys.residual_norm
    # of the corrected matrices (C was changed: it was indefinite). The residual is of
    # noisy data (10 dB), far above the sum's round-off: rel=1e-10 is ample
    assert phys.residual_norm == pytest.approx(_data_residual(phys, U, F, data.omega),
                                               rel=1e-10)
    # the nearest correction costs little residual here (measured: +0.003 %)
    assert result.residual_norm <= phys.residual_norm < 1.05 * result.residual_norm
    assert rep["eigenvalues_raised"][0] == 0 and rep["eigenvalues_raised"][1] >= 1
    assert rep["relative_change"][0] < 1e-12  # M was already SPD: untouched
    assert phys.penalty_norms == (0.0, 0.0, 0.0) and phys.m == result.m
    # the report is added to what the fit recorded (its scaling, its timings), which stays
    assert set(result.info) and "physical" not in result.info
    assert set(phys.info) == set(result.info) | {"physical"}
    assert all(phys.info[key] is value for key, value in result.info.items())


def test_make_physical_refuses_mismatched_or_degenerate_input(noisy_band3):
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    with pytest.raises(ValueError, match=r"^the data have order m = 9 but the model has m = 10$"):
        make_physical(result, U[:, :9], F[:, :9], data.omega)
    # data of a higher order than the model are refused as well
    with pytest.raises(ValueError, match=r"^the data have order m = 11 but the model has m = 10$"):
        make_physical(result, np.concatenate([U, U[:, :1]], axis=1),
                      np.concatenate([F, F[:, :1]], axis=1), data.omega)
    zero_M = replace(result, M=np.zeros_like(result.M))
    with pytest.raises(ValueError, match="M is zero"):
        make_physical(zero_M, U, F, data.omega)
    with pytest.raises(ValueError, match="IdentificationResult"):
        make_physical(result.system(), U, F, data.omega)


def test_modal_parameters_of_one_dof_oscillator():
    m, c, k = 2.0, 0.8, 50.0
    modes = modal_parameters(SecondOrderSystem([[m]], [[c]], [[k]]))
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    assert modes.eigenvalues.shape == (1,)
    assert modes.eigenvalues[0] == pytest.approx(complex(-zeta * wn, wn * np.sqrt(1 - zeta**2)))
    assert modes.frequencies_hz[0] == pytest.approx(wn / (2 * np.pi))
    assert modes.damping_ratios[0] == pytest.approx(zeta)
    assert modes.stable and modes.n_infinite == 0

    over = modal_parameters(SecondOrderSystem([[1.0]], [[10.0]], [[1.0]]))
    assert over.eigenvalues.shape == (2,) and np.all(over.eigenvalues.imag == 0)
    assert np.allclose(over.damping_ratios, 1.0) and over.stable
    unstable = modal_parameters(SecondOrderSystem([[1.0]], [[-0.1]], [[1.0]]))
    assert not unstable.stable and unstable.damping_ratios[0] < 0
    singular = modal_parameters(SecondOrderSystem(np.diag([1.0, 0.0]), np.eye(2), np.eye(2)))
    assert singular.n_infinite >= 1 and not singular.stable


def test_modes_are_sorted_by_the_natural_frequency_not_the_damped_one():
    # two uncoupled oscillators (M = I): ω = 5 rad/s with ζ = 0.01 and ω = 10 rad/s with
    # ζ = 0.9, whose damped frequency 10·√(1 − 0.81) = 4.36 rad/s lies below the first's
    # 4.9997: sorted by |λ| = ω the lightly damped one comes first
    model = SecondOrderSystem(np.eye(2), np.diag([2 * 0.9 * 10.0, 2 * 0.01 * 5.0]),
                              np.diag([100.0, 25.0]))
    modes = modal_parameters(model)
    assert 2 * np.pi * modes.frequencies_hz == pytest.approx([5.0, 10.0], rel=1e-12)
    assert modes.damping_ratios == pytest.approx([0.01, 0.9], rel=1e-12)


def test_a_massless_dof_has_one_infinite_root_with_a_damper_and_two_without():
    """M = diag(1, 0), K = 4I: the second DOF has no mass. With a damper on it (C =
    diag(0, 1)) its equation q̇ + 4q = 0 is of first order: one root at −4, one at
    infinity. Without (C = 0) it is 4q = 0: both its roots are infinite. The first DOF's
    undamped pair ±2i gives the mode 2i either way (sorted by |λ|: 2i before −4)."""
    M, K = np.diag([1.0, 0.0]), 4 * np.eye(2)
    damped = modal_parameters(SecondOrderSystem(M, np.diag([0.0, 1.0]), K))
    assert damped.n_infinite == 1
    np.testing.assert_allclose(damped.eigenvalues, [2j, -4.0], rtol=0, atol=1e-12)
    bare = modal_parameters(SecondOrderSystem(M, np.zeros((2, 2)), K))
    assert bare.n_infinite == 2
    np.testing.assert_allclose(bare.eigenvalues, [2j], rtol=0, atol=1e-12)


@pytest.mark.parametrize("mass_coupling", [0.0, 0.5])
def test_companion_modes_of_an_unsymmetric_model_solve_its_own_pencil(mass_coupling):
    """A fit with ``symmetric=False`` has unsymmetric M, C and K. With M = [[1, μ], [0, 1]]
    (μ = ``mass_coupling``) and C, K upper triangular, λ²M + λC + K =
    [[p₁(λ), μλ² + λ + 3], [0, p₂(λ)]] with p₁ = λ² + 0.2λ + 4 and p₂ = λ² + 0.4λ + 9:
    its roots are those of p₁ and p₂, by hand −0.1 + i√3.99 and −0.2 + i√8.96 (|λ| = 2
    and 3, in that order), whatever μ. The first mode's vector is e₀ (the first column
    is [p₁, 0]); the second's is ∝ [−(μλ₂² + λ₂ + 3), p₁(λ₂)] (the first row's null
    vector). Mᵀ, Kᵀ or Cᵀ in its place would pose another pencil, no longer
    triangular, with other roots and vectors."""
    M = np.array([[1.0, mass_coupling], [0.0, 1.0]])
    C = np.array([[0.2, 1.0], [0.0, 0.4]])
    K = np.array([[4.0, 3.0], [0.0, 9.0]])
    lam, phi, n_infinite = companion_modes(SecondOrderSystem(M, C, K), vectors=True)
    # a 4 × 4 companion form with entries of order 10: its eigenvalues and vectors are
    # exact to ~1e-15; 1e-12 leaves room and is far below the mutants' O(0.1) shifts
    np.testing.assert_allclose(lam, [-0.1 + 1j * np.sqrt(3.99), -0.2 + 1j * np.sqrt(8.96)],
                               rtol=0, atol=1e-12)
    assert n_infinite == 0
    assert abs(phi[1, 0]) <= 1e-12 * abs(phi[0, 0])
    l2 = lam[1]
    v = np.array([-(mass_coupling * l2**2 + l2 + 3.0), l2**2 + 0.2 * l2 + 4.0])
    cosine = abs(np.vdot(v, phi[:, 1])) / (np.linalg.norm(v) * np.linalg.norm(phi[:, 1]))
    assert cosine == pytest.approx(1.0, abs=1e-12)
    for k in range(2):  # each pair solves (λ²M + λC + K) φ = 0, to round-off
        residual = (lam[k] ** 2 * M + lam[k] * C + K) @ phi[:, k]
        assert np.linalg.norm(residual) <= 1e-12 * 10 * np.linalg.norm(phi[:, k])


def test_chain_modes_match_rayleigh_theory():
    chain = mass_spring_chain(20)
    wk = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(chain.M, chain.K)).real))
    modes = modal_parameters(chain)
    assert np.allclose(2 * np.pi * modes.frequencies_hz, wk, rtol=1e-10)
    assert np.allclose(modes.damping_ratios, 0.5 / (2 * wk) + 3e-5 * wk / 2, rtol=1e-8)


def test_exact_identification_reproduces_the_true_modes_in_the_table():
    chain = mass_spring_chain(6)
    rng = np.random.default_rng(1)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, 40)
    F = rng.standard_normal((40, 6, 2)) + 1j * rng.standard_normal((40, 6, 2))
    result = identify(chain.response(omega, F), F, omega, symmetric=True)
    rows = compare_modes(modal_parameters(result), modal_parameters(chain))
    assert len(rows) == 6
    assert max(abs(r["f_rel_error"]) for r in rows) < 1e-9
    assert max(abs(r["zeta"] - r["zeta_true"]) for r in rows) < 1e-9

    table = modal_table(result, truth=chain)
    assert list(table[0]) == [
        "mode",
        "f_hz",
        "zeta",
        "re_lambda",
        "stable",
        "f_true_hz",
        "zeta_true",
        "f_rel_error",
    ]
    md = table_markdown(table)
    assert md.count("\n") == 8 and "| 1 | 56.09 | 0.005995 |" in md
    csv_text = table_csv(modal_table(result))
    assert csv_text.splitlines()[0] == "mode,f_hz,zeta,re_lambda,stable"
    assert len(csv_text.splitlines()) == 7


def test_the_table_reports_the_frequency_error_against_the_truth_and_checks_the_kinds():
    # undamped: K × 1.21 puts every natural frequency 10 % above the truth's
    chain = mass_spring_chain(3)
    truth = SecondOrderSystem(chain.M, np.zeros((3, 3)), chain.K)
    model = SecondOrderSystem(chain.M, np.zeros((3, 3)), 1.21 * chain.K)
    rows = modal_table(model, truth=truth)
    assert [r["f_rel_error"] for r in rows] == pytest.approx([0.1] * 3, rel=1e-9)
    assert [r["f_hz"] / r["f_true_hz"] for r in rows] == pytest.approx([1.1] * 3, rel=1e-9)
    with pytest.raises(ValueError, match=r"^kinds has 2 entries for 3 modes$"):
        modal_table(model, kinds=np.array(["structural", "weak"]))
    with pytest.raises(ValueError, match=r"^kinds has 4 entries for 3 modes$"):
        modal_table(model, kinds=np.array(["structural"] * 4))


def test_the_table_reports_the_true_damping_of_the_paired_mode():
    # stiffness-proportional damping C = βK has ζ_k = β ω_k / 2; K × 1.21 with the same C
    # keeps each mode's c and k·1.21, so ω × 1.1 and ζ = β ω_k / (2 · 1.1): the true
    # column must hold the truth's ζ, 1.1 times the model's, not the model's own.
    # β = 1e-5 s with the chain's ω up to 2866 rad/s: ζ ≤ 0.015, every mode oscillatory
    chain = mass_spring_chain(3)
    beta = 1e-5
    truth = SecondOrderSystem(chain.M, beta * chain.K, chain.K)
    model = SecondOrderSystem(chain.M, beta * chain.K, 1.21 * chain.K)
    rows = modal_table(model, truth=truth)
    assert [r["zeta_true"] for r in rows] == pytest.approx(
        list(modal_parameters(truth).damping_ratios), rel=1e-12
    )
    assert [r["zeta_true"] / r["zeta"] for r in rows] == pytest.approx([1.1] * 3, rel=1e-9)


def test_the_markdown_of_two_rows():
    rows = [{"mode": 1, "f_hz": 10.123456, "stable": "yes"},
            {"mode": 2, "f_hz": 20.0, "stable": "no"}]
    assert table_markdown(rows) == ("| mode | f_hz | stable |\n|---|---|---|\n"
                                    "| 1 | 10.12 | yes |\n| 2 | 20 | no |\n")
    assert table_markdown([]) == "(no modes)\n"


def test_the_csv_of_one_row_and_of_none():
    rows = [{"mode": 1, "f_hz": 10.5, "stable": True}]
    assert table_csv(rows) == "mode,f_hz,stable\n1,10.5,True\n"
    assert table_csv([]) == ""


def test_modal_parameters_refuse_other_objects():
    with pytest.raises(ValueError, match="SecondOrderSystem"):
        modal_parameters(np.eye(2))
    with pytest.raises(ValueError, match="square"):
        nearest_psd(np.ones((2, 3)))


def modes_with(eigenvalues, n_infinite: int = 0) -> ModalParameters:
    lam = np.asarray(eigenvalues, dtype=complex)
    mag = np.abs(lam)
    return ModalParameters(lam, mag / (2 * np.pi), -lam.real / mag, n_infinite)


def test_stability_boundary_is_strict():
    # Re λ = 0 (an undamped mode) is not asymptotically stable; the smallest
    # negative real part is
    assert not modes_with([2j]).stable
    assert not modes_with([-1.0 + 1j, 0.0 + 3j]).stable
    assert modes_with([-5e-324 + 2j]).stable
    assert modes_with([-1.0 + 1j, -1e-300 + 3j]).stable
    assert not modes_with([-1.0 + 1j], n_infinite=1).stable
    assert modes_with([-1.0 + 1j, -3.0 + 3j]).max_real_part == -1.0
    # no finite eigenvalue: max Re λ is −inf; stable only without infinite ones
    empty = modes_with(np.zeros(0))
    assert empty.max_real_part == -np.inf and empty.stable


def test_undamped_oscillator_sits_on_the_boundary():
    # M = 1, C = 0, K = 4: λ = ±2i exactly (the companion form's eigenvalues are exact here)
    undamped = SecondOrderSystem([[1.0]], [[0.0]], [[4.0]])
    modes = modal_parameters(undamped)
    assert modes.eigenvalues.shape == (1,)
    assert modes.eigenvalues[0] == pytest.approx(2j, abs=1e-15)
    assert modes.max_real_part == 0.0 and modes.damping_ratios[0] == 0.0
    assert not modes.stable
    assert modal_table(undamped)[0]["stable"] == "no"
    # the least damping makes it stable, in the modes and in the table
    damped = SecondOrderSystem([[1.0]], [[1e-9]], [[4.0]])
    assert modal_parameters(damped).stable
    assert modal_table(damped)[0]["stable"] == "yes"
    assert modal_table(damped)[0]["re_lambda"] == pytest.approx(-0.5e-9, rel=1e-6)


def test_the_table_keeps_the_signs_of_an_unstable_mode():
    # M = 1, C = −0.2, K = 100: λ = 0.1 ± i√99.99, |λ| = √K = 10, so ζ = −0.1/10 = −0.01
    # and Re λ = +0.1 (rel 1e-12: the companion form of one DOF rounds at ~1e-15 of |λ|)
    (row,) = modal_table(SecondOrderSystem([[1.0]], [[-0.2]], [[100.0]]))
    assert row["zeta"] == pytest.approx(-0.01, rel=1e-12)
    assert row["re_lambda"] == pytest.approx(0.1, rel=1e-12)
    # f is the natural |λ|/2π = 10/2π Hz, not the damped Im λ/2π (√99.99, 5e-5 lower)
    assert row["f_hz"] == pytest.approx(10.0 / (2 * np.pi), rel=1e-12)
    assert row["stable"] == "no"


def test_compare_modes_pairs_by_log_frequency_and_refuses_what_it_cannot_pair():
    two_pi = 2 * np.pi
    truth = modes_with([-0.01 + two_pi * 0.2j, -0.02 + two_pi * 0.5j])
    # identified: a rigid-body mode (λ = 0, f = 0), then 0.45 Hz, then 0.21 Hz
    identified = ModalParameters(
        np.array([0.0, -0.03 + two_pi * 0.45j, -0.04 + two_pi * 0.21j]),
        np.array([0.0, 0.45, 0.21]),
        np.array([0.0, 0.011, 0.03]),
        0,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # f = 0 must not reach log(0)
        rows = compare_modes(identified, truth)
    assert [list(r) for r in rows] == [["f_hz", "zeta", "f_true_hz", "zeta_true",
                                        "f_rel_error"]] * 3
    # f = 0 pairs with the lowest true mode; the others with the nearest in log f
    paired = truth.frequencies_hz[[0, 1, 0]]
    assert [r["f_true_hz"] for r in rows] == list(paired)
    assert [r["zeta_true"] for r in rows] == list(truth.damping_ratios[[0, 1, 0]])
    f_id = np.array([0.0, 0.45, 0.21])
    assert [r["f_rel_error"] for r in rows] == pytest.approx((f_id - paired) / paired, rel=1e-12)
    # each row reports the identified mode's own frequency, not the true one it pairs with
    assert [r["f_hz"] for r in rows] == [0.0, 0.45, 0.21]
    assert [r["zeta"] for r in rows] == [0.0, 0.011, 0.03]
    # between the two true modes log f and f disagree: 0.33 Hz lies above their geometric
    # mean √(0.2 · 0.5) = 0.316 Hz, nearer 0.5 Hz in log f (ln(0.5/0.33) = 0.42 against
    # ln(0.33/0.2) = 0.50), though nearer 0.2 Hz in f (0.13 Hz against 0.17 Hz)
    between = modes_with([-0.01 + two_pi * 0.33j])
    assert compare_modes(between, truth)[0]["f_true_hz"] == truth.frequencies_hz[1]
    # an unstable identified mode (Re λ > 0) keeps its negative damping ratio in its row
    unstable = modes_with([0.01 + two_pi * 0.2j])
    assert compare_modes(unstable, truth)[0]["zeta"] == unstable.damping_ratios[0] < 0
    # one true mode is enough
    single = compare_modes(identified, modes_with([-0.01 + two_pi * 0.2j]))
    assert [r["f_true_hz"] for r in single] == [truth.frequencies_hz[0]] * 3

    message = "^compare_modes takes two ModalParameters$"
    with pytest.raises(ValueError, match=message):
        compare_modes(identified, mass_spring_chain(3))
    with pytest.raises(ValueError, match=message):
        compare_modes(mass_spring_chain(3), truth)
    no_frequency = "^the true system has no mode with a positive frequency to compare with$"
    with pytest.raises(ValueError, match=no_frequency):
        compare_modes(identified, modes_with(np.zeros(0)))
    with pytest.raises(ValueError, match=no_frequency):
        compare_modes(identified, identified)  # its first mode has f = 0


def test_make_physical_raises_eigenvalues_to_the_relative_floor(noisy_band3):
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    d, Q = np.linalg.eigh(result.K)
    # K with its two smallest eigenvalues made negative: both land on rtol · max |eig|
    bad = replace(result, K=(Q * np.r_[-d[:2], d[2:]]) @ Q.T)
    rtol = 1e-6
    phys = make_physical(bad, U, F, data.omega, rtol=rtol)
    floor = rtol * np.abs(d).max()
    got = np.linalg.eigvalsh(phys.K)
    assert got[:2] == pytest.approx([floor, floor], rel=1e-6)
    assert got[2:] == pytest.approx(d[2:], rel=1e-9)
    assert phys.info["physical"]["eigenvalues_raised"][2] == 2
    assert phys.info["physical"]["rtol"] == rtol
    # the default floor is 1e-8 of the largest magnitude (as the signature says)
    default = make_physical(bad, U, F, data.omega)
    assert default.info["physical"]["rtol"] == 1e-8
    assert np.linalg.eigvalsh(default.K)[:2] == pytest.approx([1e-8 * np.abs(d).max()] * 2,
                                                              rel=1e-6)
    # the residual before is of the matrices given, measured on the data given: the
    # result built by hand still carries its fit's residual_norm, of the original K
    before = _data_residual(bad, U, F, data.omega)
    assert before != pytest.approx(bad.residual_norm, rel=1e-6)
    assert phys.info["physical"]["residual_before"] == pytest.approx(before, rel=1e-10)
    # the residual reported is the corrected K's (not the one with negative eigenvalues)
    assert phys.residual_norm == pytest.approx(_data_residual(phys, U, F, data.omega),
                                               rel=1e-10)
    # −K: its largest eigenvalue is negative, its largest magnitude max |d|; the floor is
    # relative to ‖K‖₂ = max |d|, so every raised eigenvalue lands on the same positive
    # floor and the corrected K is positive definite
    flipped = make_physical(replace(result, K=-result.K), U, F, data.omega, rtol=rtol)
    got = np.linalg.eigvalsh(flipped.K)
    assert got == pytest.approx(np.sort(np.maximum(-d, floor)), rel=1e-6)
    assert got.min() > 0


def test_a_positive_eigenvalue_under_the_floor_is_raised_and_counted(noisy_band3):
    """M positive definite but with its smallest eigenvalue a tenth of the floor
    rtol · max |eig|: it is raised to the floor and counted as raised, like a negative
    one; the next one, ten times the floor, is kept and not counted."""
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    d, Q = np.linalg.eigh(result.M)
    rtol = 1e-6
    floor = rtol * d.max()  # M's eigenvalues are positive: max |d| = max d
    assert d.min() > 0 and d[2] > 10 * floor  # the two new ones stay the smallest two
    bad = replace(result, M=(Q * np.r_[0.1 * floor, 10 * floor, d[2:]]) @ Q.T)
    phys = make_physical(bad, U, F, data.omega, rtol=rtol)
    assert phys.info["physical"]["eigenvalues_raised"][0] == 1
    # eigvalsh's error is ~1e-16 of max d, 1e-10 of the floor: rel=1e-6 is ample
    got = np.linalg.eigvalsh(phys.M)
    assert got[:2] == pytest.approx([floor, 10 * floor], rel=1e-6)
    assert got[2:] == pytest.approx(d[2:], rel=1e-9)


def test_make_physical_reports_what_it_changed_and_names_bad_input(noisy_band3):
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    m = result.m
    # a penalised fit (penalty norms ≠ 0) whose C has one exactly zero eigenvalue and
    # one negative one: only the negative one is raised, and the penalties are gone
    # with the penalised objective
    penalised = replace(result, C=np.diag(np.r_[np.ones(m - 2), 0.0, -1.0]),
                        penalty_norms=(1.0, 2.0, 3.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        phys = make_physical(penalised, U, F, data.omega)
    rep = phys.info["physical"]
    assert rep["eigenvalues_raised"][1] == 1
    assert phys.penalty_norms == (0.0, 0.0, 0.0)
    changes = [np.linalg.norm(a - b) / np.linalg.norm(b) for a, b in
               ((phys.M, result.M), (phys.C, penalised.C), (phys.K, result.K))]
    assert rep["relative_change"] == pytest.approx(changes, rel=1e-12, abs=1e-300)
    assert rep["relative_change"][1] == pytest.approx(1 / np.sqrt(m - 1), rel=1e-12)

    with pytest.raises(ValueError, match="^K is zero: there is no positive definite matrix "
                                         "near it$"):
        make_physical(replace(result, K=np.zeros((m, m))), U, F, data.omega)
    with pytest.raises(ValueError, match="^rtol must be a positive number, got 0$"):
        make_physical(result, U, F, data.omega, rtol=0)
    with pytest.raises(ValueError, match="^result must be an IdentificationResult, got "
                                         "SecondOrderSystem$"):
        make_physical(result.system(), U, F, data.omega)
    # a result built by hand with a NaN or a complex entry is refused with the matrix's
    # own name (each reaches nearest_psd's checks under the name make_physical gives it)
    for name in "MCK":
        bad = getattr(result, name).copy()
        bad[0, 0] = np.nan
        with pytest.raises(ValueError, match=f"^{name} contains non-finite values"):
            make_physical(replace(result, **{name: bad}), U, F, data.omega)
        with pytest.raises(ValueError, match=f"^{name} must be real, got complex dtype"):
            make_physical(replace(result, **{name: getattr(result, name) + 0j}), U, F,
                          data.omega)
        # not square: refused with its own shape as given (not a transpose's), before
        # a column could broadcast against its transpose into an m × m matrix
        for shape in ((m, m + 1), (m, 1)):
            with pytest.raises(ValueError, match=f"^{name} must be a non-empty square matrix, "
                                                 fr"got shape \({shape[0]}, {shape[1]}\)$"):
                make_physical(replace(result, **{name: np.ones(shape)}), U, F, data.omega)


def test_a_model_that_is_not_symmetric_is_judged_by_its_symmetric_part(noisy_band3):
    """An asymmetric C (a fit with ``symmetric=False``): I + 3(e₁e₀ᵀ − e₀e₁ᵀ) has the
    symmetric part I, positive definite, so no eigenvalue is raised and the correction
    only drops the skew part. Its lower triangle read as a symmetric matrix would have
    the block [[1, 3], [3, 1]], eigenvalue −2: counting from it would report one."""
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    m = result.m
    skew = np.zeros((m, m))
    skew[1, 0], skew[0, 1] = 3.0, -3.0
    phys = make_physical(replace(result, C=np.eye(m) + skew), U, F, data.omega)
    assert phys.info["physical"]["eigenvalues_raised"][1] == 0
    # the nearest symmetric PSD matrix is the symmetric part itself, to round-off of
    # the eigendecomposition (~1e-15 of its unit eigenvalues)
    np.testing.assert_allclose(phys.C, np.eye(m), rtol=0, atol=1e-13)
    # M, C and K all with a skew part a tenth of their norm: the residual reported
    # before is that of the three as given, not of a transpose (which flips the skew
    # part's sign and moves ‖Ax − y‖ by a fraction of it), written out independently
    # (both sum the same products: 1e-10 relative is round-off with margin)
    lopsided = replace(result, **{name: getattr(result, name)
                                  + 0.1 * np.linalg.norm(getattr(result, name)) * skew / 3.0
                                  for name in "MCK"})
    phys = make_physical(lopsided, U, F, data.omega)
    before = _data_residual(lopsided, U, F, data.omega)
    assert phys.info["physical"]["residual_before"] == pytest.approx(before, rel=1e-10)


def test_an_undamped_model_keeps_its_zero_damping_with_no_change(noisy_band3):
    """C = 0 (an undamped model) is positive semidefinite: nothing is raised, C stays
    exactly zero, and its relative change is 0, not 0 / 0."""
    _, data, result, R = noisy_band3
    U, F = data.project(R)
    undamped = replace(result, C=np.zeros((result.m, result.m)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no 0 / 0 on the way
        phys = make_physical(undamped, U, F, data.omega)
    rep = phys.info["physical"]
    assert rep["eigenvalues_raised"][1] == 0
    np.testing.assert_array_equal(phys.C, 0.0)
    assert rep["relative_change"][1] == 0.0


def test_nearest_psd_names_its_argument():
    square = r"must be a non-empty square matrix, got shape"
    with pytest.raises(ValueError, match=rf"^A {square} \(2, 3\)$"):
        nearest_psd(np.ones((2, 3)))
    with pytest.raises(ValueError, match=rf"^K {square} \(0, 0\)$"):
        nearest_psd(np.zeros((0, 0)), name="K")
    # more rows than columns as well as fewer
    with pytest.raises(ValueError, match=rf"^A {square} \(3, 2\)$"):
        nearest_psd(np.ones((3, 2)))
    # fewer dimensions than a matrix (a vector) and more (a stack of square matrices)
    with pytest.raises(ValueError, match=rf"^A {square} \(3,\)$"):
        nearest_psd(np.ones(3))
    with pytest.raises(ValueError, match=rf"^A {square} \(2, 2, 2\)$"):
        nearest_psd(np.ones((2, 2, 2)))


def test_nearest_psd_refuses_a_complex_matrix_or_a_negative_floor():
    with pytest.raises(ValueError, match="^A must be real"):
        nearest_psd(np.eye(2) + 0j)
    # the entries' checks name the matrix as the caller does, as the shape check does
    with pytest.raises(ValueError, match="^M must be real"):
        nearest_psd(np.eye(2) + 0j, name="M")
    with pytest.raises(ValueError, match="^floor must be a non-negative number, got -1$"):
        nearest_psd(np.eye(2), floor=-1)


def test_the_table_puts_each_modes_kind_on_its_row():
    chain = mass_spring_chain(3)
    model = SecondOrderSystem(chain.M, np.zeros((3, 3)), chain.K)
    kinds = np.array(["structural", "weak", "residual"])
    assert [r["kind"] for r in modal_table(model, kinds=kinds)] == list(kinds)
    assert "kind" not in modal_table(model)[0]


def test_modal_parameters_name_the_type_they_refuse():
    with pytest.raises(ValueError, match="^model must be an IdentificationResult or a "
                                         "SecondOrderSystem, got ndarray$"):
        modal_parameters(np.eye(2))


@pytest.mark.parametrize("shapes", [
    ((2, 2), (2, 3), (2, 1)),  # C and K as wide as two 2 × 2 blocks: the pencil could be formed
    ((2, 2), (3, 3), (2, 2)),  # C alone larger
    ((2, 2), (2, 2), (1, 1)),  # K alone smaller
    ((2, 3), (2, 2), (2, 2)),  # M alone not square
    ((), (1, 1), (1, 1)),  # a bare number for M, for C, for K
    ((1, 1), (), (1, 1)),
    ((1, 1), (1, 1), ()),
])
def test_modal_parameters_refuse_a_hand_built_model_of_mismatched_shapes(shapes):
    """The companion form needs M, C and K square and of one shape; a result built by hand
    that breaks it is refused with the three shapes, before any block or eigensolve."""
    M, C, K = (np.ones(shape) for shape in shapes)
    model = IdentificationResult(
        M=M, C=C, K=K, lam=(0.0, 0.0, 0.0), symmetric=False, residual_norm=0.0,
        penalty_norms=(0.0, 0.0, 0.0), method="test", rank=0, n_unknowns=0,
        min_pivot_ratio=1.0, backend="test",
    )
    message = ("the model's M, C and K must be square matrices of one shape, got "
               f"{shapes[0]}, {shapes[1]} and {shapes[2]}")
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        modal_parameters(model)

