"""The matrix-free covariance's memory: solves in blocks of a bounded size, the stars'
inverses two to an array, the per-line inverses let go — and the same answers; a solve
that does not converge is told, never silent."""

from __future__ import annotations

import tracemalloc
import warnings

import numpy as np
import pytest

import podid_rs as pr
import podid_rs.identification.covariance as covariance
from podid_rs.identification.covariance import (
    LinearisedFit,
    MatrixFreeCovariance,
    entry_weights,
    pack_hermitian,
)


def _chain_data(n: int, s: int, seed: int = 5):
    """A chain driven by random forces on every DOF, its upper modes above the band, 0.1 %
    noise: (system, U, F, omega)."""
    system = pr.mass_spring_chain(n)
    f = pr.modal_parameters(system).frequencies_hz
    omega = 2 * np.pi * np.linspace(0.5 * f[0], 0.6 * f[-1], s)
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((s, n)) + 1j * rng.standard_normal((s, n))
    U = np.einsum("sij,sj->si", system.frf(omega), F)
    U = U * (1 + 1e-3 * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)))
    return system, U, F, omega


def _linearised(n: int, s: int, objective: str = "complex", **kw) -> LinearisedFit:
    system, U, F, omega = _chain_data(n, s)
    U, F = U[:, :, None], F[:, :, None]
    W = entry_weights("relative" if objective == "complex" else "uniform", U, objective, False)
    return LinearisedFit(system.M, system.C, system.K, U, F, omega, np.eye(n), W, objective,
                         **kw)


@pytest.mark.parametrize("objective", ["complex", "log-magnitude"])
def test_packed_grams_and_line_solves_give_the_same_products(objective):
    """N through the packed per-line matrices (P = Re G + Im G) as through G itself, and
    the products with the Jacobian once the per-line inverses are let go (solves per
    line) as with them."""
    fit = _linearised(6, 40, objective)
    rng = np.random.default_rng(1)
    V = rng.standard_normal((fit.n_params, 5))
    G, Gt = fit.line_grams(fit.bread())
    full = fit.gram_product((G, Gt), V)
    packed = fit.gram_product((pack_hermitian(G), Gt), V)
    assert pack_hermitian(G).dtype == np.float64
    assert np.abs(packed - full).max() <= 1e-13 * np.abs(full).max()
    J, JT = fit.apply_jacobian(V), fit.apply_adjoint(fit.apply_jacobian(V))
    # without the inverses from the start: the same responses and packed matrices
    lean = _linearised(6, 40, objective, keep_inverses=False)
    assert lean.Dinv is None
    assert np.abs(lean.x - fit.x).max() <= 1e-13 * np.abs(fit.x).max()
    P, Pt = lean.line_grams(lean.bread(), packed=True)
    assert P.dtype == np.float64 and np.abs(P - pack_hermitian(G)).max() <= 1e-12 * np.abs(G).max()
    assert (Pt is None) == (Gt is None)
    if Gt is not None:
        assert np.abs(Pt - Gt).max() <= 1e-12 * np.abs(Gt).max()
    fit.release_inverses()
    assert fit.Dinv is None
    J2, JT2 = fit.apply_jacobian(V), fit.apply_adjoint(fit.apply_jacobian(V))
    assert np.abs(J2 - J).max() <= 1e-12 * np.abs(J).max()
    assert np.abs(JT2 - JT).max() <= 1e-12 * np.abs(JT).max()


def test_the_stars_inverses_two_to_an_array_are_the_inverted_blocks():
    """The preconditioner from the stars' inverse factors (single precision, two to an
    array) equals the sum over the stars of the inverted, unit-diagonal blocks of N, to
    single precision; Fᵀ F is each inverse."""
    fit = _linearised(5, 40)
    grams = fit.line_grams(fit.bread())
    stars, index = fit.star_blocks(grams), fit.star_index()
    cov = MatrixFreeCovariance(_linearised(5, 40), rank=fit.n_params)
    assert cov._star_pairs.shape == (3, 16, 15)  # 5 stars of 15 × 15 in 3 arrays
    assert cov._star_pairs.dtype == np.float32
    r = np.random.default_rng(2).standard_normal((fit.n_params, 3))
    ref = np.zeros_like(r)
    for j in range(fit.m):
        d = np.sqrt(np.diagonal(stars[j]))
        block = stars[j] / np.outer(d, d) + covariance.STAR_RIDGE * np.eye(15)
        ref[index[j]] += np.linalg.solve(block, r[index[j]])
        F = covariance._inverse_factor(stars[j])
        assert np.allclose(F, np.tril(F)) and np.allclose(F.T @ F @ block, np.eye(15))
    got = cov._precondition(r)
    assert np.abs(got - ref).max() <= 1e-5 * np.abs(ref).max()


def test_column_blocks_are_equal_and_within_the_budget(monkeypatch):
    fit = _linearised(6, 30)
    cov = MatrixFreeCovariance(fit, rank=fit.n_params)
    q = fit.n_params
    monkeypatch.setattr(covariance, "CG_BLOCK_BYTES", 20 * covariance.CG_LIVE_BLOCKS * 8 * q)
    monkeypatch.setattr(covariance, "CG_BLOCK_MIN", 4)
    blocks = cov.column_blocks(50)
    assert [b.size for b in blocks] == [17, 17, 16]  # 3 blocks of at most 20
    assert np.array_equal(np.concatenate(blocks), np.arange(50))
    assert [b.size for b in cov.column_blocks(20)] == [20]
    monkeypatch.setattr(covariance, "CG_BLOCK_BYTES", 1)
    # a budget below CG_BLOCK_MIN right-hand sides: blocks of up to CG_BLOCK_MIN
    assert [b.size for b in cov.column_blocks(9)] == [3, 3, 3]


def test_the_blocked_solve_equals_the_one_block_solve(monkeypatch):
    """N X = B for 24 right-hand sides in one block and in three (tolerance 1e-11): the
    same X to 1e-8 relative, and the modes' variances through the model too."""
    fit = _linearised(8, 60)
    q = fit.n_params
    B = np.random.default_rng(3).standard_normal((q, 24))
    one = MatrixFreeCovariance(fit, rank=q, tol=1e-11)
    X1, ok1 = one.solve(B)
    assert len(one.iterations) == 1 and ok1.all()
    monkeypatch.setattr(covariance, "CG_BLOCK_BYTES", 8 * covariance.CG_LIVE_BLOCKS * 8 * q)
    monkeypatch.setattr(covariance, "CG_BLOCK_MIN", 1)
    three = MatrixFreeCovariance(_linearised(8, 60), rank=q, tol=1e-11)
    X3, ok3 = three.solve(B)
    assert len(three.iterations) == 3 and ok3.all()
    assert np.abs(X3 - X1).max() <= 1e-8 * np.abs(X1).max()

    system, U, F, omega = _chain_data(8, 60)
    monkeypatch.undo()
    whole = pr.model_uncertainty(system, U, F, omega, solver="matrix-free").modes()
    monkeypatch.setattr(covariance, "CG_BLOCK_BYTES", 6 * covariance.CG_LIVE_BLOCKS * 8 * q)
    monkeypatch.setattr(covariance, "CG_BLOCK_MIN", 1)
    unc = pr.model_uncertainty(system, U, F, omega, solver="matrix-free")
    parts = unc.modes()
    assert len(unc._cov.iterations) == 3  # 16 gradients in blocks of 6, 5, 5
    assert np.allclose(parts.std_frequency_hz, whole.std_frequency_hz, rtol=1e-7)
    assert np.allclose(parts.std_damping, whole.std_damping, rtol=1e-7)


def test_the_intervals_stay_within_their_memory_budget(monkeypatch):
    """A 30-DOF chain (1395 coordinates), the solves' budget set to 20 right-hand sides and
    the products' intermediates to 4 columns: the traced peak of the modes' intervals
    stays within the budget and 1.5 MB, the FRF band's within the budget, the draws
    (single precision) and 2 MB — where one block of the modes' 60 gradients would not
    fit (traced: 5.9 and 17 MB). The stars' inverses take half
    their square, the per-line matrices are packed, the per-line inverses let go."""
    n, s = 30, 100
    system, U, F, omega = _chain_data(n, s)
    q = 3 * n * (n + 1) // 2
    budget = 20 * covariance.CG_LIVE_BLOCKS * 8 * q
    monkeypatch.setattr(covariance, "CG_BLOCK_BYTES", budget)
    monkeypatch.setattr(covariance, "PRODUCT_ELEMENTS", s * n * 4)
    monkeypatch.setattr(covariance, "LINE_SOLVE_ELEMENTS", n * n * 10)
    monkeypatch.setattr(pr.uncertainty, "FRF_BLOCK_ELEMENTS_MATRIX_FREE", 1 << 15)
    unc = pr.model_uncertainty(system, U, F, omega, solver="matrix-free")
    cov = unc._cov
    assert cov.fit.Dinv is None  # never kept: the products solve per line
    assert cov._star_pairs.nbytes <= 0.55 * n * (3 * n) ** 2 * 8
    assert cov._grams[0].dtype == np.float64 and cov._grams[0].nbytes == s * n * n * 8
    draws = covariance.SAMPLES * q * 4
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        modes = unc.modes()
        after_modes = tracemalloc.get_traced_memory()[1] - before
        tracemalloc.reset_peak()
        band = unc.frf(omega, rows=[0, n - 1], cols=[0])
        after_band = tracemalloc.get_traced_memory()[1] - before
    finally:
        tracemalloc.stop()
    # 60 gradients in blocks of 20, the 200 draws in blocks within what the draws leave
    assert len(cov.iterations) == 3 + len(cov.column_blocks(200, held=draws)) > 3 + 10
    assert np.all(np.isfinite(modes.std_frequency_hz)) and np.all(np.isfinite(band.upper))
    assert after_modes <= budget + 1.5e6, after_modes
    assert after_band <= budget + draws + 2.0e6, after_band
    assert 60 * covariance.CG_LIVE_BLOCKS * 8 * q > budget + 1.5e6


def test_a_solve_that_does_not_converge_warns_and_says_why(monkeypatch):
    """Two iterations of CG where twenty are needed: a ConvergenceWarning, NaN variances,
    the modes' reason "not converged"; the band's draws (none solved) warn too."""
    system, U, F, omega = _chain_data(8, 60)
    monkeypatch.setattr(covariance, "CG_MAX_ITER", 2)
    unc = pr.model_uncertainty(system, U, F, omega, solver="matrix-free")
    with pytest.warns(pr.ConvergenceWarning, match="did not reach the relative residual"):
        modes = unc.modes()
    assert not modes.determined.any()
    assert set(modes.why_undetermined) == {"not converged"}
    # the 200 draws span the 108 coordinates in one iteration: none at all for them
    monkeypatch.setattr(covariance, "CG_MAX_ITER", 0)
    with pytest.warns(pr.ConvergenceWarning, match="draws are left out"):
        band = unc.frf(omega[::10])
    assert np.all(np.isnan(band.upper))
    monkeypatch.undo()
    unc = pr.model_uncertainty(system, U, F, omega, solver="matrix-free")
    with warnings.catch_warnings():
        warnings.simplefilter("error", pr.ConvergenceWarning)
        modes = unc.modes()
    assert modes.determined.all() and set(modes.why_undetermined) == {""}


def test_a_mode_whose_interval_is_wider_than_its_value_says_so():
    """A dense fit whose noise swamps the data: the modes without an interval are told
    apart from those the data do not fix."""
    system, U, F, omega = _chain_data(4, 30)
    unc = pr.model_uncertainty(system, U, F, omega, solver="dense", noise_variance=1e6)
    modes = unc.modes()
    assert not modes.determined.any()
    assert set(modes.why_undetermined) == {"wider than the value"}


def _resident_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise OSError("no VmRSS")


def test_free_memory_is_given_back_to_the_system(monkeypatch):
    """After a large array is freed glibc takes arrays up to 32 MiB from its heap, and keeps
    them resident once freed: release_free_memory gives them back (glibc only), and does
    nothing where there is no malloc_trim."""
    from podid_rs import _memory

    if _memory._malloc_trim() is None:
        pytest.skip("not glibc")
    try:
        _resident_mb()
    except OSError:
        pytest.skip("no /proc")
    big = np.ones(3_750_000)  # 30 MB: above the threshold, then raises it to 30 MB
    del big
    parts = [np.ones(250_000) for _ in range(200)]  # 2 MB each, 400 MB: from the heap
    keep = parts[-1].copy()  # (the heap's top stays in use)
    del parts
    before = _resident_mb()
    _memory.release_free_memory()
    after = _resident_mb()
    assert before - after > 200, (before, after)
    del keep
    monkeypatch.setattr(_memory.ctypes.util, "find_library", lambda name: None)
    _memory._malloc_trim.cache_clear()
    try:
        assert _memory._malloc_trim() is None
        _memory.release_free_memory()  # nothing to call: nothing done
    finally:
        _memory._malloc_trim.cache_clear()
