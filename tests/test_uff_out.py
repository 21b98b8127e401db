"""``write_uff``: the identified model written as datasets 15, 55, 58 and read back by pyuff.

Tolerances are the file's precision: dataset 15/55 fields are E13.5 (6
significant digits: 5e-6 relative per field, so 2e-5 on frequencies and
damping ratios, which combine two fields, and 1e-5 on shape entries ≤ 1);
ASCII 58 ordinates are E20.11 (5e-12 relative per part, asserted 1e-10);
binary 58 ordinates are exact doubles.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import podid_rs as pr
from podid_rs.io.uff import read_uff_geometry, read_uff_modes, uff_quantity, write_uff
from podid_rs.physical import modal_table

pyuff = pytest.importorskip("pyuff")
from conftest import BEAM_UFF  # noqa: E402
from test_measurements import write_uff as write_input_uff  # noqa: E402

GEOMETRY = np.array([[k, 0.1 * k, 0.0, -0.02 * k] for k in range(1, 8)])  # node 7 unmeasured


@pytest.fixture(scope="module")
def model():
    """An order-4 model of the 6-DOF chain from exact accelerances driven at DOFs 2, 5.

    Directions are Z (3) on nodes 1–6; the data come through a UFF file, as a user's do.
    """
    chain = pr.mass_spring_chain(6)
    freq = np.arange(0.0, 121.0, 1.0)
    H = np.zeros((freq.size, 6, 2), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])[:, :, [1, 4]]
    return chain, freq, H


@pytest.fixture(scope="module")
def written(model, tmp_path_factory):
    chain, freq, H = model
    tmp = tmp_path_factory.mktemp("uff")
    dofs = [(k + 1, 3) for k in range(6)]
    source = write_input_uff(tmp / "test.uff", freq, H, dofs, [dofs[1], dofs[4]])
    data = pr.read_uff(source, band_hz=(5.0, 120.0))
    result, R = data.identify(m=4, symmetric=True)
    path = write_uff(tmp / "model.uff", result, R, data, quantity="acceleration",
                     geometry=GEOMETRY)
    sets = pyuff.UFF(str(path)).read_sets()
    return source, data, result, R, path, sets


def identified_frf(result, R, data):
    return np.einsum("am,smk,bk->sab", R, result.system().frf(data.omega), R[data.inputs])


def test_dataset_order_and_geometry(written):
    _, _, result, _, path, sets = written
    kinds = [d["type"] for d in sets]
    n_modes = len(modal_table(result))
    assert kinds == [15] + [55] * n_modes + [58] * 12
    g = sets[0]
    assert [int(n) for n in g["node_nums"]] == list(range(1, 8))
    # every node in the global Cartesian system (0), as displacement and definition
    assert list(g["def_cs"]) == [0] * 7 and list(g["disp_cs"]) == [0] * 7
    assert np.allclose(np.c_[g["x"], g["y"], g["z"]], GEOMETRY[:, 1:], rtol=1e-5, atol=1e-12)
    assert np.allclose(read_uff_geometry(path), GEOMETRY, rtol=1e-5, atol=1e-12)


def test_dataset_55_matches_the_modal_table_and_the_shapes(written):
    _, data, result, R, _, sets = written
    rows = modal_table(result)
    modes = pr.mode_shapes(result, R, data.dofs)
    s55 = [d for d in sets if d["type"] == 55]
    assert [d["mode_n"] for d in s55] == [r["mode"] for r in rows]
    for d, row, j in zip(s55, rows, range(len(rows)), strict=True):
        lam = d["eig"]
        assert d["analysis_type"] == 3 and d["data_ch"] == 2 and d["spec_data_type"] == 8
        assert abs(abs(lam) / (2 * np.pi) / row["f_hz"] - 1) < 2e-5
        assert abs(-lam.real / abs(lam) - row["zeta"]) < 2e-5 * abs(row["zeta"])
        assert [int(n) for n in d["node_nums"]] == list(range(1, 7))
        assert np.max(np.abs(d["r3"] - modes.shapes[:, j])) < 1e-5
        assert not np.any(d["r1"]) and not np.any(d["r2"])
        assert abs(d["modal_a"] - modes.modal_a[j]) < 1e-5 * abs(modes.modal_a[j])
        assert abs(d["modal_b"] + lam * d["modal_a"]) < 2e-5 * abs(lam * d["modal_a"])
    back = read_uff_modes(written[4])
    assert back.dofs.tolist() == data.dofs.tolist()
    assert back.mode_numbers.tolist() == [r["mode"] for r in rows]
    assert np.max(np.abs(back.shapes - modes.shapes)) < 1e-5
    assert np.allclose(back.eigenvalues, modes.eigenvalues, rtol=1e-5)


def test_the_written_records_say_what_they_hold_in_their_text_fields(written, tmp_path):
    """The lines another program shows: each mode's name, number, frequency and damping
    and what its numbers are (dataset 55); each FRF's entry and origin (dataset 58),
    its abscissa in Hz and evenly spaced; a name cut to the 80 columns of a line."""
    _, data, result, R, _, sets = written
    rows = modal_table(result)
    s55 = [d for d in sets if d["type"] == 55]
    for d, row in zip(s55, rows, strict=True):
        assert d["id1"] == f"podid_rs: identified mode {row['mode']}"
        f, zeta = abs(d["eig"]) / (2 * np.pi), -d["eig"].real / abs(d["eig"])
        assert d["id2"].startswith("f = ") and ", zeta = " in d["id2"]
        f_text, z_text = d["id2"][len("f = "):].split(" Hz, zeta = ")
        assert abs(float(f_text) / f - 1) < 1e-5 and abs(float(z_text) / zeta - 1) < 1e-4
        assert (d["id3"], d["id5"]) == ("NONE", "NONE")
        assert d["id4"] == "complex eigenvalue in rad/s; shape scaled to largest entry 1"
        assert (d["model_type"], d["data_type"], d["n_data_per_node"], d["load_case"]) == \
            (1, 5, 3, 1)
    s58 = [d for d in sets if d["type"] == 58]
    for d in s58:
        assert d["id2"] == f"H({d['rsp_node']}:3, {d['ref_node']}:3) podid_rs, identified"
        assert (d["id4"], d["id5"]) == ("NONE", "NONE")
        assert d["abscissa_spacing"] == 1 and d["abscissa_spec_data_type"] == 18
    long = write_uff(tmp_path / "long.uff", result, R, data, name="x" * 100)
    assert max(len(line) for line in long.read_bytes().split(b"\n")) == 80
    back = pyuff.UFF(str(long)).read_sets()
    assert {d["id1"] for d in back if d["type"] == 55} == {"x" * 80}
    assert {d["id2"] for d in back if d["type"] == 58} == {
        (f"H({n}:3, {r}:3) " + "x" * 100)[:80] for n in range(1, 7) for r in (2, 5)}


def test_dataset_58_holds_the_identified_accelerances(written):
    _, data, result, R, path, sets = written
    H = identified_frf(result, R, data) * -(data.omega**2)[:, None, None]
    s58 = [d for d in sets if d["type"] == 58]
    seen = set()
    for d in s58:
        i = data.dofs[:, 0].tolist().index(d["rsp_node"])
        k = [int(data.dofs[j, 0]) for j in data.inputs].index(d["ref_node"])
        seen.add((i, k))
        assert (d["rsp_dir"], d["ref_dir"], d["func_type"]) == (3, 3, 4)
        assert d["ordinate_spec_data_type"] == 12 and d["orddenom_spec_data_type"] == 13
        assert np.allclose(d["x"], data.freq_hz, rtol=1e-12)
        err = np.abs(d["data"] - H[:, i, k])
        assert np.max(err / np.abs(H[:, i, k])) < 1e-10
    assert len(seen) == 12 and uff_quantity(path) == "acceleration"
    # in the documented order: one driven DOF (nodes 2, 5) at a time, each with every
    # measured DOF in the data's order, as a shaker run writes its reference's FRFs
    assert [(d["ref_node"], d["rsp_node"]) for d in s58] == [
        (ref, node) for ref in (2, 5) for node in range(1, 7)]
    # read_uff reads it back as the identified receptance: the loop closes
    again = pr.read_uff(path)
    assert again.dofs.tolist() == data.dofs.tolist() and again.inputs.tolist() == [1, 4]
    H_id = identified_frf(result, R, data)
    assert np.max(np.abs(again.U - H_id)) < 1e-10 * np.max(np.abs(H_id))


def test_frfs_beyond_one_batch_are_all_written(written, tmp_path, monkeypatch):
    """The 58 records are made and written WRITE_BATCH at a time (to bound the memory of
    a large scan); in batches of 5 the 12 records are 5 + 5 + 2, and the file is byte for
    byte the one written in a single batch."""
    import podid_rs.io.uff as uff_module

    _, data, result, R, path, _ = written
    monkeypatch.setattr(uff_module, "WRITE_BATCH", 5)
    batched = write_uff(tmp_path / "batched.uff", result, R, data, quantity="acceleration",
                        geometry=GEOMETRY)
    assert batched.read_bytes() == path.read_bytes()


def test_binary_58_is_exact_and_receptance_is_the_default(written, tmp_path):
    _, data, result, R, _, _ = written
    path = write_uff(tmp_path / "b.uff", result, R, data, binary=True)
    sets = pyuff.UFF(str(path)).read_sets()
    assert [d["type"] for d in sets].count(15) == 0
    s58 = [d for d in sets if d["type"] == 58]
    H = identified_frf(result, R, data)
    assert all(d["ordinate_spec_data_type"] == 8 and d["binary"] == 1 for d in s58)
    got = {(d["rsp_node"], d["ref_node"]): d["data"] for d in s58}
    # every digit: the two products differ by round-off (7.6e-16); ASCII keeps 12 digits
    rel = np.abs(got[(4, 5)] - H[:, 3, 1]) / np.abs(H[:, 3, 1])
    assert rel.max() < 1e-14


def test_every_bad_input_is_refused_with_its_whole_message(written, tmp_path):
    """write_uff's messages word for word, and the edges of what it accepts: the first
    and last measured DOF as inputs, two frequency lines, directions ±1 … ±3."""
    _, data, result, R, _, _ = written
    out = tmp_path / "x.uff"
    w, dofs = data.omega, data.dofs
    rot = np.c_[np.arange(1, 7), [3, 4, -4, 0, 5, 6]]
    cases = [
        ((result.M, R, data), {}, "model must be an IdentificationResult, got ndarray"),
        ((result, R, {"U": data.U}), {}, "data must be a MeasuredData, got dict"),
        ((result, R, data), {"dofs": dofs}, "give data, or dofs / inputs / omega, not both"),
        ((result, R, data), {"inputs": [0]}, "give data, or dofs / inputs / omega, not both"),
        ((result, R, data), {"omega": w}, "give data, or dofs / inputs / omega, not both"),
        ((result, R), {}, "the model has no measured-DOF labelling: UFF output needs the "
                          "(node, direction) label of each of the 6 basis rows (dofs=, or "
                          "data=)"),
        ((result, R), {"dofs": rot}, "DOF(s) [(2, 4), (3, -4), (4, 0)] are not translations "
                                     "(direction 1-3): dataset 55 with complex shapes holds "
                                     "X, Y, Z only"),
        ((result, R), {"dofs": dofs, "inputs": [0]},
         "the FRFs (dataset 58) need both inputs= and omega="),
        ((result, R), {"dofs": dofs, "inputs": [0], "omega": w[:1]},
         "omega must hold at least 2 strictly increasing frequency lines"),
        ((result, R), {"dofs": dofs, "inputs": [0], "omega": w[[0, 2, 1]]},
         "omega must hold at least 2 strictly increasing frequency lines"),
        ((result, R), {"dofs": dofs, "inputs": [0], "omega": w[[0, 0, 1]]},
         "omega must hold at least 2 strictly increasing frequency lines"),
        ((result, R), {"dofs": dofs, "inputs": [6], "omega": w},
         "inputs must index the 6 measured DOFs, got [6]"),
        ((result, R), {"dofs": dofs, "inputs": [-1], "omega": w},
         "inputs must index the 6 measured DOFs, got [-1]"),
        ((result, R), {"dofs": dofs, "inputs": [0.5], "omega": w},
         "inputs must index the 6 measured DOFs, got [0.5]"),
        # 0.5 lies above its nearest integer (0: half to even), 0.75 below it (1)
        ((result, R), {"dofs": dofs, "inputs": [0.75], "omega": w},
         "inputs must index the 6 measured DOFs, got [0.75]"),
        ((result, R), {"dofs": dofs, "inputs": [], "omega": w},
         "inputs must index the 6 measured DOFs, got []"),
        ((result, R), {"dofs": dofs, "inputs": [2, 0, 2], "omega": w},
         "inputs must not repeat a DOF, got [2, 0, 2]"),
        ((result, R, data), {"quantity": "accelerance"},
         "quantity must be one of ('displacement', 'velocity', 'acceleration'), got "
         "'accelerance'"),
    ]
    for args, kwargs, message in cases:
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            write_uff(out, *args, **kwargs)
    assert not out.exists()
    signed = np.c_[np.arange(1, 7), [1, -1, 2, -2, 3, -3]]
    write_uff(out, result, R, dofs=signed, inputs=[0, 5], omega=w[:2])
    kinds = pyuff.UFF(str(out)).get_set_types().tolist()
    assert kinds.count(58) == 12 and 55 in kinds
    # every direction's component is written, with its sign: X, Y and Z read back
    back = read_uff_modes(out)
    modes = pr.mode_shapes(result, R, signed)
    assert back.dofs.tolist() == np.abs(signed).tolist()
    assert np.max(np.abs(back.shapes - np.sign(signed[:, 1:]) * modes.shapes)) < 1e-5


def test_modes_only_without_frequency_lines(written, tmp_path):
    _, data, result, R, _, _ = written
    path = write_uff(tmp_path / "modes.uff", result, R, dofs=data.dofs)
    assert set(pyuff.UFF(str(path)).get_set_types()) == {55}
    # written again over a file of FRFs, the file is replaced, not added to: one 55 per
    # mode of the order-4 model (4 pairs: 8 modes at most) and no 58
    write_uff(path, result, R, data)
    write_uff(path, result, R, dofs=data.dofs)
    kinds = pyuff.UFF(str(path)).get_set_types().tolist()
    assert kinds == [55] * pr.mode_shapes(result, R, data.dofs).n_modes


def test_bad_input_is_named(written, tmp_path):
    source, data, result, R, _, _ = written
    out = tmp_path / "x.uff"
    with pytest.raises(ValueError, match="no measured-DOF labelling"):
        write_uff(out, result, R)
    with pytest.raises(ValueError, match=r"^UFF output needs the basis R \(n, m\) that maps "
                       r"the model to its DOFs$"):
        write_uff(out, result, None, data)
    with pytest.raises(ValueError, match=r"basis must have shape \(n, m\) with m = 4"):
        write_uff(out, result, R.T, data)
    with pytest.raises(ValueError, match="need both inputs= and omega="):
        write_uff(out, result, R, dofs=data.dofs, omega=data.omega)
    with pytest.raises(ValueError, match="not both"):
        write_uff(out, result, R, data, dofs=data.dofs)
    with pytest.raises(ValueError, match="quantity must be one of"):
        write_uff(out, result, R, data, quantity="accelerance")
    with pytest.raises(ValueError, match="not translations"):
        write_uff(out, result, R, dofs=np.c_[np.arange(1, 7), np.full(6, 5)])
    with pytest.raises(ValueError, match=r"geometry must have shape \(k, 4\)"):
        write_uff(out, result, R, data, geometry=GEOMETRY[:, :3])
    # one column too many (a node's rotation, say) and a stack of tables are refused too:
    # the check is two-sided on the columns and on the number of axes
    with pytest.raises(ValueError, match=r"^geometry must have shape \(k, 4\) \[node, x, y, "
                                         r"z\], got \(7, 5\)$"):
        write_uff(out, result, R, data, geometry=np.c_[GEOMETRY, np.zeros(7)])
    with pytest.raises(ValueError, match=r"^geometry must have shape \(k, 4\) \[node, x, y, "
                                         r"z\], got \(7, 4, 1\)$"):
        write_uff(out, result, R, data, geometry=GEOMETRY[:, :, None])
    with pytest.raises(ValueError, match=r"^geometry contains non-finite values"):
        write_uff(out, result, R, data, geometry=np.r_[GEOMETRY[:1], [[2, np.nan, 0.0, 0.0]]])
    with pytest.raises(ValueError, match=r"^geometry must have shape \(k, 4\) \[node, x, y, "
                                         r"z\], got \(0, 4\)$"):
        write_uff(out, result, R, data, geometry=GEOMETRY[:0])
    # one node's row alone, flat, is no table of nodes either (refused by name, not an
    # IndexError from its missing second axis)
    with pytest.raises(ValueError, match=r"^geometry must have shape \(k, 4\) \[node, x, y, "
                                         r"z\], got \(4,\)$"):
        write_uff(out, result, R, data, geometry=GEOMETRY[0])
    assert not out.exists()
    # one node is a geometry (the others simply have no coordinates)
    one = write_uff(tmp_path / "one.uff", result, R, data, geometry=GEOMETRY[:1])
    assert np.allclose(read_uff_geometry(one), GEOMETRY[:1], rtol=1e-5, atol=1e-12)
    # a reference file without mode shapes: the input FRF file
    with pytest.raises(ValueError, match=r"test\.uff: no dataset 55 \(mode shapes\).*58"):
        read_uff_modes(source)
    modes = pr.mode_shapes(result, R, data.dofs)
    with pytest.raises(ValueError, match="no dataset 55"):
        pr.plot_mac(modes, source, tmp_path / "mac.png")


def test_a_nonsymmetric_model_writes_no_modal_constants(written, tmp_path):
    """Without a symmetric model there is no modal A (ModeShapes.modal_a is None): the
    55 sets hold 0 for the modal constants, not a made-up value."""
    from dataclasses import replace

    _, data, result, R, _, _ = written
    skewed = replace(result, C=result.C + 1e-3 * np.triu(result.C, 1))
    assert pr.mode_shapes(skewed, R).modal_a is None
    path = write_uff(tmp_path / "skewed.uff", skewed, R, dofs=data.dofs)
    s55 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 55]
    assert s55 and all(d["modal_a"] == 0 and d["modal_b"] == 0 for d in s55)


def test_the_58_sets_label_their_abscissa_in_hertz(written):
    _, _, _, _, _, sets = written
    s58 = [d for d in sets if d["type"] == 58]
    assert s58 and all(d["abscissa_axis_units_lab"].strip() == "Hz" for d in s58)


def test_two_frequency_lines_are_written(written, tmp_path):
    _, data, result, R, _, _ = written
    path = write_uff(tmp_path / "two.uff", result, R, dofs=data.dofs, inputs=[1],
                     omega=data.omega[:2])
    s58 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
    assert len(s58) == 6 and all(d["x"].size == 2 for d in s58)


@pytest.mark.parametrize("binary", [False, True])
def test_unevenly_spaced_lines_are_written_line_by_line(written, tmp_path, binary):
    """Lines that are not evenly spaced (a band pieced together, lines thinned out) are
    written with their abscissa values (spacing 0): read back, they are the same lines,
    to the abscissa's 6 digits (E13.5: 5e-6 relative)."""
    _, data, result, R, _, _ = written
    freq = np.array([5.0, 6.5, 9.0, 20.0, 55.5, 100.0])
    path = write_uff(tmp_path / "uneven.uff", result, R, dofs=data.dofs, inputs=[1],
                     omega=2 * np.pi * freq, binary=binary)
    s58 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
    assert len(s58) == 6 and all(d["abscissa_spacing"] == 0 for d in s58)
    assert all(np.allclose(d["x"], freq, rtol=5e-6, atol=0) for d in s58)
    assert np.allclose(pr.read_uff(path).freq_hz, freq, rtol=5e-6, atol=0)
    # even to 1e-6 of a step is not even: spacing and first line would put the fourth
    # line 1.5e-6 Hz off (evenly spaced means equal steps to 1e-9); and the test is
    # relative, not absolute: steps of 1 mHz differing by 5e-9 Hz (5e-6 of a step) are
    # not equal either
    for name, step, shift in (("nearly", 1.5, 1.5e-6), ("fine", 0.001, 5e-9)):
        lines = 5.0 + step * np.arange(6.0)
        lines[3:] += shift
        path = write_uff(tmp_path / f"{name}.uff", result, R, dofs=data.dofs, inputs=[1],
                         omega=2 * np.pi * lines, binary=binary)
        s58 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
        assert all(d["abscissa_spacing"] == 0 for d in s58), name


def test_frequency_lines_and_a_mask_of_modes_are_checked(written, tmp_path):
    _, data, result, R, _, _ = written
    out = tmp_path / "x.uff"
    for omega in ([10.0], [10.0, 30.0, 20.0], [10.0, 20.0, 20.0]):
        with pytest.raises(ValueError, match=r"^omega must hold at least 2 strictly increasing "
                                             r"frequency lines$"):
            write_uff(out, result, R, dofs=data.dofs, inputs=[1], omega=omega)
    k = pr.mode_shapes(result, R).n_modes
    with pytest.raises(ValueError, match=rf"^modes must be a boolean mask over the model's {k} "
                                         r"modes, got int64 \(2,\)$"):
        write_uff(out, result, R, data, modes=np.array([1, 0]))
    # a mask of the right length but not boolean is refused too, whatever its type: 0/1
    # integers (as indices they would write the second mode k times) or "1"/"0" text, read
    # from a file (numpy casts no bool safely to text shorter than "False")
    for mask in (np.ones(k, dtype=np.int64), np.array(["1"] * k)):
        with pytest.raises(ValueError, match=rf"^modes must be a boolean mask over the model's "
                                             rf"{k} modes, got {re.escape(str(mask.dtype))} "
                                             rf"{re.escape(str(mask.shape))}$"):
            write_uff(out, result, R, data, modes=mask)
    # a boolean mask of the wrong length (one mode short, or as a column) is named as
    # such, not left to numpy's indexing
    for mask in (np.ones(k - 1, dtype=bool), np.ones((k, 1), dtype=bool)):
        with pytest.raises(ValueError, match=rf"^modes must be a boolean mask over the model's "
                                             rf"{k} modes, got bool {re.escape(str(mask.shape))}$"):
            write_uff(out, result, R, data, modes=mask)
    assert not out.exists()


def test_a_selected_mode_keeps_its_number_in_the_modal_table(written, tmp_path):
    _, data, result, R, _, _ = written
    rows = modal_table(result)
    keep = np.zeros(len(rows), dtype=bool)
    keep[1::2] = True  # modes 2, 4, ...: none written under its position among the kept
    path = write_uff(tmp_path / "some.uff", result, R, data, modes=keep)
    wanted = [r["mode"] for r in rows][1::2]
    s55 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 55]
    assert [int(d["mode_n"]) for d in s55] == wanted
    assert [d["id1"].strip() for d in s55] == [f"podid_rs: identified mode {n}" for n in wanted]
    assert read_uff_modes(path).mode_numbers.tolist() == wanted



def test_a_model_without_a_mode_to_write_and_without_geometry_holds_its_frfs(written,
                                                                              tmp_path):
    """No mode selected and no geometry (an order whose poles are all residual terms,
    from a file without one): no dataset 15 or 55 comes first, the twelve FRFs are
    written all the same; with no lines either there is nothing to write."""
    _, data, result, R, _, _ = written
    none = np.zeros(pr.mode_shapes(result, R).n_modes, dtype=bool)
    path = write_uff(tmp_path / "frfs.uff", result, R, data, modes=none)
    assert [d["type"] for d in pyuff.UFF(str(path)).read_sets()] == [58] * 12
    with pytest.raises(ValueError, match="pyuff could not write the file: Nothing to write"):
        write_uff(tmp_path / "nothing.uff", result, R, dofs=data.dofs, modes=none)

def test_data_with_labels_or_lines_beside_it_and_repeated_nodes_are_refused(written, tmp_path):
    _, data, result, R, _, _ = written
    out = tmp_path / "x.uff"
    for extra in ({"inputs": data.inputs}, {"omega": data.omega}, {"dofs": data.dofs}):
        with pytest.raises(ValueError, match=r"^give data, or dofs / inputs / omega, not both$"):
            write_uff(out, result, R, data, **extra)
    with pytest.raises(ValueError, match=r"^geometry's first column must hold distinct integer "
                       r"node numbers$"):
        write_uff(out, result, R, data, geometry=np.r_[GEOMETRY[:1], GEOMETRY])
    with pytest.raises(ValueError, match=r"^geometry's first column must hold distinct integer "
                       r"node numbers$"):
        write_uff(out, result, R, data, geometry=GEOMETRY + np.r_[0.5, 0.0, 0.0, 0.0])
    # one node number off its integer, above it (3.25 rounds down) or below it (2.75 rounds
    # up): each alone is refused, not only a geometry that holds both kinds
    for node in (3.25, 2.75):
        geometry = GEOMETRY.copy()
        geometry[2, 0] = node
        with pytest.raises(ValueError, match=r"^geometry's first column must hold distinct "
                           r"integer node numbers$"):
            write_uff(out, result, R, data, geometry=geometry)
    assert not out.exists()


def test_velocity_frfs_are_the_receptances_times_i_omega(written, tmp_path):
    _, data, result, R, _, _ = written
    path = write_uff(tmp_path / "v.uff", result, R, data, quantity="velocity", binary=True)
    s58 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
    H = identified_frf(result, R, data) * (1j * data.omega)[:, None, None]
    got = {(d["rsp_node"], d["ref_node"]): d["data"] for d in s58}
    assert np.max(np.abs(got[(4, 5)] - H[:, 3, 1])) <= 1e-12 * np.max(np.abs(H[:, 3, 1]))
    assert uff_quantity(path) == "velocity"
    assert all(d["id1"] == "FRF" for d in s58) and len(s58) == 12


def test_mac_figure_against_the_written_file(written, tmp_path):
    _, data, result, R, path, _ = written
    modes = pr.mode_shapes(result, R, data.dofs)
    values, _ = pr.shape_mac(modes, read_uff_modes(path))
    assert np.all(np.abs(np.diag(values) - 1) < 1e-8)
    png = pr.plot_mac(modes, path, tmp_path / "mac.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_frfs_read_by_reciprocity_say_so(written, tmp_path):
    # the fixture's data are a shaker layout: its 58 sets carry no remark
    sets = written[-1]
    assert all(d["id3"].strip() == "NONE" for d in sets if d["type"] == 58)
    # the real roving-hammer beam is read by reciprocity: its model's FRFs say so
    data = pr.read_uff(BEAM_UFF, band_hz=(50.0, 120.0))
    assert any("reciprocity" in note for note in data.notes)
    result, R = data.identify(m=3, symmetric=True)
    path = write_uff(tmp_path / "roving.uff", result, R, data)
    s58 = [d for d in pyuff.UFF(str(path)).read_sets() if d["type"] == 58]
    assert len(s58) == data.n and all("reciprocity" in d["id3"] for d in s58)


def test_the_58_sets_remark_reciprocity_only_when_a_note_says_so():
    from types import SimpleNamespace

    from podid_rs.io.uff import _reciprocity_remark

    assert _reciprocity_remark(None) == "NONE"
    dead = "t.uff: FRF record 5 is zero at every line in the file: a dead channel"
    assert _reciprocity_remark(SimpleNamespace(notes=(dead,))) == "NONE"
    read = "t.uff: the 9 FRFs ... 2 entries read by reciprocity, H(j, k) = H(k, j)"
    assert (_reciprocity_remark(SimpleNamespace(notes=(dead, read)))
            == "entries read by reciprocity: H(j, k) = H(k, j)")
    roving = "t.uff: a roving-hammer test: its references read as the responses"
    assert (_reciprocity_remark(SimpleNamespace(notes=(roving,)))
            == "roving-hammer test read by reciprocity: H(j, k) = H(k, j)")
