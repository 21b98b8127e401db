//! The normal equations in each block's orthonormal symmetric/skew basis (docs/design.md §3).
//!
//! Unknowns are the coordinates of X_b (b = M, C, K) in the basis
//! {E_jj} ∪ {(E_jk + E_kj)/√2} ∪ {(E_jk − E_kj)/√2}, j < k. The data term
//! tr(Z H Zᵀ) − 2 tr(Z Bᵀ) becomes xᵀ G x − 2 bᵀx with G = Tᵀ (I_m ⊗ H) T, and the
//! symmetry penalty Σ_b λ_b² ‖X_b − X_bᵀ‖² (paper eq. 40) becomes 4λ_b² on the
//! diagonal of the skew coordinates. Symmetric coordinates come first, so the
//! exact-symmetric problem (λ → ∞) is the leading principal block of G.

use faer::{Mat, MatRef};
use rayon::prelude::*;

const RSQRT2: f64 = std::f64::consts::FRAC_1_SQRT_2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Diag,
    Sym,
    Skew,
}

/// One basis matrix: block b, pair (j ≤ k), kind.
#[derive(Clone, Copy, Debug)]
pub struct Coord {
    pub block: usize,
    pub j: usize,
    pub k: usize,
    pub kind: Kind,
}

/// An entry (row, col) of a basis matrix with its coefficient.
#[derive(Clone, Copy, Debug)]
struct Entry {
    row: usize,
    col: usize,
    coef: f64,
}

impl Coord {
    fn entries(&self) -> impl Iterator<Item = Entry> {
        let Coord { j, k, kind, .. } = *self;
        let (first, second) = match kind {
            Kind::Diag => (
                Entry {
                    row: j,
                    col: j,
                    coef: 1.0,
                },
                None,
            ),
            Kind::Sym => (
                Entry {
                    row: j,
                    col: k,
                    coef: RSQRT2,
                },
                Some(Entry {
                    row: k,
                    col: j,
                    coef: RSQRT2,
                }),
            ),
            Kind::Skew => (
                Entry {
                    row: j,
                    col: k,
                    coef: RSQRT2,
                },
                Some(Entry {
                    row: k,
                    col: j,
                    coef: -RSQRT2,
                }),
            ),
        };
        std::iter::once(first).chain(second)
    }
}

/// The coordinate system of the unknowns.
pub struct Basis {
    pub m: usize,
    pub coords: Vec<Coord>,
    /// number of symmetric coordinates (they come first): 3·m(m+1)/2
    pub n_sym: usize,
}

/// Number of unknowns: 3m(m+1)/2 (exact-symmetric) or 3m².
pub fn n_unknowns(m: usize, symmetric: bool) -> usize {
    if symmetric {
        3 * m * (m + 1) / 2
    } else {
        3 * m * m
    }
}

impl Basis {
    pub fn new(m: usize, symmetric: bool) -> Basis {
        let mut coords = Vec::with_capacity(n_unknowns(m, symmetric));
        for block in 0..3 {
            for j in 0..m {
                for k in j..m {
                    let kind = if j == k { Kind::Diag } else { Kind::Sym };
                    coords.push(Coord { block, j, k, kind });
                }
            }
        }
        let n_sym = coords.len();
        if !symmetric {
            for block in 0..3 {
                for j in 0..m {
                    for k in j + 1..m {
                        coords.push(Coord {
                            block,
                            j,
                            k,
                            kind: Kind::Skew,
                        });
                    }
                }
            }
        }
        Basis { m, coords, n_sym }
    }

    /// The skew coordinates of [`Basis::new`]`(m, false)` alone, in the same order:
    /// an orthonormal basis of the skew-symmetric parts of M, C, K (used by the λ sweep).
    pub fn skew(m: usize) -> Basis {
        let full = Basis::new(m, false);
        Basis {
            m,
            coords: full.coords[full.n_sym..].to_vec(),
            n_sym: 0,
        }
    }

    pub fn len(&self) -> usize {
        self.coords.len()
    }

    pub fn is_empty(&self) -> bool {
        self.coords.is_empty()
    }

    /// For each row r of Z, the (coordinate, column in Z, coefficient) of every
    /// basis entry lying in that row, coordinates ascending.
    fn by_row(&self) -> Vec<Vec<(usize, usize, f64)>> {
        let mut rows = vec![Vec::new(); self.m];
        for (p, c) in self.coords.iter().enumerate() {
            for e in c.entries() {
                rows[e.row].push((p, c.block * self.m + e.col, e.coef));
            }
        }
        rows
    }

    /// Lower triangle (p ≥ q) of G = Tᵀ(I⊗H)T + diag(4λ_b² on skew coordinates),
    /// written column-major into `g` (len n², zero on entry).
    ///
    /// G_pq = Σ c_e c_e' H[col_e, col_e'] over entries e of p and e' of q in the same
    /// row of Z; only coordinates sharing a row are visited, so the cost is
    /// O(n·m) plus the zero fill.
    pub fn assemble(&self, h: MatRef<f64>, lam: [f64; 3], g: &mut [f64]) {
        let n = self.len();
        assert_eq!(g.len(), n * n);
        let rows = self.by_row();
        g.par_chunks_mut(n).enumerate().for_each(|(q, col)| {
            let cq = self.coords[q];
            for eq in cq.entries() {
                let hc = cq.block * self.m + eq.col;
                let list = &rows[eq.row];
                let start = list.partition_point(|&(p, _, _)| p < q);
                for &(p, hr, coef) in &list[start..] {
                    col[p] += coef * eq.coef * h[(hr, hc)];
                }
            }
            if cq.kind == Kind::Skew {
                col[q] += 4.0 * lam[cq.block] * lam[cq.block];
            }
        });
    }

    /// Right-hand side b_p = Σ c_e B[row_e, col_e] (B is m×3m).
    pub fn rhs(&self, b: MatRef<f64>) -> Vec<f64> {
        self.coords
            .iter()
            .map(|c| {
                c.entries()
                    .map(|e| e.coef * b[(e.row, c.block * self.m + e.col)])
                    .sum()
            })
            .collect()
    }

    /// Z = [X_M X_C X_K] (m×3m) from the coordinates x.
    pub fn to_blocks(&self, x: &[f64]) -> Mat<f64> {
        let mut z = Mat::zeros(self.m, 3 * self.m);
        for (c, &v) in self.coords.iter().zip(x) {
            for e in c.entries() {
                z[(e.row, c.block * self.m + e.col)] += e.coef * v;
            }
        }
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_counts_and_orthonormality() {
        for m in 1..6 {
            for sym in [false, true] {
                let basis = Basis::new(m, sym);
                assert_eq!(basis.len(), n_unknowns(m, sym));
                // to_blocks of unit vectors gives orthonormal matrices
                let mats: Vec<Mat<f64>> = (0..basis.len())
                    .map(|p| {
                        let mut x = vec![0.0; basis.len()];
                        x[p] = 1.0;
                        basis.to_blocks(&x)
                    })
                    .collect();
                for (p, a) in mats.iter().enumerate() {
                    for (q, b) in mats.iter().enumerate() {
                        let mut dot = 0.0;
                        for i in 0..m {
                            for j in 0..3 * m {
                                dot += a[(i, j)] * b[(i, j)];
                            }
                        }
                        let want = if p == q { 1.0 } else { 0.0 };
                        assert!((dot - want).abs() < 1e-15, "m={m} p={p} q={q} dot={dot}");
                    }
                }
            }
        }
    }

    /// G from the sparse assembly equals Tᵀ (I⊗H) T built entry by entry.
    #[test]
    fn assemble_matches_explicit_quadratic_form() {
        let m = 3;
        let h = Mat::from_fn(3 * m, 3 * m, |i, j| {
            let (a, b) = (i.min(j) as f64, i.max(j) as f64);
            1.0 / (1.0 + a + 2.0 * b) + if i == j { 3.0 } else { 0.0 }
        });
        let lam = [0.5, 0.0, 2.0];
        let basis = Basis::new(m, false);
        let n = basis.len();
        let mut g = vec![0.0; n * n];
        basis.assemble(h.as_ref(), lam, &mut g);
        for q in 0..n {
            for p in q..n {
                let (mut xp, mut xq) = (vec![0.0; n], vec![0.0; n]);
                xp[p] = 1.0;
                xq[q] = 1.0;
                let (zp, zq) = (basis.to_blocks(&xp), basis.to_blocks(&xq));
                // Σ_r zp[r,:] H zq[r,:]ᵀ
                let mut want = 0.0;
                for r in 0..m {
                    for a in 0..3 * m {
                        for b in 0..3 * m {
                            want += zp[(r, a)] * h[(a, b)] * zq[(r, b)];
                        }
                    }
                }
                if p == q && basis.coords[p].kind == Kind::Skew {
                    let l = lam[basis.coords[p].block];
                    want += 4.0 * l * l;
                }
                let got = g[q * n + p];
                assert!((got - want).abs() < 1e-13, "p={p} q={q}: {got} vs {want}");
            }
        }
    }
}
