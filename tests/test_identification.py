"""identify(): exact recovery, parity with the Kronecker oracle, both backends, bad input.

Tolerances: noise-free full-order data determine M, C, K exactly, and the scaled
normal matrices here have condition numbers below ~1e6, so double precision
leaves ~1e-10 relative error; we assert 1e-8 (the project's target). Parity with
the oracle is asserted where its stacked matrix is well conditioned (checked).
"""

from __future__ import annotations

import numpy as np
import pytest

from podid_rs import RankDeficientWarning, _core, identify, mass_spring_chain
from podid_rs.identification.reference import identify_kronecker
from podid_rs.identification.solvers import gram_numpy

BACKENDS = ["rust", "numpy"]


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def max_rel(res, ref) -> float:
    return max(rel(getattr(res, k), getattr(ref, k)) for k in "MCK")


def chain_data(n: int, s: int = 40, p: int = 1, seed: int = 0, noise: float = 0.0):
    """Full-order chain (R = I): random complex forces on every DOF, s lines 5–200 Hz."""
    rng = np.random.default_rng(seed)
    sys = mass_spring_chain(n)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, s)
    F = rng.standard_normal((s, n, p)) + 1j * rng.standard_normal((s, n, p))
    U = sys.response(omega, F)
    if noise:
        scale = noise * np.sqrt(np.mean(np.abs(U) ** 2, axis=0, keepdims=True))
        U = U + scale * (rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape))
    if p == 1:
        U, F = U[..., 0], F[..., 0]
    return sys, U, F, omega


def random_system_data(m: int, s: int, p: int, seed: int, noise: float):
    """A random non-symmetric, non-proportionally damped system and its data."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, m))
    M = np.eye(m) + 0.1 * A
    C = 0.2 * np.eye(m) + 0.05 * rng.standard_normal((m, m))
    K = 50 * np.eye(m) + 5 * rng.standard_normal((m, m))
    omega = np.sort(rng.uniform(0.5, 15.0, s))
    F = rng.standard_normal((s, m, p)) + 1j * rng.standard_normal((s, m, p))
    D = -(omega**2)[:, None, None] * M + 1j * omega[:, None, None] * C + K
    U = np.linalg.solve(D, F)
    U = U + noise * np.abs(U).mean() * (
        rng.standard_normal(U.shape) + 1j * rng.standard_normal(U.shape)
    )
    return (M, C, K), U, F, omega


# --------------------------------------------------------------------------- gram


def test_rust_gram_matches_numpy():
    rng = np.random.default_rng(3)
    N, m = 57, 7
    U = rng.standard_normal((N, m)) + 1j * rng.standard_normal((N, m))
    F = rng.standard_normal((N, m)) + 1j * rng.standard_normal((N, m))
    w = rng.uniform(0.3, 4.0, N)
    H, B = gram_numpy(U, F, w)
    H2, B2 = _core.gram(U, F, w)
    assert H2.shape == (3 * m, 3 * m) and B2.shape == (m, 3 * m)
    assert rel(H2, H) < 1e-12
    assert rel(B2, B) < 1e-12
    assert np.array_equal(H2, H2.T)


# ------------------------------------------------------------- exact recovery


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("n", [6, 8, 10])
@pytest.mark.parametrize("lam,symmetric", [(0.0, False), (100.0, False), (0.0, True)])
def test_noise_free_chain_recovered(backend, n, lam, symmetric):
    sys, U, F, omega = chain_data(n)
    res = identify(U, F, omega, lam, symmetric, backend=backend)
    assert res.method == "cholesky" and res.well_posed
    for X, T in zip((res.M, res.C, res.K), (sys.M, sys.C, sys.K), strict=True):
        assert rel(X, T) < 1e-8
    assert res.residual_norm < 1e-8 * np.linalg.norm(F)


def test_oracle_recovers_chain_too():
    sys, U, F, omega = chain_data(6)
    for lam, sym in [(0.0, False), (100.0, False), (0.0, True)]:
        ref = identify_kronecker(U, F, omega, lam, sym)
        assert max(rel(ref.M, sys.M), rel(ref.C, sys.C), rel(ref.K, sys.K)) < 1e-8


# ------------------------------------------------------------ oracle parity

CASES = [
    # m, s, p, seed, noise, lam, symmetric
    (1, 6, 1, 0, 0.05, 0.0, False),
    (3, 10, 1, 1, 0.05, 0.0, False),
    (4, 6, 3, 2, 0.10, (1.0, 0.0, 10.0), False),
    (5, 20, 2, 3, 0.05, (0.0, 3.0, 0.0), False),
    (6, 30, 1, 4, 0.05, 1e4, False),
    (6, 12, 2, 5, 0.20, 0.0, True),
    (8, 30, 1, 6, 0.05, (0.5, 0.5, 0.5), False),
    (12, 40, 1, 7, 0.02, 5.0, False),
    (24, 60, 1, 10, 0.02, (20.0, 0.0, 1.0), False),
    (24, 30, 1, 11, 0.05, 0.0, True),
]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("case", CASES, ids=lambda c: f"m{c[0]}-p{c[2]}-lam{c[5]}-sym{c[6]}")
def test_matches_kronecker_oracle_on_random_noisy_cases(backend, case):
    m, s, p, seed, noise, lam, symmetric = case
    _, U, F, omega = random_system_data(m, s, p, seed, noise)
    ref = identify_kronecker(U, F, omega, lam, symmetric)
    res = identify(U, F, omega, lam, symmetric, backend=backend)
    assert ref.rank == (3 * m * (m + 1) // 2 if symmetric else 3 * m * m)  # oracle full rank
    assert max_rel(res, ref) < 1e-8
    assert res.residual_norm == pytest.approx(ref.residual_norm, rel=1e-8)


@pytest.mark.parametrize("backend", BACKENDS)
def test_matches_oracle_on_noisy_chain_with_paper_lambda(backend):
    """docs/design.md §3: here the plain-basis normal equations lose 10–60 %; ours must not."""
    _, U, F, omega = chain_data(6, s=60, noise=0.05, seed=11)
    ref = identify_kronecker(U, F, omega, 100.0)
    res = identify(U, F, omega, 100.0, backend=backend)
    assert max_rel(res, ref) < 1e-8
    assert res.penalty_norm == pytest.approx(ref.penalty_norm, rel=1e-6, abs=1e-12)


def test_backends_agree_at_larger_order():
    _, U, F, omega = random_system_data(20, 60, 2, 8, 0.05)
    for lam, sym in [(0.0, False), (2.0, False), (0.0, True)]:
        a = identify(U, F, omega, lam, sym, backend="rust", solver="direct")
        b = identify(U, F, omega, lam, sym, backend="numpy")
        assert max_rel(a, b) < 1e-9


@pytest.mark.parametrize("lam, symmetric", [(0.0, False), (2.0, False), (0.0, True)])
def test_penalty_norms_are_the_skew_parts_of_the_answer(lam, symmetric):
    """‖X − Xᵀ‖_F of each returned block (NumPy's loops, not BLAS, compute them)."""
    _, U, F, omega = random_system_data(12, 40, 2, 3, 0.05)
    res = identify(U, F, omega, lam, symmetric)
    want = [np.linalg.norm(X - X.T) for X in (res.M, res.C, res.K)]
    assert res.penalty_norms == pytest.approx(want, rel=1e-12, abs=0.0)
    assert (max(want) == 0.0) == symmetric
    rel = [w / np.linalg.norm(X) for w, X in zip(want, (res.M, res.C, res.K), strict=True)]
    assert res.symmetry_defect() == pytest.approx(rel, rel=1e-12, abs=0.0)


def test_symmetric_mode_is_the_large_lambda_limit():
    _, U, F, omega = chain_data(6, s=50, noise=0.05, seed=2)
    sym = identify(U, F, omega, symmetric=True)
    for X in (sym.M, sym.C, sym.K):
        assert np.array_equal(X, X.T)
    errs = [max_rel(identify(U, F, omega, lam), sym) for lam in (1e2, 1e4, 1e6)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 1e-6


def test_threads_do_not_change_the_answer():
    _, U, F, omega = random_system_data(10, 30, 2, 9, 0.05)
    a = identify(U, F, omega, 1.0, threads=1)
    b = identify(U, F, omega, 1.0, threads=2)
    assert max_rel(a, b) < 1e-12


# --------------------------------------------------------------- bad input


def good_data():
    _, U, F, omega = random_system_data(3, 10, 1, 0, 0.0)
    return U[..., 0], F[..., 0], omega


@pytest.mark.parametrize(
    "mutate,match",
    [
        (lambda U, F, w: (U, F[:, :2], w), "same shape"),
        (lambda U, F, w: (U, F, w[:-1]), "one entry per frequency line"),
        (lambda U, F, w: (U[0], F[0], w), r"shape \(s, m\)"),
        (lambda U, F, w: (np.where(np.eye(10, 3, dtype=bool), np.nan, U), F, w), "non-finite"),
        (lambda U, F, w: (U, np.where(np.eye(10, 3, dtype=bool), np.inf, F), w), "non-finite"),
        (lambda U, F, w: (U, F, np.r_[0.0, w[1:]]), "strictly positive"),
        (lambda U, F, w: (U, F, -w), "strictly positive"),
        (lambda U, F, w: (U[:1], F[:1], w[:1]), "too few equations"),
        (lambda U, F, w: (U.astype(object), F, w), "numeric"),
        (lambda U, F, w: (np.zeros_like(U), F, w), "identically zero"),
        (lambda U, F, w: (U, F, w + 1j), "real"),
    ],
)
def test_bad_input_raises_value_error_naming_the_problem(mutate, match):
    U, F, w = mutate(*good_data())
    with pytest.raises(ValueError, match=match):
        identify(U, F, w)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"lam": -1.0}, "non-negative"),
        ({"lam": (1.0, 2.0)}, "triple"),
        ({"lam": np.nan}, "finite"),
        ({"lam": "bogus"}, "selection rule"),
        ({"lam": "gcv", "symmetric": True}, "symmetric=True"),
        ({"lam": 1.0, "noise": 0.1}, "discrepancy"),
        ({"backend": "fortran"}, "backend"),
        ({"threads": -2}, "threads"),
        ({"threads": 2**40}, "threads"),
        ({"threads": 1.5}, "threads"),
        # a bool is an int to Python; True must not pass as one worker thread
        ({"threads": True}, "threads must be None or a positive integer, got True"),
        ({"symmetric": "no"}, "True or False"),
    ],
)
def test_bad_options_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        identify(*good_data(), **kwargs)


def test_inputs_are_not_modified():
    U, F, w = good_data()
    U0, F0, w0 = U.copy(), F.copy(), w.copy()
    for backend in BACKENDS:
        identify(U, F, w, 1.0, backend=backend)
        identify(U, F, w, symmetric=True, backend=backend)
    assert np.array_equal(U, U0) and np.array_equal(F, F0) and np.array_equal(w, w0)


def test_non_contiguous_and_real_inputs_accepted():
    U, F, w = good_data()
    Ua = np.asfortranarray(U)
    Fb = np.repeat(F, 2, axis=1)[:, ::2]  # strided view of the same values
    a = identify(Ua, Fb, w.tolist())
    b = identify(U, F, w)
    assert max_rel(a, b) < 1e-14


@pytest.mark.parametrize("backend", BACKENDS)
def test_rank_deficient_data_warns_and_returns_min_norm(backend):
    # enough equations by count, but every frequency line repeats one vector:
    # H has rank 2, so M, C, K are not determined
    U, F, w = good_data()
    U = np.repeat(U[:1], 10, axis=0)
    F = np.repeat(F[:1], 10, axis=0)
    w = np.repeat(w[:1], 10)
    with pytest.warns(RankDeficientWarning, match="rank") as caught:
        res = identify(U, F, w, backend=backend)
    assert not res.well_posed and res.method == "eigen-min-norm"
    # H = Re(v vᴴ) of one complex vector v has rank 2, and the unregularised 3m × 3m system
    # is shared by the m rows of Z = [M C K]: rank 2m = 6 of 3m² = 27 unknowns
    assert (res.rank, res.n_unknowns) == (6, 27)
    assert "(rank 6 of 27 unknowns)" in str(caught[0].message)
    # the min-norm answer still fits the data it was given
    assert res.residual_norm < 1e-8 * np.linalg.norm(F)
    assert np.all(np.isfinite(res.M))


def test_memory_guard_refuses_impossible_size(monkeypatch):
    import podid_rs._memory as ident

    monkeypatch.setattr(ident, "available_memory_bytes", lambda: 10**9)
    _, U, F, omega = random_system_data(40, 70, 1, 0, 0.0)
    # 3·40² = 4800 unknowns → 184 MB normal matrix; pretend only 1 GB... fits
    identify(U, F, omega, 1.0, solver="direct")
    monkeypatch.setattr(ident, "available_memory_bytes", lambda: 10**8)
    with pytest.raises(MemoryError, match="GB"):
        identify(U, F, omega, 1.0, solver="direct")
    # the unregularised problem only needs the 3m×3m Gram matrix
    identify(U, F, omega, 0.0)
    # solver="auto" does not try the dense matrix where it would not fit
    assert identify(U, F, omega, 1.0).method == "cg"


@pytest.mark.parametrize("solver", ["direct", "cg"])
@pytest.mark.parametrize("p", [1, 3])
def test_residual_norm_from_the_core_is_the_misfit_of_the_answer(solver, p):
    # the core computes ‖Ax − y‖ from its per-line products; NumPy's row form of the
    # same misfit must agree to rounding (noisy data: the misfit is far from 0)
    from podid_rs._validation import check_frequency_data
    from podid_rs.identification.result import residual_norm

    _, U, F, omega = chain_data(6, s=30, p=p, noise=0.02)
    res = identify(U, F, omega, 1.0, solver=solver)
    want = residual_norm(res.M, res.C, res.K, check_frequency_data(U, F, omega))
    assert want > 1e-3 * np.linalg.norm(F)
    assert abs(res.residual_norm - want) <= 1e-10 * want


def test_validated_data_are_read_only_views_and_the_input_stays_writeable():
    from podid_rs._validation import check_frequency_data

    _, U, F, omega = chain_data(4, s=12)
    data = check_frequency_data(U, F, omega)
    assert np.shares_memory(data.U, U) and not data.U.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        data.F[0, 0, 0] = 1.0
    before = U.copy()
    identify(U, F, omega, 1.0, solver="cg")
    assert U.flags.writeable and F.flags.writeable and np.array_equal(U, before)


def test_too_few_equations_counts_lines_load_cases_and_the_penalised_blocks():
    """2m real equations per complex response vector (s·p of them), m(m−1)/2 more for
    each block with a positive λ, against 3m² unknowns (paper eqs. 28–30): at m = 3 and
    s·p = 4, 24 < 27 is refused, and two penalised blocks make it 30 ≥ 27."""
    (_, _, _), U, F, omega = random_system_data(3, 4, 1, 0, 0.0)
    with pytest.raises(
        ValueError,
        match=r"4 frequency line\(s\) × 1 load case\(s\) give 24 real equations for 27 "
        r"unknowns at order m = 3",
    ):
        identify(U, F, omega, (0.0, 0.0, 0.0))
    assert identify(U, F, omega, (0.0, 1.0, 1.0)).well_posed
    (_, _, _), U, F, omega = random_system_data(3, 1, 3, 0, 0.0)
    with pytest.raises(ValueError, match=r"1 frequency line\(s\) × 3 load case\(s\) give 18"):
        identify(U, F, omega)


def test_omega_of_the_wrong_length_names_both_lengths():
    U, F, w = good_data()  # s = 10
    with pytest.raises(ValueError, match=r"\(s = 10\); got shape \(9,\)"):
        identify(U, F, w[:-1])


def test_backends_report_the_same_rank_and_pivot_ratio():
    """min_pivot_ratio = min_i L_ii² / G_ii of the scaled normal matrix's Cholesky factor,
    computed by NumPy and by the Rust core on the same matrix: equal to round-off."""
    _, U, F, omega = random_system_data(8, 40, 2, 3, 0.05)
    for lam, sym in [(0.0, False), (2.0, False), (0.0, True)]:
        a = identify(U, F, omega, lam, sym, backend="rust", solver="direct")
        b = identify(U, F, omega, lam, sym, backend="numpy")
        assert (a.method, a.rank, a.n_unknowns) == (b.method, b.rank, b.n_unknowns)
        assert 0 < b.min_pivot_ratio < 1
        assert a.min_pivot_ratio == pytest.approx(b.min_pivot_ratio, rel=1e-8)


def test_the_hint_to_penalise_every_block_only_where_one_is_not():
    """At m = 3 (27 unknowns) and s·p = 3 (18 equations), λ on one block adds 3: refused,
    with the hint to penalise every block; with every block penalised and s·p = 2
    (12 + 9 = 21 < 27) refused without it."""
    (_, _, _), U, F, omega = random_system_data(3, 3, 1, 0, 0.0)
    with pytest.raises(ValueError, match=r"give 21 real .* \(a positive lam on every block"):
        identify(U, F, omega, (0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match=r"give 21 real equations for 27 unknowns at order m = 3$"):
        identify(U[:2], F[:2], omega[:2], 1.0)


# ------------------------------------------- the values quoted, the exact bounds


def test_shape_refusals_quote_the_shapes_given():
    # good_data(): U and F (10, 3), omega (10,); each message names the shapes passed
    U, F, w = good_data()
    with pytest.raises(ValueError, match=r"^U must have shape \(s, m\) or \(s, m, p\); "
                                         r"got shape \(10,\)$"):
        identify(U[:, 0], F, w)
    with pytest.raises(ValueError, match=r"^F must have shape \(s, m\) or \(s, m, p\) like U; "
                                         r"got shape \(10,\)$"):
        identify(U, F[:, 0], w)
    # (s, m) shown as given; (s, m, p) with its load cases
    with pytest.raises(ValueError, match=r"; got U \(10, 3\) and F \(10, 2\)$"):
        identify(U, F[:, :2], w)
    with pytest.raises(ValueError, match=r"; got U \(10, 3, 2\) and F \(10, 3\)$"):
        identify(np.stack([U, U], axis=2), F, w)
    with pytest.raises(ValueError, match=r"\(s = 10\); got shape \(9,\)$"):
        identify(U, F, w[:-1])
    # a column of frequencies is not 1-D, though it has one entry per line
    with pytest.raises(ValueError, match=r"^omega must be a non-empty 1-D array \(rad/s\), "
                                         r"got shape \(10, 1\)$"):
        identify(U, F, w[:, None])
    # the first entry that is not positive is named: omega[1] = 0, not the negative omega[2]
    with pytest.raises(ValueError, match=r"^omega must be strictly positive \(rad/s\); "
                                         r"omega\[1\] = 0\.0$"):
        identify(U, F, np.r_[w[0], 0.0, -w[2:]])


def test_a_zero_entry_is_data_only_all_zeros_is_refused():
    # one response entry exactly zero is legitimate (a node at a line); the refusal is
    # for U with no non-zero entry at all
    _, U, F, w = random_system_data(3, 10, 1, 0, 0.0)
    U = U[..., 0].copy()
    U[4, 1] = 0.0
    res = identify(U, F[..., 0], w)
    assert np.all(np.isfinite(res.M)) and res.well_posed


def test_the_equation_count_takes_every_load_case_and_the_symmetric_unknowns():
    # m = 2, λ = 0: 3m² = 12 unknowns, and each (line, load case) pair gives 2m = 4 real
    # equations: one line with three load cases is enough by count, with two it is not.
    # (One line cannot tell M, C and K apart, so the counted-enough case is solved with
    # the rank it has, and says so: accepted, not refused. At one ω only Re D = K − ω²M
    # and Im D = ωC are seen, 4 + 4 of the 12 numbers: rank 8.)
    _, U, F, w = random_system_data(2, 1, 3, 0, 0.0)
    with pytest.warns(RankDeficientWarning, match=r"\(rank 8 of 12 unknowns\)"):
        assert identify(U, F, w).n_unknowns == 12
    with pytest.raises(ValueError, match=r"^too few equations: 1 frequency line\(s\) × 2 load "
                                         r"case\(s\) give 8 real equations for 12 unknowns at "
                                         r"order m = 2 \(a positive lam"):
        identify(U[..., :2], F[..., :2], w)
    # exact-symmetric, m = 3: 3m(m+1)/2 = 18 unknowns, 2m = 6 equations per line
    _, U, F, w = random_system_data(3, 3, 1, 1, 0.0)
    assert identify(U, F, w, symmetric=True).n_unknowns == 18
    with pytest.raises(ValueError, match=r"give 12 real equations for 18 unknowns at order "
                                         r"m = 3$"):
        identify(U[:2], F[:2], w[:2], symmetric=True)


def test_a_lam_triple_keeps_its_order():
    U, F, w = good_data()
    assert identify(U, F, w, (1.0, 2.0, 3.0)).lam == (1.0, 2.0, 3.0)
    assert identify(U, F, w, 4.0).lam == (4.0, 4.0, 4.0)


def test_threads_up_to_the_core_bound_and_the_refusal_quotes_the_value():
    from podid_rs.identification.result import MAX_THREADS, _check_threads

    assert MAX_THREADS == 1024 and _check_threads(1024) == 1024 and _check_threads(1) == 1
    with pytest.raises(ValueError, match=r"^threads must be between 1 and 1024, got 1025$"):
        identify(*good_data(), threads=1025)
    # all cores is None, as the systems' threads: 0 is refused as the message says
    with pytest.raises(ValueError, match=r"^threads must be between 1 and 1024, got 0$"):
        identify(*good_data(), threads=0)


def test_warnings_point_at_the_line_that_called_identify():
    # stacklevel: a warning must name the caller's file, not the package's
    U, F, w = good_data()
    U, F, w = np.repeat(U[:1], 10, axis=0), np.repeat(F[:1], 10, axis=0), np.repeat(w[:1], 10)
    with pytest.warns(RankDeficientWarning) as record:
        identify(U, F, w)
    assert record[0].filename == __file__


def test_symmetry_defect_is_each_matrix_own_relative_skew_part():
    from podid_rs.identification.result import IdentificationResult

    def result(M, C, K):
        return IdentificationResult(
            np.asarray(M, float), np.asarray(C, float), np.asarray(K, float), (0.0, 0.0, 0.0),
            False, 0.0, (0.0, 0.0, 0.0), "cholesky", 12, 12, 1.0, "numpy",
        )

    # by hand: M = I is symmetric; C = [[0, 1], [0, 0]] has ‖C − Cᵀ‖ = √2 and ‖C‖ = 1;
    # K = [[2, 1], [0, 2]] has ‖K − Kᵀ‖ = √2 and ‖K‖ = 3
    d = result(np.eye(2), [[0, 1], [0, 0]], [[2, 1], [0, 2]]).symmetry_defect()
    np.testing.assert_allclose(d, (0.0, np.sqrt(2), np.sqrt(2) / 3), rtol=1e-15, atol=0)
    # a zero matrix has no skew part: 0, not 0/0
    assert result(np.eye(2), np.zeros((2, 2)), np.eye(2)).symmetry_defect() == (0.0, 0.0, 0.0)
