//! Approximate joint diagonalisation of a few symmetric matrices by one orthogonal
//! matrix, for the preconditioner's basis (docs/design.md §4, [`crate::precond`]).
//!
//! The preconditioner keeps only the diagonal of every block Qᵀ H_bb' Q. One
//! eigenbasis Q diagonalises one matrix (e.g. the sum of the diagonal blocks),
//! but in a wide band S₀ = ΣRe(uuᴴ), S₂ = Σω²Re(uuᴴ) and S₄ = Σω⁴Re(uuᴴ) weight
//! the lines so differently that their off-diagonal parts in that basis are
//! large, and the near-collinear M–K pair of each entry amplifies them. Refining
//! Q to minimise Σ_k ‖off(Qᵀ S_k Q)‖² (each S_k scaled to unit trace) roughly
//! halved CG iterations on 50–150 Hz bands in our measurements, and changed
//! nothing on the 20 % band, where one eigenbasis already fits all three.
//!
//! Method: Cardoso–Souloumiac Jacobi rotations, blocked. The indices are split
//! into blocks of [`BLOCK`]; in each round of a round-robin tournament every
//! block meets one other, the 2b×2b subproblem of each pair is jointly
//! diagonalised by scalar Jacobi sweeps (independent, in parallel), and the
//! resulting orthogonal 2b×2b transforms are applied to the full matrices as
//! independent small products W_kᵀ A_kl W_l (to Q as GEMMs): ≈ 16m³ flops a
//! sweep in cache-sized pieces instead of m³ strided scalar updates.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use rayon::prelude::*;

/// Indices per block.
pub const BLOCK: usize = 32;

/// Scalar Jacobi sweeps on each 2b×2b subproblem (a second one changed CG
/// iterations by under 2 % in our measurements).
const INNER_SWEEPS: usize = 1;

/// Symmetric n×n matrix, column-major, of a subproblem.
struct Sub {
    n: usize,
    a: Vec<f64>,
}

impl Sub {
    /// a ← Gᵀ a G for the rotation G of (p, q), p < q: rotate columns p and q
    /// (contiguous), then mirror them into rows p and q.
    fn rotate(&mut self, p: usize, q: usize, c: f64, s: f64) {
        let n = self.n;
        let (left, right) = self.a.split_at_mut(q * n);
        let (cp, cq) = (&mut left[p * n..p * n + n], &mut right[..n]);
        for (x, y) in cp.iter_mut().zip(cq.iter_mut()) {
            let (u, v) = (*x, *y);
            *x = c * u + s * v;
            *y = c * v - s * u;
        }
        // the 2×2 block: rows p, q of the column-rotated matrix, rotated too
        let (pp, qp, pq, qq) = (cp[p], cp[q], cq[p], cq[q]);
        cp[p] = c * pp + s * qp;
        cp[q] = c * qp - s * pp;
        cq[p] = c * pq + s * qq;
        cq[q] = c * qq - s * pq;
        for r in 0..n {
            if r != p && r != q {
                self.a[r * n + p] = self.a[p * n + r];
                self.a[r * n + q] = self.a[q * n + r];
            }
        }
    }
}

/// Orthogonal W (n×n) that jointly diagonalises the small symmetric matrices `subs`
/// by scalar Jacobi sweeps (they are transformed in place).
fn jacobi(subs: &mut [Sub], sweeps: usize) -> Mat<f64> {
    let n = subs[0].n;
    let mut w = Mat::<f64>::identity(n, n);
    for _ in 0..sweeps {
        for p in 0..n {
            for q in p + 1..n {
                let (mut ton, mut toff) = (0.0, 0.0);
                for a in subs.iter() {
                    let (g, h) = (a.a[p * n + p] - a.a[q * n + q], 2.0 * a.a[q * n + p]);
                    ton += g * g - h * h;
                    toff += 2.0 * g * h;
                }
                let theta = 0.5 * toff.atan2(ton + ton.hypot(toff));
                let (s, c) = theta.sin_cos();
                if s.abs() < 1e-15 {
                    continue;
                }
                for a in subs.iter_mut() {
                    a.rotate(p, q, c, s);
                }
                for i in 0..n {
                    let (x, y) = (w[(i, p)], w[(i, q)]);
                    w[(i, p)] = c * x + s * y;
                    w[(i, q)] = c * y - s * x;
                }
            }
        }
    }
    w
}

/// Rounds of a round-robin tournament between `n` players (circle method); a
/// player without an opponent in a round plays alone (`None`).
fn tournament(n: usize) -> Vec<Vec<(usize, Option<usize>)>> {
    if n <= 1 {
        return vec![vec![(0, None)]];
    }
    let slots = n + n % 2;
    let mut ring: Vec<usize> = (1..slots).collect();
    let mut rounds = Vec::with_capacity(slots - 1);
    for _ in 0..slots - 1 {
        let seats: Vec<usize> = std::iter::once(0).chain(ring.iter().copied()).collect();
        let round = (0..slots / 2)
            .filter_map(|i| {
                let (a, b) = (seats[i], seats[slots - 1 - i]);
                let real = |x: usize| (x < n).then_some(x);
                match (real(a), real(b)) {
                    (Some(a), b) => Some((a, b)),
                    (None, Some(b)) => Some((b, None)),
                    (None, None) => None,
                }
            })
            .collect();
        rounds.push(round);
        ring.rotate_right(1);
    }
    rounds
}

/// Columns `idx` of `a` times `w`, written back: a[:, idx] ← a[:, idx]·w for
/// every (idx, w) of a round (disjoint index sets).
fn apply_cols(a: &mut Mat<f64>, round: &[(Vec<usize>, Mat<f64>)], par: Par) {
    let nr = a.nrows();
    let updated: Vec<Mat<f64>> = round
        .par_iter()
        .map(|(idx, w)| {
            let mut sub = Mat::zeros(nr, idx.len());
            for (j, &c) in idx.iter().enumerate() {
                sub.col_mut(j).copy_from(a.col(c));
            }
            let mut out = Mat::zeros(nr, idx.len());
            matmul(
                out.as_mut(),
                Accum::Replace,
                sub.as_ref(),
                w.as_ref(),
                1.0,
                par,
            );
            out
        })
        .collect();
    for ((idx, _), new) in round.iter().zip(&updated) {
        for (j, &col) in idx.iter().enumerate() {
            a.col_mut(col).copy_from(new.col(j));
        }
    }
}

/// Contiguous runs of an index set made of whole blocks: (start, len) pairs.
fn runs(idx: &[usize]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &i in idx {
        match out.last_mut() {
            Some((s, l)) if *s + *l == i => *l += 1,
            _ => out.push((i, 1)),
        }
    }
    out
}

/// A ← Gᵀ A G for symmetric `a` and the block-diagonal orthogonal G of a round
/// (index sets S_k, transforms W_k, together a partition of all indices): every
/// block becomes A[S_k, S_l] ← W_kᵀ A[S_k, S_l] W_l, independent small products
/// (the upper ones computed, mirrored into the lower).
fn congruence(a: &mut Mat<f64>, round: &[(Vec<usize>, Mat<f64>)]) {
    let n = round.len();
    let spans: Vec<Vec<(usize, usize)>> = round.iter().map(|(idx, _)| runs(idx)).collect();
    // rows of S_k, gathered from column j of a
    let gather = |a: &Mat<f64>, k: usize, j: usize, out: &mut [f64]| {
        let col = a.col(j).try_as_col_major().expect("contiguous").as_slice();
        let mut at = 0;
        for &(s, l) in &spans[k] {
            out[at..at + l].copy_from_slice(&col[s..s + l]);
            at += l;
        }
    };
    let jobs: Vec<(usize, usize)> = (0..n).flat_map(|k| (k..n).map(move |l| (k, l))).collect();
    let blocks: Vec<Mat<f64>> = jobs
        .par_iter()
        .map(|&(k, l)| {
            let (ik, wk) = (&round[k].0, &round[k].1);
            let (il, wl) = (&round[l].0, &round[l].1);
            let mut sub = Mat::zeros(ik.len(), il.len());
            for (c, &j) in il.iter().enumerate() {
                let dst = sub.col_mut(c).try_as_col_major_mut().expect("contiguous");
                gather(a, k, j, dst.as_slice_mut());
            }
            wk.transpose() * &sub * wl
        })
        .collect();
    for (&(k, l), b) in jobs.iter().zip(&blocks) {
        let (ik, il) = (&round[k].0, &round[l].0);
        for (c, &jc) in il.iter().enumerate() {
            let src = b.col(c).try_as_col_major().expect("contiguous").as_slice();
            let col = a.col_mut(jc).try_as_col_major_mut().expect("contiguous");
            let col = col.as_slice_mut();
            let mut at = 0;
            for &(s, len) in &spans[k] {
                col[s..s + len].copy_from_slice(&src[at..at + len]);
                at += len;
            }
        }
        if k != l {
            for (r, &jr) in ik.iter().enumerate() {
                for (c, &jc) in il.iter().enumerate() {
                    a[(jc, jr)] = b[(r, c)];
                }
            }
        }
    }
}

/// Refine the orthogonal `q` so that the symmetric `mats` (given already in the
/// basis q, i.e. qᵀ S_k q) become as diagonal as possible together; `mats` are
/// transformed along. `sweeps` block-Jacobi sweeps.
pub fn refine(mats: &mut [Mat<f64>], q: &mut Mat<f64>, sweeps: usize, par: Par) {
    let m = q.ncols();
    let blocks: Vec<Vec<usize>> = (0..m)
        .step_by(BLOCK)
        .map(|s| (s..(s + BLOCK).min(m)).collect())
        .collect();
    let rounds = tournament(blocks.len());
    for _ in 0..sweeps {
        for round in &rounds {
            let transforms: Vec<(Vec<usize>, Mat<f64>)> = round
                .par_iter()
                .map(|&(i, j)| {
                    let mut idx = blocks[i].clone();
                    if let Some(j) = j {
                        idx.extend(&blocks[j]);
                    }
                    let n = idx.len();
                    let mut subs: Vec<Sub> = mats
                        .iter()
                        .map(|a| Sub {
                            n,
                            a: (0..n * n).map(|e| a[(idx[e % n], idx[e / n])]).collect(),
                        })
                        .collect();
                    let w = jacobi(&mut subs, INNER_SWEEPS);
                    (idx, w)
                })
                .collect();
            for a in mats.iter_mut() {
                congruence(a, &transforms);
            }
            apply_cols(q, &transforms, par);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn off(a: &Mat<f64>) -> f64 {
        let n = a.nrows();
        let mut s = 0.0;
        for j in 0..n {
            for i in 0..n {
                if i != j {
                    s += a[(i, j)] * a[(i, j)];
                }
            }
        }
        s
    }

    #[test]
    fn tournament_meets_every_pair_once() {
        for n in 1..9 {
            let mut met = vec![vec![0; n]; n];
            for round in tournament(n) {
                let mut seen = vec![false; n];
                for (a, b) in round {
                    assert!(!seen[a]);
                    seen[a] = true;
                    if let Some(b) = b {
                        assert!(!seen[b]);
                        seen[b] = true;
                        met[a.min(b)][a.max(b)] += 1;
                    }
                }
                assert!(seen.iter().all(|&s| s), "n={n}: everyone plays every round");
            }
            for (a, row) in met.iter().enumerate() {
                for &count in &row[a + 1..] {
                    assert_eq!(count, 1, "n={n}");
                }
            }
        }
    }

    /// Matrices that commute (one hidden orthogonal eigenbasis) are diagonalised
    /// jointly, across several blocks, and q stays orthogonal.
    #[test]
    fn commuting_matrices_are_diagonalised_together() {
        let m = 2 * BLOCK + 7;
        // hidden basis: eigenvectors of a fixed symmetric matrix
        let g = Mat::from_fn(m, m, |i, j| {
            ((i * 17 + j * 17 + i * j) % 23) as f64 / 23.0 - 0.5
        });
        let v = crate::precond::eigenvectors((&g + g.transpose()).as_ref(), Par::Seq).unwrap();
        let diag = |f: &dyn Fn(usize) -> f64| {
            let d = Mat::from_fn(m, m, |i, j| if i == j { f(i) } else { 0.0 });
            &v * &d * v.transpose()
        };
        let mut mats = vec![
            diag(&|i| 1.0 + i as f64),
            diag(&|i| ((i * 7) % 5) as f64),
            diag(&|i| (i as f64).sin()),
        ];
        let before: f64 = mats.iter().map(off).sum();
        let mut q = Mat::<f64>::identity(m, m);
        refine(&mut mats, &mut q, 6, Par::Seq);
        let after: f64 = mats.iter().map(off).sum();
        assert!(after < 1e-8 * before, "off: {before} -> {after}");
        let qtq = q.transpose() * &q;
        assert!((&qtq - Mat::<f64>::identity(m, m)).norm_l2() < 1e-12);
    }
}
