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

/// Allocate a zeroed vector of `len` doubles, or a clear error instead of an abort.
///
/// Uses `alloc_zeroed`, so the pages of a large matrix are not touched twice.
pub fn try_zeroed(len: usize, what: &str) -> Result<Vec<f64>, PodidError> {
    let oom = || PodidError::OutOfMemory {
        bytes: len as u128 * 8,
        what: what.to_string(),
    };
    if len == 0 {
        return Ok(Vec::new());
    }
    let layout = std::alloc::Layout::array::<f64>(len).map_err(|_| oom())?;
    // SAFETY: the layout has non-zero size; a null pointer is handled; the
    // pointer comes from the global allocator with exactly the layout that
    // `Vec<f64>` with capacity `len` uses, and all-zero bytes are valid f64s.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout) as *mut f64;
        if ptr.is_null() {
            return Err(oom());
        }
        Ok(Vec::from_raw_parts(ptr, len, len))
    }
}
