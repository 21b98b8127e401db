//! The dense Gauss–Newton step: N_θ formed explicitly (docs/design.md §6), factored by
//! Cholesky.
//!
//! In Z-coordinates N_Z[(r,c),(r',c')] = Re Σ_k G_k[r,r'] κ_bb'(ω_k) X̄_k[c,c'] for
//! columns c, c' in blocks b, b', with X̄ = Σ_j w_j² conj(x_j) x_jᵀ over the term's
//! columns and κ_bb' = conj(φ_b) φ_b' for φ = (−ω², iω, 1): only five moments
//! ω⁰ … ω⁴ occur. G and X̄ are Hermitian, so the sums split into four real GEMMs
//! over the pairs r ≤ r', c ≤ c' — ≈ 5m⁴ flops per term. The congruence
//! N_θ = Pᵀ N_Z P uses the structure of the tangent map, P = (I + Π)(I ⊗ L) on the
//! lower triangle (Π the transpose): per block pair two GEMMs of 2m⁵ flops on the
//! symmetrised N_Z, plus the rank-one terms of the floor ε tr(L Lᵀ) I.
//! Memory: the moments (m(m+1)/2 × 5m(m+1)/2, twice), O(m⁴), and N_θ.

use super::curvature::Curvature;
use super::lines;
use super::lines::{line_pieces, response_weight, terms_per_line};
use super::objective::{Evaluation, Problem};
use super::parametrisation::{n_per_block, tri, Params, CONDITION_FLOOR};
use super::step_solver::StepSolver;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::matmul;
use faer::{c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;
use std::time::Instant;

/// Wall time of the parts of forming N_θ, seconds.
#[derive(Default, Clone, Copy)]
pub(crate) struct Clock {
    /// per-line pieces (D⁻¹, G, X̄) and the gradient
    pub lines: f64,
    /// the moment GEMMs
    pub gemm: f64,
    /// symmetrisation and congruence to θ
    pub congruence: f64,
}

/// N_θ of the current point, column-major.
#[derive(Default)]
pub(crate) struct DenseNormal {
    nth: Vec<f64>,
    clock: Clock,
    /// H, the parametrisation's curvature ([`super::curvature`]), when allowed
    curv: Option<Curvature>,
    curvature: bool,
    /// whether the next step uses N_θ + H
    use_curv: bool,
    /// the Cholesky factor of the last damped system (column-major, lower)
    factor: Vec<f64>,
}

impl DenseNormal {
    pub(crate) fn with_curvature(curvature: bool) -> Self {
        DenseNormal {
            curvature,
            ..Default::default()
        }
    }

    /// H when the next step uses it.
    fn used_curvature(&self) -> Option<&Curvature> {
        self.curv.as_ref().filter(|_| self.use_curv)
    }
}

impl StepSolver for DenseNormal {
    fn prepare(
        &mut self,
        pb: &Problem,
        params: &Params,
        l: &[Mat<f64>; 3],
        ev: &Evaluation,
        par: Par,
    ) -> Vec<f64> {
        let (nth, g, gz) = normal_equations(pb, params, l, ev, par, &mut self.clock);
        self.curv = match self.curvature {
            true => Curvature::new(params, l, &gz),
            false => None,
        };
        self.nth = nth;
        g
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("normal_lines", self.clock.lines),
            ("normal_gemm", self.clock.gemm),
            ("normal_congruence", self.clock.congruence),
        ]
    }

    fn step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        _cancelled: &mut dyn FnMut() -> bool,
    ) -> Option<Vec<f64>> {
        let (x, factor) = damped_step(&self.nth, self.used_curvature(), g, mu, par)?;
        self.factor = factor;
        Some(x)
    }

    fn solve_again(&mut self, rhs: &[f64], par: Par) -> Option<Vec<f64>> {
        let n = rhs.len();
        if self.factor.len() != n * n {
            return None;
        }
        let mut x = rhs.to_vec();
        let lower = MatRef::from_column_major_slice(&self.factor, n, n);
        let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, 1, par));
        llt::solve::solve_in_place(
            lower,
            MatMut::from_column_major_slice_mut(&mut x, n, 1),
            par,
            MemStack::new(&mut mem),
        );
        x.iter().all(|v| v.is_finite()).then_some(x)
    }

    fn set_curvature(&mut self, on: bool) {
        self.use_curv = on;
    }

    fn quad(&mut self, x: &[f64], _par: Par) -> f64 {
        let n = x.len();
        let mut hx = vec![0.0; n];
        if let Some(cv) = self.used_curvature() {
            cv.apply_add(x, &mut hx);
        }
        (0..n)
            .map(|j| x[j] * ((0..n).map(|i| self.nth[j * n + i] * x[i]).sum::<f64>() + hx[j]))
            .sum()
    }
}

/// Terms processed together when forming the moments (bounds memory).
const NORMAL_CHUNK: usize = 512;

/// Index of the pair (r, r') with r ≤ r' among the m(m+1)/2 pairs, row by row.
#[inline]
fn pair(r: usize, r2: usize, m: usize) -> usize {
    r * (2 * m - r - 1) / 2 + r2
}

/// Pair index and the sign of the imaginary part of a Hermitian entry (r, r').
#[inline]
fn pair_sign(r: usize, r2: usize, m: usize) -> (usize, f64) {
    if r <= r2 {
        (pair(r, r2, m), 1.0)
    } else {
        (pair(r2, r, m), -1.0)
    }
}

/// The moment sums over all terms (np = nx = m(m+1)/2 pairs):
/// `re` = Σ [Re X̄·ω⁰, Re X̄·ω², Re X̄·ω⁴, Im X̄·ω, Im X̄·ω³] ⊗ Re G,
/// `im` = Σ [Im X̄·ω⁰, Im X̄·ω², Im X̄·ω⁴, Re X̄·ω, Re X̄·ω³] ⊗ Im G,
/// each 5nx × np column-major: row slot·nx + pair(c, c'), column pair(r, r'), so
/// that a column holds every (c, c') of one (r, r') contiguously.
struct Moments {
    re: Mat<f64>,
    im: Mat<f64>,
    m: usize,
    /// pair index and imaginary sign of every (r, r'), row-major m×m
    pairs: Vec<(usize, f64)>,
}

impl Moments {
    /// N_Z entry [(r, c), (r', c')] of block pair (b, b'), b ≤ b':
    /// Re Σ G[r,r'] κ_bb' X̄[c,c'].
    #[inline]
    fn entry(&self, kind: (usize, f64), r: usize, c: usize, r2: usize, c2: usize) -> f64 {
        let m = self.m;
        let nx = m * (m + 1) / 2;
        let (pr, sr) = self.pairs[r * m + r2];
        let (pc, sc) = self.pairs[c * m + c2];
        let (q, sign) = kind;
        if q % 2 == 0 {
            // Re(G X̄) = Re G Re X̄ − Im G Im X̄
            let row = (q / 2) * nx + pc;
            sign * (self.re[(row, pr)] - sr * sc * self.im[(row, pr)])
        } else {
            // Re(i G X̄) = −(Re G Im X̄ + Im G Re X̄)
            let row = (3 + q / 2) * nx + pc;
            -sign * (sc * self.re[(row, pr)] + sr * self.im[(row, pr)])
        }
    }
}

/// κ_bb' = conj(φ_b) φ_b' as (power q of ω, sign), with iω^q for odd q:
/// (M,M) ω⁴, (M,C) −iω³, (M,K) −ω², (C,C) ω², (C,K) −iω, (K,K) 1.
fn kappa(b: usize, bp: usize) -> (usize, f64) {
    match (b, bp) {
        (0, 0) => (4, 1.0),
        (0, 1) => (3, -1.0),
        (0, 2) => (2, -1.0),
        (1, 1) => (2, 1.0),
        (1, 2) => (1, -1.0),
        (2, 2) => (0, 1.0),
        _ => unreachable!("block pairs are ordered b ≤ b'"),
    }
}

/// The moments and the gradient in Z, all lines.
fn moments(pb: &Problem, ev: &Evaluation, par: Par, clock: &mut Clock) -> (Moments, Mat<f64>) {
    let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
    let mm = m * m;
    let np = m * (m + 1) / 2;
    let nx = np;
    let tpl = terms_per_line(pb);
    let mut mo = Moments {
        re: Mat::zeros(5 * nx, np),
        im: Mat::zeros(5 * nx, np),
        m,
        pairs: (0..m * m).map(|q| pair_sign(q / m, q % m, m)).collect(),
    };
    let mut a_all = vec![c64::new(0.0, 0.0); s * p * m];
    let chunk_lines = (NORMAL_CHUNK / tpl).max(1);
    for start in (0..s).step_by(chunk_lines) {
        let nl = chunk_lines.min(s - start);
        let k = nl * tpl;
        // column-major buffers, one column per term
        let mut gre = vec![0.0; np * k];
        let mut gim = vec![0.0; np * k];
        let mut x1 = vec![0.0; 5 * nx * k];
        let mut x2 = vec![0.0; 5 * nx * k];
        let t0 = Instant::now();
        gre.par_chunks_mut(np * tpl)
            .zip(gim.par_chunks_mut(np * tpl))
            .zip(x1.par_chunks_mut(5 * nx * tpl))
            .zip(x2.par_chunks_mut(5 * nx * tpl))
            .zip(a_all[start * p * m..(start + nl) * p * m].par_chunks_mut(p * m))
            .enumerate()
            .for_each(|(li, ((((gre, gim), x1), x2), a))| {
                let i = start + li;
                let mut g = vec![c64::new(0.0, 0.0); tpl * mm];
                line_pieces(pb, ev, i, &mut g, a);
                let w = pb.w[i];
                let pw = [1.0, w * w, w.powi(4), w, w.powi(3)];
                let mut xbar = vec![c64::new(0.0, 0.0); nx];
                for t in 0..tpl {
                    let gt = &g[t * mm..(t + 1) * mm];
                    for r in 0..m {
                        for r2 in r..m {
                            let q = pair(r, r2, m);
                            gre[t * np + q] = gt[r * m + r2].re;
                            gim[t * np + q] = gt[r * m + r2].im;
                        }
                    }
                    // X̄ = Σ_j w_j² conj(x_j) x_jᵀ over the term's columns
                    xbar.iter_mut().for_each(|z| *z = c64::new(0.0, 0.0));
                    let cols = if tpl == 1 { 0..p } else { t..t + 1 };
                    for j in cols {
                        let col = i * p + j;
                        let sc = response_weight(pb, col);
                        let x = &ev.x[col * m..(col + 1) * m];
                        for c in 0..m {
                            let xc = x[c].conj() * sc;
                            for c2 in c..m {
                                xbar[pair(c, c2, m)] += xc * x[c2];
                            }
                        }
                    }
                    let (o1, o2) = (&mut x1[t * 5 * nx..], &mut x2[t * 5 * nx..]);
                    for (q, z) in xbar.iter().enumerate() {
                        for slot in 0..3 {
                            o1[slot * nx + q] = z.re * pw[slot];
                            o2[slot * nx + q] = z.im * pw[slot];
                        }
                        for slot in 3..5 {
                            o1[slot * nx + q] = z.im * pw[slot];
                            o2[slot * nx + q] = z.re * pw[slot];
                        }
                    }
                }
            });
        clock.lines += t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let gre = MatRef::from_column_major_slice(&gre, np, k);
        let gim = MatRef::from_column_major_slice(&gim, np, k);
        let x1 = MatRef::from_column_major_slice(&x1, 5 * nx, k);
        let x2 = MatRef::from_column_major_slice(&x2, 5 * nx, k);
        matmul(mo.re.as_mut(), Accum::Add, x1, gre.transpose(), 1.0, par);
        matmul(mo.im.as_mut(), Accum::Add, x2, gim.transpose(), 1.0, par);
        clock.gemm += t0.elapsed().as_secs_f64();
    }
    let t0 = Instant::now();
    let gz = lines::gradient_z(pb, ev, &a_all, par);
    clock.lines += t0.elapsed().as_secs_f64();
    (mo, gz)
}

/// Block (b, b') of N_θ (n_b × n_b, column-major), b ≤ b'.
fn block_pair(
    mo: &Moments,
    params: &Params,
    l: &[Mat<f64>; 3],
    b: usize,
    bp: usize,
    par: Par,
) -> Vec<f64> {
    let m = params.m;
    let (m2, m3) = (m * m, m * m * m);
    let nb = n_per_block(m);
    let kind = kappa(b, bp);
    let n = |r: usize, c: usize, r2: usize, c2: usize| mo.entry(kind, r, c, r2, c2);
    // N_Z of the block pair, row-major m² × m²: nz[(r m + c) m² + r' m + c']
    let mut nz = vec![0.0; m2 * m2];
    nz.par_chunks_mut(m * m2).enumerate().for_each(|(r, rows)| {
        for r2 in 0..m {
            for c in 0..m {
                for c2 in 0..m {
                    rows[c * m2 + r2 * m + c2] = n(r, c, r2, c2);
                }
            }
        }
    });
    // the floor: Y[r,c] = Σ_c' N[(r,c),(c',c')], Y'[r',c'] = Σ_c N[(c,c),(r',c')], e = Σ Y[c,c]
    let y = Mat::from_fn(m, m, |r, c| {
        let row = &nz[(r * m + c) * m2..(r * m + c + 1) * m2];
        (0..m).map(|c2| row[c2 * m + c2]).sum::<f64>()
    });
    let y2 = Mat::from_fn(m, m, |r2, c2| {
        (0..m)
            .map(|c| nz[(c * m + c) * m2 + r2 * m + c2])
            .sum::<f64>()
    });
    let e: f64 = (0..m).map(|c| y[(c, c)]).sum();
    // A[(j, j', c), c'] = Ñ[(j,c),(j',c')], Ñ = (I+Π) N (I+Π); row-major m³ × m
    let mut a = vec![0.0; m3 * m];
    a.par_chunks_mut(m3).enumerate().for_each(|(j, aj)| {
        for c in 0..m {
            let n1 = &nz[(j * m + c) * m2..(j * m + c + 1) * m2];
            let n2 = &nz[(c * m + j) * m2..(c * m + j + 1) * m2];
            for j2 in 0..m {
                let out = &mut aj[(j2 * m + c) * m..(j2 * m + c + 1) * m];
                for (c2, o) in out.iter_mut().enumerate() {
                    *o = n1[j2 * m + c2] + n2[j2 * m + c2] + n1[c2 * m + j2] + n2[c2 * m + j2];
                }
            }
        }
    });
    drop(nz);
    let (lb, lbp) = (&l[b], &l[bp]);
    // B = A L' (column-major m³ × m): B[(j,j',c), k'] = Σ_c' Ñ[(j,c),(j',c')] L'[c',k']
    let mut bcol = vec![0.0; m3 * m];
    matmul(
        MatMut::from_column_major_slice_mut(&mut bcol, m3, m),
        Accum::Replace,
        MatRef::from_row_major_slice(&a, m3, m),
        lbp.as_ref(),
        1.0,
        par,
    );
    drop(a);
    // read B as row-major m³ × m with row (j m + j') + m² k', column c; D = B L, formed
    // transposed (Dᵀ = Lᵀ Bᵀ, Bᵀ the same buffer column-major m × m³) so that the scatter
    // below reads each (j, j', k')'s m values of k contiguously
    let mut dt = Mat::<f64>::zeros(m, m3);
    matmul(
        dt.as_mut(),
        Accum::Replace,
        lb.transpose(),
        MatRef::from_column_major_slice(&bcol, m, m3),
        1.0,
        par,
    );
    drop(bcol);
    // u = P₀ᵀ Y, u' = P₀'ᵀ Y' (without the log scale, applied below)
    let p0t = |yy: &Mat<f64>, lx: &Mat<f64>| -> Vec<f64> {
        let mut out = vec![0.0; nb];
        for j in 0..m {
            for k in 0..=j {
                out[tri(j, k)] = (k..m).map(|c| (yy[(j, c)] + yy[(c, j)]) * lx[(c, k)]).sum();
            }
        }
        out
    };
    let (u, u2) = (p0t(&y, lb), p0t(&y2, lbp));
    let eps = CONDITION_FLOOR;
    // (j, k) of every lower-triangle index, and its θ scale in L_b
    let jk: Vec<(usize, usize)> = (0..m).flat_map(|j| (0..=j).map(move |k| (j, k))).collect();
    let s1: Vec<f64> = jk
        .iter()
        .map(|&(j, k)| lines::theta_scale(params, lb, j, k))
        .collect();
    let dt = dt.as_ref();
    let mut out = vec![0.0; nb * nb];
    out.par_chunks_mut(nb).enumerate().for_each(|(col, oc)| {
        let (j2, k2) = jk[col];
        let s2 = lines::theta_scale(params, lbp, j2, k2);
        let l2 = lbp[(j2, k2)];
        for j in 0..m {
            let d = dt.col((j * m + j2) + m2 * k2);
            for k in 0..=j {
                let row = tri(j, k);
                let l1 = lb[(j, k)];
                let v =
                    d[k] + 2.0 * eps * (l2 * u[row] + l1 * u2[col]) + 4.0 * eps * eps * l1 * l2 * e;
                oc[row] = s1[row] * s2 * v;
            }
        }
    });
    out
}

/// Gauss–Newton matrix N_θ (column-major, n×n), gradient g_θ = Jᵀr and the
/// Z-gradient (m × 3m, [`lines::gradient_z`]) at the current point (scaled units).
pub(crate) fn normal_equations(
    pb: &Problem,
    params: &Params,
    l: &[Mat<f64>; 3],
    ev: &Evaluation,
    par: Par,
    clock: &mut Clock,
) -> (Vec<f64>, Vec<f64>, Mat<f64>) {
    let (mo, gz) = moments(pb, ev, par, clock);
    let t0 = Instant::now();
    let nb = n_per_block(params.m);
    let n = params.len();
    let mut nth = vec![0.0; n * n];
    for b in 0..3 {
        for bp in b..3 {
            let out = block_pair(&mo, params, l, b, bp, par);
            place_block(&mut nth, n, &out, nb, b * nb, bp * nb);
        }
    }
    let g = lines::theta_gradient(params, l, &gz);
    clock.congruence += t0.elapsed().as_secs_f64();
    (nth, g, gz)
}

/// Block `out` (nb × nb, column-major) of N_θ at rows `r0`, columns `c0` of `nth`
/// (n × n, column-major) and its transpose at (c0, r0); a diagonal block (r0 = c0) is
/// made exactly symmetric from its upper triangle. Tiles keep the transposed writes in
/// cache.
fn place_block(nth: &mut [f64], n: usize, out: &[f64], nb: usize, r0: usize, c0: usize) {
    const TILE: usize = 32;
    let diagonal = r0 == c0;
    for jt in (0..nb).step_by(TILE) {
        for it in (0..nb).step_by(TILE) {
            for jc in jt..(jt + TILE).min(nb) {
                for ir in it..(it + TILE).min(nb) {
                    // on the diagonal the entry (i, j) and (j, i) both come from i ≤ j
                    let v = match diagonal && ir > jc {
                        true => out[ir * nb + jc],
                        false => out[jc * nb + ir],
                    };
                    nth[(c0 + jc) * n + r0 + ir] = v;
                    nth[(r0 + ir) * n + c0 + jc] = v;
                }
            }
        }
    }
}

/// Solve (A + μ diag(A)) δ = −g by Cholesky, A = N or N + H (the parametrisation's
/// curvature, when given): δ and the factor; None if it is not positive definite.
fn damped_step(
    nth: &[f64],
    curvature: Option<&Curvature>,
    g: &[f64],
    mu: f64,
    par: Par,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let n = g.len();
    let mut a = nth.to_vec();
    if let Some(cv) = curvature {
        cv.dense_add(&mut a);
    }
    let dmax = (0..n).map(|i| a[i * n + i]).fold(0.0f64, f64::max);
    let floor = 1e-12 * dmax.max(f64::MIN_POSITIVE);
    for i in 0..n {
        a[i * n + i] += mu * a[i * n + i].max(floor);
    }
    let mut am = MatMut::from_column_major_slice_mut(&mut a, n, n);
    let params = Default::default();
    let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
        n, par, params,
    ));
    llt::factor::cholesky_in_place(
        am.as_mut(),
        Default::default(),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .ok()?;
    let mut x: Vec<f64> = g.iter().map(|v| -v).collect();
    let rhs = MatMut::from_column_major_slice_mut(&mut x, n, 1);
    let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, 1, par));
    llt::solve::solve_in_place(am.as_ref(), rhs, par, MemStack::new(&mut mem));
    x.iter().all(|v| v.is_finite()).then_some((x, a))
}
