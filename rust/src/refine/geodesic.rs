//! Geodesic acceleration of the Levenberg–Marquardt step (Transtrum & Sethna,
//! "Improvements to the Levenberg–Marquardt algorithm for nonlinear least-squares
//! minimization", 2012).
//!
//! The damped Gauss–Newton step v is the first-order move along the residual's
//! manifold; where the cost's valley is narrow and curved (the out-of-band modes of a
//! long band, whose individual poles the data hardly tell apart) that straight step
//! leaves the valley unless it is short, and LM is held to a crawl with many
//! rejected steps. The second-order correction — the acceleration
//!
//! ```text
//!     a = −(N + μ diag N)⁻¹ Jᵀ r_vv,    r_vv = ∂²r/∂t² along θ + t v,
//! ```
//!
//! with the same damped matrix, already factored — bends the step along the valley:
//! the step taken is v + a/2. r_vv comes from two more evaluations of the model,
//! (r(θ + hv) − 2r(θ) + r(θ − hv))/h², and Jᵀ r_vv from the gradient's own formula
//! ([`super::lines::jt_of_responses`]). A step whose acceleration is large against
//! its velocity (2‖a‖ > α‖v‖) has left the region where the expansion holds: it is
//! rejected and damped more. Measured on the shared beam (m = 35, 50–300 Hz, the final
//! fit's complex pass): the cost after 300 steps 0.776 → 0.673, the level plain LM
//! reaches after about 720 steps (docs/design.md, the refinement's step).

use faer::c64;

/// h of the central second difference along the step (a fraction of the step).
pub const GEODESIC_H: f64 = 0.1;

/// Largest 2‖a‖/‖v‖ accepted (Transtrum & Sethna's α).
pub const GEODESIC_ALPHA: f64 = 0.75;

/// (x₊ − 2x₀ + x₋)/h²: the second directional derivative of the responses by central
/// differences (exact for a quadratic).
pub(crate) fn second_difference(plus: &[c64], at: &[c64], minus: &[c64], h: f64) -> Vec<c64> {
    plus.iter()
        .zip(at)
        .zip(minus)
        .map(|((p, x), q)| (p + q - x * 2.0) / (h * h))
        .collect()
}

/// The step v + a/2, or None when 2‖a‖ > [`GEODESIC_ALPHA`]·‖v‖.
pub(crate) fn accelerated_step(v: &[f64], a: &[f64]) -> Option<Vec<f64>> {
    let norm = |x: &[f64]| x.iter().map(|t| t * t).sum::<f64>().sqrt();
    if 2.0 * norm(a) > GEODESIC_ALPHA * norm(v) {
        return None;
    }
    Some(v.iter().zip(a).map(|(x, y)| x + 0.5 * y).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_second_difference_is_exact_for_a_quadratic() {
        // x(t) = c0 + c1 t + c2 t², second derivative 2 c2 at every t
        let (c0, c1, c2) = (
            c64::new(1.0, -2.0),
            c64::new(0.5, 3.0),
            c64::new(-4.0, 0.25),
        );
        let h = 0.1;
        let x = |t: f64| c0 + c1 * t + c2 * (t * t);
        let d = second_difference(&[x(0.3 + h)], &[x(0.3)], &[x(0.3 - h)], h);
        assert!((d[0] - c2 * 2.0).norm() < 1e-10 * c2.norm());
    }

    #[test]
    fn an_acceleration_past_alpha_rejects_the_step() {
        let v = [3.0, 4.0]; // ‖v‖ = 5
        let just_in = [0.5 * GEODESIC_ALPHA * 5.0 * 0.999, 0.0];
        let just_out = [0.5 * GEODESIC_ALPHA * 5.0 * 1.001, 0.0];
        let step = accelerated_step(&v, &just_in).unwrap();
        assert_eq!(step, vec![3.0 + 0.5 * just_in[0], 4.0]);
        assert!(accelerated_step(&v, &just_out).is_none());
    }
}
