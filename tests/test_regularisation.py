"""Choosing λ: the swept curves against individual solves, the three rules, fallbacks.

The case where a chosen λ must beat both limits (``skew_mass_case``): a random
6-DOF system whose mass matrix has a real skew part (10 % of ‖M‖) while C and K
are symmetric, forces with 5 % noise, lines 2–40 rad/s. One λ in the paper's
units weighs block b's skew part by its size c_b², so with ω0 ≈ 20 rad/s the
skew parts of K and C are damped two to four decades of λ before M's. λ → 0 keeps
the noise in the skew parts of all three; λ → ∞ (exactly symmetric) loses M's
true skew part; the L-curve corner and the GCV minimum fall in between, where
the noise in K and C is gone and M's asymmetry is kept. Checked on seeds 0–9
(errors 30–50 % below λ → 0 and ~10× below λ → ∞); the test runs three.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from podid_rs import (
    LambdaSelectionWarning,
    NoCornerWarning,
    _core,
    choose_lambda,
    identify,
    lambda_curve,
    mass_spring_chain,
    plot_lambda_curve,
)
from podid_rs.identification import regularisation as reg
from podid_rs.identification.reference import kronecker_system, symmetry_constraints


def skew_mass_case(seed: int, m: int = 6, s: int = 60, p: int = 2, noise: float = 0.05, on="F"):
    """Truth, data with noise on F (or U), and the noise level: E‖noise‖ on F, RMS σ on U."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, m))
    M = np.eye(m) + 0.05 * (A + A.T)
    Q, _ = np.linalg.qr(rng.standard_normal((m, m)))
    wn = np.geomspace(2.4, 32.0, m)
    K = M @ Q @ np.diag(wn**2) @ Q.T
    K = 0.5 * (K + K.T)
    C = 0.02 * K / np.sqrt(80.0) + 0.02 * np.sqrt(80.0) * M
    S = rng.standard_normal((m, m))
    M = M + 0.1 * np.linalg.norm(M) / np.linalg.norm(S - S.T) * (S - S.T)
    omega = np.geomspace(2.0, 40.0, s)
    F = rng.standard_normal((s, m, p)) + 1j * rng.standard_normal((s, m, p))
    D = -(omega**2)[:, None, None] * M + 1j * omega[:, None, None] * C + K
    U = np.linalg.solve(D, F)
    e = (rng.standard_normal(F.shape) + 1j * rng.standard_normal(F.shape)) / np.sqrt(2)
    if on == "U":
        sigma = noise * np.sqrt(np.mean(np.abs(U) ** 2))
        return (M, C, K), U + sigma * e, F, omega, sigma
    sigma = noise * np.sqrt(np.mean(np.abs(F) ** 2))
    return (M, C, K), U, F + sigma * e, omega, sigma * np.sqrt(F.size)


def chain_case(n: int = 8, s: int = 120, noise: float = 0.01, seed: int = 0):
    """The paper's chain at full order, 5–200 Hz, noise on U: blocks weighted ~1e11 apart."""
    rng = np.random.default_rng(seed)
    sys_ = mass_spring_chain(n)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, s)
    F = rng.standard_normal((s, n)) + 1j * rng.standard_normal((s, n))
    U = sys_.response(omega, F)
    sigma = noise * np.sqrt(np.mean(np.abs(U) ** 2))
    U = U + sigma / np.sqrt(2) * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape))
    return sys_, U, F, omega, sigma


def total_rel_error(res, truth) -> float:
    return sum(
        np.linalg.norm(X - T) / np.linalg.norm(T)
        for X, T in zip((res.M, res.C, res.K), truth, strict=True)
    )


def quiet_curve(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LambdaSelectionWarning)
        return lambda_curve(*args, **kwargs)


# ------------------------------------------------------- the curve = solves


@pytest.mark.parametrize("case", ["skew-mass", "chain"])
def test_swept_norms_equal_individual_solves(case):
    if case == "skew-mass":
        _, U, F, omega, _ = skew_mass_case(0)
    else:
        _, U, F, omega, _ = chain_case()
    curve = quiet_curve(U, F, omega, n=50)
    assert curve.method == "spectral" and curve.lams.size == 50
    for lam, res, pen in zip(curve.lams, curve.residual_norms, curve.penalty_norms, strict=True):
        one = identify(U, F, omega, lam)
        assert res == pytest.approx(one.residual_norm, rel=1e-8)
        # ‖X − Xᵀ‖ of the direct answer loses ε‖X‖ to cancellation at large λ
        floor = 1e-14 * sum(np.linalg.norm(X) for X in (one.M, one.C, one.K))
        assert abs(pen - one.penalty_norm) <= 1e-8 * one.penalty_norm + floor


def test_gcv_matches_dense_influence_matrix():
    """Eq. 34 for the real stacked problem, from the Kronecker matrices of the paper."""
    _, U, F, omega, _ = skew_mass_case(1, m=3, s=12, p=1)
    A, y = kronecker_system(U, F, omega)
    J, rhs = np.vstack([A.real, A.imag]), np.concatenate([y.real, y.imag])
    L = np.vstack(symmetry_constraints(3))
    lams = np.geomspace(1e-3, 1e2, 6)
    curve = quiet_curve(U, F, omega, lams)
    for lam, g in zip(lams, curve.gcv, strict=True):
        G = J.T @ J + lam**2 * (L.T @ L)
        x = np.linalg.solve(G, J.T @ rhs)
        trace = np.trace(J @ np.linalg.solve(G, J.T))
        want = np.sum((J @ x - rhs) ** 2) / (J.shape[0] - trace) ** 2
        assert g == pytest.approx(want, rel=1e-7)


# ------------------------------------------------------------- the rules


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lcurve_and_gcv_beat_both_limits(seed):
    truth, U, F, omega, _ = skew_mass_case(seed)
    curve = lambda_curve(U, F, omega, rule="gcv")  # no warning: clear answers
    e0 = total_rel_error(identify(U, F, omega, 0.0), truth)
    einf = total_rel_error(identify(U, F, omega, symmetric=True), truth)
    assert curve.corner_curvature > reg.CORNER_MIN_CURVATURE
    for rule in ("lcurve", "gcv"):
        err = total_rel_error(identify(U, F, omega, curve.choices[rule]), truth)
        assert err < 0.9 * min(e0, einf), rule


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lcurve_and_gcv_lambdas_are_the_continuous_optimum_not_a_grid_point(seed):
    """The rules refine the fine grid's best point on the continuous curve, on both sides
    of it: on a grid of ±1/40 decade around the chosen λ (one fine-grid step each way),
    the chosen λ has the largest curvature and the smallest GCV of all. A search on one
    side only lands up to half a step (3 % in λ) off when the optimum lies on the other
    (seed 2's GCV: 7.6e-6 above the minimum)."""
    _, U, F, omega, _ = skew_mass_case(seed)
    choices = quiet_curve(U, F, omega, rule="gcv").choices
    for rule in ("lcurve", "gcv"):
        lam = choices[rule]
        grid = np.unique(np.append(lam * 10.0 ** np.linspace(-1 / 40, 1 / 40, 41), lam))
        near = quiet_curve(U, F, omega, grid)
        at = int(np.flatnonzero(grid == lam)[0])
        # the bounded search stops within 1e-6 in ln λ of the optimum, where a smooth
        # curve differs from its extremum by ~(1e-6)² relative: 1e-9 is far above that
        if rule == "gcv":
            assert near.gcv[at] <= near.gcv.min() * (1 + 1e-9), rule
        else:
            assert near.curvature[at] >= near.curvature.max() * (1 - 1e-9), rule


def test_discrepancy_residual_equals_the_target():
    truth, U, F, omega, delta = skew_mass_case(3)
    # δ is the expected norm of the noise: the true matrices' residual, up to sampling
    D = -(omega**2)[:, None, None] * truth[0] + 1j * omega[:, None, None] * truth[1] + truth[2]
    assert np.linalg.norm(D @ U - F) == pytest.approx(delta, rel=0.05)
    curve = lambda_curve(U, F, omega, rule="discrepancy", delta=delta)
    lam = curve.lam
    assert curve.residual_norms[0] < delta < curve.residual_norms[-1]
    assert identify(U, F, omega, lam).residual_norm == pytest.approx(delta, rel=1e-8)


def test_discrepancy_from_noise_level_on_the_responses():
    # with noise on U the target is only an estimate, σ²Σ‖D̂(ω)‖² from the λ = 0 fit,
    # and sits close to that fit's residual; seed 4 leaves a 10 % margin
    truth, U, F, omega, sigma = skew_mass_case(4, noise=0.001, on="U")
    res = identify(U, F, omega, "discrepancy", noise=sigma)
    curve = res.info["lambda_curve"]
    assert curve.target_residual is not None and res.lam == (curve.lam,) * 3
    assert res.residual_norm == pytest.approx(curve.target_residual, rel=1e-8)
    # an SNR is the same noise level relative to the mean power of U
    snr = 10 * np.log10(np.mean(np.abs(U) ** 2) / sigma**2)
    same = lambda_curve(U, F, omega, rule="discrepancy", snr_db=snr)
    assert same.target_residual == pytest.approx(curve.target_residual, rel=1e-12)


def test_unreachable_discrepancy_target_warns_and_returns_an_end():
    _, U, F, omega, delta = skew_mass_case(4)
    with pytest.warns(LambdaSelectionWarning, match="consistent with symmetric"):
        hi = lambda_curve(U, F, omega, rule="discrepancy", delta=1e3 * delta)
    assert hi.lam == hi.lams[-1]
    with pytest.warns(LambdaSelectionWarning, match="too small"):
        lo = lambda_curve(U, F, omega, rule="discrepancy", delta=1e-3 * delta)
    assert lo.lam == lo.lams[0]


def test_symmetric_truth_has_no_clear_corner():
    """The chain is symmetric: penalising the noise's skew part costs no residual."""
    _, U, F, omega, _ = chain_case()
    with pytest.warns(NoCornerWarning, match="symmetric=True"):
        curve = lambda_curve(U, F, omega)
    assert curve.corner_curvature < reg.CORNER_MIN_CURVATURE
    # GCV agrees that the exactly symmetric end is best
    assert curve.choices["gcv"] == curve.lams[-1] and "an end" in curve.problems["gcv"][0]


# -------------------------------------------------------- identify(lam=rule)


@pytest.mark.parametrize("backend", ["rust", "numpy"])
def test_identify_with_a_rule_equals_identify_at_the_chosen_lambda(backend):
    _, U, F, omega, _ = skew_mass_case(5)
    res = identify(U, F, omega, "lcurve", backend=backend)
    curve = res.info["lambda_curve"]
    assert curve.rule == "lcurve" and res.lam == (curve.lam,) * 3
    assert curve.lam == choose_lambda(U, F, omega, "lcurve")
    ref = identify(U, F, omega, curve.lam, backend=backend)
    for X, Y in zip((res.M, res.C, res.K), (ref.M, ref.C, ref.K), strict=True):
        assert np.linalg.norm(X - Y) < 1e-10 * np.linalg.norm(Y)
    assert res.residual_norm == pytest.approx(ref.residual_norm, rel=1e-12)
    # ‖X − Xᵀ‖ block by block (M's skew part is the truth's, C's and K's the noise's)
    assert res.penalty_norms == pytest.approx(ref.penalty_norms, rel=1e-8)
    assert res.well_posed and res.method == ("spectral-sweep" if backend == "rust" else "cholesky")


# --------------------------------------------------- repeated-solve fallback


def test_repeated_solves_find_the_same_corner_and_discrepancy():
    _, U, F, omega, delta = skew_mass_case(6)
    spec = lambda_curve(U, F, omega, delta=delta)
    calls = []

    def solve(lam):
        calls.append(lam)
        return identify(U, F, omega, lam)

    rep = lambda_curve(U, F, omega, spec.lams[::4], method="repeated", solve=solve, delta=delta)
    assert rep.method == "repeated" and np.all(np.isnan(rep.gcv))
    assert len(set(calls)) == rep.lams.size == rep.info["solves"] <= 40
    assert len(calls) == len(set(calls))  # each λ solved once, then read from the cache
    # golden section stops at a bracket of CORNER_XTOL_DECADES
    assert abs(np.log10(rep.choices["lcurve"] / spec.choices["lcurve"])) < 0.05
    assert rep.choices["discrepancy"] == pytest.approx(spec.choices["discrepancy"], rel=1e-6)
    with pytest.raises(ValueError, match="GCV needs the trace"):
        lambda_curve(U, F, omega, method="repeated", rule="gcv")


def test_rank_deficient_unregularised_problem_falls_back_to_repeated_solves():
    # 8 response vectors of order 6: H (18×18) has rank 16, but the symmetry
    # penalty makes every λ > 0 well posed
    truth, U, F, omega, _ = skew_mass_case(7, s=8, p=1)
    with pytest.warns(LambdaSelectionWarning, match="rank deficient"):
        res = identify(U, F, omega, "lcurve")
    assert res.info["lambda_curve"].method == "repeated" and res.well_posed


def test_memory_guard_switches_to_repeated_solves(monkeypatch):
    _, U, F, omega, _ = skew_mass_case(8)
    # the one memory check (podid_rs._memory) guards the repeated solves too, and at
    # m = 6 they need more than the sweep: so the sweep's need is faked, not the memory
    monkeypatch.setattr(_core, "sweep_memory_bytes", lambda m: 10**18)
    curve = quiet_curve(U, F, omega)
    assert curve.method == "repeated"
    with pytest.raises(MemoryError, match="method='repeated'"):
        lambda_curve(U, F, omega, method="spectral")


# ----------------------------------------------------------------- inputs


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"rule": "aic"}, "not a selection rule"),
        ({"rule": "discrepancy"}, "needs the noise level"),
        ({"delta": 1.0, "noise": 1.0}, "at most one"),
        ({"delta": 1.0, "snr_db": 20.0}, "and snr_db, got delta, snr_db$"),
        ({"noise": -1.0}, "finite number"),
        ({"noise": 0.0}, "noise must be a finite number"),  # no noise: nothing to aim at
        ({"delta": 0.0}, "delta must be a finite number"),
        ({"lams": [1.0, 2.0]}, "at least 3"),
        ({"lams": [0.0, 1.0, 2.0]}, "positive"),
        ({"n": 2}, "n must be"),
        ({"n": 3.5}, "n must be an integer >= 3, got 3.5"),
        ({"method": "cg"}, "method must be"),
        ({"threads": -1}, "threads"),
        ({"threads": 0}, "^threads must be between 1 and 1024, got 0$"),
    ],
)
def test_bad_options_raise(kwargs, match):
    _, U, F, omega, _ = skew_mass_case(0, m=3, s=10, p=1)
    with pytest.raises(ValueError, match=match):
        lambda_curve(U, F, omega, **kwargs)


def test_order_one_has_nothing_to_choose():
    rng = np.random.default_rng(0)
    U = rng.standard_normal((5, 1)) + 1j * rng.standard_normal((5, 1))
    with pytest.raises(ValueError, match="m = 1"):
        identify(U, U, np.arange(1.0, 6.0), "gcv")


# ------------------------------------------------------------------ plot


def test_plot_writes_a_png(tmp_path):
    _, U, F, omega, delta = skew_mass_case(9)
    curve = lambda_curve(U, F, omega, delta=delta)
    path = tmp_path / "lcurve.png"
    fig = plot_lambda_curve(curve, path, title="skew-mass case")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(fig.axes) == 4  # L-curve, GCV, norms and their twin axis


# ------------------------------------------------- what the curve reports


def test_report_counts_and_default_grids():
    """n_rows = 2·N·m real equations (N = s·p response vectors), n_unknowns = 3m², on both
    paths; the default grid has 50 points on the spectral path and 12 on the repeated one
    (the repeated curve adds the points its searches solved at)."""
    _, U, F, omega, delta = skew_mass_case(6)  # s = 60, m = 6, p = 2
    spec = quiet_curve(U, F, omega, delta=delta)
    rep = quiet_curve(U, F, omega, method="repeated", delta=delta)
    for curve in (spec, rep):
        assert (curve.n_rows, curve.n_unknowns) == (2 * 60 * 2 * 6, 3 * 6 * 6)
    assert spec.lams.size == 50
    regular = np.geomspace(rep.lams[0], rep.lams[-1], 12)
    assert all(np.isclose(rep.lams, lam, rtol=1e-12).any() for lam in regular)


def test_spectral_default_range_spans_every_skew_direction():
    """From 0.1/√ν_max to 10/√ν_min, ν the sweep's eigenvalues: λ²ν runs from 0.01 (the
    stiffest skew direction still free) to 100 (the softest one damped)."""
    _, U, F, omega, _ = skew_mass_case(6)
    U3, F3 = U.transpose(0, 2, 1).reshape(-1, 6), F.transpose(0, 2, 1).reshape(-1, 6)
    nu = np.asarray(_core.lambda_sweep(U3, F3, np.repeat(omega, 2)).eigenvalues)
    curve = quiet_curve(U, F, omega)
    assert curve.lams[0] ** 2 * nu.max() == pytest.approx(0.01, rel=1e-12)
    assert curve.lams[-1] ** 2 * nu[nu > 1e-15 * nu.max()].min() == pytest.approx(100, rel=1e-12)


def test_repeated_default_range_from_the_skew_diagonal_of_the_kronecker_normal_matrix():
    """Three decades below the smallest, one above the largest √(d/4), d = vᵀ AᵀA v over the
    unit skew directions v = (E_jk − E_kj)/√2 of the paper's stacked real system."""
    _, U, F, omega, delta = skew_mass_case(6)
    A, _ = kronecker_system(U, F, omega)
    J = np.vstack([A.real, A.imag])
    L = np.vstack(symmetry_constraints(6))
    L = L[np.linalg.norm(L, axis=1) > 0]
    d = np.einsum("ij,jk,ik->i", L, J.T @ J, L) / np.einsum("ij,ij->i", L, L)
    rep = quiet_curve(U, F, omega, method="repeated", delta=delta)
    assert rep.lams[0] == pytest.approx(1e-3 * np.sqrt(d.min() / 4), rel=1e-10)
    assert rep.lams[-1] == pytest.approx(10 * np.sqrt(d.max() / 4), rel=1e-10)


def test_repeated_corner_in_an_end_interval_is_flagged():
    """A grid whose first interval holds the corner (the spectral corner λc sits 0.2 decades
    above its first point, 0.7 below its second): the golden search finds it there (within
    its 0.02-decade bracket and the 3-point curvature's offset) and says it lies in an end
    interval, where the grid cannot show a maximum."""
    _, U, F, omega, _ = skew_mass_case(6)
    lc = quiet_curve(U, F, omega).choices["lcurve"]
    grid = lc * 10.0 ** np.array([-0.2, 0.5, 1.0, 1.5, 2.0])
    with pytest.warns(NoCornerWarning, match="in an end interval of the λ range"):
        rep = lambda_curve(U, F, omega, grid, method="repeated")
    assert grid[0] < rep.lam < grid[1]


def test_rules_other_than_the_lcurve_warn_without_claiming_a_missing_corner():
    """GCV's end-of-range problem is a LambdaSelectionWarning, not the L-curve's
    NoCornerWarning (a subclass, which a filter on corners would catch by mistake)."""
    _, U, F, omega, _ = chain_case()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lambda_curve(U, F, omega, rule="gcv")
    ours = [w for w in caught if issubclass(w.category, LambdaSelectionWarning)]
    assert len(ours) == 1 and ours[0].category is LambdaSelectionWarning
    assert str(ours[0].message).startswith("gcv: GCV is smallest at an end")


def _number_after(text: str, words: str) -> float:
    return float(text.split(words, 1)[1].split()[0])


def test_unreachable_discrepancy_messages_quote_the_residual_at_that_end():
    """The message "below the residual r at the smallest λ" quotes the curve's first
    residual, "above the residual r at the largest λ" its last (4 digits: rel 1e-3)."""
    _, U, F, omega, delta = skew_mass_case(4)
    for factor, end in ((1e-3, 0), (1e3, -1)):
        with pytest.warns(LambdaSelectionWarning) as caught:
            curve = lambda_curve(U, F, omega, rule="discrepancy", delta=factor * delta)
        text = str(caught[0].message)
        assert _number_after(text, "δ =") == pytest.approx(factor * delta, rel=1e-3)
        quoted = _number_after(text, "the residual")
        assert quoted == pytest.approx(curve.residual_norms[end], rel=1e-3)


def test_menger_curvature_of_three_points_on_a_circle():
    """1/r for three points on a circle of radius r, positive turning left (counter-
    clockwise), negative turning right, 0 on a line, NaN for coincident points."""
    p, q, r = np.array([2.0, 0.0]), np.array([0.0, 2.0]), np.array([-2.0, 0.0])
    assert reg._menger(p, q, r) == pytest.approx(0.5, rel=1e-15)
    assert reg._menger(r, q, p) == pytest.approx(-0.5, rel=1e-15)
    assert reg._menger(p, np.array([1.0, 0.0]), np.array([0.0, 0.0])) == 0.0
    assert np.isnan(reg._menger(p, p, q))


def test_no_corner_message_quotes_the_corners_curvature_and_the_threshold():
    _, U, F, omega, _ = chain_case()
    with pytest.warns(NoCornerWarning) as caught:
        curve = lambda_curve(U, F, omega)
    text = str(caught[0].message)
    # 3 significant digits: rel 5e-3
    assert _number_after(text, "largest curvature") == pytest.approx(
        curve.corner_curvature, rel=5e-3
    )
    assert _number_after(text, "is below") == pytest.approx(reg.CORNER_MIN_CURVATURE, rel=5e-3)


def test_a_given_grid_bounds_the_rules_search():
    """The rules search the continuous curve between the given grid's ends: on a grid a
    decade and more above the corner the L-curve and GCV can only answer inside it, and the
    L-curve's largest curvature there is at an end, which it says."""
    _, U, F, omega, _ = skew_mass_case(6)
    lc = quiet_curve(U, F, omega).choices["lcurve"]
    grid = lc * 10.0 ** np.array([1.0, 1.5, 2.0])
    curve = quiet_curve(U, F, omega, grid)
    for rule in ("lcurve", "gcv"):
        assert grid[0] <= curve.choices[rule] <= grid[-1], rule
    assert curve.lam in (grid[0], grid[-1])
    assert "an end of the λ range" in curve.problems["lcurve"][0]


def test_identify_passes_an_snr_on_to_the_discrepancy_rule():
    # the same noise level given as σ or as an SNR (10 log10(mean |U|² / σ²)) sets the
    # same target, through identify as through lambda_curve
    _, U, F, omega, sigma = skew_mass_case(4, noise=0.001, on="U")
    snr = 10 * np.log10(np.mean(np.abs(U) ** 2) / sigma**2)
    by_sigma = identify(U, F, omega, "discrepancy", noise=sigma).info["lambda_curve"]
    by_snr = identify(U, F, omega, "discrepancy", snr_db=snr).info["lambda_curve"]
    assert by_snr.target_residual == pytest.approx(by_sigma.target_residual, rel=1e-12)
    # outside the discrepancy rule an SNR alone is refused too, not ignored
    with pytest.raises(ValueError, match="^noise and snr_db set the discrepancy target; they "
                                         "need lam='discrepancy'$"):
        identify(U, F, omega, 1.0, snr_db=snr)


def test_the_discrepancy_target_is_the_noise_seen_through_the_fit_over_every_load_case():
    """δ = σ (p Σ_i ‖D̂(ω_i)‖²_F)^½ is the expected norm of the noise on U through the
    λ = 0 fit's dynamic stiffness, over the s·p response vectors. The noise this case added
    is known (U minus the exact responses): through D̂ its norm is δ up to sampling (720
    complex samples, ~2 % on the norm) and D̂'s own error (6 % off in all here; 10 %
    allowed, where a δ without the p = 2 load cases would be 29 % short). An SNR of 0 dB or
    below is a noise level too (σ ≥ RMS |U|): the same δ as that σ, to round-off."""
    truth, U, F, omega, sigma = skew_mass_case(4, noise=0.001, on="U")
    M, C, K = truth
    exact = np.linalg.solve(-(omega**2)[:, None, None] * M + 1j * omega[:, None, None] * C + K,
                            F)
    pilot = identify(U, F, omega, 0.0)
    D = (-(omega**2)[:, None, None] * pilot.M + 1j * omega[:, None, None] * pilot.C
         + pilot.K)
    curve = lambda_curve(U, F, omega, rule="discrepancy", noise=sigma)
    assert np.linalg.norm(D @ (U - exact)) == pytest.approx(curve.target_residual, rel=0.1)
    rms = np.sqrt(np.mean(np.abs(U) ** 2))
    for snr in (0.0, -3.0):
        by_snr = quiet_curve(U, F, omega, snr_db=snr)
        by_sigma = quiet_curve(U, F, omega, noise=rms * 10 ** (-snr / 20))
        assert by_snr.target_residual == pytest.approx(by_sigma.target_residual, rel=1e-12)



def test_the_discrepancy_target_of_exact_data_is_the_true_dynamic_stiffness():
    """On noise-free data the λ = 0 fit is the truth itself (to 1e-11 on this case), so
    δ = σ (p Σ_i ‖D(ω_i)‖²_F)^½ with D(ω) = −ω²M + iωC + K of the true M, C, K, by hand;
    1e-8 allows that round-off. The damping term is imaginary: a real ωC would move δ by
    0.15 % here."""
    from podid_rs._validation import check_frequency_data

    (M, C, K), U, F, omega, _ = skew_mass_case(4, noise=0.0, on="U")
    w = omega[:, None, None]
    D = -(w**2) * M + 1j * w * C + K
    sigma = 0.01
    expected = sigma * np.sqrt(F.shape[2] * np.sum(np.abs(D) ** 2))
    data = check_frequency_data(U, F, omega)
    assert reg._target_residual(data, sigma, None, None) == pytest.approx(expected, rel=1e-8)

def test_the_smallest_default_grid_and_a_grid_of_repeated_values():
    """n = 3 is the smallest grid the docs allow; a grid of three values of which two are
    equal has two distinct ones, and is refused (in any order)."""
    _, U, F, omega, _ = skew_mass_case(0, m=3, s=10, p=1)
    assert quiet_curve(U, F, omega, n=3).lams.size == 3
    for lams in ([1.0, 1.0, 2.0], [2.0, 1.0, 1.0]):
        with pytest.raises(ValueError, match="at least 3 distinct finite positive values"):
            lambda_curve(U, F, omega, lams)
    assert quiet_curve(U, F, omega, [3.0, 1.0, 2.0]).lams.tolist() == [1.0, 2.0, 3.0]


def test_identify_with_a_rule_keeps_the_numpy_backend_on_the_repeated_path():
    """A rank-deficient unregularised problem falls back to repeated solves: they are the
    backend's asked for, like the spectral path's (whose numpy answer is a solve too)."""
    _, U, F, omega, _ = skew_mass_case(7, s=8, p=1)
    with pytest.warns(LambdaSelectionWarning, match="rank deficient"):
        res = identify(U, F, omega, "lcurve", backend="numpy")
    assert res.info["lambda_curve"].method == "repeated" and res.backend == "numpy"
    ref = identify(U, F, omega, res.lam[0], backend="numpy")
    assert ref.backend == "numpy" and res.method == ref.method
    for X, Y in zip((res.M, res.C, res.K), (ref.M, ref.C, ref.K), strict=True):
        assert np.array_equal(X, Y)


def test_a_degenerate_repeated_l_curve_answers_at_the_grids_middle():
    """A solve whose answers are exactly symmetric has zero penalty everywhere (ln 0 is no
    point of the L-curve): no corner, the grid's middle λ returned, and the warning says
    why."""
    _, U, F, omega, _ = skew_mass_case(0, m=3, s=10, p=1)
    sym = identify(U, F, omega, symmetric=True)
    assert sym.penalty_norm == 0.0
    grid = [0.1, 1.0, 10.0, 100.0, 1000.0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # numpy's log(0)
        with pytest.warns(NoCornerWarning, match=r"degenerate \(zero penalty or residual\); "
                                                 r"λ = 10 returned"):
            curve = lambda_curve(U, F, omega, grid, method="repeated", solve=lambda lam: sym)
    assert curve.lam == 10.0 and np.isnan(curve.corner_curvature)
