"""What ``podid-rs identify`` writes for the user's next step, beside ``model.npz``.

:func:`write_identify_outputs` adds to the output folder of
:func:`podid_rs.workflow.run_identify`:

* ``model.uff`` — the model for modal and FE-correlation software
  (:func:`podid_rs.uff.write_uff`): the input's geometry (dataset 15) when it had
  one, the identified modes on the measured DOFs (55, one per row of
  ``modes.csv``) and the identified FRFs (58) in the input's ordinate;
* ``stabilisation.png`` / ``stabilisation.csv`` — the stabilisation chart over
  the POD order (:mod:`podid_rs.stabilisation`), fitted as the command fits
  (λ or exactly symmetric, made physical with ``--physical``), orders 1 …
  :func:`stabilisation_orders`, the chosen order marked;
* ``mac.png`` — the MAC between the in-band complex modes of the chosen order m
  and of order m + 1 (m − 1 at full order): shapes that persist are not artefacts
  of the order (not written when either order has no mode in the band).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from .identification import IdentificationResult
from .measurements import MeasuredData
from .modes import mode_shapes, plot_mac
from .physical import make_physical
from .pod import PODResult
from .stabilisation import plot_stabilisation, pod_fit, stabilisation_chart
from .uff import read_uff_geometry, uff_quantity, write_uff

#: the chart runs to order max(STABILISATION_ORDERS, m + 5), at most n
STABILISATION_ORDERS = 30


def stabilisation_orders(m: int, n: int) -> int:
    """Highest order charted for a chosen order m on n measured DOFs."""
    return min(n, max(STABILISATION_ORDERS, m + 5))


def source_ordinate(path: Path) -> str:
    """The ordinate the test measured: a UFF's FRF numerator type, an ``.npz``'s
    ``quantity`` array; displacement when neither says."""
    if path.suffix.lower() in (".uff", ".unv", ".uf"):
        return uff_quantity(path) or "displacement"
    if path.suffix.lower() == ".npz":
        with np.load(path, allow_pickle=False) as z:
            if "quantity" in z.files:
                return str(z["quantity"].item())
    return "displacement"


def source_geometry(path: Path) -> np.ndarray | None:
    """Node coordinates of a UFF input (dataset 15 or 2411), else None."""
    if path.suffix.lower() in (".uff", ".unv", ".uf"):
        return read_uff_geometry(path)
    return None


def command_fit(
    data: MeasuredData,
    lam: float | tuple[float, float, float] | str | None,
    physical: bool,
    basis: PODResult,
) -> Callable[[int], IdentificationResult]:
    """fit(m) as ``run_identify`` fits: eq. 49 on the POD ``basis`` of ``data``, λ or
    exactly symmetric (``lam=None``), made physical when asked."""
    plain = pod_fit(data, 0.0 if lam is None else lam, lam is None, basis)
    if not physical:
        return plain

    def fit(m: int) -> IdentificationResult:
        return make_physical(plain(m), *data.project(basis.basis(m)), data.omega)

    return fit


def write_identify_outputs(
    source: Path,
    data: MeasuredData,
    result: IdentificationResult,
    basis: np.ndarray,
    out: Path,
    *,
    band_hz: tuple[float, float],
    lam: float | tuple[float, float, float] | str | None = None,
    physical: bool = False,
    progress: bool = True,
    pod: PODResult | None = None,
    fit: Callable[[int], IdentificationResult] | None = None,
    max_order: int | None = None,
) -> list[Path]:
    """Write ``model.uff``, ``stabilisation.png``/``.csv`` and ``mac.png`` to ``out``.

    The chart fits orders 1 … ``max_order`` (default :func:`stabilisation_orders`)
    with ``fit`` (default: as the command's paper estimator, :func:`command_fit`).
    """
    quantity = source_ordinate(source)
    files = [
        write_uff(out / "model.uff", result, basis, data, quantity=quantity,
                  geometry=source_geometry(source), name=source.name)
    ]
    m = result.m
    pod = data.pod() if pod is None else pod
    top = stabilisation_orders(m, data.n) if max_order is None else max_order
    chart = stabilisation_chart(
        data, top, fit=command_fit(data, lam, physical, pod) if fit is None else fit,
        chosen_m=m, progress=progress,
    )
    files.append(chart.to_csv(out / "stabilisation.csv"))
    files.append(plot_stabilisation(
        chart, out / "stabilisation.png", quantity=quantity,
        title=f"Stabilisation chart over the POD order: {source.name}, "
        f"{band_hz[0]:g}–{band_hz[1]:g} Hz",
    ))
    other = m + 1 if m < top else m - 1
    lo, hi = float(data.freq_hz[0]), float(data.freq_hz[-1])
    if other >= 1:
        shapes = mode_shapes(result, basis, data.dofs).in_band((lo, hi)).oscillatory()
        neighbour = mode_shapes(
            chart.order(other).model, pod.basis(other), data.dofs
        ).in_band((lo, hi)).oscillatory()
        if shapes.n_modes and neighbour.n_modes:
            files.append(plot_mac(
                shapes, neighbour, out / "mac.png", names=(f"m = {m}", f"m = {other}"),
                title=f"MAC of the identified mode shapes in {lo:g}–{hi:g} Hz, "
                f"m = {m} vs m = {other}",
            ))
    return files
