//! The vector space of the matrix-free solver: the coordinates of Z = [X_M X_C X_K]
//! (m×3m) in each block's orthonormal symmetric/skew basis (the basis of
//! [`crate::normal`]), stored flat and pair-major so that the preconditioner's
//! small solves read contiguous memory.
//!
//! Layout of a vector of [`Layout::len`] doubles:
//!
//! ```text
//!   diag  3m   : X_b[j,j]                              at 3j + b
//!   sym   3P   : σ = (X_b[j,k] + X_b[k,j])/√2, j < k    at 3m + 3p + b
//!   skew  3P   : τ = (X_b[j,k] − X_b[k,j])/√2, j < k    at 3m + 3P + 3p + b   (penalty mode only)
//! ```
//!
//! with P = m(m−1)/2 pairs numbered p = [`Layout::pair`](j, k) in tiles: the
//! modes are grouped in tiles of [`TILE`], the pairs of tile rows J ≤ tile
//! column K form tile (J, K), tiles are stored column by column (K, then J) and
//! each tile's pairs column by column. A tile is the leaf of the Gauss–Seidel
//! recursion of [`crate::sgs`], whose data are then contiguous; a tile column
//! holds exactly the pairs (j, k) with k in tile K. The map between the entries
//! (X[j,k], X[k,j]) and (σ, τ) is an orthogonal involution, so the Euclidean
//! inner product of coordinates is the Frobenius inner product of the matrices,
//! and [`Layout::pack`] of a dense m×3m matrix is the adjoint of [`Layout::unpack`].
//! In the exact-symmetric mode the skew coordinates do not exist: pack projects
//! onto block-symmetric matrices.

use faer::{ColMut, MatMut, MatRef};
use rayon::prelude::*;

const RSQRT2: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Modes per tile of the pair numbering (the leaf size of [`crate::sgs`]).
pub const TILE: usize = 4;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub m: usize,
    pub symmetric: bool,
}

impl Layout {
    pub fn new(m: usize, symmetric: bool) -> Layout {
        Layout { m, symmetric }
    }

    /// Number of pairs j < k.
    pub fn n_pairs(&self) -> usize {
        self.m * self.m.saturating_sub(1) / 2
    }

    /// Index of the pair (j, k), j < k (see the module notes).
    #[inline]
    pub fn pair(&self, j: usize, k: usize) -> usize {
        debug_assert!(j < k && k < self.m);
        let (tj, tk) = (j / TILE, k / TILE);
        let k0 = tk * TILE;
        let nk = TILE.min(self.m - k0);
        let base = k0 * k0.saturating_sub(1) / 2 + tj * TILE * nk;
        let (c, r) = (k - k0, j - tj * TILE);
        if tj < tk {
            Self::in_tile(base, r, c)
        } else {
            base + c * c.saturating_sub(1) / 2 + r
        }
    }

    /// Index of the pair (j₀ + r, k₀ + c) of an off-diagonal tile (J < K) whose
    /// first pair (j₀, k₀) has index `first`: its pairs are stored column by column.
    #[inline]
    pub fn in_tile(first: usize, r: usize, c: usize) -> usize {
        first + c * TILE + r
    }

    /// Number of coordinates: 3m(m+1)/2 (exact-symmetric) or 3m².
    pub fn len(&self) -> usize {
        let half = 3 * self.m + 3 * self.n_pairs();
        if self.symmetric {
            half
        } else {
            half + 3 * self.n_pairs()
        }
    }

    pub fn is_empty(&self) -> bool {
        self.m == 0
    }

    /// Split a vector into its (diag, sym, skew) parts; skew is empty when symmetric.
    pub fn split<'a>(&self, x: &'a [f64]) -> (&'a [f64], &'a [f64], &'a [f64]) {
        let (diag, rest) = x.split_at(3 * self.m);
        let (sym, skew) = rest.split_at(3 * self.n_pairs());
        (diag, sym, skew)
    }

    pub fn split_mut<'a>(&self, x: &'a mut [f64]) -> (&'a mut [f64], &'a mut [f64], &'a mut [f64]) {
        let (diag, rest) = x.split_at_mut(3 * self.m);
        let (sym, skew) = rest.split_at_mut(3 * self.n_pairs());
        (diag, sym, skew)
    }

    /// Z (m×3m) from the coordinates x. Parallel over c, writing column c of all
    /// three blocks at once so that each pair's three values are read together.
    pub fn unpack(&self, x: &[f64], z: MatMut<f64>) {
        let m = self.m;
        assert!(x.len() == self.len() && z.nrows() == m && z.ncols() == 3 * m);
        let (diag, sym, skew) = self.split(x);
        let (z0, rest) = z.split_at_col_mut(m);
        let (z1, z2) = rest.split_at_col_mut(m);
        z0.par_col_iter_mut()
            .zip(z1.par_col_iter_mut())
            .zip(z2.par_col_iter_mut())
            .enumerate()
            .for_each(|(c, ((a, b), d))| {
                let mut cols = [a, b, d].map(dense);
                // rows r < c: upper entry of pair (r, c)
                for r in 0..c {
                    let i = 3 * self.pair(r, c);
                    for (blk, col) in cols.iter_mut().enumerate() {
                        let t = if self.symmetric { 0.0 } else { skew[i + blk] };
                        col[r] = RSQRT2 * (sym[i + blk] + t);
                    }
                }
                for (blk, col) in cols.iter_mut().enumerate() {
                    col[c] = diag[3 * c + blk];
                }
                // rows r > c: lower entry of pair (c, r)
                for r in c + 1..m {
                    let i = 3 * self.pair(c, r);
                    for (blk, col) in cols.iter_mut().enumerate() {
                        let t = if self.symmetric { 0.0 } else { skew[i + blk] };
                        col[r] = RSQRT2 * (sym[i + blk] - t);
                    }
                }
            });
    }

    /// Coordinates of Y (m×3m) into x; in the exact-symmetric mode only its
    /// block-symmetric part is kept. Parallel over the tile columns.
    pub fn pack(&self, y: MatRef<f64>, x: &mut [f64]) {
        let m = self.m;
        assert!(x.len() == self.len() && y.nrows() == m && y.ncols() == 3 * m);
        let symmetric = self.symmetric;
        let (diag, sym, skew) = self.split_mut(x);
        for (j, d) in diag.chunks_exact_mut(3).enumerate() {
            for (b, v) in d.iter_mut().enumerate() {
                *v = y[(j, b * m + j)];
            }
        }
        let sym_cols = self.split_by_tile_column(sym, 3);
        let skew_cols = if symmetric {
            (0..sym_cols.len()).map(|_| &mut [][..]).collect()
        } else {
            self.split_by_tile_column(skew, 3)
        };
        sym_cols
            .into_par_iter()
            .zip(skew_cols)
            .enumerate()
            .for_each(|(tk, (sk, tau))| {
                let first = self.pair_of_tile_column(tk);
                for k in tk * TILE..(tk * TILE + TILE).min(m) {
                    for j in 0..k {
                        let at = 3 * (self.pair(j, k) - first);
                        for b in 0..3 {
                            let (up, lo) = (y[(j, b * m + k)], y[(k, b * m + j)]);
                            sk[at + b] = RSQRT2 * (up + lo);
                            if !symmetric {
                                tau[at + b] = RSQRT2 * (up - lo);
                            }
                        }
                    }
                }
            });
    }

    /// Number of tiles along each side.
    pub fn n_tiles(&self) -> usize {
        self.m.div_ceil(TILE)
    }

    /// Index of the first pair of tile column `tk` (pairs (j, k), k in that tile).
    pub fn pair_of_tile_column(&self, tk: usize) -> usize {
        let k0 = tk * TILE;
        k0 * k0.saturating_sub(1) / 2
    }

    /// Split a pair-major array (`width` values per pair) into the runs of its
    /// tile columns.
    pub fn split_by_tile_column<'a, T>(
        &self,
        mut a: &'a mut [T],
        width: usize,
    ) -> Vec<&'a mut [T]> {
        let nt = self.n_tiles();
        let mut out = Vec::with_capacity(nt);
        for tk in 0..nt {
            let end = if tk + 1 < nt {
                self.pair_of_tile_column(tk + 1)
            } else {
                self.n_pairs()
            };
            let len = width * (end - self.pair_of_tile_column(tk));
            let (head, tail) = std::mem::take(&mut a).split_at_mut(len);
            out.push(head);
            a = tail;
        }
        out
    }
}

/// A column of a column-major matrix as a slice.
fn dense(col: ColMut<'_, f64>) -> &mut [f64] {
    col.try_as_col_major_mut()
        .expect("dense column")
        .as_slice_mut()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::normal::Basis;
    use faer::Mat;

    fn z_of(m: usize, seed: u64) -> Mat<f64> {
        Mat::from_fn(m, 3 * m, |i, j| {
            (((i * 31 + j * 17) as u64 * 2654435761 + seed) % 1000) as f64 / 500.0 - 1.0
        })
    }

    /// The tiled numbering is a bijection onto 0..P that keeps each tile and
    /// each tile column contiguous.
    #[test]
    fn pair_numbering_is_tiled_and_complete() {
        for m in [1, 2, TILE, TILE + 1, 3 * TILE + 2, 5 * TILE] {
            let lay = Layout::new(m, true);
            let mut seen = vec![false; lay.n_pairs()];
            for k in 0..m {
                for j in 0..k {
                    let p = lay.pair(j, k);
                    assert!(!seen[p], "m={m}: ({j}, {k}) numbered twice");
                    seen[p] = true;
                    let tk = k / TILE;
                    assert!(p >= lay.pair_of_tile_column(tk));
                    if tk + 1 < lay.n_tiles() {
                        assert!(p < lay.pair_of_tile_column(tk + 1));
                    }
                }
            }
            assert!(seen.iter().all(|&s| s), "m={m}");
            // a full off-diagonal tile is one run of TILE² pairs
            if m >= 2 * TILE {
                let first = lay.pair(0, TILE);
                let ps: Vec<usize> = (TILE..2 * TILE)
                    .flat_map(|k| (0..TILE).map(move |j| (j, k)))
                    .map(|(j, k)| lay.pair(j, k) - first)
                    .collect();
                assert_eq!(ps, (0..TILE * TILE).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn unpack_of_pack_is_identity_in_penalty_mode() {
        for m in 1..7 {
            let lay = Layout::new(m, false);
            assert_eq!(lay.len(), 3 * m * m);
            let z = z_of(m, 3);
            let mut x = vec![0.0; lay.len()];
            lay.pack(z.as_ref(), &mut x);
            // orthogonal: same norm
            let nx: f64 = x.iter().map(|v| v * v).sum();
            assert!((nx - z.norm_l2().powi(2)).abs() < 1e-12);
            let mut back = Mat::zeros(m, 3 * m);
            lay.unpack(&x, back.as_mut());
            assert!((&back - &z).norm_l2() < 1e-14);
        }
    }

    #[test]
    fn symmetric_pack_projects_onto_block_symmetric_matrices() {
        let m = 5;
        let lay = Layout::new(m, true);
        assert_eq!(lay.len(), 3 * m * (m + 1) / 2);
        let z = z_of(m, 7);
        let mut x = vec![0.0; lay.len()];
        lay.pack(z.as_ref(), &mut x);
        let mut back = Mat::zeros(m, 3 * m);
        lay.unpack(&x, back.as_mut());
        for b in 0..3 {
            for i in 0..m {
                for j in 0..m {
                    let want = 0.5 * (z[(i, b * m + j)] + z[(j, b * m + i)]);
                    assert!((back[(i, b * m + j)] - want).abs() < 1e-14);
                }
            }
        }
    }

    /// The coordinates are those of `normal::Basis` (same basis matrices, another order).
    #[test]
    fn coordinates_match_the_direct_paths_basis() {
        let m = 4;
        for symmetric in [false, true] {
            let lay = Layout::new(m, symmetric);
            let basis = Basis::new(m, symmetric);
            let z = z_of(m, 11);
            let mut x = vec![0.0; lay.len()];
            lay.pack(z.as_ref(), &mut x);
            let from_basis = basis.rhs(z.as_ref());
            let mut a: Vec<f64> = x.clone();
            let mut b = from_basis.clone();
            a.sort_by(f64::total_cmp);
            b.sort_by(f64::total_cmp);
            for (u, v) in a.iter().zip(&b) {
                assert!((u - v).abs() < 1e-14, "symmetric={symmetric}");
            }
        }
    }
}
