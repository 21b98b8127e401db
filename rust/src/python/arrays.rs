//! NumPy arrays in and out of the bindings: the measured columns borrowed from
//! C-contiguous arrays ([`columns`]), matrices both ways ([`mat_to_py`],
//! [`mat_from_py`]), and the name → value lists of the reports as dicts
//! ([`timings_dict`]).

use super::run::to_py;
use crate::data::Columns;
use faer::Mat;
use numpy::ndarray::Array2;
use numpy::{Complex64, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The error of an array that is not C-contiguous (the Python layer passes only
/// C-contiguous arrays: this is a misuse of `_core`).
pub(super) fn not_contiguous<E>(_: E) -> PyErr {
    PyValueError::new_err("arrays must be C-contiguous")
}

/// A faer matrix as a new NumPy array.
pub(super) fn mat_to_py(py: Python<'_>, a: &Mat<f64>) -> Py<PyArray2<f64>> {
    PyArray2::from_owned_array(
        py,
        Array2::from_shape_fn((a.nrows(), a.ncols()), |(i, j)| a[(i, j)]),
    )
    .unbind()
}

/// A C-contiguous NumPy matrix as a faer matrix.
pub(super) fn mat_from_py(a: &PyReadonlyArray2<'_, f64>) -> PyResult<Mat<f64>> {
    let sh = a.shape();
    let sl = a.as_slice().map_err(not_contiguous)?;
    Ok(Mat::from_fn(sh[0], sh[1], |i, j| sl[i * sh[1] + j]))
}

/// Borrow the validated columns (arrays are C-contiguous from the Python layer).
pub(super) fn columns<'a>(
    u: &'a PyReadonlyArray2<'_, Complex64>,
    f: &'a PyReadonlyArray2<'_, Complex64>,
    omega: &'a PyReadonlyArray1<'_, f64>,
) -> PyResult<Columns<'a>> {
    let (us, fs, ws) = (
        u.as_slice().map_err(not_contiguous)?,
        f.as_slice().map_err(not_contiguous)?,
        omega.as_slice().map_err(not_contiguous)?,
    );
    Columns::new(us, fs, ws, u.shape()[1]).map_err(to_py)
}

/// A report's (name, value) list as a dict, in its order.
pub(super) fn timings_dict(py: Python<'_>, timings: &[(&str, f64)]) -> PyResult<Py<PyDict>> {
    let t = PyDict::new(py);
    for (name, secs) in timings {
        t.set_item(*name, *secs)?;
    }
    Ok(t.unbind())
}
