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
