"""Measured data and identified models as ``.npz`` files, and measured data in from any file.

* :func:`save_data` / :func:`load_data` — a :class:`MeasuredData`; :func:`load_data`
  also reads time histories saved as ``.npz`` and UFF files (:mod:`.uff`);
* :func:`save_model` / :func:`load_model` — an :class:`IdentificationResult` with
  extra named arrays (the basis R, the DOF labels, …).

Files are read without pickles (``allow_pickle=False``).
"""

from __future__ import annotations

import json
import zipfile
import zlib
from dataclasses import MISSING, fields
from pathlib import Path

import numpy as np

from ..identification.result import IdentificationResult
from ..measured import MeasuredData, from_time_histories
from .uff import read_uff

DATA_FORMAT = "podid_rs.MeasuredData/1"
MODEL_FORMAT = "podid_rs.IdentificationResult/1"


def save_data(path: str | Path, data: MeasuredData) -> Path:
    """Write a :class:`MeasuredData` to an ``.npz`` file.

    Parameters
    ----------
    path : str or pathlib.Path
        The file; the name is used as given (no suffix is added).
    data : MeasuredData
        The data.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For data that are not a :class:`MeasuredData`.
    OSError
        When the file cannot be written.
    """
    if not isinstance(data, MeasuredData):
        raise ValueError(f"data must be a MeasuredData, got {type(data).__name__}")
    path = Path(path)
    with path.open("wb") as fh:
        np.savez(
            fh,
            format=DATA_FORMAT,
            omega=data.omega,
            U=data.U,
            F=data.F,
            dofs=data.dofs,
            inputs=data.inputs,
            notes=np.array(data.notes, dtype=str),
            measured=data.measured,
        )
    return path


def _read_npz(path: str | Path) -> dict[str, np.ndarray]:
    """All arrays of an ``.npz`` file (no pickles); ``ValueError`` if it is not one."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    try:
        z = np.load(path, allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):  # a .npy payload: a bare array
            raise ValueError("it holds a single array, not named arrays")
        with z:
            return {k: z[k] for k in z.files}
    # a cut-off file fails in zipfile, a damaged compressed one (np.savez_compressed) in zlib
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path}: not a readable .npz file: {exc}") from None


def _need(z: dict, keys: tuple[str, ...], path: str | Path, what: str) -> None:
    absent = [k for k in keys if k not in z]
    if absent:
        raise ValueError(f"{path}: {what} needs the arrays {absent} (found {sorted(z)})")


def load_data(path: str | Path, *, band_hz: tuple[float, float] | None = None) -> MeasuredData:
    """Read measured data: a UFF file (``.uff``/``.unv``/``.uf``) or an ``.npz`` file.

    An ``.npz`` is either a data set written by :func:`save_data` (with its mask of
    measured entries, :attr:`MeasuredData.measured`; complete when absent), or time
    histories with arrays ``forces``, ``responses``, ``dt`` and optionally
    ``inputs``, ``dofs``, ``quantity``, ``estimator``, ``nperseg``
    (see :func:`podid_rs.measured.from_time_histories`).

    Parameters
    ----------
    path : str or pathlib.Path
        The file; its suffix says what it is.
    band_hz : tuple of float, optional
        Keep only the lines with lo ≤ f ≤ hi Hz (both ends included).

    Returns
    -------
    MeasuredData
        The data.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        For an unknown suffix, a file that is not readable as one, arrays missing or
        malformed, or a band keeping fewer than 2 lines.
    """
    path = Path(path)
    if path.suffix.lower() in (".uff", ".unv", ".uf"):
        return read_uff(path, band_hz=band_hz)
    if path.suffix.lower() != ".npz":
        raise ValueError(f"{path}: unknown data format (expected .uff, .unv, .uf or .npz)")
    z = _read_npz(path)
    if "forces" in z or "responses" in z:
        _need(z, ("forces", "responses", "dt"), path, "a time-history file")
        opts = {k: z[k].item() for k in ("quantity", "estimator", "nperseg") if k in z}
        return from_time_histories(
            z["forces"],
            z["responses"],
            z["dt"],
            inputs=z.get("inputs"),
            dofs=z.get("dofs"),
            band_hz=band_hz,
            **opts,
        )
    _need(z, ("omega", "U", "F"), path, "a measured data set")
    notes = tuple(str(v) for v in z["notes"]) if "notes" in z else ()
    data = MeasuredData(z["omega"], z["U"], z["F"], z.get("dofs"), z.get("inputs"), notes,
                        z.get("measured"))  # files written before masks existed: complete
    return data if band_hz is None else data.band(band_hz)


def _jsonable(x: object) -> object:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    return x


def _tuples(x: object) -> object:
    if isinstance(x, dict):
        return {k: _tuples(v) for k, v in x.items()}
    if isinstance(x, list):
        return tuple(_tuples(v) for v in x)
    return x


def save_model(path: str | Path, result: IdentificationResult, **arrays: object) -> Path:
    """Write an :class:`IdentificationResult` and extra named arrays to ``.npz``.

    Array fields are stored as arrays, the rest (λ, norms, solver facts, ``info``)
    as JSON; :func:`load_model` restores them.

    Parameters
    ----------
    path : str or pathlib.Path
        The file; the name is used as given.
    result : IdentificationResult
        The model.
    **arrays : array_like
        Extra arrays to keep beside it (e.g. ``basis=R``, ``dofs=``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For a result that is not an :class:`IdentificationResult`.
    TypeError
        For an ``info`` entry that JSON cannot hold (nothing is written then).
    OSError
        When the file cannot be written.
    """
    if not isinstance(result, IdentificationResult):
        raise ValueError(f"result must be an IdentificationResult, got {type(result).__name__}")
    out: dict[str, np.ndarray] = {}
    meta: dict[str, object] = {}
    for f in fields(result):
        v = getattr(result, f.name)
        if isinstance(v, np.ndarray):
            out[f"result.{f.name}"] = v
        else:
            meta[f.name] = _jsonable(v)
    for k, v in arrays.items():
        out[f"extra.{k}"] = np.asarray(v)
    text = json.dumps(meta)  # before the file is opened: a refused entry leaves no file
    path = Path(path)
    with path.open("wb") as fh:
        np.savez(fh, format=MODEL_FORMAT, meta=text, **out)
    return path


def load_model(path: str | Path) -> tuple[IdentificationResult, dict[str, np.ndarray]]:
    """Read a model written by :func:`save_model`.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    result : IdentificationResult
        The model (tuples restored where JSON made lists).
    arrays : dict of str to numpy.ndarray
        The extra arrays, by name.

    Raises
    ------
    FileNotFoundError
        When there is no such file.
    ValueError
        For a file that is not a model written by :func:`save_model`, or lacks a field.
    """
    z = _read_npz(path)
    if "format" not in z or str(z["format"]) != MODEL_FORMAT:
        raise ValueError(f"{path}: not a model file written by save_model ({MODEL_FORMAT})")
    if "meta" not in z:  # the record of the fields save_model writes beside the arrays
        raise ValueError(f"{path}: the model file has no 'meta' record of its fields")
    meta = json.loads(str(z["meta"]))
    kwargs: dict[str, object] = {}
    for f in fields(IdentificationResult):
        if f"result.{f.name}" in z:
            kwargs[f.name] = z[f"result.{f.name}"]
        elif f.name in meta:
            kwargs[f.name] = _tuples(meta[f.name])
        elif f.default is MISSING and f.default_factory is MISSING:
            raise ValueError(f"{path}: the model lacks the field {f.name!r}")
    extras = {k.removeprefix("extra."): v for k, v in z.items() if k.startswith("extra.")}
    return IdentificationResult(**kwargs), extras
