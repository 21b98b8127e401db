//! The Gram products of DESIGN §2: H = Re(V Vᴴ) (3m×3m) and B = Re(F Vᴴ) (m×3m),
//! with v_i = [−ω_i² u_i; iω_i u_i; u_i]. The whole least-squares data term is
//! tr(Z H Zᵀ) − 2 tr(Z Bᵀ) + ‖F‖² for Z = [M C K].
//!
//! With R = Σ Re(u uᴴ)-type sums S_k = Σ ω^k Re(u_i u_iᴴ) and T_k = Σ ω^k Im(u_i u_iᴴ):
//!
//! ```text
//!     H = [  S4  −T3  −S2 ]        B = [ −Σω² Re(f uᴴ),  Σω Im(f uᴴ),  Σ Re(f uᴴ) ]
//!         [  T3   S2  −T1 ]
//!         [ −S2   T1   S0 ]
//! ```
//!
//! Every sum is one real GEMM on the stacked data [Re U; Im U].

use crate::data::Stacked;
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, MatRef, Par};

/// H (3m×3m, symmetric positive semidefinite) and B (m×3m).
pub struct Gram {
    pub h: Mat<f64>,
    pub b: Mat<f64>,
}

/// aᵀ·b, parallel.
fn atb(a: MatRef<f64>, b: MatRef<f64>, par: Par) -> Mat<f64> {
    let mut out = Mat::zeros(a.ncols(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a.transpose(), b, 1.0, par);
    out
}

/// aᵀ·a, parallel: the lower triangle by one triangular product (half the
/// flops of [`atb`]), mirrored, so the result is exactly symmetric.
fn ata(a: MatRef<f64>, par: Par) -> Mat<f64> {
    let n = a.ncols();
    let mut out = Mat::zeros(n, n);
    triangular::matmul(
        out.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        a.transpose(),
        BlockStructure::Rectangular,
        a,
        BlockStructure::Rectangular,
        1.0,
        par,
    );
    for j in 0..n {
        for i in 0..j {
            out[(i, j)] = out[(j, i)];
        }
    }
    out
}

/// Rows of `y` scaled by w^k (the weight list repeats for the real and imaginary halves).
fn weighted(y: MatRef<f64>, w: &[f64], k: i32) -> Mat<f64> {
    let n = w.len();
    Mat::from_fn(y.nrows(), y.ncols(), |r, c| y[(r, c)] * w[r % n].powi(k))
}

/// Gram products of the (scaled) stacked data.
pub fn gram(data: &Stacked, par: Par) -> Gram {
    let n = data.w.len();
    let m = data.y.ncols();
    let y0 = data.y.as_ref();
    let y1 = weighted(y0, &data.w, 1);
    let y2 = weighted(y0, &data.w, 2);
    let im0 = y0.subrows(n, n);
    let (re1, im1) = (y1.as_ref().subrows(0, n), y1.as_ref().subrows(n, n));
    let im2 = y2.as_ref().subrows(n, n);

    let s0 = ata(y0, par);
    let s2 = ata(y1.as_ref(), par);
    let s4 = ata(y2.as_ref(), par);
    // T_k = P_k − P_kᵀ with P_k = Σ ω^k Im(u) Re(u)ᵀ
    let p1 = atb(im0, re1, par);
    let p3 = atb(im2, re1, par);
    let t1 = Mat::from_fn(m, m, |i, j| p1[(i, j)] - p1[(j, i)]);
    let t3 = Mat::from_fn(m, m, |i, j| p3[(i, j)] - p3[(j, i)]);

    let mut h = Mat::zeros(3 * m, 3 * m);
    let blocks: [[(&Mat<f64>, f64); 3]; 3] = [
        [(&s4, 1.0), (&t3, -1.0), (&s2, -1.0)],
        [(&t3, 1.0), (&s2, 1.0), (&t1, -1.0)],
        [(&s2, -1.0), (&t1, 1.0), (&s0, 1.0)],
    ];
    for (bi, row) in blocks.iter().enumerate() {
        for (bj, (blk, sign)) in row.iter().enumerate() {
            for j in 0..m {
                for i in 0..m {
                    h[(bi * m + i, bj * m + j)] = sign * blk[(i, j)];
                }
            }
        }
    }

    let g0 = data.g.as_ref();
    let (gre, gim) = (g0.subrows(0, n), g0.subrows(n, n));
    let bm = atb(g0, y2.as_ref(), par);
    let bc_a = atb(gim, re1, par);
    let bc_b = atb(gre, im1, par);
    let bk = atb(g0, y0, par);
    let mut b = Mat::zeros(m, 3 * m);
    for j in 0..m {
        for i in 0..m {
            b[(i, j)] = -bm[(i, j)];
            b[(i, m + j)] = bc_a[(i, j)] - bc_b[(i, j)];
            b[(i, 2 * m + j)] = bk[(i, j)];
        }
    }
    Gram { h, b }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{Columns, Scaling};
    use faer::c64;

    fn gram_of(u: &[c64], f: &[c64], w: &[f64], m: usize) -> Gram {
        let cols = Columns::new(u, f, w, m).unwrap();
        gram(&Stacked::new(&cols, &Scaling::IDENTITY), Par::Seq)
    }

    /// m = 1, u = 1+2i, f = 3−i, ω = 2: |u|² = 5, f ū = 1 − 7i, so
    /// H = 5·[[ω⁴, 0, −ω²], [0, ω², 0], [−ω², 0, 1]] and B = [−ω²·1, ω·(−7), 1].
    #[test]
    fn single_dof_by_hand() {
        let g = gram_of(&[c64::new(1.0, 2.0)], &[c64::new(3.0, -1.0)], &[2.0], 1);
        let h = [[80.0, 0.0, -20.0], [0.0, 20.0, 0.0], [-20.0, 0.0, 5.0]];
        for (i, row) in h.iter().enumerate() {
            for (j, want) in row.iter().enumerate() {
                assert_eq!(g.h[(i, j)], *want, "H[{i},{j}]");
            }
        }
        for (j, want) in [-4.0, -14.0, 1.0].iter().enumerate() {
            assert_eq!(g.b[(0, j)], *want, "B[0,{j}]");
        }
    }

    /// m = 2, u = [1, i], ω = 1: Re(u uᴴ) = I, Im(u uᴴ) = [[0, −1], [1, 0]] = J, so the
    /// (M, C) block of H is −ω³J and the (C, K) block −ωJ.
    #[test]
    fn imaginary_part_enters_as_antisymmetric_blocks() {
        let u = [c64::new(1.0, 0.0), c64::new(0.0, 1.0)];
        let g = gram_of(&u, &[c64::new(0.0, 0.0); 2], &[1.0], 2);
        let j = [[0.0, -1.0], [1.0, 0.0]];
        for (a, jrow) in j.iter().enumerate() {
            for (b, &jab) in jrow.iter().enumerate() {
                let id = if a == b { 1.0 } else { 0.0 };
                assert_eq!(g.h[(a, 2 + b)], -jab, "(M,C)");
                assert_eq!(g.h[(2 + a, 4 + b)], -jab, "(C,K)");
                assert_eq!(g.h[(2 + a, b)], jab, "(C,M)");
                assert_eq!(g.h[(a, b)], id, "S4");
                assert_eq!(g.h[(a, 4 + b)], -id, "−S2");
            }
        }
    }
}
