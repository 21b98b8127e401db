//! Bindings of the λ sweep: [`lambda_sweep`] factors once and returns a
//! [`PyLambdaSweep`], whose `curve` gives the λ-curves at many λ
//! ([`PyLambdaCurvePoints`]) and `solve` the model at one.

use super::arrays::{columns, mat_to_py, timings_dict};
use super::run::run;
use crate::sweep::{sweep_bytes, Point, Sweep};
use faer::Par;
use numpy::{Complex64, IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The λ-curves of one common symmetry weight from one eigendecomposition
/// (the Rust [`Sweep`]). Built by `lambda_sweep`; holds n_w² doubles.
#[pyclass(name = "LambdaSweep", module = "podid_rs._core", frozen)]
pub(super) struct PyLambdaSweep {
    inner: Sweep,
}

/// The λ-curves at each λ asked for, one array per quantity (the Rust [`Point`]s).
#[pyclass(name = "LambdaCurvePoints", module = "podid_rs._core", frozen, get_all)]
pub(super) struct PyLambdaCurvePoints {
    /// ‖Ax − y‖ (eq. 28)
    residual_norm: Py<PyArray1<f64>>,
    /// ‖Lx‖, the symmetry penalty (eq. 30)
    penalty_norm: Py<PyArray1<f64>>,
    /// tr(A G(λ)⁻¹ Aᵀ): the effective number of parameters
    trace: Py<PyArray1<f64>>,
    /// the generalised cross-validation function (eq. 34)
    gcv: Py<PyArray1<f64>>,
    /// signed curvature of the L-curve (natural-log axes)
    curvature: Py<PyArray1<f64>>,
}

impl PyLambdaCurvePoints {
    fn new(py: Python<'_>, pts: &[Point]) -> PyLambdaCurvePoints {
        let field = |get: fn(&Point) -> f64| {
            pts.iter()
                .map(get)
                .collect::<Vec<_>>()
                .into_pyarray(py)
                .unbind()
        };
        PyLambdaCurvePoints {
            residual_norm: field(|p| p.residual),
            penalty_norm: field(|p| p.penalty),
            trace: field(|p| p.trace),
            gcv: field(|p| p.gcv),
            curvature: field(|p| p.curvature),
        }
    }
}

type MatTriple = (Py<PyArray2<f64>>, Py<PyArray2<f64>>, Py<PyArray2<f64>>);

#[pymethods]
impl PyLambdaSweep {
    /// The order m.
    #[getter]
    fn m(&self) -> usize {
        self.inner.m()
    }

    /// Real equations 2·N·m of the stacked problem.
    #[getter]
    fn n_rows(&self) -> usize {
        self.inner.n_rows()
    }

    /// Unknowns 3m².
    #[getter]
    fn n_unknowns(&self) -> usize {
        self.inner.n_unknowns()
    }

    /// ν_i (1/λ² units): skew direction i is damped by 1/(1 + λ²ν_i).
    #[getter]
    fn eigenvalues<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.eigenvalues().to_vec().into_pyarray(py)
    }

    /// min L_ii²/H_ii of the Cholesky factor of H (≈ 1/cond(H) up to a modest factor).
    #[getter]
    fn min_pivot_ratio(&self) -> f64 {
        self.inner.min_pivot_ratio()
    }

    /// (ω0, s_u, s_f): the scales of frequency, responses and forces.
    #[getter]
    fn scaling(&self) -> (f64, f64, f64) {
        let s = self.inner.scaling();
        (s.omega0, s.su, s.sf)
    }

    /// Wall time per phase of the factorisation, seconds.
    #[getter]
    fn timings(&self, py: Python<'_>) -> PyResult<Py<PyDict>> {
        timings_dict(py, self.inner.timings())
    }

    /// The λ-curves at each λ of `lams` (paper units): `exact` refines residual and
    /// penalty by solves (O(n_w²) per λ), otherwise all come from the spectrum
    /// (O(n_w) per λ, ~1e-8 relative).
    #[pyo3(signature = (lams, *, exact = false, threads = 0))]
    fn curve(
        &self,
        py: Python<'_>,
        lams: PyReadonlyArray1<'_, f64>,
        exact: bool,
        threads: usize,
    ) -> PyResult<PyLambdaCurvePoints> {
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
        Ok(PyLambdaCurvePoints::new(py, &pts))
    }

    /// (M, C, K) at λ (paper units).
    #[pyo3(signature = (lam, *, threads = 0))]
    fn solve(&self, py: Python<'_>, lam: f64, threads: usize) -> PyResult<MatTriple> {
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

/// Factor once for the λ-curves; None when H is not positive definite (the
/// unregularised problem is rank deficient: sweep with repeated solves instead).
#[pyfunction]
#[pyo3(signature = (u, f, omega, *, threads = 0))]
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
    sweep_bytes(m)
}

/// Add this area's functions and classes to the module.
pub(super) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyLambdaSweep>()?;
    m.add_class::<PyLambdaCurvePoints>()?;
    m.add_function(wrap_pyfunction!(lambda_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_memory_bytes, m)?)?;
    Ok(())
}
