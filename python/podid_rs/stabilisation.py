"""Stabilisation chart over the POD order: the evidence for the order m of a model.

Experimentalists choose a model order from a stabilisation chart (as for LSCF
or polyreference estimators): fit models of increasing order, draw each one's
natural frequencies against the order over the summed measured FRF, and trust
the poles that stay put as the order grows; spurious (numerical, noise) poles
wander. Here the order is the number m of POD modes (paper eqs. 7, 43), and
each model is by default the paper's estimator (eq. 49) in its exactly
symmetric limit on the first m POD modes of the measured responses — or any
``fit(m) -> IdentificationResult`` (for example a refined model).

Each pole of each order is marked

* **stable** — Re λ < 0;
* **physical** (a property of the model, not the pole) — M, K symmetric
  positive definite and C symmetric positive semidefinite (:func:`is_physical`),
  which makes every pole stable;
* **consistent** with the previous order — the nearest pole of order m − 1 in
  frequency is within ``f_tol`` (default 1 %) in natural frequency
  (``consistent_f``), and also within ``zeta_tol`` (default 5 %, relative) in
  damping ratio (``consistent``): the usual LSCF tolerances.

Poles on the real axis (overdamped, not modes) are in the table but not drawn.
"""

from __future__ import annotations

import csv
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._arrays import as_count, as_scalar
from .identification.estimator import identify
from .identification.result import IdentificationResult
from .measured import MeasuredData
from .physical import ModalParameters, modal_parameters
from .pod import PODResult

#: consistency between successive orders, relative to the previous order's pole:
#: |f − f_prev| ≤ F_TOL · f_prev and |ζ − ζ_prev| ≤ ZETA_TOL · |ζ_prev|
F_TOL = 0.01
ZETA_TOL = 0.05
#: a model is physical when M, K ≻ 0, C ⪰ 0 and each is symmetric to this relative defect;
#: C's smallest eigenvalue may be this far below 0, relative to its largest magnitude
PHYSICAL_RTOL = 1e-10


def is_physical(model: IdentificationResult, rtol: float = PHYSICAL_RTOL) -> bool:
    """M and K symmetric positive definite, C symmetric positive semidefinite.

    Symmetric: ‖X − Xᵀ‖ ≤ rtol ‖X‖; definiteness from the eigenvalues of the
    symmetric parts (C's smallest may be −rtol × its largest magnitude).

    Parameters
    ----------
    model : IdentificationResult
        The model (anything with dense ``M``, ``C``, ``K``).
    rtol : float
        The relative tolerance of both tests.

    Returns
    -------
    bool
        True for a physical model (then every pole is stable).
    """
    mats = (model.M, model.C, model.K)
    if any(np.linalg.norm(X - X.T) > rtol * np.linalg.norm(X) for X in mats):
        return False
    eM, eC, eK = (np.linalg.eigvalsh(0.5 * (X + X.T)) for X in mats)
    scale_C = float(np.max(np.abs(eC))) if eC.size else 0.0
    return bool(eM.min() > 0 and eK.min() > 0 and eC.min() >= -rtol * scale_C)


@dataclass(frozen=True)
class StabilisationOrder:
    """One order of the chart: the model's modes and how each is marked.

    Attributes
    ----------
    m : int
        The order.
    model : IdentificationResult
        What ``fit(m)`` returned.
    modes : ModalParameters
        Its :func:`podid_rs.modal_parameters` (sorted by |λ|).
    physical : bool
        Whether the model is physical (:func:`is_physical`).
    consistent_f, consistent : numpy.ndarray of bool, (k,)
        Per mode: the nearest pole of order m − 1 is within ``f_tol`` in frequency;
        and also within ``zeta_tol`` in damping ratio.
    notes : tuple of str
        The warnings its fit raised.
    stable : numpy.ndarray of bool, (k,)
        Per mode: Re λ < 0.
    oscillatory : numpy.ndarray of bool, (k,)
        Per mode: a complex pole (a mode); real poles are overdamped roots.
    """

    m: int
    model: IdentificationResult
    modes: ModalParameters
    physical: bool
    consistent_f: np.ndarray
    consistent: np.ndarray
    notes: tuple[str, ...] = ()

    @property
    def stable(self) -> np.ndarray:
        """Poles strictly in the left half-plane, Re λ < 0 (an undamped one is not)."""
        return self.modes.eigenvalues.real < 0

    @property
    def oscillatory(self) -> np.ndarray:
        """Complex poles (modes); real poles are overdamped roots."""
        return self.modes.eigenvalues.imag > 0


@dataclass(frozen=True)
class StabilisationChart:
    """Models of orders ``m_min … m_max`` and the data they were fitted to.

    What :func:`stabilisation_chart` returns; :func:`podid_rs.plot_stabilisation`
    draws it.

    Attributes
    ----------
    orders : tuple of StabilisationOrder
        Each order's model and marked poles.
    freq_hz : numpy.ndarray, (s,)
        The data's lines (Hz), the plot's abscissa.
    summed_frf : numpy.ndarray, (s,)
        Σ |U| over measured DOFs and load cases — of the FRFs in receptance, or of the
        response spectra when the data are not FRFs (``is_frf``): the plot's background.
    is_frf : bool
        Whether the data are FRFs.
    f_tol, zeta_tol : float
        The consistency tolerances (relative) in frequency and damping ratio.
    chosen_m : int or None
        The order a command picked (marked on the chart).
    band_hz : tuple of float
        The data's first and last line (Hz).
    """

    orders: tuple[StabilisationOrder, ...]
    freq_hz: np.ndarray
    summed_frf: np.ndarray
    is_frf: bool
    f_tol: float
    zeta_tol: float
    chosen_m: int | None = None

    @property
    def band_hz(self) -> tuple[float, float]:
        return float(self.freq_hz[0]), float(self.freq_hz[-1])

    def order(self, m: int) -> StabilisationOrder:
        """One order of the chart.

        Parameters
        ----------
        m : int
            The order.

        Returns
        -------
        StabilisationOrder
            Its model and marked poles.

        Raises
        ------
        KeyError
            When the chart has no order m.
        """
        for o in self.orders:
            if o.m == m:
                return o
        raise KeyError(f"the chart has no order m = {m}")

    def rows(self) -> list[dict[str, object]]:
        """One row per pole: order, mode, f, ζ, λ and the marks (CSV-ready).

        Returns
        -------
        list of dict
            Keys ``m``, ``mode``, ``f_hz``, ``zeta``, ``re_lambda``, ``im_lambda``,
            ``stable``, ``physical``, ``consistent_f``, ``consistent``, ``real_pole``,
            ``in_band``, ``chosen``.
        """
        lo, hi = self.band_hz
        out: list[dict[str, object]] = []
        for o in self.orders:
            f, z = o.modes.frequencies_hz, o.modes.damping_ratios
            for k, lam in enumerate(o.modes.eigenvalues):
                out.append({
                    "m": o.m,
                    "mode": k + 1,
                    "f_hz": float(f[k]),
                    "zeta": float(z[k]),
                    "re_lambda": float(lam.real),
                    "im_lambda": float(lam.imag),
                    "stable": bool(o.stable[k]),
                    "physical": o.physical,
                    "consistent_f": bool(o.consistent_f[k]),
                    "consistent": bool(o.consistent[k]),
                    "real_pole": bool(lam.imag == 0),
                    "in_band": bool(lo <= f[k] <= hi),
                    "chosen": o.m == self.chosen_m,
                })
        return out

    def to_csv(self, path: str | Path) -> Path:
        """Write :meth:`rows` as CSV (header first line, full precision).

        Parameters
        ----------
        path : str or pathlib.Path
            The file, replaced if it exists.

        Returns
        -------
        pathlib.Path
            ``path``.
        """
        rows = self.rows()
        path = Path(path)
        with path.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]) if rows else ["m"])
            w.writeheader()
            w.writerows(rows)
        return path


def _match_previous(
    modes: ModalParameters, prev: ModalParameters | None, f_tol: float, zeta_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """(consistent_f, consistent) of each mode against the nearest previous pole in f."""
    k = modes.eigenvalues.size
    cf, c = np.zeros(k, dtype=bool), np.zeros(k, dtype=bool)
    if prev is None or prev.eigenvalues.size == 0:
        return cf, c
    fp, zp = prev.frequencies_hz, prev.damping_ratios
    for i, (f, z) in enumerate(zip(modes.frequencies_hz, modes.damping_ratios, strict=True)):
        j = int(np.argmin(np.abs(fp - f)))
        cf[i] = fp[j] > 0 and abs(f - fp[j]) <= f_tol * fp[j]
        c[i] = cf[i] and abs(z - zp[j]) <= zeta_tol * abs(zp[j])
    return cf, c


def pod_fit(
    data: MeasuredData,
    lam: float | tuple[float, float, float] | str = 0.0,
    symmetric: bool = True,
    basis: PODResult | None = None,
) -> Callable[[int], IdentificationResult]:
    """The model of order m by eq. 49 on the first m POD modes of ``data``.

    Default: the exactly symmetric limit; ``lam``/``symmetric`` as in
    :func:`podid_rs.identify`. ``basis``: ``data.pod()`` if already computed.
    """
    basis = data.pod() if basis is None else basis

    def fit(m: int) -> IdentificationResult:
        U_m, F_m = data.project(basis.basis(m))
        return identify(U_m, F_m, data.omega, lam, symmetric)

    return fit


def stabilisation_chart(
    data: MeasuredData,
    m_max: int,
    *,
    fit: Callable[[int], IdentificationResult] | None = None,
    m_min: int = 1,
    f_tol: float = F_TOL,
    zeta_tol: float = ZETA_TOL,
    chosen_m: int | None = None,
    progress: bool = True,
) -> StabilisationChart:
    """Fit models of order ``m_min … m_max`` to ``data`` and mark their poles.

    Each pole is marked stable (Re λ < 0), consistent with the nearest pole of the
    previous order in frequency (``consistent_f``) and also in damping ratio
    (``consistent``); each model physical or not (:func:`is_physical`).

    Parameters
    ----------
    data : MeasuredData
        The measurement.
    m_max : int
        The highest order, ≥ ``m_min`` (≤ n with the default ``fit``).
    fit : callable, optional
        ``fit(m)`` returns the order-m :class:`IdentificationResult`; default
        :func:`pod_fit` (the paper's estimator, eq. 49, ``symmetric=True``, on the POD
        basis of ``data``).
    m_min : int
        The lowest order, ≥ 1.
    f_tol, zeta_tol : float
        Consistency tolerances, relative (defaults 1 % and 5 %, the usual LSCF ones).
    chosen_m : int, optional
        An order to mark as chosen (only marked).
    progress : bool
        Show a tqdm bar over the orders (on a terminal).

    Returns
    -------
    StabilisationChart
        Every order's modes and marks; warnings a fit raised are in that order's
        ``notes``.

    Raises
    ------
    ValueError
        For data that are not :class:`MeasuredData`, orders or tolerances out of
        range, a ``fit`` that is not callable or returns something other than an
        order-m result, and a ``ValueError`` of a fit (its message then names the
        order).
    MemoryError
        A fit's, its message naming the order.
    """
    from ._progress import progress_bar  # tqdm, imported on first use

    if not isinstance(data, MeasuredData):
        raise ValueError(f"data must be a MeasuredData, got {type(data).__name__}")
    m_min = as_count(m_min, "m_min", 1)
    m_max = as_count(m_max, "m_max", m_min, data.n if fit is None else None)
    f_tol = as_scalar(f_tol, "f_tol")
    zeta_tol = as_scalar(zeta_tol, "zeta_tol")
    if chosen_m is not None:
        chosen_m = as_count(chosen_m, "chosen_m", 1)
    if fit is None:
        fit = pod_fit(data)
    elif not callable(fit):
        raise ValueError(f"fit must be a callable fit(m) -> IdentificationResult, got {fit!r}")
    orders: list[StabilisationOrder] = []
    prev: ModalParameters | None = None
    bar = progress_bar(m_max - m_min + 1, enabled=progress, desc="stabilisation", unit="order")
    try:
        for m in range(m_min, m_max + 1):
            bar.set_postfix_str(f"m = {m}")
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    model = fit(m)
                except (ValueError, MemoryError) as exc:
                    raise type(exc)(f"stabilisation chart, order m = {m}: {exc}") from exc
            if not isinstance(model, IdentificationResult) or model.m != m:
                raise ValueError(
                    f"fit({m}) must return an IdentificationResult of order {m}, got {model!r}"
                )
            modes = modal_parameters(model)
            cf, c = _match_previous(modes, prev, f_tol, zeta_tol)
            orders.append(StabilisationOrder(
                m, model, modes, is_physical(model), cf, c,
                tuple(str(w.message) for w in caught),
            ))
            prev = modes
            bar.update(1)
    finally:
        bar.close()
    summed = np.sum(np.abs(data.U), axis=(1, 2))
    return StabilisationChart(tuple(orders), data.freq_hz.copy(), summed, data.is_frf,
                              f_tol, zeta_tol, chosen_m)
