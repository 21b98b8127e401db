//! Running the numerics from Python: without the GIL, on a given number of threads,
//! with a Rust error mapped to its Python exception ([`to_py`]) and a Rust panic to a
//! RuntimeError, never a PanicException ([`run`]); an iterative job on a worker
//! thread while Python's thread watches for Ctrl-C and reports progress
//! ([`run_iterative`]).

use crate::error::PodidError;
use crate::{with_threads, Progress};
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::ops::ControlFlow;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Duration;

/// The Python exception of a Rust error.
pub(super) fn to_py(e: PodidError) -> PyErr {
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
pub(super) fn run<T: Send>(
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
pub(super) fn run_iterative<T: Send>(
    py: Python<'_>,
    threads: usize,
    progress: Option<Py<PyAny>>,
    job: impl FnOnce(Progress) -> Result<T, PodidError> + Send,
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
