"""The step solvers of the output-error refinement: dense and matrix-free agree."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from podid_rs import SecondOrderSystem, identify, mass_spring_chain
from podid_rs.identification.refinement import db_errors, physical_start, refine


def chain_data(m: int, s: int, p: int, noise: float, seed: int = 0):
    """Full-order chain, p random load cases over 5–200 Hz, complex noise on U."""
    sys_ = mass_spring_chain(m)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, s)
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((s, m, p)) + 1j * rng.standard_normal((s, m, p))
    U = sys_.response(omega, F)
    U = U + noise * np.sqrt(np.mean(np.abs(U) ** 2) / 2) * (
        rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)
    )
    return sys_, U, F, omega


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def assert_same_minimum(d, f) -> None:
    """The dense step's answer d and another step's f: the same least-squares minimum
    (costs to 1e-9, models to the data's resolution), f stable by construction."""
    cd, cf = d.info["refinement"]["cost"], f.info["refinement"]["cost"]
    assert abs(cd - cf) <= 1e-9 * cd
    assert cd < d.info["refinement"]["cost_start"]
    for a, b in ((d.M, f.M), (d.C, f.C), (d.K, f.K)):
        assert rel(b, a) < 1e-5
    for X in (f.M, f.K):
        assert np.linalg.eigvalsh(X).min() > 0
    assert np.linalg.eigvalsh(f.C).min() >= -1e-12 * np.abs(f.C).max()


def two_percent_off(sys_: SecondOrderSystem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, C, K with every entry ~2 % off, kept symmetric (seeded)."""
    rng = np.random.default_rng(3)

    def perturbed(X):
        d = 0.02 * rng.standard_normal(X.shape)
        return X * (1 + d + d.T)

    return perturbed(sys_.M), perturbed(sys_.C), perturbed(sys_.K)


def test_noise_free_data_give_the_exact_model_back_with_the_matrix_free_step():
    sys_, U, F, omega = chain_data(5, 60, 2, 0.0)
    start = two_percent_off(sys_)
    res = refine(start, U, F, omega, solver="matrix-free", ftol=1e-12)
    rep = res.info["refinement"]
    assert rep["solver"] == "matrix-free"
    assert rep["converged"], rep["stop"]
    assert rep["solver_stats"]["products"] > 0
    for X, T in ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K)):
        assert rel(X, T) < 1e-8


@pytest.mark.parametrize("solver", ["dense", "matrix-free"])
def test_the_parametrisations_curvature_keeps_noise_free_data_exact(solver):
    # curvature=True (what the order sweep and the final fit use) adds a term of the
    # order of the residual: it must not stop the iteration short of the exact model
    sys_, U, F, omega = chain_data(5, 60, 2, 0.0)
    start = two_percent_off(sys_)
    plain = refine(start, U, F, omega, solver=solver, ftol=1e-12)
    res = refine(start, U, F, omega, solver=solver, ftol=1e-12, curvature=True)
    rep = res.info["refinement"]
    assert rep["converged"], rep["stop"]
    assert rep["cost"] < 1e-20 * rep["cost_start"]
    for X, T in ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K)):
        assert rel(X, T) < 1e-8
    # the same answer as Gauss–Newton alone, by another path
    assert plain.info["refinement"]["converged"]
    assert rel(res.K, plain.K) < 1e-8


@pytest.mark.parametrize("weights", ["relative", "uniform"])
def test_dense_and_matrix_free_steps_reach_the_same_model(weights):
    sys_, U, F, omega = chain_data(4, 80, 2, 1e-3, seed=1)
    start = identify(U, F, omega, symmetric=True)
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the start may be made physical
        for solver in ("dense", "matrix-free"):
            res = refine(start, U, F, omega, weights=weights, solver=solver, ftol=1e-10,
                         max_iter=400)  # fmt: skip
            assert res.info["refinement"]["solver"] == solver
            assert res.info["refinement"]["converged"], res.info["refinement"]["stop"]
            out[solver] = res
    d, f = out["dense"], out["matrix-free"]
    assert_same_minimum(d, f)


def test_auto_solves_small_orders_densely_and_bad_names_are_refused():
    sys_, U, F, omega = chain_data(3, 40, 1, 1e-3)
    start = (sys_.M, sys_.C, sys_.K)
    res = refine(start, U, F, omega)
    assert res.info["refinement"]["solver"] == "dense"
    with pytest.raises(ValueError, match="solver"):
        refine(start, U, F, omega, solver="lsqr")


def test_reported_db_errors_are_those_of_the_start_and_the_answer():
    sys_, U, F, omega = chain_data(4, 50, 2, 5e-2, seed=2)
    start = identify(U, F, omega, symmetric=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = refine(start, U, F, omega, solver="matrix-free")
        (M1, C1, K1), _ = physical_start(start.M, start.C, start.K)
    rep = res.info["refinement"]
    for (Mx, Cx, Kx), key in (((M1, C1, K1), "db_before"), ((res.M, res.C, res.K), "db_after")):
        e = db_errors(SecondOrderSystem(Mx, Cx, Kx).response(omega, F), U)
        assert rep[key] == pytest.approx((np.median(e), np.percentile(e, 95)), rel=1e-8)


def test_the_modal_metric_reaches_the_exact_model_in_fewer_steps():
    # metric="modal": LM damped and CG preconditioned in the current model's modes, each
    # step taken in X = L Lᵀ — on noise-free data the exact model, for a fifth of the work
    # of μ·diag N (measured: 22–23 steps and 107–139 Gauss–Newton products against 24
    # steps and 697–747 products; runs differ in the order of parallel sums)
    sys_, U, F, omega = chain_data(5, 60, 2, 0.0)
    start = two_percent_off(sys_)
    diag = refine(start, U, F, omega, solver="matrix-free", metric="diagonal", ftol=1e-12)
    res = refine(start, U, F, omega, metric="modal", ftol=1e-12)
    rep = res.info["refinement"]
    assert rep["solver"] == "matrix-free" and rep["metric"] == "modal"
    assert diag.info["refinement"]["metric"] == "diagonal"
    assert rep["converged"], rep["stop"]
    for X, T in ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K)):
        assert rel(X, T) < 1e-8
        # the modal step works in the start's damping modes V and turns the model back,
        # V X' Vᵀ, a product symmetric only to rounding: the result (symmetric=True) is
        # symmetric bit for bit, as the dense step's
        assert np.array_equal(X, X.T)
    assert res.symmetric
    work = rep["solver_stats"]["products"]
    assert work < diag.info["refinement"]["solver_stats"]["products"] / 2


def test_the_modal_metric_reaches_the_dense_steps_minimum_on_noisy_data():
    sys_, U, F, omega = chain_data(4, 80, 2, 1e-3, seed=1)
    start = identify(U, F, omega, symmetric=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the start may be made physical
        d = refine(start, U, F, omega, solver="dense", ftol=1e-10, max_iter=400)
        f = refine(start, U, F, omega, metric="modal", ftol=1e-10, max_iter=400)
    assert f.info["refinement"]["converged"], f.info["refinement"]["stop"]
    assert_same_minimum(d, f)


def test_the_default_metric_is_modal_where_the_step_is_matrix_free():
    # metric="auto": the modal metric for a matrix-free step (its own steps reported),
    # the dense step (chosen by solver="auto" at small m) as it was
    sys_, U, F, omega = chain_data(4, 60, 2, 1e-3, seed=2)
    start = two_percent_off(sys_)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # max_iter = 5: not converged, nor meant to
        free = refine(start, U, F, omega, solver="matrix-free", max_iter=5)
        dense = refine(start, U, F, omega, max_iter=5).info["refinement"]
    rep = free.info["refinement"]
    assert rep["solver"] == "matrix-free" and rep["metric"] == "modal"
    assert rep["solver_stats"]["x_steps"] + rep["solver_stats"]["factor_steps"] >= 1
    assert dense["solver"] == "dense" and dense["metric"] == "dense"


def test_auto_reports_the_matrix_free_step_it_takes_past_order_40():
    """solver="auto" solves densely up to m = 40 and matrix-free above: the report names
    the step the core took and its metric (the modal one by default), not the "auto"
    that was asked for. Two steps of a 41-mass chain: what was solved, not how well."""
    sys_, U, F, omega = chain_data(41, 30, 1, 0.0)
    start = two_percent_off(sys_)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # max_iter = 2: not converged, nor meant to
        rep = refine(start, U, F, omega, max_iter=2).info["refinement"]
    assert rep["solver"] == "matrix-free" and rep["metric"] == "modal"


def test_a_bad_metric_is_refused_by_name():
    sys_, U, F, omega = chain_data(3, 40, 1, 1e-3)
    start = (sys_.M, sys_.C, sys_.K)
    with pytest.raises(ValueError, match="metric"):
        refine(start, U, F, omega, metric="euclid")
    with pytest.raises(ValueError, match="matrix-free"):
        refine(start, U, F, omega, metric="modal", solver="dense")
