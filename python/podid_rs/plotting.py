"""Figures in the spirit of the paper's Figs. 2–19 (Section 6), written as PNG files.

Every function builds a :class:`matplotlib.figure.Figure` directly (no
``pyplot``), renders it with the Agg canvas and saves it, so importing or
calling this module never changes the user's interactive backend or global
figure state. FRF panels follow the paper: magnitude on a log axis against
frequency in Hz, (a) the driving point, (b) the cross entry.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
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


@dataclass(frozen=True)
class Curve:
    """One FRF line of a comparison: ``values`` ``(s, 2)`` complex, one column per entry.

    ``kind`` picks the style (a key of :data:`STYLES`); ``style`` overrides it.
    """

    label: str
    values: np.ndarray
    kind: str = "original"
    style: Mapping = field(default_factory=dict)


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
    n_items = len(curves) + (band_hz is not None)
    ncols = min(n_items, 3)
    legend_rows = -(-n_items // ncols)
    fig, axes = _new_figure(11.0, 4.35 + 0.25 * legend_rows, 2, legend_rows=legend_rows)
    for i, (ax, entry) in enumerate(zip(axes[0], entries, strict=True)):
        for c in curves:
            style = {**STYLES.get(c.kind, {}), **c.style}
            ax.plot(freq_hz, np.abs(c.values[:, i]), label=c.label, **style)
        if band_hz is not None:
            ax.axvspan(*band_hz, color="gold", alpha=0.15, lw=0, zorder=0,
                       label=f"measured band {band_hz[0]:g}–{band_hz[1]:g} Hz")
        _frf_axis(ax, entry, i)
        ax.set_xlim(freq_hz[0], freq_hz[-1])
    _legend_below(fig, axes[0, 0], ncols=ncols)
    fig.suptitle(title)
    return _save(fig, path)
