//! podid_rs core: identification of reduced M, C, K from frequency-domain data
//! (Khalil, Adhikari & Sarkar 2007) without ever forming the Kronecker matrix A.
//!
//! Pipeline of plain Rust functions (each testable with `cargo test`):
//! - [`data`]: the measured columns (u_i, f_i, ω_i) and their scaling (docs/design.md §3);
//! - [`gram`]: H = Re(V Vᴴ) and B = Re(F Vᴴ) (docs/design.md §2);
//! - [`normal`]: the normal equations in each block's symmetric/skew basis;
//! - [`direct`]: in-place Cholesky with a rank-revealing fallback;
//! - [`identify`]: the whole solve, scaled in and out;
//! - [`solution`]: what both solvers give back ([`solution::Identified`]);
//! - [`sweep`]: the λ-curves (L-curve, GCV, discrepancy) from one eigendecomposition;
//! - [`tridiag`]: two-stage symmetric tridiagonalisation (for the sweep);
//! - [`cg`]: the matrix-free alternative for large m — preconditioned CG on the
//!   packed sym/skew coordinates of [`pairs`], preconditioned by symmetric
//!   Gauss–Seidel ([`sgs`]) over the pair blocks of [`precond`].
//!
//! The Python bindings live in `python/` behind the `python` feature.

pub mod buffer;
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
pub mod random;
pub mod refine;
pub mod residual;
pub mod sgs;
pub mod solution;
pub mod sweep;
pub mod tridiag;

#[cfg(feature = "python")]
mod python;

pub use error::PodidError;

/// The progress callback of the iterative solvers (CG, the refinement): called with
/// (iteration, the solver's measure of progress — CG's recursively updated relative
/// residual, the refinement's cost); returning `Break` stops the solve with
/// [`PodidError::Interrupted`].
pub type Progress<'a> = &'a mut (dyn FnMut(usize, f64) -> std::ops::ControlFlow<()> + Send);

/// Most worker threads a caller may ask for: beyond this a count is a mistake.
pub const MAX_THREADS: usize = 1024;

/// Run `f` on a rayon pool with `threads` workers (0 = the global pool, all cores).
///
/// Pools are built once per thread count and kept, so repeated calls do not
/// start and abandon threads.
pub fn with_threads<T: Send>(
    threads: usize,
    f: impl FnOnce() -> T + Send,
) -> Result<T, PodidError> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();

    if threads == 0 {
        return Ok(f());
    }
    if threads > MAX_THREADS {
        return Err(PodidError::Invalid(format!(
            "threads must be at most {MAX_THREADS}, got {threads}"
        )));
    }
    let pool = {
        let mut pools = POOLS
            .get_or_init(Default::default)
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        match pools.get(&threads) {
            Some(p) => p.clone(),
            None => {
                let p = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .map_err(|e| {
                        PodidError::Invalid(format!("could not start {threads} threads: {e}"))
                    })?;
                let p = Arc::new(p);
                pools.insert(threads, p.clone());
                p
            }
        }
    };
    Ok(pool.install(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_pools_are_bounded_and_reused() {
        assert_eq!(with_threads(2, rayon::current_num_threads).unwrap(), 2);
        assert_eq!(with_threads(3, rayon::current_num_threads).unwrap(), 3);
        assert!(with_threads(MAX_THREADS + 1, || ()).is_err());
        let ids: Vec<_> = (0..2)
            .map(|_| with_threads(2, || std::thread::current().id()).unwrap())
            .collect();
        // both calls ran on a worker of the same pool (2 threads), not a fresh one each time
        assert!(ids.iter().all(|id| *id != std::thread::current().id()));
    }
}
