//! Errors of the core, mapped to Python exceptions by the bindings.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum PodidError {
    /// Bad input: shapes, values, a problem that cannot be posed (→ ValueError).
    Invalid(String),
    /// The dense system would not fit in memory (→ MemoryError).
    OutOfMemory { bytes: u128, what: String },
    /// The caller's progress callback asked to stop (e.g. Ctrl-C).
    Interrupted,
}

impl fmt::Display for PodidError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PodidError::Invalid(msg) => write!(f, "{msg}"),
            PodidError::OutOfMemory { bytes, what } => write!(
                f,
                "{what} needs {:.2} GB, which could not be allocated",
                *bytes as f64 / 1e9
            ),
            PodidError::Interrupted => write!(f, "interrupted"),
        }
    }
}

impl std::error::Error for PodidError {}
