//! Bindings of the output-error refinement ([`refine_output_error`]).
//!
//! The call reads in groups: the reduced data (u, f, omega, p), the start model, how
//! the columns are weighted — one of three classes, [`PyColumnWeights`],
//! [`PyMatrixWeights`] or [`PyLogMagnitudeWeights`], so that the kind of objective is
//! a type and not a choice among keywords —, how the iteration runs
//! ([`PyRefineOptions`], built with keywords), and keyword-only how the call runs
//! (`progress`, `threads`). It returns a [`PyRefined`].

use super::arrays::{mat_from_py, mat_to_py, not_contiguous, timings_dict};
use super::run::{run_iterative, to_py};
use crate::refine::{self, LogTarget, OeData, OeOptions, OeReport, StepKind, Weights};
use faer::Par;
use numpy::{
    Complex64, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// How the Levenberg–Marquardt iteration runs (the Rust [`OeOptions`]); the defaults
/// are the Rust defaults.
#[pyclass(name = "RefineOptions", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyRefineOptions {
    /// most Gauss–Newton steps (accepted or not)
    max_iter: usize,
    /// converged when the last accepted steps lowered the cost by less than this,
    /// relative, per step
    ftol: f64,
    /// converged when ‖δθ‖ ≤ xtol·(‖θ‖ + xtol)
    xtol: f64,
    /// the factors' diagonals as exp(θ): M, C, K positive definite for every θ
    log_diagonal: bool,
    /// the step's linear algebra: "dense", "matrix-free" or "auto"
    solver: String,
    /// add the curvature of the parametrisation to the Gauss–Newton matrix
    curvature: bool,
    /// matrix-free step only: damp and precondition by the modal metric
    modal_metric: bool,
    /// dense step only: add the geodesic acceleration to each step
    acceleration: bool,
}

#[pymethods]
impl PyRefineOptions {
    #[new]
    #[pyo3(signature = (*, max_iter = 200, ftol = 1e-7, xtol = 1e-12, log_diagonal = true,
        solver = "auto", curvature = false, modal_metric = false, acceleration = false))]
    #[allow(clippy::too_many_arguments)] // one per keyword of the Python constructor
    fn new(
        max_iter: usize,
        ftol: f64,
        xtol: f64,
        log_diagonal: bool,
        solver: &str,
        curvature: bool,
        modal_metric: bool,
        acceleration: bool,
    ) -> PyResult<PyRefineOptions> {
        StepKind::from_name(solver).map_err(to_py)?;
        Ok(PyRefineOptions {
            max_iter,
            ftol,
            xtol,
            log_diagonal,
            solver: solver.to_string(),
            curvature,
            modal_metric,
            acceleration,
        })
    }
}

impl PyRefineOptions {
    fn to_rust(&self) -> PyResult<OeOptions> {
        Ok(OeOptions {
            max_iter: self.max_iter,
            ftol: self.ftol,
            xtol: self.xtol,
            log_diagonal: self.log_diagonal,
            solver: StepKind::from_name(&self.solver).map_err(to_py)?,
            curvature: self.curvature,
            modal_metric: self.modal_metric,
            acceleration: self.acceleration,
        })
    }
}

/// One scalar weight w_ij ≥ 0 per column: the cost Σ w_ij² ‖x_ij − u_ij‖².
#[pyclass(name = "ColumnWeights", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyColumnWeights {
    /// (s·p,) the weight of each column, line-major
    weights: Py<PyArray1<f64>>,
}

#[pymethods]
impl PyColumnWeights {
    #[new]
    fn new(weights: Bound<'_, PyArray1<f64>>) -> Self {
        PyColumnWeights {
            weights: weights.unbind(),
        }
    }
}

/// One real m×m matrix T_ij per column: the cost Σ ‖T_ij (x_ij − u_ij)‖².
#[pyclass(name = "MatrixWeights", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyMatrixWeights {
    /// (s·p, m·m) the T_ij of each column, row-major
    matrices: Py<PyArray2<f64>>,
}

#[pymethods]
impl PyMatrixWeights {
    #[new]
    fn new(matrices: Bound<'_, PyArray2<f64>>) -> Self {
        PyMatrixWeights {
            matrices: matrices.unbind(),
        }
    }
}

/// The log-magnitude output error on n measured entries y = R x: the cost
/// Σ w_ije² (ln|y_ije| − ln|u_ije|)² (the Rust [`LogTarget`]).
#[pyclass(
    name = "LogMagnitudeWeights",
    module = "podid_rs._core",
    frozen,
    get_all
)]
pub(super) struct PyLogMagnitudeWeights {
    /// R (n, m): the measured entries of a reduced response x are R x
    basis: Py<PyArray2<f64>>,
    /// (s·p, n) the measured responses u_ije on the entries
    targets: Py<PyArray2<Complex64>>,
    /// (s·p, n) the weight w_ije ≥ 0 of each entry (0: not measured)
    entry_weights: Py<PyArray2<f64>>,
}

#[pymethods]
impl PyLogMagnitudeWeights {
    #[new]
    fn new(
        basis: Bound<'_, PyArray2<f64>>,
        targets: Bound<'_, PyArray2<Complex64>>,
        entry_weights: Bound<'_, PyArray2<f64>>,
    ) -> Self {
        PyLogMagnitudeWeights {
            basis: basis.unbind(),
            targets: targets.unbind(),
            entry_weights: entry_weights.unbind(),
        }
    }
}

/// The arrays of a weighting, borrowed for the call.
enum WeightArrays<'py> {
    Column(PyReadonlyArray1<'py, f64>),
    Matrix(PyReadonlyArray2<'py, f64>),
    LogMagnitude {
        basis: PyReadonlyArray2<'py, f64>,
        targets: PyReadonlyArray2<'py, Complex64>,
        entry_weights: PyReadonlyArray2<'py, f64>,
    },
}

impl<'py> WeightArrays<'py> {
    fn borrow(weighting: &Bound<'py, PyAny>) -> PyResult<WeightArrays<'py>> {
        let py = weighting.py();
        if let Ok(w) = weighting.cast::<PyColumnWeights>() {
            return Ok(WeightArrays::Column(
                w.get().weights.bind(py).try_readonly()?,
            ));
        }
        if let Ok(w) = weighting.cast::<PyMatrixWeights>() {
            return Ok(WeightArrays::Matrix(
                w.get().matrices.bind(py).try_readonly()?,
            ));
        }
        if let Ok(w) = weighting.cast::<PyLogMagnitudeWeights>() {
            let w = w.get();
            return Ok(WeightArrays::LogMagnitude {
                basis: w.basis.bind(py).try_readonly()?,
                targets: w.targets.bind(py).try_readonly()?,
                entry_weights: w.entry_weights.bind(py).try_readonly()?,
            });
        }
        Err(PyValueError::new_err(
            "weighting must be ColumnWeights, MatrixWeights or LogMagnitudeWeights",
        ))
    }

    fn weights(&self) -> PyResult<Weights<'_>> {
        Ok(match self {
            WeightArrays::Column(w) => Weights::Scalar(w.as_slice().map_err(not_contiguous)?),
            WeightArrays::Matrix(t) => Weights::Matrix(t.as_slice().map_err(not_contiguous)?),
            WeightArrays::LogMagnitude {
                basis,
                targets,
                entry_weights,
            } => Weights::LogMagnitude(LogTarget {
                basis: basis.as_slice().map_err(not_contiguous)?,
                n: basis.shape()[0],
                u: targets.as_slice().map_err(not_contiguous)?,
                w: entry_weights.as_slice().map_err(not_contiguous)?,
            }),
        })
    }
}

/// The refined model and what the iteration did (the Rust [`OeReport`]).
#[pyclass(name = "Refined", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyRefined {
    /// the refined mass matrix M (m×m)
    #[pyo3(name = "M")]
    mass: Py<PyArray2<f64>>,
    /// the refined damping matrix C (m×m)
    #[pyo3(name = "C")]
    damping: Py<PyArray2<f64>>,
    /// the refined stiffness matrix K (m×m)
    #[pyo3(name = "K")]
    stiffness: Py<PyArray2<f64>>,
    /// the cost of the start, caller's units
    cost_start: f64,
    /// the cost of the answer, caller's units
    cost: f64,
    /// Gauss–Newton steps taken (accepted or rejected)
    iterations: usize,
    /// Gauss–Newton steps accepted
    accepted: usize,
    /// why the iteration stopped
    stop: String,
    /// false only when max_iter ended the iteration
    converged: bool,
    /// (iteration, cost) after every accepted step, caller's units
    history: Vec<(usize, f64)>,
    /// (ω0, s_u, s_f): the scales of frequency, responses and forces
    scaling: (f64, f64, f64),
    /// wall time per phase, seconds
    timings: Py<PyDict>,
    /// the step solver used: "dense" or "matrix-free"
    solver: String,
    /// counts of the step solver's work
    solver_stats: Py<PyDict>,
    /// (s·p, m) the model responses D(ω)⁻¹ f of the start as given, in the layout
    /// of u; None when the start has a pole on a measured line
    responses_start: Option<Py<PyArray2<Complex64>>>,
    /// (s·p, m) the model responses of the answer
    responses: Py<PyArray2<Complex64>>,
}

impl PyRefined {
    fn new(py: Python<'_>, rep: &OeReport, m: usize) -> PyResult<PyRefined> {
        // (s·p, m) like the data columns
        let rows = |x: &[Complex64]| -> PyResult<Py<PyArray2<Complex64>>> {
            Ok(PyArray1::from_slice(py, x)
                .reshape([x.len() / m, m])?
                .unbind())
        };
        let sc = rep.scaling;
        Ok(PyRefined {
            mass: mat_to_py(py, &rep.mck[0]),
            damping: mat_to_py(py, &rep.mck[1]),
            stiffness: mat_to_py(py, &rep.mck[2]),
            cost_start: rep.cost_start,
            cost: rep.cost,
            iterations: rep.iterations,
            accepted: rep.accepted,
            stop: rep.stop.name().to_string(),
            converged: rep.stop.converged(),
            history: rep.history.clone(),
            scaling: (sc.omega0, sc.su, sc.sf),
            timings: timings_dict(py, &rep.timings)?,
            solver: rep.solver.to_string(),
            solver_stats: timings_dict(py, &rep.solver_stats)?,
            responses_start: rep.responses_start.as_deref().map(rows).transpose()?,
            responses: rows(&rep.responses)?,
        })
    }
}

/// Output-error refinement of the start model (M, C, K) on reduced data: u, f
/// complex (s·p, m) rows (line-major, load cases inner), omega (s,), p load cases;
/// `weighting` how the columns count, `options` how the iteration runs.
/// `progress(iteration, cost)` is called about every 0.1 s; Ctrl-C or an exception
/// in it stops the iteration and propagates.
#[pyfunction]
#[pyo3(signature = (u, f, omega, p, start, weighting, options, *, progress = None, threads = 0))]
#[allow(clippy::too_many_arguments)] // one per Python argument
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
    weighting: &Bound<'py, PyAny>,
    options: &Bound<'py, PyRefineOptions>,
    progress: Option<Py<PyAny>>,
    threads: usize,
) -> PyResult<PyRefined> {
    let opts = options.get().to_rust()?;
    let arrays = WeightArrays::borrow(weighting)?;
    let m = u.shape()[1];
    let data = OeData {
        omega: omega.as_slice().map_err(not_contiguous)?,
        u: u.as_slice().map_err(not_contiguous)?,
        f: f.as_slice().map_err(not_contiguous)?,
        weights: arrays.weights()?,
        m,
        p,
    };
    let start = [
        mat_from_py(&start.0)?,
        mat_from_py(&start.1)?,
        mat_from_py(&start.2)?,
    ];
    let rep = run_iterative(py, threads, progress, |report| {
        // on a worker of the pool, not the calling thread: the matrix-free step's O(m³)
        // block work goes side by side there, where a parallel section is a push to the
        // worker's own deque, not an injection and a blocking wait (m = 60, 1200 lines:
        // 39.7 s from outside, 28.1 s from inside; `identify`'s CG measured slower from
        // inside, m = 400: 0.82–1.05 s against 0.74–0.80 s, so it stays where it was)
        rayon::scope(|_| refine::refine(data, &start, opts, Par::rayon(0), Some(report)))
    })?;
    PyRefined::new(py, &rep, m)
}

/// Add this area's functions and classes to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRefineOptions>()?;
    m.add_class::<PyColumnWeights>()?;
    m.add_class::<PyMatrixWeights>()?;
    m.add_class::<PyLogMagnitudeWeights>()?;
    m.add_class::<PyRefined>()?;
    m.add_function(wrap_pyfunction!(refine_output_error, m)?)?;
    Ok(())
}
