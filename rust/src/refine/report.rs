//! What the refinement gives back: the refined model, the costs and steps, and why
//! the iteration stopped ([`OeReport`], [`Stop`]).

use crate::data::Scaling;
use faer::{c64, Mat};

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// relative cost decrease over the last accepted steps below ftol
    CostConverged,
    /// step below xtol
    StepConverged,
    /// the gradient vanished (an exact fit)
    GradientZero,
    /// no step lowered the cost even with the damping at its ceiling
    NoDescent,
    /// max_iter reached
    MaxIter,
}

impl Stop {
    pub fn name(&self) -> &'static str {
        match self {
            Stop::CostConverged => "cost converged",
            Stop::StepConverged => "step converged",
            Stop::GradientZero => "gradient zero",
            Stop::NoDescent => "no further descent",
            Stop::MaxIter => "max_iter reached",
        }
    }

    pub fn converged(&self) -> bool {
        !matches!(self, Stop::MaxIter)
    }
}

/// The refined model and what the iteration did.
pub struct OeReport {
    /// [M, C, K] in the caller's units
    pub mck: [Mat<f64>; 3],
    /// cost Σ‖T(x − u)‖² of the start and of the answer, caller's units
    pub cost_start: f64,
    pub cost: f64,
    /// Gauss–Newton steps taken (accepted or rejected) and accepted
    pub iterations: usize,
    pub accepted: usize,
    pub stop: Stop,
    /// (iteration, cost) after every accepted step, caller's units
    pub history: Vec<(usize, f64)>,
    pub scaling: Scaling,
    /// wall time per phase, seconds: evaluate, normal, solve, total, and the step
    /// solver's own parts
    pub timings: Vec<(&'static str, f64)>,
    /// the step solver used ("dense" or "matrix-free") and its counts
    pub solver: &'static str,
    pub solver_stats: Vec<(&'static str, f64)>,
    /// model responses D(ω)⁻¹ f of the start as given and of the answer, caller's
    /// units, in the layout of the data (column after column); the start's is None
    /// when it has a pole on a measured line
    pub responses_start: Option<Vec<c64>>,
    pub responses: Vec<c64>,
}
