"""Measured data to a reduced model on disk: the work behind ``podid-rs identify``.

:func:`run_identify` reads a data file (:func:`podid_rs.io.npz.load_data`:
UFF 58 FRFs, time histories or a saved data set), keeps the lines of a band and
builds the POD basis of the measured responses (paper §5, steps 1–5). Then, by
default, it fits **output-error models** (:mod:`podid_rs.identification.refinement`)
of order 1, 2, … by continuation over the order, chooses m by the error on held-out
lines (:mod:`podid_rs.identification.order`) and refits that order on every line: M, C, K
symmetric and positive definite, the model stable by construction, fitted to the
measured FRFs themselves. The paper's estimator (eq. 49, exactly symmetric or with
λ) is computed at the same order for comparison; ``paper_estimator=True`` writes
it instead (optionally made physical, :func:`podid_rs.physical.make_physical`).
Into the output folder go

* ``model.npz`` — the model (:func:`podid_rs.io.npz.load_model`), with the
  basis ``basis`` (n × m), the measured ``dofs``, the driven ``inputs`` and ``band_hz``;
* ``frf_input<k>.png`` — measured and identified FRF (``R H_m Rᵀ``) at the driving
  point of driven DOF k and at the measured DOF farthest from it (at most four),
  the refined model beside the paper's estimator;
* ``modes.csv`` and ``modes.md`` — the modal table (natural frequencies, damping
  ratios, stability) with the kind of every pole (:func:`podid_rs.modes.mode_kinds`):
  the structure's modes — in-band resonances of the data — apart from the fit's
  residual terms (out of band, overdamped) and weak poles; ``modes.md`` headed by a
  summary of the run: the order and why, FRF errors of the paper's estimator and of
  the refined model, stability;
* ``order.png`` and ``order.md`` — the held-out and training errors of every order
  tried (refined models only);
* ``model.uff`` — the model for modal and FE-correlation software
  (:func:`podid_rs.io.uff.write_uff`): the input's geometry (dataset 15) when it had
  one, the structure's modes on the measured DOFs (55, one per ``structural`` row
  of ``modes.csv``, with its number) and the identified FRFs (58) in the input's
  ordinate;
* ``stabilisation.png`` / ``stabilisation.csv`` — the stabilisation chart over
  the POD order (:mod:`podid_rs.stabilisation`), the evidence for the order: the
  sweep's models (every order it tried), or with ``paper_estimator`` models fitted
  as the command fits (λ or exactly symmetric, made physical with ``--physical``)
  of orders 1 … :func:`stabilisation_orders`; the chosen order marked;
* ``mac.png`` — the MAC between the structural modes of the chosen order m and
  the in-band complex modes of order m + 1 (m − 1 at full order): shapes that
  persist are not artefacts of the order (not written when either order has no mode
  in the band, or when one DOF was measured: a shape of one entry has no MAC).

The last three are :func:`write_identify_outputs`'s.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..identification.covariance import NoiseModel
from ..identification.estimator import identify
from ..identification.latent import observation_matrix
from ..identification.order import OrderSweep, final_fit, sweep_orders
from ..identification.refinement import db_errors
from ..identification.result import IdentificationResult
from ..io.npz import load_data, save_model
from ..io.uff import read_uff_geometry, uff_quantity, write_uff
from ..measured import MeasuredData
from ..modes import (
    RESIDUAL,
    RESIDUAL_ZETA,
    STRUCTURAL,
    VISIBLE_FRACTION,
    WEAK,
    mode_kinds,
    mode_shapes,
)
from ..physical import make_physical, modal_parameters, modal_table, table_csv, table_markdown
from ..plotting import (
    Curve,
    display_lines,
    plot_frf_comparison,
    plot_mac,
    plot_order_sweep,
    plot_stabilisation,
)
from ..pod import PODResult
from ..stabilisation import is_physical, pod_fit, stabilisation_chart
from ..uncertainty import LEVEL, ModelUncertainty, fit_uncertainty

MAX_OVERLAYS = 4
#: the noise of the intervals and the FRF band, estimated from the residuals per channel
#: over the neighbouring lines: a measured FRF's noise grows with the response (H1's
#: random error at a steady coherence), and one variance per channel takes the
#: resonances' noise for every line's (docs/design.md §12)
NOISE_MODEL: NoiseModel = "local"
#: the chart runs to order max(STABILISATION_ORDERS, m + 5), at most n
STABILISATION_ORDERS = 30


@dataclass(frozen=True)
class IdentifyRun:
    """What :func:`run_identify` did: the data used, the model(s), the basis and the files.

    ``result`` is the model written: the refined (output-error) model, or with
    ``paper_estimator`` the paper's (made physical when asked). ``least_squares`` is
    the paper's estimator at the same order (eq. 49); ``sweep`` the order sweep
    (None with ``paper_estimator``); ``timings`` the wall time (s) of each phase, in
    the order they ran (the summary's last line); ``uncertainty`` the covariance of the
    refined model (:func:`podid_rs.fit_uncertainty`; None with ``paper_estimator``, or
    when it could not be formed: ``uncertainty_note`` says why).
    """

    source: Path
    data: MeasuredData
    least_squares: IdentificationResult
    result: IdentificationResult
    basis: np.ndarray
    files: list[Path] = field(default_factory=list)
    sweep: OrderSweep | None = None
    timings: dict[str, float] = field(default_factory=dict)
    uncertainty: ModelUncertainty | None = None
    uncertainty_note: str = ""
    #: id(model) → (model, its errors): the summary is written to modes.md and printed
    _errors: dict = field(default_factory=dict, repr=False, compare=False)

    def frf_errors(self, model: IdentificationResult) -> tuple[float, float]:
        """Median and 95th percentile |dB| of ``model``'s responses (R H_m Rᵀ F) against
        the measured ones, over every line and measured entry (DOF and load case)."""
        if id(model) not in self._errors:
            # [R_p, 0]: a lower order's basis leads it
            d, R = self.data, self.basis[:, : model.m]
            F_m = np.einsum("im,sip->smp", R[d.inputs], d.F)
            X = np.einsum("nm,smp->snp", R, model.system().response(d.omega, F_m))
            e = db_errors(X, d.U, None if d.complete else d.measured)
            self._errors[id(model)] = (model, (float(np.median(e)), float(np.percentile(e, 95))))
        return self._errors[id(model)][1]

    def summary(self) -> str:
        """A few lines of Markdown describing the run."""
        d, r, ls = self.data, self.result, self.least_squares
        f_m = np.einsum("im,sip->smp", self.basis[d.inputs, : ls.m], d.F)
        lam = (
            "exactly symmetric (λ → ∞)"
            if ls.symmetric
            else "λ = " + ", ".join(f"{v:g}" for v in ls.lam)
        )
        lines = [
            f"- data: `{self.source.name}`, {d.s} lines {d.freq_hz[0]:g}–{d.freq_hz[-1]:g} Hz, "
            f"{d.n} measured DOFs, {d.p} load case(s), driven DOFs (node, dir) "
            + ", ".join(str(tuple(int(v) for v in d.dofs[i])) for i in d.inputs),
            *[f"- note: {note}" for note in d.notes],
        ]
        if self.sweep is not None:
            lines.append(f"- order: {self.sweep.reason}")
        else:
            lines.append(f"- order: m = {r.m}")
        latent = r.m - ls.m
        if latent > 0:
            lines.append(
                f"- coordinates: {ls.m} observed (the POD modes of the {d.n} measured DOFs) and "
                f"{latent} latent, which no sensor sees (docs/design.md §11); the paper's "
                f"estimator needs every coordinate measured, so it is fitted at m = {ls.m}"
            )
        ref = r.info.get("refinement")
        if ref is not None:
            lines.append(
                f"- model: output-error refinement ({ref['weights']} weights), "
                f"{r.iterations} Levenberg–Marquardt steps ({ref['stop']}); M, C, K symmetric, "
                f"positive definite: {'yes' if is_physical(r) else 'no'}"
            )
            if "final_refit" in ref:
                fr = ref["final_refit"]
                lines.append(f"- final fit on every line: kept the {fr['kept']} — {fr['reason']}")
        else:
            lines.append(
                f"- model: the paper's estimator (eq. 49), {lam}; solver {r.method}, rank "
                f"{r.rank} of {r.n_unknowns}"
            )
        y = np.linalg.norm(f_m)
        if r is ls:
            lines.append(
                f"- equation-error residual ‖Ax − y‖ = {r.residual_norm:.4g} "
                f"({r.residual_norm / y:.3g} of ‖y‖)"
            )
        elif latent > 0:
            lines.append(
                f"- equation-error residual ‖Ax − y‖ / ‖y‖ (what the paper's estimator "
                f"minimises): paper's estimator {ls.residual_norm / y:.3g}; not defined for "
                "the refined model (its latent coordinates have no measured response)"
            )
        else:
            lines.append(
                f"- equation-error residual ‖Ax − y‖ / ‖y‖ (what the paper's estimator "
                f"minimises): paper's estimator {ls.residual_norm / y:.3g}, "
                f"{'refined' if ref is not None else 'written'} model {r.residual_norm / y:.3g}"
            )
        if "physical" in r.info:
            p = r.info["physical"]
            change = p["residual_after"] / p["residual_before"] - 1 if p["residual_before"] else 0.0
            lines.append(
                f"- physical correction (nearest SPD M, K and PSD C): residual "
                f"{p['residual_before']:.4g} → {p['residual_after']:.4g} ({100 * change:+.2f} %), "
                f"eigenvalues raised in M, C, K: {tuple(p['eigenvalues_raised'])}"
            )
        med_ls, p95_ls = self.frf_errors(ls)
        stab_ls = "stable" if modal_parameters(ls).stable else "unstable"
        if r is not ls:
            med, p95 = self.frf_errors(r)
            stab = "stable" if modal_parameters(r).stable else "unstable"
            lines.append(
                f"- FRF error, median / 95th percentile |dB| over every line and measured DOF: "
                f"paper's estimator {med_ls:.2f} / {p95_ls:.1f} dB ({stab_ls}) → "
                f"{'refined' if ref is not None else 'written'} model {med:.2f} / {p95:.1f} dB "
                f"({stab})"
            )
        else:
            lines.append(
                f"- FRF error, median / 95th percentile |dB| over every line and measured DOF: "
                f"{med_ls:.2f} / {p95_ls:.1f} dB ({stab_ls})"
            )
        modes = modal_parameters(r)
        lines.append(
            f"- stable: {'yes' if modes.stable else 'no'} "
            f"(largest Re λ = {modes.max_real_part:.4g})"
        )
        if self.uncertainty is not None:
            structural = pole_kinds(r, self.basis, d) == STRUCTURAL
            lines.append(f"- intervals: {self.uncertainty.summary(LEVEL, structural)} "
                         "(the structure's modes)")
        elif self.uncertainty_note:
            lines.append(f"- intervals: none — {self.uncertainty_note}")
        if self.timings:
            lines.append("- wall time: " + ", ".join(
                f"{name} {seconds:.1f} s" for name, seconds in self.timings.items()))
        return "\n".join(lines) + "\n"


def _model_frf(result: IdentificationResult, R: np.ndarray, omega: np.ndarray, rows, col: int):
    """Entries ``(rows, col)`` of the model's FRF on the measured DOFs, ``R H_m(ω) Rᵀ``:
    the response to the one load ``Rᵀ e_col``."""
    load = np.broadcast_to(R[col], (omega.size, R.shape[1]))
    return result.system().response(omega, load) @ R[rows].T


def _overlays(run: IdentifyRun, out: Path) -> list[Path]:
    """One PNG per driven DOF (at most MAX_OVERLAYS): its driving point and the farthest DOF.

    FRF data are drawn with the identified FRFs over them; other data (spectra
    under random forces) have no measured FRF, so only the model's is drawn.
    """
    d = run.data
    refined = "refinement" in run.result.info
    models = [("paper's estimator (eq. 49)" if refined else "identified", run.least_squares,
               {"color": "tab:orange", "lw": 1.0} if refined else {})]
    if run.result is not run.least_squares:
        label = "refined (output error)" if refined else "identified, physical"
        models.append((label, run.result, {"color": "tab:green", "ls": "--"}))
    paths = []
    for k in range(min(d.inputs.size if d.is_frf else 1, MAX_OVERLAYS)):
        col = int(d.inputs[k])
        # the farthest DOF this force's responses measured (every DOF for complete data)
        distance = np.where(d.measured[:, k], np.abs(d.dofs[:, 0] - d.dofs[col, 0]), -1)
        far = int(np.argmax(distance))
        rows = [col, far]
        # an entry that was not measured is drawn as the model's alone, never as data
        seen = np.where(d.measured[rows, k], d.U[:, rows, k], np.nan)
        values = [_model_frf(r, run.basis[:, : r.m], d.omega, rows, col) for _, r, _ in models]
        # the lines that draw every curve as all lines would (a long test: a few thousand)
        show = display_lines(d.freq_hz, [np.abs(v) for v in values]
                             + ([np.abs(seen)] if d.is_frf else []))
        curves = [Curve("measured", seen[show], kind="original")] if d.is_frf else []
        for (label, r, style), v in zip(models, values, strict=True):
            band, band_label = None, ""
            if r is run.result and run.uncertainty is not None:
                frf = run.uncertainty.frf(d.omega[show], rows=rows, cols=[col], level=LEVEL)
                band = np.stack([frf.lower[:, :, 0], frf.upper[:, :, 0]], axis=-1)
                band_label = f"{100 * LEVEL:g} % confidence band"
            curves.append(Curve(label, v[show], kind="identified", style=style, band=band,
                                band_label=band_label))
        driven = _dof_name(d.dofs[col])
        what = "measured and identified" if d.is_frf else "identified (the data are not FRFs)"
        if d.is_frf and not d.measured[col, k]:
            what += f"; H({driven},{driven}) was not measured"
        paths.append(
            plot_frf_comparison(
                d.freq_hz[show],
                curves,
                out / f"frf_input{k + 1}.png",
                title=f"FRFs for the force at DOF {driven}: {what}, m = {run.result.m}",
                entries=[(driven, driven), (_dof_name(d.dofs[far]), driven)],
            )
        )
    return paths


def pole_kinds(result: IdentificationResult, R: np.ndarray, data: MeasuredData) -> np.ndarray:
    """The kind of each pole of ``result`` (:func:`podid_rs.modes.mode_kinds`): the
    structure's modes, weak poles and residual terms, judged against the measured FRFs
    (FRF data) or by band and damping alone (other data)."""
    shapes = mode_shapes(result, R, data.dofs)
    if data.is_frf:
        return mode_kinds(shapes, data.omega, data.U, data.inputs,
                          measured=None if data.complete else data.measured)
    return mode_kinds(shapes, data.omega)


def with_intervals(rows: list[dict], unc: ModelUncertainty, level: float = LEVEL) -> list[dict]:
    """The rows of :func:`~podid_rs.physical.modal_table` with the half-widths of the
    intervals of f and ζ at ``level`` beside them (``f_hz_pm95``, ``zeta_pm95`` at 95 %;
    ``undetermined`` where the data do not fix the mode)."""
    modes = unc.modes(level)
    tag = f"pm{100 * level:g}"
    out = []
    for row, df, dz, ok in zip(rows, modes.z * modes.std_frequency_hz,
                               modes.z * modes.std_damping, modes.determined, strict=True):
        new: dict = {}
        for key, value in row.items():
            new[key] = value
            if key in ("f_hz", "zeta"):
                new[f"{key}_{tag}"] = float(df if key == "f_hz" else dz) if ok else "undetermined"
        out.append(new)
    return out


def modes_markdown(summary: str, rows: list[dict]) -> str:
    """``modes.md``: the run's summary, the structure's modes, then the fit's other poles."""
    structural = [r for r in rows if r.get("kind", STRUCTURAL) == STRUCTURAL]
    others = [r for r in rows if r.get("kind", STRUCTURAL) != STRUCTURAL]
    text = (f"# podid-rs identify\n\n{summary}\n## Modes of the structure\n\n"
            "In-band resonances of the measured data (the poles `modes.csv` marks "
            f"`{STRUCTURAL}`); these go to `model.uff` (dataset 55).")
    pm = [key for key in (rows[0] if rows else {}) if key.startswith("f_hz_pm")]
    if pm:
        text += (f" `f_hz_{pm[0][5:]}`, `zeta_{pm[0][5:]}`: the half-width of the "
                 f"{pm[0][7:]} % confidence interval (estimate ± it), from the output-error "
                 "fit's covariance.")
    text += "\n\n"
    text += table_markdown(structural) if structural else "None.\n"
    if others:
        text += (
            "\n## Other poles of the fit (not modes of the structure)\n\n"
            f"`{RESIDUAL}`: a residual term — out of the band or at its edge, overdamped or "
            "with ζ ≥ "
            f"{RESIDUAL_ZETA:g}, standing in for modes outside the band; `{WEAK}`: in band but "
            f"not a resonance of the data — under {100 * VISIBLE_FRACTION:g} % of the largest "
            "measured response around it at every DOF, or seen at one line only. They shape "
            "the fit; they are not resonances of the data."
            + (" Their ± are the same covariance's: how closely the data fix each term of the "
               "fit (`undetermined` where they do not), not the accuracy of a modal property."
               if pm else "")
            + "\n\n" + table_markdown(others)
        )
    return text


def _dof_name(dof: np.ndarray) -> str:
    """A measured DOF as the file names it: node and direction, e.g. ``3Z`` or ``12-Y``."""
    node, direction = (int(v) for v in dof[:2])
    if 1 <= abs(direction) <= 3:
        return f"{node}{'-' if direction < 0 else ''}{'XYZ'[abs(direction) - 1]}"
    return f"{node}:{direction}"


def run_identify(
    path: str | Path,
    out: str | Path,
    *,
    band_hz: tuple[float, float],
    m: int | None = None,
    energy: float | None = None,
    lam: float | tuple[float, float, float] | None = None,
    physical: bool = False,
    paper_estimator: bool = False,
    m_max: int | None = None,
    progress: bool = True,
) -> IdentifyRun:
    """Identify a reduced model from the data file ``path`` and write it to ``out``.

    Default: output-error models by continuation over the order, m chosen on held-out
    lines (or ``m`` given, or the smallest capturing the energy fraction ``energy``,
    eq. 43), up to ``m_max``. ``paper_estimator=True``: the paper's estimator alone,
    at ``m`` or by ``energy`` (default 0.99), made physical with ``physical``.
    ``lam=None`` solves the paper's estimator exactly symmetric (the λ → ∞ limit;
    FRFs from fewer driven DOFs than m need symmetry, see
    :mod:`podid_rs.measured`), a number or triple the regularised one (eq. 40).
    ``progress`` shows the order sweep, the refinement and the chart on a terminal.
    """
    if m is not None and energy is not None:
        raise ValueError("give the reduced order m or the energy fraction, not both")
    clock = _Clock()
    source = Path(path)
    data = load_data(source, band_hz=band_hz)
    symmetric = lam is None
    pod = data.pod()
    F_n = data.forces_on_dofs()
    holes = {} if data.complete else {"measured": data.measured}  # holes weigh nothing
    clock.lap("reading the data and its POD")
    sweep = None
    if paper_estimator:
        order = m if m is not None else pod.order_for_energy(0.99 if energy is None else energy)
    else:
        order = m if energy is None else pod.order_for_energy(energy)
        bar = _SweepBar(enabled=progress)
        try:
            sweep = sweep_orders(data.U, F_n, data.omega, pod, m=order, m_max=m_max,
                                 progress=bar, **holes)
        finally:
            bar.close()
        order = sweep.chosen
        clock.lap("order sweep")
    # the paper's estimator needs every coordinate measured: at most the POD modes with energy
    R = pod.basis(min(order, int(np.sum(pod.eigenvalues > 0)), data.n))
    U_m, F_m = data.project(R)
    ls = identify(U_m, F_m, data.omega, 0.0 if symmetric else lam, symmetric)
    clock.lap("paper's estimator")
    if sweep is not None:
        result, R = final_fit(sweep, data.U, F_n, data.omega, pod, progress=progress,
                              **holes)
        clock.lap("final fit")
    elif physical:
        result = make_physical(ls, U_m, F_m, data.omega)
    else:
        result = ls
    unc, note = None, ""
    if sweep is not None:
        try:
            unc = fit_uncertainty(data, result, R, sweep, noise=NOISE_MODEL)
        except ValueError as exc:  # e.g. no degrees of freedom left for the noise
            note = str(exc)
        clock.lap("covariance")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run = IdentifyRun(source, data, ls, result, R, sweep=sweep, timings=clock.laps,
                      uncertainty=unc, uncertainty_note=note)
    files = [
        save_model(
            out / "model.npz",
            result,
            basis=R,
            dofs=data.dofs,
            inputs=data.inputs,
            band_hz=np.asarray(band_hz, dtype=float),
        )
    ]
    files += _overlays(run, out)
    clock.lap("FRF overlays")
    kinds = pole_kinds(result, R, data)
    rows = modal_table(result, kinds=kinds)
    if unc is not None:
        rows = with_intervals(rows, unc)
    (out / "modes.csv").write_text(table_csv(rows))
    (out / "modes.md").write_text(modes_markdown(run.summary(), rows))
    files += [out / "modes.csv", out / "modes.md"]
    if sweep is not None:
        files.append(plot_order_sweep(
            sweep, out / "order.png",
            title=f"Order of the output-error model: {source.name}, "
            f"{band_hz[0]:g}–{band_hz[1]:g} Hz",
        ))
        (out / "order.md").write_text(
            f"# Order sweep\n\n{sweep.reason}\n\n{sweep.table()}"
        )
        files.append(out / "order.md")
        fits = {f.m: f.model for f in sweep.fits}
        files += write_identify_outputs(
            source, data, result, R, out, band_hz=band_hz, lam=lam, physical=physical,
            progress=progress, pod=pod, fit=lambda k: result if k == order else fits[k],
            max_order=max(fits), kinds=kinds,
        )
    else:
        files += write_identify_outputs(source, data, result, R, out, band_hz=band_hz, lam=lam,
                                        physical=physical, progress=progress, pod=pod,
                                        kinds=kinds)
    clock.lap("modal table, model.uff, stabilisation chart, MAC")
    return IdentifyRun(source, data, ls, result, R, files, sweep, clock.laps, unc, note,
                       run._errors)


class _Clock:
    """Wall time of the phases of a run, in the order they ran."""

    def __init__(self) -> None:
        self.laps: dict[str, float] = {}
        self._t = time.perf_counter()

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        self.laps[name] = now - self._t
        self._t = now


class _SweepBar:
    """The order sweep as a tqdm bar on stderr: orders fitted, the latest held-out error."""

    def __init__(self, enabled: bool) -> None:
        from .._progress import progress_bar

        self.bar = progress_bar(None, enabled=enabled, desc="order sweep", unit="order")

    def __call__(self, m: int, fit) -> None:
        self.bar.update(1)
        self.bar.set_postfix_str(f"m = {m}, held-out {fit.test_db:.2f} dB")

    def close(self) -> None:
        self.bar.close()


# --------------------------------------------------------------------------- the other files


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
    kinds: np.ndarray | None = None,
) -> list[Path]:
    """Write ``model.uff``, ``stabilisation.png``/``.csv`` and ``mac.png`` to ``out``.

    The chart fits orders 1 … ``max_order`` (default :func:`stabilisation_orders`)
    with ``fit`` (default: as the command's paper estimator, :func:`command_fit`).
    """
    quantity = source_ordinate(source)
    kinds = pole_kinds(result, basis, data) if kinds is None else np.asarray(kinds)
    files = [
        write_uff(out / "model.uff", result, basis, data, quantity=quantity,
                  geometry=source_geometry(source), name=source.name,
                  modes=kinds == STRUCTURAL)
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
        title=f"Stabilisation chart over the model order: {source.name}, "
        f"{band_hz[0]:g}–{band_hz[1]:g} Hz",
    ))
    other = m + 1 if m < top else m - 1
    lo, hi = float(data.freq_hz[0]), float(data.freq_hz[-1])
    if other >= 1 and data.n >= 2:  # a MAC compares shapes over two DOFs at least
        shapes = mode_shapes(result, basis, data.dofs).select(kinds == STRUCTURAL)
        # order `other`'s observation matrix: its POD modes, a zero column per latent DOF
        observed = min(other, int(np.sum(pod.eigenvalues > 0)), data.n)
        neighbour = mode_shapes(
            chart.order(other).model, observation_matrix(pod.basis(observed), other), data.dofs
        ).in_band((lo, hi)).oscillatory()
        if shapes.n_modes and neighbour.n_modes:
            files.append(plot_mac(
                shapes, neighbour, out / "mac.png", names=(f"m = {m}", f"m = {other}"),
                title=f"MAC of the identified mode shapes in {lo:g}–{hi:g} Hz, "
                f"m = {m} vs m = {other}",
            ))
    return files
