"""solver="cg": the matrix-free path gives the direct path's answer, and says when it cannot.

The chain at full order (R = I) with random forces on every DOF and s = 2m lines
is the benchmark's problem; "narrow" is the paper's 20 % band, "wide" 50–150 Hz.
The direct answer is the reference: CG must match it to 1e-8 relative at the
default tol (the tol was chosen for that with a margin, see ``CG_TOL``).
"""

from __future__ import annotations

import io
import sys
import warnings

import numpy as np
import pytest

from podid_rs import ConvergenceWarning, identify, mass_spring_chain
from podid_rs.identification.solvers import (
    AUTO_DIRECT_MAX_UNKNOWNS,
    CG_MAX_ITER,
    CG_TOL,
    _ProgressBar,
    choose_solver,
)

BANDS = {"narrow": (102.8, 122.8), "wide": (50.0, 150.0)}


def chain(m: int, band: str, noise: float = 0.0, seed: int = 0):
    rng = np.random.default_rng(seed)
    sys_ = mass_spring_chain(m)
    omega = 2 * np.pi * np.linspace(*BANDS[band], 2 * m)
    F = rng.standard_normal((2 * m, m)) + 1j * rng.standard_normal((2 * m, m))
    U = sys_.response(omega, F)
    if noise:
        scale = noise * np.sqrt(np.mean(np.abs(U) ** 2, axis=0, keepdims=True))
        U = U + scale * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape))
    return sys_, U, F, omega


def max_rel(a, b) -> float:
    return max(
        float(np.linalg.norm(getattr(a, k) - getattr(b, k)) / np.linalg.norm(getattr(b, k)))
        for k in "MCK"
    )


# (m, lam, symmetric): exact-symmetric up to m = 60; the penalty form (3m² unknowns,
# a dense matrix of 0.9 GB at m = 60) up to 40, at the paper's λ and at a λ small
# enough that the penalty and the data term are of one size.
MODES = [
    (10, 0.0, True),
    (30, 0.0, True),
    (60, 0.0, True),
    (12, 100.0, False),
    (25, 1e-3, False),
    (40, 100.0, False),
]


@pytest.mark.parametrize("noise", [0.0, 0.05], ids=["noise-free", "noisy"])
@pytest.mark.parametrize("band", list(BANDS))
@pytest.mark.parametrize("m,lam,symmetric", MODES, ids=lambda v: str(v))
def test_cg_equals_direct(m, lam, symmetric, band, noise):
    _, U, F, omega = chain(m, band, noise, seed=m)
    direct = identify(U, F, omega, lam, symmetric, solver="direct")
    cg = identify(U, F, omega, lam, symmetric, solver="cg")
    assert direct.method == "cholesky" and cg.method == "cg"
    assert cg.relative_residual <= CG_TOL and cg.info["converged"]
    assert 0 < cg.iterations < 2000
    assert max_rel(cg, direct) < 1e-8
    # noise-free, both misfits are rounding: compare them on the scale of F
    fit = pytest.approx(direct.residual_norm, rel=1e-6, abs=1e-8 * np.linalg.norm(F))
    assert cg.residual_norm == fit
    if symmetric:
        for X in (cg.M, cg.C, cg.K):
            assert np.array_equal(X, X.T)


def test_noise_free_chain_is_recovered():
    sys_, U, F, omega = chain(50, "narrow")
    res = identify(U, F, omega, symmetric=True, solver="cg")
    for X, T in ((res.M, sys_.M), (res.C, sys_.C), (res.K, sys_.K)):
        assert np.linalg.norm(X - T) / np.linalg.norm(T) < 1e-7


def test_threads_do_not_change_the_answer():
    _, U, F, omega = chain(30, "wide", 0.05)
    a = identify(U, F, omega, 100.0, solver="cg", threads=1)
    b = identify(U, F, omega, 100.0, solver="cg", threads=2)
    assert a.iterations == b.iterations
    assert max_rel(a, b) < 1e-10


def test_iteration_limit_warns_with_the_achieved_residual():
    _, U, F, omega = chain(20, "wide", 0.05)
    with pytest.warns(ConvergenceWarning, match=r"after 3 iterations at relative residual") as w:
        res = identify(U, F, omega, 100.0, solver="cg", max_iter=3)
    assert res.iterations == 3 and res.relative_residual > CG_TOL
    assert not res.info["converged"]
    assert f"{res.relative_residual:.2e}" in str(w[0].message)
    assert np.all(np.isfinite(res.M))


def test_converged_solve_does_not_warn():
    _, U, F, omega = chain(15, "narrow")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        identify(U, F, omega, symmetric=True, solver="cg")


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"tol": 0.0}, "tol"),
        ({"tol": 1.0}, "tol"),
        ({"tol": -1e-8}, "tol"),
        ({"tol": float("nan")}, "tol"),
        ({"tol": "small"}, "tol"),
        ({"max_iter": 0}, "max_iter"),
        ({"max_iter": -5}, "max_iter"),
        ({"max_iter": 2.5}, "max_iter"),
        ({"max_iter": True}, "max_iter"),
        ({"solver": "gmres"}, "solver"),
        ({"progress": "yes"}, "progress"),
        ({"backend": "numpy", "solver": "cg"}, "backend='rust'"),
    ],
)
def test_bad_cg_options_raise(kwargs, match):
    _, U, F, omega = chain(6, "narrow")
    with pytest.raises(ValueError, match=match):
        identify(U, F, omega, 1.0, **kwargs)


def test_auto_rule():
    # unregularised: one 3m×3m system, direct at any size
    assert choose_solver(400, (0.0, 0.0, 0.0), False) == "direct"
    # up to AUTO_DIRECT_MAX_UNKNOWNS unknowns: direct
    assert 3 * 10 * 10 <= AUTO_DIRECT_MAX_UNKNOWNS < 3 * 11 * 11
    assert choose_solver(10, (1.0, 1.0, 1.0), False) == "direct"
    assert choose_solver(11, (1.0, 1.0, 1.0), False) == "cg"
    assert choose_solver(13, (0.0, 0.0, 0.0), True) == "direct"  # 3·13·14/2 = 273
    assert choose_solver(14, (0.0, 0.0, 0.0), True) == "cg"  # 315
    _, U, F, omega = chain(30, "narrow")
    assert identify(U, F, omega, 100.0).method == "cg"
    assert identify(U, F, omega, 100.0, backend="numpy").method == "cholesky"
    assert identify(U, F, omega, 0.0).method == "cholesky"


def test_auto_redoes_a_stalled_cg_by_the_direct_path():
    # two load cases at m = 16, exact-symmetric (408 unknowns: CG by the rule): the
    # normal equations are singular, CG stalls far above tol and cannot say why
    sys_ = mass_spring_chain(16)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, 64)
    F = np.zeros((64, 16), complex)
    F[:, [3, 9]] = np.random.default_rng(1).standard_normal((64, 2))
    U = sys_.response(omega, F)
    assert choose_solver(16, (0.0, 0.0, 0.0), True) == "cg"
    with pytest.warns(ConvergenceWarning) as caught:
        cg = identify(U, F, omega, symmetric=True, solver="cg")
    assert cg.relative_residual > 1e-6
    # the warning counts the iterations CG took, far fewer than it was allowed
    assert cg.iterations < CG_MAX_ITER
    assert f"CG stopped after {cg.iterations} iterations" in str(caught[0].message)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        auto = identify(U, F, omega, symmetric=True)
    assert [type(w.message).__name__ for w in caught] == ["RankDeficientWarning"]
    assert auto.method == "eigen-min-norm" and not auto.well_posed and auto.rank < 408
    assert auto.info["stalled_cg"]["iterations"] == cg.iterations
    assert auto.info["stalled_cg"]["relative_residual"] == cg.relative_residual
    # a well-posed problem of the same size: CG, no fallback
    _, U, F, omega = chain(16, "narrow")
    res = identify(U, F, omega, symmetric=True)
    assert res.method == "cg" and "stalled_cg" not in res.info


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_is_drawn_on_a_terminal_and_quiet_elsewhere(monkeypatch, capsys):
    _, U, F, omega = chain(20, "narrow")
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    res = identify(U, F, omega, symmetric=True, solver="cg", progress=True)
    err = term.getvalue()
    assert "CG: 100%" in err and f"iteration {res.iterations}," in err and err.endswith("\n")
    monkeypatch.undo()
    identify(U, F, omega, symmetric=True, solver="cg", progress=True)
    assert capsys.readouterr().err == ""  # not a terminal: no bar


def test_progress_callback_sees_the_last_iteration():
    _, U, F, omega = chain(20, "wide")
    calls = []
    res = identify(U, F, omega, symmetric=True, solver="cg", progress=lambda *a: calls.append(a))
    assert calls and calls[-1][0] == res.iterations
    assert [c[0] for c in calls] == sorted({c[0] for c in calls})
    assert all(np.isfinite(r) and r > 0 for _, r in calls)


def test_exception_in_progress_callback_propagates():
    _, U, F, omega = chain(20, "wide")

    def callback(iteration: int, residual: float) -> None:
        raise ZeroDivisionError("from the callback")

    with pytest.raises(ZeroDivisionError, match="from the callback"):
        identify(U, F, omega, symmetric=True, solver="cg", progress=callback)


@pytest.mark.parametrize("m, band", [(20, "wide"), (30, "wide"), (30, "narrow")])
@pytest.mark.parametrize("symmetric, lam", [(True, 0.0), (False, 100.0)])
def test_unattainable_tol_stops_at_the_attainable_accuracy(m, band, symmetric, lam):
    # the true residual stops following the recursive one near 1e-14: CG notices
    # and stops there, with its best iterate, instead of running to max_iter
    # (measured: 207-529 iterations, residual 8e-15-3e-14; a stall rule that relied
    # on the recursive residual ran all 20 000 and some diverged to 1e-4)
    _, U, F, omega = chain(m, band)
    with pytest.warns(ConvergenceWarning, match="above tol"):
        res = identify(U, F, omega, lam, symmetric, solver="cg", tol=1e-300, max_iter=20_000)
    assert res.iterations < 2000 and res.relative_residual < 1e-12
    converged = identify(U, F, omega, lam, symmetric, solver="cg")
    assert res.relative_residual <= converged.relative_residual


def test_cg_at_its_iteration_cap_is_not_redone_as_stalled():
    """CG that used every allowed iteration did not stall (it was stopped): auto keeps its
    answer and warns, naming the iterations it took and the residual it reached."""
    _, U, F, omega = chain(16, "narrow")
    with pytest.warns(ConvergenceWarning, match=r"CG stopped after 3 iterations") as caught:
        res = identify(U, F, omega, symmetric=True, max_iter=3)
    assert res.method == "cg" and res.iterations == 3 and "stalled_cg" not in res.info
    assert f"{res.relative_residual:.2e}" in str(caught[0].message)


def test_progress_bar_fraction_is_the_residuals_decades_over_the_tolerances():
    """log(residual)/log(tol), clipped to [0, 1]: 1e-4 of a 1e-8 target is half way."""
    bar = _ProgressBar(1e-8)
    for residual, percent in ((1e-4, 50), (1.0, 0), (10.0, 0), (1e-2, 25), (1e-9, 100)):
        bar(1, residual)
        assert bar.bar.n == percent, residual
    bar.close(1, 1e-9)


def test_auto_rule_with_one_penalised_block():
    # one positive λ already needs the 3m² normal matrix: the size rule, as for three
    assert choose_solver(10, (0.0, 1.0, 0.0), False) == "direct"
    assert choose_solver(11, (0.0, 1.0, 0.0), False) == "cg"
    assert choose_solver(11, (2.0, 0.0, 0.0), False) == "cg"


def test_a_tol_given_is_the_tol_reported():
    """CG at tol = 1e-6, not the default: a converged run records it in its info, and a run
    stopped at max_iter records and quotes it."""
    _, U, F, omega = chain(20, "wide", 0.05)
    res = identify(U, F, omega, 100.0, solver="cg", tol=1e-6)
    assert res.info["converged"] and res.info["tol"] == 1e-6
    assert res.relative_residual <= 1e-6
    with pytest.warns(ConvergenceWarning, match=r"above tol = 1\.0e-06;"):
        stopped = identify(U, F, omega, 100.0, solver="cg", tol=1e-6, max_iter=3)
    assert stopped.info["tol"] == 1e-6 and not stopped.info["converged"]
