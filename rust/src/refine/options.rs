//! How the refinement runs ([`OeOptions`]) and how each Gauss–Newton step is solved
//! ([`StepKind`]: dense or matrix-free, and the automatic choice between them).

use crate::error::PodidError;

/// Options of the Levenberg–Marquardt iteration.
#[derive(Clone, Copy, Debug)]
pub struct OeOptions {
    /// most Gauss–Newton steps (accepted or not)
    pub max_iter: usize,
    /// converged when the last [`super::FTOL_WINDOW`] accepted steps together lowered the cost
    /// by less than `FTOL_WINDOW · ftol` relative: a slow drift along a flat valley
    /// (a direction of the model the data hardly see) is not worth the time
    pub ftol: f64,
    /// converged when ‖δθ‖ ≤ xtol·(‖θ‖ + xtol)
    pub xtol: f64,
    /// diagonals of the factors as exp(θ): M, C, K positive definite for every θ
    pub log_diagonal: bool,
    /// how each Gauss–Newton step is solved
    pub solver: StepKind,
    /// add the curvature of the parametrisation X = L Lᵀ to the Gauss–Newton matrix
    /// ([`super::curvature`], [`super::CURVATURE_SWITCH`]): far better minima on measured data, whose
    /// optimum puts C on the cone's boundary; off by default — on noise-free data from
    /// a start a few per cent off it can take more steps than Gauss–Newton alone
    pub curvature: bool,
    /// matrix-free step only: damp and precondition by the modal metric and take the
    /// Gauss–Newton step in X ([`super::modal`]) instead of μ·diag N_θ and its 3×3 blocks
    pub modal_metric: bool,
    /// dense step only: add the geodesic acceleration to each step ([`super::geodesic`])
    pub acceleration: bool,
}

impl Default for OeOptions {
    fn default() -> Self {
        OeOptions {
            max_iter: 200,
            ftol: 1e-7,
            xtol: 1e-12,
            log_diagonal: true,
            solver: StepKind::Auto,
            curvature: false,
            modal_metric: false,
            acceleration: false,
        }
    }
}

/// The linear algebra of a Gauss–Newton step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// N_θ formed and factored: (3m(m+1)/2)² doubles, O(s·m⁴ + m⁶) flops per step
    Dense,
    /// preconditioned CG with N v applied line by line: O(s·m²) memory
    MatrixFree,
    /// dense while N_θ is small (see [`StepKind::resolve`]), matrix-free beyond
    Auto,
}

impl StepKind {
    /// The names the Python API uses: "dense", "matrix-free", "auto".
    pub fn from_name(name: &str) -> Result<StepKind, PodidError> {
        match name {
            "dense" => Ok(StepKind::Dense),
            "matrix-free" => Ok(StepKind::MatrixFree),
            "auto" => Ok(StepKind::Auto),
            _ => Err(PodidError::Invalid(format!(
                "solver must be 'dense', 'matrix-free' or 'auto', got {name:?}"
            ))),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            StepKind::Dense => "dense",
            StepKind::MatrixFree => "matrix-free",
            StepKind::Auto => "auto",
        }
    }

    /// Dense or matrix-free for order m on s lines with `terms` Gram terms per line.
    pub fn resolve(&self, m: usize, _s: usize, _terms: usize) -> StepKind {
        match self {
            StepKind::Auto => {
                if m <= AUTO_DENSE_MAX_M {
                    StepKind::Dense
                } else {
                    StepKind::MatrixFree
                }
            }
            k => *k,
        }
    }
}

/// Largest order the automatic choice solves densely. Measured
/// (`benches/bench_refine.py --crossover`, s = 800, chain with 0.1 % noise): the dense
/// step is 8×, 22×, 16× faster per converged fit at m = 10, 20, 30 and 2.6× at m = 40,
/// where one step costs the same either way (1.2–1.3 s) but the matrix-free CG steps
/// are inexact and LM needs about 3× as many. The dense step grows as ~m⁶ per step
/// (0.21 s at m = 30, 1.26 s at m = 40), the matrix-free one as ~m²·(CG products);
/// above m = 40 the matrix-free step is chosen, with O(s·m²) memory. With the modal
/// metric (Python's default for a matrix-free step) the chain's crossover moved to
/// between m = 10 and 20 (m = 30: 1.18 s against 5.25 s), but on the measured beam (m ≤ 30, with
/// curvature) that step fitted worse and slower, so the rule stays (benches/README.md,
/// `bench_refine.py`).
pub const AUTO_DENSE_MAX_M: usize = 40;

/// Most CG iterations of one matrix-free step.
pub const MAX_CG_ITER: usize = 100;
