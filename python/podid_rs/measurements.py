"""Measured data in: UFF dataset 58 FRFs, time histories, ``.npz`` data sets and models.

A test engineer's data become a :class:`MeasuredData`: responses ``U`` on the n
measured DOFs and forces ``F`` on the n_in driven DOFs, both frequency-first with
p load cases per frequency line. FRFs ``H (s, n, n_in)`` are the case of unit
forces, one load case per driven DOF: ``U = H``, ``F = I`` on every line.

**Coordinates.** POD and identification (paper eqs. 41–46) need responses and
forces on the same DOFs. Forces are known only where the structure is driven;
on every other measured DOF they are taken to be zero, which holds for shaker
and hammer tests and is exactly what the data can support. Hence every driven
DOF must also be a measured response DOF (a driving-point measurement), and the
reduced forces are ``F_m = Rᵀ F_n`` with ``F_n`` zero off the driven DOFs.

**What the data allow.** The POD basis comes from the measured responses
alone, ``Ruu = ∫ Re(U Uᴴ) dω`` (eq. 4): for FRFs this is the response to white
noise on the *driven* DOFs, not on every DOF as in the paper's "rain on the
roof", so it spans only what those inputs excite, on the measured DOFs only.
The identified M, C, K are the reduced matrices of that subspace (eqs. 14–16)
and are fixed by the force scale: responses without measured forces (ambient,
operational data) give a basis but no M, C, K, and a force calibration error
scales all three matrices by its inverse. Each load case gives 2m real
equations per line against 3m² unknowns (3m(m+1)/2 symmetric), so
``s · p ≥ 1.5 m`` lines × load cases is the least that can determine them.
Unit forces on p driven DOFs span at most p of the m reduced directions, and
then every ``(I + Q) [M C K]`` with ``Q F_m = 0`` fits the data as well as the
truth: plain least squares (λ = 0) is rank deficient, rank at most
m (2m + p) of 3m², unless p ≥ m. Symmetry removes that freedom for generic
systems, so identify FRF data with ``symmetric=True`` or λ > 0. Forces that vary
from line to line (random excitation, ``estimator="spectra"``) have no such limit.

**Units.** Everything is converted to receptance (displacement per unit force)
with the e^{iωt} convention of the FFT used here: velocity ÷ iω, acceleration
÷ −ω². Frequencies are rad/s inside, Hz in files and bands; the 0 Hz line is
dropped. UFF unit exponents are not applied: ordinates are taken to be in
consistent units.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import MISSING, dataclass, fields, replace
from pathlib import Path
from typing import Literal

import numpy as np

from ._arrays import as_array, as_omega
from .identification import Backend, IdentificationResult, identify
from .pod import PODResult, pod_from_frf
from .simulation import _records, frf_h1, spectra
from .systems import SecondOrderSystem

Quantity = Literal["displacement", "velocity", "acceleration"]
QUANTITIES: tuple[str, ...] = ("displacement", "velocity", "acceleration")

#: UFF specific data types of an FRF's numerator (record 9) and denominator (record 10).
UFF_QUANTITY = {8: "displacement", 11: "velocity", 12: "acceleration"}
UFF_FORCE_TYPES = (0, 1, 9, 13)  # unknown, general, reaction force, excitation force
UFF_FRF = 4  # func_type of a frequency response function
UFF_FREQUENCY_TYPES = (0, 18)  # abscissa: unknown or frequency (Hz)

DATA_FORMAT = "podid_rs.MeasuredData/1"
MODEL_FORMAT = "podid_rs.IdentificationResult/1"


def to_receptance(X: object, omega: object, quantity: str) -> np.ndarray:
    """Displacement from ``quantity`` spectra or FRFs ``X`` ``(s, ...)``: ÷ iω or ÷ −ω².

    ``omega`` ``(s,)`` in rad/s, all > 0. Returns a fresh complex array.
    """
    Xa = as_array(X, "X").astype(np.complex128)
    w = as_omega(omega)
    if Xa.ndim == 0 or Xa.shape[0] != w.size:
        raise ValueError(f"X must be frequency-first with {w.size} lines, got shape {Xa.shape}")
    w = w.reshape((-1,) + (1,) * (Xa.ndim - 1))
    if quantity == "displacement":
        return Xa
    if quantity == "velocity":
        return Xa / (1j * w)
    if quantity == "acceleration":
        return Xa / -(w**2)
    raise ValueError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")


def _dof_labels(dofs: object, n: int) -> np.ndarray:
    """(n, 2) int64 (node, direction) labels; ``None`` gives (k, 1), k = 1…n."""
    if dofs is None:
        return np.stack([np.arange(1, n + 1), np.ones(n, dtype=np.int64)], axis=1)
    d = as_array(dofs, "dofs", real=True)
    if d.shape != (n, 2):
        raise ValueError(f"dofs must have shape (n, 2) = ({n}, 2) (node, direction), got {d.shape}")
    if np.any(d != np.round(d)) or np.any(np.abs(d) > 2**53):
        raise ValueError("dofs must hold integer (node, direction) labels")
    labels = d.astype(np.int64)
    if len({tuple(r) for r in labels.tolist()}) != n:
        raise ValueError("dofs must not repeat a (node, direction) label")
    return labels


def _input_indices(inputs: object, n: int, n_in: int) -> np.ndarray:
    """Indices of the driven DOFs among the n measured ones; ``None`` → all (n_in = n)."""
    if inputs is None:
        if n_in != n:
            raise ValueError(
                f"inputs (the indices of the {n_in} driven DOFs among the {n} measured "
                "responses) must be given when they are not all of them"
            )
        return np.arange(n)
    a = as_array(inputs, "inputs", real=True).reshape(-1)
    if a.size != n_in or np.any(a != np.round(a)):
        raise ValueError(
            f"inputs must hold {n_in} integer indices (one per driven DOF), got {inputs!r}"
        )
    if np.any(a < 0) or np.any(a >= n):
        raise ValueError(f"inputs must index the {n} measured DOFs (0 … {n - 1}), got {inputs!r}")
    idx = a.astype(np.int64)
    if np.unique(idx).size != idx.size:
        raise ValueError(f"inputs must not repeat a DOF, got {inputs!r}")
    return idx


def _load_cases(x: object, name: str, s: int) -> np.ndarray:
    """Fresh complex ``(s, k, p)`` array from ``(s, k)`` or ``(s, k, p)``."""
    a = as_array(x, name).astype(np.complex128)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[0] != s or 0 in a.shape:
        raise ValueError(
            f"{name} must have shape (s, ·) or (s, ·, p) with s = {s} lines, got {a.shape}"
        )
    return a


@dataclass(frozen=True)
class MeasuredData:
    """Responses and forces of a test, frequency-first (paper eqs. 45–46 before projection).

    ``omega`` ``(s,)`` rad/s, strictly increasing, > 0; ``U`` ``(s, n, p)`` complex
    displacements on the n measured DOFs (receptances for FRF data); ``F``
    ``(s, n_in, p)`` complex forces on the driven DOFs, ``inputs`` ``(n_in,)``
    their indices among the measured DOFs; ``dofs`` ``(n, 2)`` the (node,
    direction) label of each measured DOF; ``notes`` what reading the data
    assumed (e.g. reciprocity for a roving-hammer file). The constructor checks and
    copies everything; ``(s, n)`` / ``(s, n_in)`` arrays mean one load case.
    """

    omega: np.ndarray
    U: np.ndarray
    F: np.ndarray
    dofs: np.ndarray | None = None
    inputs: np.ndarray | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        w = as_omega(self.omega)
        if w.size < 2 or np.any(np.diff(w) <= 0):
            raise ValueError("omega must hold at least 2 strictly increasing frequency lines")
        U = _load_cases(self.U, "U", w.size)
        F = _load_cases(self.F, "F", w.size)
        if F.shape[2] != U.shape[2]:
            raise ValueError(
                "U and F must have the same number of load cases p, "
                f"got {U.shape[2]} and {F.shape[2]}"
            )
        if not np.any(U):
            raise ValueError("U is identically zero: there is nothing to identify from")
        n, n_in = U.shape[1], F.shape[1]
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "U", U)
        object.__setattr__(self, "F", F)
        object.__setattr__(self, "dofs", _dof_labels(self.dofs, n))
        object.__setattr__(self, "inputs", _input_indices(self.inputs, n, n_in))
        object.__setattr__(self, "notes", tuple(str(v) for v in self.notes))

    @property
    def s(self) -> int:
        """Number of frequency lines."""
        return self.U.shape[0]

    @property
    def n(self) -> int:
        """Number of measured (response) DOFs."""
        return self.U.shape[1]

    @property
    def p(self) -> int:
        """Number of load cases per frequency line."""
        return self.U.shape[2]

    @property
    def freq_hz(self) -> np.ndarray:
        return self.omega / (2 * np.pi)

    @property
    def is_frf(self) -> bool:
        """True when the forces are unit forces, one load case per driven DOF (U = H)."""
        return self.F.shape[1] == self.p and bool(np.all(self.F == np.eye(self.p)))

    def forces_on_dofs(self) -> np.ndarray:
        """``F_n`` ``(s, n, p)``: the forces on all measured DOFs, zero off the driven ones."""
        Fn = np.zeros_like(self.U)
        Fn[:, self.inputs, :] = self.F
        return Fn

    def band(self, band_hz: tuple[float, float]) -> MeasuredData:
        """The lines with ``lo ≤ f ≤ hi`` (Hz); at least 2 must remain."""
        b = as_array(band_hz, "band_hz", real=True)
        if b.shape != (2,) or not 0 <= b[0] < b[1]:
            raise ValueError(
                f"band_hz must be a pair (lo, hi) in Hz with 0 <= lo < hi, got {band_hz!r}"
            )
        keep = (self.freq_hz >= b[0]) & (self.freq_hz <= b[1])
        if keep.sum() < 2:
            raise ValueError(
                f"band_hz {band_hz!r} keeps {int(keep.sum())} of the {self.s} lines "
                f"({self.freq_hz[0]:g}–{self.freq_hz[-1]:g} Hz); at least 2 are needed"
            )
        return replace(self, omega=self.omega[keep], U=self.U[keep], F=self.F[keep])

    def pod(self) -> PODResult:
        """POD of the measured responses: ``Ruu = ∫ Re(U Uᴴ) dω`` over the lines (eqs. 4–5).

        For FRFs this is the correlation under white noise on the driven DOFs.
        """
        return pod_from_frf(self.U, self.omega)

    def project(self, R: object) -> tuple[np.ndarray, np.ndarray]:
        """``U_m = Rᵀ U``, ``F_m = Rᵀ F_n`` ``(s, m, p)`` on a basis R ``(n, m)`` (eqs. 45–46)."""
        Ra = as_array(R, "R", real=True)
        if Ra.ndim != 2 or Ra.shape[0] != self.n or Ra.shape[1] == 0:
            raise ValueError(
                f"R must have shape (n, m) with n = {self.n} measured DOFs, got {Ra.shape}"
            )
        U_m = np.einsum("nm,snp->smp", Ra, self.U)
        F_m = np.einsum("im,sip->smp", Ra[self.inputs], self.F)
        return U_m, F_m

    def predict(self, system: SecondOrderSystem, R: object) -> np.ndarray:
        """Responses ``R Z_m(ω)⁻¹ Rᵀ F_n`` ``(s, n, p)`` of a reduced model on basis ``R`` (eq. 19).

        For FRF data this is the model's FRF on the measured DOFs, ``R H_m Rᵀ``.
        """
        if not isinstance(system, SecondOrderSystem):
            raise ValueError(f"system must be a SecondOrderSystem, got {type(system).__name__}")
        _, F_m = self.project(R)
        if F_m.shape[1] != system.n:
            raise ValueError(f"the model has {system.n} DOFs but R has {F_m.shape[1]} columns")
        return np.einsum(
            "nm,smp->snp", as_array(R, "R", real=True), system.response(self.omega, F_m)
        )

    def identify(
        self,
        m: int | None = None,
        energy: float | None = None,
        lam: float | tuple[float, float, float] = 0.0,
        symmetric: bool = False,
        *,
        backend: Backend = "rust",
        threads: int | None = None,
    ) -> tuple[IdentificationResult, np.ndarray]:
        """POD, projection and :func:`podid_rs.identify` in one step (paper §5, steps 1–6).

        The order is ``m``, or the smallest capturing the energy fraction ``energy``
        (eq. 43; 0.99 when neither is given). Returns the result and the basis R ``(n, m)``.
        """
        if m is not None and energy is not None:
            raise ValueError("give the reduced order m or the energy fraction, not both")
        basis = self.pod()
        if m is None:
            m = basis.order_for_energy(0.99 if energy is None else energy)
        R = basis.basis(m)
        U_m, F_m = self.project(R)
        result = identify(U_m, F_m, self.omega, lam, symmetric, backend=backend, threads=threads)
        return result, R

    def fit(
        self,
        m: int | None = None,
        *,
        m_max: int | None = None,
        progress: bool = False,
        threads: int | None = None,
    ):
        """Output-error models that reproduce these data (DESIGN §6, :mod:`podid_rs.model_order`).

        Orders 1, 2, … are fitted by continuation on the POD basis, m is chosen on
        held-out lines (or given), and that order is refitted on every line. Returns
        ``(model, R, sweep)``: the refined :class:`IdentificationResult` (M, C, K
        positive definite, stable), the basis R ``(n, m)`` and the
        :class:`podid_rs.model_order.OrderSweep` (every order's errors, the reason for m).
        """
        return _fit_output_error(self, m, m_max, progress, threads)


def _fit_output_error(data: MeasuredData, m, m_max, progress, threads):
    from .model_order import final_fit, sweep_orders

    pod = data.pod()
    F_n = data.forces_on_dofs()
    sweep = sweep_orders(data.U, F_n, data.omega, pod, m=m, m_max=m_max, threads=threads)
    model, R = final_fit(sweep, data.U, F_n, data.omega, pod, threads=threads,
                         progress=progress)
    return model, R, sweep


def from_frf(
    H: object,
    omega: object,
    *,
    inputs: object = None,
    dofs: object = None,
    quantity: str = "displacement",
) -> MeasuredData:
    """FRFs ``H`` ``(s, n, n_in)`` of ``quantity`` per unit force as :class:`MeasuredData`.

    ``inputs`` are the indices of the n_in driven DOFs among the n responses
    (default: all, for square H). Unit forces: p = n_in load cases, ``F = I``.
    """
    Ha = as_array(H, "H")
    if Ha.ndim != 3 or 0 in Ha.shape:
        raise ValueError(f"H must have shape (s, n_out, n_in), got {Ha.shape}")
    w = as_omega(omega)
    U = to_receptance(Ha, w, quantity)
    F = np.broadcast_to(np.eye(Ha.shape[2]), (w.size, Ha.shape[2], Ha.shape[2]))
    return MeasuredData(w, U, F, dofs, inputs)


def from_time_histories(
    forces: object,
    responses: object,
    dt: float,
    *,
    inputs: object = None,
    dofs: object = None,
    quantity: str = "displacement",
    estimator: Literal["h1", "spectra"] = "h1",
    band_hz: tuple[float, float] | None = None,
    nperseg: int | None = None,
) -> MeasuredData:
    """Time histories of forces ``(r, n_in)`` and responses ``(r, n)`` as :class:`MeasuredData`.

    Several records are ``(n_rec, r, ·)``. ``estimator="h1"``: FRFs by the H1
    estimator with Welch averaging (:func:`podid_rs.frf_h1`, segments of
    ``nperseg``), p = n_in unit load cases. ``estimator="spectra"``: the real FFT
    of each whole record (:func:`podid_rs.spectra`, as in the paper), one load
    case per record; exact for periodic records, leaky otherwise. ``inputs``:
    indices of the forced DOFs among the responses; responses in ``quantity``.
    """
    if estimator == "h1":
        omega, H = frf_h1(forces, responses, dt, nperseg=nperseg, band_hz=band_hz)
        return from_frf(H, omega, inputs=inputs, dofs=dofs, quantity=quantity)
    if estimator != "spectra":
        raise ValueError(f"estimator must be 'h1' or 'spectra', got {estimator!r}")
    if nperseg is not None:
        raise ValueError("nperseg applies to estimator='h1' only (Welch segments)")
    x = _records(forces, "forces")
    y = _records(responses, "responses")
    if x.shape[:2] != y.shape[:2]:
        raise ValueError(
            "forces and responses must have the same number of records and samples, "
            f"got {x.shape} and {y.shape}"
        )
    omega = spectra(y[0], dt, band_hz)[0]
    X = np.stack([spectra(rec, dt, band_hz)[1] for rec in x], axis=-1)
    Y = np.stack([spectra(rec, dt, band_hz)[1] for rec in y], axis=-1)
    return MeasuredData(omega, to_receptance(Y, omega, quantity), X, dofs, inputs)


# --------------------------------------------------------------------------- UFF


def _uff_sets(path: Path) -> list[dict]:
    import pyuff

    if not path.is_file():
        raise FileNotFoundError(f"no such UFF file: {path}")
    uff = pyuff.UFF(str(path))
    idx = [int(i) for i in np.flatnonzero(np.asarray(uff.get_set_types()) == 58)]
    if not idx:
        raise ValueError(f"{path}: no dataset 58 (function at nodal DOF) in the file")
    try:
        sets = uff.read_sets(idx)
    except Exception as exc:  # pyuff raises bare Exception on malformed records
        raise ValueError(f"{path}: could not read dataset 58: {exc}") from None
    return [sets] if isinstance(sets, dict) else list(sets)


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
    acceleration; ``quantity`` overrides it) is converted to receptance; the
    abscissa is frequency in Hz, shared by all records. Other records (coherence,
    time data, other datasets) are ignored. The 0 Hz line is dropped, and lines
    outside ``band_hz``.
    """
    path = Path(path)
    sets = _uff_sets(path)
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


# --------------------------------------------------------------------------- .npz


def save_data(path: str | Path, data: MeasuredData) -> Path:
    """Write a :class:`MeasuredData` to an ``.npz`` file (the name is used as given)."""
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
        )
    return path


def _read_npz(path: str | Path) -> dict[str, np.ndarray]:
    """All arrays of an ``.npz`` file (no pickles); ``ValueError`` if it is not one."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    try:
        with np.load(path, allow_pickle=False) as z:
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise ValueError("it holds a single array, not named arrays")
            return {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{path}: not a readable .npz file: {exc}") from None


def _need(z: dict, keys: tuple[str, ...], path: str | Path, what: str) -> None:
    absent = [k for k in keys if k not in z]
    if absent:
        raise ValueError(f"{path}: {what} needs the arrays {absent} (found {sorted(z)})")


def load_data(path: str | Path, *, band_hz: tuple[float, float] | None = None) -> MeasuredData:
    """Read measured data: a UFF file (``.uff``/``.unv``) or an ``.npz`` file.

    An ``.npz`` is either a data set written by :func:`save_data`, or time
    histories with arrays ``forces``, ``responses``, ``dt`` and optionally
    ``inputs``, ``dofs``, ``quantity``, ``estimator``, ``nperseg``
    (see :func:`from_time_histories`). ``band_hz`` keeps the lines in that band.
    """
    path = Path(path)
    if path.suffix.lower() in (".uff", ".unv", ".uf"):
        return read_uff(path, band_hz=band_hz)
    if path.suffix.lower() != ".npz":
        raise ValueError(f"{path}: unknown data format (expected .uff, .unv or .npz)")
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
    data = MeasuredData(z["omega"], z["U"], z["F"], z.get("dofs"), z.get("inputs"), notes)
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
    """Write an :class:`IdentificationResult` and extra named arrays (e.g. R) to ``.npz``.

    Array fields are stored as arrays, the rest (λ, norms, solver facts, ``info``)
    as JSON; :func:`load_model` restores them.
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
    path = Path(path)
    with path.open("wb") as fh:
        np.savez(fh, format=MODEL_FORMAT, meta=json.dumps(meta), **out)
    return path


def load_model(path: str | Path) -> tuple[IdentificationResult, dict[str, np.ndarray]]:
    """Read a model written by :func:`save_model`: the result and the extra arrays."""
    z = _read_npz(path)
    if "format" not in z or str(z["format"]) != MODEL_FORMAT:
        raise ValueError(f"{path}: not a model file written by save_model ({MODEL_FORMAT})")
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
