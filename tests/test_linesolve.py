"""Per-line solves of a sparse system equal the dense solve, on every path of the line solver.

A sparse :class:`SecondOrderSystem` solves ``Z(ω) X = B`` line by line with the
cheapest exact LU its pattern allows (tridiagonal, banded, SuperLU, or dense for
n < 3). Each path stores M, C and K on its own layout, so each is checked here on
a non-symmetric pattern whose three matrices differ (M diagonal, C with one
off-diagonal, K the full pattern), a band wider below than above, and entries
given twice. Tolerance: both solves are backward stable, so they differ by about
cond(Z)·ε; these systems have cond(Z) < 1e3 on the lines used, hence 1e-11
relative to the largest entry.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from podid_rs import SecondOrderSystem


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def banded_system(n: int, lower: int, upper: int, seed: int) -> SecondOrderSystem:
    """Non-symmetric band: ``lower`` diagonals below, ``upper`` above, diagonally dominant.

    M is diagonal, C has only the first diagonal below, K every diagonal of the band;
    one entry of K is given twice (duplicates add).
    """
    rng = np.random.default_rng(seed)
    offsets = list(range(-lower, upper + 1))
    K = sp.diags_array(
        [(50.0 * n if k == 0 else 1.0) * rng.uniform(0.5, 1.5, n - abs(k)) for k in offsets],
        offsets=offsets,
    ).tocoo()
    # a duplicated entry: (0, 0) given twice adds up
    K = sp.coo_array(
        (np.append(K.data, 7.0), (np.append(K.row, 0), np.append(K.col, 0))), shape=(n, n)
    )
    M = sp.diags_array(rng.uniform(0.5, 2.0, n))
    C = sp.diags_array([0.3 * np.ones(n), 0.05 * rng.uniform(-1, 1, n - 1)], offsets=[0, -1])
    return SecondOrderSystem(M, C, K)


def wide_system(n: int, seed: int) -> SecondOrderSystem:
    """Random non-symmetric pattern reaching far from the diagonal (the SuperLU path)."""
    rng = np.random.default_rng(seed)
    R = sp.random_array((n, n), density=0.08, rng=rng)
    R.data -= 0.5
    K = sp.csr_array(50.0 * n * sp.eye_array(n) + R)
    M = sp.diags_array(rng.uniform(0.5, 2.0, n))
    C = sp.csr_array(0.3 * sp.eye_array(n) + 0.01 * R.T)
    return SecondOrderSystem(M, C, K)


CASES = {
    # name: (system, the solver path it must take)
    "n=1 (dense)": (lambda: SecondOrderSystem(*(sp.csr_array([[v]]) for v in (1.5, 0.2, 90.0))),
                    "dense"),
    "n=2 (dense)": (lambda: banded_system(2, 1, 0, 1), "dense"),
    "tridiagonal, lower only": (lambda: banded_system(12, 1, 0, 2), "tridiagonal"),
    "tridiagonal": (lambda: banded_system(12, 1, 1, 3), "tridiagonal"),
    "banded 3 below, 1 above": (lambda: banded_system(15, 3, 1, 4), "banded"),
    "banded 0 below, 5 above": (lambda: banded_system(15, 0, 5, 5), "banded"),
    "banded 8 below, 2 above": (lambda: banded_system(20, 8, 2, 6), "banded"),
    "SuperLU": (lambda: wide_system(30, 7), "sparse"),
}


@pytest.mark.parametrize("name", CASES)
def test_sparse_line_solves_equal_the_dense_solve(name):
    make, kind = CASES[name]
    system = make()
    dense = system.todense()
    assert system._line_solver().kind == kind  # the path this case is meant to exercise
    rng = np.random.default_rng(0)
    omega = np.sort(rng.uniform(0.5, 40.0, 9))
    H = np.linalg.inv(dense.dynamic_stiffness(omega))
    assert rel(system.frf(omega), H) < 1e-11
    F = rng.standard_normal((9, system.n, 3)) + 1j * rng.standard_normal((9, system.n, 3))
    U = system.response(omega, F)
    assert rel(U, np.linalg.solve(dense.dynamic_stiffness(omega), F)) < 1e-11
    # the lines are independent: solving them on two threads changes no bit
    assert np.array_equal(system.response(omega, F, threads=2), U)


@pytest.mark.parametrize(("n", "upper", "kind"), [
    (2, 0, "dense"), (5, 1, "tridiagonal"), (6, 3, "banded"), (12, 11, "sparse"),
])
def test_a_singular_line_is_named(n, upper, kind):
    # undamped, M = I, K upper triangular with diagonal 1, 4, 9, …: det Z(ω) =
    # Π (k² − ω²), exactly zero at ω = 2
    K = sp.diags_array(np.arange(1.0, n + 1) ** 2).tolil()
    if upper:
        K[0, upper] = 0.5
    system = SecondOrderSystem(sp.eye_array(n), sp.csr_array((n, n)), sp.csr_array(K))
    assert system._line_solver().kind == kind
    assert np.all(np.isfinite(system.frf(np.array([1.5, 2.5]))))
    with pytest.raises(ValueError, match="singular at omega = 2 rad/s"):
        system.frf(np.array([1.5, 2.0]))


def test_lines_go_parallel_from_parallel_min_n_dofs_on(monkeypatch):
    import podid_rs._linesolve as linesolve

    monkeypatch.setattr(linesolve.os, "cpu_count", lambda: 8)
    n = linesolve.PARALLEL_MIN_N
    assert (linesolve.default_threads(n - 1), linesolve.default_threads(n)) == (1, 8)
