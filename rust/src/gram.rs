//! The Gram products of docs/design.md §2: H = Re(V Vᴴ) (3m×3m) and B = Re(F Vᴴ) (m×3m),
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
use crate::random::Lcg;
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Columns per parallel task of the element-wise passes below.
const COLS_PER_TASK: usize = 16;

/// Square tiles of [`par_transposed_pairs`]: a tile and its mirror both fit in L1.
const MIRROR_TILE: usize = 32;

/// A raw pointer that may cross threads (the tasks of [`par_transposed_pairs`]
/// write disjoint entries).
#[derive(Clone, Copy)]
struct SendPtr(*mut f64);
unsafe impl Send for SendPtr {}
unsafe impl Sync for SendPtr {}

/// For every entry (r, c) below the diagonal of a square view, `pair(lower,
/// upper)` with lower = A[r, c] and upper = A[c, r], and `diag(A[c, c])`: in
/// square tiles (a tile and its mirror fit in L1) run in parallel, one task per
/// tile column of c. The column-by-column loops this replaces read one of the
/// two triangles a whole column apart, one cache miss per entry, on one thread.
fn par_transposed_pairs(
    a: MatMut<f64>,
    pair: impl Fn(&mut f64, &mut f64) + Sync,
    diag: impl Fn(&mut f64) + Sync,
) {
    let n = a.nrows();
    assert!(a.ncols() == n && a.row_stride() == 1);
    let ld = a.col_stride() as usize;
    let ptr = SendPtr(a.as_ptr_mut());
    (0..n.div_ceil(MIRROR_TILE)).into_par_iter().for_each(|tc| {
        let p = ptr;
        let (c0, c1) = (tc * MIRROR_TILE, ((tc + 1) * MIRROR_TILE).min(n));
        for r0 in (c0..n).step_by(MIRROR_TILE) {
            for c in c0..c1 {
                for r in r0.max(c + 1)..(r0 + MIRROR_TILE).min(n) {
                    // SAFETY: (r, c) and (c, r), r > c, are distinct entries
                    // of the view, touched only by the task of c's tile
                    unsafe { pair(&mut *p.0.add(r + c * ld), &mut *p.0.add(c + r * ld)) };
                }
            }
        }
        for c in c0..c1 {
            // SAFETY: the diagonal entry of a column of this task's tile
            diag(unsafe { &mut *p.0.add(c + c * ld) });
        }
    });
}

/// Upper triangle := `sign` × the lower triangle transposed (with `sign` < 0,
/// an antisymmetric matrix: the diagonal is zeroed).
pub(crate) fn mirror_lower(a: MatMut<f64>, sign: f64) {
    par_transposed_pairs(
        a,
        |lower, upper| *upper = sign * *lower,
        |d| {
            if sign < 0.0 {
                *d = 0.0
            }
        },
    );
}

/// A := (A + Aᵀ)/2 for a square view.
pub(crate) fn symmetrize(a: MatMut<f64>) {
    par_transposed_pairs(
        a,
        |lower, upper| {
            let v = 0.5 * (*lower + *upper);
            (*lower, *upper) = (v, v);
        },
        |_| {},
    );
}

/// out[(r, c)] = f(r, c), column chunks in parallel (the element-wise passes
/// over the stacked data and the assembled blocks, which ran on one thread).
pub(crate) fn par_fill(out: MatMut<f64>, f: impl Fn(usize, usize) -> f64 + Sync) {
    out.par_col_chunks_mut(COLS_PER_TASK)
        .enumerate()
        .for_each(|(k, mut cols)| {
            for j in 0..cols.ncols() {
                let c = k * COLS_PER_TASK + j;
                for r in 0..cols.nrows() {
                    cols[(r, j)] = f(r, c);
                }
            }
        });
}

/// H (3m×3m, symmetric positive semidefinite) and B (m×3m).
pub struct Gram {
    pub h: Mat<f64>,
    pub b: Mat<f64>,
}

/// The five distinct blocks of H: S0, S2, S4 (symmetric) and T1, T3
/// (antisymmetric), each m×m, laid out in H as in the module documentation
/// ([`HBlocks::block`]); the change of basis keeps H̃ the same way.
pub struct HBlocks {
    pub s0: Mat<f64>,
    pub s2: Mat<f64>,
    pub s4: Mat<f64>,
    pub t1: Mat<f64>,
    pub t3: Mat<f64>,
}

impl HBlocks {
    /// H's diagonal blocks in the order of Z's blocks M, C, K: S4, S2, S0.
    pub fn diagonal(&self) -> [MatRef<'_, f64>; 3] {
        [self.s4.as_ref(), self.s2.as_ref(), self.s0.as_ref()]
    }

    /// Block (b, c) of H (b, c ∈ {0, 1, 2} for M, C, K) as (stored block, sign).
    pub fn block(&self, b: usize, c: usize) -> (MatRef<'_, f64>, f64) {
        let (blk, sign) = match (b, c) {
            (0, 0) => (&self.s4, 1.0),
            (0, 1) => (&self.t3, -1.0),
            (0, 2) => (&self.s2, -1.0),
            (1, 0) => (&self.t3, 1.0),
            (1, 1) => (&self.s2, 1.0),
            (1, 2) => (&self.t1, -1.0),
            (2, 0) => (&self.s2, -1.0),
            (2, 1) => (&self.t1, 1.0),
            _ => (&self.s0, 1.0),
        };
        (blk.as_ref(), sign)
    }

    /// Entry (i, j) of H (3m×3m).
    #[inline]
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        let m = self.m();
        let (blk, sign) = self.block(i / m, j / m);
        sign * blk[(i % m, j % m)]
    }

    /// Order m of each block.
    pub fn m(&self) -> usize {
        self.s0.nrows()
    }

    /// H itself, 3m×3m.
    pub fn assemble(&self) -> Mat<f64> {
        let m = self.m();
        let mut h = Mat::zeros(3 * m, 3 * m);
        par_fill(h.as_mut(), |i, j| self.entry(i, j));
        h
    }
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
    mirror_lower(out.as_mut(), 1.0);
    out
}

/// Rows `rows` of `out` := the same rows of `y` scaled by w^k (the weight list
/// repeats for the real and imaginary halves).
fn weight_rows(out: MatMut<f64>, y: MatRef<f64>, w: &[f64], k: i32, rows: std::ops::Range<usize>) {
    let n = w.len();
    let wk: Vec<f64> = rows.clone().map(|r| w[r % n].powi(k)).collect();
    let lo = rows.start;
    par_fill(out.subrows_mut(lo, rows.len()), |r, c| {
        y[(lo + r, c)] * wk[r]
    });
}

/// A := A − Aᵀ in place (T_k from P_k without a second m×m matrix).
fn minus_transpose(a: MatMut<f64>) {
    par_transposed_pairs(
        a,
        |lower, upper| {
            let (l, u) = (*lower, *upper);
            (*lower, *upper) = (l - u, u - l);
        },
        |d| *d = 0.0,
    );
}

/// Gram products of the (scaled) stacked data.
pub fn gram(data: &Stacked, par: Par) -> Gram {
    let (h, b) = gram_blocks(data, par);
    Gram { h: h.assemble(), b }
}

/// H by its five distinct blocks, and B: what the matrix-free path needs (it
/// transforms the blocks one by one, so H itself, 72 MB at m = 1000, is never
/// written).
pub fn gram_blocks(data: &Stacked, par: Par) -> (HBlocks, Mat<f64>) {
    let n = data.w.len();
    let m = data.y.ncols();
    let y0 = data.y.as_ref();
    let im0 = y0.subrows(n, n);
    let g0 = data.g.as_ref();
    let (gre, gim) = (g0.subrows(0, n), g0.subrows(n, n));
    let s0 = ata(y0, par);
    let mut b = Mat::zeros(m, 3 * m);
    matmul(
        b.as_mut().subcols_mut(2 * m, m),
        Accum::Replace,
        g0.transpose(),
        y0,
        1.0,
        par,
    );

    // one buffer holds the data weighted by ω (y1), then by ω² (y2): its
    // imaginary half first, while the products T3 and B_C still read Re y1
    let mut yw = Mat::zeros(2 * n, m);
    weight_rows(yw.as_mut(), y0, &data.w, 1, 0..2 * n);
    let s2 = ata(yw.as_ref(), par);
    // T_k = P_k − P_kᵀ with P_k = Σ ω^k Im(u) Re(u)ᵀ, formed in place
    let re1 = yw.as_ref().subrows(0, n);
    let mut t1 = atb(im0, re1, par);
    minus_transpose(t1.as_mut());
    let mut bc = b.as_mut().subcols_mut(m, m);
    matmul(bc.as_mut(), Accum::Replace, gim.transpose(), re1, 1.0, par);
    let im1 = yw.as_ref().subrows(n, n);
    matmul(bc.as_mut(), Accum::Add, gre.transpose(), im1, -1.0, par);
    weight_rows(yw.as_mut(), y0, &data.w, 2, n..2 * n);
    let (re1, im2) = (yw.as_ref().subrows(0, n), yw.as_ref().subrows(n, n));
    let mut t3 = atb(im2, re1, par);
    minus_transpose(t3.as_mut());
    weight_rows(yw.as_mut(), y0, &data.w, 2, 0..n);
    let s4 = ata(yw.as_ref(), par);
    matmul(
        b.as_mut().subcols_mut(0, m),
        Accum::Replace,
        g0.transpose(),
        yw.as_ref(),
        -1.0,
        par,
    );
    (HBlocks { s0, s2, s4, t1, t3 }, b)
}

/// H's blocks for random data (for tests and examples): 2m + 2 lines of
/// pseudo-random responses at frequencies spread over [0.5, 1.5] (scaled units),
/// so H is of the structure above and, generically, positive definite; the
/// same `seed` gives the same blocks.
pub fn random_blocks(m: usize, seed: u64) -> HBlocks {
    let mut rng = Lcg(seed);
    let n = 2 * m + 2;
    let y = Mat::from_fn(2 * n, m, |_, _| rng.uniform());
    let g = Mat::from_fn(2 * n, m, |_, _| rng.uniform());
    let w = (0..n).map(|i| 0.5 + (i as f64 + 0.5) / n as f64).collect();
    gram_blocks(&Stacked { y, g, w }, Par::Seq).0
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

    /// The tiled parallel passes equal the plain loops they replaced, bit for
    /// bit, on sizes below, at and across the tile (and on a view with a
    /// column stride larger than its rows, as the blocks of Z are).
    #[test]
    fn tiled_mirror_and_symmetrize_match_the_plain_loops() {
        for n in [1, 2, 31, 32, 33, 70] {
            let a = Mat::from_fn(n + 3, 2 * n, |i, j| ((i * 7 + j * 13) % 11) as f64 - 5.3);
            for sign in [1.0, -1.0] {
                let mut got = a.clone();
                mirror_lower(got.as_mut().submatrix_mut(0, n, n, n), sign);
                let mut want = a.clone();
                for j in 0..n {
                    if sign < 0.0 {
                        want[(j, n + j)] = 0.0;
                    }
                    for i in 0..j {
                        want[(i, n + j)] = sign * want[(j, n + i)];
                    }
                }
                assert!(got == want, "mirror n = {n}, sign {sign}");
            }
            let mut got = a.clone();
            symmetrize(got.as_mut().submatrix_mut(0, n, n, n));
            let mut want = a.clone();
            for j in 0..n {
                for i in j + 1..n {
                    let v = 0.5 * (want[(i, n + j)] + want[(j, n + i)]);
                    want[(i, n + j)] = v;
                    want[(j, n + i)] = v;
                }
            }
            assert!(got == want, "symmetrize n = {n}");
        }
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
