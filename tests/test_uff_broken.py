"""Broken Universal Files are refused or warned about, never read as something smaller.

Every broken file here is made by the test from a good one: the real beam (cut at
several byte offsets, a delimiter removed, a data line removed), or FRFs of a 3-DOF
chain written with pyuff and then damaged (a NaN or inf written into a field, a channel
of zeros, a constant channel, one exact zero). Asserted:

- a record cut off, a missing ``    -1`` delimiter, a record whose values do not match
  its header's number of points (ASCII and binary) → ``ValueError`` naming the file and
  the record (number, dataset, response / reference DOFs, line);
- a non-finite value → ``ValueError`` naming the FRF record, its response / reference
  and the first bad line in Hz;
- an FRF zero (or constant) at every line, of the file or of the band: a dead channel →
  :class:`podid_rs.DataWarning` naming it, and that entry is a hole of
  ``MeasuredData.measured`` (neither a measurement of zero nor dropped without a word;
  the notes say so too); every FRF dead → ``ValueError``;
- an FRF exactly zero at one line (pyuff writes a NaN as 0) → a ``DataWarning`` with
  the line in Hz, the values kept;
- a record whose unit labels disagree with the other records of its ordinate (g/N among
  m/N) → a ``DataWarning`` naming the record and both labels, the record not fitted; labels
  that differ only in case, spaces or ``^`` agree; a tie between two labels → ``ValueError``;
- the file itself is never modified.
"""

from __future__ import annotations

import re
import struct
import warnings

import numpy as np
import pytest

import podid_rs as pr
from podid_rs import DataWarning, read_uff
from podid_rs.io.uff import _delimiters, _uff_int

pyuff = pytest.importorskip("pyuff")

from conftest import BEAM_UFF  # noqa: E402

DOFS = [(1, 3), (2, 3), (3, 3)]


def frf_record(rsp, ref, freq, values, binary=False):
    return pyuff.prepare_58(
        binary=int(binary), func_type=4, rsp_node=rsp[0], rsp_dir=rsp[1], ref_node=ref[0],
        ref_dir=ref[1], data=np.asarray(values, dtype=complex), x=freq, abscissa_spacing=1,
        abscissa_spec_data_type=18, ordinate_spec_data_type=8, orddenom_spec_data_type=13,
    )


def write_chain(path, change=None, binary=False, references=3):
    """The receptances of a 3-DOF chain, every response over the first ``references``
    DOFs (3: 9 records, response-major); ``change(o, r, values)`` may alter a record's
    values before it is written."""
    chain = pr.mass_spring_chain(3, m1=1.0, m2=1.0)
    freq = np.arange(0.0, 301.0, 1.0)
    H = np.zeros((freq.size, 3, 3), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])
    records = []
    for o, rsp in enumerate(DOFS):
        for r, ref in enumerate(DOFS[:references]):
            values = H[:, o, r].copy()
            if change is not None:
                values = change(o, r, values)
            records.append(frf_record(rsp, ref, freq, values, binary))
    pyuff.UFF(str(path)).write_sets(records, "add")
    return path, freq, H


def delimiters(raw: bytes) -> list[int]:
    """Offsets of the delimiter lines of a file written with '\\n' line ends."""
    out, at = [], raw.find(b"    -1\n")
    while at != -1:
        out.append(at)
        at = raw.find(b"    -1\n", at + 1)
    return out


@pytest.fixture
def beam_bytes(tmp_path):
    raw = BEAM_UFF.read_bytes()
    return raw, tmp_path


# ------------------------------------------------------------------ truncation


@pytest.mark.parametrize("where", ["in the data", "in the header", "in the closing delimiter",
                                   "after an opening delimiter", "one byte short"])
def test_a_file_cut_inside_a_record_is_refused_naming_the_record(beam_bytes, where):
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    # records of the beam: 1 is dataset 15, 2… are the 30 FRFs; record k opens at
    # tags[2(k-1)] and closes at tags[2(k-1)+1]
    record = 16
    opened, closed = tags[2 * (record - 1)], tags[2 * (record - 1) + 1]
    cut = {
        "in the data": (opened + closed) // 2,
        "in the header": opened + 300,
        "in the closing delimiter": closed + 4,
        "after an opening delimiter": opened + len(b"    -1\n"),
        "one byte short": len(raw) - len(b"    -1\n") + 3,
    }[where]
    if where == "one byte short":
        record = 31
    path = tmp / "cut.uff"
    path.write_bytes(raw[:cut])
    with pytest.raises(ValueError, match=rf"cut\.uff: record {record} of the file "
                                         r"\(dataset (58|\?).*has no closing '    -1'.*cut off"):
        read_uff(path)


def test_a_missing_delimiter_is_refused(beam_bytes):
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    closing = tags[2 * 9 + 1]  # the end of record 10 (an FRF)
    for name, damaged in [
        ("no_end.uff", raw[:closing] + raw[closing + 7:]),  # its closing delimiter removed
        ("no_start.uff", raw[:closing + 7] + raw[closing + 14:]),  # the next one's opening
    ]:
        path = tmp / name
        path.write_bytes(damaged)
        with pytest.raises(ValueError, match=r"delimiter is missing after record 10 of the "
                                             r"file \(dataset 58, response 3:-3 / reference "
                                             r"10:-3"):
            read_uff(path)
    # where the run-together text starts: the first line after record 10's end, the
    # dataset number of the record whose opening delimiter is gone
    line = damaged[:closing + 7].count(b"\n") + 1
    with pytest.raises(ValueError, match=rf"from line \d+\): line {line} \('58 +'\) belongs "
                                         r"to no record, so two records ran together$"):
        read_uff(path)


def test_a_file_with_windows_line_ends_is_checked_like_any_other(beam_bytes):
    """A file saved on Windows ends its lines with CR LF: its delimiters are still
    delimiters, so the whole file reads as the LF one does and a cut record is refused
    (pyuff reads the CR LF file too, and would drop the cut record without a word)."""
    raw, tmp = beam_bytes
    crlf = raw.replace(b"\n", b"\r\n")
    assert _delimiters(crlf) == [at + raw[:at].count(b"\n") for at in delimiters(raw)]
    whole = tmp / "windows.uff"
    whole.write_bytes(crlf)
    data, lf = read_uff(whole), read_uff(BEAM_UFF)
    assert np.array_equal(data.U, lf.U) and np.array_equal(data.omega, lf.omega)
    opened, closed = _delimiters(crlf)[2 * 15 : 2 * 15 + 2]  # record 16, an FRF
    cut = tmp / "windows_cut.uff"
    cut.write_bytes(crlf[: (opened + closed) // 2])
    with pytest.raises(ValueError, match=r"windows_cut\.uff: record 16 of the file \(dataset "
                                         r"58.*has no closing '    -1'.*cut off"):
        read_uff(cut)


def test_a_file_opening_with_a_blank_line_is_counted_from_it(beam_bytes):
    """Line numbers count every line of the file, a leading blank one too."""
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    closing = tags[2 * 9 + 1]  # record 11's opening delimiter removed
    damaged = b"\n" + raw[:closing + 7] + raw[closing + 14:]
    line = damaged[:closing + 8].count(b"\n") + 1
    path = tmp / "blank_first.uff"
    path.write_bytes(damaged)
    with pytest.raises(ValueError, match=rf"from line \d+\): line {line} \('58 +'\) belongs "
                                         r"to no record"):
        read_uff(path)


def test_a_missing_delimiter_quotes_the_stray_line_alone(beam_bytes):
    """A writer that does not pad its lines to 80 columns: the stray record's dataset
    line is quoted as it stands, not run on into the lines after it."""
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    closing = tags[2 * 9 + 1]  # the end of record 10; record 11's opening delimiter removed
    dataset_line = raw.index(b"\n", closing + 14) + 1
    path = tmp / "unpadded.uff"
    path.write_bytes(raw[:closing + 7] + b"    58\n" + raw[dataset_line:])
    with pytest.raises(ValueError, match=r"delimiter is missing after record 10 .*: line \d+ "
                                         r"\('58'\) belongs to no record"):
        read_uff(path)


def test_a_stray_line_that_is_not_ascii_is_quoted_with_replacement_characters(beam_bytes):
    """A stray line in another encoding (Latin-1 'é') is quoted with U+FFFD for the
    byte ASCII cannot read, not refused with a UnicodeDecodeError; a long one is quoted
    to its first 40 characters."""
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    closing = tags[2 * 9 + 1]
    dataset_line = raw.index(b"\n", closing + 14) + 1
    path = tmp / "latin1.uff"
    stray = b"    58 caf\xe9 " + b"0123456789" * 6
    path.write_bytes(raw[:closing + 7] + stray + b"\n" + raw[dataset_line:])
    quoted = ("58 caf\ufffd " + "0123456789" * 6)[:40]
    with pytest.raises(ValueError, match=rf"after record 10 .*: line \d+ "
                                         rf"\({re.escape(repr(quoted))}\) belongs to no record"):
        read_uff(path)


def test_a_reference_node_of_ten_digits_is_named_whole(tmp_path):
    """Record 6 of dataset 58 holds the reference node in an I10 field (columns 67–76):
    a node number of all ten digits is named as it is."""
    freq = np.arange(1.0, 11.0)
    path = tmp_path / "ten.uff"
    pyuff.UFF(str(path)).write_sets(
        [frf_record((k, 3), (1234567890, 3), freq, np.full(10, k + 1j)) for k in (1, 2, 3)],
        "add")
    raw = path.read_bytes()
    tags = delimiters(raw)
    path.write_bytes(raw[:tags[2]] + raw[tags[2] + 7:])  # record 2's opening delimiter
    with pytest.raises(ValueError, match=r"delimiter is missing after record 1 of the file "
                                         r"\(dataset 58, response 1:3 / reference "
                                         r"1234567890:3, from line 1\)"):
        read_uff(path)


@pytest.mark.parametrize("lines_kept", [0, 1, 6, 7])
def test_a_file_cut_in_a_records_header_names_what_it_holds(tmp_path, lines_kept):
    """The message names what the cut record's header holds, and no more: cut right
    after its opening delimiter, the dataset is '?'; after the dataset line, 58 alone;
    cut inside record 6 of the header (the DOFs' line), still no DOFs; with that line
    whole (no line end after it), both DOFs — the response node of all ten digits of
    its I10 field (columns 42–51)."""
    freq = np.arange(1.0, 11.0)
    path = tmp_path / "cut.uff"
    pyuff.UFF(str(path)).write_sets(
        [frf_record((1234567890, 3), (k, -2), freq, np.full(10, k + 1j)) for k in (1, 2)],
        "add")
    raw = path.read_bytes()
    opened = delimiters(raw)[2]  # record 2's opening delimiter
    end = opened + len(b"    -1")
    for _ in range(lines_kept):
        end = raw.index(b"\n", end + 1)
    path.write_bytes(raw[:end])  # no line end after the last line kept
    line = raw[:opened].count(b"\n") + 1
    held = {0: "dataset \\?", 1: "dataset 58", 6: "dataset 58",
            7: "dataset 58, response 1234567890:3 / reference 2:-2"}[lines_kept]
    with pytest.raises(ValueError, match=rf"cut\.uff: record 2 of the file \({held}, from "
                                         rf"line {line}\) has no closing '    -1': the file "
                                         r"ends inside it \(cut off\?\) or its closing "
                                         r"delimiter is missing$"):
        read_uff(path)


def test_a_file_cut_between_the_response_and_the_reference_names_neither(tmp_path):
    """Cut inside the DOFs' line after its 60th column: the response's fields (columns
    42–55) are whole, the reference's (67–80) absent; the message names no DOF rather
    than half a pair."""
    freq = np.arange(1.0, 11.0)
    path = tmp_path / "half.uff"
    pyuff.UFF(str(path)).write_sets(
        [frf_record((7, 3), (k, -2), freq, np.full(10, k + 1j)) for k in (1, 2)], "add")
    raw = path.read_bytes()
    opened = delimiters(raw)[2]  # record 2's opening delimiter
    end = opened + len(b"    -1")
    for _ in range(6):
        end = raw.index(b"\n", end + 1)
    path.write_bytes(raw[:end + 1 + 60])  # 60 columns of the DOFs' line
    line = raw[:opened].count(b"\n") + 1
    with pytest.raises(ValueError, match=rf"half\.uff: record 2 of the file \(dataset 58, from "
                                         rf"line {line}\) has no closing '    -1'"):
        read_uff(path)


def test_unevenly_spaced_records_are_counted_with_their_abscissae(tmp_path):
    """Abscissa spacing 0: each point holds its frequency beside the value (ASCII: 3
    fields of a complex point, binary: 3 numbers). Whole records are read (binary to
    every digit, ASCII to its 12); one data line short is refused with both counts."""
    chain = pr.mass_spring_chain(3, m1=1.0, m2=1.0)
    freq = np.array([10.0, 12.5, 20.0, 31.0, 47.0])
    H = chain.frf(2 * np.pi * freq)
    for binary in (0, 1):
        path = tmp_path / f"uneven{binary}.uff"
        pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(
            binary=binary, func_type=4, rsp_node=rsp[0], rsp_dir=rsp[1], ref_node=ref[0],
            ref_dir=ref[1], data=H[:, o, r].astype(complex), x=freq, abscissa_spacing=0,
            abscissa_spec_data_type=18, ordinate_spec_data_type=8, orddenom_spec_data_type=13,
        ) for o, rsp in enumerate(DOFS) for r, ref in enumerate(DOFS)], "add")
        data = read_uff(path)
        np.testing.assert_array_equal(data.omega, 2 * np.pi * freq)
        assert np.max(np.abs(data.U - H) / np.abs(H)) <= (0 if binary else 1e-11)
    raw = (tmp_path / "uneven0.uff").read_bytes()
    line = raw[delimiters(raw)[0]:].split(b"\n")[14] + b"\n"  # record 1's second point
    assert line.split()[0] == b"1.25000e+01"
    (tmp_path / "short.uff").write_bytes(raw.replace(line, b"", 1))
    with pytest.raises(ValueError, match=r"record 1 of the file .* holds 12 values where its "
                                         r"header announces 5 points \(15 values\)"):
        read_uff(tmp_path / "short.uff")


def test_an_ordinate_type_pyuff_cannot_read_is_left_to_pyuff_and_named(tmp_path):
    """Record 7's ordinate data type 3 (no UFF type): the value count is not checked
    against a layout there is none of; pyuff's refusal names the record."""
    path, _, _ = write_chain(tmp_path / "ordinate.uff")
    lines = path.read_bytes().split(b"\n")
    assert lines[8].startswith(b"         6")  # record 1's ordinate type: complex double
    lines[8] = b"         3" + lines[8][10:]
    path.write_bytes(b"\n".join(lines))
    with pytest.raises(ValueError, match=r"ordinate\.uff: could not read dataset 58: record 1 "
                                         r"of the file \(dataset 58, response 1:3 / reference "
                                         r"1:3, from line 1\)"):
        read_uff(path)


def test_an_frf_over_time_is_refused_by_its_abscissa(tmp_path):
    path = tmp_path / "time.uff"
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(
        func_type=4, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, data=np.ones(5, complex),
        x=np.arange(5.0), abscissa_spacing=1, abscissa_spec_data_type=17,
        ordinate_spec_data_type=8, orddenom_spec_data_type=13,
    )], "add")
    with pytest.raises(ValueError, match=r"time\.uff: FRF record 1: the abscissa is not "
                                         r"frequency \(specific data type 18\)$"):
        read_uff(path)


def test_every_kind_of_force_is_a_denominator(tmp_path):
    """A denominator of general force (1) or reaction force (9) is a force as much as an
    excitation force (13): records over each are read, the same receptances as the file
    whose records are all over excitation forces (the same values written the same way)."""
    path, freq, H = write_chain(tmp_path / "chain.uff")
    expected = read_uff(path)
    records = []
    for k, (o, r) in enumerate((o, r) for o in range(3) for r in range(3)):
        record = frf_record(DOFS[o], DOFS[r], freq, H[:, o, r])
        record.update(orddenom_spec_data_type=(1, 9, 13)[k % 3])
        records.append(record)
    forces = tmp_path / "forces.uff"
    pyuff.UFF(str(forces)).write_sets(records, "add")
    data = read_uff(forces)
    assert data.measured.all()
    np.testing.assert_array_equal(data.U, expected.U)


def test_two_frequency_lines_are_data(tmp_path):
    """The fewest lines an FRF can have: two are read, not refused."""
    chain = pr.mass_spring_chain(3, m1=1.0, m2=1.0)
    freq = np.array([10.0, 20.0])
    H = chain.frf(2 * np.pi * freq)
    path = tmp_path / "two.uff"
    pyuff.UFF(str(path)).write_sets(
        [frf_record(rsp, ref, freq, H[:, o, r], binary=True)
         for o, rsp in enumerate(DOFS) for r, ref in enumerate(DOFS)], "add")
    data = read_uff(path)
    np.testing.assert_array_equal(data.omega, 2 * np.pi * freq)
    np.testing.assert_array_equal(data.U, H)  # binary: every digit


def test_a_record_whose_values_do_not_match_its_header_is_refused(beam_bytes):
    raw, tmp = beam_bytes
    tags = delimiters(raw)
    lines = raw[tags[2 * 4]:tags[2 * 4 + 1]].split(b"\n")  # record 5
    line = lines[30] + b"\n"  # a data line of 4 values
    path = tmp / "short.uff"
    path.write_bytes(raw.replace(line, b"", 1))
    with pytest.raises(ValueError, match=r"record 5 of the file \(dataset 58, response "
                                         r"3:-3 / reference 5:-3, from line \d+\) holds 2046 "
                                         r"values where its header announces 1025 points "
                                         r"\(2050 values\): the record is truncated or "
                                         r"damaged$"):
        read_uff(path)
    # its header says 1024 points, its data hold 1025
    header = lines[8]
    assert b"      1025" in header
    path.write_bytes(raw.replace(header, header.replace(b"      1025", b"      1024"), 1))
    with pytest.raises(ValueError, match=r"record 2 of the file .* holds 2050 values where "
                                         r"its header announces 1024 points"):
        read_uff(path)


def test_a_complex_single_precision_record_is_counted_two_values_a_point(tmp_path):
    """Ordinate type 5 (complex, single precision; pyuff writes only double): six fields
    of 13 columns a line, two values a point. Record 1 rewritten so is read, to the six
    digits of E13.5; one value short, it is refused with both counts."""
    path, _, H = write_chain(tmp_path / "chain.uff")
    raw = path.read_bytes()
    start, end = delimiters(raw)[:2]
    lines = raw[start:end].split(b"\n")
    values = [float(v) for line in lines[13:] for v in line.split()]
    assert lines[8][:20] == b"         6       301"
    header = [*lines[:8], b"         5" + lines[8][10:], *lines[9:13]]

    def single(values):
        fields = [b"%13.5e" % v for v in values]
        return [b"".join(fields[i:i + 6]) for i in range(0, len(fields), 6)]

    for kept, ok in ((values, True), (values[:-1], False)):
        record = b"\n".join([*header, *single(kept)]) + b"\n"
        path.write_bytes(raw[:start] + record + raw[end:])
        if ok:
            data = read_uff(path)
            assert np.max(np.abs(data.U - H[1:]) / np.abs(H[1:]).max()) < 1e-5
        else:
            with pytest.raises(ValueError, match=r"record 1 of the file .* holds 601 values "
                                                 r"where its header announces 301 points "
                                                 r"\(602 values\)"):
                read_uff(path)


@pytest.mark.parametrize("ordinate", [5, 2])
def test_a_binary_single_precision_record_is_counted_four_bytes_a_value(tmp_path, ordinate):
    """Binary ordinate type 5 (complex, single precision) or 2 (real, single: the real
    part kept): 4 bytes a value. Record 1 rewritten so is read to single precision;
    4 bytes short, it is refused."""
    path, _, H = write_chain(tmp_path / "bin.uff", binary=True)
    raw = path.read_bytes()
    start, end = delimiters(raw)[:2]
    lines = raw[start:end].split(b"\n", 13)
    assert lines[8][:20] == b"         6       301"
    header = [*lines[:8], b"%10d" % ordinate + lines[8][10:], *lines[9:13]]
    values = np.frombuffer(lines[13], dtype="<f8").astype("<f4")
    values = (values if ordinate == 5 else values[::2]).tobytes()
    count = 602 if ordinate == 5 else 301
    for body, ok in ((values, True), (values[:-4], False)):
        path.write_bytes(raw[:start] + b"\n".join([*header, body]) + raw[end:])
        if ok:
            data = read_uff(path)
            want = H[1:, 0, 0] if ordinate == 5 else H[1:, 0, 0].real
            assert np.max(np.abs(data.U[:, 0, 0] - want)) < 1e-6 * np.abs(want).max()
        else:
            with pytest.raises(ValueError, match=rf"record 1 of the file .* holds {count - 1} "
                                                 rf"values where its header announces 301 "
                                                 rf"points \({count} values\)"):
                read_uff(path)


def test_a_binary_record_short_of_bytes_is_refused(tmp_path):
    path, _, _ = write_chain(tmp_path / "bin.uff", binary=True)
    raw = path.read_bytes()
    tags = delimiters(raw)
    closing = tags[2 * 3 + 1]  # record 4: response 2 / reference 1
    path.write_bytes(raw[:closing - 16] + raw[closing:])
    with pytest.raises(ValueError, match=r"record 4 of the file \(dataset 58, response 2:3 / "
                                         r"reference 1:3, from line \d+\) holds 600 values "
                                         r"where its header announces 301 points \(602 "
                                         r"values\): the record is truncated or damaged$"):
        read_uff(path)


def test_a_record_without_its_dataset_number_is_refused_by_name(tmp_path):
    """The line after an opening delimiter must be the dataset number."""
    path = tmp_path / "nameless.uff"
    path.write_bytes(b"    -1\n  abc\n    -1\n")
    with pytest.raises(ValueError, match=r"nameless\.uff: record 1 of the file \(dataset \?, "
                                         r"from line 1\) has no dataset number after its "
                                         r"opening '    -1': a delimiter is missing, or the "
                                         r"record is damaged$"):
        read_uff(path)
    # a record of one line, its delimiter padded to column 80 and closed on the same line
    path.write_bytes(b"    -1" + b" " * 74 + b"    -1\n")
    with pytest.raises(ValueError, match=r"nameless\.uff: record 1 of the file \(dataset \?, "
                                         r"from line 1\) has no dataset number after"):
        read_uff(path)
    # a record of its dataset number alone is left to pyuff, which cannot read it either
    path.write_bytes(b"    -1\n    58    -1\n")
    with pytest.raises(ValueError, match=r"nameless\.uff: could not read dataset 58: record 1 "
                                         r"of the file \(dataset 58, from line 1\)"):
        read_uff(path)


def test_bytes_after_a_binary_records_values_are_counted_unless_line_ends(tmp_path):
    """Binary record 4 with 16 bytes (zeros, letters, blanks) after its values: two values
    more than its header announces, refused by the count; with line ends there, the count
    lets it pass (a line end may close the values) and what pyuff returns is refused."""
    path, _, _ = write_chain(tmp_path / "bin.uff", binary=True)
    raw = path.read_bytes()
    closing = delimiters(raw)[2 * 3 + 1]
    for extra in (b"\0" * 16, b"X" * 16, b" " * 16):  # not line ends: counted
        path.write_bytes(raw[:closing] + extra + raw[closing:])
        with pytest.raises(ValueError, match=r"record 4 of the file \(dataset 58, response "
                                             r"2:3 / reference 1:3, from line \d+\) holds 604 "
                                             r"values where its header announces 301 points"):
            read_uff(path)
    path.write_bytes(raw[:closing] + b"\n" * 8 + raw[closing:])
    with pytest.raises(ValueError, match=r"FRF record 4: abscissa and ordinate must be 1-D"):
        read_uff(path)


def test_the_whole_file_reads_and_is_not_modified(beam_bytes):
    raw, _ = beam_bytes
    data = read_uff(BEAM_UFF)
    assert data.n == 30 and data.complete and BEAM_UFF.read_bytes() == raw
    # a file whose last line lacks its line end is whole
    path = beam_bytes[1] / "no_newline.uff"
    path.write_bytes(raw[:-1])
    assert read_uff(path).n == 30


# ------------------------------------------------------------------ values


@pytest.mark.parametrize("value", ["nan", "inf"])
def test_a_non_finite_value_is_refused_with_its_line(tmp_path, value):
    path, _, _ = write_chain(tmp_path / "ascii.uff")
    raw = path.read_bytes()
    tags = delimiters(raw)
    block = raw[tags[2 * 4]:tags[2 * 4 + 1]]  # record 5: response 2 / reference 2
    lines = block.split(b"\n")
    # data line 10 holds the real and imaginary parts of lines 18 and 19 (2 values each);
    # its third field is the real part of line 19: 19 Hz
    fields = [lines[13 + 9][20 * i:20 * (i + 1)] for i in range(4)]
    fields[2] = value.rjust(20).encode()
    damaged = block.replace(lines[13 + 9], b"".join(fields), 1)
    path.write_bytes(raw.replace(block, damaged, 1))
    with pytest.raises(ValueError, match=r"FRF record 5 \(response 2:3 / reference 2:3\): its "
                                         rf"value at 19 Hz \(line 20 of 301\) is \(?{value}"):
        read_uff(path)


def test_a_non_finite_binary_value_is_refused(tmp_path):
    path, _, _ = write_chain(tmp_path / "bin.uff", binary=True)
    raw = path.read_bytes()
    tags = delimiters(raw)
    closing = tags[2 * 1 + 1]  # record 2: response 1 / reference 2
    start = closing - 301 * 16  # its 301 complex values, 16 bytes each
    at = start + 16 * 150 + 8  # the imaginary part at 150 Hz
    path.write_bytes(raw[:at] + struct.pack("<d", np.nan) + raw[at + 8:])
    with pytest.raises(ValueError, match=r"FRF record 2 \(response 1:3 / reference 2:3\): its "
                                         r"value at 150 Hz"):
        read_uff(path)
    # one bad value alone: no "more line(s)"; a second one counted
    with pytest.raises(ValueError, match=r"\(line 151 of 301\) is \([^ )]*nanj\): non-finite "
                                         r"values cannot be fitted; repair or remove the "
                                         r"record$"):
        read_uff(path)
    second = at + 16 * 10  # the imaginary part at 160 Hz too
    path.write_bytes(path.read_bytes()[:second] + struct.pack("<d", np.nan)
                     + path.read_bytes()[second + 8:])
    with pytest.raises(ValueError, match=r"\(line 151 of 301\) is \S+ and at 1 more line\(s\): "
                                         r"non-finite values"):
        read_uff(path)


def test_a_dead_channel_is_a_hole_with_a_warning(tmp_path):
    """Two shakers (at DOFs 1 and 2), three accelerometers; the one at DOF 3 is dead in
    the first run. Nothing else measured H(3, 1) (DOF 3 is not a force DOF, so
    reciprocity cannot supply it): a hole."""
    path, freq, H = write_chain(tmp_path / "dead.uff", references=2,
                                change=lambda o, r, v: 0 * v if (o, r) == (2, 0) else v)
    with pytest.warns(DataWarning, match=r"dead\.uff: FRF record 5 \(response 3:3 / reference "
                                         r"1:3\) is zero at every line in the file: a dead "
                                         r"channel; that entry is treated as not measured"):
        data = read_uff(path)
    assert data.p == 2 and not data.measured[2, 0] and data.measured.sum() == 5
    assert any("dead channel" in note for note in data.notes)
    assert any("1 of the 3 × 2 entries" in note for note in data.notes)
    assert np.all(data.U[:, 2, 0] == 0) and np.allclose(data.U[:, 2, 1], H[1:, 2, 1], rtol=1e-10)


def test_a_channel_dead_over_the_band_only_is_a_hole_there(tmp_path):
    def dead_in_band(o, r, v):
        if (o, r) == (2, 1):
            v = v.copy()
            v[(freq_band[0] <= np.arange(v.size)) & (np.arange(v.size) <= freq_band[1])] = 0
        return v

    freq_band = (100.0, 200.0)
    path, _, _ = write_chain(tmp_path / "band.uff", change=dead_in_band, references=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)  # live over the whole file… but zero lines
        with pytest.raises(DataWarning, match="exactly 0 at 101 line"):
            read_uff(path)
    with pytest.warns(DataWarning, match=r"FRF record 6 \(response 3:3 / reference 2:3\) is "
                                         r"zero at every line of the band"):
        data = read_uff(path, band_hz=freq_band)
    assert not data.measured[2, 1] and data.measured.sum() == 5


def test_a_constant_channel_is_dead_too(tmp_path):
    path, _, _ = write_chain(
        tmp_path / "const.uff", references=2,
        change=lambda o, r, v: np.full_like(v, 1e-3) if (o, r) == (2, 1) else v)
    with pytest.warns(DataWarning, match=r"FRF record 6 .* is the constant 0.001.*dead"):
        data = read_uff(path)
    assert not data.measured[2, 1]


def test_a_channel_constant_over_three_lines_is_dead_and_over_two_is_data(tmp_path):
    # three equal values are the fewest that say "constant"; two lines may be a live
    # channel that happens to repeat (the band of 100-102 Hz holds 3 lines, 100-101 Hz 2)
    def constant_at_100_to_102_hz(o, r, v):
        if (o, r) == (2, 1):
            v = v.copy()
            v[100:103] = 1e-3
        return v

    path, _, _ = write_chain(tmp_path / "three.uff", change=constant_at_100_to_102_hz,
                             references=2)
    with pytest.warns(DataWarning, match=r"FRF record 6 .* is the constant 0.001\+0j at every "
                                         r"line of the band: a dead channel"):
        data = read_uff(path, band_hz=(100.0, 102.0))
    assert data.omega.size == 3 and not data.measured[2, 1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        two = read_uff(path, band_hz=(100.0, 101.0))
    assert two.omega.size == 2 and two.measured[2, 1]


@pytest.mark.parametrize("quantity,code", [("velocity", 11), ("acceleration", 12)])
def test_a_constant_mobility_or_accelerance_channel_is_dead(tmp_path, quantity, code):
    """The channel is judged as written: an accelerometer's record holding 0.5 at every
    line is a dead channel, though as a receptance (÷ −ω²) it is not constant."""
    freq = np.arange(1.0, 21.0)
    live = 1.0 / (1.0 + 1j * freq)
    records = [
        pyuff.prepare_58(binary=0, func_type=4, rsp_node=rsp, rsp_dir=3, ref_node=1, ref_dir=3,
                         data=values.astype(complex), x=freq, abscissa_spacing=1,
                         abscissa_spec_data_type=18, ordinate_spec_data_type=code,
                         orddenom_spec_data_type=13)
        for rsp, values in ((1, live), (2, np.full(freq.size, 0.5)))
    ]
    pyuff.UFF(str(tmp_path / "acc.uff")).write_sets(records, "add")
    with pytest.warns(DataWarning, match=r"FRF record 2 \(response 2:3 / reference 1:3\) is the "
                                         r"constant 0.5\+0j at every line in the file: a dead "
                                         r"channel"):
        data = read_uff(tmp_path / "acc.uff")
    assert data.dofs.tolist() == [[1, 3]]  # the dead one left out, the live one read


def _nan_at_42_hz(o, r, v):
    """The record of response 1 / reference 1 with a NaN at 42 Hz (pyuff writes it as 0)."""
    if (o, r) == (1, 1):
        v = v.copy()
        v[42] = np.nan
    return v


def test_an_exact_zero_at_one_line_is_warned_about(tmp_path):
    path, _, H = write_chain(tmp_path / "zero.uff", change=_nan_at_42_hz)
    with pytest.warns(DataWarning, match=r"FRF record 5 \(response 2:3 / reference 2:3\) is "
                                         r"exactly 0 at 1 line\(s\), the first at 42 Hz: a "
                                         r"lost value\? \(pyuff writes NaN as 0\); kept, those "
                                         r"lines have no dB error$"):
        data = read_uff(path)
    assert data.complete and data.U[41, 1, 1] == 0  # line 42 Hz (the 0 Hz line is dropped)


def test_exact_zeros_at_two_lines_are_counted_and_the_first_is_named(tmp_path):
    """NaNs written at 42 and 50 Hz (pyuff writes them as 0): the warning counts 2 lines
    and names the lower, 42 Hz."""

    def two_nans(o, r, v):
        if (o, r) == (1, 1):
            v = v.copy()
            v[[42, 50]] = np.nan
        return v

    path, _, _ = write_chain(tmp_path / "zeros.uff", change=two_nans)
    with pytest.warns(DataWarning, match=r"FRF record 5 \(response 2:3 / reference 2:3\) is "
                                         r"exactly 0 at 2 line\(s\), the first at 42 Hz: "):
        read_uff(path)


def test_every_channel_dead_is_refused(tmp_path):
    path, _, _ = write_chain(tmp_path / "all.uff", change=lambda o, r, v: 0 * v)
    with pytest.raises(ValueError, match="every FRF record is zero at every line"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DataWarning)
            read_uff(path)


# ------------------------------------------------------------------ units


def write_labelled(path, labels, denominators=None):
    """The 3-DOF chain's 9 receptances, record k's numerator units labelled ``labels[k]``
    and its denominator's ``denominators[k]`` (default N)."""
    chain = pr.mass_spring_chain(3, m1=1.0, m2=1.0)
    freq = np.arange(0.0, 301.0, 1.0)
    H = np.zeros((freq.size, 3, 3), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])
    records = []
    for k, (o, r) in enumerate((o, r) for o in range(3) for r in range(3)):
        record = frf_record(DOFS[o], DOFS[r], freq, H[:, o, r])
        record.update(ordinate_axis_units_lab=labels[k],
                      orddenom_axis_units_lab="N" if denominators is None else denominators[k])
        records.append(record)
    pyuff.UFF(str(path)).write_sets(records, "add")
    return path


def test_a_record_in_other_units_is_left_out_and_named(tmp_path):
    labels = ["m"] * 9
    labels[5] = "mm"  # record 6: response 2:3 / reference 3:3
    path = write_labelled(tmp_path / "units.uff", labels)
    with pytest.warns(DataWarning, match=r"FRF record\(s\) 6 \(response 2:3 / reference 3:3, "
                      r"'mm/n'\) are in other units than the 8 other displacement records "
                      r"\('m/n'\): left out as not measured") as caught:
        data = read_uff(path)
    assert len([w for w in caught if "units" in str(w.message)]) == 1
    # 2:3/3:3 was measured once more, as 3:3/2:3 (reciprocity): the entry stays measured
    # from that record alone, the same values as a file without record 6
    labels[5] = "m"
    clean = read_uff(write_labelled(tmp_path / "clean.uff", labels))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DataWarning)
        np.testing.assert_allclose(data.U, clean.U, rtol=0, atol=1e-14 * np.abs(clean.U).max())
    assert any("other units" in note for note in data.notes)


def test_two_records_in_two_other_units_are_named_in_one_whole_message(tmp_path):
    """Records 2 and 6 in mm and in: one warning names both, in file order, and says
    what to do; the note is the same text after the file's name."""
    labels = ["m"] * 9
    labels[1], labels[5] = "in", "mm"  # 1:3 / 2:3 and 2:3 / 3:3 (each measured twice)
    path = write_labelled(tmp_path / "units2.uff", labels)
    text = ("FRF record(s) 2 (response 1:3 / reference 2:3, 'in/n'), 6 (response 2:3 / "
            "reference 3:3, 'mm/n') are in other units than the 7 other displacement "
            "records ('m/n'): left out as not measured (convert them to include them)")
    with pytest.warns(DataWarning, match=f"^{re.escape(f'{path}: {text}')}$"):
        data = read_uff(path)
    assert f"units2.uff: {text}" in data.notes


def test_records_without_unit_labels_are_kept_when_the_labelled_ones_disagree(tmp_path):
    """Records 8 and 9 carry no units (NONE over NONE) and record 7 is in mm among m: only
    record 7 is left out. Record 9, the driving point 3:3 / 3:3, is measured by nothing
    else, so without it the layout would change; the data are those of the clean file."""
    labels = ["m"] * 6 + ["mm", "NONE", "NONE"]  # record 7: response 3:3 / reference 1:3
    denominators = ["N"] * 7 + ["NONE", "NONE"]
    with pytest.warns(DataWarning, match=r"FRF record\(s\) 7 \(response 3:3 / reference "
                      r"1:3, 'mm/n'\) are in other units than the 6 other displacement "
                      r"records \('m/n'\): left out"):
        data = read_uff(write_labelled(tmp_path / "unlabelled.uff", labels, denominators))
    clean = read_uff(write_labelled(tmp_path / "clean.uff", ["m"] * 9))
    assert data.measured.all()
    np.testing.assert_array_equal(data.dofs[data.inputs], clean.dofs[clean.inputs])
    # 3:3 / 1:3 is measured once more, as 1:3 / 3:3 (reciprocity): the same values
    np.testing.assert_allclose(data.U, clean.U, rtol=0, atol=1e-14 * np.abs(clean.U).max())


def _read_whole_as_the_clean_file(tmp_path, name, labels, denominators):
    """The chain's file with these unit labels is read without a DataWarning, every entry
    kept, and holds the data of the file labelled m/N throughout."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        data = read_uff(write_labelled(tmp_path / name, labels, denominators))
    clean = read_uff(write_labelled(tmp_path / "clean.uff", ["m"] * 9))
    assert data.measured.all()
    np.testing.assert_array_equal(data.U, clean.U)


def test_records_labelled_in_part_are_compared_on_the_part_they_give(tmp_path):
    """Records 2 and 5 say m over NONE (a writer that left out the force's unit) among
    m/N: they agree and are kept. Record 8 says mm over NONE: its numerator disagrees,
    and it is left out, the message counting the 8 labelled records that agree."""
    labels, denominators = ["m"] * 9, ["N"] * 9
    denominators[1] = denominators[4] = "NONE"
    _read_whole_as_the_clean_file(tmp_path, "part.uff", labels, denominators)
    labels[7], denominators[7] = "mm", "NONE"  # record 8: response 3:3 / reference 2:3
    with pytest.warns(DataWarning, match=r"FRF record\(s\) 8 \(response 3:3 / reference "
                      r"2:3, 'mm/'\) are in other units than the 8 other displacement "
                      r"records \('m/n'\): left out"):
        read_uff(write_labelled(tmp_path / "part_mm.uff", labels, denominators))


def test_records_labelled_on_different_parts_agree(tmp_path):
    """No record says both units: records 1–5 say m over NONE, 6 and 7 NONE over N, 8 and
    9 nothing. The unit is then the most common label, m over nothing, and a record that
    gives only the part the unit lacks (the force's N) has nothing to disagree with: every
    record is kept, and the data are those of the clean file."""
    labels = ["m"] * 5 + ["NONE"] * 4
    denominators = ["NONE"] * 5 + ["N"] * 2 + ["NONE"] * 2
    _read_whole_as_the_clean_file(tmp_path, "halves.uff", labels, denominators)


def test_records_of_another_ordinate_are_compared_with_their_own_kind_only(tmp_path):
    """The driving points (records 1, 5, 9) are accelerances labelled m/s^2 over N among
    receptances labelled m over N: each ordinate has its own unit, so none is left out,
    and the data are the clean file's receptances. The accelerances are −ω² H written to
    12 significant digits (E20.11) and divided by −ω² again: 1e-10 relative holds that."""
    chain = pr.mass_spring_chain(3, m1=1.0, m2=1.0)
    freq = np.arange(0.0, 301.0, 1.0)
    H = np.zeros((freq.size, 3, 3), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])
    records = []
    for o in range(3):
        for r in range(3):
            record = frf_record(DOFS[o], DOFS[r], freq, H[:, o, r])
            record.update(ordinate_axis_units_lab="m", orddenom_axis_units_lab="N")
            if o == r:
                record.update(data=-((2 * np.pi * freq) ** 2) * H[:, o, r],
                              ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2")
            records.append(record)
    path = tmp_path / "mixed.uff"
    pyuff.UFF(str(path)).write_sets(records, "add")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        data = read_uff(path)
    clean = read_uff(write_labelled(tmp_path / "clean.uff", ["m"] * 9))
    assert data.measured.all()
    np.testing.assert_allclose(data.U, clean.U, rtol=1e-10, atol=0)


def test_the_unit_is_the_most_common_full_label(tmp_path):
    """Records 2, 3 and 6 say m/s over NONE (velocity labels on displacement data), records
    1 and 5 m/N, the rest nothing: the full label m/N is the unit, and the three half labels,
    which disagree with it on the numerator, are left out (their reciprocals remain) — a
    count over every label would have made 'm/s/' the unit. The denominator is the part
    after the last '/', so m/s over N is 'm/s' / 'n'."""
    from podid_rs.io.uff import _unit_parts

    assert _unit_parts("m/s/n") == ("m/s", "n") and _unit_parts("m/s/") == ("m/s", "")
    labels, denominators = ["NONE"] * 9, ["NONE"] * 9
    for k in (1, 2, 5):  # 1:3 / 2:3, 1:3 / 3:3, 2:3 / 3:3
        labels[k] = "m/s"
    for k in (0, 4):  # the driving points 1:3 and 2:3
        labels[k], denominators[k] = "m", "N"
    with pytest.warns(DataWarning, match=r"FRF record\(s\) 2 .*, 3 .*, 6 .* are in other "
                      r"units than the 2 other displacement records \('m/n'\)"):
        data = read_uff(write_labelled(tmp_path / "full.uff", labels, denominators))
    assert data.measured.all()


def test_labels_that_differ_in_spelling_only_agree(tmp_path):
    labels = ["m"] * 4 + ["M"] * 3 + [" m "] * 2
    path = write_labelled(tmp_path / "spelling.uff", labels)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        read_uff(path)


def test_how_far_apart_two_records_are_counts_the_lines_both_hold():
    # the median |dB| over lines 0 and 1 (0 and 20 dB); line 2, where one record is zero,
    # has no ratio and is not counted
    from podid_rs.io.uff import _median_db_apart

    assert _median_db_apart(np.array([1.0, 10.0, 0.0]), np.array([1.0, 1.0, 5.0])) == 10.0
    assert _median_db_apart(np.zeros(3), np.ones(3)) == 0.0
    # and the same with the zero in the other record: no line of either is counted where
    # the other is zero (a ratio to zero would be an infinite dB)
    assert _median_db_apart(np.array([1.0, 1.0, 5.0]), np.array([1.0, 10.0, 0.0])) == 10.0
    assert _median_db_apart(np.ones(3), np.zeros(3)) == 0.0


def test_labels_none_or_empty_are_no_units():
    # pyuff writes NONE where a file gives no units: such a record is unlabelled (kept
    # whatever the others say), and a label is normalised (case, spaces, ^ * and brackets)
    from podid_rs.io.uff import _units

    assert _units({"ordinate_axis_units_lab": "NONE", "orddenom_axis_units_lab": " none "}) is None
    assert _units({}) is None
    assert _units({"ordinate_axis_units_lab": "(m/s^2)", "orddenom_axis_units_lab": "NONE"}) \
        == "m/s2/"
    assert _units({"ordinate_axis_units_lab": "M", "orddenom_axis_units_lab": "[N]"}) == "m/n"


def test_a_tie_between_two_units_is_refused(tmp_path):
    labels = ["m"] * 4 + ["g"] * 4 + ["NONE"]
    path = write_labelled(tmp_path / "tie.uff", labels)
    with pytest.raises(ValueError, match=r"the displacement FRF records disagree on their "
                       r"units, as many in 'm/n' as in 'g/n' \(records \[1, 2, 3, 4\] against "
                       r"\[5, 6, 7, 8\]\): convert them to one unit"):
        read_uff(path)


def test_a_record_left_out_for_its_units_is_not_fitted(tmp_path):
    """The driving point 2:3 / 2:3 in other units: without it the fewest columns that
    hold every other record are the forces at 1 and 3 (by reciprocity), and no value of
    record 5 reaches the data."""
    labels = ["m"] * 9
    labels[4] = "in"  # record 5: the driving point 2:3 / 2:3, measured once
    with pytest.warns(DataWarning) as caught:
        data = read_uff(write_labelled(tmp_path / "hole.uff", labels))
    messages = [str(w.message) for w in caught]
    assert len(messages) == 3
    assert re.search(r"FRF record\(s\) 5 \(response 2:3 / reference 2:3", messages[0])
    # the pairs 2:3 / 1:3 and 2:3 / 3:3, each read both ways round, are averaged as any
    # reciprocal pair; the file holds the same value both ways: 0.00 dB apart
    for pair in ("(2, 3) / force at (1, 3)", "(2, 3) / force at (3, 3)"):
        assert sum(pair in m and "measured 2 times" in m and "differ by 0.00 dB" in m
                   for m in messages) == 1
    np.testing.assert_array_equal(data.dofs[data.inputs, 0], [1, 3])
    assert data.measured.all()
    _, freq, H = write_chain(tmp_path / "chain.uff")
    np.testing.assert_allclose(data.U, H[1:][:, :, [0, 2]], rtol=1e-6)


def test_the_dead_channel_warning_points_at_the_callers_line(tmp_path):
    path, _, _ = write_chain(tmp_path / "dead.uff", references=2,
                             change=lambda o, r, v: 0 * v if (o, r) == (2, 0) else v)
    with pytest.warns(DataWarning, match="dead channel") as caught:
        read_uff(path)
    assert caught[0].filename == __file__


def test_the_exact_zero_warning_points_at_the_callers_line(tmp_path):
    path, _, _ = write_chain(tmp_path / "zero.uff", change=_nan_at_42_hz)
    with pytest.warns(DataWarning, match="exactly 0 at 1 line") as caught:
        read_uff(path)
    assert [w.filename for w in caught] == [__file__]


@pytest.mark.parametrize("held", [300, 302])
def test_a_set_pyuff_reads_short_of_or_beyond_its_header_is_refused(tmp_path, monkeypatch, held):
    """Behind the check of the file's text: a dataset 58 that pyuff returns with fewer
    values than its header's number of points, or more, is refused by name, not fitted."""
    path, _, _ = write_chain(tmp_path / "chain.uff")
    read = pyuff.UFF.read_sets

    def changed(self, *args, **kwargs):
        d = read(self, *args, **kwargs)
        if d.get("type") == 58 and d.get("rsp_node") == 2 and d.get("ref_node") == 3:
            # one value lost at the end, or one more (its last repeated)
            d = dict(d, data=d["data"][:-1] if held < 301 else np.r_[d["data"], d["data"][-1]])
        return d

    monkeypatch.setattr(pyuff.UFF, "read_sets", changed)
    # the whole message: the file, the record, and what may be wrong with it
    message = (r"record 6 of the file \(dataset 58, response 2:3 / reference 3:3, from line "
               rf"\d+\) holds {held} values for the 301 points its header announces: the "
               r"record is truncated or its header is wrong$")
    with pytest.raises(ValueError, match="^" + re.escape(f"{path}: ") + message):
        read_uff(path)


@pytest.mark.parametrize("field", ["rsp_node", "rsp_dir", "ref_node", "ref_dir", "x"])
def test_a_field_of_the_wrong_type_is_refused_naming_the_file_and_record(
        tmp_path, monkeypatch, field):
    """A set pyuff returns with a DOF label that is not an integer, or a complex
    abscissa, is refused naming the file, the FRF record and the field."""
    path, _, _ = write_chain(tmp_path / "chain.uff")
    read = pyuff.UFF.read_sets

    def changed(self, *args, **kwargs):
        d = read(self, *args, **kwargs)
        if d.get("type") == 58 and d.get("rsp_node") == 1 and d.get("ref_node") == 2:
            d = dict(d, **{field: d[field] * (1 + 0j) if field == "x" else float(d[field])})
        return d

    monkeypatch.setattr(pyuff.UFF, "read_sets", changed)
    match = (r"FRF record 2 abscissa must be real, got complex dtype" if field == "x" else
             rf"FRF record 2: field '{field}' must be an integer, got \d\.0$")
    with pytest.raises(ValueError, match=rf"^{tmp_path}/chain\.uff: {match}"):
        read_uff(path)


@pytest.mark.parametrize("change", ["x one line short", "both 2-D", "no abscissa type",
                                    "no denominator type", "a displacement denominator",
                                    "one line"])
def test_abscissa_and_ordinate_of_a_set_pyuff_returns_are_checked(
        tmp_path, monkeypatch, change):
    """Behind the check of the file's text: record 2 returned with an abscissa one line
    short, with abscissa and ordinate as columns, or over a displacement, is refused by
    name; a set without an abscissa or denominator type (unknown, as 0) is read as
    frequency over force."""
    path, _, _ = write_chain(tmp_path / "chain.uff")
    expected = read_uff(path)
    read = pyuff.UFF.read_sets

    def changed(self, *args, **kwargs):
        d = read(self, *args, **kwargs)
        if d.get("type") == 58 and d.get("rsp_node") == 1 and d.get("ref_node") == 2:
            if change == "x one line short":
                d = dict(d, x=d["x"][:-1])
            elif change == "one line":  # one line, as its header says, is no FRF
                d = dict(d, x=d["x"][:1], data=d["data"][:1], num_pts=1)
            elif change == "both 2-D":
                d = dict(d, x=d["x"][:, None], data=d["data"][:, None])
            elif change == "a displacement denominator":
                d = dict(d, orddenom_spec_data_type=8)
            else:
                key = change.split()[1]  # "abscissa" or "denominator"
                d = {k: v for k, v in d.items()
                     if k != {"abscissa": "abscissa_spec_data_type",
                              "denominator": "orddenom_spec_data_type"}[key]}
        return d

    monkeypatch.setattr(pyuff.UFF, "read_sets", changed)
    if change.startswith("no "):
        assert np.array_equal(read_uff(path).U, expected.U)
        return
    if change == "a displacement denominator":
        with pytest.raises(ValueError, match=rf"^{tmp_path}/chain\.uff: FRF record 2: the "
                                             r"denominator is not a force \(specific data "
                                             r"type 13\)$"):
            read_uff(path)
        return
    with pytest.raises(ValueError, match=rf"^{tmp_path}/chain\.uff: FRF record 2: abscissa "
                                         r"and ordinate must be 1-D of equal length >= 2$"):
        read_uff(path)


def test_a_frequency_line_given_twice_is_refused(tmp_path, monkeypatch):
    """Every record with 5 Hz written as 4 Hz again: the records agree with each other, but
    a line twice has no width for the POD's trapezoid rule; refused by the file's name."""
    path, _, _ = write_chain(tmp_path / "twice.uff")
    read = pyuff.UFF.read_sets

    def repeated(self, *args, **kwargs):
        d = read(self, *args, **kwargs)
        if d.get("type") == 58:
            x = np.array(d["x"], dtype=float)
            x[5] = x[4]
            d = dict(d, x=x)
        return d

    monkeypatch.setattr(pyuff.UFF, "read_sets", repeated)
    with pytest.raises(ValueError, match=rf"^{tmp_path}/twice\.uff: the frequency lines are "
                                         r"not strictly increasing$"):
        read_uff(path)


def test_records_of_no_frf_name_the_function_types_found(tmp_path):
    """Dataset 58 records that are no FRF (func_type 1, a time response; 2, an
    auto-spectrum): the message lists the types found, and a bad ``quantity`` is named."""
    path = tmp_path / "other.uff"
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(
        func_type=func_type, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3,
        data=np.arange(5.0), x=np.arange(5.0), abscissa_spacing=1,
        abscissa_spec_data_type=18, ordinate_spec_data_type=8, orddenom_spec_data_type=13,
    ) for func_type in (2, 1, 2)], "add")
    with pytest.raises(ValueError, match=r"other\.uff: no FRF records \(dataset 58 with "
                                         r"func_type 4\); found func_type 1, 2$"):
        read_uff(path)
    good, _, _ = write_chain(tmp_path / "chain.uff")
    with pytest.raises(ValueError, match=r"^quantity must be one of \('displacement', "
                                         r"'velocity', 'acceleration'\) or None, got "
                                         r"'accelerance'$"):
        read_uff(good, quantity="accelerance")


def test_a_delimiter_is_minus_one_alone_on_its_line_or_followed_by_blanks_to_column_80():
    raw = (b"    -1\n"
           b"    58\n"
           b"        -1      NONE" + b" " * 60 + b"\n"  # -1 in an I10 field: data, not a delimiter
           b"    -1" + b" " * 74 + b"\n"  # padded to 80 columns
           b"    -1")  # the end of the file
    padded = raw.index(b"    -1" + b" " * 74)
    assert _delimiters(raw) == [0, padded, len(raw) - 6]
    # padded to column 80 where the file ends: pyuff takes blanks to column 80 as a
    # delimiter only with a byte after them (ind + 80 < len), so the check takes none
    # either (else it would pass a record that pyuff drops); one byte more and it is one
    assert _delimiters(b"    -1\n" + b"    -1" + b" " * 74) == [0]
    assert _delimiters(b"    -1\n" + b"    -1" + b" " * 74 + b"\n") == [0, 7]


def test_other_datasets_are_not_counted_as_frf_records(tmp_path):
    """Only a dataset 58's values are counted against its header. A wireframe of 8
    thin-shell triangles (dataset 2412, as pyuff writes it) after the FRFs: element 4's
    first line (number 4, FE descriptor 91, property table 1) stands where a dataset-58
    header gives its data form (ordinate type 4, 91 points, even spacing), and its node
    lines hold far fewer than 91 fields; the file reads as without the wireframe."""
    path, _, _ = write_chain(tmp_path / "mesh.uff")
    plain = read_uff(path)
    elements = [dict(element_nums=k + 1, fe_descriptor=91, phys_table=1, mat_table=1,
                     color=7, num_nodes=3, nodes_nums=[k % 2 + 1, k % 2 + 2, k % 2 + 3])
                for k in range(8)]
    pyuff.UFF(str(path)).write_sets({"type": 2412, 91: elements}, "add")
    assert pyuff.UFF(str(path)).get_set_types().tolist() == [58] * 9 + [2412]
    data = read_uff(path)
    assert data.dofs.tolist() == plain.dofs.tolist() and np.array_equal(data.U, plain.U)


@pytest.mark.parametrize("value", [None, 3.0, "3", True])
def test_an_integer_field_of_another_type_is_refused_by_name(value):
    with pytest.raises(ValueError, match=r"record 2: field 'rsp_dir' must be an integer"):
        _uff_int({"rsp_dir": value}, "rsp_dir", "record 2")
    assert _uff_int({"rsp_dir": np.int32(-3)}, "rsp_dir", "record 2") == -3


def test_frequency_lines_are_compared_relative_only(tmp_path):
    """Record 2's lines are record 1's but its first, 0 Hz, is 1e-9 Hz: they differ (an
    absolute tolerance would take any two lines closer than it for the same)."""
    freq = np.arange(0.0, 51.0)
    H = np.zeros((freq.size, 3, 3), dtype=complex)
    H[1:] = pr.mass_spring_chain(3, m1=1.0, m2=1.0).frf(2 * np.pi * freq[1:])
    shifted = freq.copy()
    shifted[0] = 1e-9
    path = tmp_path / "lines.uff"
    pyuff.UFF(str(path)).write_sets([frf_record(DOFS[0], DOFS[0], freq, H[:, 0, 0]),
                                     frf_record(DOFS[1], DOFS[0], shifted, H[:, 1, 0])], "add")
    with pytest.raises(ValueError, match="its frequency lines differ from those of record 1"):
        read_uff(path)


@pytest.mark.parametrize("ref, driven", [((2, 3), 1), ((1, 0), 0)])
def test_a_scalar_direction_zero_keeps_its_sign(tmp_path, ref, driven):
    """Direction 0 is a scalar DOF (a microphone's pressure, a temperature; as the
    reference, a volume-velocity source): it has no sign to flip, so its FRF is read as
    written — only a negative code flips one, on the response's side or the reference's."""
    freq = np.arange(1.0, 11.0)
    v = (1.0 + np.arange(10.0)) * (1 + 1j)
    records = [frf_record((1, 0), ref, freq, v), frf_record((2, 3), ref, freq, 2 * v),
               frf_record((3, -3), ref, freq, 3 * v)]
    pyuff.UFF(str(tmp_path / "scalar.uff")).write_sets(records, "add")
    data = read_uff(tmp_path / "scalar.uff")
    assert data.dofs.tolist() == [[1, 0], [2, 3], [3, 3]] and data.inputs.tolist() == [driven]
    np.testing.assert_array_equal(data.U[:, :, 0], np.c_[v, 2 * v, -3 * v])
