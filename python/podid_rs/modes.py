"""Mode shapes of an identified model on the measured DOFs, and the MAC.

An identified reduced model's modes ψ (the vectors of the pencil
``(λ²M + λC + K)ψ = 0``, paper eq. 1, from :func:`podid_rs.physical.companion_modes`)
live in POD coordinates; on the measured DOFs they are φ = R ψ (eq. 9). The
modal assurance criterion compares two sets of shapes,

    MAC(a, b) = |aᴴ b|² / ((aᴴ a)(bᴴ b)),

1 for shapes that are multiples of each other, 0 for orthogonal ones
(Allemang & Brown 1982). Shapes come from a model (:func:`mode_shapes`) or from a
UFF file's dataset 55 (:func:`podid_rs.io.uff.read_uff_modes`);
:func:`podid_rs.plotting.plot_mac` draws the MAC.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ._arrays import as_array, as_basis, as_dof_labels
from .identification.result import IdentificationResult
from .physical import companion_modes
from .systems import SecondOrderSystem

#: a model counts as symmetric (and gets its modal A) when ‖X − Xᵀ‖ ≤ this × ‖X‖
SYMMETRY_RTOL = 1e-12


@dataclass(frozen=True)
class ModeShapes:
    """Modes with their shapes on labelled DOFs.

    Made by :func:`mode_shapes` (from a model) and :func:`podid_rs.read_uff_modes`
    (from a file).

    Attributes
    ----------
    eigenvalues : numpy.ndarray, complex, (k,)
        One per mode (``Im λ ≥ 0``, sorted by ``|λ|``, as :func:`podid_rs.modal_parameters`).
    shapes : numpy.ndarray, complex, (n, k)
        Column j is mode j's shape, scaled so that its largest entry is 1.
    dofs : numpy.ndarray of int64, (n, 2), or None
        The (node, direction) labels of the rows.
    modal_a : numpy.ndarray, complex, (k,), or None
        ``ψᵀ(2λM + C)ψ`` for the scaled shapes of a symmetric model, so that the
        receptance is ``Σ_j φ_j φ_jᵀ / (a_j (iω − λ_j))`` (plus the conjugate of
        every complex mode); None when the model is not symmetric or the shapes were
        read from a file without it.
    numbers : numpy.ndarray, (k,), or None
        The modes' numbers (1-based, as in the modal table or the file), kept when
        modes are selected; None means 1 … k.
    mode_numbers : numpy.ndarray, (k,)
        ``numbers``, or 1 … k.
    frequencies_hz : numpy.ndarray, (k,)
        Undamped natural frequencies ``|λ| / 2π``.
    damping_ratios : numpy.ndarray, (k,)
        ``−Re λ / |λ|`` (0 for λ = 0).
    n_modes : int
        k.
    """

    eigenvalues: np.ndarray
    shapes: np.ndarray
    dofs: np.ndarray | None = None
    modal_a: np.ndarray | None = None
    numbers: np.ndarray | None = None

    @property
    def mode_numbers(self) -> np.ndarray:
        """1-based mode numbers (``numbers``, or 1 … k)."""
        if self.numbers is None:
            return np.arange(1, self.n_modes + 1)
        return np.asarray(self.numbers)

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Undamped natural frequencies ``|λ| / 2π``."""
        return np.abs(self.eigenvalues) / (2 * np.pi)

    @property
    def damping_ratios(self) -> np.ndarray:
        """``−Re λ / |λ|`` (0 for λ = 0)."""
        mag = np.abs(self.eigenvalues)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(mag > 0, -self.eigenvalues.real / mag, 0.0)

    @property
    def n_modes(self) -> int:
        return self.eigenvalues.size

    def in_band(self, band_hz: tuple[float, float]) -> ModeShapes:
        """The modes with natural frequency in a band.

        Parameters
        ----------
        band_hz : tuple of float
            (lo, hi) in Hz, ends included.

        Returns
        -------
        ModeShapes
            Those modes, numbers kept.
        """
        f = self.frequencies_hz
        return self.select((f >= band_hz[0]) & (f <= band_hz[1]))

    def oscillatory(self) -> ModeShapes:
        """The complex modes (``Im λ > 0``), without the real (overdamped) roots.

        Returns
        -------
        ModeShapes
            Those modes, numbers kept.
        """
        return self.select(self.eigenvalues.imag > 0)

    def select(self, keep: np.ndarray) -> ModeShapes:
        """The modes where a mask is true.

        Parameters
        ----------
        keep : numpy.ndarray of bool, (k,)
            Which modes to keep.

        Returns
        -------
        ModeShapes
            Those modes, numbers kept.
        """
        return replace(
            self,
            eigenvalues=self.eigenvalues[keep],
            shapes=self.shapes[:, keep],
            modal_a=None if self.modal_a is None else self.modal_a[keep],
            numbers=self.mode_numbers[keep],
        )


def _is_symmetric(M: np.ndarray, C: np.ndarray, K: np.ndarray) -> bool:
    return all(np.linalg.norm(X - X.T) <= SYMMETRY_RTOL * np.linalg.norm(X) for X in (M, C, K))


def mode_shapes(
    model: IdentificationResult | SecondOrderSystem,
    basis: object = None,
    dofs: object = None,
) -> ModeShapes:
    """The model's modes with shapes φ = R ψ on the measured DOFs (eq. 9).

    ψ are the vectors of the pencil ``(λ²M + λC + K)ψ = 0`` (eq. 1), from
    :func:`podid_rs.physical.companion_modes`.

    Parameters
    ----------
    model : IdentificationResult or SecondOrderSystem
        The model, order m.
    basis : array_like, (n, m), optional
        R; None gives the shapes in the model's own coordinates.
    dofs : array_like, (n, 2), optional
        (node, direction) labels of the rows, for UFF output and for matching
        against reference shapes.

    Returns
    -------
    ModeShapes
        The modes, shapes scaled to largest entry 1.

    Raises
    ------
    ValueError
        For a basis or labels of the wrong shape, or a mode with no component on
        the measured DOFs.
    """
    lam, psi, _ = companion_modes(model, vectors=True)
    m = psi.shape[0]
    R = as_basis(basis, m)
    phi = R @ psi
    top = phi[np.argmax(np.abs(phi), axis=0), np.arange(phi.shape[1])]
    if np.any(top == 0):
        raise ValueError("a mode has no component on the measured DOFs (R ψ = 0)")
    phi = phi / top
    psi = psi / top
    M, C = model.M, model.C
    modal_a = None
    if _is_symmetric(M, C, model.K):
        # zᵀ [[C, M], [M, 0]] z for z = [ψ; λψ]: the first-order form's modal A
        modal_a = lam * np.einsum("ik,ij,jk->k", psi, 2 * M, psi) + np.einsum(
            "ik,ij,jk->k", psi, C, psi
        )
    labels = None if dofs is None else as_dof_labels(dofs, phi.shape[0])
    return ModeShapes(lam, phi, labels, modal_a)


def mac(A: object, B: object) -> np.ndarray:
    """Modal assurance criterion ``|aᴴb|² / ((aᴴa)(bᴴb))`` of every column pair.

    1 for shapes that are multiples of each other, 0 for orthogonal ones (Allemang
    & Brown 1982).

    Parameters
    ----------
    A : array_like, (n, ka) or (n,)
        Shapes as columns, real or complex.
    B : array_like, (n, kb) or (n,)
        Shapes on the same rows (DOFs).

    Returns
    -------
    numpy.ndarray, (ka, kb)
        MAC values in [0, 1].

    Raises
    ------
    ValueError
        For empty arrays, different numbers of rows, or a zero column.
    """
    a, b = as_array(A, "A"), as_array(B, "B")
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    if a.ndim != 2 or b.ndim != 2 or 0 in a.shape or 0 in b.shape:
        raise ValueError(f"A and B must be non-empty (n, k) arrays, got {a.shape} and {b.shape}")
    if a.shape[0] != b.shape[0]:
        raise ValueError(
            f"A and B must have the same number of rows (DOFs), got {a.shape[0]} and {b.shape[0]}"
        )
    na, nb = np.linalg.norm(a, axis=0), np.linalg.norm(b, axis=0)
    for name, norms in (("A", na), ("B", nb)):
        if np.any(norms == 0):
            raise ValueError(f"{name} column {int(np.argmin(norms))} is zero: it has no MAC")
    cross = np.abs((a / na).conj().T @ (b / nb)) ** 2
    return np.minimum(cross, 1.0)


def shape_mac(a: ModeShapes, b: ModeShapes) -> tuple[np.ndarray, np.ndarray | None]:
    """MAC of the shapes of ``a`` (rows) against ``b`` (columns) on their common DOFs.

    With labels on both, the DOFs both sets have are used, in ``a``'s order; without,
    the rows must correspond.

    Parameters
    ----------
    a, b : ModeShapes
        The two sets of modes.

    Returns
    -------
    values : numpy.ndarray, (ka, kb)
        The MAC.
    dofs : numpy.ndarray, (k, 2), or None
        The labels of the DOFs used (None without labels).

    Raises
    ------
    ValueError
        For arguments that are not :class:`ModeShapes`, a set without modes, fewer
        than 2 common DOFs, or rows that differ (without labels).
    """
    if not isinstance(a, ModeShapes) or not isinstance(b, ModeShapes):
        raise ValueError("shape_mac compares two ModeShapes (see podid_rs.mode_shapes)")
    if a.n_modes == 0 or b.n_modes == 0:
        raise ValueError(f"nothing to compare: {a.n_modes} and {b.n_modes} modes")
    if a.dofs is None or b.dofs is None:
        return mac(a.shapes, b.shapes), None
    where = {tuple(d): i for i, d in enumerate(b.dofs.tolist())}
    rows = [(i, where[tuple(d)]) for i, d in enumerate(a.dofs.tolist()) if tuple(d) in where]
    if len(rows) < 2:
        raise ValueError(
            f"the two sets of shapes share {len(rows)} (node, direction) DOF(s); the MAC needs "
            "at least 2 (check the node numbering and directions)"
        )
    ia, ib = (np.asarray(x) for x in zip(*rows, strict=True))
    return mac(a.shapes[ia], b.shapes[ib]), a.dofs[ia]


#: kinds of pole in a fitted model, as :func:`mode_kinds` names them
STRUCTURAL, WEAK, RESIDUAL = "structural", "weak", "residual"
#: a pole with at least this damping ratio is a residual term: its half-power band,
#: 2ζ·f, spans 40 % of its frequency — no resonance a test resolves
RESIDUAL_ZETA = 0.2
#: an in-band, lightly damped pole whose term reaches this fraction of the largest
#: measured response within VISIBLE_WINDOW (relative) of its frequency at fewer than two
#: of its three nearest lines is a weak term of the fit
VISIBLE_FRACTION = 0.1
VISIBLE_WINDOW = 0.02
#: a resonance of the data rises above its surroundings: the largest measured |U| within
#: the pole's half-power band (or at its nearest line) is at least PEAK_RISE times the
#: median |U| over one side of the ring from PEAK_RING[0] to PEAK_RING[1] half-power bands
#: away (at least 2 and 6 lines; the lower side), at some measured entry
PEAK_RISE = 2.0
PEAK_RING = (3.0, 10.0)


def mode_kinds(
    shapes: ModeShapes,
    omega: object,
    U: object = None,
    inputs: object = None,
    *,
    residual_zeta: float = RESIDUAL_ZETA,
    visible_fraction: float = VISIBLE_FRACTION,
    measured: object = None,
) -> np.ndarray:
    """Tell the structure's modes from the fit's other poles.

    A fitted model's poles are not all modes of the structure: an output-error fit
    (and a modal-fit tool alike) also places poles that shape the response — below or
    above the band (residual terms, the role of LSFD's lower and upper residuals),
    overdamped, or in band but too weak to be seen. Each pole of ``shapes`` gets a
    kind:

    * ``"residual"`` — a real (overdamped) pole, one whose half-power band
      Im λ ± |Re λ| is not inside the band of ``omega`` (a pole out of the band, or at
      its edge, where the data show one flank of it), or one with damping ratio ≥
      ``residual_zeta``;
    * ``"weak"`` — in band and lightly damped, but not a resonance of the data: its
      receptance term φ_i φ_d / (a (iω − λ)) (:attr:`ModeShapes.modal_a`) reaches
      ``visible_fraction`` of the largest measured |U| within ±``VISIBLE_WINDOW`` (2 %)
      of its damped frequency Im λ, at some measured DOF i and input d, at fewer than
      two of the three measured lines nearest Im λ — e.g. a pole the fit puts beside an
      anti-resonance to shape the dip, or a nearly undamped one on a single line to fit
      that line (judged only with measured FRFs ``U`` and a symmetric model's
      ``modal_a``);
      or one where the measured data have no peak: their largest |U| within its
      half-power band is under ``PEAK_RISE`` times their median over the ring from 3 to
      10 half-power bands away at every measured entry (the fit's peak, not the data's);
    * ``"structural"`` — every other pole: a resonance of the measured data.

    Parameters
    ----------
    shapes : ModeShapes
        The model's modes on the measured DOFs (:func:`mode_shapes` of a symmetric
        model, so that ``modal_a`` is known).
    omega : array_like, (s,)
        The measured lines (rad/s), strictly increasing; their range is the band.
    U : array_like, complex, (s, n, p), optional
        The measured receptances for unit forces at ``inputs`` (FRF data).
    inputs : array_like of int, (p,), optional
        The driven DOF of each load case, as rows of ``shapes.shapes`` (with ``U``).
    residual_zeta, visible_fraction : float
        The thresholds above (defaults ``RESIDUAL_ZETA``, ``VISIBLE_FRACTION``).
    measured : array_like of bool, (n, p), optional
        With ``U``: the entries that were measured (default all); a mode is visible
        only at those (:attr:`podid_rs.MeasuredData.measured`).

    Returns
    -------
    numpy.ndarray of str, (k,)
        ``"structural"``, ``"weak"`` or ``"residual"`` per mode, in ``shapes``' order.

    Raises
    ------
    ValueError
        For lines that are not strictly increasing, ``U`` without ``inputs``, inputs
        outside the shapes' rows, or arrays whose shapes do not match (``U`` against the
        lines, the shapes' rows and the inputs; ``measured`` against ``U``'s (n, p)).
    """
    w = as_array(omega, "omega", real=True).reshape(-1)
    if w.size < 2 or np.any(np.diff(w) <= 0):  # the band is from the first line to the last
        raise ValueError("omega must hold at least 2 strictly increasing lines (rad/s)")
    lam = shapes.eigenvalues
    kinds = np.full(lam.size, STRUCTURAL, dtype=object)
    # its half-power band must lie in the band: a peak at an edge shows one flank only
    out_of_band = (lam.imag - np.abs(lam.real) < w[0]) | (lam.imag + np.abs(lam.real) > w[-1])
    kinds[(lam.imag == 0) | out_of_band | (shapes.damping_ratios >= residual_zeta)] = RESIDUAL
    if U is None or shapes.modal_a is None:
        return kinds.astype(str)
    if inputs is None:
        raise ValueError("U needs inputs: the driven DOF of each load case")
    Ua = as_array(U, "U")
    idx = np.asarray(inputs, dtype=np.int64).reshape(-1)
    if Ua.ndim != 3 or Ua.shape[0] != w.size or Ua.shape[1] != shapes.shapes.shape[0] or \
            Ua.shape[2] != idx.size:
        raise ValueError(
            f"U must be (s, n, p) = ({w.size}, {shapes.shapes.shape[0]}, {idx.size}), "
            f"got {Ua.shape}"
        )
    if np.any((idx < 0) | (idx >= Ua.shape[1])):  # a negative one would count from the end
        raise ValueError(
            f"inputs must index the {Ua.shape[1]} rows of the shapes (0 … {Ua.shape[1] - 1}), "
            f"got {idx.tolist()}"
        )
    measured_entries = (np.ones(Ua.shape[1:], dtype=bool) if measured is None
                        else np.asarray(measured))
    if measured_entries.shape != Ua.shape[1:]:  # a transposed mask would broadcast
        raise ValueError(
            f"measured must be (n, p) = {Ua.shape[1:]}, got {measured_entries.shape}"
        )
    for k in np.flatnonzero(kinds == STRUCTURAL):
        lines = np.argsort(np.abs(w - lam[k].imag), kind="stable")[:3]
        residue = np.abs(np.outer(shapes.shapes[:, k], shapes.shapes[idx, k]))
        # against the largest response around the pole, not the one at a line: a pole
        # beside an anti-resonance is large next to the dip and small next to the data
        near = np.abs(w - lam[k].imag) <= VISIBLE_WINDOW * lam[k].imag
        near[lines] = True
        level = visible_fraction * np.abs(Ua[near]).max(axis=0)
        seen = [np.any((residue / abs(shapes.modal_a[k] * (1j * w[j] - lam[k])) >= level)
                       & measured_entries) for j in lines]
        if sum(seen) < 2:  # a resonance shows at more than one line; a spike on a line not
            kinds[k] = WEAK
        elif not _data_peak(w, Ua, measured_entries, lam[k]):
            kinds[k] = WEAK  # the model has a peak there; the data have none
    return kinds.astype(str)


def _data_peak(w: np.ndarray, Ua: np.ndarray, measured: np.ndarray, lam: complex) -> bool:
    """The measured |U| rises to a peak at the pole ``lam``: within its half-power band
    (or at its nearest line) at least ``PEAK_RISE`` times its median over the ring
    ``PEAK_RING`` half-power bands away, at some measured entry. A pole the fit needs
    to shape the data between resonances (two nearly cancelling terms, or one fitting
    noise) has a peak in its own term, not in the data."""
    half = abs(lam.real)  # half the half-power band, rad/s
    distance = np.abs(w - lam.imag)
    spacing = float(np.median(np.diff(w))) if w.size > 1 else 0.0
    inner = distance <= half
    inner[int(np.argmin(distance))] = True
    ring = (distance >= max(PEAK_RING[0] * 2 * half, 2 * spacing)) & \
        (distance <= max(PEAK_RING[1] * 2 * half, 6 * spacing))
    sides = [side for side in (ring & (w < lam.imag), ring & (w > lam.imag)) if side.any()]
    if not sides:
        return True  # nothing around it to compare with: no evidence against
    peak = np.abs(Ua[inner]).max(axis=0)
    # the lower side: a resonance beside a stronger one still rises above its other side
    around = np.min([np.median(np.abs(Ua[side]), axis=0) for side in sides], axis=0)
    return bool(np.any((peak >= PEAK_RISE * around) & measured))
