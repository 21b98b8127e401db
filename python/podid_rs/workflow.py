"""Measured data to a reduced model on disk: the work behind ``podid-rs identify``.

:func:`run_identify` reads a data file (:func:`podid_rs.measurements.load_data`:
UFF 58 FRFs, time histories or a saved data set), keeps the lines of a band,
builds the POD basis of the measured responses, identifies M, C, K (paper §5,
steps 1–6), optionally makes them physical (:func:`podid_rs.physical.make_physical`)
and writes into the output folder

* ``model.npz`` — the model (:func:`podid_rs.measurements.load_model`), with the
  basis ``basis`` (n × m), the measured ``dofs``, the driven ``inputs`` and ``band_hz``;
* ``frf_input<k>.png`` — measured and identified FRF (``R H_m Rᵀ``) at the driving
  point of driven DOF k and at the measured DOF farthest from it (at most four);
* ``modes.csv`` and ``modes.md`` — the modal table (natural frequencies, damping
  ratios, stability), ``modes.md`` headed by a summary of the run;
* ``model.uff``, ``stabilisation.png``/``.csv`` and ``mac.png`` — the model for
  other tools, the evidence for the order, the MAC between two orders
  (:mod:`podid_rs.identify_outputs`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .identification import IdentificationResult
from .identify_outputs import write_identify_outputs
from .measurements import MeasuredData, load_data, save_model
from .physical import make_physical, modal_parameters, modal_table, table_csv, table_markdown
from .plotting import Curve, plot_frf_comparison

MAX_OVERLAYS = 4


@dataclass(frozen=True)
class IdentifyRun:
    """What :func:`run_identify` did: the data used, the model(s), the basis and the files.

    ``result`` is the model written (corrected when ``physical``); ``least_squares``
    the uncorrected one (the same object without ``physical``).
    """

    source: Path
    data: MeasuredData
    least_squares: IdentificationResult
    result: IdentificationResult
    basis: np.ndarray
    files: list[Path] = field(default_factory=list)

    def summary(self) -> str:
        """A few lines of Markdown describing the run."""
        d, r = self.data, self.result
        f_m = np.einsum("im,sip->smp", self.basis[d.inputs], d.F)
        lam = (
            "exactly symmetric (λ → ∞)"
            if r.symmetric
            else "λ = " + ", ".join(f"{v:g}" for v in r.lam)
        )
        modes = modal_parameters(r)
        lines = [
            f"- data: `{self.source.name}`, {d.s} lines {d.freq_hz[0]:g}–{d.freq_hz[-1]:g} Hz, "
            f"{d.n} measured DOFs, {d.p} load case(s), driven DOFs (node, dir) "
            + ", ".join(str(tuple(int(v) for v in d.dofs[i])) for i in d.inputs),
            f"- reduced order m = {r.m}; {lam}; solver {r.method}, rank {r.rank} of {r.n_unknowns}",
            f"- residual ‖Ax − y‖ = {r.residual_norm:.4g} "
            f"({r.residual_norm / np.linalg.norm(f_m):.3g} of ‖y‖)",
        ]
        if "physical" in r.info:
            p = r.info["physical"]
            change = p["residual_after"] / p["residual_before"] - 1 if p["residual_before"] else 0.0
            lines.append(
                f"- physical correction (nearest SPD M, K and PSD C): residual "
                f"{p['residual_before']:.4g} → {p['residual_after']:.4g} ({100 * change:+.2f} %), "
                f"eigenvalues raised in M, C, K: {tuple(p['eigenvalues_raised'])}"
            )
        lines.append(
            f"- stable: {'yes' if modes.stable else 'no'} "
            f"(largest Re λ = {modes.max_real_part:.4g})"
        )
        return "\n".join(lines) + "\n"


def _model_frf(result: IdentificationResult, R: np.ndarray, omega: np.ndarray, rows, col: int):
    """Entries ``(rows, col)`` of the model's FRF on the measured DOFs, ``R H_m(ω) Rᵀ``."""
    H_m = result.system().frf(omega)
    return np.einsum("am,smk,k->sa", R[rows], H_m, R[col])


def _overlays(run: IdentifyRun, out: Path) -> list[Path]:
    """One PNG per driven DOF (at most MAX_OVERLAYS): its driving point and the farthest DOF.

    FRF data are drawn with the identified FRFs over them; other data (spectra
    under random forces) have no measured FRF, so only the model's is drawn.
    """
    d = run.data
    models = [("identified", run.least_squares, {})]
    if run.result is not run.least_squares:
        models.append(("identified, physical", run.result, {"color": "tab:green", "ls": "--"}))
    paths = []
    for k in range(min(d.inputs.size if d.is_frf else 1, MAX_OVERLAYS)):
        col = int(d.inputs[k])
        far = int(np.argmax(np.abs(d.dofs[:, 0] - d.dofs[col, 0])))
        rows = [col, far]
        curves = [Curve("measured", d.U[:, rows, k], kind="original")] if d.is_frf else []
        for label, r, style in models:
            values = _model_frf(r, run.basis, d.omega, rows, col)
            curves.append(Curve(label, values, kind="identified", style=style))
        node = tuple(int(v) for v in d.dofs[col])
        what = "measured and identified" if d.is_frf else "identified (the data are not FRFs)"
        paths.append(
            plot_frf_comparison(
                d.freq_hz,
                curves,
                out / f"frf_input{k + 1}.png",
                title=f"FRFs for the force at DOF {node}: {what}, m = {run.result.m}",
                entries=[(col + 1, col + 1), (far + 1, col + 1)],
            )
        )
    return paths


def run_identify(
    path: str | Path,
    out: str | Path,
    *,
    band_hz: tuple[float, float],
    m: int | None = None,
    energy: float | None = None,
    lam: float | tuple[float, float, float] | None = None,
    physical: bool = False,
    progress: bool = True,
) -> IdentifyRun:
    """Identify a reduced model from the data file ``path`` and write it to ``out``.

    ``lam=None`` solves the exactly symmetric problem (the λ → ∞ limit; FRFs from
    fewer driven DOFs than m need symmetry, see :mod:`podid_rs.measurements`),
    a number or triple the regularised one (eq. 40). The order is ``m``, or the
    smallest capturing the energy fraction ``energy`` (default 0.99, eq. 43).
    ``progress`` shows the order sweep of the stabilisation chart on a terminal.
    """
    source = Path(path)
    data = load_data(source, band_hz=band_hz)
    symmetric = lam is None
    ls, R = data.identify(m=m, energy=energy, lam=0.0 if symmetric else lam, symmetric=symmetric)
    result = make_physical(ls, *data.project(R), data.omega) if physical else ls
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run = IdentifyRun(source, data, ls, result, R)
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
    rows = modal_table(result)
    (out / "modes.csv").write_text(table_csv(rows))
    (out / "modes.md").write_text(
        f"# podid-rs identify\n\n{run.summary()}\n## Modes of the identified model\n\n"
        + table_markdown(rows)
    )
    files += [out / "modes.csv", out / "modes.md"]
    files += write_identify_outputs(source, data, result, R, out, band_hz=band_hz, lam=lam,
                                    physical=physical, progress=progress)
    return IdentifyRun(source, data, ls, result, R, files)
