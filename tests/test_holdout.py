"""The order sweep's held-out lines: which they are, that the fit never sees them, and
the dB error that scores them (a known value computed by hand).

The sweep (:func:`podid_rs.identification.order.sweep_orders`) fits every order on
the training lines and scores it on the others. If a held-out line leaked into the
fit, the score would reward fitting noise. Here the held-out lines of the data are
replaced by garbage: every fitted model must stay the same, bit for bit (the fit is
deterministic on one thread), while the held-out score changes.
"""

from __future__ import annotations

import numpy as np
import pytest

import podid_rs as pr
from podid_rs.identification.order import HOLDOUT, final_fit, sweep_orders
from podid_rs.identification.refinement import db_errors


@pytest.fixture(scope="module")
def chain_frf():
    """Exact receptances of the 5-DOF chain, force at DOF 2, 120 lines over 10–200 Hz."""
    chain = pr.mass_spring_chain(5)
    w = 2 * np.pi * np.linspace(10.0, 200.0, 120)
    F_n = np.zeros((w.size, 5, 1), dtype=complex)
    F_n[:, 1, 0] = 1.0
    U_n = chain.response(w, F_n)
    return U_n, F_n, w, pr.pod_from_frf(U_n, w)


def test_every_holdout_th_line_is_held_out_starting_mid_group(chain_frf):
    U_n, F_n, w, P = chain_frf
    for holdout in (HOLDOUT, 3):
        sweep = sweep_orders(U_n, F_n, w, P, m=1, holdout=holdout, threads=1)
        expected = np.arange(w.size) % holdout == holdout // 2
        np.testing.assert_array_equal(sweep.test_lines, expected)
        assert sweep.reason == "m = 1 as asked"


def test_held_out_lines_do_not_reach_the_fit(chain_frf):
    U_n, F_n, w, P = chain_frf
    clean = sweep_orders(U_n, F_n, w, P, m_max=3, patience=3, threads=1)
    test = clean.test_lines
    rng = np.random.default_rng(7)
    garbage = U_n.copy()
    garbage[test] = 1e3 * (rng.standard_normal(U_n[test].shape)
                           + 1j * rng.standard_normal(U_n[test].shape))
    dirty = sweep_orders(garbage, F_n, w, P, m_max=3, patience=3, threads=1)
    np.testing.assert_array_equal(dirty.test_lines, test)
    assert [f.m for f in dirty.fits] == [f.m for f in clean.fits]
    for a, b in zip(clean.fits, dirty.fits, strict=True):
        for X, Y in ((a.model.M, b.model.M), (a.model.C, b.model.C), (a.model.K, b.model.K)):
            np.testing.assert_array_equal(X, Y)
        assert a.train_db == b.train_db and a.start == b.start
        # the garbage is what the held-out score sees: 1e3 against receptances ~1e-5
        assert b.test_db > a.test_db + 100.0


def test_db_error_of_known_ratios():
    U = np.array([1.0, 2j, -4.0, 0.5 + 0j, 3.0])
    # |X|/|U| = 10 or 1/10 is ±20 dB (to round-off); the phase plays no part
    assert db_errors(10 * U, U).tolist() == pytest.approx([20.0] * 5, rel=1e-14)
    assert db_errors(U / 10, U).tolist() == pytest.approx([20.0] * 5, rel=1e-14)
    assert db_errors(-1j * U, U).tolist() == [0.0] * 5
    assert db_errors(2 * U, U) == pytest.approx(20 * np.log10(2.0), rel=1e-14)  # 6.0206 dB
    # entries where either is zero are left out, the others keep their order
    X = np.array([10.0, 0.0, 0.4, 1.0, 3.0])
    U0 = np.array([1.0, 5.0, 4.0, 0.0, 3.0])
    assert db_errors(X, U0).tolist() == pytest.approx([20.0, 20.0, 0.0], rel=1e-14, abs=0)
    assert db_errors(np.zeros((2, 3)), np.ones((2, 3))).shape == (0,)
    # ratios beyond the float range: 1e300 against 1e-300 is 12 000 dB, not inf
    assert db_errors(np.array([1e300]), np.array([1e-300])) == pytest.approx(12000.0,
                                                                             rel=1e-14)


# --- a long test: the sweep fits the informative lines only ----------------------------


def test_lines_left_out_of_a_thinned_sweep_do_not_reach_the_fit(chain_frf, monkeypatch):
    # which lines are informative depends on every line's data (by design), so garbage
    # cannot be put on the others without moving them: here a spy records the lines
    # every refinement of the sweep is given
    import podid_rs.identification.order as order

    U_n, F_n, w, P = chain_frf
    seen = []
    real = order.refine

    def spy(start, U, F, omega, **kwargs):
        seen.append(np.asarray(omega).copy())
        return real(start, U, F, omega, **kwargs)

    monkeypatch.setattr(order, "refine", spy)
    sweep = sweep_orders(U_n, F_n, w, P, m=2, sweep_lines=40, threads=1)
    used, test = sweep.lines, sweep.test_lines
    assert 20 <= used.sum() <= 60 and used[0] and used[-1]
    assert not np.any(test & ~used)  # the held-out lines are among the used ones
    picked = np.flatnonzero(used)
    np.testing.assert_array_equal(np.flatnonzero(test),
                                  picked[np.arange(picked.size) % HOLDOUT == HOLDOUT // 2])
    assert seen
    for omega in seen:  # every refinement fits exactly the training lines
        np.testing.assert_array_equal(omega, w[used & ~test])


def test_final_fit_on_thinned_lines_is_judged_on_every_line(chain_frf):
    U_n, F_n, w, P = chain_frf
    sweep = sweep_orders(U_n, F_n, w, P, m=2, sweep_lines=40, threads=1)
    model, R = final_fit(sweep, U_n, F_n, w, P, threads=1)
    kept = model.info["refinement"]["final_refit"]
    assert kept["lines_fitted"] == int(sweep.lines.sum()) < w.size
    assert kept["reason"].endswith(f"both passes fitted the {kept['lines_fitted']} informative "
                                   f"lines of {w.size} (the median is over every line)")
    X = np.einsum("nm,smp->snp", R,
                  model.system().response(w, np.einsum("nm,snp->smp", R, F_n)))
    e = db_errors(X, U_n)
    assert kept["db_all_lines"] == pytest.approx((np.median(e), np.percentile(e, 95)),
                                                 rel=1e-9)
    for p in kept["passes"]:  # every pass is judged on every line too
        assert len(p["db_before"]) == len(p["db_after"]) == 2
    everything, _ = final_fit(sweep, U_n, F_n, w, P, threads=1, every_line=True)
    assert everything.info["refinement"]["final_refit"]["lines_fitted"] == w.size
    assert "informative" not in everything.info["refinement"]["final_refit"]["reason"]
