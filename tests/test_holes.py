"""Entries that were not measured (holes in the response × load-case grid) weigh nothing.

Asserted, and why the tolerances:
- the per-load-case metric Rᵀ diag(mask) R with its targets is the complex output error
  over the measured entries (1e-10 relative: the same sums in another order), latent
  (zero) columns of R included;
- the reduced data are Rᵀ U for complete data (bitwise), the least-squares fit of the
  measured entries with holes (1e-10 against numpy's lstsq);
- a mask with every entry True is no mask: refine gives bitwise the same model;
- whatever the holes hold, the refined model is the same (holes never enter; one thread,
  so that the sums run in one order), and on exact data of a two-force chain with five
  FRFs removed the complex objective's model is the chain: it predicts the removed FRFs
  (full order: 1e-6 relative), where the same data with the holes read as measured zeros
  do not (errors of dB); the log-magnitude objective fits the measured entries (0.1 dB);
- the order sweep and final fit through :meth:`MeasuredData.fit`, at the true order, fit
  every load case of such data and predict its holes (0.05 dB; exact data), where the
  holes read as measured zeros give errors over 1 dB there;
- the POD of data with holes is that of the zero-filled responses: each load case adds
  the products of its measured entries only (1e-12);
- a mask of another shape is refused, a transposed one (as many entries) too;
- :class:`MeasuredData` validates, zero-fills, keeps (``band``) and saves the mask;
- the dB errors and the mode kinds count measured entries only.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import podid_rs as pr
from podid_rs.identification import ConvergenceWarning
from podid_rs.identification.holes import check_measured, measured_metric, measured_targets
from podid_rs.identification.latent import observation_matrix
from podid_rs.identification.refinement import StartWarning, db_errors, physical_start, refine
from podid_rs.io.npz import load_data, save_data
from podid_rs.measured import MeasuredData, from_frf
from podid_rs.modes import mode_kinds, mode_shapes

#: the removed FRFs of the two-force chain: (response DOF, load case); no driving point
HOLES = ((0, 0), (5, 0), (7, 0), (1, 1), (3, 1))


def rel(a, b) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def random_mask(rng, n, p, fraction=0.3):
    mask = rng.random((n, p)) > fraction
    mask[np.arange(min(n, p)), np.arange(min(n, p))] = True  # no empty row or column
    mask[:, 0] |= ~mask.any(axis=1)
    return mask


def two_force_chain(n=8, inputs=(2, 5), lo=5.0, hi=700.0, step=2.0):
    """Exact receptances of the n-DOF chain (modes 44–606 Hz) for unit forces at
    ``inputs``, and the mask with the ``HOLES`` removed."""
    chain = pr.mass_spring_chain(n)
    w = 2 * np.pi * np.arange(lo, hi + step / 2, step)
    H = chain.frf(w)[:, :, list(inputs)]
    mask = np.ones((n, len(inputs)), dtype=bool)
    for j, k in HOLES:
        mask[j, k] = False
    return chain, H, w, mask


def model_frf(model, R, w, inputs):
    return np.einsum("am,smk,bk->sab", R, model.system().frf(w), R[list(inputs)])


# ------------------------------------------------------------------ the metric


def test_the_metric_is_the_output_error_over_the_measured_entries():
    rng = np.random.default_rng(1)
    s, n, p, k = 7, 9, 3, 5
    Q, _ = np.linalg.qr(rng.standard_normal((n, k)))
    R = observation_matrix(Q, k + 2)  # two latent (zero) columns
    m = R.shape[1]
    U = rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))
    mask = random_mask(rng, n, p)
    U[:, ~mask] = 0.0
    w = rng.random(s * p) + 0.5
    T, Y, const = measured_metric(w, R, U, mask)
    X = rng.standard_normal((s, m, p)) + 1j * rng.standard_normal((s, m, p))
    W = w.reshape(s, p)
    misfit = np.abs(np.einsum("nm,smp->snp", R, X) - U) ** 2
    direct = np.sum(W[:, None, :] ** 2 * mask[None] * misfit)
    Tm = T.reshape(s, p, m, m)
    reduced = sum(np.linalg.norm(Tm[i, j] @ (X[i, :, j] - Y[i, :, j])) ** 2
                  for i in range(s) for j in range(p)) + const
    assert reduced == pytest.approx(direct, rel=1e-10)


def test_targets_are_rt_u_when_complete_and_least_squares_with_holes():
    rng = np.random.default_rng(2)
    s, n, p, m = 6, 8, 2, 4
    R, _ = np.linalg.qr(rng.standard_normal((n, m)))
    U = rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))
    assert np.array_equal(measured_targets(U, R, None), np.einsum("nm,snp->smp", R, U))
    mask = random_mask(rng, n, p)
    Y = measured_targets(U, R, mask)
    for j in range(p):
        rows = mask[:, j]
        expected = np.linalg.lstsq(R[rows], U[:, rows, j].T, rcond=None)[0].T
        assert rel(Y[:, :, j], expected) < 1e-10


def test_targets_of_a_column_with_fewer_measured_entries_than_coordinates_are_minimum_norm():
    """Two measured DOFs of a load case, a basis of four coordinates: two directions of
    Rᵀ diag(mask) R are null, their eigenvalues round-off (|λ| of 1e-18 to 1e-16 here,
    the others 0.15 to 1) — dividing by them would make targets orders of magnitude
    larger than the data. The targets are the
    minimum-norm least-squares fit, whatever the sign the round-off takes; over ten bases
    some of those eigenvalues come out positive (asserted: the test reaches them)."""
    rng = np.random.default_rng(4)
    s, n, p, m = 5, 8, 1, 4
    mask = np.zeros((n, p), dtype=bool)
    mask[[1, 6], 0] = True
    positive_round_off = 0
    for _ in range(10):
        R, _ = np.linalg.qr(rng.standard_normal((n, m)))
        U = (rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))) * mask
        Q = R.T @ (mask[:, :1] * R)  # as measured_targets forms it
        lam = np.linalg.eigvalsh(0.5 * (Q + Q.T))
        positive_round_off += int(np.sum((lam > 0) & (lam < 1e-12 * lam.max())))
        expected = np.linalg.lstsq(R[mask[:, 0]], U[:, mask[:, 0], 0].T, rcond=None)[0].T
        assert rel(measured_targets(U, R, mask)[:, :, 0], expected) < 1e-10
    assert positive_round_off > 0


def test_the_targets_scale_with_the_basis_and_are_zero_where_it_sees_nothing():
    # least squares is invariant under the basis's scale: the targets of c·R are those of
    # R over c, also for c = 1e-7, where Rᵀ diag(mask) R has eigenvalues near 1e-14 (the
    # rank threshold is relative to the largest); and where the basis has no weight on the
    # measured entries of a load case, the minimum-norm fit is zero, not 0/0
    rng = np.random.default_rng(3)
    s, n, p, m = 5, 8, 2, 3
    R, _ = np.linalg.qr(rng.standard_normal((n, m)))
    U = rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))
    mask = random_mask(rng, n, p)
    Y = measured_targets(U, R, mask)
    for c in (1e-7, 1e3):
        assert rel(measured_targets(U, c * R, mask), Y / c) < 1e-8
    split = np.zeros((n, p), dtype=bool)
    split[:5, 0] = split[5:, 1] = True  # load case 0 measures DOFs 0-4, load case 1 the rest
    blind = R.copy()
    blind[5:] = 0.0  # the basis sees none of load case 1's measured DOFs
    Y = measured_targets(U, blind, split)
    assert np.all(np.isfinite(Y)) and np.all(Y[:, :, 1] == 0)
    rows = split[:, 0]
    expected = np.linalg.lstsq(blind[rows], U[:, rows, 0].T, rcond=None)[0].T
    assert rel(Y[:, :, 0], expected) < 1e-10


def test_the_constant_is_the_misfit_of_the_measured_entries_at_the_targets():
    # the part of the cost no model changes: Σ w² Σ_n mask |(R y)_n − u_n|² at the
    # targets y; the data are small (|u| ~ 1e-3) so that it is far below one
    rng = np.random.default_rng(4)
    s, n, p, m = 6, 9, 3, 4
    R, _ = np.linalg.qr(rng.standard_normal((n, m)))
    U = 1e-3 * (rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p)))
    mask = random_mask(rng, n, p)
    U[:, ~mask] = 0.0
    w = rng.random(s * p) + 0.5
    _, Y, const = measured_metric(w, R, U, mask)
    misfit = np.abs(np.einsum("nm,smp->snp", R, Y) - U) ** 2
    direct = float(np.sum(w.reshape(s, p)[:, None, :] ** 2 * mask[None] * misfit))
    assert 0 < direct < 1e-3
    assert const == pytest.approx(direct, rel=1e-8)
    # data in the range of the basis on the measured entries leave nothing: 0 up to round-off
    _, _, zero = measured_metric(w, R, np.einsum("nm,smp->snp", R, Y) * mask[None], mask)
    assert zero < 1e-12 * direct
    # and never below it: a sum of squares, whatever the sign of the round-off (the
    # difference of the two sums it is formed from is negative for these data)
    assert zero >= 0.0


def test_db_errors_count_measured_entries_only():
    U = np.ones((4, 3, 2), dtype=complex)
    X = 10 * U  # 20 dB everywhere
    mask = np.array([[True, False], [True, True], [False, True]])
    assert db_errors(X, U).size == 24
    e = db_errors(X, U, mask)
    assert e.size == 16 and np.allclose(e, 20.0)


# ------------------------------------------------------------------ refine


def test_a_mask_of_every_entry_is_no_mask():
    chain, H, w, _ = two_force_chain()
    F_n = np.zeros_like(H)
    F_n[:, [2, 5], [0, 1]] = 1.0
    R = pr.pod_from_frf(H, w).basis(6)
    start = pr.identify(*(np.einsum("nm,snp->smp", R, X) for X in (H, F_n)), w, symmetric=True)
    kwargs = dict(basis=R, max_iter=5, curvature=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StartWarning)
        warnings.simplefilter("ignore", ConvergenceWarning)
        plain = refine(start, H, F_n, w, **kwargs)
        masked = refine(start, H, F_n, w, measured=np.ones((8, 2), dtype=bool), **kwargs)
    for k in "MCK":
        assert np.array_equal(getattr(plain, k), getattr(masked, k))


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_holes_never_enter_and_the_model_predicts_them(objective):
    """Exact data, full-order basis, a start 2 % off the chain: the refined model is the
    chain whatever the holes hold — and so predicts the FRFs that were removed."""
    chain, H, w, mask = two_force_chain()
    inputs = (2, 5)
    F_n = np.zeros_like(H)
    F_n[:, list(inputs), [0, 1]] = 1.0
    R = np.eye(8)
    rng = np.random.default_rng(3)
    start = tuple(X * (1 + 0.02 * rng.standard_normal(X.shape))
                  for X in (chain.M, chain.C, chain.K))
    start = tuple(0.5 * (X + X.T) for X in start)
    zeros, garbage = H.copy(), H.copy()
    zeros[:, ~mask] = 0.0
    garbage[:, ~mask] = 1e3 * (1 + 1j)
    fits = []
    for U in (zeros, garbage):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StartWarning)
            warnings.simplefilter("ignore", ConvergenceWarning)
            fits.append(refine(start, U, F_n, w, basis=R, measured=mask, objective=objective,
                               max_iter=200, threads=1))  # one thread: sums in one order
    for k in "MCK":
        assert np.array_equal(getattr(fits[0], k), getattr(fits[1], k))
    predicted = model_frf(fits[0], R, w, inputs)
    if objective == "log-magnitude":
        # magnitudes alone (no phase) from a start 2 % off fit the measured entries
        # (median 0.02 dB after 200 steps, measured) but do not pin what the holes hold
        assert np.median(db_errors(predicted, H, mask)) < 0.1
        return
    assert "measured entries" in fits[0].info["refinement"]["weights"]
    for j, k in HOLES:
        assert rel(predicted[:, j, k], H[:, j, k]) < 1e-6
    if objective == "complex":
        # the same data with the holes read as measured zeros: the fit bends to them
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StartWarning)
            warnings.simplefilter("ignore", ConvergenceWarning)
            wrong = refine(start, zeros, F_n, w, basis=R, max_iter=200)
        off = model_frf(wrong, R, w, inputs)
        assert max(np.median(db_errors(off[:, j, k], H[:, j, k])) for j, k in HOLES) > 1.0


def test_a_refinement_with_holes_reports_on_the_measured_entries():
    """A reduced basis (4 POD modes of the 8 DOFs: the measured entries' constant part
    of the cost is not 0) and garbage in the holes: the start's dB errors are those of
    the measured entries, and the history runs from cost_start to cost, the constant
    in each."""
    chain, H, w, mask = two_force_chain()
    F_n = np.zeros_like(H)
    F_n[:, [2, 5], [0, 1]] = 1.0
    zeros = H.copy()
    zeros[:, ~mask] = 0.0
    R = pr.pod_from_frf(zeros, w).basis(4)
    U, F = np.einsum("nm,snp->smp", R, zeros), np.einsum("nm,snp->smp", R, F_n)
    start = pr.identify(U, F, w, symmetric=True)
    garbage = H.copy()
    garbage[:, ~mask] = 1e3 * (1 + 1j)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StartWarning)
        warnings.simplefilter("ignore", ConvergenceWarning)
        fit = refine(start, garbage, F_n, w, basis=R, measured=mask, max_iter=5, threads=1)
    rep = fit.info["refinement"]
    physical, _ = physical_start(start.M, start.C, start.K)  # what refine starts from
    X0 = np.einsum("nm,smp->snp", R, pr.SecondOrderSystem(*physical).response(w, F))
    e = db_errors(X0, garbage, mask)
    assert rep["db_before"] == pytest.approx((np.median(e), np.percentile(e, 95)), rel=1e-9)
    assert rep["history"][0] == (0, pytest.approx(rep["cost_start"], rel=1e-12))
    assert rep["history"][-1][1] == pytest.approx(rep["cost"], rel=1e-12)
    assert fit.backend == "rust"


def test_a_mask_needs_a_basis_and_the_data_shape():
    chain, H, w, mask = two_force_chain()
    F_n = np.zeros_like(H)
    F_n[:, [2, 5], [0, 1]] = 1.0
    model = (chain.M, chain.C, chain.K)
    with pytest.raises(ValueError, match="needs basis"):
        refine(model, H, F_n, w, measured=mask)
    with pytest.raises(ValueError, match="boolean mask of shape"):
        refine(model, H, F_n, w, basis=np.eye(8), measured=mask[:4])


# ------------------------------------------------------------------ the pipeline


def test_a_mask_of_the_wrong_shape_is_refused_also_when_it_has_as_many_entries():
    """A (p, n) mask — the grid transposed, as many entries as (n, p) — is refused: read
    as it is, the load cases' columns would be the DOFs' rows."""
    n, p = 4, 2
    mask = np.ones((n, p), dtype=bool)
    mask[0, 1] = False
    assert np.array_equal(check_measured(mask, n, p), mask)
    with pytest.raises(ValueError, match=r"boolean mask of shape \(n, p\) = \(4, 2\).*"
                                         r"got bool \(2, 4\)"):
        check_measured(mask.T, n, p)


@pytest.mark.parametrize("bad, got", [
    (np.ones((5, 2), dtype=bool), r"bool \(5, 2\)"),  # a DOF too many
    (np.ones((4, 3), dtype=bool), r"bool \(4, 3\)"),  # a load case too many
    (np.ones((3, 2), dtype=bool), r"bool \(3, 2\)"),  # a DOF too few
    # b"1" / b"0": a text file's fields read without conversion (NumPy would not cast
    # a bool to them safely, unlike to int or str)
    (np.where(np.ones((4, 2), dtype=bool), b"1", b"0"), r"\|S1 \(4, 2\)"),
])
def test_a_mask_that_is_not_boolean_of_shape_n_p_is_refused_with_what_it_is(bad, got):
    with pytest.raises(ValueError, match=r"^measured must be a boolean mask of shape "
                                         r"\(n, p\) = \(4, 2\) \(True where the response "
                                         rf"was measured\), got {got}$"):
        check_measured(bad, 4, 2)


def test_a_load_case_with_no_measured_entry_is_named():
    # every DOF is measured in another load case, so only the load-case check can refuse it
    mask = np.ones((4, 3), dtype=bool)
    mask[:, 1] = False
    with pytest.raises(ValueError, match=r"^load case\(s\) \[1\] have no measured response: "
                       r"there is nothing to fit them to; leave them out$"):
        check_measured(mask, 4, 3)
    mask = np.ones((4, 3), dtype=bool)
    mask[1] = False
    with pytest.raises(ValueError, match=r"^measured DOF\(s\) \[1\] are not measured in any "
                       r"load case: leave them out of the data$"):
        check_measured(mask, 4, 3)
    assert check_measured(np.ones((4, 3), dtype=bool), 4, 3) is None


def test_the_mask_checked_is_a_copy_of_the_callers():
    # the fitters keep the mask they were given; the caller's array may change after
    mask = np.ones((4, 2), dtype=bool)
    mask[0, 1] = False
    checked = check_measured(mask, 4, 2)
    assert checked is not mask and np.array_equal(checked, mask)
    mask[1, 0] = False
    assert checked[1, 0] and not checked[0, 1]


def test_the_order_sweep_fits_every_load_case_and_predicts_the_holes():
    """Simulated two-reference test with four FRFs removed, through MeasuredData.fit at
    the true order: a uniform 6-DOF chain (every entry within 2 dB of the others),
    forces at DOFs 1 and 4; every mode shape is fixed by the FRFs that remain."""
    chain = pr.mass_spring_chain(6, m1=1.0, m2=1.0)
    w = 2 * np.pi * np.arange(5.0, 250.0, 1.0)
    inputs = (1, 4)
    H = chain.frf(w)[:, :, list(inputs)]
    mask = np.ones((6, 2), dtype=bool)
    holes = ((0, 0), (3, 0), (5, 0), (2, 1))
    for j, k in holes:
        mask[j, k] = False
    data = from_frf(H, w, inputs=list(inputs), measured=mask)
    model, R, sweep = data.fit(m=6, threads=1)
    predicted = model_frf(model, R, w, inputs)
    # measured 0.0008–0.009 dB per entry: not round-off (the sweep's starts see the holes
    # filled with the previous order's prediction only), asserted 0.05 dB
    for k in range(2):  # every load case is fitted, on its measured entries
        rows = mask[:, k]
        assert np.median(db_errors(predicted[:, rows, k], H[:, rows, k])) < 0.05
    for j, k in holes:  # and the entries nobody measured are predicted
        assert np.median(db_errors(predicted[:, j, k], H[:, j, k])) < 0.05
    # the same data with the holes read as measured zeros: the old behaviour
    wrong = from_frf(np.where(mask, H, 0.0), w, inputs=list(inputs))
    bad, R_bad, _ = wrong.fit(m=6, threads=1)
    off = model_frf(bad, R_bad, w, inputs)
    assert max(np.median(db_errors(off[:, j, k], H[:, j, k])) for j, k in holes) > 1.0


def test_with_fewer_sensors_than_modes_and_a_hole_the_sweep_finds_the_true_order():
    """A 5-DOF chain measured at DOFs 0, 2, 4, driven at 0 and 4, the FRF from 4 to 2
    missing: three observed coordinates, two latent ones. Exact data, so the true order
    fits to round-off, and on every step — the orders' continuation, the observed order's
    run to convergence, the latent orders, the final fit — the hole must weigh nothing.
    Read as a measured zero at any one of them, the observed order's converged fit bends
    to it (2.1 dB on its training lines against 1.36), and the sweep goes on to m = 6."""
    chain = pr.mass_spring_chain(5)
    w = 2 * np.pi * np.linspace(5.0, 250.0, 200)
    sensors, inputs = [0, 2, 4], [0, 2]  # inputs: rows of the sensors (DOFs 0 and 4)
    H = chain.frf(w)[:, sensors][:, :, [0, 4]]
    mask = np.ones((3, 2), dtype=bool)
    mask[1, 1] = False
    data = from_frf(H, w, inputs=inputs, measured=mask)
    model, R, sweep = data.fit(m_max=6, threads=1)
    assert [f.m for f in sweep.fits] == [1, 2, 3, 4, 5] and sweep.chosen == 5
    assert sweep.fit(3).start.endswith("to convergence")
    assert sweep.fit(3).train_db < 1.5
    assert sweep.fit(5).test_db < 1e-3
    predicted = model_frf(model, R, w, inputs)
    assert np.median(db_errors(predicted[:, 1, 1], H[:, 1, 1])) < 1e-3  # the hole


def test_the_converged_fits_modal_start_never_reads_a_hole(monkeypatch):
    """The same chain and hole: the observed order (m = 3 < m_max) is run to
    convergence from its modal start, which must leave the hole out as every other
    step does. Each modal start the sweep builds is rebuilt here from the same call
    with garbage in the hole (10³ × the FRF beside it, phase turned): the same start (1e-10:
    the same arithmetic on the same measured entries) — read as a measurement, the
    garbage moves the shapes' least squares by orders of magnitude."""
    from podid_rs.identification import order as order_module

    chain = pr.mass_spring_chain(5)
    w = 2 * np.pi * np.linspace(5.0, 250.0, 200)
    H = chain.frf(w)[:, [0, 2, 4]][:, :, [0, 4]]
    mask = np.ones((3, 2), dtype=bool)
    mask[1, 1] = False
    data = from_frf(H, w, inputs=[0, 2], measured=mask)
    real = order_module.modal_start
    calls = []

    def spy(model, R, U_n, F_n, omega, measured=None):
        start = real(model, R, U_n, F_n, omega, measured)
        garbage = U_n.copy()
        garbage[:, 1, 1] = 1e3j * U_n[:, 1, 0]
        again = real(model, R, garbage, F_n, omega, measured)
        calls.append((start, again))
        return start

    monkeypatch.setattr(order_module, "modal_start", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        order_module.sweep_orders(data.U, data.forces_on_dofs(), data.omega, data.pod(),
                                  m_max=4, measured=mask, threads=1)
    assert calls and all(start is not None for start, _ in calls)
    for start, again in calls:
        for X, Y in zip(start, again, strict=True):
            assert np.linalg.norm(Y - X) <= 1e-10 * np.linalg.norm(X)


def test_the_starts_of_each_order_see_the_holes_filled_with_the_last_orders_prediction(
        monkeypatch):
    """The fits never see the holes; the starts of an observed order (continuation,
    residual peak, the paper's estimator) are made from reduced data Rᵀ U whose holes
    hold the previous order's prediction R x — on the first order, zeros. Checked on
    what the sweep hands the starts, order by order, against that prediction made here
    from the fits it returns (to 1e-12 of the data: one einsum order apart)."""
    from podid_rs.identification import order as order_module

    chain, H, w, mask = two_force_chain(step=4.0)
    F_n = np.zeros((w.size, 8, 2), dtype=complex)
    F_n[:, 2, 0] = F_n[:, 5, 1] = 1.0
    U_n = np.where(mask, H, 0.0)
    P = pr.pod_from_frf(U_n, w)
    seen = {}
    observed_starts = order_module._observed_starts

    def spy(order, previous, fits, Ut, Ft, wt, w_):
        seen[order] = Ut.copy()
        return observed_starts(order, previous, fits, Ut, Ft, wt, w_)

    monkeypatch.setattr(order_module, "_observed_starts", spy)
    sweep = order_module.sweep_orders(U_n, F_n, w, P, m=3, max_iter=5, threads=1,
                                      measured=mask)
    train = ~sweep.test_lines & sweep.lines
    for m in (1, 2, 3):
        R = P.basis(m)
        filled = U_n
        if m > 1:
            R_prev = P.basis(m - 1)
            x = sweep.fit(m - 1).model.system().response(
                w, np.einsum("nm,snp->smp", R_prev, F_n))
            filled = np.where(mask, U_n, np.einsum("nm,smp->snp", R_prev, x))
        expected = np.einsum("nm,snp->smp", R, filled)[train]
        assert np.abs(seen[m] - expected).max() < 1e-12 * np.abs(expected).max()
    # the holes matter here: with zeros in them the data the second order starts from differ
    zeros = np.einsum("nm,snp->smp", P.basis(2), U_n)[train]
    assert np.abs(seen[2] - zeros).max() > 1e-3 * np.abs(zeros).max()


def test_the_pod_of_data_with_holes_is_that_of_its_measured_entries():
    chain, H, w, mask = two_force_chain()
    data = from_frf(H, w, inputs=[2, 5], measured=mask)
    expected = pr.pod_from_frf(np.where(mask, H, 0.0), w)
    assert np.allclose(data.pod().eigenvalues, expected.eigenvalues, rtol=1e-12, atol=0)
    # entry (a, b) of the correlation sums the load cases that measured both a and b
    Ruu = pr.correlation_from_frf(data.U, w)
    q = np.zeros(w.size)
    q[:-1] += 0.5 * np.diff(w)
    q[1:] += 0.5 * np.diff(w)
    a, b = 0, 3  # a measured in load case 1 only, b in load case 0 only
    both = [k for k in range(2) if mask[a, k] and mask[b, k]]
    manual = sum(np.sum(q * np.real(H[:, a, k] * np.conj(H[:, b, k]))) for k in both)
    assert both == [] and Ruu[a, b] == pytest.approx(manual, abs=1e-12 * np.abs(Ruu).max())


# ------------------------------------------------------------------ MeasuredData


def test_measured_data_validates_zero_fills_keeps_and_saves_its_mask(tmp_path):
    chain, H, w, mask = two_force_chain()
    given = H.copy()
    data = from_frf(given, w, inputs=[2, 5], measured=mask)
    assert np.array_equal(given, H)  # nothing the user passed is modified
    assert np.array_equal(data.measured, mask) and not data.complete
    assert np.all(data.U[:, ~mask] == 0) and np.array_equal(data.U[:, mask], H[:, mask])
    banded = data.band((20.0, 80.0))
    assert np.array_equal(banded.measured, mask)
    back = load_data(save_data(tmp_path / "holes.npz", data))
    assert np.array_equal(back.measured, mask) and np.array_equal(back.U, data.U)
    complete = from_frf(H, w, inputs=[2, 5])
    assert complete.complete and complete.measured.shape == (8, 2)
    # a data set saved before masks existed reads as complete
    np.savez(tmp_path / "old.npz", omega=w, U=H, F=complete.F, inputs=np.array([2, 5]))
    assert load_data(tmp_path / "old.npz").complete
    for bad, match in [
        (mask.astype(int), "boolean mask"),
        (mask[:, :1], "boolean mask"),
        (np.zeros((8, 2), dtype=bool) | (np.arange(8) == 0)[:, None] * [True, False],
         "load case"),
        (np.ones((8, 2), dtype=bool) & (np.arange(8) != 4)[:, None], "not measured in any"),
    ]:
        with pytest.raises(ValueError, match=match):
            from_frf(H, w, inputs=[2, 5], measured=bad)


def test_a_hole_makes_no_mode_visible():
    """mode_kinds judges visibility on the measured entries: a hole counts as if its
    measured response were infinite — no mode term can reach a fraction of it."""
    chain, H, w, mask = two_force_chain()
    inputs = [2, 5]
    model = pr.identify(*(np.einsum("nm,snp->smp", np.eye(8), X) for X in
                          (H, np.broadcast_to(np.eye(8)[:, inputs], H.shape))), w,
                        symmetric=True)
    shapes = mode_shapes(model, np.eye(8))
    U = np.where(mask, H, 0.0)
    huge = np.where(mask, H, 1e300)
    with_mask = mode_kinds(shapes, w, U, inputs, measured=mask)
    assert np.array_equal(with_mask, mode_kinds(shapes, w, huge, inputs))
    assert np.array_equal(mode_kinds(shapes, w, H, inputs),
                          mode_kinds(shapes, w, H, inputs, measured=np.ones_like(mask)))


def test_predict_and_project_with_holes():
    chain, H, w, mask = two_force_chain()
    data = from_frf(H, w, inputs=[2, 5], measured=mask)
    U_m, F_m = data.project(np.eye(8))
    # with the full basis the least-squares reduced response of a column with holes is
    # its measured entries, zeros elsewhere (minimum norm): nothing is invented
    assert np.allclose(U_m[:, mask], H[:, mask], rtol=1e-14, atol=0)
    assert np.all(np.abs(U_m[:, ~mask]) <= 1e-14 * np.abs(H).max())
    assert isinstance(data, MeasuredData) and F_m.shape == U_m.shape


def test_projection_with_holes_fits_the_measured_entries_on_a_reduced_basis():
    """On a basis of fewer modes than DOFs the reduced response of a load case with holes
    is the least-squares fit of its measured entries: its residual there is orthogonal
    to the measured rows of R (the normal equations), which the plain projection Rᵀ U of
    the zero-filled column is not; a complete load case has Rᵀ u itself."""
    chain, H, w, mask = two_force_chain()
    complete = np.ones_like(mask)
    complete[:, 0] = mask[:, 0]  # load case 0 has holes, load case 1 none
    data = from_frf(H, w, inputs=[2, 5], measured=complete)
    R = data.pod().basis(4)
    U_m, _ = data.project(R)
    Rj = R * complete[:, :1]  # the measured rows of R for load case 0
    residual = np.einsum("nm,sm->sn", R, U_m[:, :, 0]) - data.U[:, :, 0]
    normal = np.einsum("nm,sn->sm", Rj, residual)
    # round-off of a 4 × 4 least-squares solve, eps times the condition number (about
    # 2e3 for the measured rows' Gram matrix RⱼᵀRⱼ) of the measured right-hand side: far
    # below 1e-10 of it; the plain projection misses by about 1e-2 of it
    scale = np.abs(np.einsum("nm,sn->sm", Rj, data.U[:, :, 0])).max()
    assert np.abs(normal).max() <= 1e-10 * scale
    np.testing.assert_allclose(U_m[:, :, 1], np.einsum("nm,sn->sm", R, H[:, :, 1]),
                               rtol=1e-12, atol=1e-12 * np.abs(H).max())


def test_the_order_limit_counts_measured_entries_only():
    """Each measured entry gives 2 real equations per fitted line; a hole gives none. An
    order whose free parameters exceed the measured entries' equations is refused with
    the count of measured entries, where the full grid would still allow it."""
    from podid_rs.identification.latent import free_parameters
    from podid_rs.identification.order import order_limit, sweep_orders

    chain = pr.mass_spring_chain(6, m1=1.0, m2=1.0)
    omega = 2 * np.pi * np.linspace(5, 150, 12)
    H = chain.frf(omega)[:, :2, :2]
    mask = np.array([[True, True], [True, False]])
    data = from_frf(H * mask, omega, inputs=[0, 1], measured=mask)
    lines = int(np.sum(np.arange(12) % 4 != 2))
    full, holed = order_limit(lines, 2, 2, 2), order_limit(lines, 2, 2, 2, entries=3)
    assert holed < full
    assert free_parameters(holed, 2) <= 2 * lines * 3 < free_parameters(holed + 1, 2)
    with pytest.raises(ValueError, match=rf"m must be in \[1, {holed}\]: .* more than the "
                       rf"{2 * lines * 3} real equations of the {lines} fitted lines × 3 "
                       r"measured entries of the 2 × 2 grid"):
        sweep_orders(data.U, data.forces_on_dofs(), data.omega, data.pod(), m=holed + 1,
                     measured=mask)
