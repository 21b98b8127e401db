import numpy as np
import pytest

from podid_rs.identification.reference import (
    identify_kronecker,
    kronecker_system,
    symmetry_constraints,
    vec_permutation,
)
from podid_rs.systems import mass_spring_chain


def vec(X: np.ndarray) -> np.ndarray:
    return X.ravel(order="F")


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def random_data(m: int, s: int, p: int = 1, seed: int = 0):
    """O(1) random responses and forces: a generic, non-symmetric, noisy problem."""
    rng = np.random.default_rng(seed)
    shape = (s, m, p)
    U = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    F = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    return U, F, np.linspace(0.5, 2.0, s)


@pytest.mark.parametrize(("p", "q"), [(1, 1), (1, 4), (3, 1), (2, 3), (5, 4)])
def test_vec_permutation_maps_vec_x_to_vec_x_transpose(p, q):
    X = np.random.default_rng(p * 10 + q).standard_normal((p, q))
    P = vec_permutation(p, q)
    assert P.shape == (p * q, p * q)
    np.testing.assert_array_equal(P @ vec(X), vec(X.T))
    np.testing.assert_array_equal(P.T, vec_permutation(q, p))
    np.testing.assert_array_equal(P @ P.T, np.eye(p * q))


def test_kronecker_system_is_eq_25_block_by_block():
    m, s, p = 3, 4, 2
    U, F, omega = random_data(m, s, p)
    A, y = kronecker_system(U, F, omega)
    assert A.shape == (s * p * m, 3 * m * m) and y.shape == (s * p * m,)
    eye = np.eye(m)
    row = 0
    for i in range(s):
        W = np.hstack([-(omega[i] ** 2) * eye, 1j * omega[i] * eye, eye])
        for load in range(p):
            np.testing.assert_array_equal(A[row : row + m], np.kron(U[i, :, load][None, :], W))
            np.testing.assert_array_equal(y[row : row + m], F[i, :, load])
            row += m


def test_a_times_vec_mck_is_the_dynamic_equation():
    m = 4
    U, F, omega = random_data(m, 5, 2, seed=1)
    rng = np.random.default_rng(2)
    M, C, K = (rng.standard_normal((m, m)) for _ in range(3))
    A, _ = kronecker_system(U, F, omega)
    Ax = (A @ vec(np.vstack([M, C, K]))).reshape(5, 2, m)
    for i, w in enumerate(omega):
        Z = -(w**2) * M + 1j * w * C + K
        np.testing.assert_allclose(Ax[i].T, Z @ U[i], rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("m", [1, 2, 4])
def test_symmetry_constraints_give_vec_of_skew_parts(m):
    rng = np.random.default_rng(m)
    x = rng.standard_normal(3 * m * m)
    S = x.reshape((3 * m, m), order="F")
    blocks = S[:m], S[m : 2 * m], S[2 * m :]
    for L, B in zip(symmetry_constraints(m), blocks, strict=True):
        assert L.shape == (m * m, 3 * m * m)
        np.testing.assert_allclose(L @ x, vec(B - B.T), atol=1e-15)


@pytest.mark.parametrize("n", [6, 7, 8, 9, 10])
@pytest.mark.parametrize(
    "kwargs", [{"lam": 0.0}, {"lam": 100.0}, {"symmetric": True}], ids=["lam0", "lam100", "sym"]
)
def test_recovers_the_chain_at_full_order(n, kwargs):
    system = mass_spring_chain(n)
    rng = np.random.default_rng(n)
    omega = 2 * np.pi * np.linspace(5.0, 200.0, 36)
    F = rng.standard_normal((36, n)) + 1j * rng.standard_normal((36, n))
    U = system.response(omega, F)
    result = identify_kronecker(U, F, omega, **kwargs)
    for got, true in ((result.M, system.M), (result.C, system.C), (result.K, system.K)):
        assert rel(got, true) < 1e-8
    assert result.rank == (3 * n * (n + 1) // 2 if kwargs.get("symmetric") else 3 * n * n)
    assert result.residual_norm < 1e-7 * np.linalg.norm(F)


def test_penalised_solution_solves_the_normal_equations_of_eq_49():
    U, F, omega = random_data(3, 8, 2, seed=3)
    lam = (0.7, 1.5, 3.0)
    result = identify_kronecker(U, F, omega, lam)
    A, y = kronecker_system(U, F, omega)
    L_M, L_C, L_K = symmetry_constraints(3)
    G = np.real(A.conj().T @ A) + sum(
        w**2 * L.T @ L for w, L in zip(lam, (L_M, L_C, L_K), strict=True)
    )
    x = np.linalg.solve(G, np.real(A.conj().T @ y))
    S = x.reshape((9, 3), order="F")
    np.testing.assert_allclose(np.vstack([result.M, result.C, result.K]), S, rtol=1e-10)
    np.testing.assert_allclose(result.residual_norm, np.linalg.norm(A @ x - y), rtol=1e-10)
    np.testing.assert_allclose(
        result.penalty_norm, np.linalg.norm(np.vstack([L_M, L_C, L_K]) @ x), rtol=1e-8
    )


def test_symmetric_mode_is_the_large_lambda_limit():
    U, F, omega = random_data(4, 10, seed=4)
    sym = identify_kronecker(U, F, omega, symmetric=True)
    for B in (sym.M, sym.C, sym.K):
        np.testing.assert_array_equal(B, B.T)
    assert sym.penalty_norm == 0.0
    loose = identify_kronecker(U, F, omega, lam=0.0)
    assert loose.penalty_norm > 0.1  # the data alone do not give symmetric matrices
    tight = identify_kronecker(U, F, omega, lam=1e5)
    for a, b in ((tight.M, sym.M), (tight.C, sym.C), (tight.K, sym.K)):
        assert rel(a, b) < 1e-6
    assert sym.residual_norm >= loose.residual_norm


def test_too_few_lines_give_a_rank_deficient_solve():
    U, F, omega = random_data(4, 2, seed=5)  # 16 real equations for 48 unknowns
    assert identify_kronecker(U, F, omega).rank == 16


def test_inputs_are_not_modified():
    U, F, omega = random_data(3, 8, 2, seed=6)
    copies = U.copy(), F.copy(), omega.copy()
    identify_kronecker(U, F, omega, 10.0)
    identify_kronecker(U, F, omega, symmetric=True)
    kronecker_system(U, F, omega)
    for a, b in zip((U, F, omega), copies, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"omega": np.array([1.0, -1.0, 2.0])}, "strictly positive"),
        ({"F": np.ones((3, 2))}, "same shape"),
        ({"U": np.full((3, 3), np.nan)}, "non-finite"),
        ({"omega": np.ones(4)}, "one entry per frequency line"),
        ({"lam": -1.0}, "non-negative"),
        ({"lam": (1.0, 2.0)}, "triple"),
    ],
)
def test_invalid_input_raises(change, message):
    args = {"U": np.ones((3, 3)), "F": np.ones((3, 3)), "omega": np.ones(3), "lam": 0.0}
    args.update(change)
    with pytest.raises(ValueError, match=message):
        identify_kronecker(**args)


def test_memory_guard_names_the_size():
    U = np.ones((20_000, 40), dtype=complex)
    with pytest.raises(ValueError, match="GiB"):
        identify_kronecker(U, U, np.ones(20_000))
    with pytest.raises(ValueError, match="GiB"):
        kronecker_system(U, U, np.ones(20_000))
    with pytest.raises(ValueError, match="GiB"):
        symmetry_constraints(80)


@pytest.mark.parametrize("bad", [0, -1, 2.5, True])
def test_sizes_must_be_positive_integers(bad):
    with pytest.raises(ValueError):
        vec_permutation(bad, 2)
    with pytest.raises(ValueError):
        symmetry_constraints(bad)


def test_size_guard_refuses_only_above_the_limit_and_quotes_the_gib():
    from podid_rs.identification.reference import MAX_BYTES, _check_size

    _check_size(MAX_BYTES, "at the limit")  # 2 GiB exactly is allowed
    with pytest.raises(ValueError, match=r"^one byte more would take 2\.0 GiB \(limit 2 GiB\)"):
        _check_size(MAX_BYTES + 1, "one byte more")
    # L_M, L_C, L_K at m = 80: 3 · 8 B · 80² · 3·80² = 2 949 120 000 B = 2.75 GiB
    with pytest.raises(ValueError, match=r"^L_M, L_C, L_K \(3 x 6400 x 19200\) would take 2\.7 "
                                         r"GiB \(limit 2 GiB\)"):
        symmetry_constraints(80)
    # A of 60 000 columns at m = 10: 16 B · 600 000 × 300 = 2.88e9 B = 2.68 GiB, refused;
    # counted at 8 B a complex entry it would pass as 1.34 GiB
    U = np.ones((60_000, 10), dtype=complex)
    with pytest.raises(ValueError, match=r"^A \(600000 x 300 complex\) would take 2\.7 GiB"):
        kronecker_system(U, U, np.ones(60_000))
