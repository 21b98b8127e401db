//! What a solve of the identification problem gives back, shared by the direct
//! solver ([`crate::identify`]) and the matrix-free one ([`crate::cg`]): the
//! identified M, C, K with what the solver saw ([`Identified`], with the CG
//! iteration's [`CgReport`]), and the check both make of λ before they start.

use crate::data::Scaling;
use crate::direct::Method;
use crate::error::PodidError;
use faer::Mat;

/// Identified M, C, K with what the solver saw.
pub struct Identified {
    /// [M, C, K], each m×m, in the caller's units
    pub mck: [Mat<f64>; 3],
    pub method: Method,
    /// numerical rank of the normal matrix (= n_unknowns when well posed)
    pub rank: usize,
    pub n_unknowns: usize,
    pub min_pivot_ratio: f64,
    pub scaling: Scaling,
    /// wall time per phase, seconds (direct: gram, form, factor, residual, total;
    /// CG: gram, setup (basis: its share choosing Q), iterate, and within
    /// iterate gemm (the double-precision operator of the residual checks) and
    /// solves (the preconditioner's triangular solves), residual, total)
    pub timings: Vec<(&'static str, f64)>,
    /// iterations and final residual of the matrix-free solver (None for direct)
    pub cg: Option<CgReport>,
    /// the data misfit ‖Ax − y‖ of the answer (eq. 28, [`crate::residual`])
    pub residual_norm: f64,
}

/// What the matrix-free iteration achieved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgReport {
    pub iterations: usize,
    /// true relative residual ‖b − A x‖ / ‖b‖ of the returned answer (scaled problem)
    pub relative_residual: f64,
    pub converged: bool,
}

/// λ must be finite and non-negative.
pub(crate) fn check_lam(lam: [f64; 3]) -> Result<(), PodidError> {
    if lam.iter().all(|l| l.is_finite() && *l >= 0.0) {
        Ok(())
    } else {
        Err(PodidError::Invalid(format!(
            "lam must be finite and non-negative, got {lam:?}"
        )))
    }
}
