//! The compiled module `podid_rs._core`: thin PyO3 bindings over the plain Rust
//! functions, one file per area — `identify` (the direct and the matrix-free solve at a
//! fixed λ, their memory, the Gram products), `sweep` (the λ sweep) and `refine` (the
//! output-error refinement) —, with `run` (running the numerics: the GIL released,
//! errors mapped, panics caught, Ctrl-C) and `arrays` (NumPy in and out) under them.
//!
//! How the module looks from Python:
//!
//! - arrays arrive validated and C-contiguous from the package (`podid_rs.identification`);
//!   a non-contiguous one is a ValueError;
//! - results are classes with read-only attributes (`Identified`, `LambdaCurvePoints`,
//!   `Refined`: frozen, one attribute per field), never dicts read back by key;
//! - the refinement takes its options as a `RefineOptions` built with keywords and its
//!   weighting as one of `ColumnWeights`, `MatrixWeights`, `LogMagnitudeWeights`
//!   (see the `refine` file);
//! - how a call runs — `progress` (a callable, polled about every 0.1 s) and `threads`
//!   (0: all cores) — is keyword-only;
//! - a Rust error is a ValueError, MemoryError or KeyboardInterrupt, a Rust panic a
//!   RuntimeError (never a PanicException), and Ctrl-C stops an iterative solve.
//!
//! `python/podid_rs/_core.pyi` describes every name, attribute and argument of the
//! module; `tests/test_core_stub.py` fails when the two drift apart.

mod arrays;
mod identify;
mod refine;
mod run;
mod sweep;

use pyo3::prelude::*;

/// The Rust core of podid_rs: identification at a fixed λ, the λ sweep and the
/// output-error refinement (described by the stub `_core.pyi`).
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    identify::register(m)?;
    sweep::register(m)?;
    refine::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
