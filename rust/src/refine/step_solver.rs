//! The interface between the Levenberg–Marquardt iteration
//! ([`super::iteration`]) and the linear algebra of its Gauss–Newton steps: the
//! dense solver ([`super::dense`]) and the matrix-free one ([`super::matfree`]).

use super::objective::{Evaluation, Problem};
use super::parametrisation::Params;
use faer::{Mat, Par};

/// The linear algebra of one Gauss–Newton step. At the current point `prepare`
/// returns the gradient g = Jᵀr (J the Jacobian of the weighted residual r in θ);
/// `step` then solves (N + μ·diag(N)) δ = −g for a damping μ (N = JᵀJ; None if it
/// could not), and `quad` gives δᵀNδ for the model's predicted decrease.
pub(crate) trait StepSolver {
    fn prepare(
        &mut self,
        pb: &Problem,
        params: &Params,
        l: &[Mat<f64>; 3],
        ev: &Evaluation,
        par: Par,
    ) -> Vec<f64>;
    /// `cancelled` is polled during long solves; when it returns true the solver
    /// stops (its answer is then ignored).
    fn step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        cancelled: &mut dyn FnMut() -> bool,
    ) -> Option<Vec<f64>>;
    fn quad(&mut self, step: &[f64], par: Par) -> f64;
    /// Solve the damped system of the last `step` again for another right-hand side
    /// (None where the solver keeps no factor of it: the matrix-free one).
    fn solve_again(&mut self, _rhs: &[f64], _par: Par) -> Option<Vec<f64>> {
        None
    }
    /// The decrease of the cost the Gauss–Newton model predicts for `step`:
    /// −2gᵀδ − δᵀNδ (a solver that retracts its step gives its model's own).
    fn predicted(&mut self, g: &[f64], step: &[f64], par: Par) -> f64 {
        let gd: f64 = g.iter().zip(step).map(|(a, b)| a * b).sum();
        -2.0 * gd - self.quad(step, par)
    }
    /// Whether the next step uses the parametrisation's curvature ([`super::curvature`]).
    fn set_curvature(&mut self, on: bool);
    /// The LM damping μ of the first step (after the first `prepare`).
    fn initial_damping(&self) -> f64 {
        1e-3
    }
    /// Wall time of the solver's own parts, seconds (for the report).
    fn timings(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Counts of the solver's work (for the report).
    fn stats(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}
