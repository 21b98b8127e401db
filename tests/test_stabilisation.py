"""Stabilisation chart over the POD order (podid_rs.stabilisation).

The marking logic is tested on models built with known poles (so every mark is
known exactly); the default fit on exact chain FRFs, where the full-order model
must recover the chain (frequencies to 1e-7, as in test_cli_identify).
"""

from __future__ import annotations

import csv
import re
import warnings

import numpy as np
import pytest

from podid_rs import IdentificationResult, mass_spring_chain, modal_parameters
from podid_rs.measured import from_frf
from podid_rs.plotting import plot_stabilisation
from podid_rs.stabilisation import (
    F_TOL,
    ZETA_TOL,
    is_physical,
    stabilisation_chart,
)

PNG = b"\x89PNG\r\n\x1a\n"


def model_with_modes(f_hz, zeta) -> IdentificationResult:
    """A diagonal (modal) model with natural frequencies f_hz and damping ratios zeta."""
    w = 2 * np.pi * np.asarray(f_hz, dtype=float)
    z = np.broadcast_to(np.asarray(zeta, dtype=float), w.shape)
    m = w.size
    return IdentificationResult(
        M=np.eye(m), C=np.diag(2 * z * w), K=np.diag(w**2), lam=(0.0, 0.0, 0.0),
        symmetric=True, residual_norm=0.0, penalty_norms=(0.0, 0.0, 0.0), method="test",
        rank=m, n_unknowns=m, min_pivot_ratio=1.0, backend="test",
    )


@pytest.fixture(scope="module")
def chain_data():
    chain = mass_spring_chain(6)
    omega = 2 * np.pi * np.linspace(1.0, 200.0, 400)
    return chain, from_frf(chain.frf(omega)[:, :, [1, 4]], omega, inputs=[1, 4])


def test_an_unstable_pole_keeps_its_signs_in_the_rows(chain_data):
    """A one-mode model at 10 Hz with ζ = −0.01 (C = 2ζω < 0): λ = ω(0.01 ± i√(1 − 1e-4)),
    so the row reports ζ = −0.01 and Re λ = +0.01 · 2π · 10 rad/s, not stable. rel 1e-9:
    the 2 × 2 pencil's eigenvalues round at ~1e-15 of |λ| = 62.8 rad/s."""
    _, data = chain_data
    chart = stabilisation_chart(data, 1, fit=lambda m: model_with_modes([10.0], -0.01),
                                progress=False)
    (row,) = chart.rows()
    assert row["zeta"] == pytest.approx(-0.01, rel=1e-9)
    assert row["re_lambda"] == pytest.approx(0.01 * 2 * np.pi * 10.0, rel=1e-9)
    assert row["stable"] is False


def test_is_physical():
    good = model_with_modes([10.0, 20.0], 0.02)
    assert is_physical(good)
    from dataclasses import replace

    assert not is_physical(replace(good, K=np.diag([1.0, -1.0])))
    assert not is_physical(replace(good, C=np.diag([1.0, -1e-3])))
    assert not is_physical(replace(good, M=np.array([[1.0, 0.1], [0.0, 1.0]])))
    assert is_physical(replace(good, C=np.zeros((2, 2))))  # undamped is passive


def test_marks_follow_the_stated_tolerances(chain_data):
    _, data = chain_data
    base = [10.0, 20.0, 40.0, 80.0]

    def fit(m: int) -> IdentificationResult:
        # order m: the first m poles; order 3 moves pole 1 by half the frequency
        # tolerance and its damping by twice the damping tolerance
        f, z = np.array(base[:m]), np.full(m, 0.02)
        if m == 3:
            f[0] *= 1 + F_TOL / 2
            z[0] *= 1 + 2 * ZETA_TOL
        if m == 4:
            f[1] *= 1 + 2 * F_TOL
        return model_with_modes(f, z)

    chart = stabilisation_chart(data, 4, fit=fit, chosen_m=3, progress=False)
    assert [o.m for o in chart.orders] == [1, 2, 3, 4] and chart.chosen_m == 3
    # the chart keeps the tolerances it marked with, each under its name (the plot's
    # legend states them)
    assert (chart.f_tol, chart.zeta_tol) == (F_TOL, ZETA_TOL) == (0.01, 0.05)
    cf = [o.consistent_f.tolist() for o in chart.orders]
    c = [o.consistent.tolist() for o in chart.orders]
    assert cf == [[False], [True, False], [True, True, False], [True, False, True, False]]
    assert c == [[False], [True, False], [False, True, False], [False, False, True, False]]
    assert all(o.physical and o.stable.all() for o in chart.orders)
    rows = chart.rows()
    assert len(rows) == 10 and sum(r["chosen"] for r in rows) == 3
    assert np.allclose([r["f_hz"] for r in rows if r["m"] == 4], [10.0, 20.4, 40.0, 80.0])
    # three times either tolerance: order 4's pole 2 (moved 2 %) is within 3 % in frequency,
    # order 3's pole 1 (damping moved 10 %) within 15 % in damping
    loose = stabilisation_chart(data, 4, fit=fit, f_tol=3 * F_TOL, zeta_tol=3 * ZETA_TOL,
                                progress=False)
    assert (loose.f_tol, loose.zeta_tol) == (3 * F_TOL, 3 * ZETA_TOL)
    assert loose.orders[3].consistent_f.tolist() == [True, True, True, False]
    assert loose.orders[2].consistent.tolist() == [True, True, False]


def test_default_fit_recovers_the_chain_at_full_order(chain_data, tmp_path, capsys):
    chain, data = chain_data
    chart = stabilisation_chart(data, 6, chosen_m=6)
    assert capsys.readouterr().err == ""  # not a terminal: no progress bar
    full = chart.order(6)
    truth = modal_parameters(chain)
    assert full.physical and full.stable.all() and full.oscillatory.all()
    assert np.allclose(full.modes.frequencies_hz, truth.frequencies_hz, rtol=1e-7)
    assert np.allclose(full.modes.damping_ratios, truth.damping_ratios, rtol=1e-6)
    path = chart.to_csv(tmp_path / "stabilisation.csv")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == sum(o.modes.eigenvalues.size for o in chart.orders)
    assert {"m", "mode", "f_hz", "zeta", "stable", "physical", "consistent"} <= set(rows[0])
    back = [float(r["f_hz"]) for r in rows if r["m"] == "6"]
    assert np.array_equal(back, full.modes.frequencies_hz)
    png = plot_stabilisation(chart, tmp_path / "stab.png", quantity="acceleration")
    assert png.read_bytes()[:8] == PNG


def test_bad_input_is_named(chain_data):
    _, data = chain_data
    with pytest.raises(ValueError, match=r"m_max must be in \[1, 6\]"):
        stabilisation_chart(data, 7, progress=False)
    with pytest.raises(ValueError, match="must return an IdentificationResult of order 2"):
        stabilisation_chart(data, 3, fit=lambda m: model_with_modes([10.0], 0.01),
                            progress=False)

    def failing(m: int) -> IdentificationResult:
        raise ValueError("too few equations")

    with pytest.raises(ValueError, match="order m = 1: too few equations"):
        stabilisation_chart(data, 2, fit=failing, progress=False)
    with pytest.raises(ValueError, match="fit must be a callable"):
        stabilisation_chart(data, 2, fit="lscf", progress=False)
    with pytest.raises(ValueError, match="data must be a MeasuredData"):
        stabilisation_chart(data.U, 2)
    for name in ("f_tol", "zeta_tol"):
        with pytest.raises(ValueError, match=rf"^{name} must be a positive number, got 0$"):
            stabilisation_chart(data, 2, progress=False, **{name: 0})


def test_every_bad_input_is_refused_with_its_whole_message(chain_data):
    """Each of stabilisation_chart's messages word for word, and the edges: m_max up to
    the data's DOFs without a fit and beyond them with one; m_min = m_max and
    chosen_m = 1 accepted; a fit's MemoryError keeps its type and gains the order."""
    _, data = chain_data
    diagonal = lambda m: model_with_modes(10.0 * np.arange(1, m + 1), 0.01)  # noqa: E731
    cases = [
        ((data.U, 2), {}, "data must be a MeasuredData, got ndarray"),
        ((data, 2), {"m_min": 0}, "m_min must be >= 1, got 0"),
        ((data, 2), {"m_min": 1.0}, "m_min must be an integer, got 1.0"),
        ((data, 7), {}, "m_max must be in [1, 6], got 7"),
        ((data, 2), {"m_min": 3}, "m_max must be in [3, 6], got 2"),
        ((data, 2), {"f_tol": -0.1}, "f_tol must be a positive number, got -0.1"),
        ((data, 2), {"zeta_tol": "x"}, "zeta_tol must be a numeric array"),
        ((data, 2), {"chosen_m": 0}, "chosen_m must be >= 1, got 0"),
        ((data, 2), {"chosen_m": True}, "chosen_m must be an integer, got True"),
        ((data, 2), {"fit": "lscf"},
         "fit must be a callable fit(m) -> IdentificationResult, got 'lscf'"),
        ((data, 2), {"fit": lambda m: diagonal(m + 1)},
         "fit(1) must return an IdentificationResult of order 1, got IdentificationResult"),
        ((data, 2), {"fit": lambda m: "a model"},
         "fit(1) must return an IdentificationResult of order 1, got 'a model'"),
        # a wrong order between m_min and m_max: the order asked for, named twice
        ((data, 4), {"m_min": 2, "fit": lambda m: diagonal(m + 1 if m == 3 else m)},
         "fit(3) must return an IdentificationResult of order 3, got IdentificationResult"),
    ]
    for args, kwargs, message in cases:
        with pytest.raises(ValueError, match=f"^{re.escape(message)}"):
            stabilisation_chart(*args, progress=False, **kwargs)

    def out_of_memory(m: int) -> IdentificationResult:
        raise MemoryError("the normal matrix needs 9 GB")

    with pytest.raises(MemoryError, match=r"^stabilisation chart, order m = 2: the normal "
                                          r"matrix needs 9 GB$"):
        stabilisation_chart(data, 3, m_min=2, fit=out_of_memory, progress=False)
    assert [o.m for o in stabilisation_chart(data, 6, m_min=6, progress=False).orders] == [6]

    def fails_at_three(m: int) -> IdentificationResult:
        if m == 3:
            raise ValueError("too few equations")
        return diagonal(m)

    # an order between m_min and m_max: the message names the order that failed
    with pytest.raises(ValueError, match=r"^stabilisation chart, order m = 3: too few "
                                         r"equations$"):
        stabilisation_chart(data, 4, m_min=2, fit=fails_at_three, progress=False)
    chart = stabilisation_chart(data, 8, m_min=7, fit=diagonal, progress=False, chosen_m=1)
    assert [o.m for o in chart.orders] == [7, 8] and chart.chosen_m == 1


def test_pod_fit_is_eq_49_on_the_given_basis(chain_data):
    from podid_rs import identify, pod_from_frf
    from podid_rs.stabilisation import pod_fit

    _, data = chain_data
    U3, F3 = data.project(data.pod().basis(3))
    # default: the exactly symmetric limit with λ = 0 on the data's own POD
    expected = identify(U3, F3, data.omega, 0.0, True)
    got = pod_fit(data)(3)
    np.testing.assert_array_equal(got.K, expected.K)
    assert got.symmetric and got.lam == (0.0, 0.0, 0.0)
    # lam and symmetric reach the estimator
    plain = pod_fit(data, lam=2.0, symmetric=False)(3)
    np.testing.assert_array_equal(plain.K, identify(U3, F3, data.omega, 2.0, False).K)
    # a given basis is used as it is: here the POD of only the first half of the lines
    half = pod_from_frf(data.U[:200], data.omega[:200])
    assert not np.allclose(np.abs(half.basis(3)), np.abs(data.pod().basis(3)), atol=1e-3)
    Uh, Fh = data.project(half.basis(3))
    np.testing.assert_array_equal(pod_fit(data, basis=half)(3).K,
                                  identify(Uh, Fh, data.omega, 0.0, True).K)
    # spectra with complex forces (FRF data have the real identity): the same receptances
    # with each line's forces and responses turned by its own phase. The forces reach the
    # estimator with their phase; without it the fit would be of other data
    from dataclasses import replace

    phase = np.exp(1j * np.linspace(0.3, 2.5, data.s))[:, None, None]
    turned = replace(data, U=phase * data.U, F=phase * data.F)
    Ut, Ft = turned.project(turned.pod().basis(3))
    assert np.max(np.abs(Ft.imag)) > 0.5 * np.max(np.abs(Ft))
    np.testing.assert_array_equal(pod_fit(turned)(3).K,
                                  identify(Ut, Ft, data.omega, 0.0, True).K)


def test_pole_marks_at_their_boundaries_and_the_charts_band(chain_data):
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import StabilisationOrder

    # an undamped mode (Re λ = 0) is not stable; a real root (Im λ = 0) is not a mode
    lam = np.array([-1.0 + 5.0j, 0.0 + 7.0j, -3.0 + 0.0j])
    modes = ModalParameters(lam, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), 0)
    order = StabilisationOrder(3, model_with_modes([1.0, 2.0, 3.0], 0.01), modes, True,
                               np.ones(3, bool), np.ones(3, bool))
    assert order.stable.tolist() == [True, False, True]
    assert order.oscillatory.tolist() == [True, True, False]

    _, data = chain_data
    chart = stabilisation_chart(data, 2)
    assert chart.band_hz == (data.freq_hz[0], data.freq_hz[-1]) == (1.0, 200.0)


def test_a_chart_without_orders_writes_its_header_alone(tmp_path):
    from podid_rs.stabilisation import StabilisationChart

    chart = StabilisationChart((), np.array([1.0, 2.0]), np.ones(2), True, 0.01, 0.05)
    assert chart.rows() == []
    assert chart.to_csv(tmp_path / "empty.csv").read_bytes() == b"m\r\n"  # csv ends rows with CR LF


def test_the_rows_of_a_chart_by_hand():
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import StabilisationChart, StabilisationOrder

    lam = np.array([-1.0 + 5.0j, 0.0 + 7.0j, -3.0 + 0.0j])
    modes = ModalParameters(lam, np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam), 0)
    order = StabilisationOrder(3, model_with_modes([1.0, 2.0, 3.0], 0.01), modes, True,
                               np.array([True, False, True]), np.array([False, False, True]))
    chart = StabilisationChart((order,), np.array([0.5, 1.0]), np.ones(2), True, 0.01, 0.05,
                               chosen_m=3)
    rows = chart.rows()
    assert list(rows[0]) == ["m", "mode", "f_hz", "zeta", "re_lambda", "im_lambda", "stable",
                             "physical", "consistent_f", "consistent", "real_pole", "in_band",
                             "chosen"]
    assert [r["mode"] for r in rows] == [1, 2, 3]
    # f = |λ| / 2π and ζ = −Re λ / |λ| of each pole: √26, 7 and 3 rad/s
    assert [r["f_hz"] for r in rows] == pytest.approx(
        [np.sqrt(26) / (2 * np.pi), 7 / (2 * np.pi), 3 / (2 * np.pi)], rel=1e-15)
    assert [r["zeta"] for r in rows] == pytest.approx([1 / np.sqrt(26), 0.0, 1.0], rel=1e-15)
    assert [r["im_lambda"] for r in rows] == [5.0, 7.0, 0.0]
    assert [r["re_lambda"] for r in rows] == [-1.0, 0.0, -3.0]
    assert [r["stable"] for r in rows] == [True, False, True]
    assert [r["consistent_f"] for r in rows] == [True, False, True]
    assert [r["consistent"] for r in rows] == [False, False, True]
    assert [r["real_pole"] for r in rows] == [False, False, True]
    # f = |λ| / 2π: 0.81, 1.11 and 0.48 Hz against the band 0.5-1 Hz
    assert [r["in_band"] for r in rows] == [True, False, False]
    assert all(r["chosen"] and r["physical"] and r["m"] == 3 for r in rows)
    from dataclasses import replace

    unphysical = replace(chart, orders=(replace(order, physical=False),))
    assert [r["physical"] for r in unphysical.rows()] == [False, False, False]


def test_damping_may_be_semidefinite_to_the_tolerance_of_its_largest_eigenvalue():
    from dataclasses import replace

    from podid_rs.stabilisation import PHYSICAL_RTOL

    good = model_with_modes([10.0, 20.0], 0.02)
    assert is_physical(replace(good, C=np.diag([1.0, 0.0])))  # one undamped direction
    assert is_physical(replace(good, C=np.diag([1.0, -0.5 * PHYSICAL_RTOL])))
    assert not is_physical(replace(good, C=np.diag([1.0, -2.0 * PHYSICAL_RTOL])))


def test_the_damping_tolerance_is_relative_to_the_damping_not_to_the_mass():
    """C's smallest eigenvalue may be rtol × C's largest below 0, whatever M's size: with
    C = diag(1, −ε) the verdict is the same for a mass 10⁴ times smaller or larger than C
    (each ε a factor 2 inside or outside rtol × 1, so the mass's scale would flip it)."""
    from dataclasses import replace

    from podid_rs.stabilisation import PHYSICAL_RTOL

    good = model_with_modes([10.0, 20.0], 0.02)
    for mass in (1e-4, 1e4):
        assert is_physical(replace(good, M=mass * np.eye(2),
                                   C=np.diag([1.0, -0.5 * PHYSICAL_RTOL]))), mass
        assert not is_physical(replace(good, M=mass * np.eye(2),
                                       C=np.diag([1.0, -2.0 * PHYSICAL_RTOL]))), mass


def test_a_pole_at_either_tolerance_exactly_is_consistent():
    # |1.5 - 1| = 0.5 × 1 Hz and |0.75 - 0.5| = 0.5 × 0.5: both exact in binary
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    def modes(f, z):
        return ModalParameters(np.array([-1.0 + 1.0j]), np.array([f]), np.array([z]), 0)

    cf, c = _match_previous(modes(1.5, 0.75), modes(1.0, 0.5), 0.5, 0.5)
    assert cf.tolist() == [True] and c.tolist() == [True]
    cf, c = _match_previous(modes(1.5, 0.76), modes(1.0, 0.5), 0.5, 0.5)
    assert cf.tolist() == [True] and c.tolist() == [False]


def test_the_frequency_tolerance_is_relative_to_the_previous_orders_pole():
    # |Δf| = 0.5 Hz both ways, f_tol = 0.4: 0.4 × 1 Hz = 0.4 < 0.5 (a pole moving up from
    # 1 Hz to 1.5 Hz is not consistent) but 0.4 × 1.5 Hz = 0.6 > 0.5 (one moving down from
    # 1.5 Hz to 1 Hz is); relative to the new pole the verdicts would swap. The margins
    # (0.1 Hz) are far above rounding.
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    def modes(f):
        return ModalParameters(np.array([-1.0 + 1.0j]), np.array([f]), np.array([0.5]), 0)

    cf, c = _match_previous(modes(1.5), modes(1.0), 0.4, 0.5)
    assert cf.tolist() == [False] and c.tolist() == [False]
    cf, c = _match_previous(modes(1.0), modes(1.5), 0.4, 0.5)
    assert cf.tolist() == [True] and c.tolist() == [True]


def test_the_nearest_previous_pole_is_nearest_in_hz_not_in_log_frequency():
    """Previous poles at 0.995 Hz (ζ = 0.02) and 1.00501 Hz (ζ = 0.04), a new pole at 1 Hz
    with ζ = 0.02: in Hz the lower one is nearer (0.005 < 0.00501), so the pole is
    consistent in damping too; in log-frequency the upper one is (ln(1/0.995) = 0.0050125 >
    ln 1.00501 = 0.0049975), whose ζ is 100 % off. The margins (1e-5 Hz) are far above
    rounding; both previous poles are within f_tol = 1 %."""
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    def modes(f, z):
        lam = np.array([-1.0 + 1.0j] * len(f))
        return ModalParameters(lam, np.array(f), np.array(z), 0)

    cf, c = _match_previous(modes([1.0], [0.02]), modes([0.995, 1.00501], [0.02, 0.04]),
                            0.01, 0.05)
    assert cf.tolist() == [True] and c.tolist() == [True]


def test_the_chart_sums_the_data_per_line_and_names_a_bad_chosen_order(chain_data):
    _, data = chain_data
    chart = stabilisation_chart(data, 2, progress=False, chosen_m=2)
    assert np.array_equal(chart.summed_frf, np.sum(np.abs(data.U), axis=(1, 2)))
    assert chart.chosen_m == 2
    with pytest.raises(ValueError, match=r"^chosen_m must be"):
        stabilisation_chart(data, 2, progress=False, chosen_m=0)
    assert stabilisation_chart(data, 2, progress=False, chosen_m=1).chosen_m == 1  # the least


@pytest.mark.parametrize("m_min", [1, 2])
def test_progress_counts_the_orders_on_a_terminal(chain_data, monkeypatch, m_min):
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    screen = Terminal()
    monkeypatch.setattr(sys, "stderr", screen)
    stabilisation_chart(chain_data[1], 3, m_min=m_min, progress=True)
    # tqdm pads a line with blanks to the length of the one it overwrites (the rate's
    # width varies): the bar's text is the last line without them
    last = screen.getvalue()[:-1].split("\r")[-1].rstrip(" ")
    orders = 3 - m_min + 1  # m_min … 3: the bar's total is the orders fitted, not m_max
    assert last.startswith("stabilisation: 100%") and f"| {orders}/{orders} [" in last
    assert last.endswith(", m = 3]")  # the order last fitted, in the bar's postfix
    # each order's postfix is drawn as its fit starts, k orders done before it: the bar
    # names every order in turn, not the last one throughout
    drawn = {(int(done), int(m)) for done, m in
             re.findall(r"\| (\d+)/\d+ \[[^\]]*, m = (\d+)\]", screen.getvalue())}
    assert all((m - m_min, m) in drawn for m in range(m_min, 4))


def test_no_progress_bar_when_asked_for_none_even_on_a_terminal(chain_data, monkeypatch):
    """progress=False silences the bar where it would otherwise be drawn (a terminal)."""
    import io
    import sys

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    screen = Terminal()
    monkeypatch.setattr(sys, "stderr", screen)
    assert len(stabilisation_chart(chain_data[1], 2, progress=False).orders) == 2
    assert screen.getvalue() == ""


def test_symmetry_is_judged_relative_to_each_matrix_size():
    """‖X − Xᵀ‖ ≤ rtol ‖X‖: a stiffness of 10⁸ N/m asymmetric by 10⁻¹² of itself (the
    round-off of its assembly) is symmetric; a mass of 10⁻⁶ kg asymmetric by 10⁻⁶ of
    itself is not."""
    from dataclasses import replace

    good = model_with_modes([10.0, 20.0], 0.02)
    skew = np.array([[0.0, 1.0], [0.0, 0.0]])
    K = 1e8 * np.array([[2.0, -1.0], [-1.0, 2.0]])
    assert is_physical(replace(good, K=K + 1e-12 * np.linalg.norm(K) * skew))
    assert not is_physical(replace(good, M=1e-6 * np.eye(2) + 1e-12 * skew))


def test_every_matrix_must_be_symmetric_its_definite_symmetric_part_is_not_enough():
    """A damping or a stiffness with a skew part (circulatory forces: a follower load, a
    rotor's cross-coupled bearings) is not a passive structure's, even when its symmetric
    part is positive definite; each of C and K is judged on its own. The skew parts are
    1 % of the matrix (2-norm), ten orders above PHYSICAL_RTOL."""
    from dataclasses import replace

    good = model_with_modes([10.0, 20.0], 0.02)
    skew = np.array([[0.0, 1.0], [-1.0, 0.0]])
    for name in ("M", "C", "K"):
        X = getattr(good, name)
        Y = X + 0.01 * np.linalg.norm(X, 2) * skew
        assert np.linalg.eigvalsh(0.5 * (Y + Y.T)).min() > 0  # its symmetric part: X's
        bent = replace(good, **{name: Y})
        assert not is_physical(bent), name


def test_a_fits_warnings_are_the_orders_notes(chain_data):
    _, data = chain_data

    def warning_fit(m: int) -> IdentificationResult:
        warnings.warn(f"order {m} is only a test", UserWarning, stacklevel=2)
        return model_with_modes([10.0 * (k + 1) for k in range(m)], 0.02)

    chart = stabilisation_chart(data, 2, fit=warning_fit, progress=False)
    assert [o.notes for o in chart.orders] == [("order 1 is only a test",),
                                               ("order 2 is only a test",)]


def test_every_warning_of_a_fit_is_a_note_in_the_order_it_was_raised(chain_data):
    _, data = chain_data

    def two_warnings_fit(m: int) -> IdentificationResult:
        warnings.warn(f"order {m}: first", UserWarning, stacklevel=2)
        warnings.warn(f"order {m}: second", RuntimeWarning, stacklevel=2)
        return model_with_modes([10.0 * (k + 1) for k in range(m)], 0.02)

    chart = stabilisation_chart(data, 1, fit=two_warnings_fit, progress=False)
    assert chart.orders[0].notes == ("order 1: first", "order 1: second")


def test_a_mass_with_a_zero_eigenvalue_is_not_physical():
    from dataclasses import replace

    good = model_with_modes([10.0, 20.0], 0.02)
    assert not is_physical(replace(good, M=np.diag([1.0, 0.0])))


def test_a_chart_of_one_mode_writes_one_row_under_its_header(chain_data, tmp_path):
    _, data = chain_data
    chart = stabilisation_chart(data, 1)
    rows = chart.rows()
    assert len(rows) == 1
    with open(chart.to_csv(tmp_path / "one.csv"), newline="") as fh:
        back = list(csv.DictReader(fh))
    assert list(back[0]) == list(rows[0]) and back[0]["m"] == "1"
    assert float(back[0]["f_hz"]) == rows[0]["f_hz"]


def test_to_csv_replaces_a_file_that_exists(chain_data, tmp_path):
    """The docstring's "replaced if it exists": a stale file, then the same chart written
    twice, leave one header and the chart's one row — the bytes of a first write."""
    _, data = chain_data
    chart = stabilisation_chart(data, 1)
    fresh = chart.to_csv(tmp_path / "fresh.csv").read_bytes()
    stale = tmp_path / "stale.csv"
    stale.write_text("an older chart\n" * 5)
    chart.to_csv(stale)
    chart.to_csv(stale)
    assert stale.read_bytes() == fresh
    with open(stale, newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(chart.rows()) == 1


def test_the_symmetry_and_damping_tolerances_are_the_given_rtol():
    """rtol reaches both tests of is_physical: a mass asymmetric by 10⁻⁸ of itself and a
    damping with an eigenvalue 10⁻⁸ of its largest below 0 are not physical at the default
    10⁻¹⁰, and are at rtol = 10⁻⁶ (both two orders inside either tolerance)."""
    from dataclasses import replace

    from podid_rs.stabilisation import PHYSICAL_RTOL

    assert PHYSICAL_RTOL == 1e-10
    good = model_with_modes([10.0, 20.0], 0.02)
    skew = np.array([[0.0, 1.0], [0.0, 0.0]])
    bent = replace(good, M=np.eye(2) + 1e-8 * np.linalg.norm(np.eye(2)) * skew)
    assert not is_physical(bent)
    assert is_physical(bent, rtol=1e-6)
    leaky = replace(good, C=np.diag([1.0, -1e-8]))
    assert not is_physical(leaky)
    assert is_physical(leaky, rtol=1e-6)


def test_a_stiffness_with_a_rigid_body_mode_is_not_physical():
    # a free structure's K (a zero eigenvalue) is semidefinite, not definite
    from dataclasses import replace

    good = model_with_modes([10.0, 20.0], 0.02)
    assert not is_physical(replace(good, K=np.array([[1.0, -1.0], [-1.0, 1.0]])))


def test_a_chart_names_the_order_it_does_not_have(chain_data):
    _, data = chain_data
    chart = stabilisation_chart(data, 2, progress=False)
    assert chart.order(2).m == 2
    with pytest.raises(KeyError, match=r"^'the chart has no order m = 5'$"):
        chart.order(5)


def test_a_chart_from_a_higher_order_has_no_lower_one():
    # orders 2 … 3 only: order 1 is below the chart, not its lowest order
    models = {m: model_with_modes(10.0 * np.arange(1, m + 1), 0.02) for m in (2, 3)}
    data = from_frf(np.ones((5, 3, 1), dtype=complex), 2 * np.pi * np.linspace(5, 40, 5),
                    inputs=[0])
    chart = stabilisation_chart(data, 3, m_min=2, fit=models.__getitem__, progress=False)
    assert [chart.order(m).m for m in (2, 3)] == [2, 3]
    for m in (1, 4):
        with pytest.raises(KeyError, match=rf"^'the chart has no order m = {m}'$"):
            chart.order(m)


def test_a_pole_at_zero_frequency_is_consistent_with_nothing():
    # the frequency tolerance is relative to the previous pole's frequency: 0 Hz gives
    # no tolerance to be within, even for another pole at 0 Hz
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    zero = ModalParameters(np.array([0j]), np.array([0.0]), np.array([0.0]), 0)
    cf, c = _match_previous(zero, zero, 0.5, 0.5)
    assert cf.tolist() == [False] and c.tolist() == [False]


def test_a_chart_of_response_spectra_says_so(chain_data):
    # the same receptances as the spectra of forces of amplitude 2: no longer FRFs
    from dataclasses import replace

    _, data = chain_data
    spectra = replace(data, U=2.0 * data.U, F=2.0 * data.F)
    assert data.is_frf and not spectra.is_frf
    assert stabilisation_chart(data, 1, progress=False).is_frf
    assert not stabilisation_chart(spectra, 1, progress=False).is_frf



def test_a_previous_order_without_poles_leaves_every_pole_unmatched():
    # a model whose poles are all infinite (a zero mass) has none to compare with
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    one = ModalParameters(np.array([-1.0 + 1.0j]), np.array([1.0]), np.array([0.5]), 0)
    none = ModalParameters(np.zeros(0, dtype=complex), np.zeros(0), np.zeros(0), 2)
    cf, c = _match_previous(one, none, 0.5, 0.5)
    assert cf.tolist() == [False] and c.tolist() == [False]


def test_a_pole_at_either_end_of_the_charts_band_is_in_it():
    """The band is the data's first and last line, 0.5 and 1 Hz, ends included: poles
    at exactly 0.5 and 1 Hz are in band, ones at 0.49 and 1.01 Hz are not (margins of
    1 %, far above rounding; the rows take f from the modes as given)."""
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import StabilisationChart, StabilisationOrder

    f = np.array([0.49, 0.5, 1.0, 1.01])
    lam = 2 * np.pi * f * complex(-0.01, np.sqrt(1 - 1e-4))
    modes = ModalParameters(lam, f, np.full(4, 0.01), 0)
    order = StabilisationOrder(4, model_with_modes(f, 0.01), modes, True,
                               np.zeros(4, bool), np.zeros(4, bool))
    chart = StabilisationChart((order,), np.array([0.5, 0.75, 1.0]), np.ones(3), True,
                               0.01, 0.05)
    assert [r["in_band"] for r in chart.rows()] == [False, True, True, False]


def test_each_pole_is_matched_with_the_previous_orders_nearest_in_frequency():
    """Order m − 1 has poles at 10 and 30 Hz, order m at 5, 10 and 30 Hz (a new pole
    below the others): the 10 Hz pole, second of its order, matches the first of the
    previous one and the 30 Hz pole the second; the new 5 Hz pole is 50 % from its
    nearest (10 Hz) and matches nothing. Pairing by position would compare 10 Hz with
    30 Hz. Equal damping ratios: consistent follows consistent_f."""
    from podid_rs.physical import ModalParameters
    from podid_rs.stabilisation import _match_previous

    def modes(f_hz):
        f = np.asarray(f_hz, dtype=float)
        lam = 2 * np.pi * f * complex(-0.01, np.sqrt(1 - 1e-4))
        return ModalParameters(lam, f, np.full(f.size, 0.01), 0)

    cf, c = _match_previous(modes([5.0, 10.0, 30.0]), modes([10.0, 30.0]), F_TOL, ZETA_TOL)
    assert cf.tolist() == [False, True, True]
    assert c.tolist() == [False, True, True]


def test_definiteness_is_of_the_symmetric_part_of_a_nearly_symmetric_mass():
    """M = [[1, b + δ], [b − δ, 1]] with b = 1 + δ/2, δ = 2⁻³⁶ (every entry exact in binary)
    passes the symmetry test (‖M − Mᵀ‖ = 2√2 δ ≈ 4e-11 ≤ 1e-10 × ‖M‖ ≈ 2e-10). Its
    symmetric part [[1, b], [b, 1]] has the eigenvalues 1 ± b, the smaller −δ/2 ≈ −7e-12:
    not positive definite. Its lower triangle read as a symmetric matrix has 1 ± (b − δ),
    the smaller +δ/2, and would pass. δ/2 is four orders above the eigensolver's round-off
    (a few eps × ‖M‖ ≈ 1e-15), so the sign is the hand value's."""
    from dataclasses import replace

    from podid_rs.stabilisation import PHYSICAL_RTOL

    delta = 2.0**-36
    b = 1.0 + delta / 2
    M = np.array([[1.0, b + delta], [b - delta, 1.0]])
    assert np.linalg.norm(M - M.T) <= PHYSICAL_RTOL * np.linalg.norm(M)
    good = model_with_modes([10.0, 20.0], 0.02)
    assert not is_physical(replace(good, M=M))
    # the same matrix made exactly symmetric with the lower triangle's value is physical
    assert is_physical(replace(good, M=np.array([[1.0, b - delta], [b - delta, 1.0]])))
