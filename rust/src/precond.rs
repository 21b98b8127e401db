//! The preconditioner of the matrix-free solver (docs/design.md §4), and the basis it lives in.
//!
//! Let Q be the eigenvectors of S = H_MM + H_CC + H_KK (m×m), refined to
//! diagonalise the three blocks together ([`crate::joint`]). In the variables
//! X̃_b = Qᵀ X_b Q the data term is still a row operator, Z̃ ↦ Z̃ H̃ with
//! H̃ = (I₃⊗Q)ᵀ H (I₃⊗Q), and the penalty and the symmetric projection are
//! unchanged (Q is orthogonal, so X̃ − X̃ᵀ = Qᵀ(X − Xᵀ)Q). The approximation:
//! keep of every block H̃_bb' only its diagonal. Then column k of every row sees
//! the 3×3 matrix D(k)[b][b'] = H̃[bm+k, b'm+k], and the operator decouples
//! into independent systems per entry pair: in the pair's sym/skew coordinates
//! (σ, τ) of [`crate::pairs`],
//!
//! ```text
//!   [ A    C     ] [σ]        A = (D(j) + D(k))/2
//!   [ C    A + Λ ] [τ]        C = (D(k) − D(j))/2,   Λ = diag(4λ̃_b²)
//! ```
//!
//! (6×6; the exact-symmetric mode keeps the 3×3 A, a diagonal entry j = k the
//! 3×3 D(j)). It is exact when Q diagonalises every block of H at once. The
//! skew blocks ±T₁, ±T₃ of H have zero diagonal in any orthonormal basis, so
//! their coupling is the part always left out. The solver works in the Q basis
//! throughout, so each preconditioner application costs O(m²), not O(m³).

use crate::gram::{mirror_lower, HBlocks};
use crate::joint;
use crate::pairs::{Layout, TILE};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Orthonormal eigenvectors (columns) of the symmetric m×m matrix `s` (lower triangle read).
pub fn eigenvectors(s: MatRef<f64>, par: Par) -> Result<Mat<f64>, String> {
    let m = s.nrows();
    let mut u = Mat::zeros(m, m);
    let mut w = faer::diag::Diag::<f64>::zeros(m);
    let params = Default::default();
    let mut mem = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
        m,
        ComputeEigenvectors::Yes,
        par,
        params,
    ));
    self_adjoint_evd(
        s,
        w.as_mut(),
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .map_err(|e| format!("eigendecomposition for the preconditioner failed: {e:?}"))?;
    Ok(u)
}

/// Block-Jacobi sweeps of the joint diagonalisation refining Q.
pub const JOINT_SWEEPS: usize = 1;

/// Q is refined only if some diagonal block of H keeps more than this fraction
/// of its (squared Frobenius) norm off the diagonal in the eigenbasis of their
/// sum. Measured on the full-order chain, m = 100–1000: 0.03–0.4 % on the 20 %
/// band, where a sweep saved 0–9 % of the CG iterations at about its own cost,
/// and 1.7–2.1 % on 50–150 Hz, where it halved them.
pub const JOINT_MIN_OFF: f64 = 0.01;

/// ‖off(a)‖²_F / ‖a‖²_F.
fn off_fraction(a: MatRef<f64>) -> f64 {
    let (mut off, mut all) = (0.0, 0.0);
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            let v = a[(i, j)] * a[(i, j)];
            all += v;
            if i != j {
                off += v;
            }
        }
    }
    if all > 0.0 {
        off / all
    } else {
        0.0
    }
}

/// Qᵀ A Q for A (m×m) symmetric (`sign` = 1) or antisymmetric (−1): A Q by one
/// GEMM, of Qᵀ(A Q) only the lower triangle (a triangular product, half a
/// GEMM), mirrored with `sign`, so the result is exactly (anti)symmetric.
/// `aq` (m×m) is scratch for A Q, shared by a run of congruences (each fresh
/// m×m is first-touch page faults).
fn congruence(a: MatRef<f64>, q: MatRef<f64>, sign: f64, par: Par, aq: &mut Mat<f64>) -> Mat<f64> {
    matmul(aq.as_mut(), Accum::Replace, a, q, 1.0, par);
    let mut out = Mat::zeros(q.nrows(), q.nrows());
    congruence_end(aq.as_ref(), q, sign, par, out.as_mut());
    out
}

/// [`congruence`] in place: A := Qᵀ A Q.
fn congruence_in_place(a: &mut Mat<f64>, q: MatRef<f64>, sign: f64, par: Par, aq: &mut Mat<f64>) {
    matmul(aq.as_mut(), Accum::Replace, a.as_ref(), q, 1.0, par);
    congruence_end(aq.as_ref(), q, sign, par, a.as_mut());
}

/// out = Qᵀ (A Q), its lower triangle by a triangular product, mirrored.
fn congruence_end(aq: MatRef<f64>, q: MatRef<f64>, sign: f64, par: Par, mut out: MatMut<f64>) {
    triangular::matmul(
        out.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        q.transpose(),
        BlockStructure::Rectangular,
        aq,
        BlockStructure::Rectangular,
        1.0,
        par,
    );
    mirror_lower(out, sign);
}

/// Q: eigenvectors of the sum of the three diagonal blocks of H (3m×3m), in
/// ascending order; when one eigenbasis leaves too much off their diagonals
/// ([`JOINT_MIN_OFF`], wide bands) refined by [`joint::refine`] to diagonalise
/// the three blocks (each scaled to unit trace) together, and ordered by the
/// frequency of each mode. Also returns the blocks Qᵀ H_bb Q it formed if Q was
/// not refined afterwards: [`to_basis`] needs them too (they are 3 of its 5
/// transforms, about 0.6 of an operator GEMM at m = 1000).
#[allow(clippy::type_complexity)]
pub fn basis_of(h: &HBlocks, par: Par) -> Result<(Mat<f64>, Option<[Mat<f64>; 3]>), String> {
    let m = h.m();
    let block = h.diagonal();
    let sum = Mat::from_fn(m, m, |i, j| (0..3).map(|b| block[b][(i, j)]).sum::<f64>());
    let mut q = eigenvectors(sum.as_ref(), par)?;
    let mut aq = Mat::zeros(m, m);
    let diag = block.map(|blk| congruence(blk, q.as_ref(), 1.0, par, &mut aq));
    if diag
        .iter()
        .all(|a| off_fraction(a.as_ref()) <= JOINT_MIN_OFF)
    {
        return Ok((q, Some(diag)));
    }
    let mut mats: Vec<Mat<f64>> = diag
        .into_iter()
        .enumerate()
        .map(|(b, a)| {
            let trace: f64 = (0..m).map(|i| block[b][(i, i)]).sum();
            let scale = if trace > 0.0 { 1.0 / trace } else { 1.0 };
            a * faer::Scale(scale)
        })
        .collect();
    joint::refine(&mut mats, &mut q, JOINT_SWEEPS, par);
    // order the modes by frequency, (Qᵀ H_KK Q)_kk / (Qᵀ H_CC Q)_kk ~ 1/ω_k²: the
    // Gauss–Seidel sweeps of [`crate::sgs`] then meet the modes that couple
    // most in turn (50–150 Hz: 11–14 % fewer iterations at m = 400–1000; on
    // the 20 % band, where the modes share one frequency, 5 % more)
    let key = |k: usize| mats[2][(k, k)] / mats[1][(k, k)];
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)));
    q = Mat::from_fn(m, m, |i, j| q[(i, order[j])]);
    Ok((q, None))
}

/// out = a·(I₃⊗Q) for a with 3m columns (one GEMM per block column).
fn right_blocks(a: MatRef<f64>, q: MatRef<f64>, transpose: bool, par: Par, mut out: MatMut<f64>) {
    let m = q.nrows();
    let q = if transpose { q.transpose() } else { q };
    for b in 0..3 {
        matmul(
            out.as_mut().subcols_mut(b * m, m),
            Accum::Replace,
            a.subcols(b * m, m),
            q,
            1.0,
            par,
        );
    }
}

/// (H̃, B̃) = ((I⊗Q)ᵀ H (I⊗Q), Qᵀ B (I⊗Q)) for H of the structure of
/// [`crate::gram`]: blocks S4, −T3, −S2 / T3, S2, −T1 / −S2, T1, S0 with S_k
/// symmetric and T_k antisymmetric. H̃ has the same structure and is returned
/// as its five distinct blocks, never assembled (9m² doubles, 72 MB at
/// m = 1000, of fresh memory the CG path does not need). Only those five are
/// transformed (15m³ flops, not 36m³ for all nine), each exactly
/// (anti)symmetric ([`congruence`]), so H̃ is exactly symmetric; `diag`, if
/// given, are the three diagonal ones already formed by [`basis_of`] (then 6m³).
/// H and B are taken by value: the results are written into their memory.
pub fn to_basis(
    mut h: HBlocks,
    mut b: Mat<f64>,
    q: MatRef<f64>,
    diag: Option<[Mat<f64>; 3]>,
    par: Par,
) -> (HBlocks, Mat<f64>) {
    let m = q.nrows();
    // every product goes into the memory of what it replaces, but for one
    // m×m and one m×3m scratch: fresh memory costs page faults
    let mut aq = Mat::zeros(m, m);
    match diag {
        Some([s4, s2, s0]) => (h.s4, h.s2, h.s0) = (s4, s2, s0),
        None => {
            for a in [&mut h.s4, &mut h.s2, &mut h.s0] {
                congruence_in_place(a, q, 1.0, par, &mut aq);
            }
        }
    }
    congruence_in_place(&mut h.t3, q, -1.0, par, &mut aq);
    congruence_in_place(&mut h.t1, q, -1.0, par, &mut aq);
    drop(aq);
    let mut qb = Mat::zeros(m, 3 * m);
    matmul(
        qb.as_mut(),
        Accum::Replace,
        q.transpose(),
        b.as_ref(),
        1.0,
        par,
    );
    right_blocks(qb.as_ref(), q, false, par, b.as_mut());
    (h, b)
}

/// Z := (I₃⊗Q) Z̃ (I₃⊗Qᵀ), i.e. X_b = Q X̃_b Qᵀ for every block of Z̃ (m×3m),
/// in place, with `scratch` (m×3m) for Q Z̃.
pub fn from_basis(mut z: MatMut<f64>, q: MatRef<f64>, par: Par, mut scratch: MatMut<f64>) {
    matmul(scratch.as_mut(), Accum::Replace, q, z.as_ref(), 1.0, par);
    right_blocks(scratch.as_ref(), q, true, par, z.as_mut());
}

/// Index of (i, j), j ≤ i, in a packed lower triangle stored row by row.
#[inline]
fn tri(i: usize, j: usize) -> usize {
    i * (i + 1) / 2 + j
}

/// In-place Cholesky L Lᵀ of a packed n×n SPD matrix, storing 1/L_ii on the
/// diagonal (the solves then multiply instead of divide). A pivot that is not
/// above `1e3·ε` times its diagonal entry (or a non-positive diagonal entry) is
/// replaced by that floor (by 1 if the entry is not positive), so the result
/// always defines an SPD approximate inverse: the preconditioner must stay SPD
/// even for degenerate data. The floor is relative to each entry's own diagonal,
/// since penalty rows can exceed data rows by 10¹⁵. Returns whether a pivot was
/// floored (then L Lᵀ is not the matrix given).
fn small_cholesky(a: &mut [f64], n: usize) -> bool {
    let mut floored = false;
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[tri(i, j)];
            for k in 0..j {
                s -= a[tri(i, k)] * a[tri(j, k)];
            }
            a[tri(i, j)] = if i == j {
                let d = a[tri(i, i)];
                let floor = if d > 0.0 && d.is_finite() {
                    1e3 * f64::EPSILON * d
                } else {
                    1.0
                };
                floored |= s.partial_cmp(&floor) != Some(std::cmp::Ordering::Greater);
                1.0 / s.max(floor).sqrt()
            } else {
                s * a[tri(j, j)]
            };
        }
    }
    floored
}

/// W = L⁻¹ in place, for a packed factor L from [`small_cholesky`] (whose
/// diagonal already holds 1/L_ii = W_ii), column by column.
fn invert(l: &mut [f64], n: usize) {
    let mut w = [0.0; MAX_PACKED];
    let w = &mut w[..l.len()];
    for j in 0..n {
        w[tri(j, j)] = l[tri(j, j)];
        for i in j + 1..n {
            let s: f64 = (j..i).map(|k| l[tri(i, k)] * w[tri(k, j)]).sum();
            w[tri(i, j)] = -s * l[tri(i, i)];
        }
    }
    l.copy_from_slice(w);
}

/// x ↦ W x (or Wᵀ x) for a stored inverse factor W = L⁻¹ (packed lower
/// triangle). Each output is an independent dot product: no chain of
/// dependent steps as in a substitution with L, which made the penalty mode's
/// 6×6 pair solves latency-bound (N is a constant, so the loops unroll: this
/// runs about twice per pair per triangular solve).
#[inline(always)]
pub fn inv_mul<const N: usize, T: Copy + Into<f64>>(
    w: &[T],
    x: &[f64; N],
    transpose: bool,
) -> [f64; N] {
    let w = &w[..N * (N + 1) / 2];
    let mut out = [0.0; N];
    if transpose {
        for (k, o) in out.iter_mut().enumerate() {
            let mut s = 0.0;
            for i in k..N {
                s += w[tri(i, k)].into() * x[i];
            }
            *o = s;
        }
    } else {
        for (i, o) in out.iter_mut().enumerate() {
            let mut s = 0.0;
            for k in 0..i + 1 {
                s += w[tri(i, k)].into() * x[k];
            }
            *o = s;
        }
    }
    out
}

/// Solve L Lᵀ x = r: x = Wᵀ W r.
#[inline]
fn small_solve<const N: usize, T: Copy + Into<f64>>(w: &[T], x: &mut [f64; N]) {
    *x = inv_mul::<N, T>(w, &inv_mul::<N, T>(w, x, false), true);
}

/// [`small_solve`] of a 3-vector stored in a slice.
#[inline]
fn solve3<T: Copy + Into<f64>>(l: &[T], x: &mut [f64]) {
    let mut v = [x[0], x[1], x[2]];
    small_solve::<3, T>(l, &mut v);
    x.copy_from_slice(&v);
}

/// Factor a small SPD block given as its packed lower triangle, stored as the
/// inverse W = L⁻¹ of its Cholesky factor ([`inv_mul`]); if a pivot had to be
/// floored, also return D − L Lᵀ (packed), the part the factor misses.
fn factor(a: &[f64], n: usize) -> (Packed, Option<Vec<f64>>) {
    let len = a.len();
    let mut l = [0.0; MAX_PACKED];
    l[..len].copy_from_slice(a);
    let floored = small_cholesky(&mut l[..len], n).then(|| {
        let entry = |i: usize, k: usize| {
            if k == i {
                1.0 / l[tri(i, i)]
            } else {
                l[tri(i, k)]
            }
        };
        let mut delta = a.to_vec();
        for i in 0..n {
            for j in 0..=i {
                delta[tri(i, j)] -= (0..=j).map(|k| entry(i, k) * entry(j, k)).sum::<f64>();
            }
        }
        delta
    });
    invert(&mut l[..len], n);
    (l, floored)
}

/// x ↦ L x (or Lᵀ x) from the stored W = L⁻¹, by substitution (for
/// [`PairPrecond::mul_factor`]; the solves never need it).
#[inline]
fn small_mul<const N: usize, T: Copy + Into<f64>>(
    w: &[T],
    x: &[f64; N],
    transpose: bool,
) -> [f64; N] {
    let w = |i: usize| -> f64 { w[i].into() };
    let mut z = [0.0; N];
    if transpose {
        for i in (0..N).rev() {
            let s: f64 = (i + 1..N).map(|k| w(tri(k, i)) * z[k]).sum();
            z[i] = (x[i] - s) / w(tri(i, i));
        }
    } else {
        for i in 0..N {
            let s: f64 = (0..i).map(|k| w(tri(i, k)) * z[k]).sum();
            z[i] = (x[i] - s) / w(tri(i, i));
        }
    }
    z
}

/// Storage of the pairs' inverse factors W = R⁻¹. Single precision: they are
/// the bulk of the bytes the triangular solves stream (21 values per pair in
/// the penalty mode, as many as its two packed vectors of 6), and rounding W
/// to f32 perturbs each pair block D by a relative ~1e-7 in its own scaling
/// (the entries of a triangular inverse factor keep their relative precision
/// under diagonal scaling, so a penalty 10¹⁵ above the data does not spill
/// into the data part) — the size of the single-precision couplings' error,
/// which the double-precision true residual corrects in the same way.
pub type PairFactor = f32;

/// A pair block whose factor was floored: its coordinates and D − L Lᵀ.
struct Correction {
    coords: Vec<usize>,
    delta: Vec<f64>,
}

/// The pair-block preconditioner in the Q basis: the factors of the blocks D
/// (3×3 per diagonal entry, 3×3 or 6×6 per pair) that the symmetric Gauss–Seidel
/// preconditioner of [`crate::sgs`] uses as its diagonal.
pub struct PairPrecond {
    layout: Layout,
    /// W = R⁻¹ for the Cholesky factor R of D(j), 6 doubles per j ([`factor`])
    diag: Vec<f64>,
    /// W = R⁻¹ of the pair block, 6 (symmetric: A) or 21 (6×6) values per
    /// pair, in single precision (see [`PairFactor`])
    pairs: Vec<PairFactor>,
    /// blocks whose factor had to be floored (degenerate data; usually none)
    corrections: Vec<Correction>,
}

/// Values of a packed lower triangle of at most 6×6 (the first n(n+1)/2 used):
/// on the stack, since the set-up factors one per pair (500 000 at m = 1000:
/// with three heap vectors per pair the penalty mode's factors took 0.22 s,
/// on the stack 0.17 s, load 5).
const MAX_PACKED: usize = 21;
type Packed = [f64; MAX_PACKED];

/// Packed lower triangle of the n×n matrix f(i, j) (first n(n+1)/2 values).
fn packed(n: usize, f: &dyn Fn(usize, usize) -> f64) -> Packed {
    let mut out = [0.0; MAX_PACKED];
    for i in 0..n {
        for j in 0..=i {
            out[tri(i, j)] = f(i, j);
        }
    }
    out
}

impl PairPrecond {
    /// From H̃ (by its blocks, in the Q basis) and the squared penalty weights Λ_b = 4λ̃_b².
    pub fn new(ht: &HBlocks, layout: Layout, pen: [f64; 3]) -> PairPrecond {
        let m = layout.m;
        let n_pairs = layout.n_pairs();
        let d: Vec<[[f64; 3]; 3]> = (0..m)
            .map(|k| {
                let mut dk = [[0.0; 3]; 3];
                for (b, row) in dk.iter_mut().enumerate() {
                    for (c, v) in row.iter_mut().enumerate() {
                        *v = ht.entry(b * m + k, c * m + k);
                    }
                }
                dk
            })
            .collect();
        let mut corrections = Vec::new();
        let mut diag = Vec::with_capacity(6 * m);
        for (j, dk) in d.iter().enumerate() {
            let (l, delta) = factor(&packed(3, &|i, c| dk[i][c])[..6], 3);
            diag.extend(&l[..6]);
            if let Some(delta) = delta {
                let coords = (0..3).map(|b| 3 * j + b).collect();
                corrections.push(Correction { coords, delta });
            }
        }
        let width = if layout.symmetric { 6 } else { 21 };
        let mut pairs: Vec<PairFactor> = vec![0.0; width * n_pairs];
        let cols = layout.split_by_tile_column(&mut pairs, width);
        let floored: Vec<Correction> = cols
            .into_par_iter()
            .enumerate()
            .flat_map_iter(|(tk, run)| {
                let first = layout.pair_of_tile_column(tk);
                let mut floored = Vec::new();
                for k in tk * TILE..(tk * TILE + TILE).min(m) {
                    for j in 0..k {
                        let p = layout.pair(j, k);
                        let out = &mut run[width * (p - first)..width * (p - first + 1)];
                        let a = |i: usize, c: usize| 0.5 * (d[j][i][c] + d[k][i][c]);
                        let (block, delta) = if layout.symmetric {
                            factor(&packed(3, &|i, c| a(i, c))[..6], 3)
                        } else {
                            let cc = |i: usize, c: usize| 0.5 * (d[k][i][c] - d[j][i][c]);
                            let full = |i: usize, c: usize| match (i < 3, c < 3) {
                                (true, true) => a(i, c),
                                (false, true) => cc(i - 3, c),
                                (true, false) => cc(i, c - 3),
                                (false, false) => {
                                    a(i - 3, c - 3) + if i == c { pen[i - 3] } else { 0.0 }
                                }
                            };
                            factor(&packed(6, &full)[..21], 6)
                        };
                        for (o, v) in out.iter_mut().zip(&block) {
                            *o = *v as PairFactor;
                        }
                        if let Some(delta) = delta {
                            let sigma = (0..3).map(|b| 3 * m + 3 * p + b);
                            let tau = (0..3).map(|b| 3 * m + 3 * n_pairs + 3 * p + b);
                            let coords = if layout.symmetric {
                                sigma.collect()
                            } else {
                                sigma.chain(tau).collect()
                            };
                            floored.push(Correction { coords, delta });
                        }
                    }
                }
                floored
            })
            .collect();
        corrections.extend(floored);
        PairPrecond {
            layout,
            diag,
            pairs,
            corrections,
        }
    }

    /// The packed factors of the pairs p_lo..p_hi.
    pub fn pair_factors(&self, p_lo: usize, p_hi: usize) -> &[PairFactor] {
        let width = if self.layout.symmetric { 6 } else { 21 };
        &self.pairs[width * p_lo..width * p_hi]
    }

    /// The packed factors of the diagonal entries j_lo..j_hi.
    pub fn diag_factors(&self, j_lo: usize, j_hi: usize) -> &[f64] {
        &self.diag[6 * j_lo..6 * j_hi]
    }

    /// The packed factor of D(j), the block of diagonal entry j (3×3).
    #[inline]
    pub fn diag_factor(&self, j: usize) -> &[f64] {
        &self.diag[6 * j..6 * j + 6]
    }

    /// The packed factor of the block of pair p: 3×3 (exact-symmetric mode)
    /// or 6×6 on (σ, τ) (penalty mode).
    #[inline]
    pub fn pair_factor(&self, p: usize) -> &[PairFactor] {
        let width = if self.layout.symmetric { 6 } else { 21 };
        &self.pairs[width * p..width * p + width]
    }

    /// out = R v (or Rᵀ v) for the block-diagonal Cholesky factor R of D = R Rᵀ
    /// (not used by the solves, which need only R⁻¹: a check for tests).
    pub fn mul_factor(&self, v: &[f64], out: &mut [f64], transpose: bool) {
        let lay = self.layout;
        let (vd, vs, vk) = lay.split(v);
        let (od, os, ok) = lay.split_mut(out);
        for ((o, x), l) in od
            .chunks_exact_mut(3)
            .zip(vd.chunks_exact(3))
            .zip(self.diag.chunks_exact(6))
        {
            o.copy_from_slice(&small_mul::<3, _>(l, &[x[0], x[1], x[2]], transpose));
        }
        const CH: usize = 1024;
        if lay.symmetric {
            os.par_chunks_mut(3 * CH)
                .zip(vs.par_chunks(3 * CH))
                .zip(self.pairs.par_chunks(6 * CH))
                .for_each(|((os, vs), ls)| {
                    let it = os.chunks_exact_mut(3).zip(vs.chunks_exact(3));
                    for ((o, x), l) in it.zip(ls.chunks_exact(6)) {
                        o.copy_from_slice(&small_mul::<3, _>(l, &[x[0], x[1], x[2]], transpose));
                    }
                });
        } else {
            os.par_chunks_mut(3 * CH)
                .zip(ok.par_chunks_mut(3 * CH))
                .zip(vs.par_chunks(3 * CH).zip(vk.par_chunks(3 * CH)))
                .zip(self.pairs.par_chunks(21 * CH))
                .for_each(|(((os, ok), (vs, vk)), ls)| {
                    let outs = os.chunks_exact_mut(3).zip(ok.chunks_exact_mut(3));
                    let ins = vs.chunks_exact(3).zip(vk.chunks_exact(3));
                    for (((s, t), (x, y)), l) in outs.zip(ins).zip(ls.chunks_exact(21)) {
                        let v6 = [x[0], x[1], x[2], y[0], y[1], y[2]];
                        let r = small_mul::<6, _>(l, &v6, transpose);
                        s.copy_from_slice(&r[..3]);
                        t.copy_from_slice(&r[3..]);
                    }
                });
        }
    }

    /// w += (D − R Rᵀ) t on the blocks whose factor was floored (none for
    /// non-degenerate data), so that D + L + Lᵀ stays the operator exactly.
    pub fn correct(&self, t: &[f64], w: &mut [f64]) {
        for c in &self.corrections {
            let n = c.coords.len();
            for i in 0..n {
                for j in 0..n {
                    let d = if j <= i {
                        c.delta[tri(i, j)]
                    } else {
                        c.delta[tri(j, i)]
                    };
                    w[c.coords[i]] += d * t[c.coords[j]];
                }
            }
        }
    }

    /// Doubles held by the factors (for the memory estimate; the pairs' single
    /// precision values count half, rounded up).
    pub fn doubles(layout: Layout) -> usize {
        let pair_values = if layout.symmetric { 6 } else { 21 } * layout.n_pairs();
        6 * layout.m + (pair_values * std::mem::size_of::<PairFactor>()).div_ceil(8)
    }

    /// z = P⁻¹ r.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let lay = self.layout;
        z.copy_from_slice(r);
        let (zd, zs, zk) = lay.split_mut(z);
        for (x, l) in zd.chunks_exact_mut(3).zip(self.diag.chunks_exact(6)) {
            solve3(l, x);
        }
        if lay.symmetric {
            zs.par_chunks_mut(3 * 1024)
                .zip(self.pairs.par_chunks(6 * 1024))
                .for_each(|(xs, ls)| {
                    for (x, l) in xs.chunks_exact_mut(3).zip(ls.chunks_exact(6)) {
                        solve3(l, x);
                    }
                });
        } else {
            zs.par_chunks_mut(3 * 1024)
                .zip(zk.par_chunks_mut(3 * 1024))
                .zip(self.pairs.par_chunks(21 * 1024))
                .for_each(|((xs, xk), ls)| {
                    let it = xs.chunks_exact_mut(3).zip(xk.chunks_exact_mut(3));
                    for ((s, t), l) in it.zip(ls.chunks_exact(21)) {
                        let mut x = [s[0], s[1], s[2], t[0], t[1], t[2]];
                        small_solve::<6, _>(l, &mut x);
                        s.copy_from_slice(&x[..3]);
                        t.copy_from_slice(&x[3..]);
                    }
                });
        }
    }
}
