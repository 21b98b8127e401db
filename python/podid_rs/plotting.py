"""Every figure of the package, written as PNG files.

- the paper's Figs. 2–19 (Section 6): :func:`plot_full_frf`,
  :func:`plot_pod_eigenvalues`, :func:`plot_frf_comparison`;
- the choice of λ (§4.2): :func:`plot_lambda_curve`;
- the order on measured data: :func:`plot_order_sweep`, :func:`plot_stabilisation`;
- mode shapes: :func:`plot_mac`.

Every function builds a :class:`matplotlib.figure.Figure` directly (no
``pyplot``), renders it with the Agg canvas and saves it, so importing or
calling this module never changes the user's interactive backend or global
figure state; matplotlib itself is imported on the first figure. FRF panels
follow the paper: magnitude on a log axis against frequency in Hz, (a) the
driving point, (b) the cross entry. The data modules import nothing from here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .identification.order import OrderSweep
from .identification.regularisation import LambdaCurve
from .io.uff import read_uff_modes
from .modes import ModeShapes, shape_mac
from .stabilisation import StabilisationChart

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: Line styles by the role a curve plays in a comparison.
STYLES: dict[str, dict] = {
    "original": {"color": "black", "lw": 1.6, "ls": "-", "zorder": 2},
    "projected": {"color": "tab:blue", "lw": 1.3, "ls": "--", "zorder": 3},
    "identified": {"color": "tab:red", "lw": 1.3, "ls": "-", "zorder": 4, "alpha": 0.9},
    "refined": {"color": "tab:green", "lw": 1.4, "ls": "--", "zorder": 5},
}
_BAND_COLORS = ("tab:orange", "tab:green", "tab:purple", "tab:cyan")
_DPI = 110
_LN10 = math.log(10.0)
#: MAC values are written in the cells of a figure up to this many cells
ANNOTATE_MAX_CELLS = 400
#: frequency bins of :func:`display_lines`: about twice the pixel columns of an FRF panel
DISPLAY_BINS = 1024


@dataclass(frozen=True)
class Curve:
    """One FRF line of a comparison: ``values`` ``(s, 2)`` complex, one column per entry.

    ``kind`` picks the style (a key of :data:`STYLES`); ``style`` overrides it. ``band``
    ``(s, 2, 2)`` — the lower and upper |H| of each entry per line (a confidence band,
    :meth:`podid_rs.ModelUncertainty.frf`), labelled ``band_label`` — is shaded in the
    curve's colour.
    """

    label: str
    values: np.ndarray
    kind: str = "original"
    style: Mapping = field(default_factory=dict)
    band: np.ndarray | None = None
    band_label: str = ""


def _entry_name(entry: tuple[int | str, int | str]) -> str:
    return f"H({entry[0]},{entry[1]})"


def _panel_title(i: int, entry: tuple[int, int]) -> str:
    kind = "driving-point FRF" if entry[0] == entry[1] else "cross-FRF"
    return f"({'ab'[i] if i < 2 else i}) {kind} {_entry_name(entry)}"


def _new_figure(width: float, height: float, ncols: int, nrows: int = 1,
                legend_rows: int = 0):
    """A figure with a grid of axes and fixed margins.

    Fixed margins instead of constrained layout: the layout engine measured
    ~0.3 s per figure here, most of the time of a ``--quick`` run.
    ``legend_rows`` reserves space under the axes for a figure legend.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=_DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False)
    bottom = (0.55 + 0.25 * legend_rows) / height
    # room for log-axis tick labels such as 6×10⁻⁶ and the y label beside them
    fig.subplots_adjust(left=1.05 / width, right=1 - 0.15 / width, top=1 - 0.6 / height,
                        bottom=bottom, wspace=1.15 / (width / ncols - 1.15), hspace=0.45)
    return fig, axes


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=_DPI)
    return path


def _legend_below(fig: Figure, ax, ncols: int) -> None:
    """One legend for the whole figure, under the panels, so that it hides no curve."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", bbox_to_anchor=(0.5, 0.0), ncols=ncols,
               fontsize=9, frameon=False)


def _frf_axis(ax, entry: tuple[int, int], i: int) -> None:
    ax.set_yscale("log")
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel(f"|{_entry_name(entry)}(ω)| (m/N)")
    ax.set_title(_panel_title(i, entry), fontsize=10)
    ax.grid(True, which="major", alpha=0.35)
    ax.grid(True, which="minor", alpha=0.12)


def plot_full_frf(
    freq_hz: np.ndarray,
    H: np.ndarray,
    bands_hz: Sequence[tuple[float, float]],
    path: str | Path,
    *,
    n: int,
    entries: Sequence[tuple[int, int]] = ((50, 50), (60, 40)),
) -> Path:
    """The full model's FRFs with the frequency bands shaded (paper Fig. 2).

    ``H`` is ``(s, 2)`` complex on ``freq_hz`` ``(s,)``; ``entries`` are the
    1-based (row, column) of its two columns.
    """
    fig, axes = _new_figure(11.0, 4.6, 2, legend_rows=1)
    for i, (ax, entry) in enumerate(zip(axes[0], entries, strict=True)):
        ax.plot(freq_hz, np.abs(H[:, i]), label=f"original FRF, n = {n}", **STYLES["original"])
        for b, (lo, hi) in enumerate(bands_hz):
            color = _BAND_COLORS[b % len(_BAND_COLORS)]
            ax.axvspan(lo, hi, color=color, alpha=0.12, lw=0)
            # bands may overlap (1 and 2 do): a labelled bar per band, staggered in height
            y = 0.96 - 0.05 * (b % 2)
            ax.plot([lo, hi], [y, y], color=color, lw=4, solid_capstyle="butt",
                    transform=ax.get_xaxis_transform(), label=f"band {b + 1}: {lo:g}–{hi:g} Hz")
            ax.text(hi, y, f" {b + 1}", transform=ax.get_xaxis_transform(), va="center",
                    fontsize=8, color=color, fontweight="bold")
        _frf_axis(ax, entry, i)
        ax.set_xlim(freq_hz[0], freq_hz[-1])
        lo_y, hi_y = ax.get_ylim()
        ax.set_ylim(lo_y, hi_y * 5)  # headroom for the band bars
    _legend_below(fig, axes[0, 0], ncols=5)
    fig.suptitle(f"Fig. 2 — FRFs of the {n}-DOF chain and the four frequency bands")
    return _save(fig, path)


def plot_pod_eigenvalues(
    eigenvalues: Sequence[Mapping[str, np.ndarray]],
    bands_hz: Sequence[tuple[float, float]],
    orders: Sequence[int],
    path: str | Path,
    *,
    n_show: int = 30,
) -> Path:
    """Normalised POD eigenvalues λ_i/λ_max for each band (paper Fig. 3).

    ``eigenvalues[b]`` maps a label (e.g. "noise-free", "SNR 10 dB") to the
    descending eigenvalues of band b; the first label is drawn most prominently.
    ``orders[b]`` is the retained m, marked by a vertical line.
    """
    nb = len(bands_hz)
    ncols = 2 if nb > 1 else 1
    nrows = -(-nb // ncols)
    fig, axes = _new_figure(10.0, 3.4 * nrows, ncols, nrows)
    markers = ("o", "s", "^", "v", "D")
    for b, ax in enumerate(axes.flat):
        if b >= nb:
            ax.set_visible(False)
            continue
        for j, (label, lam) in enumerate(eigenvalues[b].items()):
            lam = np.asarray(lam, dtype=float)
            k = min(n_show, lam.size)
            ax.semilogy(np.arange(1, k + 1), lam[:k] / lam[0], marker=markers[j % 5],
                        ms=5 if j == 0 else 3.5, lw=1.2 if j == 0 else 0.8,
                        alpha=1.0 if j == 0 else 0.75, label=label)
        ax.axvline(orders[b] + 0.5, color="grey", ls=":", lw=1.2)
        ax.text(orders[b] + 0.8, 0.04, f"m = {orders[b]}", transform=ax.get_xaxis_transform(),
                fontsize=9, color="dimgrey")
        lo, hi = bands_hz[b]
        ax.set_title(f"band {b + 1}: {lo:g}–{hi:g} Hz", fontsize=10)
        ax.set_xlabel("POD mode index $i$")
        ax.set_ylabel(r"$\lambda_i\,/\,\lambda_{\max}$")
        ax.set_xlim(0.3, n_show + 0.7)
        ax.grid(True, which="major", alpha=0.35)
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle("Fig. 3 — normalised eigenvalues of the response correlation matrix")
    return _save(fig, path)


def display_lines(freq_hz: np.ndarray, magnitudes: Sequence[np.ndarray],
                  bins: int = DISPLAY_BINS) -> np.ndarray:
    """The lines that draw FRF curves as all of them would at a figure's resolution.

    The frequency axis is cut into ``bins`` bins of equal width; in each, the first and
    last line and, for every curve, its lowest and highest line are kept (the M4
    aggregation of a time-series chart): a line drawn through them covers, in every
    bin, the same span as the line through every point, so a resonance one line wide
    keeps its height. A 46 750-line test keeps a few thousand lines, and what is
    evaluated per line for the figure (a confidence band) costs that much less.

    Parameters
    ----------
    freq_hz : numpy.ndarray, (s,)
        The lines, increasing.
    magnitudes : sequence of numpy.ndarray, each (s,) or (s, k)
        The curves to be drawn (NaN where a curve has no value).
    bins : int
        Number of bins; every line is kept when there are at most ``4 * bins``.

    Returns
    -------
    numpy.ndarray of int
        Increasing indices of the lines to draw.
    """
    s = freq_hz.size
    if s <= 4 * bins:
        return np.arange(s)
    span = max(float(freq_hz[-1] - freq_hz[0]), np.finfo(float).tiny)
    ids = np.minimum(((freq_hz - freq_hz[0]) / span * bins).astype(np.intp), bins - 1)
    starts = np.flatnonzero(np.diff(ids)) + 1
    keep = [np.array([0, s - 1]), starts, starts - 1]
    group_first = np.concatenate(([0], starts))  # each bin's first position in a sorted order
    group_last = np.concatenate((starts - 1, [s - 1]))
    for mags in magnitudes:
        columns = np.asarray(mags, dtype=float).reshape(s, -1)
        for v in columns.T:
            lowest = np.lexsort((np.where(np.isnan(v), np.inf, v), ids))
            highest = np.lexsort((np.where(np.isnan(v), -np.inf, v), ids))
            keep += [lowest[group_first], highest[group_last]]
    return np.unique(np.concatenate(keep))


def plot_frf_comparison(
    freq_hz: np.ndarray,
    curves: Sequence[Curve],
    path: str | Path,
    *,
    title: str,
    band_hz: tuple[float, float] | None = None,
    entries: Sequence[tuple[int | str, int | str]] = ((50, 50), (60, 40)),
) -> Path:
    """Two FRF panels (driving point, cross) comparing several models (paper Figs. 4–19).

    ``entries`` name the two FRF entries (1-based indices, or DOF names such as "3Z").

    Each :class:`Curve` holds both entries; the measured band is shaded when
    ``band_hz`` is given, so in-band and out-of-band behaviour read apart.
    """
    # legend entries: the curves and the band; at most three side by side
    n_items = len(curves) + (band_hz is not None) + sum(
        c.band is not None and bool(c.band_label) for c in curves)
    ncols = min(n_items, 3)
    legend_rows = -(-n_items // ncols)
    fig, axes = _new_figure(11.0, 4.35 + 0.25 * legend_rows, 2, legend_rows=legend_rows)
    for i, (ax, entry) in enumerate(zip(axes[0], entries, strict=True)):
        for c in curves:
            style = {**STYLES.get(c.kind, {}), **c.style}
            line = ax.plot(freq_hz, np.abs(c.values[:, i]), label=c.label, **style)[0]
            if c.band is not None:
                ax.fill_between(freq_hz, c.band[:, i, 0], c.band[:, i, 1], lw=0, alpha=0.25,
                                color=line.get_color(), zorder=line.get_zorder() - 0.5,
                                label=c.band_label or None)
        if band_hz is not None:
            ax.axvspan(*band_hz, color="gold", alpha=0.15, lw=0, zorder=0,
                       label=f"measured band {band_hz[0]:g}–{band_hz[1]:g} Hz")
        _frf_axis(ax, entry, i)
        ax.set_xlim(freq_hz[0], freq_hz[-1])
    _legend_below(fig, axes[0, 0], ncols=ncols)
    fig.suptitle(title)
    return _save(fig, path)


# --------------------------------------------------------------------------- λ


def _narrow_log_axis(axis, values: np.ndarray) -> None:
    """Plain, uncrowded ticks on a log axis whose data span less than a decade."""
    from matplotlib import ticker

    v = values[np.isfinite(values) & (values > 0)]
    if v.size and v.max() < 10 * v.min():
        axis.set_major_locator(ticker.MaxNLocator(4))
        axis.set_minor_locator(ticker.NullLocator())
        axis.set_major_formatter(ticker.FuncFormatter(lambda x, _: f"{x:.5g}"))


def plot_lambda_curve(
    curve: LambdaCurve, path: str | Path | None = None, *, title: str | None = None
) -> Figure:
    """The L-curve with the chosen corner, GCV against λ, and both norms against λ (§4.2).

    Parameters
    ----------
    curve : LambdaCurve
        What :func:`podid_rs.lambda_curve` returned.
    path : str or pathlib.Path, optional
        Write the figure there (PNG, 150 dpi).
    title : str, optional
        A title over the three panels.

    Returns
    -------
    matplotlib.figure.Figure
        The figure (Agg canvas, no pyplot state).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax_l, ax_g, ax_n = fig.subplots(1, 3)
    marks = {"lcurve": ("o", "C3"), "gcv": ("s", "C2"), "discrepancy": ("D", "C4")}
    names = {"lcurve": "L-curve corner", "gcv": "GCV minimum", "discrepancy": "discrepancy"}
    ln = np.log(curve.lams)
    log_res, log_pen = np.log(curve.residual_norms), np.log(curve.penalty_norms)

    def on_curve(lam: float) -> tuple[float, float]:
        """The point of the L-curve at λ, by interpolation in ln λ."""
        t = math.log(lam)
        return float(np.exp(np.interp(t, ln, log_res))), float(np.exp(np.interp(t, ln, log_pen)))

    ax_l.loglog(curve.residual_norms, curve.penalty_norms, ".-", color="C0", lw=1, ms=4)
    for k in range(math.ceil(ln[0] / _LN10), math.floor(ln[-1] / _LN10) + 1):
        ax_l.annotate(
            f"$10^{{{k}}}$",
            on_curve(10.0**k),
            xytext=(4, 3),
            textcoords="offset points",
            fontsize=7,
            color="0.35",
        )
    for rule, lam in curve.choices.items():
        mk, col = marks[rule]
        sel = " (chosen)" if rule == curve.rule else ""
        label = f"{names[rule]}{sel}: λ = {lam:.3g}"
        ax_l.loglog(*on_curve(lam), mk, color=col, ms=9, mfc="none", mew=2, label=label)
    _narrow_log_axis(ax_l.xaxis, curve.residual_norms)
    ax_l.set_xlabel("residual norm ‖Ax − y‖")
    ax_l.set_ylabel("penalty norm ‖Lx‖ = (Σ ‖X − Xᵀ‖²)$^{1/2}$")
    kap = curve.corner_curvature
    corner = f" (corner curvature {kap:.3g})" if math.isfinite(kap) else ""
    ax_l.set_title(f"L-curve, λ marked by decade{corner}")
    ax_l.legend(fontsize=8, loc="best")
    ax_l.grid(True, which="both", alpha=0.3)

    ax_g.set_title("generalised cross-validation")
    if np.any(np.isfinite(curve.gcv)):
        ax_g.loglog(curve.lams, curve.gcv, ".-", color="C0", lw=1, ms=4)
        if "gcv" in curve.choices:
            lam = curve.choices["gcv"]
            ax_g.axvline(lam, color="C2", ls="--", label=f"minimum: λ = {lam:.3g}")
            ax_g.legend(fontsize=8)
        _narrow_log_axis(ax_g.yaxis, curve.gcv)
        ax_g.set_xlabel("λ")
        ax_g.set_ylabel("GCV(λ) = ‖Ax − y‖² / (2Nm − t(λ))²")
        ax_g.grid(True, which="both", alpha=0.3)
    else:
        ax_g.text(0.5, 0.5, "not available from repeated solves", ha="center", va="center")
        ax_g.set_axis_off()

    ax_n.loglog(curve.lams, curve.residual_norms, ".-", color="C0", lw=1, ms=4, label="‖Ax − y‖")
    ax_p = ax_n.twinx()
    ax_p.loglog(curve.lams, curve.penalty_norms, ".-", color="C1", lw=1, ms=4)
    ax_n.plot([], [], ".-", color="C1", label="‖Lx‖ (right axis)")
    if curve.target_residual is not None:
        ax_n.axhline(curve.target_residual, color="C4", ls=":", label="target δ")
    for rule, lam in curve.choices.items():
        ax_n.axvline(lam, color=marks[rule][1], ls="--", lw=1, label=names[rule])
    _narrow_log_axis(ax_n.yaxis, curve.residual_norms)
    ax_n.set_xlabel("λ")
    ax_n.set_ylabel("residual norm")
    ax_p.set_ylabel("penalty norm")
    ax_n.set_title(f"norms against λ ({curve.method} sweep)")
    ax_n.legend(fontsize=8, loc="center left")
    ax_n.grid(True, which="both", alpha=0.3)
    if title:
        fig.suptitle(title)
    if path is not None:
        fig.savefig(path, dpi=150)
    return fig


# --------------------------------------------------------------------------- order


def plot_order_sweep(sweep: OrderSweep, path: str | Path, *, title: str | None = None) -> Path:
    """Held-out and training median |dB| error against the order, the chosen m marked.

    Parameters
    ----------
    sweep : OrderSweep
        What :func:`podid_rs.sweep_orders` returned.
    path : str or pathlib.Path
        The PNG to write (folders are created).
    title : str, optional
        The figure's title.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    fig, axes = _new_figure(7.5, 4.2, 1)
    ax = axes[0, 0]
    ms = [f.m for f in sweep.fits]
    ax.plot(ms, [f.test_db for f in sweep.fits], "o-", color="tab:red", label="held-out lines")
    ax.plot(ms, [f.train_db for f in sweep.fits], "s--", color="tab:blue", ms=4,
            label="training lines")
    unstable = [f for f in sweep.fits if not f.stable]
    if unstable:
        ax.plot([f.m for f in unstable], [f.test_db for f in unstable], "kx", ms=9,
                label="unstable")
    ax.axvline(sweep.chosen, color="grey", ls=":", lw=1.2)
    at_right = sweep.chosen > (ms[0] + ms[-1]) / 2  # keep the label inside the axes
    ax.text(sweep.chosen, 0.97, f" m = {sweep.chosen} ", transform=ax.get_xaxis_transform(),
            va="top", ha="right" if at_right else "left", fontsize=9, color="dimgrey")
    ax.set_yscale("log")
    ax.set_xlabel("reduced order m (POD modes)")
    ax.set_ylabel("median |dB error| of the FRFs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=9)
    fig.suptitle(title or "Order of the output-error model: error on held-out lines")
    return _save(fig, path)


_POWER = {"displacement": 0, "velocity": 1, "acceleration": 2}
_ORDINATE = {"displacement": "receptance", "velocity": "mobility", "acceleration": "accelerance"}


def plot_stabilisation(
    chart: StabilisationChart,
    path: str | Path,
    *,
    quantity: str = "displacement",
    title: str | None = None,
) -> Path:
    """The chart as a PNG: poles (frequency vs order) over the summed measured FRF.

    Markers: ○ new pole, △ frequency consistent with order m − 1, ● frequency
    and damping consistent; green for a physical model, blue otherwise, red ×
    for an unstable pole. The chosen order is shaded (and named in the legend).

    Parameters
    ----------
    chart : StabilisationChart
        What :func:`podid_rs.stabilisation_chart` returned.
    path : str or pathlib.Path
        The PNG to write (folders are created).
    quantity : {"displacement", "velocity", "acceleration"}
        Draw the background FRF as receptance, mobility or accelerance (as the test
        measured).
    title : str, optional
        The figure's title.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For an unknown ``quantity``.
    """
    if quantity not in _POWER:
        raise ValueError(f"quantity must be one of {tuple(_POWER)}, got {quantity!r}")
    lo, hi = chart.band_hz
    fig, axes = _new_figure(11.0, 6.4, 1, legend_rows=2)
    fig.subplots_adjust(right=1 - 1.0 / 11.0)  # room for the FRF axis on the right
    ax = axes[0, 0]
    back = ax.twinx()
    summed = chart.summed_frf * (2 * np.pi * chart.freq_hz) ** _POWER[quantity]
    show = display_lines(chart.freq_hz, [summed], bins=2 * DISPLAY_BINS)  # one wide panel
    back.semilogy(chart.freq_hz[show], summed[show], color="0.6", lw=1.0)
    what = "FRF" if chart.is_frf else "response spectrum"
    back.set_ylabel(f"Σ |measured {what}| ({_ORDINATE[quantity] if chart.is_frf else quantity})",
                    color="0.4")
    back.tick_params(axis="y", colors="0.4")
    ax.set_zorder(back.get_zorder() + 1)
    ax.patch.set_visible(False)

    styles = {
        "new": dict(marker="o", facecolors="none", s=22, lw=0.9),
        "f": dict(marker="^", facecolors="none", s=26, lw=0.9),
        "fz": dict(marker="o", s=26, lw=0.5),
    }
    labels = {"new": "new pole", "f": f"frequency within {100 * chart.f_tol:g} %",
              "fz": f"frequency and damping within {100 * chart.f_tol:g} % / "
                    f"{100 * chart.zeta_tol:g} %"}
    seen: set[str] = set()
    for o in chart.orders:
        f = o.modes.frequencies_hz
        show = o.oscillatory & (f >= lo) & (f <= hi)
        color = "tab:green" if o.physical else "tab:blue"
        for key, pick in (("new", ~o.consistent_f), ("f", o.consistent_f & ~o.consistent),
                          ("fz", o.consistent)):
            sel = show & pick & o.stable
            if np.any(sel):
                st = dict(styles[key])
                if st.pop("facecolors", None) == "none":
                    st.update(facecolors="none", edgecolors=color)
                else:
                    st.update(color=color)
                ax.scatter(f[sel], np.full(sel.sum(), o.m), label=None, **st)
                seen.add(key)
        bad = show & ~o.stable
        if np.any(bad):
            ax.scatter(f[bad], np.full(bad.sum(), o.m), marker="x", color="tab:red", s=22,
                       lw=1.0)
            seen.add("unstable")
    handles = []
    for key in ("new", "f", "fz"):
        st = dict(styles[key])
        if st.pop("facecolors", None) == "none":
            st.update(facecolors="none", edgecolors="0.25")
        else:
            st.update(color="0.25")
        handles.append(ax.scatter([], [], label=labels[key], **st))
    handles.append(ax.scatter([], [], marker="x", color="tab:red", s=22, label="unstable pole"))
    handles.append(ax.scatter([], [], marker="s", color="tab:green", s=22,
                              label="physical model (M, K ≻ 0, C ⪰ 0)"))
    handles.append(ax.scatter([], [], marker="s", color="tab:blue", s=22,
                              label="model not physical"))
    if chart.chosen_m is not None:
        # marked by a band and in the legend: a label on the axes would hide poles
        handles.append(ax.axhspan(chart.chosen_m - 0.45, chart.chosen_m + 0.45, color="gold",
                                  alpha=0.35, lw=0, label=f"chosen order m = {chart.chosen_m}"))
    ms = [o.m for o in chart.orders]
    ax.set_ylim(min(ms) - 0.7, max(ms) + 0.7)
    ax.set_xlim(lo, hi)
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel("model order m (POD modes)")
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.grid(True, alpha=0.25)
    fig.legend(handles=handles, loc="lower center", ncols=4, fontsize=8, frameon=False)
    fig.suptitle(title or "Stabilisation chart over the POD order")
    return _save(fig, path)


# --------------------------------------------------------------------------- modes


def _mode_labels(s: ModeShapes) -> list[str]:
    return [f"{j}: {f:.4g} Hz" for j, f in zip(s.mode_numbers, s.frequencies_hz, strict=True)]


def plot_mac(
    identified: ModeShapes,
    reference: ModeShapes | str | Path,
    path: str | Path,
    *,
    names: tuple[str, str] = ("identified", "reference"),
    band_hz: tuple[float, float] | None = None,
    title: str | None = None,
) -> Path:
    """The MAC of ``identified`` against ``reference`` as a PNG (values in the cells).

    Parameters
    ----------
    identified : ModeShapes
        The rows.
    reference : ModeShapes, str or pathlib.Path
        The columns: shapes of another model (:func:`podid_rs.mode_shapes`), or a
        UFF file whose dataset 55 holds them (:func:`podid_rs.read_uff_modes`).
    path : str or pathlib.Path
        The PNG to write (folders are created).
    names : tuple of str
        What to call the two sets in the labels.
    band_hz : tuple of float, optional
        Keep the modes of both in (lo, hi) Hz.
    title : str, optional
        The figure's title.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        As for :func:`podid_rs.shape_mac` and :func:`podid_rs.read_uff_modes`.
    FileNotFoundError
        For a reference file that does not exist.
    """
    if isinstance(reference, str | Path):
        ref_name = Path(reference).name
        reference = read_uff_modes(reference)
        names = (names[0], f"{names[1]} ({ref_name})")
    if band_hz is not None:
        identified, reference = identified.in_band(band_hz), reference.in_band(band_hz)
    values, used = shape_mac(identified, reference)
    ka, kb = values.shape
    size = min(max(4.5, 0.45 * max(ka, kb) + 2.5), 14.0)
    fig, axes = _new_figure(size + 1.2, size, 1)
    ax = axes[0, 0]
    fig.subplots_adjust(left=1.6 / (size + 1.2), bottom=1.7 / size, right=1 - 1.2 / (size + 1.2))
    image = ax.imshow(values, vmin=0.0, vmax=1.0, cmap="Blues", aspect="auto")
    fig.colorbar(image, ax=ax, fraction=0.05, pad=0.03, label="MAC")
    if ka * kb <= ANNOTATE_MAX_CELLS:
        for (i, j), v in np.ndenumerate(values):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=7,
                    color="white" if v > 0.6 else "black")
    ax.set_yticks(range(ka), _mode_labels(identified), fontsize=7)
    ax.set_xticks(range(kb), _mode_labels(reference), fontsize=7, rotation=60, ha="right")
    ax.set_ylabel(f"{names[0]} mode")
    ax.set_xlabel(f"{names[1]} mode")
    n_dofs = identified.shapes.shape[0] if used is None else len(used)
    ax.set_title(title or f"MAC, {names[0]} vs {names[1]} ({n_dofs} DOFs)", fontsize=10)
    return _save(fig, path)
