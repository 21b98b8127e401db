//! The matrix-free Gauss–Newton step for large m: (N + μ·diag N) δ = −g by
//! preconditioned conjugate gradients, N v = Jᵀ(J v) applied line by line.
//!
//! Nothing of size m⁴ is formed. With scalar weights the step keeps the Gram matrix
//! G = D⁻ᴴD⁻¹ of every line (s·m² complex numbers, formed anyway for the diagonal
//! below) and applies it by one Hermitian matrix-vector product per column: half the
//! memory traffic of the two triangular-pair solves through the LU factors, which the
//! step keeps and uses instead with matrix weights (G = Aᴴ A, A = T D⁻¹, one per
//! column there). Measured at m = 100, s = 2000: 0.056–0.071 s per product against
//! 0.113–0.123 s through the LU factors (load 5.5–6). Per column:
//!
//! ```text
//!     δX_b = P_b v_b,   y = δD x = (−ω² δM + iω δC + δK) x,   z = D⁻ᴴ TᵀT D⁻¹ y,
//!     (N v)_b = P_bᵀ Re Σ z (φ_b x)ᴴ,       φ = (−ω², iω, 1),
//! ```
//!
//! the first and last by GEMMs over all columns, the middle one per line. The
//! exact diagonal of N (the LM damping, and the Jacobi preconditioner) needs G and
//! G L per line, O(s·m³) flops but O(m²) memory per thread: it is computed at
//! every accepted point ([`DIAG_REFRESH`]). From X = L Lᵀ, θ = (j, k) moves
//! δX = e_j ℓ_kᵀ + ℓ_k e_jᵀ, so
//!
//! ```text
//!     N_(jk),(jk) = Σ |φ_b|² [G_jj |a_k|² + (LᵀGL)_kk X̄_jj + 2 Re((GL)_jk conj(a_k) x_j)] · s_jk²
//! ```
//!
//! with a = Lᵀx and X̄_jj = |x_j|² summed over the term's columns (the floor's
//! O(ε) terms are left out of the damping), s_jk = L_jj on a logged diagonal.
//!
//! The files: `prepared` keeps the point and applies N_θ v, `sums` forms the per-point
//! sums over lines (diagonal blocks, modal metric), `preconditioner` the damping and
//! preconditioner of the CG; this file the solver — the CG of one step, the step in X
//! of the modal path and its retraction to the factors.

mod preconditioner;
mod prepared;
mod sums;

use crate::refine::curvature::Curvature;
use crate::refine::input::Weights;
use crate::refine::line_solves::solve_lines_adjoint;
use crate::refine::lines::{self, response_weight, terms_per_line};
use crate::refine::modal::ModalMetric;
use crate::refine::objective::{Evaluation, Problem};
use crate::refine::parametrisation::{gram_lower, n_per_block, Params, CONDITION_FLOOR};
use crate::refine::step_solver::StepSolver;
use faer::{c32, c64, Mat, MatRef, Par};
use preconditioner::{dot, inner_solve, inverse3, Metric};
use prepared::{weight_twice, Prepared};
use rayon::prelude::*;
use std::time::Instant;
use sums::{diagonal, modal_sums, modal_sums_y};

/// Stopping rule of the inner CG: relative residual below
/// min(CG_ETA_MAX, sqrt(‖g‖/‖g₀‖)) (a forcing term that tightens as the gradient
/// falls, so that the outer iteration keeps its fast final convergence: with a fixed
/// 0.1, noise-free data stalled at 7e-3 from the exact model), never below
/// CG_ETA_MIN.
const CG_ETA_MAX: f64 = 0.1;
const CG_ETA_MIN: f64 = 1e-10;

/// The diagonal of N_θ (damping and preconditioner) is recomputed at every this
/// many accepted steps: it costs O(s·m³), the rest of a step O(s·m²) per product.
/// Measured: refreshed every 5 steps, LM stalled on noise-free data (7e-3 from the
/// exact model at m = 5); at every step it converges.
pub const DIAG_REFRESH: usize = 1;

/// The first LM damping with the modal metric: B_θ is on the scale of N_θ (equal on
/// the modal unknowns), so μ = 1 halves the Gauss–Newton step (μ·diag N starts at
/// 1e-3, a scale of its own).
const MODAL_START_DAMPING: f64 = 1.0;

/// Most steps that go straight to the factors after steps in X left the cone, before
/// the next is tried (after the k-th failure in a row: 2^(k−1) − 1, at most this).
/// Where the optimum sits on the cone's edge nearly every step in X leaves it (chain,
/// m = 100, 2000 lines: 1 of 144 taken) and its CG solve — half the products of the
/// whole refinement — is thrown away; where a step in X fails now and then (the
/// 5-DOF chain from 2 % off: 4 of 23 steps) the next step tries again (waiting 10
/// steps after each failure took that case from 23 steps to 33–37).
const X_STEP_WAIT: usize = 10;

/// The matrix-free step solver.
pub(crate) struct MatrixFree {
    /// what the step keeps of the current point
    prep: Prepared,
    /// points prepared so far
    prepares: usize,
    /// diag(N_θ), and the 3×3 blocks coupling M, C, K at each (j, k)
    diag: Vec<f64>,
    blocks: Vec<f64>,
    /// ‖g‖ at the first point, for the forcing term
    g0: f64,
    /// δᵀNδ of the last step
    last: Option<(Vec<f64>, f64)>,
    /// how many CG iterations, and N products
    pub cg_iterations: usize,
    pub products: usize,
    pub cg_cap_hits: usize,
    t_prepare: f64,
    t_diagonal: f64,
    t_products: f64,
    /// the CG iteration cap (after which the current iterate is the step)
    max_cg: usize,
    /// add the parametrisation's curvature ([`super::curvature`]), and it at this point
    curvature: bool,
    curv: Option<Curvature>,
    /// whether the next step (and its products) uses it
    use_curv: bool,
    /// damp and precondition by the modal metric ([`super::modal`]) where it can be
    /// formed (else by diag N_θ and its 3×3 blocks), and it at this point
    use_modal: bool,
    modal: Option<ModalMetric>,
    /// the last step taken in X (θ of chol(X + δX) minus θ) and the decrease its
    /// Gauss–Newton model predicts
    retracted: Option<(Vec<f64>, f64)>,
    /// modal path: steps taken in X, steps in the factors (X + δX left the cone), and
    /// the products spent on the steps in X (whether taken or not)
    x_steps: usize,
    factor_steps: usize,
    x_products: usize,
    /// per block (M, C, K): how often X + δX was not positive definite
    out_of_cone: [usize; 3],
    /// steps still to go straight to the factors ([`X_STEP_WAIT`])
    x_wait: usize,
    /// steps in X in a row that left the cone
    x_failures: usize,
}

impl MatrixFree {
    pub(crate) fn new(max_cg: usize) -> Self {
        MatrixFree {
            prep: Prepared::empty(),
            prepares: 0,
            diag: Vec::new(),
            blocks: Vec::new(),
            last: None,
            g0: 0.0,
            cg_iterations: 0,
            products: 0,
            cg_cap_hits: 0,
            t_prepare: 0.0,
            t_diagonal: 0.0,
            t_products: 0.0,
            max_cg,
            curvature: false,
            curv: None,
            use_curv: false,
            use_modal: false,
            modal: None,
            retracted: None,
            x_steps: 0,
            factor_steps: 0,
            x_products: 0,
            out_of_cone: [0; 3],
            x_wait: 0,
            x_failures: 0,
        }
    }

    /// Damp and precondition by the modal metric ([`super::modal`]) and take the steps
    /// in X, instead of μ·diag N_θ and its 3×3 blocks.
    pub(crate) fn with_modal_metric(mut self, on: bool) -> Self {
        self.use_modal = on;
        self
    }

    pub(crate) fn with_curvature(mut self, curvature: bool) -> Self {
        self.curvature = curvature;
        self
    }

    /// diag(N_θ) at the prepared point.
    #[cfg(test)]
    pub(crate) fn diagonal(&self) -> &[f64] {
        &self.diag
    }

    /// The modal metric at the prepared point.
    #[cfg(test)]
    pub(crate) fn modal(&self) -> Option<&ModalMetric> {
        self.modal.as_ref()
    }

    /// N_θ[(b, t), (b', t)] at the prepared point, t = tri(j, k).
    #[cfg(test)]
    pub(crate) fn block(&self, b: usize, bp: usize, t: usize) -> f64 {
        let nb = self.diag.len() / 3;
        let q = sums::PAIRS
            .iter()
            .position(|&pr| pr == (b.min(bp), b.max(bp)))
            .unwrap();
        self.blocks[q * nb + t]
    }

    /// (N (+ H) + μD) δ = −g by preconditioned CG.
    fn solve_step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        cancelled: &mut dyn FnMut() -> bool,
    ) -> Option<Vec<f64>> {
        let n = g.len();
        // the LM damping μD and the preconditioner: the modal metric (D = B_θ,
        // preconditioner ((1 + μ) B_θ)⁻¹), else D = diag(N + H) and the 3×3 blocks of
        // N + μD (M, C, K at one (j, k)) inverted per block (Jacobi where a block is
        // not numerically positive)
        let metric = match self.modal.take() {
            Some(modal) => Metric::Modal(Box::new(modal)),
            None => Metric::Diagonal(self.diagonal_metric(n, mu)),
        };
        let damp = |v: &[f64]| -> Vec<f64> {
            match &metric {
                Metric::Modal(b) => b.apply(v).into_iter().map(|x| mu * x).collect(),
                Metric::Diagonal((damp, _)) => v.iter().zip(damp).map(|(a, e)| a * e).collect(),
            }
        };
        // with the curvature H (the modal path's step in the factors): B_θ⁻¹ does not
        // see H, which dominates where a factor is nearly singular — a few CG
        // iterations on (1 + μ)B_θ + H (O(m³) each), preconditioned by B_θ⁻¹, instead
        let curv = match (&self.curv, self.use_curv) {
            (Some(cv), true) => Some(cv.clone()),
            _ => None,
        };
        let precondition = |r: &[f64]| -> Vec<f64> {
            match &metric {
                Metric::Modal(b) => match &curv {
                    // in the modal coordinates y (δθ = R y): Rᵀ((1 + μ)B_θ + H)R =
                    // (1 + μ)B_Y + RᵀHR, B_Y block diagonal — the same iterates as in θ
                    // with B_θ⁻¹, for 11 instead of 17 m×m products per block and iteration
                    Some(cv) => {
                        let y = inner_solve(
                            &b.dual_y(r),
                            |v| {
                                let th = b.theta_of_y(v);
                                let mut h = vec![0.0; th.len()];
                                cv.apply_add(&th, &mut h);
                                let mut out = b.dual_y(&h);
                                for (o, a) in out.iter_mut().zip(b.block_apply(v)) {
                                    *o += (1.0 + mu) * a;
                                }
                                out
                            },
                            |v| b.block_solve(v, mu),
                        );
                        b.theta_of_y(&y)
                    }
                    None => b.solve(r, mu),
                },
                Metric::Diagonal((_, pre)) => {
                    let nb = n / 3;
                    let mut z = vec![0.0; n];
                    for (t, q) in pre.iter().enumerate() {
                        let (r0, r1, r2) = (r[t], r[nb + t], r[2 * nb + t]);
                        z[t] = q[0] * r0 + q[3] * r1 + q[4] * r2;
                        z[nb + t] = q[3] * r0 + q[1] * r1 + q[5] * r2;
                        z[2 * nb + t] = q[4] * r0 + q[5] * r1 + q[2] * r2;
                    }
                    z
                }
            }
        };
        let gn = dot(g, g).sqrt();
        if self.g0 == 0.0 {
            self.g0 = gn;
        }
        let eta = (gn / self.g0).sqrt().clamp(CG_ETA_MIN, CG_ETA_MAX);
        // CG on A δ = b, A = N + μD, b = −g, from δ = 0
        let mut x = vec![0.0; n];
        let mut r: Vec<f64> = g.iter().map(|v| -v).collect();
        let mut z = precondition(&r);
        let mut d = z.clone();
        let mut rz = dot(&r, &z);
        let bn = gn;
        let mut it = 0;
        loop {
            if cancelled() {
                self.restore(metric);
                return None;
            }
            let mut ad = self.apply(&d, par);
            for (v, e) in ad.iter_mut().zip(damp(&d)) {
                *v += e;
            }
            let dad = dot(&d, &ad);
            if dad.is_nan() || dad <= 0.0 {
                // not positive definite along d: stop with what we have
                break;
            }
            let alpha = rz / dad;
            let r_prev = r.clone();
            for q in 0..n {
                x[q] += alpha * d[q];
                r[q] -= alpha * ad[q];
            }
            it += 1;
            let rn = dot(&r, &r).sqrt();
            if rn <= eta * bn || it >= self.max_cg {
                if it >= self.max_cg && rn > eta * bn {
                    self.cg_cap_hits += 1;
                }
                break;
            }
            z = precondition(&r);
            let rz2 = dot(&r, &z);
            // Polak–Ribière (flexible CG: the inner solve is not one fixed matrix); the
            // same β as Fletcher–Reeves for a fixed preconditioner
            let beta = if curv.is_some() && matches!(metric, Metric::Modal(_)) {
                let zr_old: f64 = z.iter().zip(&r_prev).map(|(a, c)| a * c).sum();
                ((rz2 - zr_old) / rz).max(0.0)
            } else {
                rz2 / rz
            };
            rz = rz2;
            for q in 0..n {
                d[q] = z[q] + beta * d[q];
            }
        }
        self.cg_iterations += it;
        if it == 0 || !x.iter().all(|v| v.is_finite()) {
            self.restore(metric);
            return None;
        }
        // δᵀNδ = δᵀAδ − μ δᵀDδ, δᵀAδ = δᵀ(b − r) = −gᵀδ − rᵀδ
        let xax = -dot(g, &x) - dot(&r, &x);
        let xdx = dot(&x, &damp(&x));
        self.restore(metric);
        self.last = Some((x.clone(), xax - xdx));
        Some(x)
    }

    /// The damping μ·diag(N + H) and the inverted 3×3 blocks of N + μD.
    fn diagonal_metric(&self, n: usize, mu: f64) -> (Vec<f64>, Vec<[f64; 6]>) {
        // diag(N + H): the Gauss–Newton diagonal and the parametrisation's curvature
        let diag: Vec<f64> = match (&self.curv, self.use_curv) {
            (Some(cv), true) => self
                .diag
                .iter()
                .zip(cv.diagonal())
                .map(|(a, b)| a + b)
                .collect(),
            _ => self.diag.clone(),
        };
        let dmax = diag.iter().fold(0.0f64, |a, v| a.max(*v));
        let floor = 1e-12 * dmax.max(f64::MIN_POSITIVE);
        let damp: Vec<f64> = diag.iter().map(|d| mu * d.max(floor)).collect();
        let nb = n / 3;
        let pre = (0..nb)
            .map(|t| {
                let e = |b: usize| diag[b * nb + t].max(floor) + damp[b * nb + t];
                let a = [
                    [e(0), self.blocks[3 * nb + t], self.blocks[4 * nb + t]],
                    [0.0, e(1), self.blocks[5 * nb + t]],
                    [0.0, 0.0, e(2)],
                ];
                inverse3(a).unwrap_or([1.0 / e(0), 1.0 / e(1), 1.0 / e(2), 0.0, 0.0, 0.0])
            })
            .collect();
        (damp, pre)
    }

    /// The step in θ that moves X to X + P δθ exactly: θ(chol(X + δX)) − θ, the
    /// parametrisation's floor ε tr(L Lᵀ) I taken off first; None where X + δX is not
    /// positive definite (Err: the block that left, or 3 for a step that is not finite).
    pub(crate) fn retract(&self, dth: &[f64]) -> Result<Vec<f64>, usize> {
        let (m, nb) = (self.prep.m, n_per_block(self.prep.m));
        let params = self.prep.params();
        let mut new_l = self.prep.l.clone();
        for b in 0..3 {
            let dx = lines::tangent(&params, &self.prep.l[b], &dth[b * nb..(b + 1) * nb]);
            let x = gram_lower(&self.prep.l[b]);
            let target = Mat::from_fn(m, m, |i, j| x[(i, j)] + dx[(i, j)]);
            let tr: f64 = (0..m).map(|i| target[(i, i)]).sum();
            let shift = CONDITION_FLOOR * tr / (1.0 + m as f64 * CONDITION_FLOOR);
            let inner = Mat::from_fn(m, m, |i, j| {
                0.5 * (target[(i, j)] + target[(j, i)]) - if i == j { shift } else { 0.0 }
            });
            new_l[b] = inner.llt(faer::Side::Lower).map_err(|_| b)?.L().to_owned();
        }
        let (th0, th1) = (params.pack(&self.prep.l), params.pack(&new_l));
        let step: Vec<f64> = th1.iter().zip(&th0).map(|(a, b)| a - b).collect();
        if step.iter().all(|v| v.is_finite()) {
            Ok(step)
        } else {
            Err(3)
        }
    }

    /// The step in the factors, with their curvature.
    fn factor_step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        cancelled: &mut dyn FnMut() -> bool,
        asked: bool,
    ) -> Option<Vec<f64>> {
        // where the step in X leaves the cone (or left it lately): the step in the
        // factors, with their curvature (without it the model overestimates every
        // decrease there and LM crawls: measured, gain ratio ≈ 0.68 at a damping of 50;
        // cutting the step in X back to the cone instead, direction by direction or as a
        // whole, stalled, and so did projecting X + δX onto the cone: m = 100, cost
        // 0.494 after 25 steps against 0.225)
        self.factor_steps += 1;
        self.use_curv = self.curv.is_some();
        let x = self.solve_step(g, mu, par, cancelled);
        self.use_curv = asked;
        x
    }

    /// Keep the modal metric of this point for the next step from it.
    fn restore(&mut self, metric: Metric) {
        if let Metric::Modal(b) = metric {
            self.modal = Some(*b);
        }
    }

    /// N_θ v, with the parametrisation's curvature H when the step uses it.
    pub(crate) fn apply(&mut self, v: &[f64], par: Par) -> Vec<f64> {
        let t0 = Instant::now();
        let mut out = self.prep.product(v, par);
        if let (Some(cv), true) = (&self.curv, self.use_curv) {
            cv.apply_add(v, &mut out);
        }
        self.products += 1;
        self.t_products += t0.elapsed().as_secs_f64();
        out
    }
}

impl StepSolver for MatrixFree {
    fn prepare(
        &mut self,
        pb: &Problem,
        params: &Params,
        l: &[Mat<f64>; 3],
        ev: &Evaluation,
        par: Par,
    ) -> Vec<f64> {
        let t0 = Instant::now();
        let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
        let mm = m * m;
        let tpl = terms_per_line(pb);
        self.prep.m = m;
        self.prep.p = p;
        self.prep.log_diagonal = params.log_diagonal;
        self.prep.tpl = tpl;
        self.prep.l = l.clone();
        self.prep.w = pb.w.clone();
        self.prep.x = ev.x.clone();
        self.prep.xw = (0..s * p).map(|col| response_weight(pb, col)).collect();
        // with scalar weights the products apply the Gram matrices G = D⁻ᴴD⁻¹ kept from
        // the diagonal (one Hermitian matrix-vector product per line instead of four
        // triangular solves through the LU factors, same memory)
        self.prep.use_gram = tpl == 1;
        if self.prep.use_gram {
            self.prep.lu = Vec::new();
            self.prep.perm = Vec::new();
        } else {
            self.prep.lu.clone_from(&ev.lu);
            self.prep.perm.clone_from(&ev.perm);
        }
        self.prep.tw = match pb.data.weights {
            Weights::Matrix(t) => Some(t.to_vec()),
            _ => None,
        };
        let log = ev.log.as_ref();
        self.prep.metric = log.map(|terms| terms.metric.clone());
        // a = Aᴴ r per column = D⁻ᴴ TᵀT (x − u) (w² with scalar weights; D⁻ᴴ ρ for
        // the log-magnitude objective)
        let mut a = vec![c64::new(0.0, 0.0); s * p * m];
        {
            let (lu, perm, tw, xw) = (&ev.lu, &ev.perm, &self.prep.tw, &self.prep.xw);
            a.par_chunks_mut(p * m).enumerate().for_each(|(i, ai)| {
                let off = i * p * m;
                for (q, v) in ai.iter_mut().enumerate() {
                    *v = match log {
                        Some(terms) => terms.rho[off + q],
                        None => ev.x[off + q] - pb.u[off + q],
                    };
                }
                if let Some(t) = tw {
                    weight_twice(&t[i * p * mm..(i + 1) * p * mm], ai, m);
                }
                let lui = MatRef::from_column_major_slice(&lu[i * mm..(i + 1) * mm], m, m);
                solve_lines_adjoint(lui, &perm[i * m..(i + 1) * m], ai, m, p);
                for j in 0..p {
                    let sc = xw[i * p + j];
                    for v in &mut ai[j * m..(j + 1) * m] {
                        *v *= sc;
                    }
                }
            });
        }
        let gz = lines::gradient_z(pb, ev, &a, par);
        let grad = lines::theta_gradient(params, l, &gz);
        self.curv = if self.curvature || self.use_modal {
            Curvature::new(params, l, &gz)
        } else {
            None
        };
        self.modal = if self.use_modal {
            ModalMetric::new(params, l)
        } else {
            None
        };
        if self.modal.is_some() || self.prep.use_gram || self.prepares.is_multiple_of(DIAG_REFRESH)
        {
            let t1 = Instant::now();
            // with the modal metric and scalar weights: G_Y in single precision instead
            let in_y = self.modal.is_some()
                && self.prep.use_gram
                && matches!(pb.data.weights, Weights::Scalar(_));
            let mut gram = std::mem::take(&mut self.prep.gram);
            gram.resize(
                if self.prep.use_gram && !in_y {
                    s * mm
                } else {
                    0
                },
                c64::new(0.0, 0.0),
            );
            let mut gram_y = std::mem::take(&mut self.prep.gram_y);
            gram_y.resize(if in_y { s * mm } else { 0 }, c32::new(0.0, 0.0));
            self.prep.gram_t = None;
            if let Some(mut modal) = self.modal.take() {
                let sums = if in_y {
                    self.prep.gram_t = Some(modal.t().to_owned());
                    modal_sums_y(&self.prep, ev, &mut gram_y, &modal)
                } else {
                    modal_sums(&self.prep, pb, ev, &mut gram, &modal)
                };
                modal.set_sums(&sums);
                self.modal = Some(modal);
            } else {
                let blocks = diagonal(&self.prep, pb, ev, &mut gram);
                self.diag = blocks[..3 * n_per_block(m)].to_vec();
                self.blocks = blocks;
            }
            self.prep.gram = gram;
            self.prep.gram_y = gram_y;
            self.t_diagonal += t1.elapsed().as_secs_f64();
        }
        self.prepares += 1;
        self.last = None;
        self.t_prepare += t0.elapsed().as_secs_f64();
        grad
    }

    fn step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        cancelled: &mut dyn FnMut() -> bool,
    ) -> Option<Vec<f64>> {
        self.retracted = None;
        if self.modal.is_none() {
            return self.solve_step(g, mu, par, cancelled);
        }
        // the Gauss–Newton step in X (the modal metric is B_X pulled back, and so is
        // the damping), taken in X: X + δX, where that stays positive definite
        let asked = self.use_curv;
        if self.x_wait > 0 {
            // the last step in X left the cone: straight to the step in the factors
            self.x_wait -= 1;
            return self.factor_step(g, mu, par, cancelled, asked);
        }
        self.use_curv = false;
        let before = self.products;
        let x = self.solve_step(g, mu, par, cancelled);
        self.x_products += self.products - before;
        self.use_curv = asked;
        match self.retract(&x?) {
            Ok(step) => {
                let x = &self.last.as_ref()?.0;
                let predicted = -2.0 * dot(g, x) - self.last.as_ref()?.1;
                self.retracted = Some((step.clone(), predicted));
                self.x_steps += 1;
                self.x_failures = 0;
                return Some(step);
            }
            Err(b) if b < 3 => self.out_of_cone[b] += 1,
            Err(_) => {}
        }
        // after the k-th failure in a row wait 2^(k−1) − 1 steps (at most X_STEP_WAIT)
        self.x_failures += 1;
        self.x_wait = ((1usize << (self.x_failures - 1).min(16)) - 1).min(X_STEP_WAIT);
        self.factor_step(g, mu, par, cancelled, asked)
    }

    fn set_curvature(&mut self, on: bool) {
        self.use_curv = on;
    }

    fn predicted(&mut self, g: &[f64], step: &[f64], par: Par) -> f64 {
        if let Some((r, pred)) = &self.retracted {
            if r.as_slice() == step {
                return *pred;
            }
        }
        -2.0 * dot(g, step) - self.quad(step, par)
    }

    fn initial_damping(&self) -> f64 {
        if self.modal.is_some() {
            MODAL_START_DAMPING
        } else {
            1e-3
        }
    }

    fn quad(&mut self, step: &[f64], par: Par) -> f64 {
        if let Some((x, q)) = &self.last {
            if x.as_slice() == step {
                return *q;
            }
        }
        let nv = self.apply(step, par);
        dot(step, &nv)
    }

    fn timings(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("matfree_prepare", self.t_prepare),
            ("matfree_diagonal", self.t_diagonal),
            ("matfree_products", self.t_products),
        ]
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut stats = vec![
            ("cg_iterations", self.cg_iterations as f64),
            ("products", self.products as f64),
            ("cg_cap_hits", self.cg_cap_hits as f64),
        ];
        if self.use_modal {
            stats.extend([
                ("x_steps", self.x_steps as f64),
                ("factor_steps", self.factor_steps as f64),
                ("x_step_products", self.x_products as f64),
                ("out_of_cone_m", self.out_of_cone[0] as f64),
                ("out_of_cone_c", self.out_of_cone[1] as f64),
                ("out_of_cone_k", self.out_of_cone[2] as f64),
            ]);
        }
        stats
    }
}
