//! podid_rs core: identification of reduced M, C, K from frequency-domain data
//! (Khalil, Adhikari & Sarkar 2007) without ever forming the Kronecker matrix A.
//!
//! Pipeline of plain Rust functions (each testable with `cargo test`):
//! - [`data`]: the measured columns (u_i, f_i, ω_i) and their scaling (DESIGN §3);
//! - [`gram`]: H = Re(V Vᴴ) and B = Re(F Vᴴ) (DESIGN §2);
//! - [`normal`]: the normal equations in each block's symmetric/skew basis;
//! - [`direct`]: in-place Cholesky with a rank-revealing fallback;
//! - [`identify`]: the whole solve, scaled in and out;
//! - [`cg`]: the matrix-free alternative for large m — preconditioned CG on the
//!   packed sym/skew coordinates of [`pairs`], preconditioned by [`precond`].
//!
//! The Python bindings live in `python.rs` behind the `python` feature.

pub mod cg;
pub mod data;
pub mod direct;
pub mod error;
pub mod gram;
pub mod identify;
pub mod joint;
pub mod normal;
pub mod pairs;
pub mod precond;

#[cfg(feature = "python")]
mod python;

pub use error::PodidError;

/// Run `f` on a rayon pool with `threads` workers (0 = all cores).
pub fn with_threads<T: Send>(
    threads: usize,
    f: impl FnOnce() -> T + Send,
) -> Result<T, PodidError> {
    if threads == 0 {
        return Ok(f());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| PodidError::Invalid(format!("could not start {threads} threads: {e}")))?;
    Ok(pool.install(f))
}
