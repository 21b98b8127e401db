//! The data misfit ‖Ax − y‖ of eq. 28 for identified M, C, K: the norm of
//! (−ω_i² M + iω_i C + K) u_i − f_i over all N columns.
//!
//! Computed from the per-line products, never from the Gram expansion
//! xᵀHx − 2bᵀx + ‖y‖², which cancels when the residual is small (docs/design.md §3).
//! The lines are taken in chunks; each chunk stacks its scaled data
//! [Re U; Im U] and does one GEMM with [X̃_Mᵀ X̃_Cᵀ X̃_Kᵀ] (2N·m·3m·2 flops in
//! all), in parallel over chunks. In scaled units (ω̃ = ω/ω0, Ũ = U/s_u,
//! F̃ = F/s_f, X_b = c_b X̃_b) every line's residual is s_f times
//! −ω̃² X̃_M ũ + iω̃ X̃_C ũ + X̃_K ũ − f̃, all O(1): the sum of squares cannot
//! overflow.

use crate::data::{Columns, Scaling};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Lines per chunk: fixed, so the sum does not depend on the number of threads.
const LINES: usize = 64;

/// ‖Ax − y‖ for the scaled answer `z` = [X̃_M X̃_C X̃_K] (m×3m) of the scaled problem.
pub fn residual_norm(cols: &Columns, scaling: &Scaling, z: MatRef<f64>) -> f64 {
    let mut xt = Mat::zeros(cols.m, 3 * cols.m);
    residual_norm_with(cols, scaling, z, xt.as_mut())
}

/// [`residual_norm`] with `xt` (m×3m, any values) as scratch.
pub fn residual_norm_with(
    cols: &Columns,
    scaling: &Scaling,
    z: MatRef<f64>,
    mut xt: MatMut<f64>,
) -> f64 {
    let (n, m) = (cols.len(), cols.m);
    // xt[:, b·m + i] = row i of X̃_b: P = Ũ·xt holds the products X̃_b ũ as rows
    assert!(xt.nrows() == m && xt.ncols() == 3 * m);
    for c in 0..3 * m {
        for j in 0..m {
            xt[(j, c)] = z[(c % m, (c / m) * m + j)];
        }
    }
    let xt = xt.as_ref();
    let (iu, iff, iw) = (1.0 / scaling.su, 1.0 / scaling.sf, 1.0 / scaling.omega0);
    let parts: Vec<f64> = (0..n.div_ceil(LINES))
        .into_par_iter()
        .map(|chunk| {
            let lo = chunk * LINES;
            let len = LINES.min(n - lo);
            let y = Mat::from_fn(2 * len, m, |r, c| {
                let v = cols.u[(lo + r % len) * m + c];
                iu * if r < len { v.re } else { v.im }
            });
            let mut p = Mat::zeros(2 * len, 3 * m);
            matmul(p.as_mut(), Accum::Replace, y.as_ref(), xt, 1.0, Par::Seq);
            let mut sum = 0.0;
            for l in 0..len {
                let w = cols.omega[lo + l] * iw;
                let w2 = w * w;
                let f = &cols.f[(lo + l) * m..(lo + l + 1) * m];
                for (i, fi) in f.iter().enumerate() {
                    // (re, im) of −ω̃² X̃_M ũ + iω̃ X̃_C ũ + X̃_K ũ − f̃
                    let (pm, pc, pk) = (i, m + i, 2 * m + i);
                    let re = -w2 * p[(l, pm)] - w * p[(len + l, pc)] + p[(l, pk)] - iff * fi.re;
                    let im =
                        -w2 * p[(len + l, pm)] + w * p[(l, pc)] + p[(len + l, pk)] - iff * fi.im;
                    sum += re * re + im * im;
                }
            }
            sum
        })
        .collect();
    scaling.sf * parts.iter().sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::tests::{data, truth};
    use faer::c64;

    /// Against the literal sum over lines, on a model that does not fit the data.
    #[test]
    fn matches_the_literal_misfit() {
        let m = 5;
        let t = truth(m);
        let omegas: Vec<f64> = (0..2 * LINES + 7).map(|i| 1.0 + 0.37 * i as f64).collect();
        let (u, f, w) = data(&t, &omegas);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        let sc = Scaling::of(&cols);
        // a model off the truth, in the caller's units, and its scaled form
        let x: [Mat<f64>; 3] = [0, 1, 2].map(|b| {
            Mat::from_fn(m, m, |i, j| {
                t[b][(i, j)] * (1.0 + 0.01 * ((i * 3 + j * 5 + b) % 7) as f64)
            })
        });
        let c = sc.block_factors();
        let z = Mat::from_fn(m, 3 * m, |i, col| x[col / m][(i, col % m)] / c[col / m]);
        let mut want = 0.0;
        for (l, w) in w.iter().enumerate() {
            for i in 0..m {
                let mut r = -f[l * m + i];
                for j in 0..m {
                    let d = c64::new(-w * w * x[0][(i, j)] + x[2][(i, j)], w * x[1][(i, j)]);
                    r += d * u[l * m + j];
                }
                want += r.norm_sqr();
            }
        }
        let got = residual_norm(&cols, &sc, z.as_ref());
        let want = want.sqrt();
        assert!(want > 1e-3, "the model must not fit: {want}");
        assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
    }
}
