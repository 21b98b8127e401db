import numpy as np
import pytest
import scipy.sparse as sp

from podid_rs.systems import (
    DENSE_CHAIN_MAX,
    SecondOrderSystem,
    mass_spring_chain,
    mass_spring_lattice,
)


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



def test_a_sparse_non_symmetric_system_projects_as_the_explicit_products():
    """RᵀXR for a non-symmetric system held sparse (the chain's symmetric matrices cannot
    tell RᵀXR from RᵀXᵀR): the products in another order, round-off apart."""
    dense = random_system(6, 5)
    sparse = SecondOrderSystem(*(sp.csr_array(X) for X in (dense.M, dense.C, dense.K)))
    R = np.linalg.qr(np.random.default_rng(6).standard_normal((6, 3)))[0]
    reduced = sparse.project(R)
    for name in "MCK":
        X = getattr(dense, name)
        # the random matrices' asymmetry is of the order of their entries: a transpose
        # is off by O(1), round-off by ~1e-15
        assert rel(R.T @ X.T @ R, R.T @ X @ R) > 0.1
        assert rel(getattr(reduced, name), R.T @ X @ R) < 1e-12

def test_a_sparse_non_symmetric_systems_dynamic_stiffness_is_the_dense_ones():
    """Z(ω) = −ω²M + iωC + K formed from sparse non-symmetric matrices (the chain's
    symmetric ones cannot tell Z from Zᵀ): the dense system's, bit for bit (the same
    operations on the same doubles)."""
    dense = random_system(5, 7)
    sparse = SecondOrderSystem(*(sp.csr_array(X) for X in (dense.M, dense.C, dense.K)))
    omega = np.array([0.5, 3.0])
    Z = sparse.dynamic_stiffness(omega)
    np.testing.assert_array_equal(Z, dense.dynamic_stiffness(omega))
    assert not np.allclose(Z[1], Z[1].T)  # a transpose would show


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


# ------------------------------------------- sparse input, messages, options, the lattice


@pytest.mark.parametrize(
    ("which", "bad", "message"),
    [
        (0, sp.csr_array(np.eye(2, dtype=bool)), "M must be a numeric matrix, got dtype bool"),
        (2, sp.csr_array(np.eye(2) * (1 + 1j)), "K must be real, got complex dtype complex128"),
        (1, sp.csr_array(np.diag([1.0, np.inf])), r"C contains non-finite values \(NaN or inf\)"),
        (0, np.ones((2, 3)), r"M must be a non-empty square matrix, got shape \(2, 3\)"),
        (2, np.zeros((0, 0)), r"K must be a non-empty square matrix, got shape \(0, 0\)"),
        (1, np.eye(3), r"same shape, got \(2, 2\), \(3, 3\) and \(2, 2\)"),
    ],
)
def test_invalid_matrices_are_named_with_their_dtype_or_shape(which, bad, message):
    mats = [np.eye(2), np.eye(2), 4.0 * np.eye(2)]
    mats[which] = bad
    with pytest.raises(ValueError, match=message):
        SecondOrderSystem(*mats)


def test_a_dense_matrix_beside_a_sparse_one_is_checked_as_the_dense_are():
    with pytest.raises(ValueError, match="M must be real"):
        SecondOrderSystem(1j * np.eye(2), np.eye(2), sp.csr_array(np.eye(2)))


def test_sparse_matrices_are_stored_as_copies():
    K = sp.csr_array(4.0 * np.eye(2))
    system = SecondOrderSystem(sp.eye_array(2), sp.csr_array((2, 2)), K)
    K.data[:] = 99.0
    assert np.array_equal(system.K.toarray(), 4.0 * np.eye(2))


def test_one_sparse_matrix_makes_the_system_sparse():
    """M and C dense, K sparse: all three held sparse, the same FRF as the dense system."""
    dense = random_system(4, 3)
    mixed = SecondOrderSystem(dense.M, dense.C, sp.csr_array(dense.K))
    assert mixed.is_sparse and all(sp.issparse(X) for X in (mixed.M, mixed.C, mixed.K))
    assert repr(mixed) == "SecondOrderSystem(n=4, sparse)" and repr(dense) == (
        "SecondOrderSystem(n=4)")
    omega = np.array([1.0, 6.0])
    assert rel(mixed.frf(omega), dense.frf(omega)) < 1e-12


def test_todense_gives_dense_arrays_of_the_same_entries():
    chain = mass_spring_chain(5, sparse=True)
    dense = chain.todense()
    assert not dense.is_sparse and isinstance(dense.M, np.ndarray)
    for X, Y in ((dense.M, chain.M), (dense.C, chain.C), (dense.K, chain.K)):
        assert np.array_equal(X, Y.toarray())
    again = dense.todense()
    assert again is not dense and np.array_equal(again.K, dense.K)
    # the chain's M and C differ (C = a0 M + a1 K): each copied to its own place
    assert np.array_equal(again.M, dense.M) and np.array_equal(again.C, dense.C)


@pytest.mark.parametrize(
    ("idx", "message"),
    [
        (np.array([], dtype=int), "rows must be a non-empty 1-D sequence of integer DOF indices"),
        ([], "rows must be a non-empty 1-D sequence of integer DOF indices"),  # float64
        ([1.0], "rows must be a non-empty 1-D sequence of integer DOF indices"),
        ([[0, 1]], "rows must be a non-empty 1-D sequence of integer DOF indices"),
    ],
)
def test_malformed_indices_are_refused(idx, message):
    with pytest.raises(ValueError, match=message):
        random_system(3, 0).frf([1.0], rows=idx)


def test_rows_or_cols_alone_select_those_entries():
    """rows alone: every column of those rows; cols alone: every row; a scalar index is
    one index."""
    system = random_system(4, 4)
    omega = np.array([2.0, 5.0])
    full = system.frf(omega)
    assert rel(system.frf(omega, rows=[2]), full[:, [2], :]) < 1e-12
    assert rel(system.frf(omega, cols=[3, 0]), full[:, :, [3, 0]]) < 1e-12
    assert rel(system.frf(omega, rows=1, cols=2), full[:, [1]][:, :, [2]]) < 1e-12


def test_sparse_entries_and_dynamic_stiffness_are_the_dense_ones():
    """The chain held sparse against the same chain held dense: the dynamic stiffness
    (formed densely from the sparse matrices), some FRF entries and a projection."""
    sparse, dense = mass_spring_chain(6, sparse=True), mass_spring_chain(6, sparse=False)
    # the Rayleigh damping has other entries than M and K: a swap of C shows
    omega = np.array([3.0, 40.0, 700.0])
    np.testing.assert_array_equal(sparse.dynamic_stiffness(omega),
                                  dense.dynamic_stiffness(omega))
    rows, cols = [5, 0], [1, 4, 2]
    some = sparse.frf(omega, rows=rows, cols=cols)
    assert rel(some, dense.frf(omega)[:, rows][:, :, cols]) < 1e-12
    R = np.linalg.qr(np.random.default_rng(1).standard_normal((6, 2)))[0]
    # the same products in another order: round-off apart
    for name in "MCK":
        np.testing.assert_allclose(getattr(sparse.project(R), name),
                                   getattr(dense.project(R), name), rtol=1e-13)


def test_threads_are_checked_on_the_sparse_path():
    chain = mass_spring_chain(4, sparse=True)
    with pytest.raises(ValueError, match=r"threads must be in \[1, 1024\], got 0"):
        chain.frf([1.0], rows=[0], threads=0)
    with pytest.raises(ValueError, match=r"threads must be in \[1, 1024\], got 1025"):
        chain.response([1.0], np.ones((1, 4)), threads=1025)


def test_malformed_forces_and_basis_are_named_with_their_shapes():
    system = random_system(3, 0)
    with pytest.raises(ValueError, match=r"with s = 2 lines and n = 3 DOFs, got \(3, 3\)"):
        system.response([1.0, 2.0], np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"with s = 2 lines and n = 3 DOFs, got \(2, 3, 1, 1\)"):
        system.response([1.0, 2.0], np.ones((2, 3, 1, 1)))
    with pytest.raises(ValueError, match=r"R must have shape \(n, m\) with n = 3, got \(3, 0\)"):
        system.project(np.zeros((3, 0)))


def test_sparse_chain_holds_the_dense_chains_entries_bit_for_bit():
    """eqs. 51–52 on both layouts, with distinct masses: m1 on the first n // 2 DOFs."""
    kwargs = dict(m1=0.25, m2=3.0, ku=7.0, a0=0.5, a1=0.125)
    sparse, dense = mass_spring_chain(5, sparse=True, **kwargs), mass_spring_chain(5, **kwargs)
    assert sparse.is_sparse and not dense.is_sparse
    assert np.array_equal(sparse.M.diagonal(), [0.25, 0.25, 3.0, 3.0, 3.0])
    assert sparse.K[0, 1] == sparse.K[1, 0] == -7.0 and sparse.K[0, 0] == 14.0
    for X, Y in ((sparse.M, dense.M), (sparse.C, dense.C), (sparse.K, dense.K)):
        assert np.array_equal(X.toarray(), Y)


def test_the_chains_sparse_keyword_overrides_the_size_rule():
    assert mass_spring_chain(3, sparse=True).is_sparse
    assert not mass_spring_chain(DENSE_CHAIN_MAX + 1, sparse=False).is_sparse


def test_the_chains_second_mass_is_checked_by_name():
    with pytest.raises(ValueError, match=r"m2 must be a positive number, got -1\.0"):
        mass_spring_chain(4, m2=-1.0)


def test_memory_refusals_say_how_much():
    """By hand: a dense chain of 10⁶ masses is 3 matrices × 3 (with temporaries) × 8 B ×
    10¹² = 7.2e13 B; a lattice of 10⁵ × 10⁵ masses 3 × 3 × 12 B × 5 per row × 10¹⁰ rows =
    5.4e12 B."""
    with pytest.raises(MemoryError, match=r"a dense chain of 1000000 masses needs 7.2e\+04 GB"):
        mass_spring_chain(10**6, sparse=False)
    with pytest.raises(MemoryError, match=r"100000 × 100000 masses needs 5.4e\+03 GB"):
        mass_spring_lattice(10**5, 10**5)
    # nx before ny: 10⁵ × 2·10⁵ masses, twice the rows, 1.08e13 B
    with pytest.raises(MemoryError, match=r"100000 × 200000 masses needs 1.08e\+04 GB"):
        mass_spring_lattice(10**5, 2 * 10**5)


def test_lattice_dofs_are_numbered_along_x_first():
    """DOF j·nx + i: with nx = 3, DOFs 0–1 and 0–3 are neighbours, 2–3 are not (2 ends a
    row); an edge mass has one spring to ground per side on the edge (corner: two)."""
    lat = mass_spring_lattice(3, 4, k=5.0)
    K = lat.K.toarray()
    assert K[0, 1] == K[0, 3] == -5.0 and K[2, 3] == 0.0
    # row sums: the springs to ground, 2 at a corner, 1 on an edge, 0 inside
    assert np.allclose(K.sum(axis=1).reshape(4, 3),
                       5.0 * np.array([[2, 1, 2], [1, 0, 1], [1, 0, 1], [2, 1, 2]]))


def test_lattice_variations_draw_each_property_alone_and_follow_the_seed():
    nominal = mass_spring_lattice(3, 3, mass=2.0, k=10.0).K.toarray()
    heavy = mass_spring_lattice(3, 3, mass=2.0, k=10.0, mass_variation=0.5, seed=4)
    masses = heavy.M.diagonal()
    # nine uniform draws in (1 ± 0.5)·2: all equal has probability zero
    assert np.ptp(masses) > 0 and np.all(np.abs(masses / 2.0 - 1.0) <= 0.5)
    assert np.array_equal(heavy.K.toarray(), nominal)
    stiff = mass_spring_lattice(3, 3, mass=2.0, k=10.0, stiffness_variation=0.5, seed=4)
    springs = -stiff.K.toarray()[nominal < 0]
    assert np.ptp(springs) > 0 and np.all(np.abs(springs / 10.0 - 1.0) <= 0.5)
    assert np.array_equal(stiff.M.diagonal(), np.full(9, 2.0))
    again = mass_spring_lattice(3, 3, mass=2.0, k=10.0, stiffness_variation=0.5, seed=4)
    other = mass_spring_lattice(3, 3, mass=2.0, k=10.0, stiffness_variation=0.5, seed=5)
    assert np.array_equal(again.K.toarray(), stiff.K.toarray())
    assert not np.array_equal(other.K.toarray(), stiff.K.toarray())



def test_lattice_variations_spread_on_both_sides_of_the_nominal_values():
    """(1 ± variation) times the nominal value: of 100 masses and 180 springs some are
    lighter (softer) and some heavier (stiffer) than nominal, and their mean is the nominal
    value. A uniform draw on one side only would leave every ratio above 1 (probability
    2^-100 for a symmetric draw); the mean of n uniform draws on ±0.5 has standard deviation
    0.5/√(3n) ≤ 0.029 here, so 0.1 is over three of them, and a one-sided draw's mean
    (1.25) is far outside."""
    nominal = mass_spring_lattice(10, 10, mass=2.0, k=10.0).K.toarray()
    lat = mass_spring_lattice(10, 10, mass=2.0, k=10.0, mass_variation=0.5,
                              stiffness_variation=0.5, seed=2)
    masses = lat.M.diagonal() / 2.0
    springs = -lat.K.toarray()[nominal < 0] / 10.0  # each spring between two masses twice
    for ratio in (masses, springs):
        assert ratio.min() < 1.0 < ratio.max()
        assert abs(ratio.mean() - 1.0) < 0.1

def test_lattice_parameters_are_checked_by_name():
    assert mass_spring_lattice(2, 2, a0=0.0, a1=0.0).C.count_nonzero() == 0
    with pytest.raises(ValueError, match=r"k must be a positive number, got 0\.0"):
        mass_spring_lattice(2, 2, k=0.0)
    with pytest.raises(ValueError, match=r"ny must be >= 1, got 0"):
        mass_spring_lattice(2, 0)


@pytest.mark.parametrize("sparse", [False, True])
def test_an_frf_too_large_names_its_lines_rows_and_columns(sparse, monkeypatch):
    """3 lines × 2 rows × 4 columns of complex doubles are 384 B; with 100 B available the
    request is refused, quoted as lines × rows × columns on both paths (rows ≠ columns)."""
    import podid_rs._memory as memory

    chain = mass_spring_chain(5, sparse=sparse)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 100)
    with pytest.raises(MemoryError, match=r"^the FRF of 3 lines × 2 × 4 entries needs 3.84e-07 GB"):
        chain.frf([1.0, 2.0, 3.0], rows=[0, 1], cols=[0, 1, 2, 3])


@pytest.mark.parametrize(
    ("ask", "message"),
    [
        # twice the (s, n, n) complex array: 2 × 16 B × 3 lines × 5²
        (lambda dense, sparse: dense.dynamic_stiffness([1.0, 2.0, 3.0]),
         r"^the dense dynamic stiffness of 3 lines × 5 × 5 DOFs needs 2.4e-06 GB"),
        # the full dense FRF, three times its 16 B × 3 × 5 × 5
        (lambda dense, sparse: dense.frf([1.0, 2.0, 3.0]),
         r"^the FRF of 3 lines × 5 × 5 entries needs 3.6e-06 GB"),
        # twice the response's 16 B × 3 × 5 × 2
        (lambda dense, sparse: dense.response([1.0, 2.0, 3.0], np.ones((3, 5, 2))),
         r"^the response to forces of shape \(3, 5, 2\) needs 9.6e-07 GB"),
        # the dense copy of the sparse chain: three matrices of 8 B × 5²
        (lambda dense, sparse: sparse.todense(),
         r"^a dense copy of a 5-DOF system needs 6e-07 GB"),
        # a sparse chain: 3 × 3 × 12 B × 3 entries per row × 5 rows (the lattice has 5)
        (lambda dense, sparse: mass_spring_chain(5, sparse=True),
         r"^a chain of 5 masses needs 1.62e-06 GB"),
    ],
)
def test_each_memory_refusal_quotes_the_bytes_its_request_needs(ask, message, monkeypatch):
    """With 100 B available every request on a 5-DOF chain is refused, and its message
    quotes the bytes it needs, by hand (a real machine grants them all, so no other test
    sees a factor of an estimate)."""
    import podid_rs._memory as memory

    dense, sparse = mass_spring_chain(5, sparse=False), mass_spring_chain(5, sparse=True)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 100)
    with pytest.raises(MemoryError, match=message):
        ask(dense, sparse)
