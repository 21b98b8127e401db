"""Mode shapes on the measured DOFs and the MAC (podid_rs.modes).

Tolerances: exact-data models reproduce the chain's modes to ~1e-9 (the
identification's own accuracy, see test_identification), so MAC values of
matching modes are asserted within 1e-8 of 1 and the residue sum within 1e-8.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg

from podid_rs import (
    ModeShapes,
    SecondOrderSystem,
    mac,
    mass_spring_chain,
    modal_parameters,
    mode_shapes,
    shape_mac,
)
from podid_rs.measured import from_frf
from podid_rs.plotting import plot_mac

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def full_order():
    """The 6-DOF chain identified at full order from exact FRFs driven at DOFs 2 and 5."""
    chain = mass_spring_chain(6)
    omega = 2 * np.pi * np.linspace(1.0, 200.0, 400)
    data = from_frf(chain.frf(omega)[:, :, [1, 4]], omega, inputs=[1, 4])
    result, R = data.identify(m=6, symmetric=True)
    return chain, data, result, R


def test_mac_definition_and_invariances():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((7, 3)) + 1j * rng.standard_normal((7, 3))
    B = rng.standard_normal((7, 4))
    expected = np.array(
        [[abs(a.conj() @ b) ** 2 / ((a.conj() @ a).real * (b @ b)) for b in B.T] for a in A.T]
    )
    got = mac(A, B)
    assert got.shape == (3, 4) and np.allclose(got, expected, rtol=1e-13)
    assert np.allclose(mac(A * (2 - 3j), B * -5.0), got, rtol=1e-13)
    assert np.allclose(np.diag(mac(A, A)), 1.0, rtol=1e-14)
    Q = np.linalg.qr(rng.standard_normal((7, 4)))[0]
    assert np.allclose(mac(Q, Q), np.eye(4), atol=1e-15)
    assert mac(A[:, 0], A[:, 0]).shape == (1, 1)


@pytest.mark.parametrize(
    "A,B,message",
    [
        (np.ones((4, 2)), np.ones((5, 2)),
         r"^A and B must have the same number of rows \(DOFs\), got 4 and 5$"),
        # A of more rows than B as well as of fewer
        (np.ones((5, 2)), np.ones((4, 2)),
         r"^A and B must have the same number of rows \(DOFs\), got 5 and 4$"),
        (np.ones((4, 2)), np.zeros((4, 2)), "B column 0 is zero"),
        # one zero column among others is refused too (its MAC would be 0 / 0)
        (np.ones((4, 2)), np.array([[1.0, 0.0]] * 4), "^B column 1 is zero: it has no MAC$"),
        (np.ones((4, 0)), np.ones((4, 2)), "non-empty"),
        # B without columns too: it has no MAC, not an empty (2, 0) answer
        (np.ones((4, 2)), np.ones((4, 0)),
         r"non-empty \(n, k\) arrays, got \(4, 2\) and \(4, 0\)$"),
        (np.full((4, 2), np.nan), np.ones((4, 2)), "A contains non-finite"),
        # either side: a NaN in B would give NaN MAC values, not a message
        (np.ones((4, 2)), np.array([[1.0, np.nan]] * 4), "^B contains non-finite"),
        (np.ones((4, 2, 2)), np.ones((4, 2)), r"non-empty \(n, k\) arrays, got \(4, 2, 2\)"),
        (np.ones((4, 2)), np.ones((4, 2, 2)), r"non-empty \(n, k\) arrays, got \(4, 2\) and"),
        # a scalar, of fewer dimensions than a shape, on either side
        (2.0, np.ones((4, 2)),
         r"^A and B must be non-empty \(n, k\) arrays, got \(\) and \(4, 2\)$"),
        (np.ones((4, 2)), 2.0,
         r"^A and B must be non-empty \(n, k\) arrays, got \(4, 2\) and \(\)$"),
    ],
)
def test_mac_bad_input_is_named(A, B, message):
    with pytest.raises(ValueError, match=message):
        mac(A, B)


def test_shapes_of_a_proportionally_damped_chain_are_its_normal_modes():
    chain = mass_spring_chain(8)
    modes = mode_shapes(chain)
    assert np.allclose(modes.eigenvalues, modal_parameters(chain).eigenvalues, rtol=1e-12)
    assert np.allclose(np.max(np.abs(modes.shapes), axis=0), 1.0, rtol=1e-14)
    assert np.max(np.abs(modes.shapes.imag)) < 1e-10  # Rayleigh damping: real modes
    _, phi = scipy.linalg.eigh(chain.K, chain.M)
    # the same shapes as the undamped modes (MAC is not M-orthogonality: the
    # off-diagonal terms are the modes' auto-MAC, not 0, for a non-uniform mass)
    assert np.allclose(mac(modes.shapes, phi), mac(phi, phi), atol=1e-10)
    assert np.allclose(np.diag(mac(modes.shapes, phi)), 1.0, atol=1e-12)


def test_complex_shapes_are_scaled_by_their_entry_of_largest_modulus():
    # one dashpot at the chain's end: non-proportional damping, modes far from real
    # (the first two have |Im φ| up to 0.2 and 0.37 of their largest entry)
    chain = mass_spring_chain(4)
    C = np.zeros((4, 4))
    C[3, 3] = 0.5 * np.sqrt(chain.K[3, 3] * chain.M[3, 3])
    modes = mode_shapes(SecondOrderSystem(chain.M, C, chain.K))
    phi = modes.shapes
    assert np.max(np.abs(phi.imag)) > 0.1  # the fixture does what it says
    # the entry of largest modulus is exactly 1 (a real, positive unit), none larger;
    # scaling by the entry of largest real part would leave entries up to 28 in modulus
    top = phi[np.argmax(np.abs(phi), axis=0), np.arange(4)]
    assert np.allclose(top, 1.0, rtol=0, atol=1e-14)
    assert np.all(np.abs(phi) <= 1 + 1e-14)
    # still the pencil's vectors: (λ²M + λC + K) φ = 0 (eq. 1), to rounding relative to ‖K‖
    for lam, p in zip(modes.eigenvalues, phi.T, strict=True):
        Z = lam**2 * chain.M + lam * C + chain.K
        assert np.linalg.norm(Z @ p) < 1e-9 * np.linalg.norm(chain.K)


def test_identified_shapes_on_the_measured_dofs_match_the_chain(full_order):
    chain, data, result, R = full_order
    ident = mode_shapes(result, R, data.dofs)
    truth = mode_shapes(chain, dofs=data.dofs)
    assert ident.shapes.shape == (6, 6) and ident.dofs.tolist() == data.dofs.tolist()
    assert np.allclose(ident.frequencies_hz, truth.frequencies_hz, rtol=1e-8)
    values, used = shape_mac(ident, truth)
    assert used.tolist() == data.dofs.tolist()
    assert np.all(np.abs(np.diag(values) - 1) < 1e-8)
    assert np.allclose(values, mac(truth.shapes, truth.shapes), atol=1e-8)


def test_modal_a_makes_the_shapes_a_residue_model(full_order):
    _, data, result, R = full_order
    modes = mode_shapes(result, R)
    assert modes.modal_a is not None
    s = 1j * data.omega[:, None, None]
    phi = modes.shapes
    terms = np.einsum("ak,bk->kab", phi, phi) / modes.modal_a[:, None, None]
    H = sum(terms[k] / (s - modes.eigenvalues[k]) for k in range(modes.n_modes))
    H = H + sum(terms[k].conj() / (s - modes.eigenvalues[k].conj()) for k in range(modes.n_modes)
                if modes.eigenvalues[k].imag > 0)
    H_n = np.einsum("am,smk,bk->sab", R, result.system().frf(data.omega), R)
    assert np.max(np.abs(H - H_n)) < 1e-8 * np.max(np.abs(H_n))


@pytest.mark.parametrize("name", ["M", "C", "K"])
def test_nonsymmetric_model_has_no_modal_a(full_order, name):
    """Any one of M, C, K not symmetric (the others as identified) leaves no modal A."""
    from dataclasses import replace

    _, _, result, R = full_order
    X = getattr(result, name)
    skewed = replace(result, **{name: X + 1e-3 * np.triu(X, 1)})
    assert mode_shapes(skewed, R).modal_a is None


def test_shape_mac_uses_the_common_dofs_and_names_a_mismatch(full_order):
    _, data, result, R = full_order
    ident = mode_shapes(result, R, data.dofs)
    order = [5, 3, 1, 0]
    subset = ModeShapes(ident.eigenvalues, ident.shapes[order] * 1j, ident.dofs[order])
    values, used = shape_mac(ident, subset)
    assert sorted(used.tolist()) == sorted(ident.dofs[order].tolist())
    assert np.allclose(np.diag(values), 1.0, rtol=1e-12)
    elsewhere = ModeShapes(ident.eigenvalues, ident.shapes, ident.dofs + [100, 0])
    with pytest.raises(ValueError, match="share 0 .* DOF"):
        shape_mac(ident, elsewhere)
    with pytest.raises(ValueError, match=r"basis must have shape \(n, m\) with m = 6"):
        mode_shapes(result, R[:, :4])


def test_shape_mac_without_labels_compares_the_rows_as_they_are(full_order):
    _, _, result, R = full_order
    ident = mode_shapes(result, R)
    later = ident.select(np.array([False, False, True, False, True, True]))
    values, used = shape_mac(ident, later)
    assert used is None and values.shape == (6, 3)
    assert np.allclose(values[[2, 4, 5], [0, 1, 2]], 1.0, rtol=1e-12)
    assert np.allclose(values, mac(ident.shapes, later.shapes), rtol=1e-14)


def test_selected_modes_keep_their_modal_constants(full_order):
    """select (and in_band, oscillatory) keeps each kept mode's a, so that the kept
    shapes remain a residue model."""
    _, _, result, R = full_order
    modes = mode_shapes(result, R)
    keep = np.array([True, False, True, False, False, True])
    kept = modes.select(keep)
    assert kept.modal_a is not None
    np.testing.assert_array_equal(kept.modal_a, modes.modal_a[keep])
    band = modes.in_band((0.0, modes.frequencies_hz[keep].max()))
    np.testing.assert_array_equal(band.modal_a, modes.modal_a[band.mode_numbers - 1])


def test_plot_mac_against_another_model(full_order, tmp_path):
    chain, data, result, R = full_order
    ident = mode_shapes(result, R, data.dofs)
    path = plot_mac(ident, mode_shapes(chain, dofs=data.dofs), tmp_path / "mac.png",
                    names=("identified", "FE model"), band_hz=(0.0, 60.0))
    assert path.read_bytes()[:8] == PNG
    upper = ident.in_band((30.0, 1e3))
    assert upper.mode_numbers[0] == 1 + np.sum(ident.frequencies_hz < 30.0)
    assert ident.oscillatory().n_modes == 6  # the chain has no overdamped root


def test_mode_kinds_tell_resonances_from_the_fits_other_poles():
    """A modal model with known poles, seen at one sensor that is also the driving point:
    in band and visible at its lines → structural; in band but under 10 % of the data
    around it, or seen at one line only → weak; ζ ≥ 0.2, out of the band or at its edge,
    or real → residual."""
    from podid_rs.modes import mode_kinds

    w = 2 * np.pi * np.linspace(20.0, 150.0, 1301)

    def kinds_of(f_hz, zeta, shape, **kw):
        wn = 2 * np.pi * np.asarray(f_hz)
        zeta = np.asarray(zeta)
        model = SecondOrderSystem(np.eye(wn.size), np.diag(2 * zeta * wn), np.diag(wn**2))
        R = np.asarray([shape], dtype=float)
        shapes = mode_shapes(model, R)
        F = np.zeros((w.size, wn.size, 1))
        F[:, :, 0] = R[0]
        U = np.einsum("nm,smp->snp", R, model.response(w, F))
        found = dict(zip(np.round(shapes.frequencies_hz, 6), mode_kinds(shapes, w, U, [0], **kw),
                         strict=True))
        return found, shapes, U

    f = [30.0, 60.0, 90.0, 120.0, 200.0]
    found, shapes, U = kinds_of(f, [0.01, 0.01, 0.25, 0.01, 0.01], [1, 1, 1, 0.02, 1])
    assert [found[k] for k in sorted(found)] == [
        "structural", "structural", "residual", "weak", "residual"]
    # an overdamped DOF (a real pole pair) is a residual term too
    found, _, _ = kinds_of([30.0, 60.0, 1.0], [0.01, 0.01, 3.0], [1, 1, 1])
    assert sorted(found.values()) == ["residual", "residual", "structural", "structural"]
    # a strong mode narrower than the line spacing (half-power band 2|Re λ| below the
    # 0.1 Hz lines) is still a resonance of the data: the lines on both sides show it;
    # a nearly undamped, weak pole sitting on one line (fitting that line alone) is not
    found, _, _ = kinds_of([30.0, 60.05, 90.0], [0.01, 1e-4, 1e-8], [1, 1, 3e-3])
    assert 2 * 1e-4 * 2 * np.pi * 60.05 < 2 * np.pi * 0.1
    assert [found[k] for k in sorted(found)] == ["structural", "structural", "weak"]
    # a pole at the band's edge (half-power band not inside 20–150 Hz) is a residual term
    found, _, _ = kinds_of([30.0, 20.1, 149.9], [0.01, 0.01, 0.01], [1, 1, 1])
    assert [found[k] for k in sorted(found)] == ["residual", "structural", "residual"]
    # without measured FRFs only band and damping decide: nothing is weak
    assert "weak" not in mode_kinds(shapes, w)
    # a high enough visibility threshold makes every in-band light pole weak
    assert "structural" not in mode_kinds(shapes, w, U, [0], visible_fraction=1e6)
    with pytest.raises(ValueError, match="U needs inputs"):
        mode_kinds(shapes, w, U)
    # the lines as a column are the same lines
    assert np.array_equal(mode_kinds(shapes, w[:, None], U, [0]), mode_kinds(shapes, w, U, [0]))
    # a selection keeps the modes' numbers: the in-band ones of five are 1-4
    band = shapes.in_band((20.0, 150.0))
    assert band.mode_numbers.tolist() == [1, 2, 3, 4]
    assert band.select(np.array([False, True, False, True])).mode_numbers.tolist() == [2, 4]

def test_a_half_power_band_that_ends_exactly_at_the_bands_edge_is_in_the_band():
    """Lines at 10 … 200 rad/s. Poles whose half-power band Im λ ± |Re λ| ends exactly at
    10 or at 200 rad/s (both flanks within the lines) are structural; a tenth of a rad/s
    further out they show one flank only and are residual."""
    from podid_rs.modes import mode_kinds

    w = np.arange(10.0, 201.0)
    lam = np.array([-0.5 + 10.5j, -0.5 + 199.5j, -0.5 + 10.4j, -0.5 + 199.6j])
    shapes = ModeShapes(eigenvalues=lam, shapes=np.ones((1, 4)), modal_a=None)
    assert list(mode_kinds(shapes, w)) == ["structural", "structural", "residual", "residual"]


def test_an_undamped_pole_in_band_is_structural_and_a_real_one_residual():
    """An undamped mode at exactly 1 rad/s (Im λ = 1, Re λ = 0: its half-power band is
    the line itself, inside 0.5–2 rad/s) is a structural mode; a real pole is a residual
    term whatever its size, even at 0 (ζ of a zero pole is not defined). And a bad line
    is named as omega."""
    from podid_rs.modes import mode_kinds

    w = np.linspace(0.5, 2.0, 31)
    lam = np.array([1j, -1.0 + 0j, 0j])
    shapes = ModeShapes(eigenvalues=lam, shapes=np.ones((1, 3)), modal_a=None)
    assert list(mode_kinds(shapes, w)) == ["structural", "residual", "residual"]
    with pytest.raises(ValueError, match="^omega contains non-finite values"):
        mode_kinds(shapes, np.r_[w[:-1], np.nan])


def test_a_pole_midway_between_two_lines_is_judged_on_the_lower_third_line():
    """Lines at 1, 2, …, 200 rad/s and a lightly damped pole at exactly 10.5 rad/s: its
    two nearest lines tie (10 and 11), and so do the next two (9 and 12); it is judged on
    10, 11 and the lower, 9 (a stable sort: ties in line order — NumPy's default sort
    breaks them otherwise on this machine). The visibility window (2 % of 10.5 rad/s)
    holds no line, so those three set the level. The data are the pole's own term with
    a spike 100 times its peak: at 12 rad/s, left out, the pole is structural; at
    9 rad/s, one of the three, it is weak (not seen at two lines)."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -0.05 + 10.5j
    a = 2j * lam.imag
    term = 1 / (a * (1j * w - lam))
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((1, 1)),
                        modal_a=np.array([a]))
    for spike, kind in ((12.0, "structural"), (9.0, "weak")):
        U = term.copy()
        U[w == spike] = 100 * abs(term[w == 10.0])
        assert list(mode_kinds(shapes, w, U[:, None, None], inputs=[0])) == [kind]


def test_a_pole_is_seen_through_its_shape_at_the_driven_dof():
    """Two DOFs, the force at the second (inputs=[1]); a lightly damped pole at 50 rad/s
    whose shape is 1 at the driven DOF and 1e-3 at the first, a node of the mode, on
    lines 1, 2, …, 200 rad/s. The data are the pole's own term, φ_i φ_1 / (a (iω − λ)):
    it is seen at its three nearest lines (|iω − λ| is 0.5 at 50 rad/s and √1.25 at 49
    and 51: 0.45 of the peak there, above 0.1) and the data rise to a peak (13 times the
    ring 3–10 rad/s away), so it is structural.
    Its residue is φ_i φ_1, the shape at the driven DOF; at the first row's (1e-3) the
    term would be a thousandth of the data: weak."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -0.5 + 50j
    a = 2j * lam.imag
    phi = np.array([1e-3, 1.0])
    term = 1 / (a * (1j * w - lam))
    U = (phi[None, :] * phi[1] * term[:, None])[:, :, None]
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=phi[:, None].astype(complex),
                        modal_a=np.array([a]))
    assert list(mode_kinds(shapes, w, U, inputs=[1])) == ["structural"]


def test_a_model_symmetric_to_round_off_relative_to_its_size_has_modal_constants():
    """The symmetry test is relative (SYMMETRY_RTOL = 1e-12 of ‖X‖): a stiffness of norm
    about 3e4 asymmetric by 1e-13 of it is symmetric (modal constants known), one
    asymmetric by 1e-9 of it is not."""
    chain = mass_spring_chain(3)
    M, C, K = (np.asarray(X, dtype=float) for X in (chain.M, chain.C, chain.K))
    assert np.linalg.norm(K) > 1e3
    for skew, symmetric in ((1e-13, True), (1e-9, False)):
        K2 = K.copy()
        K2[0, 1] += skew * np.linalg.norm(K)
        shapes = mode_shapes(SecondOrderSystem(M, C, K2))
        assert (shapes.modal_a is not None) is symmetric


def test_a_pole_where_the_data_have_no_peak_is_weak():
    """The data of one mode (30 Hz) against a model that also has a strong pole at
    100 Hz, where the data fall smoothly as 1/ω²: its own term is as large as the data
    there (the visibility test passes), but the data do not rise to a peak — weak; the
    resonance stays structural. With the 100 Hz mode in the data, it is structural."""
    from podid_rs.modes import mode_kinds

    w = 2 * np.pi * np.linspace(20.0, 150.0, 1301)
    F = np.ones((w.size, 1, 1))

    def seen_at_one_sensor(f_hz):
        wn = 2 * np.pi * np.asarray(f_hz)
        model = SecondOrderSystem(np.eye(wn.size), np.diag(2 * 0.01 * wn), np.diag(wn**2))
        R = np.ones((1, wn.size))
        U = np.einsum("nm,smp->snp", R, model.response(w, np.einsum("nm,snp->smp", R, F)))
        return model, R, U

    _, _, U_data = seen_at_one_sensor([30.0])
    two, R, U_two = seen_at_one_sensor([30.0, 100.0])
    shapes = mode_shapes(two, R)
    near = np.abs(w / (2 * np.pi) - 100.0) < 2.0
    line = int(np.argmin(np.abs(w / (2 * np.pi) - 100.0)))
    term = 1.0 / abs(shapes.modal_a[1] * (1j * w[line] - shapes.eigenvalues[1]))
    assert term > 0.1 * np.abs(U_data[near]).max()  # visible by the term test alone
    kinds = dict(zip(np.round(shapes.frequencies_hz), mode_kinds(shapes, w, U_data, [0]),
                     strict=True))
    assert kinds == {30.0: "structural", 100.0: "weak"}
    kinds = dict(zip(np.round(shapes.frequencies_hz), mode_kinds(shapes, w, U_two, [0]),
                     strict=True))
    assert kinds == {30.0: "structural", 100.0: "structural"}


def test_a_zero_eigenvalue_has_zero_damping_ratio():
    shapes = ModeShapes(np.array([0.0 + 0.0j, -1.0 + 1.0j]), np.eye(2, dtype=complex))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        zeta = shapes.damping_ratios
    np.testing.assert_allclose(zeta, [0.0, 1 / np.sqrt(2)], rtol=1e-15)


def _pole_on_a_grid(half: float, level, lower: int = 40, upper: int = 40):
    """|U| = level(d) at the lines w = 100 + d (d = -lower..upper, spacing 1 rad/s) around
    the pole -half + 100j, as one measured entry."""
    d = np.arange(-lower, upper + 1)
    return 100.0 + d, np.array([[level(abs(k), k)] for k in d]), complex(-half, 100.0)


@pytest.mark.parametrize(
    "half, level, upper",
    [
        # half-power band 2 rad/s: the ring is 6 to 20 rad/s away on each side; its lines
        # 6-14 at 1 and 15-20 at 0.01 have the median 1 (the ring starts at 6, not 9)
        (1.0, lambda a, k: 1.5 if a <= 1 else (1.0 if a < 15 else 0.01), 40),
        # the same ring (6 to 20 rad/s: 3, not 1.5, half-power bands) with lines 6-13 at 1
        # and 14-20 at 0.01: its median is 1 (8 of 15 lines); the lines 2-5 at 0.01,
        # nearer than the ring, would pull a ring from 3 rad/s to 0.01 (10 of 18 lines)
        (1.0, lambda a, k: 1.5 if a <= 1 else (1.0 if 6 <= a < 14 else 0.01), 40),
        # a pole sharper than the lines: the ring is 2 to 6 lines away (not 7); lines 2-4
        # at 1 and 5-7 at 0.01 leave the median 1
        (0.1, lambda a, k: 1.5 if a == 0 else (1.0 if a < 5 else 0.01), 40),
        # the ring at 1 on both sides, every line beyond it on the upper side at 0.01:
        # those lines are no part of the ring
        (1.0, lambda a, k: 1.5 if a <= 1 else (1.0 if a <= 20 else 0.01), 200),
    ],
)
def test_a_pole_rising_less_than_twice_its_ring_is_no_peak_of_the_data(half, level, upper):
    from podid_rs.modes import PEAK_RISE, _data_peak

    assert PEAK_RISE == 2.0
    w, Ua, lam = _pole_on_a_grid(half, level, upper=upper)
    assert not _data_peak(w, Ua, np.array([True]), lam)  # 1.5 < 2 × 1
    # the same pole rising to 2.5 is a peak, and an entry not measured shows none
    Ua[np.abs(w - 100.0) <= max(half, 0.5)] = 2.5
    assert _data_peak(w, Ua, np.array([True]), lam)
    assert not _data_peak(w, Ua, np.array([False]), lam)


@pytest.mark.parametrize("below, above", [(1.0, 3.0), (3.0, 1.0)])
def test_a_resonance_beside_a_stronger_one_rises_above_the_lower_side_of_its_ring(below, above):
    """On one side of the pole the flank of a stronger resonance (3), on the other the
    data at 1: the pole's 2.5 is a peak against the lower side (2.5 ≥ 2 × 1), whichever
    side it is on — against the higher one (2 × 3 = 6) no resonance beside a stronger one
    would ever count; 1.5 rises above neither."""
    from podid_rs.modes import _data_peak

    w, Ua, lam = _pole_on_a_grid(1.0, lambda a, k: 2.5 if a <= 1 else (below if k < 0 else above))
    assert _data_peak(w, Ua, np.array([True]), lam)
    Ua[np.abs(w - 100.0) <= 1.0] = 1.5
    assert not _data_peak(w, Ua, np.array([True]), lam)


def test_the_ring_is_measured_in_the_median_line_spacing_not_the_mean():
    """Lines 1 rad/s apart from 90 to 110 and one far line at 200: the median spacing is
    1, the mean 110/21 ≈ 5.2 rad/s. A pole at 100 with |Re λ| = 0.1 has its ring from
    max(3 × 0.2, 2 × 1) = 2 to max(10 × 0.2, 6 × 1) = 6 rad/s away: lines 94–98 and
    102–106, all at 1, so 1.5 at the pole is no peak (1.5 < 2 × 1) and 2.5 is one. A ring
    from the mean spacing (10.5 to 31 rad/s away) would hold no line, and a pole with
    nothing around it counts as a peak."""
    from podid_rs.modes import _data_peak

    w = np.append(np.arange(90.0, 111.0), 200.0)
    Ua = np.ones((w.size, 1, 1), dtype=complex)
    lam = complex(-0.1, 100.0)
    Ua[w == 100.0] = 1.5
    assert not _data_peak(w, Ua, np.ones((1, 1), dtype=bool), lam)
    Ua[w == 100.0] = 2.5
    assert _data_peak(w, Ua, np.ones((1, 1), dtype=bool), lam)


def test_two_lines_size_the_ring_by_their_spacing():
    """Two lines, 100 and 101 rad/s, a pole at 100 with |Re λ| = 0.1: their one spacing
    (1 rad/s) puts the ring at 2 to 6 rad/s away, where there is no line, so there is no
    evidence against the peak; a spacing of 0 would put it at 0.6 to 2 rad/s and take in
    the line at 101, as high as the pole's own: no peak."""
    from podid_rs.modes import _data_peak

    w = np.array([100.0, 101.0])
    assert _data_peak(w, np.ones((2, 1, 1), dtype=complex), np.ones((1, 1), dtype=bool),
                      complex(-0.1, 100.0))


def test_shape_mac_needs_two_common_dofs():
    """One common DOF makes the MAC of any two shapes 1 (two complex numbers are always
    multiples of each other): it is refused; two are enough."""
    lam = np.array([-1.0 + 60.0j, -2.0 + 90.0j])
    a = ModeShapes(lam, np.array([[1.0, 0.5], [0.5, -1.0], [0.2, 0.3]], dtype=complex),
                   np.array([[1, 3], [2, 3], [3, 3]]))
    b = ModeShapes(lam, a.shapes[[0, 2]], np.array([[1, 3], [7, 3]]))
    with pytest.raises(ValueError, match=r"^the two sets of shapes share 1 \(node, direction\) "
                       r"DOF\(s\); the MAC needs at least 2 "):
        shape_mac(a, b)
    c = ModeShapes(lam, a.shapes[[0, 2]], np.array([[1, 3], [3, 3]]))
    values, used = shape_mac(a, c)
    assert used.tolist() == [[1, 3], [3, 3]]
    np.testing.assert_allclose(np.diag(values), 1.0, rtol=1e-12)


def test_a_mode_the_sensors_do_not_see_is_refused():
    # two uncoupled DOFs, the sensor on the first: the second's mode is 0 on it
    model = SecondOrderSystem(np.eye(2), np.diag([0.1, 0.2]), np.diag([100.0, 400.0]))
    with pytest.raises(ValueError, match=r"^a mode has no component on the measured DOFs "
                       r"\(R ψ = 0\)$"):
        mode_shapes(model, np.array([[1.0, 0.0]]))


def test_shape_mac_names_an_empty_set():
    modes = ModeShapes(np.array([-1.0 + 60.0j]), np.ones((3, 1), dtype=complex))
    empty = modes.select(np.array([False]))
    with pytest.raises(ValueError, match=r"^nothing to compare: 1 and 0 modes$"):
        shape_mac(modes, empty)
    # either side: an empty first set is named as such, not left to the MAC's own check
    with pytest.raises(ValueError, match=r"^nothing to compare: 0 and 1 modes$"):
        shape_mac(empty, modes)


def test_companion_modes_return_vectors_only_when_asked():
    from podid_rs.physical import companion_modes

    chain = mass_spring_chain(3)
    lam, vectors, infinite = companion_modes(chain)
    assert vectors is None and lam.size == 3 and infinite == 0
    assert companion_modes(chain, vectors=True)[1].shape == (3, 3)


def test_oscillatory_keeps_a_mode_below_one_radian_per_second():
    """A slow suspension mode (0.1 Hz: Im λ = 0.63 rad/s) is oscillatory as any other;
    only the real (overdamped) roots are left out."""
    lam = np.array([2 * np.pi * 0.1 * complex(-0.01, 1.0), -3.0 + 0j,
                    2 * np.pi * 10.0 * complex(-0.01, 1.0)])
    modes = ModeShapes(lam, np.eye(3, dtype=complex))
    assert modes.oscillatory().mode_numbers.tolist() == [1, 3]


def test_in_band_keeps_a_mode_at_either_end_of_the_band():
    lam = 2 * np.pi * np.array([10.0, 20.0, 30.0]) * complex(-0.01, np.sqrt(1 - 1e-4))
    modes = ModeShapes(lam, np.eye(3, dtype=complex))
    f = modes.frequencies_hz
    assert modes.in_band((f[0], f[1])).mode_numbers.tolist() == [1, 2]
    assert modes.in_band((f[1], f[2])).mode_numbers.tolist() == [2, 3]


def test_mode_kinds_names_the_data_of_the_wrong_shape_or_not_finite():
    from podid_rs.modes import mode_kinds

    model = SecondOrderSystem(np.eye(2), np.diag([0.5, 1.0]), np.diag([400.0, 2500.0]))
    shapes = mode_shapes(model)
    w = np.linspace(10.0, 60.0, 51)
    U = model.frf(w)[:, :, :1]
    with pytest.raises(ValueError, match=r"U must be \(s, n, p\) = \(51, 2, 1\)"):
        mode_kinds(shapes, w, U[:-1], [0])  # one line short, the DOFs right
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(51, 2, 2\)$"):
        mode_kinds(shapes, w, model.frf(w), [0])  # two load cases, one input
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(51, 3, 1\)$"):
        mode_kinds(shapes, w, np.ones((51, 3, 1)), [0])  # a third DOF the shapes lack
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(51, 1, 1\)$"):
        mode_kinds(shapes, w, U[:, :1], [0])  # one DOF short of the shapes'
    # each count too large as well as too small, and U of too few or too many dimensions
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(52, 2, 1\)$"):
        mode_kinds(shapes, w, np.ones((52, 2, 1)), [0])  # one line too many
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 2\), got "
                                         r"\(51, 2, 1\)$"):
        mode_kinds(shapes, w, U, [0, 1])  # two inputs, one load case
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(51, 2\)$"):
        mode_kinds(shapes, w, U[:, :, 0], [0])  # no load-case axis
    with pytest.raises(ValueError, match=r"^U must be \(s, n, p\) = \(51, 2, 1\), got "
                                         r"\(51, 2, 1, 1\)$"):
        mode_kinds(shapes, w, U[..., None], [0])  # one axis too many
    U[3, 0, 0] = np.nan
    with pytest.raises(ValueError, match="U contains non-finite values"):
        mode_kinds(shapes, w, U, [0])
    # a driven DOF outside the shapes' rows, past the end or negative (which NumPy would
    # read from the end: the second DOF's residue for the first's)
    for bad in ([2], [-1]):
        with pytest.raises(ValueError, match=r"^inputs must index the 2 rows of the shapes "
                                             rf"\(0 … 1\), got \{bad}$"):
            mode_kinds(shapes, w, model.frf(w)[:, :, :1], bad)


def test_mode_kinds_needs_the_lines_in_increasing_order():
    """The band is the first line to the last: lines given high to low would make every
    pole fall outside it (a residual term), so they are refused, as is a single line."""
    from podid_rs.modes import mode_kinds

    model = SecondOrderSystem(np.eye(2), np.diag([0.5, 1.0]), np.diag([400.0, 2500.0]))
    shapes = mode_shapes(model)
    w = np.linspace(10.0, 60.0, 51)
    assert mode_kinds(shapes, w).tolist() == ["structural", "structural"]  # 20, 50 rad/s
    # two lines are a band: 15 and 55 rad/s hold both poles' half-power bands
    assert mode_kinds(shapes, [15.0, 55.0]).tolist() == ["structural", "structural"]
    message = r"^omega must hold at least 2 strictly increasing lines \(rad/s\)$"
    for bad in (w[::-1], np.r_[w[:10], w[9:]], w[:1]):
        with pytest.raises(ValueError, match=message):
            mode_kinds(shapes, bad)


def test_each_entry_rises_above_its_own_ring():
    """Two entries flat at 1 and at 1e-3 around a pole at 100 rad/s (half-power half-width
    1): neither rises at the pole, so there is no peak — though the first stands above
    the second's ring a thousandfold."""
    from podid_rs.modes import _data_peak

    w = np.linspace(50.0, 150.0, 201)
    Ua = np.ones((w.size, 2, 1))
    Ua[:, 1] = 1e-3
    assert not _data_peak(w, Ua, np.ones((2, 1), dtype=bool), complex(-1.0, 100.0))


def test_companion_modes_of_equal_size_keep_the_eigensolvers_order():
    """150 uncoupled oscillators of three stiffnesses: three values of |λ|, each exactly
    shared by 50 poles. Sorted by |λ| with ties in the order scipy.linalg.eig returns
    them (a stable sort), each pole keeps its own vector; NumPy's default sort reorders
    ties among other keys, and would pair the poles with the vectors in another order."""
    import scipy.linalg

    from podid_rs.physical import companion_modes

    k = np.tile([4.0, 9.0, 16.0], 50)
    n = k.size
    lam, vectors, _ = companion_modes(SecondOrderSystem(np.eye(n), 0.1 * np.eye(n),
                                                        np.diag(k)), vectors=True)
    eye, zero = np.eye(n), np.zeros((n, n))
    all_lam, Z = scipy.linalg.eig(np.block([[zero, eye], [-np.diag(k), -0.1 * eye]]),
                                  np.block([[eye, zero], [zero, eye]]))
    pick = np.flatnonzero(all_lam.imag >= 0)
    assert pick.size == n and np.unique(np.abs(all_lam[pick])).size == 3
    order = pick[np.argsort(np.abs(all_lam[pick]), kind="stable")]
    np.testing.assert_array_equal(lam, all_lam[order])
    np.testing.assert_array_equal(vectors, Z[:n, order])


def test_an_undamped_model_is_symmetric_and_has_its_modal_constants():
    """C = 0 is symmetric (‖C − Cᵀ‖ = 0 ≤ SYMMETRY_RTOL·‖C‖ = 0): the undamped chain's
    modes get modal constants a = 2λ φᵀMφ (the C term vanishes) — here, with M = I and
    shapes (1, 1) and (1, −1), a = 4λ."""
    model = SecondOrderSystem(np.eye(2), np.zeros((2, 2)), np.array([[2.0, -1.0], [-1.0, 2.0]]))
    shapes = mode_shapes(model)
    np.testing.assert_allclose(np.abs(shapes.shapes), 1.0, rtol=1e-12)
    np.testing.assert_allclose(shapes.eigenvalues, [1j, np.sqrt(3) * 1j], rtol=1e-12)
    np.testing.assert_allclose(shapes.modal_a, 4 * shapes.eigenvalues, rtol=1e-12)


def test_a_zero_pole_has_zero_damping_not_nan():
    """A free mass (K = C = 0) has a double pole at exactly 0: frequency 0 and damping
    ratio 0 (−Re λ/|λ| is 0/0 there), without a warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        table = modal_parameters(SecondOrderSystem(np.eye(1), np.zeros((1, 1)),
                                                   np.zeros((1, 1))))
    assert np.array_equal(table.eigenvalues, [0j, 0j])
    assert np.array_equal(table.damping_ratios, [0.0, 0.0])


def test_the_visibility_window_includes_its_edges():
    """A pole at exactly 100 rad/s (half-power band ±1 rad/s: its term is seen at its
    three nearest lines 99–101), lines at 1, 2, …, 200 rad/s: its window ±VISIBLE_WINDOW
    (2 %) ends exactly on the lines 98 and 102, and includes them. A spike 100 times the
    pole's peak on line 102 sets the level the pole must reach (VISIBLE_FRACTION of it,
    10 peaks), which it reaches at none of its nearest lines: weak. Off the window's edge
    (on line 103) the spike is not in it: structural."""
    from podid_rs.modes import VISIBLE_WINDOW, mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -1.0 + 100.0j
    assert abs(102.0 - lam.imag) == VISIBLE_WINDOW * lam.imag  # exactly on the edge
    a = 2j * lam.imag
    term = 1 / (a * (1j * w - lam))
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((1, 1)),
                        modal_a=np.array([a]))
    for spike, kind in ((102.0, "weak"), (103.0, "structural")):
        U = term.copy()
        U[w == spike] = 100 * abs(term[w == 100.0])
        assert list(mode_kinds(shapes, w, U[:, None, None], inputs=[0])) == [kind]


def test_a_pole_seen_at_two_of_its_three_nearest_lines_is_a_resonance():
    """A pole midway between lines 100 and 101 rad/s (λ = −0.3 + 100.5j): its term is
    1/|0.5i + 0.3| = 1.71 (in units of 1/|a|) on both and 1/|1.5i − 0.3| = 0.65 on the
    third nearest, 99. A spike of 10 on line 102, inside the ±2 % window, sets the level
    to VISIBLE_FRACTION × 10 = 1: the pole is seen on two lines of three, which is a
    resonance (structural); a spike of 20 (level 2) leaves it seen on none: weak."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -0.3 + 100.5j
    a = 2j * lam.imag
    term = 1 / (a * (1j * w - lam))
    unit = 1 / abs(a)
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((1, 1)),
                        modal_a=np.array([a]))
    for spike, kind in ((10.0, "structural"), (20.0, "weak")):
        U = term.copy()
        U[w == 102.0] = spike * unit
        assert list(mode_kinds(shapes, w, U[:, None, None], inputs=[0])) == [kind]


def test_an_entry_that_was_not_measured_does_not_make_a_pole_visible():
    """The pole of the visibility-window test (λ = −1 + 100i, lines 1, 2, …, 200 rad/s)
    at two sensors, driven at the first. The first entry is measured: its term with a
    spike 100 times the pole's peak on line 102 (inside the ±2 % window), so the level
    (10 peaks) is reached at none of the three nearest lines. The second entry is a hole
    of the test holding zeros, where any term reaches the level 0.1 × 0: were it judged,
    the pole would be seen on every line (and the first entry's data do rise to a peak
    at it, so it would be structural). Judged on the measured entry alone it is weak."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -1.0 + 100.0j
    a = 2j * lam.imag
    term = 1 / (a * (1j * w - lam))
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((2, 1)),
                        modal_a=np.array([a]))
    U = np.zeros((w.size, 2, 1), dtype=complex)
    U[:, 0, 0] = term
    U[w == 102.0, 0, 0] = 100 * abs(term[w == 100.0])
    measured = np.array([[True], [False]])
    assert list(mode_kinds(shapes, w, U, inputs=[0], measured=measured)) == ["weak"]
    # the same data with the zeros counted as measured: seen everywhere, and a resonance
    assert list(mode_kinds(shapes, w, U, inputs=[0])) == ["structural"]
    # the mask transposed, (p, n), would broadcast against (n, p) and count both entries
    # as measured: it is refused, and so is a mask with the entries in one row
    with pytest.raises(ValueError, match=r"^measured must be \(n, p\) = \(2, 1\), got \(1, 2\)$"):
        mode_kinds(shapes, w, U, inputs=[0], measured=measured.T)
    with pytest.raises(ValueError, match=r"^measured must be \(n, p\) = \(2, 1\), got \(2,\)$"):
        mode_kinds(shapes, w, U, inputs=[0], measured=measured[:, 0])
    # and a mask of more entries than U's (a second load case U lacks): it would broadcast
    # too, against the one column of U
    with pytest.raises(ValueError, match=r"^measured must be \(n, p\) = \(2, 1\), got \(2, 2\)$"):
        mode_kinds(shapes, w, U, inputs=[0], measured=np.ones((2, 2), dtype=bool))
    # a mask given as a list (array_like) is named by the shape it has as an array
    with pytest.raises(ValueError, match=r"^measured must be \(n, p\) = \(2, 1\), got \(1, 2\)$"):
        mode_kinds(shapes, w, U, inputs=[0], measured=[[True, False]])


def test_the_mac_of_a_shape_with_itself_is_at_most_one():
    """|aᴴa|² / (aᴴa)² is 1, but computed in floating point it can come out a unit of
    round-off above it; MAC values are clipped to [0, 1]. 200 random complex shapes: 1 to
    1e-15 (a few units of round-off), never above."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((7, 200)) + 1j * rng.standard_normal((7, 200))
    values = mac(a, a)
    assert values.max() <= 1.0
    np.testing.assert_allclose(np.diag(values), 1.0, rtol=0, atol=1e-15)


def test_residual_damping_ratio_is_inclusive():
    """λ = 8(−0.6 + 0.8i): |λ| = 8 and ζ = 0.6 exactly in binary; its half-power band
    6.4 ± 4.8 rad/s lies inside the lines 1 … 12 rad/s. At residual_zeta = 0.6 it is a
    residual term (ζ ≥ the threshold), just above it a structural mode."""
    from podid_rs.modes import mode_kinds

    shapes = ModeShapes(np.array([8 * complex(-0.6, 0.8)]), np.ones((1, 1)))
    assert shapes.damping_ratios.tolist() == [0.6]
    w = np.arange(1.0, 13.0)
    assert list(mode_kinds(shapes, w, residual_zeta=0.6)) == ["residual"]
    assert list(mode_kinds(shapes, w, residual_zeta=0.6000001)) == ["structural"]


def test_a_zero_pole_is_residual_even_on_a_line_at_zero():
    """A band that starts at 0 rad/s (a static line): a pole λ = 0 sits on it with a
    half-power band of zero width, inside the band, and ζ = 0; it is still a real root,
    no mode."""
    from podid_rs.modes import mode_kinds

    shapes = ModeShapes(np.array([0j, 1j]), np.ones((1, 2)))
    assert list(mode_kinds(shapes, np.linspace(0.0, 2.0, 21))) == ["residual", "structural"]


def test_a_sharp_poles_ring_is_two_to_six_lines_away():
    """A pole 0.1 rad/s from the axis on lines 1 rad/s apart: its ring is the lines 2 to 6
    away (PEAK_RING half-power bands are 0.6 and 2 rad/s, under the lines' minimum). The
    data: 1.2 at the pole, 10 one line away, 1 two and three lines away, 0.5 four to six
    lines away and 100 beyond. The ring's median is 0.5 and 1.2 ≥ 2 × 0.5 a peak; a ring
    from the first line (median 0.75), to the third (median 1) or to the seventh (median
    0.75) would leave none."""
    from podid_rs.modes import _data_peak

    def level(a, k):
        return {0: 1.2, 1: 10.0, 2: 1.0, 3: 1.0, 4: 0.5, 5: 0.5, 6: 0.5}.get(a, 100.0)

    w, Ua, lam = _pole_on_a_grid(0.1, level)
    assert _data_peak(w, Ua, np.array([True]), lam)


def test_a_line_at_the_edge_of_the_half_power_band_is_part_of_the_peak():
    """Half-power band 99 … 101 rad/s on lines 1 rad/s apart: the lines at 99 and 101 are
    in it (ends included). The data: 2.5 at those two, 1 everywhere else — a peak only if
    the band's ends count (at the pole's own line 1 is no rise over the ring's 1)."""
    from podid_rs.modes import _data_peak

    w, Ua, lam = _pole_on_a_grid(1.0, lambda a, k: 2.5 if a == 1 else 1.0)
    assert _data_peak(w, Ua, np.array([True]), lam)


@pytest.mark.parametrize(
    "w, lam",
    [
        (np.array([99.0, 100.0, 101.0]), complex(-0.1, 100.0)),  # the ring: 2 to 6 lines away
        (np.array([100.0]), 100j),  # one line, at an undamped pole: not its own ring
    ],
)
def test_a_pole_with_no_line_in_its_ring_is_not_judged(w, lam):
    """No line in the ring on either side: no evidence against a peak (a flat response
    passes). One line has no spacing: it counts as 0, not as numpy's median of no
    differences (nan, with a RuntimeWarning), so no warning is raised."""
    from podid_rs.modes import _data_peak

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _data_peak(w, np.ones((w.size, 1)), np.array([True]), lam)


def test_shape_mac_with_labels_on_one_side_only_compares_the_rows_as_they_are():
    labelled = ModeShapes(np.array([1j, 2j]), np.array([[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
                          dofs=np.array([[1, 3], [2, 3], [3, 3]]))
    bare = ModeShapes(np.array([1j]), np.array([[1.0], [1.0], [0.0]]))
    for a, b in ((labelled, bare), (bare, labelled)):
        values, dofs = shape_mac(a, b)
        assert dofs is None
        np.testing.assert_array_equal(values, mac(a.shapes, b.shapes))
    # the rows by hand: (1, 1, 0) against itself 1, against (0, 1, 1) 1/4
    np.testing.assert_allclose(shape_mac(labelled, bare)[0], [[1.0], [0.25]], rtol=1e-15)


def test_without_modal_constants_the_data_are_not_consulted():
    """The shapes of a model that is not symmetric have no modal_a: no term to compare
    with the data, so a pole is judged on its band and damping alone: a lightly damped
    pole at 50 rad/s (its term 0.02 at its line) that flat data of 1 would show weak."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -0.5 + 50j
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((1, 1), dtype=complex),
                        modal_a=np.array([2j * lam.imag]))
    flat = np.ones((w.size, 1, 1), dtype=complex)
    assert list(mode_kinds(shapes, w, flat, inputs=[0])) == ["weak"]
    bare = ModeShapes(eigenvalues=shapes.eigenvalues, shapes=shapes.shapes)
    assert list(mode_kinds(bare, w, flat, inputs=[0])) == ["structural"]


def test_shape_mac_refuses_anything_but_two_mode_shapes_on_either_side():
    lam = np.array([-1.0 + 60.0j, -2.0 + 90.0j])
    a = ModeShapes(lam, np.array([[1.0, 0.5], [0.5, -1.0], [0.2, 0.3]], dtype=complex),
                   np.array([[1, 3], [2, 3], [3, 3]]))
    for left, right in ((a, a.shapes), (a.shapes, a), (a.shapes, a.shapes)):
        with pytest.raises(ValueError, match=r"^shape_mac compares two ModeShapes"):
            shape_mac(left, right)


def test_a_selection_of_a_selection_keeps_the_original_numbers():
    """Numbers survive a second selection: of modes 1–4, oscillatory() drops the real
    root (mode 2) and in_band() then the 10 Hz mode (mode 1). The survivors are modes 3
    and 4 of the model, not the 2nd and 3rd of the first selection — counting from the
    selection at hand would say [2, 3]."""
    lam = np.array([2 * np.pi * 10.0 * complex(-0.01, 1.0), -3.0 + 0j,
                    2 * np.pi * 20.0 * complex(-0.01, 1.0), 2 * np.pi * 30.0 * complex(-0.01, 1.0)])
    modes = ModeShapes(lam, np.eye(4, dtype=complex), modal_a=np.array([1.0, 2.0, 3.0, 4.0]))
    twice = modes.oscillatory().in_band((15.0, 35.0))
    assert twice.mode_numbers.tolist() == [3, 4]
    assert twice.modal_a.tolist() == [3.0, 4.0]
    np.testing.assert_array_equal(twice.eigenvalues, lam[[2, 3]])


def test_modal_a_of_a_non_proportionally_damped_model_is_a_residue_model():
    """A dashpot at one end of a 3-DOF chain (C not a combination of M and K) gives
    complex modes: their shapes are not real multiples of a real vector, so the modal
    constants a = ψᵀ(2λM + C)ψ need the plain transpose (not ψᴴ). With a 4 × 3 basis
    (orthonormal columns, not the identity) the poles' residues Σ φφᵀ/(a(iω − λ)) plus
    conjugates must give R H(ω) Rᵀ of the model's own receptance. The model is exact:
    the sum agrees to round-off of the eigensolver (1e-10 of its largest entry is ample)."""
    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[300.0, -100.0, 0.0], [-100.0, 250.0, -150.0], [0.0, -150.0, 150.0]])
    C = np.diag([0.0, 0.0, 4.0])
    model = SecondOrderSystem(M, C, K)
    R = np.linalg.qr(np.random.default_rng(3).standard_normal((4, 3)))[0]
    modes = mode_shapes(model, R)
    assert modes.modal_a is not None and np.all(modes.eigenvalues.imag > 0)
    # the shapes really are complex (non-proportional damping), the case the test is for
    assert np.max(np.abs(modes.shapes.imag)) > 1e-3
    omega = np.linspace(1.0, 30.0, 60)
    s = 1j * omega[:, None, None]
    terms = np.einsum("ak,bk->kab", modes.shapes, modes.shapes) / modes.modal_a[:, None, None]
    H = sum(terms[k] / (s - lam) + terms[k].conj() / (s - lam.conj())
            for k, lam in enumerate(modes.eigenvalues))
    H_n = np.einsum("am,smk,bk->sab", R, model.frf(omega), R)
    assert np.max(np.abs(H - H_n)) < 1e-10 * np.max(np.abs(H_n))


def test_a_hole_holding_zeros_is_no_peak_of_the_data():
    """The pole λ = −1 + 100i at two sensors, the second a hole holding zeros (as
    MeasuredData keeps them). The measured entry is flat at the term's own peak value:
    the pole is visible there (its term reaches the level at all three nearest lines)
    but the data do not rise (1 < 2 × 1) — weak. The hole's zeros "rise" (0 ≥ 2 × 0):
    judged there too, the peak test would call the pole a resonance of the data."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = -1.0 + 100.0j
    a = 2j * lam.imag
    shapes = ModeShapes(eigenvalues=np.array([lam]), shapes=np.ones((2, 1)),
                        modal_a=np.array([a]))
    U = np.zeros((w.size, 2, 1), dtype=complex)
    U[:, 0, 0] = 1 / abs(a)  # the term's modulus at its own line, 1 / |a · 1|
    measured = np.array([[True], [False]])
    assert list(mode_kinds(shapes, w, U, inputs=[0], measured=measured)) == ["weak"]
    assert list(mode_kinds(shapes, w, U, inputs=[0])) == ["structural"]


def test_a_sharp_poles_ring_is_counted_in_the_lines_usual_spacing():
    """Lines 60, 61, …, 140 rad/s and one stray line at 1 rad/s: their spacing is 1 rad/s
    (the median), not the first gap of 59. A pole 0.1 rad/s from the axis at 100 rad/s
    has its ring 2 to 6 lines away, where the flat data equal the pole's: no peak. With
    the first gap as the spacing the ring would start 118 rad/s away, hold no line, and
    the pole would go unjudged (a peak by default)."""
    from podid_rs.modes import _data_peak

    w = np.r_[1.0, np.arange(60.0, 141.0)]
    assert not _data_peak(w, np.ones((w.size, 1)), np.array([True]), complex(-0.1, 100.0))


def test_a_term_exactly_at_the_visibility_level_is_seen():
    """λ = −1 + 100i on lines 1, 2, …, 200 rad/s, a = 2i·Im λ, one sensor, driven. The
    term 1/|a(iω − λ)| is 1/200 on line 100 and c = 1/(200√2) on lines 99 and 101
    (computed here as the code does, so equal to the last bit). The data: 2c on the lines
    within ±2 % (98–102), c/10 elsewhere; with visible_fraction = 1/2 the level is exactly
    c (products by powers of two are exact), which the term reaches at all three nearest
    lines (the level included), and the data rise from c/10 to 2c: structural. A strict
    level would see the pole at line 100 alone and call it weak."""
    from podid_rs.modes import mode_kinds

    w = np.arange(1.0, 201.0)
    lam = np.complex128(-1.0 + 100.0j)
    a = np.complex128(2j * lam.imag)
    c = 1.0 / abs(a * (1j * 99.0 - lam))
    assert c == 1.0 / abs(a * (1j * 101.0 - lam)) < 1.0 / abs(a * (1j * 100.0 - lam))
    shapes = ModeShapes(np.array([lam]), np.ones((1, 1)), modal_a=np.array([a]))
    U = np.full((w.size, 1, 1), c / 10, dtype=complex)
    U[np.abs(w - 100.0) <= 2.0] = 2 * c
    assert list(mode_kinds(shapes, w, U, [0], visible_fraction=0.5)) == ["structural"]
