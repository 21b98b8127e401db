"""What ``podid-rs identify`` writes beside model.npz: model.uff, the stabilisation
chart and the MAC between two orders (podid_rs.apps.identify).

Tolerances: dataset 55 fields carry 6 significant digits (2e-5 on frequencies and
damping ratios, which combine two fields); see test_uff_out.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

from podid_rs import mass_spring_chain, modal_parameters, read_uff_modes
from podid_rs.apps.cli import build_parser, main
from podid_rs.apps.identify import stabilisation_orders

pyuff = pytest.importorskip("pyuff")
from test_measurements import write_uff  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def read_rows(path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture
def beam_like(tmp_path):
    """Accelerances of the 8-DOF chain driven at DOF 3, nodes 11–18 in Z, with a geometry."""
    chain = mass_spring_chain(8)
    freq = np.arange(0.0, 161.0, 0.5)
    H = np.zeros((freq.size, 8, 1), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])[:, :, [2]]
    dofs = [(11 + k, 3) for k in range(8)]
    path = write_uff(tmp_path / "bench.uff", freq, H, dofs, [dofs[2]])
    geometry = pyuff.prepare_15(node_nums=list(range(10, 20)), def_cs=[0] * 10,
                                disp_cs=[0] * 10, color=[1] * 10,
                                x=[0.1 * k for k in range(10)], y=[0.0] * 10, z=[0.0] * 10)
    pyuff.UFF(str(path)).write_sets(geometry, "add")
    return chain, path


def test_identify_writes_uff_stabilisation_and_mac(beam_like, tmp_path, capsys):
    """The paper's estimator: the chart fits orders 1 … 8 by eq. 49."""
    chain, path = beam_like
    out = tmp_path / "out"
    argv = ["identify", str(path), "--band-hz", "2", "160", "--m", "5", "--out", str(out)]
    assert main([*argv, "--no-progress", "--paper-estimator"]) == 0
    assert capsys.readouterr().err == ""
    for png in ("stabilisation.png", "mac.png"):
        assert (out / png).read_bytes()[:8] == PNG

    sets = pyuff.UFF(str(out / "model.uff")).read_sets()
    kinds = [d["type"] for d in sets]
    geometry = [d for d in sets if d["type"] == 15]
    assert len(geometry) == 1 and [int(n) for n in geometry[0]["node_nums"]] == list(range(10, 20))
    rows = read_rows(out / "modes.csv")
    # dataset 55 holds the structure's modes, each under its number in the modal table
    modes = [r for r in rows if r["kind"] == "structural"]
    s55 = [d for d in sets if d["type"] == 55]
    assert modes and len(s55) == len(modes) and kinds.count(58) == 8
    for d, row in zip(s55, modes, strict=True):
        assert int(d["mode_n"]) == int(row["mode"])
        lam = d["eig"]
        assert abs(abs(lam) / (2 * np.pi) / float(row["f_hz"]) - 1) < 2e-5
        assert abs(-lam.real / abs(lam) - float(row["zeta"])) < 2e-5 * abs(float(row["zeta"]))
        assert [int(n) for n in d["node_nums"]] == list(range(11, 19))
    s58 = [d for d in sets if d["type"] == 58]
    assert {d["ordinate_spec_data_type"] for d in s58} == {12}  # accelerance in, out
    assert {(d["ref_node"], d["ref_dir"]) for d in s58} == {(13, 3)}

    rows = read_rows(out / "stabilisation.csv")
    assert {int(r["m"]) for r in rows} == set(range(1, stabilisation_orders(5, 8) + 1))
    assert {r["m"] for r in rows if r["chosen"] == "True"} == {"5"}
    full = [r for r in rows if r["m"] == "8"]
    truth = modal_parameters(chain).frequencies_hz
    f_full = np.array([float(r["f_hz"]) for r in full])
    assert np.allclose(f_full[truth < 160], truth[truth < 160], rtol=1e-6)  # in band
    # above the band the modes are extrapolated from ASCII data of 12 significant digits:
    # their error depends on the round-off of the basis (1.4e-3 at 517 Hz with the POD
    # by snapshots, under 1e-3 with the n × n correlation), so the bound is 5e-3
    assert np.allclose(f_full, truth, rtol=5e-3)
    assert read_uff_modes(out / "model.uff").n_modes == len(modes)


def test_refined_identify_charts_the_orders_of_its_sweep(beam_like, tmp_path, capsys):
    """The default: the chart shows the sweep's output-error models, 1 … m, m chosen."""
    chain, path = beam_like
    out = tmp_path / "out"
    argv = ["identify", str(path), "--band-hz", "2", "160", "--m", "5", "--out", str(out)]
    assert main([*argv, "--no-progress"]) == 0
    assert capsys.readouterr().err == ""
    rows = read_rows(out / "stabilisation.csv")
    assert {int(r["m"]) for r in rows} == set(range(1, 6))
    assert {r["m"] for r in rows if r["chosen"] == "True"} == {"5"}
    assert {r["physical"] for r in rows} == {"True"}  # every refined model is physical
    assert (out / "mac.png").read_bytes()[:8] == PNG
    rows = read_rows(out / "modes.csv")
    s55 = [d for d in pyuff.UFF(str(out / "model.uff")).read_sets() if d["type"] == 55]
    # the structure's modes go to the UFF; a pole above the 160 Hz band is a residual term
    assert [int(d["mode_n"]) for d in s55] == [
        int(r["mode"]) for r in rows if r["kind"] == "structural"]
    assert all(float(r["f_hz"]) > 160 for r in rows if r["kind"] == "residual")


def test_stabilisation_orders_rule():
    assert stabilisation_orders(5, 8) == 8
    assert stabilisation_orders(5, 100) == 30
    assert stabilisation_orders(40, 100) == 45


def test_no_progress_option():
    args = build_parser().parse_args(
        ["identify", "x.uff", "--band-hz", "1", "2", "--out", "o", "--no-progress"]
    )
    assert args.no_progress


def test_the_sweeps_bar_quotes_the_order_and_its_held_out_error():
    """The bar's postfix: the order fitted and its held-out error (not its training one)."""
    from types import SimpleNamespace

    from podid_rs.apps.identify import _SweepBar

    bar = _SweepBar(enabled=False)
    bar(3, SimpleNamespace(test_db=1.234, train_db=0.5))
    assert bar.bar.postfix == "m = 3, held-out 1.23 dB"
    bar.close()


def test_dof_names_give_the_node_and_the_signed_axis():
    from podid_rs.apps.identify import _dof_name

    names = {(7, 1): "7X", (12, -2): "12-Y", (3, 3): "3Z", (8, -3): "8-Z", (4, 0): "4:0",
             (5, 4): "5:4", (6, -4): "6:-4"}
    for dof, name in names.items():
        assert _dof_name(np.array(dof)) == name


def test_intervals_sit_beside_their_values_at_the_level_asked():
    """Half-widths z·σ (z = 2 here by construction), f's beside f and ζ's beside ζ, named
    by the level; a mode the data do not fix is `undetermined` in both."""
    from types import SimpleNamespace

    from podid_rs.apps.identify import with_intervals

    asked = []
    modes = SimpleNamespace(z=2.0, std_frequency_hz=np.array([0.5, 0.25]),
                            std_damping=np.array([0.01, 0.02]),
                            determined=np.array([True, False]))
    unc = SimpleNamespace(modes=lambda level: asked.append(level) or modes)
    rows = [{"mode": 1, "f_hz": 10.0, "zeta": 0.02, "stable": "yes"},
            {"mode": 2, "f_hz": 30.0, "zeta": 0.05, "stable": "no"}]
    out = with_intervals(rows, unc, level=0.9)
    assert asked == [0.9]
    assert list(out[0]) == ["mode", "f_hz", "f_hz_pm90", "zeta", "zeta_pm90", "stable"]
    assert out[0] == {"mode": 1, "f_hz": 10.0, "f_hz_pm90": 1.0, "zeta": 0.02,
                      "zeta_pm90": 0.02, "stable": "yes"}
    assert out[1]["f_hz_pm90"] == out[1]["zeta_pm90"] == "undetermined"


def test_modes_markdown_names_the_interval_level_and_keeps_rows_without_a_kind():
    """Rows without a `kind` (a table made without kinds) are the structure's modes."""
    from podid_rs.apps.identify import modes_markdown

    rows = [{"mode": 1, "f_hz": 10.0, "f_hz_pm90": 1.0, "zeta": 0.02, "zeta_pm90": 0.002}]
    md = modes_markdown("- run\n", rows)
    assert "`f_hz_pm90`, `zeta_pm90`: the half-width of the 90 % confidence interval" in md
    assert "None." not in md and "Other poles" not in md and "| 1 | 10 |" in md


def test_modes_markdown_says_none_when_the_fit_found_no_mode_of_the_structure():
    """Only a residual term: the modes' heading says "None." rather than an empty or
    header-only table, and the residual term is listed under the other poles."""
    from podid_rs.apps.identify import modes_markdown

    rows = [{"mode": 1, "f_hz": 500.0, "zeta": 0.3, "kind": "residual"}]
    md = modes_markdown("- run\n", rows)
    structure, others = md.split("## Other poles")
    assert structure.rstrip().endswith("None.") and "| mode |" not in structure
    assert "| 1 | 500 |" in others


def test_modes_markdown_lists_only_the_structures_modes_under_their_heading():
    """A structural mode, a residual term and a weak pole: the first table (the modes of
    the structure, what model.uff holds) has the structural row alone, the second the
    other two."""
    from podid_rs.apps.identify import modes_markdown

    rows = [{"mode": 1, "f_hz": 10.0, "zeta": 0.02, "kind": "structural"},
            {"mode": 2, "f_hz": 500.0, "zeta": 0.3, "kind": "residual"},
            {"mode": 3, "f_hz": 40.0, "zeta": 0.01, "kind": "weak"}]
    md = modes_markdown("- run\n", rows)
    structure, others = md.split("## Other poles")
    assert "| 1 | 10 |" in structure
    assert "| 2 | 500 |" not in structure and "| 3 | 40 |" not in structure
    assert "| 2 | 500 |" in others and "| 3 | 40 |" in others and "| 1 | 10 |" not in others


def test_modes_markdown_states_the_thresholds_the_kinds_were_judged_by():
    """The paragraph over the other poles tells the reader the rules of mode_kinds: a weak
    pole is under a percentage of the largest measured response — the percentage must be
    100 × the fraction mode_kinds applies, not the fraction itself with a % sign — and a
    residual term has ζ at least the damping mode_kinds calls a residual's."""
    import re

    from podid_rs.apps.identify import modes_markdown
    from podid_rs.modes import RESIDUAL_ZETA, VISIBLE_FRACTION

    rows = [{"mode": 1, "f_hz": 10.0, "zeta": 0.02, "kind": "weak"}]
    md = modes_markdown("- run\n", rows)
    percent = re.search(r"under ([0-9.eE+-]+) % of the largest", md)
    zeta = re.search(r"ζ ≥ ([0-9.eE+-]+)", md)
    assert percent is not None and zeta is not None
    # printed with :g (six significant digits): the constants are round numbers
    assert float(percent.group(1)) / 100 == pytest.approx(VISIBLE_FRACTION, rel=1e-6)
    assert float(zeta.group(1)) == pytest.approx(RESIDUAL_ZETA, rel=1e-6)


def _summary_after_a_physical_correction(before: float, after: float, raised: tuple) -> str:
    """The summary of the exact 3-DOF chain's paper estimate, its info saying a physical
    correction took the residual from ``before`` to ``after`` raising ``raised`` (the
    report's numbers stand in for a correction)."""
    import dataclasses
    from pathlib import Path

    from podid_rs.apps.identify import IdentifyRun
    from podid_rs.measured import from_frf

    chain = mass_spring_chain(3, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    w = 2 * np.pi * np.arange(1.0, 60.0, 0.5)
    data = from_frf(chain.frf(w)[:, :, [0]], w, inputs=[0])
    ls, R = data.identify(m=3, symmetric=True)
    report = {"residual_before": before, "residual_after": after, "eigenvalues_raised": raised}
    written = dataclasses.replace(ls, info={**ls.info, "physical": report})
    return IdentifyRun(Path("chain.uff"), data, ls, written, R).summary()


def test_the_summary_quotes_the_physical_corrections_change_in_percent():
    """A physical correction that took the residual from 2 to 3: +50 %, by hand."""
    text = _summary_after_a_physical_correction(2.0, 3.0, (0, 1, 0))
    assert "residual 2 → 3 (+50.00 %), eigenvalues raised in M, C, K: (0, 1, 0)" in text


def test_a_correction_of_a_zero_residual_is_quoted_as_no_change():
    """Exact data can leave the paper's estimator a residual of exactly 0, which the
    correction keeps: the summary quotes +0.00 %, not a division by zero."""
    text = _summary_after_a_physical_correction(0.0, 0.0, (0, 0, 0))
    assert "residual 0 → 0 (+0.00 %), eigenvalues raised in M, C, K: (0, 0, 0)" in text


def test_the_mac_compares_the_chosen_order_with_the_next(beam_like, tmp_path, capsys,
                                                         monkeypatch):
    """m = 7 of an 8-DOF chart: the MAC's other order is 8 (m + 1 up to the chart's top)."""
    from podid_rs.apps import identify as identify_module

    seen = {}

    def fake_mac(a, b, path, *, names, title):
        seen.update(names=names, title=title, a=a, b=b)
        return path

    def fake_chart(chart, path, *, quantity="displacement", title=None):
        seen.update(quantity=quantity)
        return path

    monkeypatch.setattr(identify_module, "plot_mac", fake_mac)
    monkeypatch.setattr(identify_module, "plot_stabilisation", fake_chart)
    chain, path = beam_like
    argv = ["identify", str(path), "--band-hz", "2", "160", "--m", "7", "--paper-estimator",
            "--no-progress", "--out", str(tmp_path / "out")]
    assert main(argv) == 0
    assert seen["names"] == ("m = 7", "m = 8")
    assert seen["title"] == "MAC of the identified mode shapes in 2–160 Hz, m = 7 vs m = 8"
    # the chart's ordinate is the file's (accelerance), as model.uff's
    assert seen["quantity"] == "acceleration"
    # m = 7: the structure's modes alone (fewer than the table's rows: the others are
    # residual terms above the band); m = 8, the chain itself: its modes in 2–160 Hz,
    # three of its eight (43.9, 101.4 and 152.1 Hz)
    rows = read_rows(tmp_path / "out" / "modes.csv")
    structural = [r for r in rows if r["kind"] == "structural"]
    assert 0 < len(structural) < len(rows) and seen["a"].n_modes == len(structural)
    truth = modal_parameters(chain).frequencies_hz
    assert seen["b"].n_modes == np.sum((truth >= 2) & (truth <= 160)) == 3


def test_overlays_draw_four_driven_dofs_and_their_farthest_dof(tmp_path, capsys, monkeypatch):
    """Five driven DOFs of the 6-DOF chain (nodes 1–5 of 1–6 along X): four overlays, each
    the driving point and the measured DOF farthest from it (node 6, or node 1 for nodes
    4 and 5)."""
    from podid_rs.apps import identify as identify_module

    calls = []

    def fake_overlay(freq, curves, path, *, title, entries):
        calls.append((path.name, entries))
        return path

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    chain = mass_spring_chain(6)
    freq = np.arange(5.0, 201.0, 1.0)
    dofs = [(k + 1, 1) for k in range(6)]
    path = write_uff(tmp_path / "five.uff", freq, chain.frf(2 * np.pi * freq)[:, :, :5], dofs,
                     dofs[:5])
    argv = ["identify", str(path), "--band-hz", "5", "200", "--m", "6", "--paper-estimator",
            "--no-progress", "--out", str(tmp_path / "out")]
    assert main(argv) == 0
    assert calls == [
        ("frf_input1.png", [("1X", "1X"), ("6X", "1X")]),
        ("frf_input2.png", [("2X", "2X"), ("6X", "2X")]),
        ("frf_input3.png", [("3X", "3X"), ("6X", "3X")]),
        ("frf_input4.png", [("4X", "4X"), ("1X", "4X")]),
    ]


def test_source_ordinate_of_a_saved_data_set(tmp_path):
    from podid_rs.apps.identify import source_ordinate

    np.savez(tmp_path / "velocity.npz", quantity=np.array("velocity"))
    np.savez(tmp_path / "plain.npz", dt=np.array(0.1))
    assert source_ordinate(tmp_path / "velocity.npz") == "velocity"
    assert source_ordinate(tmp_path / "plain.npz") == "displacement"
    assert source_ordinate(tmp_path / "notes.txt") == "displacement"
    # a suffix in capitals names the same format, as load_data reads it
    with open(tmp_path / "LOUD.NPZ", "wb") as fh:
        np.savez(fh, quantity=np.array("acceleration"))
    assert source_ordinate(tmp_path / "LOUD.NPZ") == "acceleration"


def holed_run(tmp_path):
    """A run on the exact 6-DOF chain's FRFs driven at DOFs 1 and 3 (nodes 1–6 along X),
    with three of the twelve entries not measured, the driving point of the second force
    among them. The model is the chain itself on the identity basis."""
    from pathlib import Path
    from types import SimpleNamespace

    from podid_rs.apps.identify import IdentifyRun
    from podid_rs.measured import from_frf

    chain = mass_spring_chain(6, m1=1.0, m2=1.0)
    w = 2 * np.pi * np.arange(5.0, 250.0, 1.0)
    H = chain.frf(w)[:, :, [0, 2]]
    mask = np.ones((6, 2), dtype=bool)
    for j, k in ((5, 0), (2, 1), (0, 1)):
        mask[j, k] = False
    data = from_frf(H, w, inputs=[0, 2], dofs=[(k + 1, 1) for k in range(6)], measured=mask)
    model = SimpleNamespace(m=6, system=lambda: chain, info={})  # what the run asks of it
    return IdentifyRun(Path(tmp_path / "holes.uff"), data, model, model, np.eye(6))


def test_an_overlay_says_when_its_driving_point_was_not_measured(tmp_path, monkeypatch):
    """H(3X,3X) is a hole: the second overlay's title says so, the first's (its driving
    point measured, its farthest measured DOF node 5) does not."""
    from podid_rs.apps import identify as identify_module

    titles = []

    def fake_overlay(freq, curves, path, *, title, entries):
        titles.append((title, entries))
        return path

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    identify_module._overlays(holed_run(tmp_path), tmp_path)
    (first, first_entries), (second, _) = titles
    assert first_entries == [("1X", "1X"), ("5X", "1X")]
    assert "not measured" not in first
    assert "; H(3X,3X) was not measured" in second


def test_an_overlay_draws_and_bands_the_column_of_its_driven_dof(tmp_path, monkeypatch):
    """The second force is load case 2 but drives DOF 3: its overlay draws column 3X of
    H — the model's (the chain itself) at the driving point and at node 6, the measured
    one blank at the hole H(3X,3X) — and asks the confidence band for that column. (With
    load case k driving DOF k, as in the other layouts, the two indices coincide.) The
    model's curve solves the same systems as chain.frf: round-off apart (1e-12)."""
    import dataclasses
    from types import SimpleNamespace

    from podid_rs.apps import identify as identify_module

    drawn, asked = [], []

    def fake_overlay(freq, curves, path, *, title, entries):
        drawn.append((freq, curves))
        return path

    def frf(omega, *, rows, cols, level):
        asked.append((list(rows), list(cols)))
        shape = (omega.size, len(rows), len(cols))
        return SimpleNamespace(lower=np.zeros(shape), upper=np.ones(shape))

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    run = dataclasses.replace(holed_run(tmp_path), uncertainty=SimpleNamespace(frf=frf))
    identify_module._overlays(run, tmp_path)
    assert asked == [([0, 4], [0]), ([2, 5], [2])]
    freq, (measured, model) = drawn[1]
    omega = run.data.omega[np.searchsorted(run.data.freq_hz, freq)]  # the lines drawn
    H = mass_spring_chain(6, m1=1.0, m2=1.0).frf(omega)

    def rel_err(a, b):
        return float(np.abs(a - b).max() / np.abs(b).max())

    assert rel_err(model.values, H[:, [2, 5], 2]) < 1e-12
    assert np.all(np.isnan(measured.values[:, 0]))
    assert rel_err(measured.values[:, 1], H[:, 5, 2]) < 1e-12


def test_pole_kinds_take_each_residue_at_the_driven_dof():
    """Three equal masses in a chain, the middle one numbered first: the second mode has a
    node at DOF 0 and none at the end mass driven, DOF 1 (the one load case). Each mode
    shows in the driving-point FRF, so all three are the structure's; a residue taken at
    DOF 0 (the load case's index) would call the second weak."""
    from podid_rs import SecondOrderSystem
    from podid_rs.apps.identify import pole_kinds
    from podid_rs.measured import from_frf

    chain = mass_spring_chain(3, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    order = [1, 0, 2]
    system = SecondOrderSystem(*(X[np.ix_(order, order)] for X in (chain.M, chain.C, chain.K)))
    w = 2 * np.pi * np.arange(1.0, 60.0, 0.05)  # the modes at 12, 22.5 and 29.4 Hz
    data = from_frf(system.frf(w)[:, :, [1]], w, inputs=[1])
    result, R = data.identify(m=3, symmetric=True)  # exact data: the chain itself
    assert pole_kinds(result, R, data).tolist() == ["structural"] * 3


def test_an_overlays_farthest_dof_is_measured_from_its_driven_dof(tmp_path, monkeypatch):
    """Load case 1 drives node 4 of nodes 1–6: its farthest DOF is node 1 (3 away), not
    node 6 (the farthest from node 1, which the load case's index would name); load case
    2 drives node 1, whose farthest is node 6."""
    from pathlib import Path
    from types import SimpleNamespace

    from podid_rs.apps import identify as identify_module
    from podid_rs.apps.identify import IdentifyRun
    from podid_rs.measured import from_frf

    calls = []

    def fake_overlay(freq, curves, path, *, title, entries):
        calls.append(entries)
        return path

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    chain = mass_spring_chain(6)
    w = 2 * np.pi * np.arange(5.0, 201.0, 1.0)
    data = from_frf(chain.frf(w)[:, :, [3, 0]], w, inputs=[3, 0],
                    dofs=[(k + 1, 1) for k in range(6)])
    model = SimpleNamespace(m=6, system=lambda: chain, info={})  # what the overlays ask
    run = IdentifyRun(Path(tmp_path / "far.uff"), data, model, model, np.eye(6))
    identify_module._overlays(run, tmp_path)
    assert calls == [[("4X", "4X"), ("1X", "4X")], [("1X", "1X"), ("6X", "1X")]]


def test_pole_kinds_judge_the_measured_entries_only():
    """Five equal masses driven at masses 2 and 4, the nodes of the third mode (22.5 Hz):
    no measured FRF shows it, so it is weak and the other four are the structure's. One
    response is not measured (mass 1 under the first force): its hole holds a zero, which
    a judge blind to the holes would take for a level the mode's zero residue reaches."""
    from podid_rs.apps.identify import pole_kinds
    from podid_rs.measured import from_frf

    chain = mass_spring_chain(5, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    w = 2 * np.pi * np.arange(1.0, 60.0, 0.05)
    mask = np.ones((5, 2), dtype=bool)
    mask[0, 0] = False
    data = from_frf(chain.frf(w)[:, :, [1, 3]], w, inputs=[1, 3], measured=mask)
    assert np.allclose(modal_parameters(chain).frequencies_hz[2], 22.5, rtol=1e-3)
    kinds = pole_kinds(chain, np.eye(5), data)  # the chain itself on the identity basis
    assert kinds.tolist() == ["structural", "structural", "weak", "structural", "structural"]


def test_the_confidence_band_is_drawn_on_the_written_model_alone(tmp_path, monkeypatch):
    """Each overlay draws the paper's estimator and the model written, two objects in a run
    (one in the layouts above); the band, from the written model's covariance, shades the
    written model's curve and not the paper's estimator's."""
    import dataclasses
    from types import SimpleNamespace

    from podid_rs.apps import identify as identify_module

    drawn = []

    def fake_overlay(freq, curves, path, *, title, entries):
        drawn.append(curves)
        return path

    def frf(omega, *, rows, cols, level):
        shape = (omega.size, len(rows), len(cols))
        return SimpleNamespace(lower=np.zeros(shape), upper=np.ones(shape))

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    run = holed_run(tmp_path)
    paper = SimpleNamespace(**vars(run.result))  # the same chain, another model object
    run = dataclasses.replace(run, least_squares=paper, uncertainty=SimpleNamespace(frf=frf))
    identify_module._overlays(run, tmp_path)
    assert len(drawn) == 2
    for measured, paper_curve, written_curve in drawn:
        assert measured.band is None and paper_curve.band is None
        assert written_curve.band is not None and written_curve.band_label == (
            "95 % confidence band")
