//! Symmetric Gauss–Seidel over entry pairs: the preconditioner of the matrix-free
//! solver (docs/design.md §4), applied with Eisenstat's trick by [`crate::cg`].
//!
//! In the Q basis of [`crate::precond`] the normal operator splits as
//! G = D + L + Lᵀ: D the pair blocks of [`crate::precond::PairPrecond`] (3×3 per
//! diagonal entry, 3×3 or 6×6 per pair (j, k)), L the couplings of each pair to the pairs before
//! it in column-major pair order (larger index k first, then j). Every coupling
//! outside D comes from the row operator Z ↦ Z H̃ with the mode-diagonal 3×3
//! blocks of H̃ removed; written on the entry matrix Y (Y_ic ∈ ℝ³, one value per
//! block) it is
//!
//! ```text
//!   (L Y)_ic = Σ_{l<c} Y_il H̃(l, c)        (H̃(l, c) the 3×3 block of modes l, c)
//! ```
//!
//! i.e. the strictly block-upper part U of H̃ (in mode-major order) acting from
//! the right, Y ↦ Y U; the entry (i, c) and its mirror (c, i) meet only in D.
//! The penalty, which can exceed the data by 10¹⁵, lives in D alone, and D is
//! solved in the sym/skew coordinates (σ, τ), so it never touches the entries.
//!
//! The triangular solve (D + L) y = r is a triangular Lyapunov/Sylvester
//! equation; it is done recursively (RECSY style): split the modes in halves
//! a|b, solve the a×a part, update the accumulated lower terms of what depends on
//! it by one GEMM, solve the a×b and b×a entries (a triangular Sylvester problem,
//! split the same way), update, solve b×b. All couplings across halves are
//! GEMMs in single precision (H̃ in f32, ≈ 9m³ flops per solve: half an operator
//! GEMM); only those within leaves of [`LEAF`] modes are done entry by entry.
//! The solve (D + Lᵀ) is the same recursion in reverse mode order. The two
//! threads share the work as rayon tasks only: independent Sylvester quarters,
//! and large GEMMs cut in halves (each piece on one thread). Each leaf asks for
//! the data of the next one in the sequential order before it computes.
//!
//! The entries are kept in a 3m×m matrix, column i holding row i of Y in
//! mode-major order (Y_il[b] at row 3l + b), so that both the GEMMs and the
//! dot products of the leaves read contiguous memory.
//!
//! The files: `couplings` holds H̃ in single precision ([`Sgs`]), `solve` the state
//! of one solve, `recursion` the recursive triangular solve, `leaf` its leaves.

mod couplings;
mod leaf;
mod recursion;
mod solve;

pub use couplings::{Sgs, SgsWork, LEAF};
pub use solve::Ends;

#[cfg(test)]
mod tests;
