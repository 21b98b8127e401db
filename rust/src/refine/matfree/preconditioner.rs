//! The LM damping and the preconditioner of the matrix-free step's CG ([`Metric`]):
//! the modal metric, or μ·diag(N + H) with the inverted 3×3 M–C–K blocks of N + μD
//! ([`inverse3`]); and the few inner CG iterations ([`inner_solve`]) that precondition
//! by the modal metric when the parametrisation's curvature is in the step.

use crate::refine::modal::ModalMetric;

/// The LM damping and preconditioner of one step.
pub(crate) enum Metric {
    Modal(Box<ModalMetric>),
    /// μ·diag(N + H), and the inverted 3×3 blocks of N + μD
    Diagonal((Vec<f64>, Vec<[f64; 6]>)),
}

/// Inner iterations of the preconditioner with the curvature. Measured (chain,
/// m = 100, 2000 lines, whole refine): 3 / 8 / 16 / 32 / 64 → 934 s (max_iter) / 522 /
/// 293 / 215 / 241 s; the outer CG then never hits its cap (2 213 products at 32
/// against 11 415 at 8). m = 60, 1200 lines: 36.7 s at 8, 31.7 s at 32.
const INNER_CG: usize = 32;

/// About A⁻¹ r by INNER_CG preconditioned CG iterations (A = `apply`, preconditioner
/// `pre`), from 0.
pub(crate) fn inner_solve(
    r: &[f64],
    apply: impl Fn(&[f64]) -> Vec<f64>,
    pre: impl Fn(&[f64]) -> Vec<f64>,
) -> Vec<f64> {
    let mut x = vec![0.0; r.len()];
    let mut res = r.to_vec();
    let mut z = pre(&res);
    let mut d = z.clone();
    let mut rz = dot(&res, &z);
    for _ in 0..INNER_CG {
        let ad = apply(&d);
        let dad = dot(&d, &ad);
        if dad.is_nan() || rz.is_nan() || dad <= 0.0 || rz <= 0.0 {
            break;
        }
        let alpha = rz / dad;
        for q in 0..x.len() {
            x[q] += alpha * d[q];
            res[q] -= alpha * ad[q];
        }
        z = pre(&res);
        let rz2 = dot(&res, &z);
        let beta = rz2 / rz;
        rz = rz2;
        for q in 0..x.len() {
            d[q] = z[q] + beta * d[q];
        }
    }
    x
}

/// Inverse of a symmetric positive definite 3×3 matrix (upper triangle of `a`) as
/// [00, 11, 22, 01, 02, 12], by Cholesky; None when it is not numerically positive.
pub(crate) fn inverse3(a: [[f64; 3]; 3]) -> Option<[f64; 6]> {
    let l00 = a[0][0].sqrt();
    let l10 = a[0][1] / l00;
    let l20 = a[0][2] / l00;
    let d1 = a[1][1] - l10 * l10;
    if l00.is_nan() || l00 <= 0.0 || d1.is_nan() || d1 <= 1e-12 * a[1][1] {
        return None;
    }
    let l11 = d1.sqrt();
    let l21 = (a[1][2] - l20 * l10) / l11;
    let d2 = a[2][2] - l20 * l20 - l21 * l21;
    if d2.is_nan() || d2 <= 1e-12 * a[2][2] {
        return None;
    }
    let l22 = d2.sqrt();
    // L⁻¹ (lower), then A⁻¹ = L⁻ᵀ L⁻¹
    let i00 = 1.0 / l00;
    let i11 = 1.0 / l11;
    let i22 = 1.0 / l22;
    let i10 = -l10 * i00 / l11;
    let i21 = -l21 * i11 / l22;
    let i20 = -(l20 * i00 + l21 * i10) / l22;
    Some([
        i00 * i00 + i10 * i10 + i20 * i20,
        i11 * i11 + i21 * i21,
        i22 * i22,
        i10 * i11 + i20 * i21,
        i20 * i22,
        i21 * i22,
    ])
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
