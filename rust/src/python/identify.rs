//! Bindings of the identification at a fixed λ: the direct solve
//! ([`identify_direct`]) and the matrix-free one ([`identify_cg`]), both returning an
//! [`PyIdentified`]; the memory each would take; the Gram products; and the GEMM
//! rate the CG benchmarks compare with.

use super::arrays::{columns, mat_to_py, timings_dict};
use super::run::{run, run_iterative};
use crate::cg::{self, CgOptions};
use crate::data::{Scaling, Stacked};
use crate::solution::Identified;
use crate::{gram, identify};
use faer::Par;
use numpy::{Complex64, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// M, C, K identified at a fixed λ, in the caller's units, with what the solver saw
/// (the Rust [`Identified`]). The last three are None for the direct solve.
#[pyclass(name = "Identified", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyIdentified {
    /// the mass matrix M (m×m)
    #[pyo3(name = "M")]
    mass: Py<PyArray2<f64>>,
    /// the damping matrix C (m×m)
    #[pyo3(name = "C")]
    damping: Py<PyArray2<f64>>,
    /// the stiffness matrix K (m×m)
    #[pyo3(name = "K")]
    stiffness: Py<PyArray2<f64>>,
    /// how the normal equations were solved: "cholesky", "eigen-min-norm" or "cg"
    method: String,
    /// numerical rank of the normal matrix (= n_unknowns when well posed)
    rank: usize,
    n_unknowns: usize,
    /// smallest pivot (or eigenvalue) of the normal matrix over its largest (NaN for CG)
    min_pivot_ratio: f64,
    /// (ω0, s_u, s_f): the scales of frequency, responses and forces
    scaling: (f64, f64, f64),
    /// the data misfit ‖Ax − y‖ of the answer (eq. 28)
    residual_norm: f64,
    /// wall time per phase, seconds
    timings: Py<PyDict>,
    /// CG iterations taken
    iterations: Option<usize>,
    /// the true relative residual ‖b − A x‖/‖b‖ of the answer (scaled problem)
    relative_residual: Option<f64>,
    /// whether CG reached its tolerance
    converged: Option<bool>,
}

impl PyIdentified {
    fn new(py: Python<'_>, id: &Identified) -> PyResult<PyIdentified> {
        let s = id.scaling;
        Ok(PyIdentified {
            mass: mat_to_py(py, &id.mck[0]),
            damping: mat_to_py(py, &id.mck[1]),
            stiffness: mat_to_py(py, &id.mck[2]),
            method: id.method.name().to_string(),
            rank: id.rank,
            n_unknowns: id.n_unknowns,
            min_pivot_ratio: id.min_pivot_ratio,
            scaling: (s.omega0, s.su, s.sf),
            residual_norm: id.residual_norm,
            timings: timings_dict(py, &id.timings)?,
            iterations: id.cg.map(|r| r.iterations),
            relative_residual: id.cg.map(|r| r.relative_residual),
            converged: id.cg.map(|r| r.converged),
        })
    }
}

type MatPair = (Py<PyArray2<f64>>, Py<PyArray2<f64>>);

/// Gram products H = Re(V Vᴴ) (3m×3m) and B = Re(F Vᴴ) (m×3m), unscaled.
/// u, f: complex (N, m) rows u_i, f_i; omega: (N,).
#[pyfunction(name = "gram")]
#[pyo3(signature = (u, f, omega, *, threads = 0))]
fn py_gram<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    threads: usize,
) -> PyResult<MatPair> {
    let cols = columns(&u, &f, &omega)?;
    let g = run(py, threads, || {
        Ok(gram::gram(
            &Stacked::new(&cols, &Scaling::IDENTITY),
            Par::rayon(0),
        ))
    })?;
    Ok((mat_to_py(py, &g.h), mat_to_py(py, &g.b)))
}

/// Direct identification (paper eq. 49 in the symmetric/skew basis).
#[pyfunction]
#[pyo3(signature = (u, f, omega, lam, symmetric, *, threads = 0))]
fn identify_direct<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    lam: (f64, f64, f64),
    symmetric: bool,
    threads: usize,
) -> PyResult<PyIdentified> {
    let cols = columns(&u, &f, &omega)?;
    let lam = [lam.0, lam.1, lam.2];
    let id = run(py, threads, || {
        identify::identify(&cols, lam, symmetric, Par::rayon(0))
    })?;
    PyIdentified::new(py, &id)
}

/// Matrix-free identification by preconditioned CG, to the relative residual `tol`
/// in at most `max_iter` iterations. `progress`, if given, is called as
/// progress(iteration, recursive relative residual) about every 0.1 s and after the
/// last iteration; Ctrl-C or an exception in `progress` stops the solve and
/// propagates.
#[pyfunction]
#[pyo3(signature = (u, f, omega, lam, symmetric, tol, max_iter, *, progress = None, threads = 0))]
#[allow(clippy::too_many_arguments)] // one per Python argument
fn identify_cg<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    lam: (f64, f64, f64),
    symmetric: bool,
    tol: f64,
    max_iter: usize,
    progress: Option<Py<PyAny>>,
    threads: usize,
) -> PyResult<PyIdentified> {
    let cols = columns(&u, &f, &omega)?;
    let lam = [lam.0, lam.1, lam.2];
    let opts = CgOptions { tol, max_iter };
    let id = run_iterative(py, threads, progress, |report| {
        cg::identify_cg(&cols, lam, symmetric, opts, Some(report), Par::rayon(0))
    })?;
    PyIdentified::new(py, &id)
}

/// Bytes of the matrix-free solver's working set.
#[pyfunction]
fn cg_memory_bytes(m: usize, symmetric: bool) -> u128 {
    cg::memory_bytes(m, symmetric)
}

/// GFLOP/s of faer's GEMM in the shape of one CG operator apply (m×3m by 3m×3m),
/// best of `repeat`, on `threads` threads (0 = all): the benchmarks' floor.
#[pyfunction]
#[pyo3(signature = (m, repeat = 3, threads = 0))]
fn operator_gemm_gflops(py: Python<'_>, m: usize, repeat: usize, threads: usize) -> PyResult<f64> {
    run(py, threads, || {
        Ok(cg::operator_gemm_gflops(m, repeat, Par::rayon(0)))
    })
}

/// Bytes of the largest dense matrix the direct path would allocate.
#[pyfunction]
fn direct_memory_bytes(m: usize, lam: (f64, f64, f64), symmetric: bool) -> u128 {
    identify::dense_bytes(m, [lam.0, lam.1, lam.2], symmetric)
}

/// Add this area's functions and classes to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyIdentified>()?;
    m.add_function(wrap_pyfunction!(py_gram, m)?)?;
    m.add_function(wrap_pyfunction!(identify_direct, m)?)?;
    m.add_function(wrap_pyfunction!(direct_memory_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(identify_cg, m)?)?;
    m.add_function(wrap_pyfunction!(cg_memory_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(operator_gemm_gflops, m)?)?;
    Ok(())
}
