//! Two-stage symmetric tridiagonalisation A = Q₁BQ₁ᵀ = Q T Qᵀ — dense → band B
//! of width b by blocked Householder QR of column panels, then band → tridiagonal
//! T = Q₂ᵀBQ₂ by bulge chasing — for what the λ sweep needs: T, Qᵀ applied to a
//! few given vectors (as Q₂'s small reflectors are generated, so they are not
//! stored), and shifted solves (I + sA)⁻¹ = Q₁(I + sB)⁻¹Q₁ᵀ, Q₁ applied as
//! matrix–matrix products and the band by banded Cholesky in O(n b²) per shift.
//!
//! Why two stages: the one-stage reduction (faer's `tridiag_in_place`, LAPACK's
//! dsytrd) spends half its flops in matrix–vector products over the whole
//! trailing matrix, so it runs at memory speed. At order 5310 on two cores it
//! took 29 s, three times a Cholesky factorisation of twice that order. Here the
//! bulk, (4/3)n³ flops, is matrix–matrix products on the trailing matrix (stage
//! 1); the chase costs O(n²b) on a band held in cache (stage 2).
//!
//! Stage 1, panel by panel (columns c0..c0+b, rows r0 = c0+b..n): QR of the
//! panel P = Q_P R (faer, Q_P = I − V S Vᵀ with S = T⁻¹ for faer's block factor T),
//! then the trailing matrix A₂₂ ← Q_Pᵀ A₂₂ Q_P = A₂₂ − Z Vᵀ − V Zᵀ with
//! Y = A₂₂ V S and Z = Y − ½ V (Sᵀ Vᵀ Y), on the lower triangle only.
//!
//! Stage 2 (sweep j annihilates column j below its subdiagonal): a reflector on
//! rows j+1..j+b, applied on both sides of its diagonal block and from the right
//! to the b×b block below, where it fills a bulge; the next reflector
//! annihilates the bulge's first column, and so on down the band. The rest of
//! each bulge lies inside the block that sweep j+1 treats at the same depth, so
//! band plus bulge never needs more than 2b subdiagonals.

use crate::buffer::DenseBuf;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::householder;
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::qr::no_pivoting::factor::{qr_in_place, qr_in_place_scratch};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// One stage-1 panel: Q_P acts on rows r0.. with Householder vectors stored in
/// columns c0..c0+p of the matrix and block factor t (p×p, upper triangular).
struct Panel {
    r0: usize,
    c0: usize,
    t: Mat<f64>,
}

/// A = Q₁BQ₁ᵀ = Q T Qᵀ, with Q₁ in factored form and the band B.
pub struct Tridiagonal {
    n: usize,
    b: usize,
    /// A after stage 1, n×n column-major: the band, and the panels' Householder
    /// vectors below it
    a: DenseBuf,
    panels: Vec<Panel>,
    /// B, lower band: entry (r, c), 0 ≤ r − c ≤ b, at c·(b+1) + r − c
    band: Vec<f64>,
    /// T: diagonal (n) and subdiagonal (n − 1)
    pub diag: Vec<f64>,
    pub sub: Vec<f64>,
    /// wall time of the two stages, seconds
    pub seconds: [f64; 2],
}

/// Householder reflector of x (LAPACK dlarfg): x becomes v with v[0] = 1, and
/// (I − τvvᵀ) x_old = β e₁. Returns (τ, β); τ = 0 when x is already β e₁.
fn householder_vector(x: &mut [f64]) -> (f64, f64) {
    let alpha = x[0];
    let tail: f64 = x[1..].iter().map(|v| v * v).sum::<f64>().sqrt();
    if tail == 0.0 {
        x[0] = 1.0;
        return (0.0, alpha);
    }
    let beta = -alpha.hypot(tail).copysign(alpha);
    let scale = 1.0 / (alpha - beta);
    x[1..].iter_mut().for_each(|v| *v *= scale);
    x[0] = 1.0;
    ((beta - alpha) / beta, beta)
}

/// Lower band with 2b subdiagonals (band plus bulge), column-major: entry (r, c),
/// 0 ≤ r − c ≤ 2b, at c·(2b+1) + r − c.
struct Band {
    ld: usize,
    data: Vec<f64>,
}

impl Band {
    fn at(&self, r: usize, c: usize) -> usize {
        c * self.ld + r - c
    }

    /// (I − τvvᵀ) B (I − τvvᵀ) on the symmetric diagonal block rows/cols i0..i0+len.
    fn two_sided(&mut self, i0: usize, v: &[f64], tau: f64) {
        let len = v.len();
        // w = τ B v from the lower triangle
        let mut w = vec![0.0; len];
        for c in 0..len {
            let col = self.at(i0 + c, i0 + c);
            w[c] += self.data[col] * v[c];
            for r in c + 1..len {
                let b = self.data[col + r - c];
                w[r] += b * v[c];
                w[c] += b * v[r];
            }
        }
        w.iter_mut().for_each(|x| *x *= tau);
        let alpha = -0.5 * tau * w.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        w.iter_mut().zip(v).for_each(|(x, y)| *x += alpha * y);
        for c in 0..len {
            let col = self.at(i0 + c, i0 + c);
            for r in c..len {
                self.data[col + r - c] -= v[r] * w[c] + w[r] * v[c];
            }
        }
    }

    /// Block rows r0..r0+rows, columns i0..i0+len times (I − τvvᵀ) from the right.
    fn right(&mut self, r0: usize, rows: usize, i0: usize, v: &[f64], tau: f64) {
        let mut s = vec![0.0; rows];
        for (c, &vc) in v.iter().enumerate() {
            let base = self.at(r0, i0 + c);
            for (r, sr) in s.iter_mut().enumerate() {
                *sr += self.data[base + r] * vc;
            }
        }
        for (c, &vc) in v.iter().enumerate() {
            let base = self.at(r0, i0 + c);
            for (r, sr) in s.iter().enumerate() {
                self.data[base + r] -= tau * sr * vc;
            }
        }
    }

    /// (I − τvvᵀ) times the block rows r0..r0+len, columns c0..c1, from the left.
    fn left(&mut self, r0: usize, c0: usize, c1: usize, v: &[f64], tau: f64) {
        for c in c0..c1 {
            let base = self.at(r0, c);
            let col = &mut self.data[base..base + v.len()];
            let d: f64 = col.iter().zip(v).map(|(a, b)| a * b).sum();
            col.iter_mut().zip(v).for_each(|(a, b)| *a -= tau * d * b);
        }
    }
}

/// The columns of x as slices (x column-major with contiguous columns).
fn columns(x: MatMut<'_, f64>) -> Vec<&mut [f64]> {
    let mut out = Vec::with_capacity(x.ncols());
    let mut rest = x;
    while rest.ncols() > 0 {
        let (first, tail) = rest.split_at_col_mut(1);
        out.push(
            first
                .col_mut(0)
                .try_as_col_major_mut()
                .expect("contiguous column")
                .as_slice_mut(),
        );
        rest = tail;
    }
    out
}

/// Trailing matrices smaller than this are updated on one thread (measured at
/// n = 570: 5 ms on one thread, 13 ms on two).
const SEQUENTIAL_BELOW: usize = 1024;

/// Stage 1 in place on the lower triangle of `a` (n×n column-major).
fn reduce_to_band(a: &mut [f64], n: usize, b: usize, par: Par) -> Vec<Panel> {
    let mut panels = Vec::new();
    let mut c0 = 0;
    // a panel has something to annihilate while at least two rows lie below the band
    while c0 + b + 1 < n {
        let r0 = c0 + b;
        let np = n - r0;
        let p = b.min(np);
        // on small trailing matrices, thread start-up costs more than it saves
        let par = if np < SEQUENTIAL_BELOW { Par::Seq } else { par };
        let mut am = MatMut::from_column_major_slice_mut(a, n, n);
        let mut t = Mat::zeros(p, p);
        {
            let params = Default::default();
            let mut mem = MemBuffer::new(qr_in_place_scratch::<f64>(np, b, p, par, params));
            let panel = am.as_mut().submatrix_mut(r0, c0, np, b);
            qr_in_place(panel, t.as_mut(), par, MemStack::new(&mut mem), params);
        }
        let v = Mat::from_fn(np, p, |i, j| match i.cmp(&j) {
            std::cmp::Ordering::Less => 0.0,
            std::cmp::Ordering::Equal => 1.0,
            std::cmp::Ordering::Greater => am[(r0 + i, c0 + j)],
        });
        // Y = A₂₂ V T⁻¹, A₂₂ symmetric from its lower triangle
        let mut y = Mat::zeros(np, p);
        {
            let a22 = am.as_ref().submatrix(r0, r0, np, np);
            let (rect, lower) = (BlockStructure::Rectangular, BlockStructure::TriangularLower);
            let strict_upper = BlockStructure::StrictTriangularUpper;
            triangular::matmul(
                y.as_mut(),
                rect,
                Accum::Replace,
                a22,
                lower,
                v.as_ref(),
                rect,
                1.0,
                par,
            );
            triangular::matmul(
                y.as_mut(),
                rect,
                Accum::Add,
                a22.transpose(),
                strict_upper,
                v.as_ref(),
                rect,
                1.0,
                par,
            );
        }
        solve_lower_triangular_in_place(t.transpose(), y.as_mut().transpose_mut(), par);
        // Z = Y − ½ V T⁻ᵀ (Vᵀ Y)
        let mut w = Mat::zeros(p, p);
        matmul(
            w.as_mut(),
            Accum::Replace,
            v.transpose(),
            y.as_ref(),
            1.0,
            par,
        );
        solve_lower_triangular_in_place(t.transpose(), w.as_mut(), par);
        matmul(y.as_mut(), Accum::Add, v.as_ref(), w.as_ref(), -0.5, par);
        // A₂₂ ← A₂₂ − Z Vᵀ − V Zᵀ, lower triangle
        let mut a22 = am.as_mut().submatrix_mut(r0, r0, np, np);
        let (rect, lower) = (BlockStructure::Rectangular, BlockStructure::TriangularLower);
        triangular::matmul(
            a22.as_mut(),
            lower,
            Accum::Add,
            y.as_ref(),
            rect,
            v.transpose(),
            rect,
            -1.0,
            par,
        );
        triangular::matmul(
            a22.as_mut(),
            lower,
            Accum::Add,
            v.as_ref(),
            rect,
            y.transpose(),
            rect,
            -1.0,
            par,
        );
        panels.push(Panel { r0, c0, t });
        c0 += b;
    }
    panels
}

impl Tridiagonal {
    /// Reduce the symmetric matrix given by the lower triangle of `a` (n×n
    /// column-major; the upper triangle is ignored) with band width `b` ≥ 1, and
    /// set x ← Qᵀx for the columns of `x` (n×k).
    pub fn new(mut a: DenseBuf, n: usize, b: usize, mut x: MatMut<f64>, par: Par) -> Tridiagonal {
        assert!(b >= 1 && a.len() == n * n && x.nrows() == n);
        let start = std::time::Instant::now();
        let panels = reduce_to_band(&mut a, n, b, par);
        let band_seconds = start.elapsed().as_secs_f64();
        let mut tri = Tridiagonal {
            n,
            b,
            a,
            panels,
            band: Vec::new(),
            diag: Vec::new(),
            sub: Vec::new(),
            seconds: [band_seconds, 0.0],
        };
        tri.apply_stage1(x.as_mut(), true, par);
        let a = &tri.a;

        let ld = 2 * b + 1;
        let mut band = Band {
            ld,
            data: vec![0.0; ld * n],
        };
        let mut stage1 = vec![0.0; (b + 1) * n];
        for c in 0..n {
            for r in c..n.min(c + b + 1) {
                let k = band.at(r, c);
                band.data[k] = a[c * n + r];
                stage1[c * (b + 1) + r - c] = a[c * n + r];
            }
        }
        let mut xcols = columns(x);
        let mut v = vec![0.0; b];
        for j in 0..n.saturating_sub(2) {
            // the reflector annihilating column j below its subdiagonal
            let (mut i0, mut len) = (j + 1, b.min(n - 1 - j));
            let mut pivot_col = j;
            loop {
                let base = band.at(i0, pivot_col);
                let v = &mut v[..len];
                v.copy_from_slice(&band.data[base..base + len]);
                let (tau, beta) = householder_vector(v);
                band.data[base] = beta;
                band.data[base + 1..base + len]
                    .iter_mut()
                    .for_each(|x| *x = 0.0);
                if pivot_col > j {
                    // the other columns of the bulge block, from the left
                    band.left(i0, pivot_col + 1, i0, v, tau);
                }
                band.two_sided(i0, v, tau);
                // Q₂ᵀ = ⋯H₂H₁: this reflector comes next
                xcols.iter_mut().for_each(|col| {
                    let seg = &mut col[i0..i0 + len];
                    let d: f64 = seg.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
                    seg.iter_mut()
                        .zip(v.iter())
                        .for_each(|(a, b)| *a -= tau * d * b);
                });
                // the block below fills with a bulge; its first column is next
                let r0 = i0 + len;
                if r0 >= n {
                    break;
                }
                let rows = b.min(n - r0);
                band.right(r0, rows, i0, v, tau);
                if rows < 2 {
                    break;
                }
                pivot_col = i0;
                i0 = r0;
                len = rows;
            }
        }
        tri.diag = (0..n).map(|i| band.data[band.at(i, i)]).collect();
        tri.sub = (1..n).map(|i| band.data[band.at(i, i - 1)]).collect();
        tri.band = stage1;
        tri.seconds[1] = start.elapsed().as_secs_f64() - band_seconds;
        tri
    }

    /// Column j of x ← (I + s_j A)⁻¹ column j, through the band: Q₁(I + s_j B)⁻¹Q₁ᵀ.
    /// Every s_j ≥ 0 and A positive semidefinite, so I + s_j B is positive definite.
    pub fn solve_shifted(&self, shifts: &[f64], mut x: MatMut<f64>, par: Par) {
        assert_eq!(x.ncols(), shifts.len());
        self.apply_stage1(x.as_mut(), true, par);
        columns(x.as_mut())
            .into_par_iter()
            .zip(shifts.par_iter())
            .for_each(|(col, &s)| self.band_solve(s, col));
        self.apply_stage1(x, false, par);
    }

    /// x ← (I + sB)⁻¹ x by banded Cholesky (right-looking, column-major band),
    /// O(n b²).
    fn band_solve(&self, s: f64, x: &mut [f64]) {
        let (n, b, ld) = (self.n, self.b, self.b + 1);
        let mut l: Vec<f64> = self.band.iter().map(|v| s * v).collect();
        for j in 0..n {
            l[j * ld] += 1.0;
        }
        for j in 0..n {
            let (head, tail) = l.split_at_mut((j + 1) * ld);
            let col = &mut head[j * ld..];
            let d = col[0].sqrt();
            col[0] = d;
            let cnt = b.min(n - 1 - j);
            col[1..=cnt].iter_mut().for_each(|v| *v /= d);
            // trailing update by column j: L[j+r, j+c] −= L[j+r, j] L[j+c, j]
            for c in 1..=cnt {
                let lc = col[c];
                let target = &mut tail[(c - 1) * ld..(c - 1) * ld + cnt - c + 1];
                for (t, lr) in target.iter_mut().zip(&col[c..=cnt]) {
                    *t -= lr * lc;
                }
            }
        }
        for j in 0..n {
            x[j] /= l[j * ld];
            let xj = x[j];
            for i in j + 1..n.min(j + b + 1) {
                x[i] -= l[j * ld + i - j] * xj;
            }
        }
        for j in (0..n).rev() {
            let mut v = x[j];
            for i in j + 1..n.min(j + b + 1) {
                v -= l[j * ld + i - j] * x[i];
            }
            x[j] = v / l[j * ld];
        }
    }

    /// Q₁ (panels last to first) or Q₁ᵀ (first to last).
    fn apply_stage1(&self, mut x: MatMut<f64>, transpose: bool, par: Par) {
        let a = MatRef::from_column_major_slice(&self.a, self.n, self.n);
        let order: Box<dyn Iterator<Item = &Panel>> = if transpose {
            Box::new(self.panels.iter())
        } else {
            Box::new(self.panels.iter().rev())
        };
        for panel in order {
            let (np, p) = (self.n - panel.r0, panel.t.nrows());
            let basis = a.submatrix(panel.r0, panel.c0, np, p);
            let rhs = x.as_mut().subrows_mut(panel.r0, np);
            let mut mem = MemBuffer::new(
                householder::apply_block_householder_on_the_left_in_place_scratch::<f64>(
                    np,
                    p,
                    rhs.ncols(),
                ),
            );
            let stack = MemStack::new(&mut mem);
            let t = panel.t.as_ref();
            if transpose {
                householder::apply_block_householder_transpose_on_the_left_in_place_with_conj(
                    basis,
                    t,
                    Conj::No,
                    rhs,
                    par,
                    stack,
                );
            } else {
                householder::apply_block_householder_on_the_left_in_place_with_conj(
                    basis,
                    t,
                    Conj::No,
                    rhs,
                    par,
                    stack,
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Lcg;

    fn buf(a: &[f64]) -> DenseBuf {
        let mut b = DenseBuf::zeroed(a.len(), "test matrix").unwrap();
        b.copy_from_slice(a);
        b
    }

    fn symmetric(n: usize, seed: u64) -> Mat<f64> {
        let mut rng = Lcg(seed);
        let g = Mat::from_fn(n, n, |_, _| rng.uniform());
        &g + g.transpose()
    }

    /// Qᵀ (from the identity) orthogonal and Qᵀ A Q = T, for band widths below, at
    /// and above n, with several panels and a short last panel.
    #[test]
    fn reduction_reproduces_the_matrix() {
        for (n, b) in [
            (1, 3),
            (2, 1),
            (5, 2),
            (9, 3),
            (40, 4),
            (40, 64),
            (77, 8),
            (130, 32),
        ] {
            let a = symmetric(n, n as u64 + 7 * b as u64);
            // only the lower triangle is read: spoil the upper one
            let lower: Vec<f64> = (0..n * n)
                .map(|k| {
                    if k % n >= k / n {
                        a[(k % n, k / n)]
                    } else {
                        9.0
                    }
                })
                .collect();
            let mut qt = Mat::<f64>::identity(n, n);
            let tri = Tridiagonal::new(buf(&lower), n, b, qt.as_mut(), Par::Seq);
            let t = Mat::from_fn(n, n, |i, j| {
                if i == j {
                    tri.diag[i]
                } else if i == j + 1 {
                    tri.sub[j]
                } else if j == i + 1 {
                    tri.sub[i]
                } else {
                    0.0
                }
            });
            let tol = 1e-13 * (n as f64) * a.norm_l2();
            let reduced = &qt * &a * qt.transpose();
            assert!((&reduced - &t).norm_l2() < tol, "n={n} b={b}: Qᵀ A Q ≠ T");
            let eye = Mat::<f64>::identity(n, n);
            assert!(
                (&qt * qt.transpose() - eye).norm_l2() < 1e-13 * n as f64,
                "n={n} b={b}"
            );
        }
    }

    #[test]
    fn shifted_solves_invert_identity_plus_shifted_matrix() {
        let n = 90;
        let g = symmetric(n, 11);
        let a = &g * &g; // positive semidefinite
        let lower: Vec<f64> = (0..n * n).map(|k| a[(k % n, k / n)]).collect();
        let tri = Tridiagonal::new(buf(&lower), n, 8, Mat::zeros(n, 0).as_mut(), Par::Seq);
        let shifts = [0.0, 1e-3, 1.0, 1e4];
        let rhs = Mat::from_fn(n, shifts.len(), |i, j| ((i * 5 + j) % 7) as f64 - 3.0);
        let mut x = rhs.clone();
        tri.solve_shifted(&shifts, x.as_mut(), Par::Seq);
        for (j, &s) in shifts.iter().enumerate() {
            let lhs = Mat::<f64>::identity(n, n) + &a * s;
            let back = &lhs * x.col(j).as_mat();
            let err = (back - rhs.col(j).as_mat()).norm_l2();
            assert!(
                err < 1e-11 * (1.0 + s) * a.norm_l2() * x.col(j).norm_l2(),
                "s={s}: {err}"
            );
        }
    }

    #[test]
    fn parallel_reduction_matches_sequential() {
        let n = 150;
        let a = symmetric(n, 3);
        let lower: Vec<f64> = (0..n * n).map(|k| a[(k % n, k / n)]).collect();
        let x0 = Mat::from_fn(n, 5, |i, j| ((i * 7 + j * 3) % 11) as f64);
        let (mut x, mut y) = (x0.clone(), x0.clone());
        let seq = Tridiagonal::new(buf(&lower), n, 16, x.as_mut(), Par::Seq);
        let par = Tridiagonal::new(buf(&lower), n, 16, y.as_mut(), Par::rayon(2));
        assert!((&x - &y).norm_l2() < 1e-12 * x.norm_l2());
        for (a, b) in seq.diag.iter().zip(&par.diag) {
            assert!((a - b).abs() < 1e-12 * n as f64);
        }
    }
}
