"""``podid-rs identify``: UFF and time-history files in, model, FRF overlays and modes out.

Tolerance: the UFF is written in ASCII and binary records alternately; the ASCII
ones carry 12 significant digits, which leaves the weakly observed damping
matrix within ~3e-7 of the truth at full order (asserted 1e-6).
"""

from __future__ import annotations

import csv
import subprocess
import sys

import numpy as np
import pytest

from podid_rs import load_model, mass_spring_chain, modal_parameters
from podid_rs.apps.cli import main

pytest.importorskip("pyuff")
from test_measurements import periodic_test, write_uff  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def uff_file(tmp_path):
    """Exact FRFs of the 6-DOF chain, driven at DOFs 2 and 5, as accelerance in a UFF."""
    chain = mass_spring_chain(6)
    freq = np.arange(0.0, 201.0, 1.0)
    H = np.zeros((freq.size, 6, 2), dtype=complex)
    H[1:] = chain.frf(2 * np.pi * freq[1:])[:, :, [1, 4]]
    dofs = [(k + 1, 1) for k in range(6)]
    return chain, write_uff(tmp_path / "test.uff", freq, H, dofs, [dofs[1], dofs[4]])


def read_rows(path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def check_full_order_outputs(chain, out, names_extra=()):
    """model.npz holds the chain at full order (to 1e-6, see the module docstring), the
    modal table its modes, the overlays and the chart are written."""
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(["frf_input1.png", "frf_input2.png", "mac.png", "model.npz",
                            "model.uff", "modes.csv", "modes.md", "stabilisation.csv",
                            "stabilisation.png", *names_extra])
    for png in ("frf_input1.png", "frf_input2.png"):
        assert (out / png).read_bytes()[:8] == PNG

    model, extras = load_model(out / "model.npz")
    R = extras["basis"]
    assert R.shape == (6, 6) and extras["inputs"].tolist() == [1, 4]
    assert extras["band_hz"].tolist() == [5.0, 200.0] and extras["dofs"].shape == (6, 2)
    for k in "MCK":
        X = R @ getattr(model, k) @ R.T
        assert np.linalg.norm(X - getattr(chain, k)) < 1e-6 * np.linalg.norm(getattr(chain, k))

    rows = read_rows(out / "modes.csv")
    truth = modal_parameters(chain)
    assert [r["mode"] for r in rows] == ["1", "2", "3", "4", "5", "6"]
    assert np.allclose([float(r["f_hz"]) for r in rows], truth.frequencies_hz, rtol=1e-7)
    assert np.allclose([float(r["zeta"]) for r in rows], truth.damping_ratios, rtol=1e-6)
    assert all(r["stable"] == "yes" for r in rows)
    md = (out / "modes.md").read_text()
    assert "`test.uff`" in md and "196 lines 5–200 Hz" in md and "| mode | f_hz |" in md
    # the fixture's six DOFs along X, forces at DOFs 2 and 5: two load cases
    assert "6 measured DOFs, 2 load case(s), driven DOFs (node, dir) (2, 1), (5, 1)" in md
    return model


def test_identify_uff_full_order_recovers_the_chain(uff_file, tmp_path, capsys):
    """The default: output-error models by continuation up to the asked order."""
    chain, path = uff_file
    out = tmp_path / "out"
    status = main(["identify", str(path), "--band-hz", "5", "200", "--m", "6", "--out", str(out)])
    assert status == 0
    stdout = capsys.readouterr().out
    assert "output-error refinement" in stdout and "m = 6 as asked" in stdout
    assert "stable: yes" in stdout and "positive definite: yes" in stdout
    assert "→ refined model" in stdout  # the FRF errors' line names the model written
    # every coordinate of m = 6 observed by the six sensors: no latent line, and the
    # equation-error residual given for both models
    assert "- coordinates:" not in stdout and "not defined for the refined model" not in stdout
    assert "minimises): paper's estimator " in stdout and ", refined model " in stdout
    model = check_full_order_outputs(chain, out, ("order.md", "order.png"))
    assert model.method == "output-error" and model.symmetric
    table = (out / "order.md").read_text()
    assert all(f"| {k} " in table for k in range(1, 6)) and "| 6 **(chosen)** |" in table


def test_identify_paper_estimator_alone(uff_file, tmp_path, capsys):
    chain, path = uff_file
    out = tmp_path / "out"
    argv = ["identify", str(path), "--band-hz", "5", "200", "--m", "6", "--paper-estimator"]
    assert main([*argv, "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "exactly symmetric" in stdout and "stable: yes" in stdout
    model = check_full_order_outputs(chain, out)
    assert model.method == "cholesky"


def test_identify_chooses_the_order_on_held_out_lines(uff_file, tmp_path, capsys):
    chain, path = uff_file
    out = tmp_path / "out"
    assert main(["identify", str(path), "--band-hz", "5", "200", "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "held-out median error" in stdout and "one line in 4 held out" in stdout
    model, extras = load_model(out / "model.npz")
    # exact FRFs of a 6-DOF chain: the full order reproduces them, nothing less does as well
    assert model.m == 6 and (out / "order.png").read_bytes()[:8] == PNG



def test_m_max_bounds_the_order_sweep(uff_file, tmp_path):
    """Exact FRFs of the 6-DOF chain choose m = 6 (the test above); with --m-max 3 no
    order above 3 is tried, so the model written has m ≤ 3."""
    chain, path = uff_file
    out = tmp_path / "out"
    argv = ["identify", str(path), "--band-hz", "5", "200", "--m-max", "3", "--no-progress",
            "--out", str(out)]
    assert main(argv) == 0
    model, _ = load_model(out / "model.npz")
    assert 1 <= model.m <= 3

def test_identify_time_histories_with_lambda_and_physical(tmp_path, capsys):
    system = mass_spring_chain(4, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    x, Y, _, r = periodic_test(system, [0, 2], r=2**14)
    data = tmp_path / "shaker.npz"
    np.savez(data, forces=x, responses=np.fft.irfft(Y, n=r, axis=0), dt=1 / 256, inputs=[0, 2])
    out = tmp_path / "out"
    argv = ["identify", str(data), "--band-hz", "2", "60", "--energy", "0.9999"]
    status = main([*argv, "--lam", "1e3", "--physical", "--paper-estimator", "--out", str(out)])
    assert status == 0
    stdout = capsys.readouterr().out
    assert "λ = 1000, 1000, 1000" in stdout and "physical correction" in stdout
    model, _ = load_model(out / "model.npz")
    rep = model.info["physical"]
    assert model.residual_norm == rep["residual_after"] < 1.05 * rep["residual_before"]
    # the summary quotes the correction's change of residual, after against before
    before, after = rep["residual_before"], rep["residual_after"]
    change = 100 * (after / before - 1)
    assert f"residual {before:.4g} → {after:.4g} ({change:+.2f} %)" in stdout
    assert "→ written model" in stdout  # made physical: not the paper's estimator itself
    for X in (model.M, model.C, model.K):
        assert np.array_equal(X, X.T)
    assert np.linalg.eigvalsh(model.M).min() > 0 and np.linalg.eigvalsh(model.K).min() > 0
    assert (out / "frf_input2.png").read_bytes()[:8] == PNG
    # the stabilisation chart fits as the command does: every order made physical
    assert {r["physical"] for r in read_rows(out / "stabilisation.csv")} == {"True"}
    # ... with the command's λ: at the chosen order the chart's model is the one written
    # (the same fit of the same data, so equal to round-off: 1e-9)
    chosen = [float(r["f_hz"]) for r in read_rows(out / "stabilisation.csv")
              if r["chosen"] == "True"]
    written = [float(r["f_hz"]) for r in read_rows(out / "modes.csv")]
    assert chosen and np.allclose(sorted(chosen), sorted(written), rtol=1e-9)


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--m", "2", "--energy", "0.9"], "not allowed with"),
        (["--m", "0"], "positive integer"),
        (["--lam", "1", "2"], "one value or three"),
        (["--band-hz", "50", "10"], "LO < HI"),
        (["--physical"], "physical by construction"),
        (["--m", "3", "--m-max", "5"], "--m-max bounds the order sweep"),
    ],
)
def test_identify_usage_errors_exit_2(uff_file, tmp_path, capsys, extra, message):
    _, path = uff_file
    argv = ["identify", str(path), "--band-hz", "5", "200", "--out", str(tmp_path / "o")]
    with pytest.raises(SystemExit) as exc:
        main([*argv, *extra])
    assert exc.value.code == 2 and message in capsys.readouterr().err


@pytest.mark.parametrize(
    "data,extra,message",
    [
        ("absent.uff", [], "no such UFF file"),
        (None, ["--band-hz", "10", "10.5"], "keeps 1 of"),
        # an order with more free parameters than the data have equations
        (None, ["--m", "500"], "free parameters, more than the"),
        ("notes.txt", [], "unknown data format"),
    ],
)
def test_identify_data_errors_exit_1(uff_file, tmp_path, capsys, data, extra, message):
    _, path = uff_file
    if data is not None:
        path = tmp_path / data
        if data.endswith(".txt"):
            path.write_text("hello")
    argv = ["identify", str(path), "--band-hz", "5", "200", "--out", str(tmp_path / "o"), *extra]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert err.startswith("podid-rs identify: error:") and message in err


def test_identify_runs_as_a_module(uff_file, tmp_path):
    _, path = uff_file
    out = tmp_path / "out"
    argv = ["identify", str(path), "--band-hz", "5", "200", "--energy", "0.99", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "podid_rs", *argv], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert "- order: m = " in proc.stdout and (out / "model.npz").is_file()


def test_identify_writes_the_intervals_of_the_refined_model(uff_file, tmp_path, capsys):
    """± columns in modes.csv and modes.md, one summary line; the paper's estimator alone
    has none (its covariance is not the refined model's)."""
    chain, path = uff_file
    out = tmp_path / "out"
    assert main(["identify", str(path), "--band-hz", "5", "200", "--m", "6",
                 "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert "- intervals: 95 % intervals from the sandwich covariance" in stdout
    rows = read_rows(out / "modes.csv")
    assert all(key in rows[0] for key in ("f_hz_pm95", "zeta_pm95"))
    for r in rows:
        if r["kind"] == "structural":  # exact data: intervals at round-off, but there
            assert 0 <= float(r["f_hz_pm95"]) < 1e-6 * float(r["f_hz"])
    assert "f_hz_pm95" in (out / "modes.md").read_text()
    # the noise of measured FRFs (per channel over the neighbouring lines, as the FRF band
    # takes it), and the typical interval over the structure's modes alone: here fewer
    # than every mode of the table (the others are residual terms above the band)
    assert "noise estimated from the residuals, per channel (DOF and load case), over the " \
        "neighbouring lines" in stdout
    structural = [r for r in rows if r["kind"] == "structural"]
    assert 0 < len(structural) < len(rows)
    assert f"median half-width over {len(structural)} mode(s)" in stdout
    plain = tmp_path / "plain"
    assert main(["identify", str(path), "--band-hz", "5", "200", "--m", "6",
                 "--paper-estimator", "--out", str(plain)]) == 0
    assert "- intervals" not in capsys.readouterr().out
    assert "f_hz_pm95" not in read_rows(plain / "modes.csv")[0]


def test_identify_a_single_driving_point_frf(tmp_path, capsys):
    """One sensor at the driving point: the model gets latent coordinates, every file but
    the MAC (a shape of one entry has none) is written, and the chain's four modes are in
    the table."""
    chain = mass_spring_chain(4, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    freq = np.arange(1.0, 51.0, 0.05)
    H = chain.frf(2 * np.pi * freq, rows=[0], cols=[0])
    path = write_uff(tmp_path / "point.uff", freq, H, [(1, 1)], [(1, 1)])
    out = tmp_path / "out"
    assert main(["identify", str(path), "--band-hz", "1", "50", "--out", str(out),
                 "--no-progress"]) == 0
    stdout = capsys.readouterr().out
    # one sensor: one POD mode observed, the rest of the chosen order latent
    m = load_model(out / "model.npz")[0].m
    assert m > 1 and (f"- coordinates: 1 observed (the POD modes of the 1 measured DOFs) "
                      f"and {m - 1} latent") in stdout
    assert not (out / "mac.png").exists() and (out / "stabilisation.png").exists()
    f_true = np.sort(modal_parameters(chain).frequencies_hz)
    f = [float(r["f_hz"]) for r in read_rows(out / "modes.csv") if r["kind"] == "structural"]
    assert len(f) == 4 and np.allclose(np.sort(f), f_true, rtol=1e-3)


def test_overlay_entries_are_those_of_r_h_rt():
    """The overlays' model FRF (the response to the one load Rᵀ e_col) is the
    (rows, col) entries of R H_m(ω) Rᵀ."""
    from types import SimpleNamespace

    from podid_rs.apps.identify import _model_frf

    chain = mass_spring_chain(5)
    model = SimpleNamespace(system=lambda: chain)  # what _model_frf asks of a model
    R = np.linalg.qr(np.random.default_rng(0).standard_normal((8, 5)))[0]
    w = np.linspace(1.0, 50.0, 300)
    full = np.einsum("am,smk,bk->sab", R, chain.frf(w), R)
    np.testing.assert_allclose(_model_frf(model, R, w, [0, 7], 3), full[:, [0, 7], 3],
                               rtol=1e-12, atol=1e-12 * np.abs(full).max())


def test_run_identify_refuses_an_order_and_an_energy_together(uff_file, tmp_path):
    from podid_rs.apps.identify import run_identify

    _, path = uff_file
    with pytest.raises(ValueError, match="give the reduced order m or the energy fraction, "
                                         "not both"):
        run_identify(path, tmp_path / "o", band_hz=(5.0, 200.0), m=2, energy=0.9,
                     progress=False)


def test_frf_errors_are_those_of_r_h_rt_at_the_driven_columns(uff_file, tmp_path):
    """The summary's median and 95th percentile |dB|: the model's FRF R H_m R[inputs]ᵀ
    (by the full FRF here, by one response per load case in the run) against the measured
    FRFs, over every line and entry. m = 3 < 6: errors of order 1 dB, not round-off.
    Tolerance: the two ways solve the same systems, round-off apart (1e-9 relative)."""
    from podid_rs.apps.identify import run_identify

    _, path = uff_file
    run = run_identify(path, tmp_path / "o", band_hz=(5.0, 200.0), m=3, paper_estimator=True,
                       progress=False)
    d, model = run.data, run.least_squares
    R = run.basis[:, : model.m]
    X = np.einsum("am,smk,bk->sab", R, model.system().frf(d.omega), R[[1, 4]])
    e = np.abs(20 * np.log10(np.abs(X) / np.abs(d.U)))
    median, p95 = run.frf_errors(model)
    assert median == pytest.approx(np.median(e), rel=1e-9)
    assert p95 == pytest.approx(np.percentile(e, 95), rel=1e-9)
    assert median < p95  # not a degenerate spread
    # the residual's ‖y‖ = ‖R[inputs]ᵀ F‖, the rows of the driven DOFs 2 and 5 (at m = 3 < 6
    # the rows of R differ in norm: the first two DOFs' would give another ratio)
    y = np.linalg.norm(np.einsum("bm,sbp->smp", R[[1, 4]], d.F))
    assert abs(np.linalg.norm(R[:2]) / np.linalg.norm(R[[1, 4]]) - 1) > 0.01
    assert f"({model.residual_norm / y:.3g} of ‖y‖)" in run.summary()


def test_the_chart_shows_the_written_model_at_the_chosen_order(uff_file, tmp_path):
    """At m = 4 the final fit on every line changes the sweep's fit of that order; the
    stabilisation chart's row for the chosen order is the model written. Both rows come
    from the same eigenvalue solve of the same matrices: equal to round-off (1e-12)."""
    from podid_rs.apps.identify import run_identify

    _, path = uff_file
    out = tmp_path / "out"
    run = run_identify(path, out, band_hz=(5.0, 200.0), m=4, progress=False)
    swept = {fit.m: fit.model for fit in run.sweep.fits}[4]
    assert not np.allclose(swept.K, run.result.K, rtol=1e-9, atol=0)  # the refit was kept
    chosen = [r for r in read_rows(out / "stabilisation.csv") if r["chosen"] == "True"]
    assert {r["m"] for r in chosen} == {"4"}
    written = [float(r["f_hz"]) for r in read_rows(out / "modes.csv")]
    assert np.allclose(sorted(float(r["f_hz"]) for r in chosen), sorted(written), rtol=1e-12)
    # the summary's FRF-error line quotes each model's own errors, and they differ here
    errors = [run.frf_errors(model) for model in (run.least_squares, run.result)]
    assert errors[0] != errors[1]
    (med_ls, p95_ls), (med, p95) = errors
    assert (f"paper's estimator {med_ls:.2f} / {p95_ls:.1f} dB" in run.summary()
            and f"refined model {med:.2f} / {p95:.1f} dB" in run.summary())
    # ... and each model's own equation-error ratio ‖Z(ω) U_m − F_m‖ / ‖F_m‖ (computed
    # here from its dynamic stiffness; the same products in another order, 1e-9), which
    # differ at m = 4 (at full order both are round-off)
    d = run.data
    U_m, F_m = d.project(run.basis[:, :4])
    ratios = []
    for model in (run.least_squares, run.result):
        Z = model.system().dynamic_stiffness(d.omega)
        residual = np.linalg.norm(np.einsum("sij,sjp->sip", Z, U_m) - F_m)
        assert model.residual_norm == pytest.approx(residual, rel=1e-9)
        ratios.append(f"{model.residual_norm / np.linalg.norm(F_m):.3g}")
    assert ratios[0] != ratios[1]
    assert f"paper's estimator {ratios[0]}, refined model {ratios[1]}" in run.summary()


def test_the_paper_estimator_keeps_99_percent_of_the_energy_by_default(uff_file, tmp_path):
    from podid_rs.apps.identify import run_identify

    _, path = uff_file
    run = run_identify(path, tmp_path / "o", band_hz=(5.0, 200.0), paper_estimator=True,
                       progress=False)
    pod = run.data.pod()
    assert pod.order_for_energy(0.9) < pod.order_for_energy(0.99)  # the default shows
    assert run.result.m == pod.order_for_energy(0.99)


def test_frf_errors_and_the_residual_ratio_of_forces_that_are_not_unit_loads(tmp_path):
    """Random forces on DOFs 2 and 5 in three load cases (saved data, not FRFs: F is not
    I, and n_in = 2 ≠ p = 3), m = 3 < 6: the errors are those of R H_m R[inputs]ᵀ F
    against U, and the residual's ‖y‖ is ‖R[inputs]ᵀ F‖, both from the full FRF of the
    reduced model here. Tolerance as above (1e-9 relative); the ratio to its 3 digits."""
    from podid_rs.apps.identify import run_identify
    from podid_rs.io.npz import save_data
    from podid_rs.measured import MeasuredData

    chain = mass_spring_chain(6)
    rng = np.random.default_rng(5)
    omega = 2 * np.pi * np.arange(5.0, 201.0, 1.0)
    F = rng.standard_normal((omega.size, 2, 3)) + 1j * rng.standard_normal((omega.size, 2, 3))
    Fn = np.zeros((omega.size, 6, 3), dtype=complex)
    Fn[:, [1, 4]] = F
    data = MeasuredData(omega, chain.response(omega, Fn), F, inputs=[1, 4])
    path = save_data(tmp_path / "random.npz", data)
    run = run_identify(path, tmp_path / "o", band_hz=(5.0, 200.0), m=3, paper_estimator=True,
                       progress=False)
    d, model = run.data, run.least_squares
    assert not d.is_frf and d.F.shape[1:] == (2, 3) and d.inputs.tolist() == [1, 4]
    R = run.basis[:, :3]
    X = np.einsum("am,smk,bk,sbp->sap", R, model.system().frf(d.omega), R[[1, 4]], d.F)
    e = np.abs(20 * np.log10(np.abs(X) / np.abs(d.U)))
    median, p95 = run.frf_errors(model)
    assert median == pytest.approx(np.median(e), rel=1e-9)
    assert p95 == pytest.approx(np.percentile(e, 95), rel=1e-9)
    y = np.linalg.norm(np.einsum("bm,sbp->smp", R[[1, 4]], d.F))
    assert f"({model.residual_norm / y:.3g} of ‖y‖)" in run.summary()
    # three load cases of forces on two driven DOFs, counted apart
    assert "6 measured DOFs, 3 load case(s), driven DOFs (node, dir) " in run.summary()
    # no measured FRF, and load cases that are not the driven DOFs: one overlay (the
    # model's response to the first driven DOF's unit force), not one per driven DOF
    assert [f.name for f in run.files if f.name.startswith("frf_input")] == ["frf_input1.png"]


def test_identify_with_holes_predicts_them_from_the_measured_entries(tmp_path):
    """The exact 6-DOF chain driven at DOFs 1 and 3, three of its twelve FRFs not measured
    (one a driving point), saved as a data set: the refined model at full order, fitted
    to the measured entries alone, reproduces the chain's FRFs at the holes too. A fit
    that read the holes as zero responses would pull the model towards zero there.
    Tolerance: exact data in doubles; the fit stops at ~1e-12 relative, asserted 1e-8."""
    from podid_rs.apps.identify import run_identify
    from podid_rs.io.npz import save_data
    from podid_rs.measured import from_frf

    chain = mass_spring_chain(6, m1=1.0, m2=1.0)
    w = 2 * np.pi * np.arange(5.0, 250.0, 1.0)
    mask = np.ones((6, 2), dtype=bool)
    holes = ((5, 0), (2, 1), (0, 1))
    for j, k in holes:
        mask[j, k] = False
    data = from_frf(chain.frf(w)[:, :, [0, 2]], w, inputs=[0, 2], measured=mask)
    path = save_data(tmp_path / "holes.npz", data)
    run = run_identify(path, tmp_path / "o", band_hz=(5.0, 249.0), m=6, progress=False)
    R = run.basis
    P = np.einsum("am,smk,bk->sab", R, run.result.system().frf(run.data.omega), R[[0, 2]])
    truth = chain.frf(run.data.omega)[:, :, [0, 2]]
    for j, k in holes:
        assert np.abs(P[:, j, k] - truth[:, j, k]).max() < 1e-8 * np.abs(truth[:, j, k]).max()
    # the summary judges each model by its own poles: the paper's estimator (the holes read
    # as zeros in its projection) is unstable here, the refined model stable
    assert not modal_parameters(run.least_squares).stable and modal_parameters(run.result).stable
    med, p95 = run.frf_errors(run.result)
    text = run.summary()
    assert f"(unstable) → refined model {med:.2f} / {p95:.1f} dB (stable)" in text
    assert "- stable: yes" in text


def test_energy_sets_the_order_of_the_refined_model_and_of_the_paper_estimator(uff_file,
                                                                               tmp_path):
    """--energy reaches both paths: the sweep runs to the order that captures the energy
    asked (below 6, which the held-out lines choose unbounded, see above), and the paper's
    estimator is fitted at that order, not at its default 0.99's."""
    from podid_rs.apps.identify import run_identify

    _, path = uff_file
    run = run_identify(path, tmp_path / "r", band_hz=(5.0, 200.0), energy=0.999,
                       progress=False)
    pod = run.data.pod()
    k = pod.order_for_energy(0.999)
    assert k < 6 and run.result.m == k and run.sweep.reason == f"m = {k} as asked"
    paper = run_identify(path, tmp_path / "p", band_hz=(5.0, 200.0), energy=0.9,
                         paper_estimator=True, progress=False)
    assert pod.order_for_energy(0.9) < pod.order_for_energy(0.99)  # the energy shows
    assert paper.result.m == pod.order_for_energy(0.9)


def test_a_model_without_a_structural_mode_is_written_with_its_frfs(uff_file, tmp_path):
    """m = 1 of the 6-DOF chain (refined, no geometry in the file): the one pole pair is
    no mode of the structure, so model.uff holds no dataset 55, only the model's FRFs (one
    per measured DOF and driven DOF: 12); the sweep's one order leaves no other for a MAC."""
    pyuff = pytest.importorskip("pyuff")
    _, path = uff_file
    out = tmp_path / "out"
    assert main(["identify", str(path), "--band-hz", "5", "200", "--m", "1", "--no-progress",
                 "--out", str(out)]) == 0
    assert not [r for r in read_rows(out / "modes.csv") if r["kind"] == "structural"]
    sets = pyuff.UFF(str(out / "model.uff")).read_sets()
    assert [d["type"] for d in sets] == [58] * 12
    assert not (out / "mac.png").exists() and (out / "stabilisation.png").exists()


def test_a_latent_model_is_titled_by_its_own_order_and_quotes_the_papers_residual(tmp_path,
                                                                                monkeypatch):
    """One sensor at the driving point (as above): the refined model has latent coordinates
    (m > 1), the paper's estimator m = 1. The overlay's title gives the order of the model
    written, its curves are named by what each model is, and the residual line quotes the
    paper's estimator's ratio ‖Ax − y‖ / ‖y‖, here computed from its dynamic stiffness (the
    refined model has none defined: its latent coordinates have no measured response).
    Tolerance: the same products in another order, round-off apart (1e-9)."""
    from podid_rs.apps import identify as identify_module

    titles, labels = [], []

    def fake_overlay(freq, curves, path, *, title, entries):
        titles.append(title)
        labels.append([curve.label for curve in curves])
        return path

    monkeypatch.setattr(identify_module, "plot_frf_comparison", fake_overlay)
    chain = mass_spring_chain(4, m1=1.0, m2=1.0, ku=1e4, a0=2.0, a1=1e-3)
    freq = np.arange(1.0, 51.0, 0.05)
    path = write_uff(tmp_path / "point.uff", freq, chain.frf(2 * np.pi * freq, rows=[0],
                                                             cols=[0]), [(1, 1)], [(1, 1)])
    run = identify_module.run_identify(path, tmp_path / "o", band_hz=(1.0, 50.0),
                                       progress=False)
    ls, d = run.least_squares, run.data
    assert ls.m == 1 < run.result.m
    assert titles and all(t.endswith(f", m = {run.result.m}") for t in titles)
    # the curves are named by the model written (refined), beside the paper's estimator
    assert labels == [["measured", "paper's estimator (eq. 49)", "refined (output error)"]]
    U_m, F_m = d.project(run.basis[:, :1])
    Z = ls.system().dynamic_stiffness(d.omega)
    residual = np.linalg.norm(np.einsum("sij,sjp->sip", Z, U_m) - F_m)
    assert ls.residual_norm == pytest.approx(residual, rel=1e-9)
    assert (f"paper's estimator {ls.residual_norm / np.linalg.norm(F_m):.3g}; not defined "
            "for the refined model") in run.summary()


def test_progress_reaches_the_sweeps_bar_the_final_fit_and_the_chart(uff_file, tmp_path,
                                                                    monkeypatch):
    """progress=False and True each reach the sweep's bar, the final fit and the
    stabilisation chart (the last two default to False and True: a call that left the
    option out would show in one of the two runs)."""
    import inspect

    from podid_rs.apps import identify as identify_module

    seen = []

    def spy(name, real):
        def call(*args, **kwargs):
            bound = inspect.signature(real).bind(*args, **kwargs)
            bound.apply_defaults()
            seen.append((name, bound.arguments["progress"]))
            return real(*args, **kwargs)
        return call

    class Bar(identify_module._SweepBar):
        def __init__(self, enabled):
            seen.append(("sweep", enabled))
            super().__init__(enabled)

    monkeypatch.setattr(identify_module, "_SweepBar", Bar)
    for name in ("final_fit", "stabilisation_chart"):
        monkeypatch.setattr(identify_module, name, spy(name, getattr(identify_module, name)))
    _, path = uff_file
    for progress in (False, True):  # off a terminal no bar is drawn either way
        seen.clear()
        identify_module.run_identify(path, tmp_path / f"o{progress}", band_hz=(5.0, 200.0),
                                     m=2, progress=progress)
        assert seen == [("sweep", progress), ("final_fit", progress),
                        ("stabilisation_chart", progress)]
