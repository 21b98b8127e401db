//! Output-error refinement: the model that reproduces the measurement.
//!
//! The paper's estimator (eq. 49) minimises the *equation error* Σ‖D(ω_i)u_i − f_i‖²,
//! D = −ω²M + iωC + K. Here we minimise the *output error*
//!
//! ```text
//!     Σ_ij ‖T_ij (x_ij − u_ij)‖²,    x_ij = D(ω_i)⁻¹ f_ij   (the model's response)
//! ```
//!
//! over every line i and load case j, with a weight T_ij per column: a scalar w_ij
//! (relative, uniform, the user's) or a real m×m matrix (per-entry weights on the
//! measured DOFs, reduced by the caller). The matrices are parametrised by their
//! Cholesky factors, M = L_M L_Mᵀ + ε‖L_M‖² I, … (L lower triangular, ε = 1e-10),
//! so every model is symmetric with M, C, K ≻ 0 by construction; with the
//! `log_diagonal` option (default) the diagonals of the factors are exp(θ), which
//! makes M, C and K positive definite for every θ — and the model asymptotically
//! stable (every eigenvalue of the pencil has Re λ < 0).
//!
//! Levenberg–Marquardt with the analytic Jacobian: with v̂ = [−ω²x; iωx; x] and
//! δZ = [δM δC δK],
//!
//! ```text
//!     δx = −D⁻¹ (δZ v̂),     δX = δL Lᵀ + L δLᵀ.
//! ```
//!
//! One complex LU of D(ω_i) per line and evaluation, in parallel over lines.
//! In the entry coordinates of Z (row-major, index (r, c)) the Gauss–Newton matrix
//! is a sum of Kronecker products over the columns,
//!
//! ```text
//!     N_Z = Re Σ G ⊗ V̄,      G = Aᴴ A (m×m),  V̄ = conj(v̂) v̂ᵀ (3m×3m),  A = T D⁻¹,
//! ```
//!
//! formed by one real GEMM over all lines; the chain rule to the factors is a
//! congruence N_θ = Pᵀ N_Z P with the sparse tangent map P of δL ↦ δX. Everything is
//! done on scaled data (ω by its RMS, u and f by theirs).
//!
//! The step (N_θ + μ diag N_θ) δ = −g is solved densely (`dense.rs`: N_θ formed and
//! factored, (3m(m+1)/2)² doubles) or matrix-free (`matfree/`: preconditioned CG
//! with N_θ v applied line by line through the LU factors, O(s·m²) memory);
//! [`StepKind::Auto`] picks by m.

//!
//! The files, one job each:
//!
//! - `input`: the measured data and their weights, checked;
//! - `options`: the options, and which step solver ([`StepKind`]);
//! - `report`: what the refinement gives back;
//! - `parametrisation`: θ ↦ the Cholesky factors ↦ X = L Lᵀ + ε tr(L Lᵀ) I, the
//!   factor of a given matrix, the damping basis of the modal step;
//! - `objective`: the scaled problem and one evaluation of the output error;
//! - `line_solves`: solves with D(ω) of one line from its LU factors;
//! - `start`: the data's scaling and the start model made into factors;
//! - `iteration`: the Levenberg–Marquardt loop ([`refine`]);
//! - `step_solver`: what the loop asks of a step solver, `dense` and `matfree`
//!   the two solvers, with the pieces they share (`lines`: per-line Gram matrices,
//!   gradient and tangent map; `curvature`: the parametrisation's curvature;
//!   `modal`: the modal metric; `geodesic`: the dense step's geodesic acceleration).

mod curvature;
mod dense;
mod geodesic;
mod input;
mod iteration;
mod line_solves;
mod lines;
mod matfree;
mod modal;
mod objective;
mod options;
mod parametrisation;
mod report;
mod start;
mod step_solver;

pub use geodesic::{GEODESIC_ALPHA, GEODESIC_H};
pub use input::{LogTarget, OeData, Weights};
pub use iteration::{refine, CURVATURE_SWITCH, FTOL_WINDOW};
pub use options::{OeOptions, StepKind, AUTO_DENSE_MAX_M, MAX_CG_ITER};
pub use parametrisation::{n_per_block, psd_factor, CONDITION_FLOOR};
pub use report::{OeReport, Stop};
pub use start::{damping_floor, C_START_FLOOR};

#[cfg(test)]
mod tests;
