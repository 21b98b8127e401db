//! Matrix-free identification for large orders: preconditioned conjugate gradients
//! on the normal equations, never forming the 3m²×3m² normal matrix (docs/design.md §4).
//!
//! In the scaled problem the normal equations for Z = [X_M X_C X_K] (m×3m) are
//!
//! ```text
//!   Z H + Σ_b 2λ̃_b² (X_b − X_bᵀ)[block b] = B          (penalty mode)
//!   sym_b(Z H) = sym_b(B),  X_b = X_bᵀ                  (exact-symmetric mode)
//! ```
//!
//! We iterate on the coordinates of [`crate::pairs`] in the basis of
//! [`crate::precond`] (X̃_b = Qᵀ X_b Q): the operator is one m×3m by 3m×3m GEMM
//! (≈ 18m³ flops) plus O(m²) packing, and in those coordinates it is exactly the
//! direct path's normal matrix (the penalty is 4λ̃² on skew coordinates), so the
//! two paths solve the same equations. Memory is O(m²).

use crate::data::{scaled, unscale, Columns};
use crate::direct::Method;
use crate::error::PodidError;
use crate::gram::{gram_blocks, symmetrize, HBlocks};
use crate::normal::n_unknowns;
use crate::pairs::Layout;
use crate::precond::{basis_of, from_basis, to_basis, PairPrecond};
use crate::residual::residual_norm_with;
use crate::sgs::{Ends, Sgs, SgsWork};
use crate::solution::{check_lam, CgReport, Identified};
use crate::Progress;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use rayon::prelude::*;
use std::time::Instant;

/// Stopping rule of the iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CgOptions {
    /// stop when ‖b − A x‖ / ‖b‖ ≤ tol (scaled problem, true residual)
    pub tol: f64,
    pub max_iter: usize,
}

/// Chunk length of the vector reductions: fixed, so sums do not depend on the
/// number of threads.
const CHUNK: usize = 1 << 14;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    let parts: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(u, v)| u * v).sum())
        .collect();
    parts.iter().sum()
}

/// p = z + beta·p
fn xpby(z: &[f64], beta: f64, p: &mut [f64]) {
    p.par_chunks_mut(CHUNK)
        .zip(z.par_chunks(CHUNK))
        .for_each(|(p, z)| p.iter_mut().zip(z).for_each(|(v, u)| *v = u + beta * *v));
}

/// The normal operator in the Q basis, on packed coordinates.
pub struct Operator<'a> {
    ht: &'a HBlocks,
    pub layout: Layout,
    /// 4λ̃_b² on the skew coordinates of block b
    pen: [f64; 3],
    z: Mat<f64>,
    y: Mat<f64>,
    par: Par,
    /// wall time spent in the GEMM so far (the rest of an apply is O(m²))
    pub gemm_seconds: f64,
    /// wall time [`pcg`] spent in the triangular solves of its preconditioner
    pub solve_seconds: f64,
}

impl<'a> Operator<'a> {
    pub fn new(ht: &'a HBlocks, layout: Layout, pen: [f64; 3], par: Par) -> Self {
        let m = layout.m;
        Self::with_z(ht, layout, pen, par, Mat::zeros(m, 3 * m))
    }

    /// [`Operator::new`] with `z` (m×3m, any values) as its scratch for Z.
    pub fn with_z(ht: &'a HBlocks, layout: Layout, pen: [f64; 3], par: Par, z: Mat<f64>) -> Self {
        let m = layout.m;
        assert!(z.nrows() == m && z.ncols() == 3 * m);
        Operator {
            ht,
            layout,
            pen,
            z,
            y: Mat::zeros(m, 3 * m),
            par,
            gemm_seconds: 0.0,
            solve_seconds: 0.0,
        }
    }

    /// The two m×3m scratch matrices, for reuse (fresh memory costs page faults).
    pub fn into_buffers(self) -> (Mat<f64>, Mat<f64>) {
        (self.z, self.y)
    }

    /// out = A x
    pub fn apply(&mut self, x: &[f64], out: &mut [f64]) {
        self.layout.unpack(x, self.z.as_mut());
        let start = Instant::now();
        // Y = Z H̃ block by block: Y_c = Σ_b X_b H̃(b, c), nine m×m GEMMs
        let m = self.layout.m;
        for c in 0..3 {
            for b in 0..3 {
                let (blk, sign) = self.ht.block(b, c);
                let accum = if b == 0 { Accum::Replace } else { Accum::Add };
                let (z, y) = (self.z.as_ref().subcols(b * m, m), self.y.as_mut());
                matmul(y.subcols_mut(c * m, m), accum, z, blk, sign, self.par);
            }
        }
        self.gemm_seconds += start.elapsed().as_secs_f64();
        self.layout.pack(self.y.as_ref(), out);
        if !self.layout.symmetric {
            let (_, _, xk) = self.layout.split(x);
            let (_, _, ok) = self.layout.split_mut(out);
            let pen = self.pen;
            ok.par_chunks_mut(3 * CHUNK)
                .zip(xk.par_chunks(3 * CHUNK))
                .for_each(|(o, x)| {
                    for (o3, x3) in o.chunks_exact_mut(3).zip(x.chunks_exact(3)) {
                        for b in 0..3 {
                            o3[b] += pen[b] * x3[b];
                        }
                    }
                });
        }
    }
}

/// ‖b − A x‖ into r, returned relative to ‖b‖.
fn true_residual(op: &mut Operator, x: &[f64], b: &[f64], bnorm: f64, r: &mut [f64]) -> f64 {
    op.apply(x, r);
    r.par_chunks_mut(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .for_each(|(r, b)| r.iter_mut().zip(b).for_each(|(v, u)| *v = u - *v));
    dot(r, r).sqrt() / bnorm
}

/// x += α·t, r −= α·q in one pass; returns ‖r‖² (fixed chunking, as [`dot`]).
fn step(alpha: f64, t: &[f64], q: &[f64], x: &mut [f64], r: &mut [f64]) -> f64 {
    let parts: Vec<f64> = x
        .par_chunks_mut(CHUNK)
        .zip(r.par_chunks_mut(CHUNK))
        .zip(t.par_chunks(CHUNK).zip(q.par_chunks(CHUNK)))
        .map(|((x, r), (t, q))| {
            let mut rr = 0.0;
            for (((xi, ri), ti), qi) in x.iter_mut().zip(r.iter_mut()).zip(t).zip(q) {
                *xi += alpha * ti;
                *ri -= alpha * qi;
                rr += *ri * *ri;
            }
            rr
        })
        .collect();
    parts.iter().sum()
}

/// The symmetric Gauss–Seidel split of the normal equations (Eisenstat 1981).
///
/// With G = D + L + Lᵀ ([`crate::sgs`]), D = R Rᵀ and C = (D + Lᵀ) R⁻ᵀ, the
/// preconditioner is M = (D + Lᵀ) D⁻¹ (D + L) = C Cᵀ, and CG runs on
/// Ĝ = C⁻¹ G C⁻ᵀ. Since G = (D + L) + (D + Lᵀ) − D,
///
/// ```text
///   Ĝ v = Rᵀ (t + (D + Lᵀ)⁻¹ L t),   t = (D + L)⁻¹ R v = C⁻ᵀ v,
/// ```
///
/// two triangular solves and no product with G: an iteration costs about one
/// operator GEMM, in single precision. L t is what the first solve subtracted.
/// (This order of the two sweeps took 1–2 % fewer iterations than the other.)
struct Split<'a> {
    pre: &'a PairPrecond,
    sgs: &'a Sgs,
    work: SgsWork,
    /// wall time in the triangular solves so far
    solve_seconds: f64,
    /// L t, and Rᵀ t (from the first solve, for the second)
    w: Vec<f64>,
    rt: Vec<f64>,
}

impl<'a> Split<'a> {
    fn new(pre: &'a PairPrecond, sgs: &'a Sgs, layout: Layout) -> Self {
        let n = layout.len();
        Split {
            pre,
            sgs,
            work: SgsWork::new(layout.m),
            solve_seconds: 0.0,
            w: vec![0.0; n],
            rt: vec![0.0; n],
        }
    }

    /// q = Ĝ v and t = C⁻ᵀ v (the factor products R v and Rᵀ(t + u) are done
    /// inside the solves).
    fn apply(&mut self, v: &[f64], q: &mut [f64], t: &mut [f64]) {
        let start = Instant::now();
        let (pre, sgs) = (self.pre, self.sgs);
        let (w, rt) = (Some(&mut self.w[..]), Some(&mut self.rt[..]));
        sgs.solve_with(pre, v, t, w, rt, false, Ends::FactorIn, &mut self.work);
        pre.correct(t, &mut self.w);
        let ends = Ends::FactorOut(Some(&self.rt));
        sgs.solve_with(pre, &self.w, q, None, None, true, ends, &mut self.work);
        self.solve_seconds += start.elapsed().as_secs_f64();
    }

    /// out = C⁻¹ r.
    fn transform(&mut self, r: &[f64], out: &mut [f64]) {
        let start = Instant::now();
        let ends = Ends::FactorOut(None);
        self.sgs
            .solve_with(self.pre, r, out, None, None, true, ends, &mut self.work);
        self.solve_seconds += start.elapsed().as_secs_f64();
    }
}

/// The true residual is computed in double precision (replacing the recursive
/// one, a "reliable update") each time the recursive one has fallen by this
/// factor since the last time, and when it seems to have reached tol. Measured
/// (m = 400, 50–150 Hz): the same iterations for 1e-1 … 1e-3; at 1e-5 the
/// single-precision drift already stalled the iteration above tol, and without
/// updates it stalls near 1e-6. At m = 1000 on the 20 % band 1e-3 needed half
/// the double-precision operator GEMMs of 1e-2 for the same iterations.
const RELIABLE: f64 = 1e-3;

/// The iteration has stalled when the recursive residual has predicted this
/// reduction since the true residual last halved.
const STALLED: f64 = 8.0;

/// The true residual is also computed when it has not been for twice the
/// longest run of iterations the true residual ever needed to halve (at least
/// [`MIN_SPAN`]), whatever the recursive residual says: near the attainable
/// accuracy the recursive residual of the single-precision split need not fall
/// at all, and a rule that waited for it ran to max_iter at tol 1e-300 in 7 of
/// the 12 cases of `benches/bench_cg.py --stall` (once diverging to 6e-3).
const CHECK_SPAN: usize = 2;

/// The iteration has also stalled when the true residual has not halved for
/// this many times the longest run it ever needed to halve (at least
/// [`MIN_SPAN`] times that many): it no longer follows the iteration.
const STALL_SPAN: usize = 6;

/// Shortest run of iterations the two spans above are counted in.
const MIN_SPAN: usize = 10;

/// CG preconditioned by symmetric Gauss–Seidel, from x = 0, judged on the true
/// residual ‖b − G x‖/‖b‖ of the double-precision operator `op`.
///
/// The iteration itself runs in the split form of [`Split`], whose couplings are
/// single-precision GEMMs; its recursive residual is that of Ĝ. The true
/// residual (one double-precision operator GEMM) replaces it each time the
/// recursive one has fallen by [`RELIABLE`], when its estimate (the recursive
/// residual times ‖r‖/‖r̂‖ at the last replacement) reaches `tol`, and when it
/// has not been computed for a while ([`CHECK_SPAN`]): converged if the true
/// one is at tol, else the iteration goes on from it. The answer is accumulated
/// in double precision, so single precision costs iterations only if the
/// couplings were too inaccurate, never accuracy. The iteration has reached the
/// attainable accuracy of the problem in floating point, and stops there not
/// converged, when the true residual has not halved while the recursive one
/// predicted a reduction by [`STALLED`], or for [`STALL_SPAN`] times as long as
/// it ever needed to halve; it then returns the iterate of the smallest true
/// residual seen.
pub fn pcg(
    op: &mut Operator,
    pre: &PairPrecond,
    sgs: &Sgs,
    b: &[f64],
    opts: CgOptions,
    progress: &mut Option<Progress>,
) -> Result<(Vec<f64>, CgReport), PodidError> {
    let n = b.len();
    let mut x = vec![0.0; n];
    let bnorm = dot(b, b).sqrt();
    if bnorm == 0.0 {
        let report = CgReport {
            iterations: 0,
            relative_residual: 0.0,
            converged: true,
        };
        return Ok((x, report));
    }
    let mut split = Split::new(pre, sgs, op.layout);
    let mut r = vec![0.0; n];
    let mut q = vec![0.0; n];
    let mut t = vec![0.0; n];
    split.transform(b, &mut r);
    let mut p = r.clone();
    let mut rr = dot(&r, &r);
    // ‖b − G x‖ ≈ scale·‖r̂‖
    let mut scale = bnorm / rr.sqrt();
    let mut at_update = rr.sqrt();
    // the true residual at the last check that halved it, the iterations then,
    // the longest run between two such checks, and the reduction the recursive
    // residual has predicted since
    let (mut anchor, mut anchor_at, mut longest) = (f64::INFINITY, 0, MIN_SPAN);
    let mut predicted = 1.0;
    let mut iterations = 0;
    let mut last_update = 0;
    // the smallest true residual seen and its iterate
    let mut best: Option<(f64, Vec<f64>)> = None;
    let mut true_res = None;
    while iterations < opts.max_iter {
        split.apply(&p, &mut q, &mut t);
        let pq = dot(&p, &q);
        if !(pq > 0.0 && pq.is_finite() && rr.is_finite()) {
            break; // breakdown: nothing more to gain from this direction
        }
        let alpha = rr / pq;
        let mut rr_new = step(alpha, &t, &q, &mut x, &mut r);
        iterations += 1;
        let estimate = rr_new.sqrt() * scale / bnorm;
        if let Some(cb) = progress.as_mut() {
            if cb(iterations, estimate).is_break() {
                return Err(PodidError::Interrupted);
            }
        }
        let fallen = rr_new.sqrt() / at_update;
        let overdue = iterations - last_update >= CHECK_SPAN * longest;
        if estimate <= opts.tol || fallen <= RELIABLE || overdue {
            last_update = iterations;
            // b − G x into q, free until the next iteration's solves
            let res = true_residual(op, &x, b, bnorm, &mut q);
            predicted *= at_update / rr_new.sqrt();
            if res <= 0.5 * anchor {
                longest = longest.max(iterations - anchor_at);
                (anchor, anchor_at) = (res, iterations);
                predicted = 1.0;
            }
            match best.as_mut() {
                Some((least, bx)) if res < *least => {
                    *least = res;
                    bx.copy_from_slice(&x);
                }
                None => best = Some((res, x.clone())),
                _ => {}
            }
            let stalled = predicted >= STALLED || iterations - anchor_at >= STALL_SPAN * longest;
            if res <= opts.tol || stalled {
                true_res = Some(res);
                break;
            }
            split.transform(&q, &mut r);
            rr_new = dot(&r, &r);
            scale = res * bnorm / rr_new.sqrt();
            at_update = rr_new.sqrt();
        }
        xpby(&r, rr_new / rr, &mut p);
        rr = rr_new;
    }
    let mut relative_residual = match true_res {
        Some(t) => t,
        None => true_residual(op, &x, b, bnorm, &mut q),
    };
    if let Some((least, bx)) = best {
        if least < relative_residual {
            (relative_residual, x) = (least, bx);
        }
    }
    let report = CgReport {
        iterations,
        relative_residual,
        converged: relative_residual <= opts.tol,
    };
    op.solve_seconds += split.solve_seconds;
    Ok((x, report))
}

/// Bytes of the solver's O(m²) working set, an upper bound: H's five blocks,
/// B and their transforms (at most 21m²; afterwards H̃'s five blocks, 5m²),
/// Z and Z·H̃ (6m²), the answer's change of basis (3m²), eight CG vectors (one
/// the best iterate), the pair factors and the single-precision H̃ and scratch
/// of the Gauss–Seidel solves. (At m = 1000 a call's peak resident memory rose
/// by 0.47 / 0.36 GB with / without the penalty, against 0.50 / 0.38 GB here.
/// Since then the transforms and the change of basis reuse the memory of what
/// they replace, so the bound has slack.)
pub fn memory_bytes(m: usize, symmetric: bool) -> u128 {
    let lay = Layout::new(m, symmetric);
    let doubles = 30 * m * m + 8 * lay.len() + PairPrecond::doubles(lay);
    doubles as u128 * 8 + Sgs::bytes(m) as u128
}

/// Identify M, C, K like [`crate::identify::identify`], by preconditioned CG.
/// Non-convergence is not an error: the report says what was achieved.
///
/// Runs on a worker of the current rayon pool (directly if this thread is one):
/// called from outside the pool, every `rayon::join` of the triangular solves
/// would be sent into the pool and waited for by a third thread. The whole solve
/// runs there, not only the iteration, so that its allocations share one malloc
/// arena (the iteration alone on the worker raised the peak memory at m = 1000 by
/// 0.11 GB: it could not reuse what the set-up had freed).
pub fn identify_cg(
    cols: &Columns,
    lam: [f64; 3],
    symmetric: bool,
    opts: CgOptions,
    progress: Option<Progress>,
    par: Par,
) -> Result<Identified, PodidError> {
    rayon::scope(|_| identify_cg_here(cols, lam, symmetric, opts, progress, par))
}

fn identify_cg_here(
    cols: &Columns,
    lam: [f64; 3],
    symmetric: bool,
    opts: CgOptions,
    mut progress: Option<Progress>,
    par: Par,
) -> Result<Identified, PodidError> {
    check_lam(lam)?;
    if !(opts.tol > 0.0 && opts.tol < 1.0) {
        return Err(PodidError::Invalid(format!(
            "tol must lie in (0, 1), got {}",
            opts.tol
        )));
    }
    if opts.max_iter == 0 {
        return Err(PodidError::Invalid("max_iter must be at least 1".into()));
    }
    let start = Instant::now();
    let m = cols.m;
    let (scaling, (hb, b)) = scaled(cols, |data| gram_blocks(data, par));
    let gram_seconds = start.elapsed().as_secs_f64();

    let t = Instant::now();
    let (q, diag) = basis_of(&hb, par).map_err(PodidError::Invalid)?;
    let basis_seconds = t.elapsed().as_secs_f64();
    let (ht, bt) = to_basis(hb, b, q.as_ref(), diag, par);
    let layout = Layout::new(m, symmetric);
    let pen = scaling.scaled_lam(lam).map(|l| 4.0 * l * l);
    let pre = PairPrecond::new(&ht, layout, pen);
    let sgs = Sgs::new(&ht, layout, par);
    let mut rhs = vec![0.0; layout.len()];
    layout.pack(bt.as_ref(), &mut rhs);
    let setup_seconds = t.elapsed().as_secs_f64();

    let t = Instant::now();
    // B̃'s memory (m×3m) is the operator's Z, and afterwards the answer's
    let mut op = Operator::with_z(&ht, layout, pen, par, bt);
    let (x, report) = pcg(&mut op, &pre, &sgs, &rhs, opts, &mut progress)?;
    let iterate_seconds = t.elapsed().as_secs_f64();
    let (gemm_seconds, solve_seconds) = (op.gemm_seconds, op.solve_seconds);

    let (mut z, mut scratch) = op.into_buffers();
    layout.unpack(&x, z.as_mut());
    from_basis(z.as_mut(), q.as_ref(), par, scratch.as_mut());
    if symmetric {
        for b in 0..3 {
            symmetrize(z.as_mut().submatrix_mut(0, b * m, m, m));
        }
    }
    let t = Instant::now();
    let residual_norm = residual_norm_with(cols, &scaling, z.as_ref(), scratch.as_mut());
    let residual_seconds = t.elapsed().as_secs_f64();
    let nu = n_unknowns(m, symmetric);
    Ok(Identified {
        mck: unscale(z.as_ref(), &scaling),
        method: Method::ConjugateGradient,
        rank: nu,
        n_unknowns: nu,
        min_pivot_ratio: f64::NAN,
        scaling,
        timings: vec![
            ("gram", gram_seconds),
            ("setup", setup_seconds),
            ("basis", basis_seconds),
            ("iterate", iterate_seconds),
            ("gemm", gemm_seconds),
            ("solves", solve_seconds),
            ("residual", residual_seconds),
            ("total", start.elapsed().as_secs_f64()),
        ],
        cg: Some(report),
        residual_norm,
    })
}

/// GFLOP/s of one operator-shaped GEMM (m×3m by 3m×3m), best of `repeat`: the
/// floor of a CG iteration is 18m³ flops at this rate.
pub fn operator_gemm_gflops(m: usize, repeat: usize, par: Par) -> f64 {
    let a = Mat::<f64>::from_fn(m, 3 * m, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
    let h = Mat::<f64>::from_fn(3 * m, 3 * m, |i, j| ((i * 5 + j * 3) % 13) as f64 - 6.0);
    let mut y = Mat::<f64>::zeros(m, 3 * m);
    let mut best = f64::INFINITY;
    for _ in 0..repeat.max(1) + 1 {
        let t = Instant::now();
        matmul(y.as_mut(), Accum::Replace, a.as_ref(), h.as_ref(), 1.0, par);
        best = best.min(t.elapsed().as_secs_f64());
    }
    18.0 * (m as f64).powi(3) / best / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Columns;
    use crate::gram::random_blocks;
    use crate::identify::identify;
    use crate::identify::tests::{data, rel_err, truth};
    use crate::normal::Basis;
    use std::ops::ControlFlow;

    const OPTS: CgOptions = CgOptions {
        tol: 1e-13,
        max_iter: 2000,
    };

    /// The packed operator is the direct path's normal matrix G (with Q = I).
    #[test]
    fn operator_is_the_direct_normal_matrix() {
        let m = 4;
        let h = random_blocks(m, 1);
        let full = h.assemble();
        let lam = [0.7, 0.0, 2.0];
        for symmetric in [false, true] {
            let basis = Basis::new(m, symmetric);
            let n = basis.len();
            let mut g = vec![0.0; n * n];
            basis.assemble(full.as_ref(), lam, &mut g);
            let layout = Layout::new(m, symmetric);
            let pen = lam.map(|l| 4.0 * l * l);
            let mut op = Operator::new(&h, layout, pen, Par::Seq);
            for p in 0..n {
                // G e_p as a matrix, against A applied to the same basis matrix
                let mut e = vec![0.0; n];
                e[p] = 1.0;
                let gcol: Vec<f64> = (0..n)
                    .map(|i| if i >= p { g[p * n + i] } else { g[i * n + p] })
                    .collect();
                let want = basis.to_blocks(&gcol);
                let mut x = vec![0.0; layout.len()];
                layout.pack(basis.to_blocks(&e).as_ref(), &mut x);
                let mut out = vec![0.0; layout.len()];
                op.apply(&x, &mut out);
                let mut got = Mat::zeros(m, 3 * m);
                layout.unpack(&out, got.as_mut());
                assert!((&got - &want).norm_l2() < 1e-13, "sym={symmetric} p={p}");
            }
        }
    }

    /// When every block of H is diagonal in one basis the preconditioner is the
    /// inverse up to the single-precision rounding of its pair factors: one
    /// iteration reaches ~1e-7, a second (after the true-residual update) tol.
    #[test]
    fn preconditioner_is_exact_for_simultaneously_diagonal_blocks() {
        let m = 5;
        // per mode the 3×3 block [S4 0 −S2; 0 S2 0; −S2 0 S0] (T = 0)
        let diag = |f: &dyn Fn(f64) -> f64| {
            Mat::from_fn(m, m, |i, j| if i == j { f(i as f64) } else { 0.0 })
        };
        let h = HBlocks {
            s4: diag(&|k| 4.0 + k),
            s2: diag(&|_| 2.0),
            s0: diag(&|k| 2.0 + 0.3 * k),
            t1: Mat::zeros(m, m),
            t3: Mat::zeros(m, m),
        };
        let rhs_z = Mat::from_fn(m, 3 * m, |i, j| ((i + 2 * j) % 5) as f64 - 2.0);
        for (symmetric, pen) in [
            (true, [0.0; 3]),
            (false, [0.0; 3]),
            (false, [3.0, 0.0, 1e6]),
        ] {
            let layout = Layout::new(m, symmetric);
            let pre = PairPrecond::new(&h, layout, pen);
            let sgs = Sgs::new(&h, layout, Par::Seq);
            let mut op = Operator::new(&h, layout, pen, Par::Seq);
            let mut b = vec![0.0; layout.len()];
            layout.pack(rhs_z.as_ref(), &mut b);
            let (_, rep) = pcg(&mut op, &pre, &sgs, &b, OPTS, &mut None).unwrap();
            assert!(
                rep.converged && rep.iterations <= 2,
                "{symmetric} {pen:?}: {rep:?}"
            );
        }
    }

    fn chain_like_columns(m: usize, perturb: f64) -> (Vec<faer::c64>, Vec<faer::c64>, Vec<f64>) {
        let t = truth(m);
        let omegas: Vec<f64> = (0..12).map(|i| 3.0 + 2.0 * i as f64).collect();
        let (mut u, f, w) = data(&t, &omegas);
        for (i, z) in u.iter_mut().enumerate() {
            *z *= 1.0 + perturb * (((i * 7919) % 13) as f64 / 6.0 - 1.0);
        }
        (u, f, w)
    }

    #[test]
    fn cg_matches_direct_in_every_mode() {
        for perturb in [0.0, 0.05] {
            let m = 5;
            let (u, f, w) = chain_like_columns(m, perturb);
            let cols = Columns::new(&u, &f, &w, m).unwrap();
            let modes = [
                ([0.0; 3], false),
                ([0.0; 3], true),
                ([1e-3, 0.0, 0.2], false),
                // a penalty 10¹⁵ above the data term: the pair blocks must not lose
                // the data part next to it
                ([1e5; 3], false),
            ];
            let mut iterations = vec![];
            for (lam, sym) in modes {
                let direct = identify(&cols, lam, sym, Par::Seq).unwrap();
                let cg = identify_cg(&cols, lam, sym, OPTS, None, Par::Seq).unwrap();
                let rep = cg.cg.unwrap();
                assert!(rep.converged, "{rep:?}");
                iterations.push(rep.iterations);
                assert_eq!(cg.method, Method::ConjugateGradient);
                for b in 0..3 {
                    let e = rel_err(&cg.mck[b], &direct.mck[b]);
                    assert!(
                        e < 1e-9,
                        "perturb={perturb} lam={lam:?} sym={sym} block {b}: {e}"
                    );
                }
                if sym {
                    for x in &cg.mck {
                        assert_eq!(x, &x.transpose().to_owned());
                    }
                }
            }
            // λ → ∞ is the exact-symmetric problem, and so is its preconditioner
            assert!(iterations[3] <= iterations[1] + 3, "{iterations:?}");
        }
    }

    #[test]
    fn iteration_limit_reports_non_convergence_and_callback_can_stop() {
        let m = 4;
        let (u, f, w) = chain_like_columns(m, 0.05);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        let opts = CgOptions {
            tol: 1e-14,
            max_iter: 2,
        };
        let mut seen = Vec::new();
        let mut record = |it: usize, res: f64| {
            seen.push((it, res));
            ControlFlow::Continue(())
        };
        let id = identify_cg(&cols, [1.0; 3], false, opts, Some(&mut record), Par::Seq).unwrap();
        let rep = id.cg.unwrap();
        assert!(!rep.converged && rep.iterations == 2 && rep.relative_residual > 1e-14);
        assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), vec![1, 2]);
        let mut stop = |_: usize, _: f64| ControlFlow::Break(());
        let err = identify_cg(&cols, [1.0; 3], false, OPTS, Some(&mut stop), Par::Seq);
        assert_eq!(err.err(), Some(PodidError::Interrupted));
        for bad in [0.0, 1.0, f64::NAN] {
            let o = CgOptions { tol: bad, ..OPTS };
            assert!(identify_cg(&cols, [1.0; 3], false, o, None, Par::Seq).is_err());
        }
        let o = CgOptions {
            max_iter: 0,
            ..OPTS
        };
        assert!(identify_cg(&cols, [1.0; 3], false, o, None, Par::Seq).is_err());
    }
}
