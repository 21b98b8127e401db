"""All Universal File (UFF) handling: measured FRFs, geometry and modes in, the model out.

In (pyuff reads the file):

* :func:`read_uff` — the FRFs of dataset 58 (func_type 4) as :class:`MeasuredData`,
  laid out as the fewest force columns by reciprocity (shaker columns and
  roving-hammer rows together), entries nobody measured as holes; a record cut off or
  damaged is refused, never read as a smaller file;
* :func:`read_uff_geometry` — node coordinates from dataset 15 (or 2411);
* :func:`read_uff_modes` — mode shapes from dataset 55;
* :func:`uff_quantity` — the ordinate (displacement, velocity, acceleration) of the FRFs.

Out, :func:`write_uff` writes what modal software and finite-element correlation
tools read (the inverse of :func:`read_uff`):

* dataset 15 — the node coordinates, when the test's geometry is known
  (:func:`read_uff_geometry` takes it from the input file);
* dataset 55 — one set per mode of the modal table
  (:func:`podid_rs.physical.modal_table`): complex eigenvalue analysis (type 3),
  the eigenvalue λ in rad/s (natural frequency |λ|/2π, damping ratio −Re λ/|λ|),
  the mode shape φ = R ψ on the measured (node, direction) DOFs (largest entry 1),
  and, for a symmetric model, the modal A and B (B = −λA) that make the set a
  complete residue model: H = Σ φφᵀ / (A (iω − λ)) + conjugates;
* dataset 58 — the identified FRF ``R H_m(ω) Rᵀ`` for every measured DOF and
  driven DOF, in the ordinate the test had (``quantity``: accelerance in,
  accelerance out); an entry the test did not measure says so in its fourth ID line.

Precision is the format's: dataset 15 and 55 fields and the 58 abscissa carry 6
significant digits (E13.5), ASCII 58 ordinates 12 (E20.11), binary 58 ordinates
are exact doubles.
"""

from __future__ import annotations

import bisect
import itertools
import warnings
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .._arrays import as_array, as_basis, as_dof_labels, as_omega
from ..identification.result import IdentificationResult
from ..measured import (
    QUANTITIES,
    DataWarning,
    MeasuredData,
    band_lines,
    from_frf,
    to_receptance,
)
from ..modes import ModeShapes, mode_shapes

#: UFF specific data types of an FRF's numerator (record 9) and denominator (record 10).
UFF_QUANTITY = {8: "displacement", 11: "velocity", 12: "acceleration"}
UFF_FORCE_TYPES = (0, 1, 9, 13)  # unknown, general, reaction force, excitation force
UFF_FRF = 4  # func_type of a frequency response function
UFF_FREQUENCY_TYPES = (0, 18)  # abscissa: unknown or frequency (Hz)
#: UFF specific data type of a displacement, velocity or acceleration numerator
UFF_NUMERATOR = {q: k for k, q in UFF_QUANTITY.items()}
UFF_EXCITATION_FORCE = 13
UFF_FREQUENCY = 18
#: dataset 55 analysis types whose sets are modes: normal (2), complex 1st/2nd order (3, 7)
UFF_MODAL_ANALYSES = (2, 3, 7)
#: identified FRF records made and written at a time (pyuff's dictionaries of a whole
#: 4000-point scan held at once took 18 MB)
WRITE_BATCH = 256


def _pyuff():
    """pyuff, imported on first use (``import podid_rs`` does not need it)."""
    import pyuff

    return pyuff


def _read_sets(path: str | Path, types: tuple[int, ...], header_only: bool = False):
    """The sets of the given dataset types, and the types the file holds.

    The file's records are checked first (:func:`_check_records`): pyuff pairs the
    ``    -1`` delimiters and drops a record that is not closed, so a file cut off in
    the middle of a record would otherwise read as a smaller file without a word.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such UFF file: {path}")
    layout = _check_records(path)
    uff = _pyuff().UFF(str(path))
    found = [int(t) for t in np.asarray(uff.get_set_types()).reshape(-1)]
    idx = [i for i, t in enumerate(found) if t in types]
    if not idx:
        return [], found
    what = "/".join(str(t) for t in types)
    sets = []
    for i in idx:  # one at a time, so that a record pyuff cannot read is named
        try:
            d = uff.read_sets(i, header_only=header_only)
        except Exception as exc:  # pyuff raises bare Exception on malformed records
            raise ValueError(
                f"{path}: could not read dataset {what}: {layout.describe(i)}: {exc}"
            ) from None
        if not header_only and d.get("type") == 58:
            size, points = np.size(d.get("data")), d.get("num_pts")
            if isinstance(points, int | np.integer) and size != points:
                raise ValueError(
                    f"{path}: {layout.describe(i)} holds {size} values for the {points} "
                    "points its header announces: the record is truncated or its header "
                    "is wrong"
                )
        sets.append(d)
    return sets, found


#: the delimiter line that opens and closes every UFF record
_DELIMITER = b"    -1"
#: values per line of a dataset-58 ASCII record, by ordinate type and abscissa spacing:
#: the field widths of one line (pyuff reads them the same way)
_FIELDS_58 = {
    (2, 1): (13,) * 6, (5, 1): (13,) * 6, (2, 0): (13,) * 6, (5, 0): (13,) * 6,
    (4, 1): (20,) * 4, (6, 1): (20,) * 4, (4, 0): (13, 20, 13, 20), (6, 0): (13, 20, 20),
}


def _delimiters(raw: bytes) -> list[int]:
    """Offsets of the ``    -1`` delimiters, found as pyuff finds them (followed by the
    end of the line or of the file, or by blanks to column 80)."""
    out, at, size = [], -1, len(raw)
    while (at := raw.find(_DELIMITER, at + 1)) != -1:
        end = at + len(_DELIMITER)
        if end == size or raw[end] in (10, 13) or (
            at + 80 < size and raw[end:at + 80] == b" " * (80 - len(_DELIMITER))
        ):
            out.append(at)
    return out


def _int(text: bytes) -> int | None:
    try:
        return int(text)
    except ValueError:
        return None


@dataclass(frozen=True)
class _Records:
    """Where each record of a UFF file is: the offsets of its delimiters, for messages."""

    raw: bytes
    tags: tuple[int, ...]

    def line(self, offset: int) -> int:
        return self.raw.count(b"\n", 0, offset) + 1

    def describe(self, k: int) -> str:
        """Record k (0-based) as a message names it: number, dataset, DOFs and line."""
        start = self.tags[2 * k]
        lines = self.raw[start:start + 2000].split(b"\n", 9)
        kind = _int(lines[1][:6]) if len(lines) > 1 else None
        text = f"record {k + 1} of the file (dataset {kind if kind is not None else '?'}"
        if kind == 58 and len(lines) > 7:
            ids = lines[7]
            rsp = (_int(ids[41:51]), _int(ids[51:55]))
            ref = (_int(ids[66:76]), _int(ids[76:80]))
            if None not in rsp + ref:
                text += f", response {rsp[0]}:{rsp[1]} / reference {ref[0]}:{ref[1]}"
        return text + f", from line {self.line(start)})"


def _check_records(path: Path) -> _Records:
    """Refuse a file whose records are not whole, naming the file and the record.

    pyuff pairs the delimiters and drops what is left over, and reads a record's
    values without comparing them with its header. Here: every record opened by a
    delimiter must be closed by one (else the file was cut off inside it, or a
    delimiter is missing); nothing but blanks may stand between records (else a
    delimiter is missing and two records ran together); a record's second line must
    be its dataset number; and a dataset-58 record must hold the values its header's
    number of points announces (ASCII: counted in the fields pyuff reads; binary: the
    bytes).
    """
    raw = path.read_bytes()
    records = _Records(raw, tuple(_delimiters(raw)))
    tags = records.tags
    for k in range(len(tags) // 2):
        start, end = tags[2 * k], tags[2 * k + 1]
        if k > 0:
            gap = raw[tags[2 * k - 1] + len(_DELIMITER):start]
            if gap.strip():
                text = gap.strip().split(b"\n", 1)[0][:40].decode("ascii", "replace")
                at = tags[2 * k - 1] + len(_DELIMITER) + len(gap) - len(gap.lstrip())
                raise ValueError(
                    f"{path}: a '    -1' delimiter is missing after {records.describe(k - 1)}: "
                    f"line {records.line(at)} ({text!r}) belongs to no record, so two records "
                    "ran together"
                )
        _check_58(path, records, k, raw[start:end])
    if len(tags) % 2:
        k = len(tags) // 2
        raise ValueError(
            f"{path}: {records.describe(k)} has no closing '    -1': the file ends inside "
            "it (cut off?) or its closing delimiter is missing"
        )
    return records


def _check_58(path: Path, records: _Records, k: int, block: bytes) -> None:
    """A dataset-58 record (``block``: its opening delimiter to its closing one) must
    hold as many values as its header's number of points announces."""
    lines = block.split(b"\n", 13)
    kind = _int(lines[1][:6]) if len(lines) > 1 else None
    if kind is None:
        raise ValueError(
            f"{path}: {records.describe(k)} has no dataset number after its opening "
            "'    -1': a delimiter is missing, or the record is damaged"
        )
    if kind != 58 or len(lines) < 14:
        return  # other datasets are pyuff's to read; a short header is too
    binary = lines[1][6:7].lower() == b"b"
    form = (_int(lines[8][0:10]), _int(lines[8][10:20]), _int(lines[8][20:30]))
    ordinate, points, spacing = form
    if None in form or (ordinate, spacing) not in _FIELDS_58:
        return  # a header pyuff cannot read either: it says so
    per_point = (2 if ordinate in (5, 6) else 1) + (spacing == 0)
    expected = points * per_point
    body = lines[13]
    if binary:  # the values, then at most a line end before the closing delimiter
        size = 4 if ordinate in (2, 5) else 8
        whole = len(body) >= expected * size and not body[expected * size:].strip(b"\r\n")
        held = expected if whole else len(body) // size
    else:
        starts = np.cumsum((0,) + _FIELDS_58[(ordinate, spacing)][:-1]).tolist()
        held = sum(bisect.bisect_left(starts, len(line.rstrip()))
                   for line in body.split(b"\n"))
    if held != expected:
        raise ValueError(
            f"{path}: {records.describe(k)} holds {held} values where its header announces "
            f"{points} points ({expected} values): the record is truncated or damaged"
        )


# --------------------------------------------------------------------------- in


def _uff_int(d: dict, key: str, where: str) -> int:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, int | np.integer):
        raise ValueError(f"{where}: field {key!r} must be an integer, got {v!r}")
    return int(v)


#: two FRFs of the same entry whose median |dB| difference exceeds this are refused, not
#: averaged: they do not measure the same thing (calibration, direction, a wrong label)
DUPLICATE_DB = 3.0

Dof = tuple[int, int]


@dataclass(frozen=True)
class _Frf:
    """One FRF record as read: its number among the file's FRF records, the response
    and reference DOFs (directions made positive), the receptance on the lines kept,
    and the record's own (signed) label for messages."""

    number: int
    response: Dof
    reference: Dof
    values: np.ndarray
    label: str

    @property
    def name(self) -> str:
        return f"FRF record {self.number} ({self.label})"


def read_uff(
    path: str | Path,
    *,
    quantity: str | None = None,
    band_hz: tuple[float, float] | None = None,
) -> MeasuredData:
    """FRFs from the dataset-58 records (func_type 4) of a Universal File.

    Each record is one FRF, response (node, direction) over reference (node,
    direction); a negative direction code (−3 = −Z) flips the sign, so that every
    FRF is in the positive directions. The FRFs are laid out as columns, one per
    force DOF (:func:`_driving_point_layout`): every measured FRF is an entry
    H(j, k) of a column k directly or by reciprocity H(j, k) = H(k, j), with the
    fewest columns that do so — a shaker test keeps its references, a roving-hammer
    file (fixed response, roving references) becomes the column of a force at the
    fixed DOF, and the two combined become two columns. Every column's force DOF
    must be a measured response. Entries nobody measured are holes
    (:attr:`MeasuredData.measured`); two FRFs of the same entry are averaged, with a
    :class:`~podid_rs.measured.DataWarning`, unless their median difference exceeds
    ``DUPLICATE_DB`` dB. ``notes`` say what was done. Numerator type 8/11/12
    (displacement, velocity, acceleration) is converted to receptance; the abscissa
    is frequency in Hz, shared by all records. Other records (coherence, time data,
    other datasets) are ignored. The 0 Hz line is dropped.

    Nothing is read silently: a record cut off or whose values do not match its
    header, and non-finite values, are refused; an FRF that is zero at every line
    (of the band) — a dead channel — is left out as not measured, with a
    :class:`~podid_rs.measured.DataWarning`, as is a record whose unit labels
    (``ordinate_axis_units_lab`` / ``orddenom_axis_units_lab``) disagree with those of
    the other records of its ordinate (g/N among (m/s²)/N; a tie is refused); lines of
    an FRF that are exactly zero are warned about (kept; their dB error is not defined).

    Parameters
    ----------
    path : str or pathlib.Path
        The file (``.uff``, ``.unv``, …).
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Overrides the numerator type of the records.
    band_hz : tuple of float, optional
        Keep only the lines with lo ≤ f ≤ hi Hz (both ends included).

    Returns
    -------
    MeasuredData
        The FRFs as unit load cases, with the (node, direction) labels and the mask
        of measured entries.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        Naming the file and record: no FRF records, a record cut off, a missing
        delimiter, a record whose values do not match its header's number of points,
        unreadable or inconsistent records (abscissa, denominator, numerator type,
        frequency lines), non-finite values (with the first line in Hz), two FRFs of
        one entry more than ``DUPLICATE_DB`` apart, a force DOF that is not a
        measured response, every FRF dead, or a band keeping fewer than 2 lines.

    Warns
    -----
    DataWarning
        For a dead channel, exact zeros in an FRF, or an FRF measured twice.
    """
    path = Path(path)
    sets, _ = _read_sets(path, (58,))
    if not sets:
        raise ValueError(f"{path}: no dataset 58 (function at nodal DOF) in the file")
    frfs = [d for d in sets if d.get("func_type") == UFF_FRF]
    if not frfs:
        found = sorted({str(d.get("func_type")) for d in sets})
        raise ValueError(
            f"{path}: no FRF records (dataset 58 with func_type 4); "
            f"found func_type {', '.join(found)}"
        )
    if quantity is not None and quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {QUANTITIES} or None, got {quantity!r}")
    freq = None
    raw: list[tuple[int, Dof, Dof, np.ndarray, str, str]] = []
    for k, d in enumerate(frfs):
        where = f"{path}: FRF record {k + 1}"
        rsp = (_uff_int(d, "rsp_node", where), _uff_int(d, "rsp_dir", where))
        ref = (_uff_int(d, "ref_node", where), _uff_int(d, "ref_dir", where))
        label = f"response {rsp[0]}:{rsp[1]} / reference {ref[0]}:{ref[1]}"
        x = as_array(d.get("x"), f"{where} abscissa", real=True)
        y = _finite_ordinate(d.get("data"), x, f"{where} ({label})")
        if x.ndim != 1 or y.shape != x.shape or x.size < 2:
            raise ValueError(f"{where}: abscissa and ordinate must be 1-D of equal length >= 2")
        if d.get("abscissa_spec_data_type", 0) not in UFF_FREQUENCY_TYPES:
            raise ValueError(f"{where}: the abscissa is not frequency (specific data type 18)")
        if d.get("orddenom_spec_data_type", 0) not in UFF_FORCE_TYPES:
            raise ValueError(f"{where}: the denominator is not a force (specific data type 13)")
        q = quantity or UFF_QUANTITY.get(d.get("ordinate_spec_data_type"))
        if q is None:
            raise ValueError(
                f"{where}: the numerator type {d.get('ordinate_spec_data_type')!r} is not "
                "displacement (8), velocity (11) or acceleration (12); pass quantity="
            )
        if freq is None:
            freq = x
        elif x.shape != freq.shape or not np.allclose(x, freq, rtol=1e-9, atol=0.0):
            raise ValueError(f"{where}: its frequency lines differ from those of record 1")
        sign = (-1.0 if rsp[1] < 0 else 1.0) * (-1.0 if ref[1] < 0 else 1.0)
        raw.append((k + 1, (rsp[0], abs(rsp[1])), (ref[0], abs(ref[1])), sign * y, q, label,
                    _units(d)))
    if np.any(np.diff(freq) <= 0):
        raise ValueError(f"{path}: the frequency lines are not strictly increasing")
    positive = np.flatnonzero(freq > 0)
    keep = positive if band_hz is None else positive[band_lines(freq[positive], band_hz)]
    omega = 2 * np.pi * freq[keep]
    where = "of the band" if band_hz is not None else "in the file"
    raw, notes = _same_units(raw, path)
    records = []
    for number, rsp, ref, y, q, label, _ in raw:
        record = _Frf(number, rsp, ref, to_receptance(y[keep], omega, q), label)
        dead = _dead_channel(record, y[keep], freq[keep], where)
        if dead:
            warnings.warn(f"{path}: {dead}", DataWarning, stacklevel=2)
            notes.append(f"{path.name}: {dead}")
        else:
            records.append(record)
    if not records:
        raise ValueError(f"{path}: every FRF record is zero at every line {where}")
    layout = _driving_point_layout(records, path)
    rows, cols = layout.rows, layout.columns
    H = np.zeros((omega.size, len(rows), len(cols)), dtype=np.complex128)
    for (o, r), values in layout.entries.items():
        H[:, rows.index(o), cols.index(r)] = values
    mask = np.zeros((len(rows), len(cols)), dtype=bool)
    for o, r in layout.entries:
        mask[rows.index(o), cols.index(r)] = True
    data = from_frf(H, omega, inputs=[rows.index(r) for r in cols],
                    dofs=np.asarray(rows, dtype=np.int64), measured=mask)
    return replace(data, notes=(*layout.notes, *notes))


def _units(record: dict) -> str | None:
    """The record's unit labels, numerator / denominator, normalised (case, spaces,
    ``^``, ``*`` and brackets ignored); None where the file gives none."""
    labels = []
    for key in ("ordinate_axis_units_lab", "orddenom_axis_units_lab"):
        text = str(record.get(key, "") or "").strip()
        labels.append("" if text.upper() in ("", "NONE") else
                      "".join(c for c in text.lower() if c not in " ^*()[]"))
    return None if not any(labels) else "/".join(labels)


def _unit_parts(label: str) -> tuple[str, str]:
    """A label of :func:`_units` as (numerator, denominator), ``""`` for a part not given
    (the denominator follows the last ``/``: a numerator may hold one, as m/s2)."""
    num, _, den = label.rpartition("/")
    return num, den


def _same_unit(label: str, unit: str) -> bool:
    """Whether two labels agree on every part both give."""
    return all(a == b or not a or not b
               for a, b in zip(_unit_parts(label), _unit_parts(unit), strict=True))


def _same_units(raw: list, path: Path) -> tuple[list, list[str]]:
    """The records whose unit labels agree with the others of the same ordinate
    (displacement, velocity, acceleration): a record labelled in another unit (g/N
    among (m/s²)/N) would enter the fit at another scale, so it is left out as not
    measured, with a :class:`DataWarning` naming it and both labels. The unit is the
    most common label among the records labelled in full (numerator and denominator),
    else among all; a tie between two labels cannot be settled and is refused. A
    record labelled in part ((m/s²) over NONE) is compared on the part it gives, and
    records without labels are kept."""
    keep, notes = [], []
    for q in dict.fromkeys(item[4] for item in raw):
        group = [item for item in raw if item[4] == q]
        counts: dict[str, int] = {}
        for item in group:
            if item[6] is not None:
                counts[item[6]] = counts.get(item[6], 0) + 1
        full = {k: v for k, v in counts.items() if all(_unit_parts(k))}
        if len(counts) > 1:
            ranked = sorted((full or counts).items(), key=lambda kv: -kv[1])
            if len(ranked) > 1 and ranked[0][1] == ranked[1][1]:
                raise ValueError(
                    f"{path}: the {q} FRF records disagree on their units, as many in "
                    f"{ranked[0][0]!r} as in {ranked[1][0]!r} (records "
                    f"{[i[0] for i in group if i[6] == ranked[0][0]]} against "
                    f"{[i[0] for i in group if i[6] == ranked[1][0]]}): convert them to one unit"
                )
            unit = ranked[0][0]
            agree = [item[6] is None or _same_unit(item[6], unit) for item in group]
            odd = [item for item, ok in zip(group, agree, strict=True) if not ok]
            group = [item for item, ok in zip(group, agree, strict=True) if ok]
            if odd:
                labelled = sum(item[6] is not None for item in group)
                text = (f"FRF record(s) {', '.join(f'{i[0]} ({i[5]}, {i[6]!r})' for i in odd)} "
                        f"are in other units than the {labelled} other {q} records "
                        f"({unit!r}): left out as not measured (convert them to include them)")
                warnings.warn(f"{path}: {text}", DataWarning, stacklevel=3)
                notes.append(f"{path.name}: {text}")
        keep += [id(item) for item in group]
    return [item for item in raw if id(item) in keep], notes


def _finite_ordinate(values: object, x: np.ndarray, where: str) -> np.ndarray:
    """The ordinate as a fresh array; ``ValueError`` naming the first non-finite line."""
    y = np.asarray(values)
    if np.issubdtype(y.dtype, np.number) and y.shape == x.shape:
        bad = np.flatnonzero(~np.isfinite(y))
        if bad.size:
            i = int(bad[0])
            more = f" and at {bad.size - 1} more line(s)" if bad.size > 1 else ""
            raise ValueError(
                f"{where}: its value at {x[i]:g} Hz (line {i + 1} of {y.size}) is {y[i]}"
                f"{more}: non-finite values cannot be fitted; repair or remove the record"
            )
    return as_array(values, f"{where} ordinate")


def _dead_channel(
    record: _Frf, written: np.ndarray, freq_hz: np.ndarray, where: str
) -> str | None:
    """What is wrong with an FRF that measured nothing (zero or constant at every line of
    the values as ``written``, in the record's own quantity: a constant accelerance is no
    longer constant as a receptance), None for a live one — which gets a warning of its
    own for lines that are exactly zero (a value lost in writing: pyuff writes NaN as 0)."""
    v = written
    if not np.any(v):
        return (f"{record.name} is zero at every line {where}: a dead channel; that entry "
                "is treated as not measured")
    if v.size >= 3 and np.all(v == v[0]):
        return (f"{record.name} is the constant {v[0]:.4g} at every line {where}: a dead "
                "channel; that entry is treated as not measured")
    zero = np.flatnonzero(v == 0)
    if zero.size:
        warnings.warn(
            f"{record.name} is exactly 0 at {zero.size} line(s), the first at "
            f"{freq_hz[zero[0]]:g} Hz: a lost value? (pyuff writes NaN as 0); kept, "
            "those lines have no dB error",
            DataWarning,
            stacklevel=3,
        )
    return None


@dataclass(frozen=True)
class _Layout:
    """The FRFs as a grid: response DOFs (rows), force DOFs (columns), the measured
    entries' values keyed (response, force), and notes on what was done."""

    rows: list[Dof]
    columns: list[Dof]
    entries: dict[tuple[Dof, Dof], np.ndarray]
    notes: tuple[str, ...]


def _force_columns(records: list[_Frf]) -> list[Dof]:
    """The fewest force DOFs such that every measured pair {response, reference} has
    one of them: a vertex cover of the graph of measured pairs. A driving-point FRF
    H(k, k) makes k a column; the rest greedily, the DOF that covers most of the
    pairs left first (ties: the file's references, then the lower DOF); then a
    column every pair of which another column covers is dropped."""
    pairs = {tuple(sorted((f.response, f.reference))) for f in records}
    references = {f.reference for f in records}
    forced = {a for a, b in pairs if a == b}
    chosen = set(forced)
    left = {e for e in pairs if not chosen.intersection(e)}
    added = []
    while left:
        count = Counter(v for e in left for v in set(e))
        best = max(count, key=lambda v: (count[v], v in references, (-v[0], -v[1])))
        chosen.add(best)
        added.append(best)
        left = {e for e in left if best not in e}
    for v in reversed(added):
        others = chosen - {v}
        if all(e[0] in others or e[1] in others for e in pairs if v in e):
            chosen = others
    return sorted(chosen)


def _driving_point_layout(records: list[_Frf], path: Path) -> _Layout:
    """The FRF grid with every force DOF among the responses, by reciprocity if need be.

    A shaker test measures the driving point: its references are responses too. A
    roving-hammer test fixes the response and roves the reference, so its references
    are not responses; Maxwell–Betti reciprocity, H(j, k) = H(k, j), turns it into
    the column of the FRF matrix for a force at the fixed response DOF. In general
    the columns are the fewest force DOFs that hold every measured pair
    (:func:`_force_columns`): a record H(o, r) is the entry (o, r) of column r when
    r is a column, else the entry (r, o) of column o by reciprocity; an entry (k, j)
    between two columns that only H(j, k) measured is filled by reciprocity too.
    Several records of one entry are averaged (:func:`_average`). Entries no record
    gives are holes. Every column's force DOF must be a measured response (a row
    with a measured entry): the force is projected on the basis of the responses.
    """
    columns = _force_columns(records)
    cols = set(columns)
    groups: dict[tuple[Dof, Dof], list[_Frf]] = {}
    by_reciprocity = 0
    for f in records:
        key = (f.response, f.reference) if f.reference in cols else (f.reference, f.response)
        by_reciprocity += f.reference not in cols
        groups.setdefault(key, []).append(f)
    entries = {}
    for key, group in groups.items():  # a loop, not a comprehension: _average's warning
        entries[key] = _average(key, group, path)  # counts its frames (3.12 inlines them)
    for (o, r), values in list(entries.items()):
        if o in cols and o != r and (r, o) not in entries:
            entries[(r, o)] = values  # the mirror entry of two columns, by reciprocity
            by_reciprocity += 1
    rows = sorted({key[0] for key in entries} | {key[1] for key in entries})
    unmeasured = [c for c in columns if not any(o == c for o, _ in entries)]
    if unmeasured:
        raise ValueError(
            f"{path}: reference DOF(s) {unmeasured} are not among the measured responses, "
            "and reciprocity cannot supply their driving point (no FRF pairs them with "
            "another force DOF, or measures them as a response): the force must be known on "
            "a measured DOF to be projected"
        )
    outs = sorted({f.response for f in records})
    refs = sorted({f.reference for f in records})
    notes = []
    if by_reciprocity and set(outs) <= set(refs) and columns == outs:
        notes.append(
            f"{path.name}: the {len(refs)} reference DOFs are not all among the "
            f"{len(outs)} response DOF(s) (a roving-hammer test): read by reciprocity, "
            "H(j, k) = H(k, j), as the FRFs of the hit DOFs for a force at the response "
            f"DOF(s) {outs}"
        )
    elif by_reciprocity or columns != refs:
        notes.append(
            f"{path.name}: the {len(records)} FRFs of {len(outs)} response and {len(refs)} "
            f"reference DOF(s) are laid out as the FRF columns of forces at {columns} (the "
            "fewest force DOFs that hold every measured pair); "
            f"{by_reciprocity} entr{'y' if by_reciprocity == 1 else 'ies'} read by "
            "reciprocity, H(j, k) = H(k, j)"
        )
    holes = [(o, r) for r in columns for o in rows if (o, r) not in entries]
    if holes:
        notes.append(
            f"{path.name}: {len(holes)} of the {len(rows)} × {len(columns)} entries "
            f"(response × force) were not measured, e.g. response {holes[0][0]} / force "
            f"at {holes[0][1]}: they weigh nothing in the fit and in every error"
        )
    notes += [f"{path.name}: {_duplicate_note(key, group)}"
              for key, group in groups.items() if len(group) > 1]
    return _Layout(rows, columns, entries, tuple(notes))


def _median_db_apart(a: np.ndarray, b: np.ndarray) -> float:
    """Median |20 log10(|a| / |b|)| over the lines where both are non-zero."""
    both = (a != 0) & (b != 0)
    if not np.any(both):
        return 0.0
    return float(np.median(np.abs(20 * np.log10(np.abs(a[both]) / np.abs(b[both])))))


def _duplicate_note(key: tuple[Dof, Dof], group: list[_Frf]) -> str:
    """What was done with several FRFs of one entry: averaged, and how far apart."""
    apart = max(_median_db_apart(a.values, b.values)
                for i, a in enumerate(group) for b in group[i + 1:])
    return (
        f"response {key[0]} / force at {key[1]} was measured {len(group)} "
        f"times ({', '.join(f.name for f in group)}), directly or by reciprocity: "
        f"averaged; they differ by {apart:.2f} dB (median |dB| over the lines read)"
    )


def _average(key: tuple[Dof, Dof], group: list[_Frf], path: Path) -> np.ndarray:
    """The value of one entry: its record, or the mean of several that agree to
    ``DUPLICATE_DB`` dB (median over the lines), with a warning; refused otherwise."""
    if len(group) == 1:
        return group[0].values
    for i, a in enumerate(group):
        for b in group[i + 1:]:
            apart = _median_db_apart(a.values, b.values)
            if apart > DUPLICATE_DB:
                raise ValueError(
                    f"{path}: {a.name} and {b.name} both measure response {key[0]} / force "
                    f"at {key[1]} (directly or by reciprocity) but differ by a median "
                    f"{apart:.1f} dB (more than {DUPLICATE_DB:g} dB): they do not measure "
                    "the same thing (calibration, direction or DOF label?); remove one"
                )
    warnings.warn(f"{path}: {_duplicate_note(key, group)}", DataWarning, stacklevel=4)
    return np.mean([f.values for f in group], axis=0)


def read_uff_geometry(path: str | Path) -> np.ndarray | None:
    """Node coordinates from dataset 15 or 2411 of a Universal File.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    numpy.ndarray, (k, 4), or None
        Rows [node, x, y, z] sorted by node; None when the file has no geometry.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        When pyuff cannot read the sets.
    """
    sets, _ = _read_sets(path, (15, 2411))
    rows: dict[int, tuple[float, float, float]] = {}
    for d in sets:
        for node, x, y, z in zip(d["node_nums"], d["x"], d["y"], d["z"], strict=True):
            rows[int(node)] = (float(x), float(y), float(z))
    if not rows:
        return None
    return np.array([(n, *xyz) for n, xyz in sorted(rows.items())], dtype=np.float64)


def uff_quantity(path: str | Path) -> str | None:
    """The ordinate of a file's FRF records (dataset 58, func_type 4) when they agree.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    str or None
        ``"displacement"``, ``"velocity"`` or ``"acceleration"`` (numerator type 8,
        11, 12); None when the records disagree or have none of these.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        When pyuff cannot read the headers.
    """
    sets, _ = _read_sets(path, (58,), header_only=True)
    found = {UFF_QUANTITY.get(d.get("ordinate_spec_data_type")) for d in sets
             if d.get("func_type") == UFF_FRF}
    return found.pop() if len(found) == 1 else None


def read_uff_modes(path: str | Path) -> ModeShapes:
    """Mode shapes from the dataset-55 sets of a Universal File (normal or complex modes).

    Normal modes (analysis type 2) give λ = ω(−ζ + i√(1 − ζ²)) from the frequency
    and viscous damping ratio; complex ones (3, 7) their eigenvalue. Modes keep the
    file's order; the DOFs are every (node, direction 1–6) that is non-zero in some
    mode.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    ModeShapes
        The modes, with their numbers in the file and the DOF labels.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        Naming the file, when it has no dataset 55, none holding modes, only zero
        shapes, or sets pyuff cannot read.
    """
    sets, found = _read_sets(path, (55,))
    if not sets:
        kinds = ", ".join(str(t) for t in sorted(set(found))) or "none"
        raise ValueError(
            f"{path}: no dataset 55 (mode shapes) in the file; it holds dataset(s) {kinds}"
        )
    modes = [d for d in sets if d.get("analysis_type") in UFF_MODAL_ANALYSES]
    if not modes:
        kinds = sorted({str(d.get("analysis_type")) for d in sets})
        raise ValueError(
            f"{path}: its dataset-55 sets are not modes (analysis type {', '.join(kinds)}; "
            "modes are 2, 3 or 7)"
        )
    eig, columns, numbers = [], [], []
    for d in modes:
        numbers.append(int(d.get("mode_n", len(numbers) + 1)))
        if d["analysis_type"] == 2:
            w, z = 2 * np.pi * float(d["freq"]), float(d.get("modal_damp_vis", 0.0))
            eig.append(w * complex(-z, np.sqrt(max(1.0 - z * z, 0.0))))
        else:
            eig.append(complex(d["eig"]))
        col = {}
        for k in range(1, 7):
            for node, v in zip(d["node_nums"], d.get(f"r{k}", ()), strict=False):
                col[(int(node), k)] = complex(v)
        columns.append(col)
    dofs = sorted({key for col in columns for key, v in col.items() if v != 0})
    if not dofs:
        raise ValueError(f"{path}: every dataset-55 mode shape is zero")
    shapes = np.array([[col.get(key, 0.0) for col in columns] for key in dofs])
    return ModeShapes(np.asarray(eig), shapes, np.asarray(dofs, dtype=np.int64),
                      numbers=np.asarray(numbers))


# --------------------------------------------------------------------------- out


def _receptance_to(quantity: str, omega: np.ndarray) -> np.ndarray:
    """Factor from receptance to ``quantity`` per force: 1, iω or −ω² (inverse of
    :func:`podid_rs.measured.to_receptance`)."""
    return {"displacement": np.ones_like(omega) + 0j, "velocity": 1j * omega,
            "acceleration": -(omega**2) + 0j}[quantity]


def _check_geometry(geometry: object) -> np.ndarray | None:
    if geometry is None:
        return None
    g = as_array(geometry, "geometry", real=True)
    if g.ndim != 2 or g.shape[1] != 4 or g.shape[0] == 0:
        raise ValueError(f"geometry must have shape (k, 4) [node, x, y, z], got {g.shape}")
    if np.any(g[:, 0] != np.round(g[:, 0])) or np.unique(g[:, 0]).size != g.shape[0]:
        raise ValueError("geometry's first column must hold distinct integer node numbers")
    return g


def _set_55(j: int, modes: ModeShapes, nodes: list[int], name: str) -> dict:
    lam = complex(modes.eigenvalues[j])
    number = int(modes.mode_numbers[j])  # the mode's number in the modal table
    a = 0j if modes.modal_a is None else complex(modes.modal_a[j])
    r = np.zeros((3, len(nodes)), dtype=np.complex128)
    for (node, direction), v in zip(modes.dofs.tolist(), modes.shapes[:, j], strict=True):
        if 1 <= abs(direction) <= 3:
            r[abs(direction) - 1, nodes.index(node)] = np.sign(direction) * v
    f, zeta = modes.frequencies_hz[j], modes.damping_ratios[j]
    return _pyuff().prepare_55(
        id1=f"{name}: identified mode {number}"[:80],
        id2=f"f = {f:.6g} Hz, zeta = {zeta:.6g}"[:80],
        id3="NONE",
        id4="complex eigenvalue in rad/s; shape scaled to largest entry 1"[:80],
        id5="NONE",
        model_type=1,
        analysis_type=3,
        data_ch=2,
        spec_data_type=8,
        data_type=5,
        n_data_per_node=3,
        r1=r[0],
        r2=r[1],
        r3=r[2],
        load_case=1,
        mode_n=number,
        eig=lam,
        modal_a=a,
        modal_b=-lam * a,
        node_nums=[int(n) for n in nodes],
    )


def _reciprocity_remark(data: MeasuredData | None) -> str:
    """The 58 sets' third ID line when the data were read by reciprocity (a roving-hammer
    file: its references became the responses, ``read_uff``'s note), else ``"NONE"``."""
    if data is not None and any("roving-hammer" in note for note in data.notes):
        return "roving-hammer test read by reciprocity: H(j, k) = H(k, j)"
    if data is not None and any("reciprocity" in note for note in data.notes):
        return "entries read by reciprocity: H(j, k) = H(k, j)"
    return "NONE"


def _sets_58(
    model: IdentificationResult, R: np.ndarray, dofs: np.ndarray, inputs: np.ndarray,
    omega: np.ndarray, quantity: str, binary: bool, name: str, remark: str = "NONE",
    measured: np.ndarray | None = None,
) -> Iterator[dict]:
    """The identified FRFs' dataset-58 records, one per (measured DOF, driven DOF), made
    as they are taken; the model's responses are computed here, before the first."""
    pyuff = _pyuff()
    # R H_m Rᵀ at the driven DOFs: the responses to the loads Rᵀ e_k, not all of H_m
    loads = np.broadcast_to(R[inputs].T, (omega.size, *R[inputs].T.shape))
    H = np.einsum("am,smk->sak", R, model.system().response(omega, loads)) * (
        _receptance_to(quantity, omega)[:, None, None]
    )
    freq = omega / (2 * np.pi)
    step = np.diff(freq)
    even = bool(np.allclose(step, step[0], rtol=1e-9, atol=0.0))
    return (_set_58(pyuff, H, freq, even, dofs, i, k, col, quantity, binary, name, remark,
                    measured) for k, col in enumerate(inputs) for i in range(dofs.shape[0]))


def _set_58(pyuff, H, freq, even, dofs, i, k, col, quantity, binary, name, remark, measured):
    """The record of H[:, i, k]: measured DOF i's response to driven DOF ``col``."""
    ref = (int(dofs[col, 0]), int(dofs[col, 1]))
    node, direction = (int(v) for v in dofs[i, :2])
    return pyuff.prepare_58(
        binary=int(binary),
        id1="FRF",
        id2=f"H({node}:{direction}, {ref[0]}:{ref[1]}) {name}, identified"[:80],
        id3=remark[:80],
        id4="NONE" if measured is None or measured[i, k] else
        "not measured in the test: the model's prediction",
        id5="NONE",
        func_type=UFF_FRF,
        rsp_node=int(node),
        rsp_dir=int(direction),
        ref_node=ref[0],
        ref_dir=ref[1],
        data=np.ascontiguousarray(H[:, i, k]),
        x=freq,
        abscissa_spacing=int(even),
        abscissa_spec_data_type=UFF_FREQUENCY,
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=UFF_NUMERATOR[quantity],
        orddenom_spec_data_type=UFF_EXCITATION_FORCE,
    )


def write_uff(
    path: str | Path,
    model: IdentificationResult,
    basis: object,
    data: MeasuredData | None = None,
    *,
    dofs: object = None,
    inputs: object = None,
    omega: object = None,
    quantity: str = "displacement",
    geometry: object = None,
    binary: bool = False,
    name: str = "podid_rs",
    modes: object = None,
) -> Path:
    """Write the identified model to a Universal File: datasets 15, 55 and 58.

    Dataset 15 holds the geometry, 55 one set per mode (translations, directions
    1–3, only), 58 the identified FRFs ``R H_m(ω) Rᵀ`` (module docstring), one driven
    DOF at a time, each with every measured DOF in the labels' order. FRFs from
    data read by reciprocity (a roving-hammer file) say so in their third ID line; the
    FRF of an entry the test did not measure (a hole of ``data.measured``) is written
    too, and says in its fourth ID line that it is the model's prediction.
    The file is replaced if it exists.

    Parameters
    ----------
    path : str or pathlib.Path
        The file to write.
    model : IdentificationResult
        The model, order m.
    basis : array_like, (n, m)
        R, which maps the model to the n measured DOFs.
    data : MeasuredData, optional
        The data identified from: supplies the (node, direction) labels, the driven
        DOFs and the frequency lines.
    dofs : array_like, (n, 2), optional
        Without ``data``: the labels.
    inputs : array_like, optional
        Without ``data``: indices of the driven DOFs, each once, needed with ``omega``
        for the FRFs.
    omega : array_like, optional
        Without ``data``: the lines (rad/s) of the FRFs; without it no dataset 58 is
        written.
    quantity : {"displacement", "velocity", "acceleration"}
        The 58 ordinate (the test's: ``"acceleration"`` for accelerance).
    geometry : array_like, (k, 4), optional
        [node, x, y, z] rows for dataset 15.
    binary : bool
        Write 58 ordinates as exact doubles.
    name : str
        Written into the sets' ID lines.
    modes : array_like of bool, (k,), optional
        Which of the model's modes (in :func:`podid_rs.modal_parameters`' order) get a
        dataset 55, e.g. only the structural ones (:func:`podid_rs.modes.mode_kinds`);
        default all. Each keeps its number in the modal table.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For a model that is not an :class:`IdentificationResult`, ``data`` together
        with ``dofs``/``inputs``/``omega``, a missing basis or labels, a rotational
        DOF, ``inputs`` without ``omega`` (or the reverse), malformed arguments, or
        when pyuff cannot write the file.
    OSError
        When the file cannot be written.
    """
    if not isinstance(model, IdentificationResult):
        raise ValueError(f"model must be an IdentificationResult, got {type(model).__name__}")
    if data is not None:
        if not isinstance(data, MeasuredData):
            raise ValueError(f"data must be a MeasuredData, got {type(data).__name__}")
        if dofs is not None or inputs is not None or omega is not None:
            raise ValueError("give data, or dofs / inputs / omega, not both")
        dofs, inputs, omega = data.dofs, data.inputs, data.omega
    if basis is None:
        raise ValueError("UFF output needs the basis R (n, m) that maps the model to its DOFs")
    R = as_basis(basis, model.m)
    if dofs is None:
        raise ValueError(
            "the model has no measured-DOF labelling: UFF output needs the (node, direction) "
            f"label of each of the {R.shape[0]} basis rows (dofs=, or data=)"
        )
    labels = as_dof_labels(dofs, R.shape[0])
    rotations = [tuple(d) for d in labels.tolist() if not 1 <= abs(d[1]) <= 3]
    if rotations:
        raise ValueError(
            f"DOF(s) {rotations[:3]} are not translations (direction 1-3): dataset 55 with "
            "complex shapes holds X, Y, Z only"
        )
    if (omega is None) != (inputs is None):
        raise ValueError("the FRFs (dataset 58) need both inputs= and omega=")
    if omega is not None:
        w = as_omega(omega)
        if w.size < 2 or np.any(np.diff(w) <= 0):
            raise ValueError("omega must hold at least 2 strictly increasing frequency lines")
        idx = as_array(inputs, "inputs", real=True).reshape(-1)
        if idx.size == 0 or np.any(idx != np.round(idx)) or np.any((idx < 0) | (idx >= len(R))):
            raise ValueError(f"inputs must index the {len(R)} measured DOFs, got {inputs!r}")
        if np.unique(idx).size != idx.size:  # as MeasuredData: one load case per driven DOF
            raise ValueError(f"inputs must not repeat a DOF, got {inputs!r}")
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")
    geom = _check_geometry(geometry)

    shapes = mode_shapes(model, R, labels)
    if modes is not None:
        keep = np.asarray(modes)
        if keep.dtype != np.bool_ or keep.shape != (shapes.n_modes,):
            raise ValueError(
                f"modes must be a boolean mask over the model's {shapes.n_modes} modes, "
                f"got {keep.dtype} {keep.shape}"
            )
        shapes = shapes.select(keep)
    nodes = sorted({int(n) for n in labels[:, 0]})
    sets = []
    if geom is not None:
        sets.append(_pyuff().prepare_15(
            node_nums=[int(n) for n in geom[:, 0]],
            def_cs=[0] * len(geom), disp_cs=[0] * len(geom), color=[1] * len(geom),
            x=geom[:, 1].tolist(), y=geom[:, 2].tolist(), z=geom[:, 3].tolist(),
        ))
    sets += [_set_55(j, shapes, nodes, name) for j in range(shapes.n_modes)]
    frfs = iter(())
    if omega is not None:
        frfs = _sets_58(model, R, labels, idx.astype(np.int64), w, quantity, binary, name,
                        _reciprocity_remark(data),
                        None if data is None or data.complete else data.measured)
    path = Path(path)
    path.unlink(missing_ok=True)
    try:
        writer = _pyuff().UFF(str(path))
        # pyuff re-reads the whole file after every set it writes: O(sets²), minutes
        # for a 4000-point scan; nothing here reads the file back, so no index is kept
        writer.refresh = lambda: None
        # pyuff refuses an empty list: without geometry and modes (a model whose poles
        # are all residual terms) the first sets written are FRFs
        writer.write_sets(sets or list(itertools.islice(frfs, WRITE_BATCH)), mode="add")
        while batch := list(itertools.islice(frfs, WRITE_BATCH)):
            writer.write_sets(batch, mode="add")
    except OSError:
        raise
    except Exception as exc:  # pyuff raises bare Exception from its writers
        raise ValueError(f"{path}: pyuff could not write the file: {exc}") from None
    return path
