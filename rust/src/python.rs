//! Thin PyO3 bindings over the plain Rust functions. Arrays arrive validated and
//! C-contiguous from `podid_rs.identification`; the GIL is released during the
//! numerics; a Rust panic becomes a RuntimeError, never a PanicException.

use crate::data::{Columns, Scaling, Stacked};
use crate::error::PodidError;
use crate::{identify, with_threads};
use faer::{Mat, Par};
use numpy::ndarray::Array2;
use numpy::{Complex64, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::panic::{catch_unwind, AssertUnwindSafe};

fn to_py(e: PodidError) -> PyErr {
    match e {
        PodidError::Invalid(msg) => PyValueError::new_err(msg),
        e @ PodidError::OutOfMemory { .. } => PyMemoryError::new_err(e.to_string()),
    }
}

/// Run the numerics without the GIL, on `threads` threads, turning panics into errors.
fn run<T: Send>(
    py: Python<'_>,
    threads: usize,
    f: impl FnOnce() -> Result<T, PodidError> + Send,
) -> PyResult<T> {
    let out = py.detach(|| catch_unwind(AssertUnwindSafe(|| with_threads(threads, f))));
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
    let t = PyDict::new(py);
    for (name, secs) in &id.timings {
        t.set_item(*name, *secs)?;
    }
    d.set_item("timings", t)?;
    Ok(d)
}

/// Bytes of the largest dense matrix the direct path would allocate.
#[pyfunction]
fn direct_memory_bytes(m: usize, lam: (f64, f64, f64), symmetric: bool) -> u128 {
    identify::dense_bytes(m, [lam.0, lam.1, lam.2], symmetric)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(py_gram, m)?)?;
    m.add_function(wrap_pyfunction!(identify_direct, m)?)?;
    m.add_function(wrap_pyfunction!(direct_memory_bytes, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
