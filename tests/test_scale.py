"""Large-n machinery on small cases: sparse systems, the lattice, simulation
without histories, POD by the method of snapshots, memory refusals, and the paper's
chain path against the dense one. The 10⁴–10⁵-DOF runs are in benches/bench_scale.py.

Tolerances. Dense (LAPACK zgesv) and sparse (zgtsv / zgbsv / SuperLU) solves are
both backward stable, so they differ by about cond(Z(ω))·ε; near the chain's
lightly damped resonances cond(Z) reaches 1e3–1e4, hence 1e-10 relative to the
largest entry. POD by the Gram matrix and by the correlation matrix agree to
ε·λ_max in the eigenvalues and ε·λ_max/gap in a mode: 1e-10 on test data whose
eigenvalue gaps are all above 1e-3 λ_max.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import podid_rs._memory as memory
from podid_rs import identify, pod, pod_from_frf, simulate_white_noise
from podid_rs.apps.paper import chain_entries, frf_entries
from podid_rs.pod import pod_from_spectra
from podid_rs.simulation import white_noise_spectrum
from podid_rs.systems import SecondOrderSystem, mass_spring_chain, mass_spring_lattice


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def random_sparse_system(n: int, seed: int) -> SecondOrderSystem:
    """Non-symmetric, wide-band sparse pattern (the SuperLU path), well conditioned."""
    rng = np.random.default_rng(seed)
    R = sp.random_array((n, n), density=0.05, rng=rng) - sp.random_array((n, n), density=0.05,
                                                                       rng=rng)
    M = sp.eye_array(n) + 0.1 * R
    K = 100.0 * (n * sp.eye_array(n) + R.T)
    C = 0.5 * sp.eye_array(n) + 0.01 * R
    return SecondOrderSystem(M, C, K)


SYSTEMS = {
    "chain (tridiagonal)": lambda: mass_spring_chain(40, sparse=True),
    "lattice 6x5 (banded)": lambda: mass_spring_lattice(6, 5, mass_variation=0.2,
                                                        stiffness_variation=0.2, seed=1),
    "lattice 12x10 (SuperLU)": lambda: mass_spring_lattice(12, 10, seed=2,
                                                           stiffness_variation=0.1),
    "random (SuperLU)": lambda: random_sparse_system(50, 3),
}
EXPECTED_KIND = {"chain (tridiagonal)": "tridiagonal", "lattice 6x5 (banded)": "banded",
                 "lattice 12x10 (SuperLU)": "sparse", "random (SuperLU)": "sparse"}


@pytest.mark.parametrize("name", SYSTEMS)
def test_sparse_and_dense_systems_agree(name):
    system = SYSTEMS[name]()
    dense = system.todense()
    assert system.is_sparse and not dense.is_sparse
    assert system._line_solver().kind == EXPECTED_KIND[name]
    rng = np.random.default_rng(0)
    omega = 2 * np.pi * np.sort(rng.uniform(1.0, 150.0, 25))
    H = dense.frf(omega)
    assert rel(system.frf(omega), H) < 1e-10
    rows, cols = [3, 0, system.n - 1], [system.n // 2, 1]
    sub = system.frf(omega, rows=rows, cols=cols, threads=2)
    assert sub.shape == (25, 3, 2)
    assert rel(sub, H[:, rows][:, :, cols]) < 1e-10
    assert rel(dense.frf(omega, rows=rows, cols=cols), H[:, rows][:, :, cols]) < 1e-12
    F = rng.standard_normal((25, system.n, 2)) + 1j * rng.standard_normal((25, system.n, 2))
    U = system.response(omega, F, threads=2)
    assert rel(U, dense.response(omega, F)) < 1e-10
    assert rel(system.response(omega, F[:, :, 0]), U[:, :, 0]) < 1e-14
    R = np.linalg.qr(rng.standard_normal((system.n, 4)))[0]
    a, b = system.project(R), dense.project(R)
    for X, Y in ((a.M, b.M), (a.C, b.C), (a.K, b.K)):
        assert isinstance(X, np.ndarray) and rel(X, Y) < 1e-13


def test_sparse_chain_holds_the_dense_chains_entries():
    sparse, dense = mass_spring_chain(9, sparse=True), mass_spring_chain(9, sparse=False)
    for X, Y in ((sparse.M, dense.M), (sparse.C, dense.C), (sparse.K, dense.K)):
        np.testing.assert_array_equal(X.toarray(), Y)
    assert not mass_spring_chain(1000).is_sparse and mass_spring_chain(1001).is_sparse


def test_mixed_sparse_and_dense_input_and_bad_sparse_input():
    M = sp.eye_array(3, format="csc")
    system = SecondOrderSystem(M, np.zeros((3, 3)), 2.0 * np.eye(3))
    assert system.is_sparse and sp.issparse(system.K)
    M.data[0] = 5.0  # stored as a copy
    assert system.M[0, 0] == 1.0
    with pytest.raises(ValueError, match="real"):
        SecondOrderSystem(1j * sp.eye_array(2), sp.eye_array(2), sp.eye_array(2))
    with pytest.raises(ValueError, match="non-finite"):
        SecondOrderSystem(sp.eye_array(2) * np.nan, sp.eye_array(2), sp.eye_array(2))
    with pytest.raises(ValueError, match="same shape"):
        SecondOrderSystem(sp.eye_array(2), sp.eye_array(3), sp.eye_array(2))
    with pytest.raises(ValueError, match="singular"):
        SecondOrderSystem(sp.eye_array(4), sp.csr_array((4, 4)), sp.eye_array(4)).frf([1.0])
    with pytest.raises(ValueError, match="rows must index"):
        mass_spring_chain(5, sparse=True).frf([1.0], rows=[5])


def test_lattice_is_the_5_point_laplacian_with_fixed_edges():
    nx, ny, k = 5, 4, 3.0
    system = mass_spring_lattice(nx, ny, mass=2.0, k=k, a0=0.1, a1=0.01)
    K = system.K.toarray()
    T = lambda n: 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)  # noqa: E731
    np.testing.assert_allclose(K, k * (np.kron(np.eye(ny), T(nx)) + np.kron(T(ny), np.eye(nx))),
                               rtol=1e-15)
    np.testing.assert_allclose(system.C.toarray(), 0.1 * system.M.toarray() + 0.01 * K)
    # natural frequencies: √(k/m)·2·√(sin²(pπ/2(nx+1)) + sin²(qπ/2(ny+1)))
    p, q = np.meshgrid(np.arange(1, nx + 1), np.arange(1, ny + 1))
    theory = np.sort(np.sqrt(k / 2.0) * 2 * np.sqrt(
        np.sin(p * np.pi / (2 * (nx + 1))) ** 2 + np.sin(q * np.pi / (2 * (ny + 1))) ** 2
    ).ravel())
    wn = np.sqrt(np.sort(np.linalg.eigvalsh(K / 2.0)))
    np.testing.assert_allclose(wn, theory, rtol=1e-12)


def test_lattice_variation_is_reproducible_and_splits_repeated_modes():
    a = mass_spring_lattice(6, 6, mass_variation=0.1, stiffness_variation=0.1, seed=7)
    b = mass_spring_lattice(6, 6, mass_variation=0.1, stiffness_variation=0.1, seed=7)
    assert (a.K != b.K).nnz == 0 and (a.M != b.M).nnz == 0
    Kd = a.K.toarray()
    assert np.array_equal(Kd, Kd.T) and np.all(np.linalg.eigvalsh(Kd) > 0)
    masses = a.M.diagonal()
    assert np.all(np.abs(masses - 1.0) <= 0.1) and np.ptp(masses) > 0.05
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(a.M.toarray(), Kd)).real)
    uniform = np.sort(np.linalg.eigvalsh(mass_spring_lattice(6, 6).K.toarray()))
    assert np.min(np.diff(uniform)) < 1e-6 * uniform[-1]  # square: repeated modes
    assert np.min(np.diff(w2)) > 1e-4 * w2[-1]
    with pytest.raises(ValueError, match="variation"):
        mass_spring_lattice(3, 3, mass_variation=1.0)


def test_white_noise_spectrum_is_the_plain_formula_bit_for_bit():
    shape, scale = (70, 9), 3.7
    rng = np.random.default_rng(11)
    expected = scale * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))
    got = white_noise_spectrum(np.random.default_rng(11), shape, scale, block=16)
    np.testing.assert_array_equal(got.view(float), expected.view(float))


CHAIN = mass_spring_chain(30, sparse=True)
BAND, DT, DURATION = (20.0, 60.0), 1 / 200, 8.0


def test_simulation_without_histories_has_the_same_spectra():
    with_h = simulate_white_noise(CHAIN, BAND, DT, DURATION, seed=4, histories=True)
    without = simulate_white_noise(CHAIN, BAND, DT, DURATION, seed=4, histories=False)
    assert without.forces is None and without.response is None
    assert with_h.response.shape == (1600, 30) and without.n_samples == 1600
    np.testing.assert_array_equal(without.omega, with_h.omega)
    assert rel(without.force_spectrum, with_h.force_spectrum) < 1e-13
    assert rel(without.response_spectrum, with_h.response_spectrum) < 1e-13
    auto = simulate_white_noise(CHAIN, BAND, DT, DURATION, seed=4)
    assert auto.response is not None  # 0.8 MB of histories: kept


def test_pod_from_spectra_equals_the_time_correlation_by_parseval():
    sim = simulate_white_noise(CHAIN, BAND, DT, DURATION, seed=5, histories=True)
    time_pod = pod(sim.response, method="correlation")
    for method in ("correlation", "snapshots"):
        spec = pod_from_spectra(sim.response_spectrum, sim.n_samples, method=method)
        lam = time_pod.eigenvalues
        assert np.abs(spec.eigenvalues - lam).max() < 1e-10 * lam[0]
        m = time_pod.order_for_energy(0.999)
        gaps = -np.diff(lam[: m + 1])
        assert gaps.min() > 1e-3 * lam[0]  # well separated, so the modes are fixed
        assert rel(spec.basis(m), time_pod.basis(m)) < 1e-10
    assert sim.pod().n_modes == 30  # 2·s > n: the correlation side


def separated_snapshots(r: int, n: int, seed: int) -> np.ndarray:
    """r snapshots of n DOFs with r distinct, well separated POD eigenvalues."""
    rng = np.random.default_rng(seed)
    Q = np.linalg.qr(rng.standard_normal((n, r)))[0]
    V = np.linalg.qr(rng.standard_normal((r, r)))[0]
    return V @ np.diag(np.geomspace(10.0, 0.1, r)) @ Q.T


def test_method_of_snapshots_matches_the_correlation_matrix():
    u = separated_snapshots(12, 80, 0)
    a, b = pod(u, method="snapshots"), pod(u, method="correlation")
    assert pod(u).n_modes == 12  # auto: r < n
    assert a.eigenvalues.shape == (80,) and np.all(a.eigenvalues[12:] == 0)
    assert np.abs(a.eigenvalues - b.eigenvalues).max() < 1e-10 * b.eigenvalues[0]
    assert rel(a.modes, b.modes[:, :12]) < 1e-10
    np.testing.assert_allclose(a.modes.T @ a.modes, np.eye(12), atol=1e-12)
    assert a.order_for_energy(1.0) == 12
    with pytest.raises(ValueError, match="only 12 POD modes"):
        a.basis(13)
    X = np.random.default_rng(1).standard_normal((5, 80, 2))
    np.testing.assert_allclose(a.project(X, 3), np.einsum("nm,snp->smp", b.basis(3), X),
                               atol=1e-12)


def test_pod_from_frf_by_snapshots_matches_the_correlation():
    system = mass_spring_lattice(8, 7, mass_variation=0.1, seed=3)
    omega = 2 * np.pi * np.linspace(40.0, 60.0, 9)
    H = system.frf(omega, cols=[10, 30])  # 2·9·2 = 36 snapshot rows < 56 DOFs
    a, b = pod_from_frf(H, omega), pod_from_frf(H, omega, method="correlation")
    assert a.n_modes <= 36 and b.n_modes == 56
    assert np.abs(a.eigenvalues - b.eigenvalues).max() < 1e-10 * b.eigenvalues[0]
    m = 3  # the eigenvalues fall by 1e-6 within five modes; these three stand apart
    assert np.all(-np.diff(b.eigenvalues[: m + 1]) > 1e-4 * b.eigenvalues[0])
    assert rel(a.basis(m), b.basis(m)) < 1e-10


def test_too_large_requests_are_refused_before_allocation(monkeypatch):
    big = mass_spring_chain(100_000)
    assert big.is_sparse
    omega = 2 * np.pi * np.linspace(1.0, 10.0, 401)
    with pytest.raises(MemoryError, match=r"FRF of 401 lines × 100000 × 100000 .* needs"):
        big.frf(omega)
    with pytest.raises(MemoryError, match="needs"):
        big.dynamic_stiffness(omega)
    with pytest.raises(MemoryError, match="a chain of 1000000000000 masses needs"):
        mass_spring_chain(10**12)
    with pytest.raises(MemoryError, match="histories=False"):
        simulate_white_noise(big, (1.0, 2.0), 1 / 400, 1000.0, histories=True)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 10**6)
    with pytest.raises(MemoryError, match="correlation matrix"):
        pod(np.ones((3, 1000)), method="correlation")
    with pytest.raises(MemoryError, match="dense copy"):
        mass_spring_chain(2000).todense()


def test_paper_chain_path_matches_the_dense_chain():
    """Band 4 of the quick study on the sparse chain (the study's path) and on the
    dense chain of old: spectra, original FRFs, POD basis, identified model and the
    table's dB errors agree to 1e-10 (the n = 100 table is unchanged)."""
    band, dt, duration, m = (102.8, 122.8), 1 / 400, 8.0, 13
    entries = chain_entries(100)
    assert entries == ((50, 50), (60, 40))
    out = []
    for system in (mass_spring_chain(100, sparse=True), mass_spring_chain(100, sparse=False)):
        sim = simulate_white_noise(system, band, dt, duration, seed=8, histories=True)
        H = frf_entries(system, sim.omega, entries)
        P = pod(sim.response)
        R = P.basis(m)
        res = identify(P.project(sim.response_spectrum, m), P.project(sim.force_spectrum, m),
                       sim.omega, lam=100.0)
        H_id = frf_entries(res.system(), sim.omega, entries, basis=R)
        db = np.abs(20 * np.log10(np.abs(H_id) / np.abs(H)))
        out.append((sim.response_spectrum, H, R, res.K, np.median(db, axis=0)))
    for a, b in zip(*out, strict=True):
        assert rel(a, b) < 1e-10


def test_identify_workflow_on_a_scan_allocates_nothing_of_n_by_n(tmp_path):
    """`run_identify` on FRFs at n = 4000 points (12 lines, 2 inputs): POD by snapshots,
    projection, overlays and modal table; numpy's allocations (traced by tracemalloc)
    peak far below one n × n array (128 MB)."""
    import tracemalloc

    from podid_rs.apps.identify import run_identify
    from podid_rs.io.npz import save_data
    from podid_rs.measured import from_frf

    system = mass_spring_lattice(80, 50, mass_variation=0.05, seed=0)
    omega = 2 * np.pi * np.linspace(20.0, 24.0, 12)
    inputs = [1020, 2555]
    H = system.frf(omega, cols=inputs)
    dofs = np.stack([np.arange(1, 4001), np.full(4000, 3)], axis=1)
    path = save_data(tmp_path / "scan.npz", from_frf(H, omega, inputs=inputs, dofs=dofs))
    # the bound is on the workflow's arrays: matplotlib's first import (its font cache,
    # ~20 MB) is done before tracing, as when any other test has drawn a figure first
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401

    tracemalloc.start()
    try:
        run = run_identify(path, tmp_path / "out", band_hz=(19.0, 25.0), m=6)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert run.basis.shape == (4000, 6) and run.result.m == 6
    assert peak < 0.25 * 8 * 4000**2, f"peak {peak / 1e6:.0f} MB"
    assert (tmp_path / "out" / "frf_input1.png").is_file()


def test_cli_paper_n_reaches_the_study(monkeypatch, capsys):
    import podid_rs.apps.paper as paper
    from podid_rs.apps.cli import main

    seen = {}

    class Study:
        def summary(self):
            return "done"

    def fake(out, **kwargs):
        seen.update(kwargs)
        return Study()

    real = paper.run_paper_study
    monkeypatch.setattr(paper, "run_paper_study", fake)
    assert main(["paper", "--quick", "--n", "100000", "--no-progress"]) == 0
    assert seen["n"] == 100_000 and seen["quick"]
    with pytest.raises(SystemExit):
        main(["paper", "--n", "1"])
    assert "--n" in capsys.readouterr().err
    with pytest.raises(ValueError, match="n must be an integer >= 2"):
        real(n=1)
    assert chain_entries(100_000) == ((50_000, 50_000), (60_000, 40_000))
