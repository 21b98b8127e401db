//! Thin PyO3 bindings over the plain Rust functions. Arrays arrive validated and
//! C-contiguous from `podid_rs.identification`; the GIL is released during the
//! numerics; a Rust panic becomes a RuntimeError, never a PanicException.

use crate::cg::{self, CgOptions};
use crate::data::{Columns, Scaling, Stacked};
use crate::error::PodidError;
use crate::solution::Identified;
use crate::sweep::Sweep;
use crate::{identify, with_threads};
use faer::{Mat, Par};
use numpy::ndarray::Array2;
use numpy::{
    Complex64, IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ops::ControlFlow;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Duration;

fn to_py(e: PodidError) -> PyErr {
    match e {
        PodidError::Invalid(msg) => PyValueError::new_err(msg),
        e @ PodidError::OutOfMemory { .. } => PyMemoryError::new_err(e.to_string()),
        PodidError::Interrupted => PyKeyboardInterrupt::new_err("interrupted"),
    }
}

type Outcome<T> = std::thread::Result<Result<Result<T, PodidError>, PodidError>>;

/// The Python error for the outcome of a job run under `catch_unwind(with_threads(..))`.
fn outcome<T>(out: Outcome<T>) -> PyResult<T> {
    match out {
        Ok(Ok(Ok(v))) => Ok(v),
        Ok(Ok(Err(e))) | Ok(Err(e)) => Err(to_py(e)),
        Err(panic) => {
            let msg = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            Err(PyRuntimeError::new_err(format!(
                "internal error in the Rust core: {msg}"
            )))
        }
    }
}

/// Run the numerics without the GIL, on `threads` threads, turning panics into errors.
fn run<T: Send>(
    py: Python<'_>,
    threads: usize,
    f: impl FnOnce() -> Result<T, PodidError> + Send,
) -> PyResult<T> {
    outcome(py.detach(|| catch_unwind(AssertUnwindSafe(|| with_threads(threads, f)))))
}

/// How often the waiting thread looks at Ctrl-C and reports progress.
const POLL: Duration = Duration::from_millis(100);

/// Like [`run`] for an iterative job: it runs on a worker thread while this
/// (Python's) thread polls for signals every [`POLL`] and passes the latest
/// (iteration, residual) to `progress`, and once more at the end. Ctrl-C, or an
/// exception raised by `progress`, stops the job at its next iteration and is
/// re-raised here.
fn run_iterative<T: Send>(
    py: Python<'_>,
    threads: usize,
    progress: Option<Py<PyAny>>,
    job: impl FnOnce(cg::Progress) -> Result<T, PodidError> + Send,
) -> PyResult<T> {
    let cancel = AtomicBool::new(false);
    let latest = Mutex::new((0usize, f64::NAN));
    let (out, raised) = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = mpsc::channel();
            let (latest, cancel) = (&latest, &cancel);
            s.spawn(move || {
                let mut report = |it: usize, res: f64| {
                    if let Ok(mut l) = latest.lock() {
                        *l = (it, res);
                    }
                    if cancel.load(Ordering::Relaxed) {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                };
                let out = catch_unwind(AssertUnwindSafe(|| {
                    with_threads(threads, || job(&mut report))
                }));
                // the receiver outlives this scope's threads: it cannot be gone
                let _ = tx.send(out);
            });
            let mut raised: Option<PyErr> = None;
            let mut shown = 0;
            // check Ctrl-C, and show the latest iteration if it is new
            let mut poll = |check_signals: bool| {
                let (it, res) = latest.lock().map(|l| *l).unwrap_or((0, f64::NAN));
                let step = Python::attach(|py| {
                    if check_signals {
                        py.check_signals()?;
                    }
                    match &progress {
                        Some(cb) if it > shown => cb.call1(py, (it, res)).map(|_| ()),
                        _ => Ok(()),
                    }
                });
                shown = it;
                step
            };
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(out) => {
                        if raised.is_none() {
                            raised = poll(false).err();
                        }
                        return (out, raised);
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) if raised.is_none() => {
                        if let Err(e) = poll(true) {
                            raised = Some(e);
                            cancel.store(true, Ordering::Relaxed);
                        }
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        let msg = "the solver thread ended without a result";
                        return (Err(Box::new(msg) as Box<_>), raised);
                    }
                }
            }
        })
    });
    match raised {
        Some(e) => Err(e),
        None => outcome(out),
    }
}

fn mat_to_py<'py>(py: Python<'py>, a: &Mat<f64>) -> Bound<'py, PyArray2<f64>> {
    PyArray2::from_owned_array(
        py,
        Array2::from_shape_fn((a.nrows(), a.ncols()), |(i, j)| a[(i, j)]),
    )
}

/// Borrow the validated columns (arrays are C-contiguous from the Python layer).
fn columns<'a>(
    u: &'a PyReadonlyArray2<'_, Complex64>,
    f: &'a PyReadonlyArray2<'_, Complex64>,
    omega: &'a PyReadonlyArray1<'_, f64>,
) -> PyResult<Columns<'a>> {
    let err = |_| PyValueError::new_err("arrays must be C-contiguous");
    let (us, fs, ws) = (
        u.as_slice().map_err(err)?,
        f.as_slice().map_err(err)?,
        omega.as_slice().map_err(err)?,
    );
    Columns::new(us, fs, ws, u.shape()[1]).map_err(to_py)
}

type MatPair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// Gram products H = Re(V Vᴴ) (3m×3m) and B = Re(F Vᴴ) (m×3m), unscaled (DESIGN §2).
/// u, f: complex (N, m) rows u_i, f_i; omega: (N,).
#[pyfunction(name = "gram")]
#[pyo3(signature = (u, f, omega, threads = 0))]
fn py_gram<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    threads: usize,
) -> PyResult<MatPair<'py>> {
    let cols = columns(&u, &f, &omega)?;
    let g = run(py, threads, || {
        Ok(crate::gram::gram(
            &Stacked::new(&cols, &Scaling::IDENTITY),
            Par::rayon(0),
        ))
    })?;
    Ok((mat_to_py(py, &g.h), mat_to_py(py, &g.b)))
}

/// Direct identification (paper eq. 49 in the symmetric/skew basis). Returns a dict
/// with M, C, K, method, rank, n_unknowns, min_pivot_ratio, scaling.
#[pyfunction]
#[pyo3(signature = (u, f, omega, lam, symmetric, threads = 0))]
fn identify_direct<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    lam: (f64, f64, f64),
    symmetric: bool,
    threads: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let cols = columns(&u, &f, &omega)?;
    let lam = [lam.0, lam.1, lam.2];
    let id = run(py, threads, || {
        identify::identify(&cols, lam, symmetric, Par::rayon(0))
    })?;
    result_dict(py, &id)
}

/// The identification as a dict: M, C, K, method, rank, n_unknowns,
/// min_pivot_ratio, scaling, timings, and for CG iterations, relative_residual,
/// converged.
fn result_dict<'py>(py: Python<'py>, id: &Identified) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, x) in ["M", "C", "K"].iter().zip(&id.mck) {
        d.set_item(*name, mat_to_py(py, x))?;
    }
    d.set_item("method", id.method.name())?;
    d.set_item("rank", id.rank)?;
    d.set_item("n_unknowns", id.n_unknowns)?;
    d.set_item("min_pivot_ratio", id.min_pivot_ratio)?;
    let s = id.scaling;
    d.set_item("scaling", (s.omega0, s.su, s.sf))?;
    d.set_item("residual_norm", id.residual_norm)?;
    let t = PyDict::new(py);
    for (name, secs) in &id.timings {
        t.set_item(*name, *secs)?;
    }
    d.set_item("timings", t)?;
    if let Some(rep) = id.cg {
        d.set_item("iterations", rep.iterations)?;
        d.set_item("relative_residual", rep.relative_residual)?;
        d.set_item("converged", rep.converged)?;
    }
    Ok(d)
}

/// Matrix-free identification by preconditioned CG (DESIGN §4); the same dict as
/// `identify_direct` plus iterations, relative_residual, converged. `progress`,
/// if given, is called as progress(iteration, recursive relative residual) about
/// every 0.1 s and after the last iteration; Ctrl-C or an exception in
/// `progress` stops the solve and propagates.
#[pyfunction]
#[pyo3(signature = (u, f, omega, lam, symmetric, tol, max_iter, progress = None, threads = 0))]
#[allow(clippy::too_many_arguments)]
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
) -> PyResult<Bound<'py, PyDict>> {
    let cols = columns(&u, &f, &omega)?;
    let lam = [lam.0, lam.1, lam.2];
    let opts = CgOptions { tol, max_iter };
    let id = run_iterative(py, threads, progress, |report| {
        cg::identify_cg(&cols, lam, symmetric, opts, Some(report), Par::rayon(0))
    })?;
    result_dict(py, &id)
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

fn timings_dict<'py>(py: Python<'py>, timings: &[(&str, f64)]) -> PyResult<Bound<'py, PyDict>> {
    let t = PyDict::new(py);
    for (name, secs) in timings {
        t.set_item(*name, *secs)?;
    }
    Ok(t)
}

/// The λ-curves of one common symmetry weight from one eigendecomposition
/// (`crate::sweep`). Built by `lambda_sweep`; holds n_w² doubles.
#[pyclass(name = "LambdaSweep", module = "podid_rs._core", frozen)]
struct PyLambdaSweep {
    inner: Sweep,
}

#[pymethods]
impl PyLambdaSweep {
    #[getter]
    fn m(&self) -> usize {
        self.inner.m()
    }

    /// Real equations 2·N·m of the stacked problem.
    #[getter]
    fn n_rows(&self) -> usize {
        self.inner.n_rows()
    }

    #[getter]
    fn n_unknowns(&self) -> usize {
        self.inner.n_unknowns()
    }

    /// ν_i (1/λ² units): skew direction i is damped by 1/(1 + λ²ν_i).
    #[getter]
    fn eigenvalues<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.eigenvalues().to_vec().into_pyarray(py)
    }

    #[getter]
    fn min_pivot_ratio(&self) -> f64 {
        self.inner.min_pivot_ratio()
    }

    #[getter]
    fn scaling(&self) -> (f64, f64, f64) {
        let s = self.inner.scaling();
        (s.omega0, s.su, s.sf)
    }

    #[getter]
    fn timings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        timings_dict(py, self.inner.timings())
    }

    /// residual ‖Ax−y‖, penalty ‖Lx‖, trace, gcv and curvature at each λ (paper
    /// units): `exact` refines residual and penalty by solves (O(n_w²) per λ),
    /// otherwise all come from the spectrum (O(n_w) per λ, ~1e-8 relative).
    #[pyo3(signature = (lams, exact = false, threads = 0))]
    fn curve<'py>(
        &self,
        py: Python<'py>,
        lams: PyReadonlyArray1<'py, f64>,
        exact: bool,
        threads: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let lams = lams
            .as_slice()
            .map_err(|_| PyValueError::new_err("lams must be C-contiguous"))?;
        if !lams.iter().all(|l| l.is_finite() && *l >= 0.0) {
            return Err(PyValueError::new_err(
                "lams must be finite and non-negative",
            ));
        }
        let sweep = &self.inner;
        let pts = run(py, threads, || {
            Ok(if exact {
                sweep.exact_points(lams, Par::rayon(0))
            } else {
                lams.iter().map(|&l| sweep.spectral_point(l)).collect()
            })
        })?;
        let d = PyDict::new(py);
        let fields: [(&str, PointField); 5] = [
            ("residual_norm", |p| p.residual),
            ("penalty_norm", |p| p.penalty),
            ("trace", |p| p.trace),
            ("gcv", |p| p.gcv),
            ("curvature", |p| p.curvature),
        ];
        for (name, get) in fields {
            d.set_item(
                name,
                pts.iter().map(get).collect::<Vec<_>>().into_pyarray(py),
            )?;
        }
        Ok(d)
    }

    /// (M, C, K) at λ (paper units).
    #[pyo3(signature = (lam, threads = 0))]
    fn solve<'py>(&self, py: Python<'py>, lam: f64, threads: usize) -> PyResult<MatTriple<'py>> {
        if !(lam.is_finite() && lam >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "lam must be finite and non-negative, got {lam}"
            )));
        }
        let sweep = &self.inner;
        let [mm, cc, kk] = run(py, threads, || Ok(sweep.solve(lam, Par::rayon(0))))?;
        Ok((mat_to_py(py, &mm), mat_to_py(py, &cc), mat_to_py(py, &kk)))
    }
}

/// One field of a [`Point`](crate::sweep::Point), for building the curve dict.
type PointField = fn(&crate::sweep::Point) -> f64;

type MatTriple<'py> = (
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray2<f64>>,
);

/// Factor once for the λ-curves; None when H is not positive definite (the
/// unregularised problem is rank deficient: sweep with repeated solves instead).
#[pyfunction]
#[pyo3(signature = (u, f, omega, threads = 0))]
fn lambda_sweep<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    threads: usize,
) -> PyResult<Option<PyLambdaSweep>> {
    let cols = columns(&u, &f, &omega)?;
    let sweep = run(py, threads, || Sweep::new(&cols, Par::rayon(0)))?;
    Ok(sweep.map(|inner| PyLambdaSweep { inner }))
}

/// Bytes of the largest matrix `lambda_sweep` allocates.
#[pyfunction]
fn sweep_memory_bytes(m: usize) -> u128 {
    crate::sweep::sweep_bytes(m)
}

/// Output-error refinement (`crate::refine`, DESIGN §6) of the start model (M, C, K)
/// on reduced data: u, f complex (s·p, m) rows (line-major, load cases inner),
/// omega (s,), p load cases; weights either `weights` (s·p,) scalars or
/// `weight_matrices` (s·p, m·m) row-major T_ij. Returns a dict with M, C, K,
/// cost_start, cost, iterations, accepted, stop, converged, history, scaling,
/// timings. `progress(iteration, cost)` is called about every 0.1 s; Ctrl-C or an
/// exception in it stops the iteration and propagates.
#[pyfunction]
#[pyo3(signature = (u, f, omega, p, start, weights = None, weight_matrices = None,
    log_magnitude = None, max_iter = 200, ftol = 1e-7, xtol = 1e-12, log_diagonal = true, progress = None,
    threads = 0, solver = "auto", curvature = false, modal_metric = false))]
#[allow(clippy::too_many_arguments)]
fn refine_output_error<'py>(
    py: Python<'py>,
    u: PyReadonlyArray2<'py, Complex64>,
    f: PyReadonlyArray2<'py, Complex64>,
    omega: PyReadonlyArray1<'py, f64>,
    p: usize,
    start: (
        PyReadonlyArray2<'py, f64>,
        PyReadonlyArray2<'py, f64>,
        PyReadonlyArray2<'py, f64>,
    ),
    weights: Option<PyReadonlyArray1<'py, f64>>,
    weight_matrices: Option<PyReadonlyArray2<'py, f64>>,
    log_magnitude: Option<(
        PyReadonlyArray2<'py, f64>,
        PyReadonlyArray2<'py, Complex64>,
        PyReadonlyArray2<'py, f64>,
    )>,
    max_iter: usize,
    ftol: f64,
    xtol: f64,
    log_diagonal: bool,
    progress: Option<Py<PyAny>>,
    threads: usize,
    solver: &str,
    curvature: bool,
    modal_metric: bool,
) -> PyResult<Bound<'py, PyDict>> {
    use crate::refine::{LogTarget, OeData, OeOptions, StepKind, Weights};
    let solver = StepKind::from_name(solver).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let err = |_| PyValueError::new_err("arrays must be C-contiguous");
    let (us, fs, ws) = (
        u.as_slice().map_err(err)?,
        f.as_slice().map_err(err)?,
        omega.as_slice().map_err(err)?,
    );
    let m = u.shape()[1];
    let weights = match (&weights, &weight_matrices, &log_magnitude) {
        (Some(w), None, None) => Weights::Scalar(w.as_slice().map_err(err)?),
        (None, Some(t), None) => Weights::Matrix(t.as_slice().map_err(err)?),
        // (R (n, m), targets (s·p, n), entry weights (s·p, n))
        (None, None, Some((r, ul, wl))) => Weights::LogMagnitude(LogTarget {
            basis: r.as_slice().map_err(err)?,
            n: r.shape()[0],
            u: ul.as_slice().map_err(err)?,
            w: wl.as_slice().map_err(err)?,
        }),
        _ => {
            return Err(PyValueError::new_err(
                "give exactly one of weights, weight_matrices and log_magnitude",
            ))
        }
    };
    let data = OeData {
        omega: ws,
        u: us,
        f: fs,
        weights,
        m,
        p,
    };
    let to_mat = |a: &PyReadonlyArray2<'py, f64>| -> PyResult<Mat<f64>> {
        let sh = a.shape();
        let sl = a.as_slice().map_err(err)?;
        Ok(Mat::from_fn(sh[0], sh[1], |i, j| sl[i * sh[1] + j]))
    };
    let start = [to_mat(&start.0)?, to_mat(&start.1)?, to_mat(&start.2)?];
    let opts = OeOptions {
        max_iter,
        ftol,
        xtol,
        log_diagonal,
        solver,
        curvature,
        modal_metric,
    };
    let rep = run_iterative(py, threads, progress, |report| {
        // on a worker of the pool, not the calling thread: the matrix-free step's O(m³)
        // block work goes side by side there, where a parallel section is a push to the
        // worker's own deque, not an injection and a blocking wait (m = 60, 1200 lines:
        // 39.7 s from outside, 28.1 s from inside; `identify`'s CG measured slower from
        // inside, m = 400: 0.82–1.05 s against 0.74–0.80 s, so it stays where it was)
        rayon::scope(|_| crate::refine::refine(data, &start, opts, Par::rayon(0), Some(report)))
    })?;
    let d = PyDict::new(py);
    for (name, x) in ["M", "C", "K"].iter().zip(&rep.mck) {
        d.set_item(*name, mat_to_py(py, x))?;
    }
    d.set_item("cost_start", rep.cost_start)?;
    d.set_item("cost", rep.cost)?;
    d.set_item("iterations", rep.iterations)?;
    d.set_item("accepted", rep.accepted)?;
    d.set_item("stop", rep.stop.name())?;
    d.set_item("converged", rep.stop.converged())?;
    d.set_item("history", rep.history.clone())?;
    let sc = rep.scaling;
    d.set_item("scaling", (sc.omega0, sc.su, sc.sf))?;
    d.set_item("timings", timings_dict(py, &rep.timings)?)?;
    d.set_item("solver", rep.solver)?;
    d.set_item("solver_stats", timings_dict(py, &rep.solver_stats)?)?;
    // (s·p, m) like the data columns
    let rows = |x: &[Complex64]| {
        use numpy::PyArrayMethods;
        PyArray1::from_slice(py, x).reshape([x.len() / m, m])
    };
    if let Some(x) = &rep.responses_start {
        d.set_item("responses_start", rows(x)?)?;
    }
    d.set_item("responses", rows(&rep.responses)?)?;
    Ok(d)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_gram, m)?)?;
    m.add_function(wrap_pyfunction!(identify_direct, m)?)?;
    m.add_function(wrap_pyfunction!(direct_memory_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(lambda_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_memory_bytes, m)?)?;
    m.add_class::<PyLambdaSweep>()?;
    m.add_function(wrap_pyfunction!(identify_cg, m)?)?;
    m.add_function(wrap_pyfunction!(cg_memory_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(operator_gemm_gflops, m)?)?;
    m.add_function(wrap_pyfunction!(refine_output_error, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
