"""read_uff_modes on files other programs write: normal modes (dataset 55, analysis type 2)
with their frequency and damping ratio, mode numbers, and the files it must refuse.

The model files podid_rs writes hold complex modes (analysis type 3, tested with
write_uff); a modal-analysis program typically writes normal modes, whose eigenvalue
is λ = ω(−ζ + i√(1 − ζ²)) (real, −ζω, for ζ ≥ 1). Frequencies and damping ratios
here have at most 6 significant digits, which the format's E13.5 fields hold exactly.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

pyuff = pytest.importorskip("pyuff")

from podid_rs.io.uff import read_uff_modes  # noqa: E402


def normal_mode(mode_n: int, freq: float, zeta: float, r1, r2, nodes, analysis_type: int = 2):
    return pyuff.prepare_55(
        id1="a modal-analysis program", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
        model_type=1, analysis_type=analysis_type, data_ch=2, spec_data_type=8, data_type=2,
        n_data_per_node=3, r1=np.asarray(r1, float), r2=np.asarray(r2, float),
        r3=np.zeros(len(nodes)), load_case=1, mode_n=mode_n, freq=freq, modal_m=1.0,
        modal_damp_vis=zeta, modal_damp_his=0.0, node_nums=list(nodes),
        **({"freq_step_n": 1} if analysis_type == 5 else {}),
    )


def write(path, *sets):
    uff = pyuff.UFF(str(path))
    for d in sets:
        uff.write_sets(d, "add")
    return path


def test_normal_modes_give_their_eigenvalue_number_and_dofs(tmp_path):
    path = write(
        tmp_path / "normal.uff",
        normal_mode(3, 12.5, 0.02, [1.0, 0.0], [0.0, 0.0], [5, 6]),
        normal_mode(4, 40.0, 0.0, [1.0, 0.0], [0.0, -0.5], [5, 6]),
        normal_mode(7, 2.0, 1.5, [0.0, 0.25], [0.0, 0.0], [5, 6]),  # overdamped
    )
    modes = read_uff_modes(path)
    w = 2 * np.pi * np.array([12.5, 40.0, 2.0])
    expected = w * np.array([complex(-0.02, np.sqrt(1 - 0.02**2)), 1j, -1.5])
    np.testing.assert_allclose(modes.eigenvalues, expected, rtol=1e-14)
    assert modes.mode_numbers.tolist() == [3, 4, 7]
    # DOFs: every (node, direction) non-zero in some mode, sorted; the file's order of modes
    assert modes.dofs.tolist() == [[5, 1], [6, 1], [6, 2]]
    np.testing.assert_array_equal(modes.shapes, [[1, 1, 0], [0, 0, 0.25], [0, -0.5, 0]])


def test_modes_without_a_number_or_a_damping_ratio(tmp_path, monkeypatch):
    """A set that carries no mode number (pyuff returns none) is numbered by its place
    among the file's modes, 1, 2, … as a modal table counts them; a normal mode without
    a viscous damping ratio is undamped, λ = iω."""
    path = write(
        tmp_path / "unnumbered.uff",
        normal_mode(3, 12.5, 0.02, [1.0, 0.0], [0.0, 0.0], [5, 6]),
        normal_mode(4, 40.0, 0.0, [1.0, 0.0], [0.0, -0.5], [5, 6]),
    )
    read = pyuff.UFF.read_sets

    def without_numbers(self, *args, **kwargs):
        d = read(self, *args, **kwargs)
        return {k: v for k, v in d.items() if k not in ("mode_n", "modal_damp_vis")}

    monkeypatch.setattr(pyuff.UFF, "read_sets", without_numbers)
    modes = read_uff_modes(path)
    assert modes.mode_numbers.tolist() == [1, 2]
    np.testing.assert_allclose(modes.eigenvalues, 2j * np.pi * np.array([12.5, 40.0]),
                               rtol=1e-14)


def complex_mode(analysis_type: int, mode_n: int, eig: complex, r1, nodes):
    n = len(nodes)
    return pyuff.prepare_55(
        id1="a modal-analysis program", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
        model_type=1, analysis_type=analysis_type, data_ch=2, spec_data_type=8, data_type=5,
        n_data_per_node=3, r1=np.asarray(r1, complex), r2=np.zeros(n, complex),
        r3=np.zeros(n, complex), load_case=1, mode_n=mode_n, eig=eig, modal_a=0j,
        modal_b=0j, node_nums=list(nodes),
    )


def test_complex_modes_of_first_and_second_order_analyses_give_their_eigenvalue(tmp_path):
    """Analysis type 7 (complex eigenvalue, second order) holds modes as type 3 (first
    order) does: both are read, with the file's eigenvalue, number and complex shape. The
    values are exact in the file's E13.5 fields (a few digits each)."""
    path = write(
        tmp_path / "complex.uff",
        complex_mode(7, 2, complex(-1.5, 60.0), [1.0, 0.5j], [5, 6]),
        complex_mode(3, 5, complex(-0.25, 10.0), [0.0, 1.0], [5, 6]),
    )
    modes = read_uff_modes(path)
    assert modes.eigenvalues.tolist() == [complex(-1.5, 60.0), complex(-0.25, 10.0)]
    assert modes.mode_numbers.tolist() == [2, 5]
    assert modes.dofs.tolist() == [[5, 1], [6, 1]]
    assert modes.shapes.tolist() == [[1, 0], [0.5j, 1]]


def exactly(text: str) -> str:
    return "^" + re.escape(text) + "$"


def test_files_without_modes_are_refused_naming_what_they_hold(tmp_path):
    empty = tmp_path / "empty.uff"
    empty.write_text("")
    with pytest.raises(ValueError, match=exactly(
            f"{empty}: no dataset 55 (mode shapes) in the file; it holds dataset(s) none")):
        read_uff_modes(empty)

    other = write(
        tmp_path / "other.uff",
        pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1],
                         x=[0.0, 1.0], y=[0.0, 0.0], z=[0.0, 0.0]),
        pyuff.prepare_58(binary=0, func_type=4, rsp_node=1, rsp_dir=1, ref_node=1, ref_dir=1,
                         data=np.ones(3, complex), x=np.arange(3.0), abscissa_spacing=1,
                         abscissa_spec_data_type=18, ordinate_spec_data_type=12,
                         orddenom_spec_data_type=13),
    )
    with pytest.raises(ValueError, match=exactly(
            f"{other}: no dataset 55 (mode shapes) in the file; it holds dataset(s) 15, 58")):
        read_uff_modes(other)

    # two sets of analysis type 5 (frequency response); pyuff writes no type 1 (static),
    # so the first set's analysis-type field (record 6, second I10) is rewritten to 1
    path = write(tmp_path / "response.uff",
                 *(normal_mode(1, 3.0, 0.0, [1.0], [0.0], [5], analysis_type=5)
                   for _ in range(2)))
    text = path.read_text()
    record6 = "         1         5         2         8         2         3"
    assert text.count(record6) == 2
    path.write_text(text.replace(record6, record6[:10] + "         1" + record6[20:], 1))
    with pytest.raises(ValueError, match=exactly(
            f"{path}: its dataset-55 sets are not modes (analysis type 1, 5; "
            "modes are 2, 3 or 7)")):
        read_uff_modes(path)

    zero = write(tmp_path / "zero.uff", normal_mode(1, 10.0, 0.01, [0.0], [0.0], [5]))
    with pytest.raises(ValueError, match=exactly(f"{zero}: every dataset-55 mode shape is zero")):
        read_uff_modes(zero)


def test_geometry_from_dataset_2411_and_15_sorted_by_node(tmp_path):
    from podid_rs.io.uff import read_uff_geometry

    path = write(
        tmp_path / "geometry.uff",
        pyuff.prepare_2411(node_nums=[3, 1], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1],
                           x=[0.5, 1.25], y=[0.0, 2.0], z=[-1.0, 0.0]),
        pyuff.prepare_15(node_nums=[2], def_cs=[0], disp_cs=[0], color=[1],
                         x=[4.0], y=[5.0], z=[6.0]),
    )
    np.testing.assert_array_equal(read_uff_geometry(path),
                                  [[1, 1.25, 2, 0], [2, 4, 5, 6], [3, 0.5, 0, -1]])
    assert read_uff_geometry(write(tmp_path / "modes_only.uff",
                                   normal_mode(1, 10.0, 0.01, [1.0], [0.0], [5]))) is None


def frf_record(node: int, numerator: int):
    return pyuff.prepare_58(binary=0, func_type=4, rsp_node=node, rsp_dir=1, ref_node=1,
                            ref_dir=1, data=np.ones(3, complex), x=np.arange(1.0, 4.0),
                            abscissa_spacing=1, abscissa_spec_data_type=18,
                            ordinate_spec_data_type=numerator, orddenom_spec_data_type=13)


def test_uff_quantity_only_when_the_records_agree(tmp_path):
    from podid_rs.io.uff import uff_quantity

    same = write(tmp_path / "same.uff", frf_record(1, 11), frf_record(2, 11))
    assert uff_quantity(same) == "velocity"
    mixed = write(tmp_path / "mixed.uff", frf_record(1, 11), frf_record(2, 12))
    assert uff_quantity(mixed) is None
    none = write(tmp_path / "none.uff", normal_mode(1, 10.0, 0.01, [1.0], [0.0], [5]))
    assert uff_quantity(none) is None
    # a time response (func_type 1) in displacement beside velocity FRFs is no FRF: the
    # FRFs' ordinate is the file's
    response = dict(frf_record(3, 8), func_type=1)
    beside = write(tmp_path / "beside.uff", frf_record(1, 11), response, frf_record(2, 11))
    assert uff_quantity(beside) == "velocity"


def test_uff_quantity_reads_the_headers_only(tmp_path):
    """The ordinate is in the records' headers: a record whose values pyuff cannot read
    (a number spelled with letters) still tells it, though reading the data refuses it."""
    from podid_rs.io.uff import read_uff, uff_quantity

    good = write(tmp_path / "good.uff", frf_record(1, 11))
    last = "   1.00000000000e+00   0.00000000000e+00\n    -1"
    text = good.read_text()
    assert text.count(last) == 1  # the record's last value, just before its delimiter
    bad = tmp_path / "bad.uff"
    bad.write_text(text.replace(last, "   abcdefghijklmnop   0.00000000000e+00\n    -1"))
    with pytest.raises(ValueError, match="could not read dataset 58"):
        read_uff(bad)
    assert uff_quantity(bad) == "velocity"

def test_a_single_array_is_not_a_data_file(tmp_path):
    from podid_rs.io.npz import load_data

    path = tmp_path / "single.npz"
    with path.open("wb") as fh:
        np.save(fh, np.ones(3))
    with pytest.raises(ValueError, match=exactly(
            f"{path}: not a readable .npz file: it holds a single array, not named arrays")):
        load_data(path)
    with pytest.raises(FileNotFoundError, match=exactly(f"no such file: {tmp_path / 'no.npz'}")):
        load_data(tmp_path / "no.npz")


def test_modes_over_different_nodes_are_zero_where_a_mode_has_no_value(tmp_path):
    path = write(
        tmp_path / "partial.uff",
        normal_mode(1, 10.0, 0.01, [1.0, 0.5], [0.0, 0.0], [5, 6]),
        normal_mode(2, 20.0, 0.01, [0.25], [1.0], [6]),  # node 5 not in this set
    )
    modes = read_uff_modes(path)
    assert modes.dofs.tolist() == [[5, 1], [6, 1], [6, 2]]
    np.testing.assert_array_equal(modes.shapes, [[1.0, 0.0], [0.5, 0.25], [0.0, 1.0]])


def test_rotations_of_six_values_per_node_are_directions_4_to_6(tmp_path):
    d = pyuff.prepare_55(
        id1="a modal-analysis program", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
        model_type=1, analysis_type=2, data_ch=3, spec_data_type=8, data_type=2,
        n_data_per_node=6, r1=np.array([1.0, 0.0]), r2=np.zeros(2), r3=np.zeros(2),
        r4=np.array([0.0, 0.5]), r5=np.zeros(2), r6=np.array([-0.25, 0.0]),
        load_case=1, mode_n=1, freq=10.0, modal_m=1.0, modal_damp_vis=0.01,
        modal_damp_his=0.0, node_nums=[5, 6],
    )
    modes = read_uff_modes(write(tmp_path / "rotations.uff", d))
    assert modes.dofs.tolist() == [[5, 1], [5, 6], [6, 4]]
    np.testing.assert_array_equal(modes.shapes[:, 0], [1.0, -0.25, 0.5])
