"""Measured data in memory: :class:`MeasuredData`, from FRFs or from time histories.

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

**Entries that were not measured.** A multi-reference test can leave holes in the
n × p grid of responses × load cases (a channel lost in one run, two campaigns
combined). ``measured`` ``(n, p)`` marks the entries that were measured; the holes
hold zeros and weigh nothing in the fit and in every error
(:mod:`podid_rs.identification.holes`). The POD correlation is that of the
zero-filled responses: a load case with holes contributes its measured entries
only (:meth:`MeasuredData.pod`).

Files are read and written by :mod:`podid_rs.io` (UFF dataset 58, ``.npz``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from ._arrays import as_array, as_dof_labels, as_omega
from .identification.estimator import identify
from .identification.holes import check_measured, measured_targets
from .identification.order import OrderSweep, final_fit, sweep_orders
from .identification.result import IdentificationResult
from .identification.solvers import Backend
from .pod import PODResult, pod_from_frf
from .simulation import _records, frf_h1, spectra
from .systems import SecondOrderSystem

Quantity = Literal["displacement", "velocity", "acceleration"]
QUANTITIES: tuple[str, ...] = ("displacement", "velocity", "acceleration")


class DataWarning(UserWarning):
    """Something in the measured data was not used as it stands, and what was done.

    Raised (as a warning) when reading data: an FRF that is zero at every line (a
    dead channel: that entry is treated as not measured), lines of an FRF that are
    exactly zero, or the same FRF measured twice (the two are averaged). The message
    names the file, the record and the response / reference DOFs.

    Parameters
    ----------
    message : str
        What was found and what was done with it.
    """


def to_receptance(X: object, omega: object, quantity: str) -> np.ndarray:
    """Displacement from spectra or FRFs of displacement, velocity or acceleration.

    With the e^{iωt} convention: velocity ÷ iω, acceleration ÷ −ω².

    Parameters
    ----------
    X : array_like, (s, ...)
        Spectra or FRFs, frequency-first.
    omega : array_like, (s,)
        Angular frequencies (rad/s), all > 0.
    quantity : {"displacement", "velocity", "acceleration"}
        What X measures.

    Returns
    -------
    numpy.ndarray, complex
        A fresh array of X's shape.

    Raises
    ------
    ValueError
        For malformed X or omega, or an unknown quantity.
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


def band_lines(freq_hz: np.ndarray, band_hz: tuple[float, float]) -> np.ndarray:
    """The lines of a band: a mask over ``freq_hz`` of the lines with lo ≤ f ≤ hi.

    Raises ``ValueError`` for a malformed band (not 0 ≤ lo < hi) or one keeping fewer
    than 2 lines, naming the band and the lines there are.
    """
    b = as_array(band_hz, "band_hz", real=True)
    if b.shape != (2,) or not 0 <= b[0] < b[1]:
        raise ValueError(
            f"band_hz must be a pair (lo, hi) in Hz with 0 <= lo < hi, got {band_hz!r}"
        )
    keep = (freq_hz >= b[0]) & (freq_hz <= b[1])
    if keep.sum() < 2:
        raise ValueError(
            f"band_hz {band_hz!r} keeps {int(keep.sum())} of the {freq_hz.size} lines "
            f"({freq_hz[0]:g}–{freq_hz[-1]:g} Hz); at least 2 are needed"
        )
    return keep


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

    The constructor checks and copies everything; ``(s, n)`` / ``(s, n_in)`` arrays
    mean one load case. Made by :func:`from_frf`, :func:`from_time_histories`,
    :func:`podid_rs.read_uff` and :func:`podid_rs.load_data`.

    Parameters
    ----------
    omega : array_like, (s,)
        Angular frequencies (rad/s), at least 2, strictly increasing, > 0.
    U : array_like, complex, (s, n) or (s, n, p)
        Displacements on the n measured DOFs (receptances for FRF data), not all zero.
    F : array_like, complex, (s, n_in) or (s, n_in, p)
        Forces on the driven DOFs, with U's load cases.
    dofs : array_like, (n, 2), optional
        The (node, direction) label of each measured DOF, integers, distinct
        (default (k, 1), k = 1 … n).
    inputs : array_like, (n_in,), optional
        Indices of the driven DOFs among the measured ones, distinct (default: all,
        when n_in = n).
    notes : tuple of str
        What reading the data assumed (e.g. reciprocity for a roving-hammer file).
    measured : array_like of bool, (n, p), optional
        True where response n of load case p was measured (default: every entry).
        The responses in the other entries (holes) are set to zero in ``U`` and weigh
        nothing in the fit and its errors. Every load case and every DOF needs a
        measured entry.

    Attributes
    ----------
    omega : numpy.ndarray, (s,)
        The lines, rad/s.
    U : numpy.ndarray, complex, (s, n, p)
        The responses.
    F : numpy.ndarray, complex, (s, n_in, p)
        The forces.
    dofs : numpy.ndarray of int64, (n, 2)
        The (node, direction) labels.
    inputs : numpy.ndarray of int64, (n_in,)
        The driven DOFs' indices.
    notes : tuple of str
        What reading the data assumed.
    measured : numpy.ndarray of bool, (n, p)
        The entries that were measured (all True for complete data).
    complete : bool
        Whether every entry was measured.
    s : int
        Number of frequency lines.
    n : int
        Number of measured (response) DOFs.
    p : int
        Number of load cases per frequency line.
    freq_hz : numpy.ndarray, (s,)
        The lines in Hz.
    is_frf : bool
        True when the forces are unit forces, one load case per driven DOF (U = H).

    Raises
    ------
    ValueError
        For malformed or inconsistent arrays, fewer than 2 lines, U identically
        zero, or bad ``dofs``/``inputs``/``measured``.
    """

    omega: np.ndarray
    U: np.ndarray
    F: np.ndarray
    dofs: np.ndarray | None = None
    inputs: np.ndarray | None = None
    notes: tuple[str, ...] = ()
    measured: np.ndarray | None = None

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
        mask = check_measured(self.measured, U.shape[1], U.shape[2])
        if mask is not None:
            U[:, ~mask] = 0.0  # a fresh copy: the holes hold zeros, whatever was passed
        if not np.any(U):
            raise ValueError("U is identically zero: there is nothing to identify from")
        n, n_in = U.shape[1], F.shape[1]
        object.__setattr__(
            self, "measured", np.ones((n, U.shape[2]), dtype=bool) if mask is None else mask
        )
        object.__setattr__(self, "omega", w)
        object.__setattr__(self, "U", U)
        object.__setattr__(self, "F", F)
        object.__setattr__(self, "dofs", as_dof_labels(self.dofs, n))
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
        """The frequency lines in Hz, ω / 2π."""
        return self.omega / (2 * np.pi)

    @property
    def complete(self) -> bool:
        """Whether every response of every load case was measured."""
        return bool(self.measured.all())

    def _mask(self) -> np.ndarray | None:
        """The mask for the fitters: None for complete data."""
        return None if self.complete else self.measured

    @property
    def is_frf(self) -> bool:
        """True when the forces are unit forces, one load case per driven DOF (U = H)."""
        return self.F.shape[1] == self.p and bool(np.all(self.F == np.eye(self.p)))

    def forces_on_dofs(self) -> np.ndarray:
        """The forces on all measured DOFs, zero off the driven ones.

        Returns
        -------
        numpy.ndarray, complex, (s, n, p)
            ``F_n``, whose reduced forces are ``F_m = Rᵀ F_n`` (eq. 46).
        """
        Fn = np.zeros_like(self.U)
        Fn[:, self.inputs, :] = self.F
        return Fn

    def band(self, band_hz: tuple[float, float]) -> MeasuredData:
        """The lines of a frequency band.

        Parameters
        ----------
        band_hz : tuple of float
            (lo, hi) in Hz, ``0 ≤ lo < hi``; lines with ``lo ≤ f ≤ hi`` are kept.

        Returns
        -------
        MeasuredData
            The same data on those lines.

        Raises
        ------
        ValueError
            For a malformed band, or one that keeps fewer than 2 lines.
        """
        keep = band_lines(self.freq_hz, band_hz)
        return replace(self, omega=self.omega[keep], U=self.U[keep], F=self.F[keep])

    def pod(self) -> PODResult:
        """POD of the measured responses: ``Ruu = ∫ Re(U Uᴴ) dω`` over the lines (eqs. 4–5).

        For FRFs this is the correlation under white noise on the driven DOFs. With
        holes (``measured``) it is the correlation of the zero-filled responses: each
        load case contributes the products of its measured entries only, and a DOF
        counts with the load cases that measured it. No hole is filled with a guess;
        what this costs is the order in which directions enter the basis (a DOF
        measured in fewer load cases carries less energy), not what a full basis
        spans: every measured DOF with a non-zero response has a direction.

        Returns
        -------
        PODResult
            :func:`podid_rs.pod_from_frf` of U.
        """
        return pod_from_frf(self.U, self.omega)

    def project(self, R: object) -> tuple[np.ndarray, np.ndarray]:
        """The reduced responses and forces on a basis (eqs. 45–46).

        Parameters
        ----------
        R : array_like, real, (n, m)
            The basis, e.g. the first m POD modes.

        Returns
        -------
        U_m, F_m : numpy.ndarray, complex, (s, m, p)
            ``Rᵀ U`` and ``Rᵀ F_n``. With holes, ``U_m`` per load case is the reduced
            response that best reproduces the measured entries
            (:func:`~podid_rs.identification.holes.measured_targets`): a hole is not
            a response of zero.

        Raises
        ------
        ValueError
            When R is not a real (n, m) array.
        """
        Ra = as_array(R, "R", real=True)
        if Ra.ndim != 2 or Ra.shape[0] != self.n or Ra.shape[1] == 0:
            raise ValueError(
                f"R must have shape (n, m) with n = {self.n} measured DOFs, got {Ra.shape}"
            )
        U_m = measured_targets(self.U, Ra, self._mask())
        F_m = np.einsum("im,sip->smp", Ra[self.inputs], self.F)
        return U_m, F_m

    def predict(self, system: SecondOrderSystem, R: object) -> np.ndarray:
        """Responses of a reduced model on basis R to these data's forces (eq. 19).

        For FRF data this is the model's FRF on the measured DOFs, ``R H_m Rᵀ``.

        Parameters
        ----------
        system : SecondOrderSystem
            The reduced model, order m.
        R : array_like, real, (n, m)
            Its basis.

        Returns
        -------
        numpy.ndarray, complex, (s, n, p)
            ``R Z_m(ω)⁻¹ Rᵀ F_n`` on each line.

        Raises
        ------
        ValueError
            For a system that is not a :class:`SecondOrderSystem`, R of the wrong shape
            or order, or a singular dynamic stiffness on a line.
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

        Parameters
        ----------
        m : int, optional
            The reduced order.
        energy : float, optional
            Without ``m``, the order is the smallest capturing this energy fraction
            (eq. 43; 0.99 when neither is given).
        lam, symmetric, backend, threads
            As for :func:`podid_rs.identify`.

        Returns
        -------
        result : IdentificationResult
            The identified model.
        R : numpy.ndarray, (n, m)
            Its basis.

        Raises
        ------
        ValueError
            When both ``m`` and ``energy`` are given, or as :func:`podid_rs.identify`.
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
    ) -> tuple[IdentificationResult, np.ndarray, OrderSweep]:
        """Output-error models that reproduce these data (docs/design.md §6).

        Orders 1, 2, … are fitted by continuation on the POD basis, m is chosen on
        held-out lines (or given), and that order is refitted on every line
        (:func:`podid_rs.sweep_orders`, :func:`podid_rs.final_fit`).

        Parameters
        ----------
        m : int, optional
            The order; default chosen on held-out lines.
        m_max : int, optional
            Largest order tried (as for :func:`podid_rs.sweep_orders`).
        progress : bool
            Show the final refinement's progress on stderr.
        threads : int, optional
            Worker threads (None = all cores).

        Returns
        -------
        model : IdentificationResult
            The refined model (M, C, K positive definite, stable).
        R : numpy.ndarray, (n, m)
            Its basis.
        sweep : OrderSweep
            Every order's errors and the reason for m.

        Raises
        ------
        ValueError
            As for :func:`podid_rs.sweep_orders`.
        """
        return _fit_output_error(self, m, m_max, progress, threads)


def _fit_output_error(
    data: MeasuredData, m: int | None, m_max: int | None, progress: bool, threads: int | None
) -> tuple[IdentificationResult, np.ndarray, OrderSweep]:
    pod = data.pod()
    F_n = data.forces_on_dofs()
    holes = {} if data.complete else {"measured": data.measured}  # complete: the calls as ever
    sweep = sweep_orders(data.U, F_n, data.omega, pod, m=m, m_max=m_max, threads=threads,
                         **holes)
    model, R = final_fit(sweep, data.U, F_n, data.omega, pod, threads=threads,
                         progress=progress, **holes)
    return model, R, sweep


def from_frf(
    H: object,
    omega: object,
    *,
    inputs: object = None,
    dofs: object = None,
    quantity: str = "displacement",
    measured: object = None,
) -> MeasuredData:
    """FRFs per unit force as :class:`MeasuredData`: p = n_in unit load cases, ``F = I``.

    Parameters
    ----------
    H : array_like, complex, (s, n, n_in)
        FRFs, frequency-first.
    omega : array_like, (s,)
        Angular frequencies (rad/s).
    inputs : array_like, (n_in,), optional
        Indices of the n_in driven DOFs among the n responses (default: all, for
        square H).
    dofs : array_like, (n, 2), optional
        (node, direction) labels of the responses.
    quantity : {"displacement", "velocity", "acceleration"}
        What H measures per unit force; converted to receptance.
    measured : array_like of bool, (n, n_in), optional
        True where the FRF was measured (default: all); the others are holes.

    Returns
    -------
    MeasuredData
        U = the receptances, F = I on every line.

    Raises
    ------
    ValueError
        For malformed H, omega, inputs, dofs or measured, or an unknown quantity.
    """
    Ha = as_array(H, "H")
    if Ha.ndim != 3 or 0 in Ha.shape:
        raise ValueError(f"H must have shape (s, n_out, n_in), got {Ha.shape}")
    w = as_omega(omega)
    U = to_receptance(Ha, w, quantity)
    F = np.broadcast_to(np.eye(Ha.shape[2]), (w.size, Ha.shape[2], Ha.shape[2]))
    return MeasuredData(w, U, F, dofs, inputs, measured=measured)


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
    """Time histories of forces and responses as :class:`MeasuredData`.

    Parameters
    ----------
    forces : array_like, real, (r, n_in) or (n_rec, r, n_in)
        Force histories (several records: ``(n_rec, r, ·)``).
    responses : array_like, real, (r, n) or (n_rec, r, n)
        Response histories, with the forces' records and samples.
    dt : float
        Sampling interval (s).
    inputs : array_like, (n_in,), optional
        Indices of the forced DOFs among the responses.
    dofs : array_like, (n, 2), optional
        (node, direction) labels of the responses.
    quantity : {"displacement", "velocity", "acceleration"}
        What the responses measure; converted to displacement.
    estimator : {"h1", "spectra"}
        ``"h1"``: FRFs by the H1 estimator with Welch averaging
        (:func:`podid_rs.frf_h1`, segments of ``nperseg``), p = n_in unit load
        cases. ``"spectra"``: the real FFT of each whole record
        (:func:`podid_rs.spectra`, as in the paper), one load case per record; exact
        for periodic records, leaky otherwise.
    band_hz : tuple of float, optional
        The lines kept, (lo, hi) in Hz.
    nperseg : int, optional
        Welch segment length (``"h1"`` only).

    Returns
    -------
    MeasuredData
        The data on the lines of the band.

    Raises
    ------
    ValueError
        For malformed histories or options, or ``nperseg`` with ``"spectra"``.
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
    responses_f = [spectra(rec, dt, band_hz) for rec in y]
    omega = responses_f[0][0]
    X = np.stack([spectra(rec, dt, band_hz)[1] for rec in x], axis=-1)
    Y = np.stack([spectrum for _, spectrum in responses_f], axis=-1)
    return MeasuredData(omega, to_receptance(Y, omega, quantity), X, dofs, inputs)
