import numpy as np
import pytest

from podid_rs.systems import SecondOrderSystem, mass_spring_chain


def random_system(n: int, seed: int) -> SecondOrderSystem:
    """Non-symmetric, non-proportionally damped, well-conditioned system."""
    rng = np.random.default_rng(seed)
    M = np.eye(n) + 0.2 * rng.standard_normal((n, n))
    C = 3.0 * rng.standard_normal((n, n))
    K = 100.0 * (np.eye(n) * n + rng.standard_normal((n, n)))
    return SecondOrderSystem(M, C, K)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.mark.parametrize("seed", range(5))
def test_frf_equals_direct_inverse_for_general_systems(seed):
    system = random_system(6, seed)
    omega = np.random.default_rng(seed + 100).uniform(0.1, 50.0, size=7)
    H = system.frf(omega)
    assert H.shape == (7, 6, 6) and H.dtype == np.complex128
    for w, Hw in zip(omega, H, strict=True):
        direct = np.linalg.inv(-(w**2) * system.M + 1j * w * system.C + system.K)
        assert rel(Hw, direct) < 1e-12


def test_frf_of_the_chain_equals_direct_inverse():
    system = mass_spring_chain(20)
    omega = 2 * np.pi * np.array([1.5, 11.5, 63.0, 122.8])
    for w, Hw in zip(omega, system.frf(omega), strict=True):
        direct = np.linalg.inv(system.K - w**2 * system.M + 1j * w * system.C)
        assert rel(Hw, direct) < 1e-10


def test_dynamic_stiffness_formula():
    system = random_system(4, 1)
    omega = np.array([0.5, 2.0])
    Z = system.dynamic_stiffness(omega)
    assert Z.shape == (2, 4, 4)
    np.testing.assert_allclose(Z[1], -4.0 * system.M + 2j * system.C + system.K, rtol=1e-15)


@pytest.mark.parametrize("shape", [(9, 5), (9, 5, 3)])
def test_response_satisfies_the_dynamic_equation(shape):
    system = random_system(5, 2)
    rng = np.random.default_rng(3)
    omega = rng.uniform(0.5, 30.0, size=9)
    F = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    F_before = F.copy()
    U = system.response(omega, F)
    assert U.shape == F.shape
    np.testing.assert_array_equal(F, F_before)
    Z = system.dynamic_stiffness(omega)
    lhs = np.einsum("sij,sj...->si...", Z, U)
    assert rel(lhs, F) < 1e-12


def test_response_accepts_real_forces():
    system = random_system(3, 4)
    omega = np.array([1.0, 2.0])
    F = np.ones((2, 3))
    np.testing.assert_allclose(system.response(omega, F), system.frf(omega).sum(axis=2))


def test_project_matches_explicit_products():
    system = random_system(6, 5)
    R = np.linalg.qr(np.random.default_rng(6).standard_normal((6, 3)))[0]
    reduced = system.project(R)
    assert reduced.n == 3
    np.testing.assert_allclose(reduced.M, R.T @ system.M @ R, rtol=1e-14)
    np.testing.assert_allclose(reduced.C, R.T @ system.C @ R, rtol=1e-14)
    np.testing.assert_allclose(reduced.K, R.T @ system.K @ R, rtol=1e-14)


@pytest.mark.parametrize("n", [1, 5, 6])
def test_chain_matrices_follow_eqs_51_52(n):
    system = mass_spring_chain(n, m1=0.1, m2=1.0, ku=4e5, a0=0.5, a1=3e-5)
    masses = [0.1] * (n // 2) + [1.0] * (n - n // 2)
    K = np.zeros((n, n))
    for i in range(n):
        K[i, i] = 2 * 4e5
        if i + 1 < n:
            K[i, i + 1] = K[i + 1, i] = -4e5
    np.testing.assert_array_equal(system.M, np.diag(masses))
    np.testing.assert_array_equal(system.K, K)
    np.testing.assert_allclose(system.C, 0.5 * np.diag(masses) + 3e-5 * K, rtol=1e-15)


def test_default_chain_is_the_papers():
    system = mass_spring_chain()
    assert system.n == 100
    assert system.M[49, 49] == 0.1 and system.M[50, 50] == 1.0
    assert system.K[0, 0] == 8e5 and system.K[0, 1] == -4e5 and system.K[0, 2] == 0


def test_matrices_are_stored_as_copies():
    M, C, K = np.eye(2), np.zeros((2, 2)), 4.0 * np.eye(2)
    system = SecondOrderSystem(M, C, K)
    M[0, 0] = 99.0
    assert system.M[0, 0] == 1.0
    assert system.M.dtype == np.float64
    assert SecondOrderSystem([[1]], [[0]], [[2]]).K.dtype == np.float64


@pytest.mark.parametrize(
    ("M", "C", "K", "message"),
    [
        (np.ones((2, 3)), np.ones((2, 3)), np.ones((2, 3)), "square"),
        (np.eye(2), np.eye(3), np.eye(2), "same shape"),
        (np.eye(2), np.eye(2) * np.nan, np.eye(2), "non-finite"),
        (np.eye(2) * 1j, np.eye(2), np.eye(2), "real"),
        (np.eye(2), np.eye(2), "stiff", "numeric"),
        (np.eye(2, dtype=bool), np.eye(2), np.eye(2), "numeric"),
    ],
)
def test_invalid_matrices_raise(M, C, K, message):
    with pytest.raises(ValueError, match=message):
        SecondOrderSystem(M, C, K)


@pytest.mark.parametrize(
    ("omega", "message"),
    [
        ([1.0, 0.0], "strictly positive"),
        ([-2.0], "strictly positive"),
        ([[1.0, 2.0]], "1-D"),
        ([], "non-empty"),
        ([1.0, np.inf], "non-finite"),
        ([1.0 + 1j], "real"),
    ],
)
def test_invalid_omega_raises(omega, message):
    with pytest.raises(ValueError, match=message):
        random_system(2, 0).frf(omega)


def test_invalid_forces_and_basis_raise():
    system = random_system(3, 0)
    with pytest.raises(ValueError, match="F must have shape"):
        system.response([1.0, 2.0], np.ones((2, 4)))
    with pytest.raises(ValueError, match="F must have shape"):
        system.response([1.0, 2.0], np.ones(3))
    with pytest.raises(ValueError, match="R must have shape"):
        system.project(np.ones((4, 2)))


def test_singular_dynamic_stiffness_raises():
    system = SecondOrderSystem(np.eye(2), np.zeros((2, 2)), np.eye(2))
    with pytest.raises(ValueError, match="singular"):
        system.frf([1.0])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n": 0}, "n must be"),
        ({"n": 2.5}, "integer"),
        ({"m1": -1.0}, "m1"),
        ({"ku": 0.0}, "ku"),
        ({"a0": -0.1}, "a0"),
        ({"a1": np.nan}, "a1"),
    ],
)
def test_invalid_chain_parameters_raise(kwargs, message):
    with pytest.raises(ValueError, match=message):
        mass_spring_chain(**kwargs)


# ------------------------------------------------ indices, chunks, switches, the lattice


def test_frf_indices_run_from_0_to_n_minus_1():
    system = random_system(5, 0)
    omega = [3.0, 7.0]
    assert system.frf(omega, rows=[4], cols=[0]).shape == (2, 1, 1)
    for bad in ([5], [-1]):
        with pytest.raises(ValueError, match=r"rows must index the 5 DOFs \(0 … 4\)"):
            system.frf(omega, rows=bad)
    with pytest.raises(ValueError, match=r"cols must index the 5 DOFs \(0 … 4\), got \[5\]"):
        system.frf(omega, cols=[5])


@pytest.mark.parametrize(("rows", "cols"), [([0, 2], [1, 3]), ([4, 0, 3], [2])])
def test_some_frf_entries_are_those_of_the_full_frf(rows, cols):
    system = random_system(5, 1)
    omega = np.array([2.0, 9.0, 31.0])
    full = system.frf(omega)
    some = system.frf(omega, rows=rows, cols=cols)
    assert np.array_equal(some.shape, (3, len(rows), len(cols)))
    assert rel(some, full[:, rows][:, :, cols]) < 1e-12


@pytest.mark.parametrize("s", [1, 5])
def test_every_line_is_solved_when_the_lines_come_in_chunks(s, monkeypatch):
    """Chunks of two lines (DENSE_CHUNK_BYTES cut to 2 dynamic stiffnesses of 4 × 4):
    one line, and five lines in chunks 2 + 2 + 1 — the last chunk solved too."""
    from podid_rs import systems

    monkeypatch.setattr(systems, "DENSE_CHUNK_BYTES", 2 * 16 * 4 * 4)
    system = random_system(4, 2)
    omega = np.linspace(1.0, 20.0, s)
    F = np.random.default_rng(0).standard_normal((s, 4))
    U = system.response(omega, F)
    H = system.frf(omega, rows=[1, 3], cols=[0, 2])
    for i, w in enumerate(omega):
        Z = -(w**2) * system.M + 1j * w * system.C + system.K
        assert rel(U[i], np.linalg.solve(Z, F[i])) < 1e-12
        assert rel(H[i], np.linalg.inv(Z)[np.ix_([1, 3], [0, 2])]) < 1e-12


def test_the_chain_is_dense_up_to_its_limit_and_sparse_beyond():
    from podid_rs.systems import DENSE_CHAIN_MAX

    assert not mass_spring_chain(DENSE_CHAIN_MAX).is_sparse
    assert mass_spring_chain(DENSE_CHAIN_MAX + 1).is_sparse


def test_an_undamped_chain_is_allowed():
    chain = mass_spring_chain(4, a0=0.0, a1=0.0)
    assert not np.any(chain.C)


def test_lattice_frequencies_follow_the_closed_form():
    """Uniform lattice: ω² = (k/mass)·4(sin²(pπ/2(nx+1)) + sin²(qπ/2(ny+1))) for p ≤ nx,
    q ≤ ny — the 5-point Laplacian with every edge mass grounded."""
    from podid_rs.systems import mass_spring_lattice

    nx, ny, mass, k = 3, 4, 2.0, 50.0
    lat = mass_spring_lattice(nx, ny, mass, k)
    got = np.sort(np.linalg.eigvalsh(lat.K.toarray()) / mass)
    p, q = np.meshgrid(np.arange(1, nx + 1), np.arange(1, ny + 1))
    s2 = np.sin(p * np.pi / (2 * (nx + 1))) ** 2 + np.sin(q * np.pi / (2 * (ny + 1))) ** 2
    assert np.allclose(got, np.sort((k / mass * 4 * s2).ravel()), rtol=1e-12)
    C = (0.5 * lat.M + 3e-5 * lat.K).toarray()  # the default Rayleigh coefficients
    assert np.allclose(lat.M.diagonal(), mass) and np.allclose(lat.C.toarray(), C)


def test_lattice_variations_are_fractions_below_one():
    from podid_rs.systems import mass_spring_lattice

    lat = mass_spring_lattice(3, 3, mass=2.0, mass_variation=0.99, seed=1)
    assert np.all(np.abs(lat.M.diagonal() / 2.0 - 1.0) <= 0.99)
    with pytest.raises(ValueError, match=r"must be in \[0, 1\), got 1 and 0"):
        mass_spring_lattice(3, 3, mass_variation=1.0)
    with pytest.raises(ValueError, match=r"got 0 and 1"):
        mass_spring_lattice(3, 3, stiffness_variation=1.0)
