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

use super::curvature::Curvature;
use super::input::Weights;
use super::line_solves::{solve_lines, solve_lines_adjoint, solve_lines_single};
use super::lines::{self, line_pieces, response_weight, terms_per_line};
use super::modal::{add_line_sums, add_sums_y, ModalMetric};
use super::objective::{Evaluation, Problem};
use super::parametrisation::{gram_lower, n_per_block, tri, Params, CONDITION_FLOOR};
use super::step_solver::StepSolver;
use faer::linalg::matmul::matmul;
use faer::{c32, c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;
use std::time::Instant;

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

/// The matrix-free step solver.
pub(crate) struct MatrixFree {
    m: usize,
    p: usize,
    log_diagonal: bool,
    /// LU factors and row permutations of every line (from the evaluation)
    lu: Vec<c64>,
    perm: Vec<usize>,
    /// G = D⁻ᴴD⁻¹ of every line, row-major (scalar weights), instead of the LU factors
    use_gram: bool,
    gram: Vec<c64>,
    /// with the modal metric and scalar weights: G_Y = T⁻¹ G T⁻ᵀ of every line instead
    /// (row-major, single precision: [`modal_sums_y`]), and T
    gram_y: Vec<c32>,
    gram_t: Option<Mat<f64>>,
    /// T of every column, row-major m×m (matrix weights only)
    tw: Option<Vec<f64>>,
    /// the metric W of every column at this point, row-major m×m (log-magnitude only)
    metric: Option<Vec<f64>>,
    /// points prepared so far
    prepares: usize,
    /// model responses x of every column, and w² (1 with matrix weights)
    x: Vec<c64>,
    xw: Vec<f64>,
    /// scaled ω of every line
    w: Vec<f64>,
    tpl: usize,
    l: [Mat<f64>; 3],
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
            m: 0,
            p: 0,
            log_diagonal: true,
            lu: Vec::new(),
            perm: Vec::new(),
            use_gram: false,
            gram: Vec::new(),
            gram_y: Vec::new(),
            gram_t: None,
            tw: None,
            metric: None,
            prepares: 0,
            x: Vec::new(),
            xw: Vec::new(),
            w: Vec::new(),
            tpl: 1,
            l: [Mat::zeros(0, 0), Mat::zeros(0, 0), Mat::zeros(0, 0)],
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
        let q = PAIRS
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
        let (m, nb) = (self.m, n_per_block(self.m));
        let params = self.params();
        let mut new_l = self.l.clone();
        for b in 0..3 {
            let dx = lines::tangent(&params, &self.l[b], &dth[b * nb..(b + 1) * nb]);
            let x = gram_lower(&self.l[b]);
            let target = Mat::from_fn(m, m, |i, j| x[(i, j)] + dx[(i, j)]);
            let tr: f64 = (0..m).map(|i| target[(i, i)]).sum();
            let shift = CONDITION_FLOOR * tr / (1.0 + m as f64 * CONDITION_FLOOR);
            let inner = Mat::from_fn(m, m, |i, j| {
                0.5 * (target[(i, j)] + target[(j, i)]) - if i == j { shift } else { 0.0 }
            });
            new_l[b] = inner.llt(faer::Side::Lower).map_err(|_| b)?.L().to_owned();
        }
        let (th0, th1) = (params.pack(&self.l), params.pack(&new_l));
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

    fn params(&self) -> Params {
        Params {
            m: self.m,
            log_diagonal: self.log_diagonal,
        }
    }

    /// N_θ v.
    pub(crate) fn apply(&mut self, v: &[f64], par: Par) -> Vec<f64> {
        let t0 = Instant::now();
        let (m, p) = (self.m, self.p);
        let n = self.x.len() / m; // columns
        let nb = n_per_block(m);
        let params = self.params();
        let dx: Vec<Mat<f64>> = (0..3)
            .map(|b| lines::tangent(&params, &self.l[b], &v[b * nb..(b + 1) * nb]))
            .collect();
        // [δM δC δK] X over all columns, X as [Re X | Im X] (m × 2n)
        let xr = MatRef::from_column_major_slice(&self.x, m, n);
        let xri = Mat::<f64>::from_fn(m, 2 * n, |r, c| {
            if c < n {
                xr[(r, c)].re
            } else {
                xr[(r, c - n)].im
            }
        });
        // with G_Y (modal coordinates): Tᵀ δX_b, so that y' = Tᵀ y and z = T G_Y y'
        let gram_t = self.gram_t.as_ref();
        let mut stacked = Mat::<f64>::zeros(3 * m, m);
        for (b, d) in dx.iter().enumerate() {
            let mut dst = stacked.as_mut().submatrix_mut(b * m, 0, m, m);
            match gram_t {
                Some(t) => matmul(
                    dst,
                    Accum::Replace,
                    t.transpose(),
                    d.as_ref(),
                    1.0,
                    Par::Seq,
                ),
                None => dst.copy_from(d.as_ref()),
            }
        }
        let mut prod = Mat::<f64>::zeros(3 * m, 2 * n);
        matmul(
            prod.as_mut(),
            Accum::Replace,
            stacked.as_ref(),
            xri.as_ref(),
            1.0,
            par,
        );
        // per column: y = −ω² δM x + iω δC x + δK x, z = D⁻ᴴ TᵀT D⁻¹ y; z'_b = conj(φ_b) z
        let mut zs = Mat::<f64>::zeros(3 * m, 2 * n); // [Re z'_b | Im z'_b] stacked by block
        {
            let mm = m * m;
            let (w, xw) = (&self.w, &self.xw);
            let (lu, perm, tw, metric) = (&self.lu, &self.perm, &self.tw, &self.metric);
            let (use_gram, gram, gram_y) = (self.use_gram, &self.gram, &self.gram_y);
            let in_y = gram_t.is_some();
            let prod = &prod;
            let lines: Vec<Vec<c64>> = (0..w.len())
                .into_par_iter()
                .map(|i| {
                    let om = w[i];
                    let mut y: Vec<c64> = (0..p * m)
                        .map(|q| {
                            let (col, r) = (i * p + q / m, q % m);
                            let pm = c64::new(prod[(r, col)], prod[(r, n + col)]);
                            let pc = c64::new(prod[(m + r, col)], prod[(m + r, n + col)]);
                            let pk = c64::new(prod[(2 * m + r, col)], prod[(2 * m + r, n + col)]);
                            pm * (-om * om) + pc * c64::new(0.0, om) + pk
                        })
                        .collect();
                    if in_y {
                        // z' = G_Y y' in the modal coordinates, single precision
                        let g = MatRef::from_row_major_slice(&gram_y[i * mm..(i + 1) * mm], m, m);
                        let yin = Mat::<c32>::from_fn(m, p, |r, c| {
                            let v = y[c * m + r];
                            c32::new(v.re as f32, v.im as f32)
                        });
                        let mut z = Mat::<c32>::zeros(m, p);
                        matmul(
                            z.as_mut(),
                            Accum::Replace,
                            g,
                            yin.as_ref(),
                            c32::new(1.0, 0.0),
                            Par::Seq,
                        );
                        for c in 0..p {
                            for r in 0..m {
                                let v = z[(r, c)];
                                y[c * m + r] = c64::new(v.re as f64, v.im as f64);
                            }
                        }
                    } else if use_gram {
                        // z = G y, G Hermitian (row-major)
                        let g = MatRef::from_row_major_slice(&gram[i * mm..(i + 1) * mm], m, m);
                        let yin = MatRef::from_column_major_slice(&y, m, p).to_owned();
                        matmul(
                            MatMut::from_column_major_slice_mut(&mut y, m, p),
                            Accum::Replace,
                            g,
                            yin.as_ref(),
                            c64::new(1.0, 0.0),
                            Par::Seq,
                        );
                    } else {
                        let lui = MatRef::from_column_major_slice(&lu[i * mm..(i + 1) * mm], m, m);
                        let pi = &perm[i * m..(i + 1) * m];
                        solve_lines(lui, pi, &mut y, m, p);
                        if let Some(t) = tw {
                            weight_twice(&t[i * p * mm..(i + 1) * p * mm], &mut y, m);
                        }
                        if let Some(wm) = metric {
                            weigh(&wm[i * p * mm..(i + 1) * p * mm], &mut y, m);
                        }
                        solve_lines_adjoint(lui, pi, &mut y, m, p);
                    }
                    for j in 0..p {
                        let sc = xw[i * p + j];
                        for v in &mut y[j * m..(j + 1) * m] {
                            *v *= sc;
                        }
                    }
                    y
                })
                .collect();
            for (i, z) in lines.iter().enumerate() {
                let om = w[i];
                for j in 0..p {
                    let col = i * p + j;
                    for r in 0..m {
                        let zr = z[j * m + r];
                        // conj(φ): −ω², −iω, 1
                        let z0 = zr * (-om * om);
                        let z1 = zr * c64::new(0.0, -om);
                        for (b, zb) in [z0, z1, zr].into_iter().enumerate() {
                            zs[(b * m + r, col)] = zb.re;
                            zs[(b * m + r, n + col)] = zb.im;
                        }
                    }
                }
            }
        }
        // R_b = Re Σ z'_b xᴴ = [Re z'_b | Im z'_b] [Re x | Im x]ᵀ
        let mut rz = Mat::<f64>::zeros(3 * m, m);
        matmul(
            rz.as_mut(),
            Accum::Replace,
            zs.as_ref(),
            xri.transpose(),
            1.0,
            par,
        );
        if let Some(t) = gram_t {
            // R_b = T Re Σ z'_b xᴴ
            for b in 0..3 {
                let zb = rz.as_ref().submatrix(b * m, 0, m, m).to_owned();
                matmul(
                    rz.as_mut().submatrix_mut(b * m, 0, m, m),
                    Accum::Replace,
                    t.as_ref(),
                    zb.as_ref(),
                    1.0,
                    Par::Seq,
                );
            }
        }
        let mut out = vec![0.0; 3 * nb];
        for b in 0..3 {
            lines::tangent_adjoint(
                &params,
                &self.l[b],
                |r, c| rz[(b * m + r, c)],
                &mut out[b * nb..(b + 1) * nb],
            );
        }
        if let (Some(cv), true) = (&self.curv, self.use_curv) {
            cv.apply_add(v, &mut out);
        }
        self.products += 1;
        self.t_products += t0.elapsed().as_secs_f64();
        out
    }
}

/// Σ over lines of `term(i, tl, G, out)` for every Gram term G of every line
/// (`width` sums; G formed, used, and kept in `gram` when it is not empty, else
/// dropped: O(s·m³) flops, O(m²) memory per thread).
fn line_sums(
    solver: &MatrixFree,
    pb: &Problem,
    ev: &Evaluation,
    gram: &mut [c64],
    width: usize,
    term: impl Fn(usize, usize, &[c64], &mut [f64]) + Sync,
) -> Vec<f64> {
    let (m, p, tpl) = (solver.m, solver.p, solver.tpl);
    let mm = m * m;
    let line = |i: usize, g: &mut [c64], out: &mut Vec<f64>| {
        let mut a = vec![c64::new(0.0, 0.0); p * m];
        line_pieces(pb, ev, i, g, &mut a);
        for tl in 0..tpl {
            term(i, tl, &g[tl * mm..(tl + 1) * mm], out);
        }
    };
    let add = |mut a: Vec<f64>, b: Vec<f64>| {
        for (x, y) in a.iter_mut().zip(&b) {
            *x += y;
        }
        a
    };
    // per-thread sums (not one vector per line)
    if !gram.is_empty() {
        gram.par_chunks_mut(tpl * mm)
            .enumerate()
            .fold(
                || vec![0.0; width],
                |mut out, (i, g)| {
                    line(i, g, &mut out);
                    out
                },
            )
            .reduce(|| vec![0.0; width], add)
    } else {
        (0..solver.w.len())
            .into_par_iter()
            .fold(
                || vec![0.0; width],
                |mut out, i| {
                    let mut g = vec![c64::new(0.0, 0.0); tpl * mm];
                    line(i, &mut g, &mut out);
                    out
                },
            )
            .reduce(|| vec![0.0; width], add)
    }
}

/// The sums of the modal metric ([`super::modal`]): 3 per modal pair (j, k).
fn modal_sums(
    solver: &MatrixFree,
    pb: &Problem,
    ev: &Evaluation,
    gram: &mut [c64],
    modal: &ModalMetric,
) -> Vec<f64> {
    let (m, p, tpl) = (solver.m, solver.p, solver.tpl);
    let ti = modal.ti();
    line_sums(solver, pb, ev, gram, 3 * n_per_block(m), |i, tl, g, out| {
        let cols: Vec<(&[c64], f64)> = (0..p)
            .filter(|&j| tpl == 1 || j == tl)
            .map(|j| {
                let col = i * p + j;
                (&solver.x[col * m..(col + 1) * m], solver.xw[col])
            })
            .collect();
        add_line_sums(ti, g, &cols, solver.w[i], out);
    })
}

/// The sums of the modal metric with scalar weights, from G_Y = Eᴴ E, E = D⁻¹ T⁻ᵀ (one
/// LU solve with m right-hand sides per line, instead of D⁻¹, G = D⁻ᴴ D⁻¹ and then
/// T⁻¹ G T⁻ᵀ: 12m³ instead of 18m³ flops per line), G_Y kept in `gram` for the
/// products, which then run in the modal coordinates (z = T G_Y Tᵀ y). E and G_Y in
/// single precision (the LU rounded from the evaluation's): they only shape the step —
/// the Gauss–Newton matrix and the metric, to ~1e-7 relative —, while the gradient,
/// the cost and the model stay in double precision, so the minimum is the same (the
/// noise-free tests return the exact model to 1e-8). Measured at m = 100, 2000 lines:
/// prepares 22.8 → 18.3–18.9 s.
fn modal_sums_y(
    solver: &MatrixFree,
    ev: &Evaluation,
    gram: &mut [c32],
    modal: &ModalMetric,
) -> Vec<f64> {
    let (m, p) = (solver.m, solver.p);
    let mm = m * m;
    let ti = modal.ti();
    // T⁻ᵀ, column-major
    let tit: Vec<c32> = (0..mm)
        .map(|q| c32::new(ti[(q / m, q % m)] as f32, 0.0))
        .collect();
    let width = 3 * n_per_block(m);
    gram.par_chunks_mut(mm)
        .enumerate()
        .fold(
            || vec![0.0; width],
            |mut out, (i, g)| {
                let mut e = tit.clone();
                let lui = MatRef::from_column_major_slice(&ev.lu[i * mm..(i + 1) * mm], m, m);
                solve_lines_single(lui, &ev.perm[i * m..(i + 1) * m], &mut e, m, m);
                lines::gram_into(
                    MatMut::from_row_major_slice_mut(g, m, m),
                    MatRef::from_column_major_slice(&e, m, m),
                );
                let cols: Vec<(&[c64], f64)> = (0..p)
                    .map(|j| {
                        let col = i * p + j;
                        (&solver.x[col * m..(col + 1) * m], solver.xw[col])
                    })
                    .collect();
                let gy = &*g;
                add_sums_y(
                    ti,
                    |j, k| {
                        let z = gy[j * m + k];
                        c64::new(z.re as f64, z.im as f64)
                    },
                    &cols,
                    solver.w[i],
                    &mut out,
                );
                out
            },
        )
        .reduce(
            || vec![0.0; width],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                a
            },
        )
}

/// The 3×3 blocks of N_θ coupling M, C, K at each (j, k) (see the module note;
/// layout: pair q of [`PAIRS`] at q·nb + tri(j, k), the diagonal first).
fn diagonal(solver: &MatrixFree, pb: &Problem, ev: &Evaluation, gram: &mut [c64]) -> Vec<f64> {
    let m = solver.m;
    let nb = n_per_block(m);
    // [L_M L_C L_K] (m × 3m)
    let l3 = Mat::<f64>::from_fn(m, 3 * m, |r, c| solver.l[c / m][(r, c % m)]);
    let mut d = line_sums(solver, pb, ev, gram, 6 * nb, |i, tl, g, out| {
        line_diagonal(solver, i, tl, g, &l3, out)
    });
    // the log scales s_b,jk s_b',jk
    let sc =
        |b: usize, j: usize, k: usize| lines::theta_scale(&solver.params(), &solver.l[b], j, k);
    for (q, &(b, bp)) in PAIRS.iter().enumerate() {
        for j in 0..m {
            for k in 0..=j {
                d[q * nb + tri(j, k)] *= sc(b, j, k) * sc(bp, j, k);
            }
        }
    }
    d
}

/// The part of diag(N_θ) of line `i`, term `tl` (of Gram matrix `g`, row-major).
fn line_diagonal(
    solver: &MatrixFree,
    i: usize,
    tl: usize,
    g: &[c64],
    l3: &Mat<f64>,
    out: &mut [f64],
) {
    let (m, p, tpl) = (solver.m, solver.p, solver.tpl);
    let nb = n_per_block(m);
    let om = solver.w[i];
    let gt = MatRef::from_row_major_slice(g, m, m);
    // G L3 as [Re G; Im G] L3
    let gri = Mat::<f64>::from_fn(2 * m, m, |r, c| {
        if r < m {
            gt[(r, c)].re
        } else {
            gt[(r - m, c)].im
        }
    });
    let mut gl = Mat::<f64>::zeros(2 * m, 3 * m);
    matmul(
        gl.as_mut(),
        Accum::Replace,
        gri.as_ref(),
        l3.as_ref(),
        1.0,
        Par::Seq,
    );
    let cols: Vec<usize> = if tpl == 1 {
        (0..p).map(|j| i * p + j).collect()
    } else {
        vec![i * p + tl]
    };
    let phi = [
        c64::new(-om * om, 0.0),
        c64::new(0.0, om),
        c64::new(1.0, 0.0),
    ];
    let glc = |j: usize, b: usize, k: usize| c64::new(gl[(j, b * m + k)], gl[(m + j, b * m + k)]);
    // (L_bᵀ G L_b')_kk = Σ_j L_b,jk (G L_b')_jk for the six pairs
    let lgl: Vec<Vec<c64>> = PAIRS
        .iter()
        .map(|&(b, bp)| {
            let l = &solver.l[b];
            (0..m)
                .map(|k| (k..m).map(|j| glc(j, bp, k) * l[(j, k)]).sum())
                .collect()
        })
        .collect();
    for &col in &cols {
        let x = &solver.x[col * m..(col + 1) * m];
        let a: Vec<Vec<c64>> = (0..3)
            .map(|b| {
                let l = &solver.l[b];
                (0..m)
                    .map(|k| (k..m).map(|c| x[c] * l[(c, k)]).sum())
                    .collect()
            })
            .collect();
        for (q, &(b, bp)) in PAIRS.iter().enumerate() {
            let sc = phi[b].conj() * phi[bp] * solver.xw[col];
            for j in 0..m {
                let gjj = gt[(j, j)].re;
                let xj = x[j];
                let xj2 = xj.norm_sqr();
                for k in 0..=j {
                    let (ab, abp) = (a[b][k], a[bp][k]);
                    let v = ab.conj() * abp * gjj
                        + ab.conj() * xj * glc(j, bp, k)
                        + xj.conj() * abp * glc(j, b, k).conj()
                        + lgl[q][k] * xj2;
                    out[q * nb + tri(j, k)] += (sc * v).re;
                }
            }
        }
    }
}

/// v_j ← W_j v_j for the p columns of one line (W_j symmetric row-major m×m, one
/// after another in `w`; v column after column).
fn weigh(w: &[f64], v: &mut [c64], m: usize) {
    for (wc, vj) in w.chunks(m * m).zip(v.chunks_mut(m)) {
        let wv: Vec<c64> = (0..m)
            .map(|r| (0..m).map(|q| vj[q] * wc[r * m + q]).sum())
            .collect();
        vj.copy_from_slice(&wv);
    }
}

/// v_j ← T_jᵀ T_j v_j for the p columns of one line (T_j row-major m×m, one after
/// another in `t`; v column after column).
fn weight_twice(t: &[f64], v: &mut [c64], m: usize) {
    let mm = m * m;
    for (tc, vj) in t.chunks(mm).zip(v.chunks_mut(m)) {
        let tv: Vec<c64> = (0..m)
            .map(|r| (0..m).map(|q| vj[q] * tc[r * m + q]).sum())
            .collect();
        for (q, x) in vj.iter_mut().enumerate() {
            *x = (0..m).map(|r| tv[r] * tc[r * m + q]).sum();
        }
    }
}

/// The LM damping and preconditioner of one step.
enum Metric {
    Modal(Box<ModalMetric>),
    /// μ·diag(N + H), and the inverted 3×3 blocks of N + μD
    Diagonal((Vec<f64>, Vec<[f64; 6]>)),
}

/// Most steps that go straight to the factors after steps in X left the cone, before
/// the next is tried (after the k-th failure in a row: 2^(k−1) − 1, at most this).
/// Where the optimum sits on the cone's edge nearly every step in X leaves it (chain,
/// m = 100, 2000 lines: 1 of 144 taken) and its CG solve — half the products of the
/// whole refinement — is thrown away; where a step in X fails now and then (the
/// 5-DOF chain from 2 % off: 4 of 23 steps) the next step tries again (waiting 10
/// steps after each failure took that case from 23 steps to 33–37).
const X_STEP_WAIT: usize = 10;

/// Inner iterations of the preconditioner with the curvature. Measured (chain,
/// m = 100, 2000 lines, whole refine): 3 / 8 / 16 / 32 / 64 → 934 s (max_iter) / 522 /
/// 293 / 215 / 241 s; the outer CG then never hits its cap (2 213 products at 32
/// against 11 415 at 8). m = 60, 1200 lines: 36.7 s at 8, 31.7 s at 32.
const INNER_CG: usize = 32;

/// About A⁻¹ r by INNER_CG preconditioned CG iterations (A = `apply`, preconditioner
/// `pre`), from 0.
fn inner_solve(
    r: &[f64],
    apply: impl Fn(&[f64]) -> Vec<f64>,
    pre: impl Fn(&[f64]) -> Vec<f64>,
) -> Vec<f64> {
    let mut x = vec![0.0; r.len()];
    let mut res = r.to_vec();
    let mut z = pre(&res);
    let mut d = z.clone();
    let mut rz = dot(&res, &z);
    for _ in 0..INNER_CG {
        let ad = apply(&d);
        let dad = dot(&d, &ad);
        if dad.is_nan() || rz.is_nan() || dad <= 0.0 || rz <= 0.0 {
            break;
        }
        let alpha = rz / dad;
        for q in 0..x.len() {
            x[q] += alpha * d[q];
            res[q] -= alpha * ad[q];
        }
        z = pre(&res);
        let rz2 = dot(&res, &z);
        let beta = rz2 / rz;
        rz = rz2;
        for q in 0..x.len() {
            d[q] = z[q] + beta * d[q];
        }
    }
    x
}

/// Block pairs (b, b') of the 3×3 blocks of N_θ kept per unknown (j, k): the
/// diagonal first, then M–C, M–K, C–K.
const PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// Inverse of a symmetric positive definite 3×3 matrix (upper triangle of `a`) as
/// [00, 11, 22, 01, 02, 12], by Cholesky; None when it is not numerically positive.
fn inverse3(a: [[f64; 3]; 3]) -> Option<[f64; 6]> {
    let l00 = a[0][0].sqrt();
    let l10 = a[0][1] / l00;
    let l20 = a[0][2] / l00;
    let d1 = a[1][1] - l10 * l10;
    if l00.is_nan() || l00 <= 0.0 || d1.is_nan() || d1 <= 1e-12 * a[1][1] {
        return None;
    }
    let l11 = d1.sqrt();
    let l21 = (a[1][2] - l20 * l10) / l11;
    let d2 = a[2][2] - l20 * l20 - l21 * l21;
    if d2.is_nan() || d2 <= 1e-12 * a[2][2] {
        return None;
    }
    let l22 = d2.sqrt();
    // L⁻¹ (lower), then A⁻¹ = L⁻ᵀ L⁻¹
    let i00 = 1.0 / l00;
    let i11 = 1.0 / l11;
    let i22 = 1.0 / l22;
    let i10 = -l10 * i00 / l11;
    let i21 = -l21 * i11 / l22;
    let i20 = -(l20 * i00 + l21 * i10) / l22;
    Some([
        i00 * i00 + i10 * i10 + i20 * i20,
        i11 * i11 + i21 * i21,
        i22 * i22,
        i10 * i11 + i20 * i21,
        i20 * i22,
        i21 * i22,
    ])
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
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
        self.m = m;
        self.p = p;
        self.log_diagonal = params.log_diagonal;
        self.tpl = tpl;
        self.l = l.clone();
        self.w = pb.w.clone();
        self.x = ev.x.clone();
        self.xw = (0..s * p).map(|col| response_weight(pb, col)).collect();
        // with scalar weights the products apply the Gram matrices G = D⁻ᴴD⁻¹ kept from
        // the diagonal (one Hermitian matrix-vector product per line instead of four
        // triangular solves through the LU factors, same memory)
        self.use_gram = tpl == 1;
        if self.use_gram {
            self.lu = Vec::new();
            self.perm = Vec::new();
        } else {
            self.lu.clone_from(&ev.lu);
            self.perm.clone_from(&ev.perm);
        }
        self.tw = match pb.data.weights {
            Weights::Matrix(t) => Some(t.to_vec()),
            _ => None,
        };
        let log = ev.log.as_ref();
        self.metric = log.map(|terms| terms.metric.clone());
        // a = Aᴴ r per column = D⁻ᴴ TᵀT (x − u) (w² with scalar weights; D⁻ᴴ ρ for
        // the log-magnitude objective)
        let mut a = vec![c64::new(0.0, 0.0); s * p * m];
        {
            let (lu, perm, tw, xw) = (&ev.lu, &ev.perm, &self.tw, &self.xw);
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
        if self.modal.is_some() || self.use_gram || self.prepares.is_multiple_of(DIAG_REFRESH) {
            let t1 = Instant::now();
            // with the modal metric and scalar weights: G_Y in single precision instead
            let in_y = self.modal.is_some()
                && self.use_gram
                && matches!(pb.data.weights, Weights::Scalar(_));
            let mut gram = std::mem::take(&mut self.gram);
            gram.resize(
                if self.use_gram && !in_y { s * mm } else { 0 },
                c64::new(0.0, 0.0),
            );
            let mut gram_y = std::mem::take(&mut self.gram_y);
            gram_y.resize(if in_y { s * mm } else { 0 }, c32::new(0.0, 0.0));
            self.gram_t = None;
            if let Some(mut modal) = self.modal.take() {
                let sums = if in_y {
                    self.gram_t = Some(modal.t().to_owned());
                    modal_sums_y(self, ev, &mut gram_y, &modal)
                } else {
                    modal_sums(self, pb, ev, &mut gram, &modal)
                };
                modal.set_sums(&sums);
                self.modal = Some(modal);
            } else {
                let blocks = diagonal(self, pb, ev, &mut gram);
                self.diag = blocks[..3 * n_per_block(m)].to_vec();
                self.blocks = blocks;
            }
            self.gram = gram;
            self.gram_y = gram_y;
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
