"""FRF files laid out as columns by reciprocity: shaker columns, hammer rows, holes, duplicates.

The files are written by the tests from the exact receptances of a uniform 4-DOF chain
(every value is known). Asserted:

- a complete shaker grid (every reference among the responses) reads as before: one
  column per reference, each record at its own entry, no note, nothing averaged —
  even where H(j, k) and H(k, j) differ (they are two measurements, not one);
- a pair measured one way only fills the entry of the other way by reciprocity
  between two force DOFs, and says so; an entry nobody measured is a hole;
- the fewest force DOFs that hold every measured pair: a shaker column plus a
  roving-hammer row are two columns (their common FRF averaged, with a
  :class:`DataWarning` saying how far apart the two were); a tie goes to the file's
  reference, between two references to the lower DOF; a pair a driving point's column
  already holds counts for neither of its DOFs there; a driving point lost from a
  shaker grid leaves its pairs to the other columns, by reciprocity;
- two FRFs of one entry more than 3 dB apart are refused, naming both records;
- a force DOF no FRF measures as a response is refused (as before).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import podid_rs as pr
from podid_rs import DataWarning, read_uff

pyuff = pytest.importorskip("pyuff")

CHAIN = pr.mass_spring_chain(4, m1=1.0, m2=1.0)
FREQ = np.arange(0.0, 301.0, 1.0)
H = np.zeros((FREQ.size, 4, 4), dtype=complex)
H[1:] = CHAIN.frf(2 * np.pi * FREQ[1:])


def write(path, pairs, scale=None, frf=H):
    """One record per (response, reference) pair of 1-based DOF numbers (direction 3),
    in the given order; ``scale`` maps a record's index to a factor on its values;
    ``frf`` is the receptance written (the 4-DOF chain's unless given)."""
    records = []
    for i, (o, r) in enumerate(pairs):
        factor = 1.0 if scale is None else scale.get(i, 1.0)
        records.append(pyuff.prepare_58(
            func_type=4, rsp_node=o, rsp_dir=3, ref_node=r, ref_dir=3,
            data=factor * frf[:, o - 1, r - 1], x=FREQ, abscissa_spacing=1,
            abscissa_spec_data_type=18, ordinate_spec_data_type=8, orddenom_spec_data_type=13,
        ))
    pyuff.UFF(str(path)).write_sets(records, "add")
    return path


def entry(data, o, r):
    """The receptance of response DOF o to the force at DOF r (1-based), as read."""
    rows = [int(n) for n in data.dofs[:, 0]]
    cols = [rows[i] for i in data.inputs]
    return data.U[:, rows.index(o), cols.index(r)]


def columns(data):
    return [int(data.dofs[i, 0]) for i in data.inputs]


def test_a_complete_shaker_grid_reads_as_before(tmp_path):
    pairs = [(o, r) for o in range(1, 5) for r in (1, 3)]
    path = write(tmp_path / "grid.uff", pairs, scale={pairs.index((1, 3)): 1.2})
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        data = read_uff(path)
    assert columns(data) == [1, 3] and data.complete and data.notes == ()
    # H(1, 3) was written 1.2× off: it stays at its own entry, H(3, 1) at its own
    assert np.allclose(entry(data, 1, 3), 1.2 * H[1:, 0, 2], rtol=1e-10)
    assert np.allclose(entry(data, 3, 1), H[1:, 2, 0], rtol=1e-10)


def test_one_way_pairs_fill_by_reciprocity_and_the_rest_are_holes(tmp_path):
    # a 2-shaker grid (forces at 1 and 3) without H(3, 1), nor H(4, 3) or its mirror
    pairs = [(o, r) for o in range(1, 5) for r in (1, 3) if (o, r) not in ((3, 1), (4, 3))]
    data = read_uff(write(tmp_path / "holes.uff", pairs))
    assert columns(data) == [1, 3]
    assert np.allclose(entry(data, 3, 1), H[1:, 0, 2], rtol=1e-10)  # = H(1, 3)
    mask = data.measured
    assert mask.sum() == 7 and not mask[3, 1]  # H(4, 3): nobody measured it
    assert any("1 entry read by reciprocity" in note for note in data.notes)
    assert any("1 of the 4 × 2 entries" in note and "response (4, 3) / force at (3, 3)"
               in note for note in data.notes)
    # the 6 records have 4 response DOFs (1-4) and 2 reference DOFs (1, 3)
    assert any("the 6 FRFs of 4 response and 2 reference DOF(s)" in note
               for note in data.notes)


def test_the_hole_note_names_the_first_hole_of_the_first_force_column(tmp_path):
    """Forces at 1 and 3 over responses 1-4, without H(2, 3) and H(4, 1): the note counts
    2 holes of 4 × 2 and names the first in the force columns' order, response 4 / force 1
    (as the mask's columns, the load cases, are read), not H(2, 3) of the first row."""
    pairs = [(o, r) for o in range(1, 5) for r in (1, 3) if (o, r) not in ((2, 3), (4, 1))]
    data = read_uff(write(tmp_path / "two.uff", pairs))
    assert columns(data) == [1, 3] and data.measured.sum() == 6
    assert data.notes == (
        "two.uff: 2 of the 4 × 2 entries (response × force) were not measured, e.g. response "
        "(4, 3) / force at (1, 3): they weigh nothing in the fit and in every error",
    )


def test_a_driving_point_is_a_column_before_the_greedy_choice(tmp_path):
    """H(1, 2), H(3, 3), H(3, 4), H(4, 1), H(4, 2): the driving point makes 3 a column
    first; the pairs left, {1, 2}, {1, 4}, {2, 4}, tie at two each and go to the lower
    DOFs, 1 then 2. Counted without the driving point first, 4 (in three pairs) would
    be taken first, and the columns would be 1, 3, 4."""
    pairs = [(1, 2), (3, 3), (3, 4), (4, 1), (4, 2)]
    data = read_uff(write(tmp_path / "driving.uff", pairs))
    assert columns(data) == [1, 2, 3]
    assert np.allclose(entry(data, 3, 3), H[1:, 2, 2], rtol=1e-10)


def test_two_entries_read_by_reciprocity_are_counted_in_words(tmp_path):
    # three shakers (1, 2, 3) without H(2, 1) and H(3, 1): both from their mirrors
    pairs = [(o, r) for o in range(1, 5) for r in (1, 2, 3) if (o, r) not in ((2, 1), (3, 1))]
    data = read_uff(write(tmp_path / "three.uff", pairs))
    assert columns(data) == [1, 2, 3] and data.complete
    assert any(note.endswith("; 2 entries read by reciprocity, H(j, k) = H(k, j)")
               for note in data.notes)


def test_a_shaker_column_and_a_hammer_row_are_two_columns(tmp_path):
    """Campaign 1: a shaker at DOF 2, all four accelerometers. Campaign 2: one
    accelerometer at DOF 3, the hammer at every DOF. Both measured H(3, 2)."""
    shaker = [(o, 2) for o in range(1, 5)]
    hammer = [(3, r) for r in range(1, 5)]
    # the hammer's H(3, 2) 0.5 dB off the shaker's
    path = write(tmp_path / "two.uff", shaker + hammer, scale={len(shaker) + 1: 10 ** 0.025})
    with pytest.warns(DataWarning, match=r"response \(3, 3\) / force at \(2, 3\) was measured "
                                         r"2 times \(FRF record 3 \(response 3:3 / reference "
                                         r"2:3\), FRF record 6 .*averaged; they differ by "
                                         r"0\.50 dB"):
        data = read_uff(path)
    assert columns(data) == [2, 3] and data.complete
    assert np.allclose(entry(data, 3, 2), (1 + 10 ** 0.025) / 2 * H[1:, 2, 1], rtol=1e-10)
    assert np.allclose(entry(data, 2, 3), entry(data, 3, 2), rtol=0)  # its mirror
    for o in (1, 4):
        assert np.allclose(entry(data, o, 3), H[1:, 2, o - 1], rtol=1e-10)  # hammer row
        assert np.allclose(entry(data, o, 2), H[1:, o - 1, 1], rtol=1e-10)  # shaker column
    assert any("laid out as the FRF columns of forces at [(2, 3), (3, 3)]" in note
               for note in data.notes)
    assert any("(the fewest force DOFs that hold every measured pair)" in note
               for note in data.notes)


def test_three_measurements_of_one_entry_are_as_far_apart_as_the_widest_two(tmp_path):
    """H(3, 2) measured three times, 0.5 and 1.0 dB above the first: the pairs are 0.5,
    1.0 and 0.5 dB apart, and what the note reports is how far apart they are, 1.00 dB
    (all three are within the 3 dB that refuses, so they are averaged)."""
    shaker = [(o, 2) for o in range(1, 5)]
    path = write(tmp_path / "three.uff", shaker + [(3, 2), (3, 2)],
                 scale={4: 10 ** 0.025, 5: 10 ** 0.05})
    with pytest.warns(DataWarning, match=r"response \(3, 3\) / force at \(2, 3\) was measured "
                                         r"3 times .*averaged; they differ by 1\.00 dB"):
        data = read_uff(path)
    assert any("measured 3 times" in note and "they differ by 1.00 dB" in note
               for note in data.notes)
    mean = (1 + 10 ** 0.025 + 10 ** 0.05) / 3
    assert np.allclose(entry(data, 3, 2), mean * H[1:, 2, 1], rtol=1e-10)


def test_two_measurements_apart_by_a_drift_are_as_far_apart_as_their_median_line(tmp_path):
    """H(3, 2) measured twice, the second's level drifting linearly from 0 dB at 0 Hz to
    2 dB at 300 Hz (f / 150 dB at f Hz): the note's distance is the median over every line
    read, 1 … 300 Hz, (150 + 151) / 2 / 150 = 1.0033 dB, whatever the phase of the FRF at
    the line (its real part changes sign at the resonances). A constant factor between the
    two, as above, gives the same distance over any subset of the lines."""
    shaker = [(o, 2) for o in range(1, 5)]
    drift = 10 ** (FREQ / 150 / 20)
    path = write(tmp_path / "drift.uff", shaker + [(3, 2)], scale={4: drift})
    # the file's 13 significant digits move the dB by ~1e-11, far from 1.005's rounding
    with pytest.warns(DataWarning, match=r"response \(3, 3\) / force at \(2, 3\) was measured "
                                         r"2 times .*averaged; they differ by 1\.00 dB"):
        data = read_uff(path)
    assert np.allclose(entry(data, 3, 2), (1 + drift[1:]) / 2 * H[1:, 2, 1], rtol=1e-10)


def test_a_tie_goes_to_the_files_reference(tmp_path):
    # a shaker at 1 (driving point measured) and H(2, 3): 2 or 3 could hold that pair;
    # 3 is the file's reference, so it is read directly — only H(1, 3), the mirror of
    # H(3, 1) between the two force DOFs, comes by reciprocity
    pairs = [(1, 1), (2, 1), (3, 1), (2, 3)]
    data = read_uff(write(tmp_path / "tie.uff", pairs))
    assert columns(data) == [1, 3]
    assert np.allclose(entry(data, 2, 3), H[1:, 1, 2], rtol=1e-10)
    assert np.allclose(entry(data, 1, 3), H[1:, 2, 0], rtol=1e-10)
    assert any("1 entry read by reciprocity" in note for note in data.notes)
    assert data.n == 3 and data.measured.sum() == 5  # H(3, 3): never measured


def test_a_tie_between_two_references_goes_to_the_lower_dof(tmp_path):
    """A shaker at 1 (driving point measured), H(1, 2) and H(2, 3): the pair {2, 3} is
    held by 2 or by 3, both the file's references, each in one pair left — the lower DOF,
    2, is the column. H(2, 3) comes by reciprocity as H(3, 2), H(1, 2) is read directly,
    and no entry is measured twice (with 3 as the column H(1, 2) would become H(2, 1), a
    second measurement of the shaker's)."""
    pairs = [(1, 1), (2, 1), (3, 1), (1, 2), (2, 3)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        data = read_uff(write(tmp_path / "lower.uff", pairs))
    assert columns(data) == [1, 2]
    assert np.allclose(entry(data, 1, 2), H[1:, 0, 1], rtol=1e-10)
    assert np.allclose(entry(data, 3, 2), H[1:, 1, 2], rtol=1e-10)  # = H(2, 3)
    assert any("1 entry read by reciprocity" in note for note in data.notes)


def test_pairs_a_driving_point_holds_do_not_count_in_the_greedy_choice(tmp_path):
    """Shakers at 3 and 4 (driving points measured) with an accelerometer at 1 on both,
    H(2, 3), and a shaker at 2 measured at 1 only: H(3, 3), H(4, 4), H(1, 3), H(1, 4),
    H(1, 2), H(2, 3). 3 and 4 are columns first, and they hold {1, 3}, {1, 4} and
    {2, 3} whichever DOF of the pair is the lower; the one pair left, {1, 2}, ties at one
    pair each and goes to the file's reference 2, so H(1, 2) is read directly. Counted
    with the pairs 3 and 4 already hold, 1 (in three pairs) would be the column and
    H(1, 2) would come by reciprocity as the entry (2, 1)."""
    pairs = [(3, 3), (4, 4), (1, 3), (1, 4), (1, 2), (2, 3)]
    data = read_uff(write(tmp_path / "held.uff", pairs))
    assert columns(data) == [2, 3, 4]
    assert np.allclose(entry(data, 1, 2), H[1:, 0, 1], rtol=1e-10)
    # H(3, 2), the mirror of H(2, 3) between two force DOFs, is the one reciprocal entry
    assert np.allclose(entry(data, 3, 2), H[1:, 1, 2], rtol=1e-10)
    assert any("1 entry read by reciprocity" in note for note in data.notes)


def test_a_lost_driving_point_leaves_its_pairs_to_the_other_columns(tmp_path):
    """A 3-shaker grid whose driving point H(1, 1) is lost: the fewest columns that hold
    every pair are 2 and 3; H(2, 1), H(3, 1) are read as H(1, 2), H(1, 3) and averaged
    with those (the same FRFs by reciprocity)."""
    pairs = [(o, r) for o in range(1, 4) for r in range(1, 4) if (o, r) != (1, 1)]
    with pytest.warns(DataWarning, match="measured 2 times"):
        data = read_uff(write(tmp_path / "lost.uff", pairs))
    assert columns(data) == [2, 3] and data.complete and data.n == 3


def test_a_greedy_column_the_later_ones_make_superfluous_is_dropped(tmp_path):
    """Six DOFs: H(5, 5), H(5, 6), H(4, 6), H(3, 5), H(1, 3), H(2, 3), H(6, 1). 5 is a
    column (its driving point); of the pairs left, {4, 6} and {2, 3} share no DOF, so two
    more columns are needed, and {1, 3}, {1, 6} leave one choice: 3 and 6 — three
    columns, the fewest. The greedy pass takes 1 first (in two pairs left, as 3 and 6,
    and the lowest), then 3 and 6, which hold both of 1's pairs: 1 is dropped, not kept
    as a fourth load case."""
    chain = pr.mass_spring_chain(6)
    frf = np.zeros((FREQ.size, 6, 6), dtype=complex)
    frf[1:] = chain.frf(2 * np.pi * FREQ[1:])
    pairs = [(5, 5), (5, 6), (4, 6), (3, 5), (1, 3), (2, 3), (6, 1)]
    data = read_uff(write(tmp_path / "six.uff", pairs, frf=frf))
    assert columns(data) == [3, 5, 6] and data.p == 3
    # H(6, 1) is the entry (1, 6) of column 6, by reciprocity
    assert np.allclose(entry(data, 1, 6), frf[1:, 5, 0], rtol=1e-10)


def test_two_measurements_of_one_entry_that_disagree_are_refused(tmp_path):
    shaker = [(o, 2) for o in range(1, 5)]
    hammer = [(3, r) for r in range(1, 5)]
    path = write(tmp_path / "bad.uff", shaker + hammer, scale={len(shaker) + 1: -10.0})
    with pytest.raises(ValueError, match=r"FRF record 3 \(response 3:3 / reference 2:3\) and "
                                         r"FRF record 6 \(response 3:3 / reference 2:3\) both "
                                         r"measure response \(3, 3\) / force at \(2, 3\).*"
                                         r"differ by a median 20\.0 dB"):
        read_uff(path)


def test_two_measurements_exactly_the_limit_apart_are_averaged(tmp_path, monkeypatch):
    """The limit is inclusive: H(3, 2) measured twice, the second twice the first, is
    |20 log10(1/2)| dB apart at every line; with the limit set to exactly that the two
    are averaged (1.5 × the FRF), and with the limit a hair below it they are refused."""
    from podid_rs.io import uff

    shaker = [(o, 2) for o in range(1, 5)]
    path = write(tmp_path / "edge.uff", shaker + [(3, 2)], scale={4: 2.0})
    apart = abs(20 * np.log10(0.5))  # |a| / |b| = 1/2 exactly: scaling by 2 is exact
    monkeypatch.setattr(uff, "DUPLICATE_DB", apart)
    with pytest.warns(DataWarning, match="measured 2 times"):
        data = read_uff(path)
    assert np.allclose(entry(data, 3, 2), 1.5 * H[1:, 2, 1], rtol=1e-10)
    monkeypatch.setattr(uff, "DUPLICATE_DB", np.nextafter(apart, 0.0))
    with pytest.raises(ValueError, match=r"differ by a median 6\.0 dB"):
        read_uff(path)


def test_the_duplicate_warning_points_at_the_callers_line(tmp_path):
    # H(3, 2) measured twice, the same values: averaged with a warning at read_uff's caller
    # (left out of the mutation run, whose trampolines add frames: docs/testing.md)
    shaker = [(o, 2) for o in range(1, 5)]
    with pytest.warns(DataWarning, match="measured 2 times") as caught:
        read_uff(write(tmp_path / "twice.uff", shaker + [(3, 2)]))
    assert [c.filename for c in caught] == [__file__]


def test_a_force_no_frf_measures_as_a_response_is_refused(tmp_path):
    # a hammer row at response 3 that never hit DOF 3 itself
    pairs = [(3, r) for r in (1, 2, 4)]
    with pytest.raises(ValueError, match="not among the measured responses"):
        read_uff(write(tmp_path / "nodp.uff", pairs))


def test_the_written_model_says_which_entries_were_not_measured(tmp_path):
    pairs = [(o, r) for o in range(1, 5) for r in (1, 3) if (o, r) not in ((3, 1), (4, 3))]
    data = read_uff(write(tmp_path / "holes.uff", pairs))
    model, R = data.identify(m=4, symmetric=True)
    sets = pyuff.UFF(str(pr.write_uff(tmp_path / "model.uff", model, R, data))).read_sets()
    s58 = [d for d in sets if d["type"] == 58]
    assert len(s58) == 8  # every entry, the hole too
    notes = {(d["rsp_node"], d["ref_node"]): d["id4"] for d in s58}
    assert notes[(4, 3)].startswith("not measured") and notes[(3, 1)] == "NONE"
    assert all(d["id3"].startswith("entries read by reciprocity") for d in s58)
