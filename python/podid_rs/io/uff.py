"""All Universal File (UFF) handling: measured FRFs, geometry and modes in, the model out.

In (pyuff reads the file):

* :func:`read_uff` — the FRFs of dataset 58 (func_type 4) as :class:`MeasuredData`;
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
  accelerance out).

Precision is the format's: dataset 15 and 55 fields and the 58 abscissa carry 6
significant digits (E13.5), ASCII 58 ordinates 12 (E20.11), binary 58 ordinates
are exact doubles.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .._arrays import as_array, as_basis, as_dof_labels, as_omega
from ..identification.result import IdentificationResult
from ..measured import QUANTITIES, MeasuredData, from_frf, to_receptance
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


def _pyuff():
    """pyuff, imported on first use (``import podid_rs`` does not need it)."""
    import pyuff

    return pyuff


def _read_sets(path: str | Path, types: tuple[int, ...], header_only: bool = False):
    """The sets of the given dataset types, and the types the file holds."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such UFF file: {path}")
    uff = _pyuff().UFF(str(path))
    found = [int(t) for t in np.asarray(uff.get_set_types()).reshape(-1)]
    idx = [i for i, t in enumerate(found) if t in types]
    if not idx:
        return [], found
    try:
        sets = uff.read_sets(idx, header_only=header_only)
    except Exception as exc:  # pyuff raises bare Exception on malformed records
        what = "/".join(str(t) for t in types)
        raise ValueError(f"{path}: could not read dataset {what}: {exc}") from None
    return ([sets] if isinstance(sets, dict) else list(sets)), found


# --------------------------------------------------------------------------- in


def _uff_int(d: dict, key: str, where: str) -> int:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, int | np.integer):
        raise ValueError(f"{where}: field {key!r} must be an integer, got {v!r}")
    return int(v)


def read_uff(
    path: str | Path,
    *,
    quantity: str | None = None,
    band_hz: tuple[float, float] | None = None,
) -> MeasuredData:
    """FRFs from the dataset-58 records (func_type 4) of a Universal File.

    Each record is one FRF, response (node, direction) over reference (node,
    direction); a negative direction code (−3 = −Z) flips the sign, so that every
    FRF is in the positive directions. DOFs are ordered by (node, direction),
    response DOFs and driven DOFs alike; every reference must also be a response
    (driving point) and every response/reference pair must be present once. A
    roving-hammer file (fixed response, roving references, the response among the
    references) is read by reciprocity as the FRF column of a force at the fixed
    DOF, and says so in ``notes``. Numerator type 8/11/12 (displacement, velocity,
    acceleration) is converted to receptance; the abscissa is frequency in Hz,
    shared by all records. Other records (coherence, time data, other datasets) are
    ignored. The 0 Hz line is dropped.

    Parameters
    ----------
    path : str or pathlib.Path
        The file (``.uff``, ``.unv``, …).
    quantity : {"displacement", "velocity", "acceleration"}, optional
        Overrides the numerator type of the records.
    band_hz : tuple of float, optional
        Keep only the lines in (lo, hi) Hz.

    Returns
    -------
    MeasuredData
        The FRFs as unit load cases, with the (node, direction) labels.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        Naming the file and record: no FRF records, unreadable or inconsistent
        records (abscissa, denominator, numerator type, frequency lines, duplicates),
        a reference that is not a response and cannot be made one by reciprocity,
        a missing FRF of the response × reference grid, or a band keeping fewer than
        2 lines.
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
    entries: dict[tuple[tuple[int, int], tuple[int, int]], tuple[np.ndarray, str]] = {}
    for k, d in enumerate(frfs):
        where = f"{path}: FRF record {k + 1}"
        rsp = (_uff_int(d, "rsp_node", where), _uff_int(d, "rsp_dir", where))
        ref = (_uff_int(d, "ref_node", where), _uff_int(d, "ref_dir", where))
        x = as_array(d.get("x"), f"{where} abscissa", real=True)
        y = as_array(d.get("data"), f"{where} ordinate")
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
        key = ((rsp[0], abs(rsp[1])), (ref[0], abs(ref[1])))
        if key in entries:
            raise ValueError(f"{where}: a second FRF for response {key[0]} / reference {key[1]}")
        sign = (-1.0 if rsp[1] < 0 else 1.0) * (-1.0 if ref[1] < 0 else 1.0)
        entries[key] = (sign * y, q)
    if np.any(np.diff(freq) <= 0):
        raise ValueError(f"{path}: the frequency lines are not strictly increasing")
    entries, notes = _driving_point_layout(entries, path)
    outs = sorted({k[0] for k in entries})
    refs = sorted({k[1] for k in entries})
    missing = [(o, r) for o in outs for r in refs if (o, r) not in entries]
    if missing:
        raise ValueError(
            f"{path}: {len(missing)} FRF(s) of the {len(outs)} × {len(refs)} grid are missing, "
            f"e.g. response {missing[0][0]} / reference {missing[0][1]}"
        )
    keep = freq > 0
    omega = 2 * np.pi * freq[keep]
    H = np.empty((omega.size, len(outs), len(refs)), dtype=np.complex128)
    for (o, r), (y, q) in entries.items():
        H[:, outs.index(o), refs.index(r)] = to_receptance(y[keep], omega, q)
    data = from_frf(
        H,
        omega,
        inputs=[outs.index(r) for r in refs],
        dofs=np.asarray(outs, dtype=np.int64),
    )
    data = replace(data, notes=notes)
    return data if band_hz is None else data.band(band_hz)


def _driving_point_layout(entries: dict, path: Path) -> tuple[dict, tuple[str, ...]]:
    """The FRF grid with every reference among the responses, by reciprocity if need be.

    A shaker test measures the driving point: its references are responses too. A
    roving-hammer test fixes the response and roves the reference, so its references
    are not responses; Maxwell–Betti reciprocity, H(j, k) = H(k, j), turns it into
    the column of the FRF matrix for a force at the fixed response DOF, which must
    then be among the hit points. Returns the entries keyed (response, reference)
    and a note saying what was done (empty when nothing was).
    """
    outs = sorted({k[0] for k in entries})
    refs = sorted({k[1] for k in entries})
    missing_refs = [r for r in refs if r not in outs]
    if not missing_refs:
        return entries, ()
    if all(o in refs for o in outs):
        note = (
            f"{path.name}: the {len(refs)} reference DOFs are not all among the "
            f"{len(outs)} response DOF(s) (a roving-hammer test): read by reciprocity, "
            "H(j, k) = H(k, j), as the FRFs of the hit DOFs for a force at the response "
            f"DOF(s) {outs}"
        )
        return {(r, o): v for (o, r), v in entries.items()}, (note,)
    raise ValueError(
        f"{path}: reference DOF(s) {missing_refs} are not among the measured responses, "
        "and not every response is a reference either, so reciprocity cannot supply "
        "the driving point; the force must be known on a measured DOF to be projected"
    )


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
    if data is not None and any("reciprocity" in note for note in data.notes):
        return "roving-hammer test read by reciprocity: H(j, k) = H(k, j)"
    return "NONE"


def _sets_58(
    model: IdentificationResult, R: np.ndarray, dofs: np.ndarray, inputs: np.ndarray,
    omega: np.ndarray, quantity: str, binary: bool, name: str, remark: str = "NONE",
) -> list[dict]:
    pyuff = _pyuff()
    H_m = model.system().frf(omega)
    H = np.einsum("am,smk,bk->sab", R, H_m, R[inputs]) * _receptance_to(quantity, omega)[
        :, None, None
    ]
    freq = omega / (2 * np.pi)
    step = np.diff(freq)
    even = bool(np.allclose(step, step[0], rtol=1e-9, atol=0.0))
    sets = []
    for k, col in enumerate(inputs):
        ref = (int(dofs[col, 0]), int(dofs[col, 1]))
        for i, (node, direction) in enumerate(dofs.tolist()):
            sets.append(pyuff.prepare_58(
                binary=int(binary),
                id1="FRF",
                id2=f"H({node}:{direction}, {ref[0]}:{ref[1]}) {name}, identified"[:80],
                id3=remark[:80],
                id4="NONE",
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
            ))
    return sets


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
    1–3, only), 58 the identified FRFs ``R H_m(ω) Rᵀ`` (module docstring). FRFs from
    data read by reciprocity (a roving-hammer file) say so in their third ID line.
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
        Without ``data``: indices of the driven DOFs, needed with ``omega`` for the
        FRFs.
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
    if omega is not None:
        sets += _sets_58(model, R, labels, idx.astype(np.int64), w, quantity, binary, name,
                         _reciprocity_remark(data))
    path = Path(path)
    path.unlink(missing_ok=True)
    try:
        writer = _pyuff().UFF(str(path))
        # pyuff re-reads the whole file after every set it writes: O(sets²), minutes
        # for a 4000-point scan; nothing here reads the file back, so no index is kept
        writer.refresh = lambda: None
        writer.write_sets(sets, mode="add")
    except OSError:
        raise
    except Exception as exc:  # pyuff raises bare Exception from its writers
        raise ValueError(f"{path}: pyuff could not write the file: {exc}") from None
    return path
