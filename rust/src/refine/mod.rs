//! Output-error refinement (DESIGN §6): the model that reproduces the measurement.
//!
//! The paper's estimator (eq. 49) minimises the *equation error* Σ‖D(ω_i)u_i − f_i‖²,
//! D = −ω²M + iωC + K. Here we minimise the *output error*
//!
//! ```text
//!     Σ_ij ‖T_ij (x_ij − u_ij)‖²,    x_ij = D(ω_i)⁻¹ f_ij   (the model's response)
//! ```
//!
//! over every line i and load case j, with a weight T_ij per column: a scalar w_ij
//! (relative, uniform, the user's) or a real m×m matrix (per-entry weights on the
//! measured DOFs, reduced by the caller). The matrices are parametrised by their
//! Cholesky factors, M = L_M L_Mᵀ + ε‖L_M‖² I, … (L lower triangular, ε = 1e-10),
//! so every model is symmetric with M, C, K ≻ 0 by construction; with the
//! `log_diagonal` option (default) the diagonals of the factors are exp(θ), which
//! makes M, C and K positive definite for every θ — and the model asymptotically
//! stable (every eigenvalue of the pencil has Re λ < 0).
//!
//! Levenberg–Marquardt with the analytic Jacobian: with v̂ = [−ω²x; iωx; x] and
//! δZ = [δM δC δK],
//!
//! ```text
//!     δx = −D⁻¹ (δZ v̂),     δX = δL Lᵀ + L δLᵀ.
//! ```
//!
//! One complex LU of D(ω_i) per line and evaluation, in parallel over lines.
//! In the entry coordinates of Z (row-major, index (r, c)) the Gauss–Newton matrix
//! is a sum of Kronecker products over the columns,
//!
//! ```text
//!     N_Z = Re Σ G ⊗ V̄,      G = Aᴴ A (m×m),  V̄ = conj(v̂) v̂ᵀ (3m×3m),  A = T D⁻¹,
//! ```
//!
//! formed by one real GEMM over all lines; the chain rule to the factors is a
//! congruence N_θ = Pᵀ N_Z P with the sparse tangent map P of δL ↦ δX. Everything is
//! done on data scaled as in DESIGN §3 (ω by its RMS, u and f by theirs).
//!
//! The step (N_θ + μ diag N_θ) δ = −g is solved densely (`dense.rs`: N_θ formed and
//! factored, (3m(m+1)/2)² doubles) or matrix-free (`matfree.rs`: preconditioned CG
//! with N_θ v applied line by line through the LU factors, O(s·m²) memory);
//! [`StepKind::Auto`] picks by m.

mod curvature;
mod dense;
mod lines;
mod matfree;
mod modal;

use crate::cg::Progress;
use crate::data::Scaling;
use crate::error::PodidError;
use dense::DenseNormal;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor as lu_factor, solve as lu_solve};
use faer::{c64, Mat, MatMut, MatRef, Par, Side};
use rayon::prelude::*;
use std::ops::ControlFlow;
use std::time::Instant;

/// Weight of each column (line i, load case j), in the order of the data.
#[derive(Clone, Copy)]
pub enum Weights<'a> {
    /// one scalar w_ij ≥ 0 per column: s·p values
    Scalar(&'a [f64]),
    /// one real m×m matrix T_ij per column, row-major: s·p·m·m values
    Matrix(&'a [f64]),
    /// the log-magnitude output error on measured entries (see [`LogTarget`])
    LogMagnitude(LogTarget<'a>),
}

/// The log-magnitude output error Σ_ije w_ije² (ln|y_ije| − ln|u_ije|)², y_ij = R x_ij:
/// each measured entry's dB error counts alike, whatever its level, and phase not at
/// all. Its Gauss–Newton matrix is Σ Re(J)ᵀRe(J) = ½ Re(JᴴJ) + ½ Re(JᵀJ) for the
/// complex J = ∂(ln y); the step uses the first half — the Hermitian metric
/// W_ij = ½ Rᵀ diag(w²/|y|²) R per column, re-formed at every point — which the
/// fast paths already take (the second half averages out over lines of varying
/// phase), with the exact gradient, so LM still descends the exact cost.
#[derive(Clone, Copy)]
pub struct LogTarget<'a> {
    /// R, n×m row-major (the measured entries are R x)
    pub basis: &'a [f64],
    pub n: usize,
    /// measured responses on the n entries, index ((i·p + j)·n + e)
    pub u: &'a [c64],
    /// weight w_ije ≥ 0 of each entry, same layout (0: not measured)
    pub w: &'a [f64],
}

/// Measured reduced data: s lines, p load cases, order m.
#[derive(Clone, Copy)]
pub struct OeData<'a> {
    /// angular frequency of each line (s)
    pub omega: &'a [f64],
    /// target responses u_ij, index ((i·p + j)·m + r)
    pub u: &'a [c64],
    /// forces f_ij, same layout
    pub f: &'a [c64],
    pub weights: Weights<'a>,
    pub m: usize,
    pub p: usize,
}

impl OeData<'_> {
    pub fn s(&self) -> usize {
        self.omega.len()
    }

    fn validate(&self) -> Result<(), PodidError> {
        let (s, p, m) = (self.s(), self.p, self.m);
        let bad = |msg: String| Err(PodidError::Invalid(msg));
        if s == 0 || p == 0 || m == 0 {
            return bad(format!("empty data: s = {s} lines, p = {p}, m = {m}"));
        }
        if self.u.len() != s * p * m || self.f.len() != s * p * m {
            return bad(format!(
                "u and f must hold s·p·m = {} values, got {} and {}",
                s * p * m,
                self.u.len(),
                self.f.len()
            ));
        }
        let finite = |z: &c64| z.re.is_finite() && z.im.is_finite();
        if !self.u.iter().all(finite) || !self.f.iter().all(finite) {
            return bad("u or f contains NaN or inf".into());
        }
        if !self.omega.iter().all(|w| w.is_finite() && *w > 0.0) {
            return bad("omega must be finite and strictly positive".into());
        }
        match self.weights {
            Weights::Scalar(w) => {
                if w.len() != s * p {
                    return bad(format!("scalar weights: expected s·p = {} values", s * p));
                }
                if !w.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    return bad("weights must be finite and non-negative".into());
                }
                if w.iter().all(|v| *v == 0.0) {
                    return bad("every weight is zero: there is nothing to fit".into());
                }
            }
            Weights::Matrix(t) => {
                if t.len() != s * p * m * m {
                    return bad(format!(
                        "matrix weights: expected s·p·m² = {} values",
                        s * p * m * m
                    ));
                }
                if !t.iter().all(|v| v.is_finite()) {
                    return bad("weights must be finite".into());
                }
            }
            Weights::LogMagnitude(lt) => {
                let n = lt.n;
                if n == 0 || lt.basis.len() != n * m {
                    return bad(format!(
                        "log-magnitude basis: expected n·m = {} values (n = {n})",
                        n * m
                    ));
                }
                if !lt.basis.iter().all(|v| v.is_finite()) {
                    return bad("log-magnitude basis contains NaN or inf".into());
                }
                if lt.u.len() != s * p * n || lt.w.len() != s * p * n {
                    return bad(format!(
                        "log-magnitude targets and weights: expected s·p·n = {} values each",
                        s * p * n
                    ));
                }
                if !lt.w.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    return bad("weights must be finite and non-negative".into());
                }
                if lt.w.iter().all(|v| *v == 0.0) {
                    return bad("every weight is zero: there is nothing to fit".into());
                }
                if !lt.u.iter().all(finite) {
                    return bad("log-magnitude targets contain NaN or inf".into());
                }
                if lt
                    .u
                    .iter()
                    .zip(lt.w)
                    .any(|(z, w)| *w > 0.0 && z.norm_sqr() == 0.0)
                {
                    return bad(
                        "a weighted target entry is zero: its log-magnitude is undefined \
                         (give it weight 0)"
                            .into(),
                    );
                }
            }
        }
        Ok(())
    }
}

/// Options of the Levenberg–Marquardt iteration.
#[derive(Clone, Copy, Debug)]
pub struct OeOptions {
    /// most Gauss–Newton steps (accepted or not)
    pub max_iter: usize,
    /// converged when the last [`FTOL_WINDOW`] accepted steps together lowered the cost
    /// by less than `FTOL_WINDOW · ftol` relative: a slow drift along a flat valley
    /// (a direction of the model the data hardly see) is not worth the time
    pub ftol: f64,
    /// converged when ‖δθ‖ ≤ xtol·(‖θ‖ + xtol)
    pub xtol: f64,
    /// diagonals of the factors as exp(θ): M, C, K positive definite for every θ
    pub log_diagonal: bool,
    /// how each Gauss–Newton step is solved
    pub solver: StepKind,
    /// add the curvature of the parametrisation X = L Lᵀ to the Gauss–Newton matrix
    /// ([`curvature`], [`CURVATURE_SWITCH`]): far better minima on measured data, whose
    /// optimum puts C on the cone's boundary; off by default — on noise-free data from
    /// a start a few per cent off it can take more steps than Gauss–Newton alone
    pub curvature: bool,
    /// matrix-free step only: damp and precondition by the modal metric and take the
    /// Gauss–Newton step in X ([`modal`]) instead of μ·diag N_θ and its 3×3 blocks
    pub modal_metric: bool,
}

impl Default for OeOptions {
    fn default() -> Self {
        OeOptions {
            max_iter: 200,
            ftol: 1e-7,
            xtol: 1e-12,
            log_diagonal: true,
            solver: StepKind::Auto,
            curvature: false,
            modal_metric: false,
        }
    }
}

/// The linear algebra of a Gauss–Newton step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// N_θ formed and factored: (3m(m+1)/2)² doubles, O(s·m⁴ + m⁶) flops per step
    Dense,
    /// preconditioned CG with N v applied line by line: O(s·m²) memory
    MatrixFree,
    /// dense while N_θ is small (see [`StepKind::resolve`]), matrix-free beyond
    Auto,
}

impl StepKind {
    /// The names the Python API uses: "dense", "matrix-free", "auto".
    pub fn from_name(name: &str) -> Result<StepKind, PodidError> {
        match name {
            "dense" => Ok(StepKind::Dense),
            "matrix-free" => Ok(StepKind::MatrixFree),
            "auto" => Ok(StepKind::Auto),
            _ => Err(PodidError::Invalid(format!(
                "solver must be 'dense', 'matrix-free' or 'auto', got {name:?}"
            ))),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            StepKind::Dense => "dense",
            StepKind::MatrixFree => "matrix-free",
            StepKind::Auto => "auto",
        }
    }

    /// Dense or matrix-free for order m on s lines with `terms` Gram terms per line.
    pub fn resolve(&self, m: usize, _s: usize, _terms: usize) -> StepKind {
        match self {
            StepKind::Auto => {
                if m <= AUTO_DENSE_MAX_M {
                    StepKind::Dense
                } else {
                    StepKind::MatrixFree
                }
            }
            k => *k,
        }
    }
}

/// Largest order the automatic choice solves densely. Measured
/// (`benches/bench_refine.py --crossover`, s = 800, chain with 0.1 % noise): the dense
/// step is 8×, 22×, 16× faster per converged fit at m = 10, 20, 30 and 2.6× at m = 40,
/// where one step costs the same either way (1.2–1.3 s) but the matrix-free CG steps
/// are inexact and LM needs about 3× as many. The dense step grows as ~m⁶ per step
/// (0.21 s at m = 30, 1.26 s at m = 40), the matrix-free one as ~m²·(CG products);
/// above m = 40 the matrix-free step is chosen, with O(s·m²) memory. With the modal
/// metric (Python's default for a matrix-free step) the chain's crossover moved to
/// between m = 10 and 20 (m = 30: 1.18 s against 5.25 s), but on the measured beam (m ≤ 30, with
/// curvature) that step fitted worse and slower, so the rule stays (README).
pub const AUTO_DENSE_MAX_M: usize = 40;

/// Most CG iterations of one matrix-free step.
pub const MAX_CG_ITER: usize = 100;

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// relative cost decrease over the last accepted steps below ftol
    CostConverged,
    /// step below xtol
    StepConverged,
    /// the gradient vanished (an exact fit)
    GradientZero,
    /// no step lowered the cost even with the damping at its ceiling
    NoDescent,
    /// max_iter reached
    MaxIter,
}

impl Stop {
    pub fn name(&self) -> &'static str {
        match self {
            Stop::CostConverged => "cost converged",
            Stop::StepConverged => "step converged",
            Stop::GradientZero => "gradient zero",
            Stop::NoDescent => "no further descent",
            Stop::MaxIter => "max_iter reached",
        }
    }

    pub fn converged(&self) -> bool {
        !matches!(self, Stop::MaxIter)
    }
}

/// The refined model and what the iteration did.
pub struct OeReport {
    /// [M, C, K] in the caller's units
    pub mck: [Mat<f64>; 3],
    /// cost Σ‖T(x − u)‖² of the start and of the answer, caller's units
    pub cost_start: f64,
    pub cost: f64,
    /// Gauss–Newton steps taken (accepted or rejected) and accepted
    pub iterations: usize,
    pub accepted: usize,
    pub stop: Stop,
    /// (iteration, cost) after every accepted step, caller's units
    pub history: Vec<(usize, f64)>,
    pub scaling: Scaling,
    /// wall time per phase, seconds: evaluate, normal, solve, total, and the step
    /// solver's own parts
    pub timings: Vec<(&'static str, f64)>,
    /// the step solver used ("dense" or "matrix-free") and its counts
    pub solver: &'static str,
    pub solver_stats: Vec<(&'static str, f64)>,
    /// model responses D(ω)⁻¹ f of the start as given and of the answer, caller's
    /// units, in the layout of the data (column after column); the start's is None
    /// when it has a pole on a measured line
    pub responses_start: Option<Vec<c64>>,
    pub responses: Vec<c64>,
}

/// The linear algebra of one Gauss–Newton step. At the current point `prepare`
/// returns the gradient g = Jᵀr (J the Jacobian of the weighted residual r in θ);
/// `step` then solves (N + μ·diag(N)) δ = −g for a damping μ (N = JᵀJ; None if it
/// could not), and `quad` gives δᵀNδ for the model's predicted decrease.
pub(crate) trait StepSolver {
    fn prepare(
        &mut self,
        pb: &Problem,
        params: &Params,
        l: &[Mat<f64>; 3],
        ev: &Evaluation,
        par: Par,
    ) -> Vec<f64>;
    /// `cancelled` is polled during long solves; when it returns true the solver
    /// stops (its answer is then ignored).
    fn step(
        &mut self,
        g: &[f64],
        mu: f64,
        par: Par,
        cancelled: &mut dyn FnMut() -> bool,
    ) -> Option<Vec<f64>>;
    fn quad(&mut self, step: &[f64], par: Par) -> f64;
    /// The decrease of the cost the Gauss–Newton model predicts for `step`:
    /// −2gᵀδ − δᵀNδ (a solver that retracts its step gives its model's own).
    fn predicted(&mut self, g: &[f64], step: &[f64], par: Par) -> f64 {
        let gd: f64 = g.iter().zip(step).map(|(a, b)| a * b).sum();
        -2.0 * gd - self.quad(step, par)
    }
    /// Whether the next step uses the parametrisation's curvature ([`curvature`]).
    fn set_curvature(&mut self, on: bool);
    /// The LM damping μ of the first step (after the first `prepare`).
    fn initial_damping(&self) -> f64 {
        1e-3
    }
    /// Wall time of the solver's own parts, seconds (for the report).
    fn timings(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// Counts of the solver's work (for the report).
    fn stats(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
}

/// Unknowns per block: the lower triangle of L.
pub fn n_per_block(m: usize) -> usize {
    m * (m + 1) / 2
}

/// Index of L[j][k] (j ≥ k) in a block's parameters.
#[inline]
pub(crate) fn tri(j: usize, k: usize) -> usize {
    j * (j + 1) / 2 + k
}

/// Lower-triangular factor of a symmetric matrix, with eigenvalues below `floor`
/// raised to it first (so a PSD matrix with zero eigenvalues still factors).
pub fn psd_factor(x: MatRef<f64>, floor: f64) -> Result<Mat<f64>, PodidError> {
    let m = x.nrows();
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| PodidError::Invalid(format!("eigendecomposition failed: {e:?}")))?;
    let (q, d) = (evd.U(), evd.S().column_vector());
    let raised = Mat::from_fn(m, m, |i, j| {
        (0..m)
            .map(|k| q[(i, k)] * d[k].max(floor) * q[(j, k)])
            .sum::<f64>()
    });
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (raised[(i, j)] + raised[(j, i)]));
    let l = sym.llt(Side::Lower).map_err(|_| {
        PodidError::Invalid(
            "the start model could not be factored: it is not positive semidefinite".into(),
        )
    })?;
    Ok(l.L().to_owned())
}

/// Parameters θ of three factors (scaled units).
pub(crate) struct Params {
    m: usize,
    log_diagonal: bool,
}

impl Params {
    fn len(&self) -> usize {
        3 * n_per_block(self.m)
    }

    /// θ from the factors [L_M, L_C, L_K].
    fn pack(&self, l: &[Mat<f64>; 3]) -> Vec<f64> {
        let nb = n_per_block(self.m);
        let mut th = vec![0.0; 3 * nb];
        for (b, lb) in l.iter().enumerate() {
            for j in 0..self.m {
                for k in 0..=j {
                    let v = lb[(j, k)];
                    th[b * nb + tri(j, k)] = if j == k && self.logged(b) {
                        // the sign of a column of L is free: log|L_jj|
                        v.abs().max(f64::MIN_POSITIVE).ln()
                    } else {
                        v
                    };
                }
            }
        }
        th
    }

    fn logged(&self, _b: usize) -> bool {
        self.log_diagonal
    }

    /// The factors from θ.
    fn unpack(&self, th: &[f64]) -> [Mat<f64>; 3] {
        let (m, nb) = (self.m, n_per_block(self.m));
        [0, 1, 2].map(|b| {
            Mat::from_fn(m, m, |j, k| {
                if k > j {
                    0.0
                } else {
                    let v = th[b * nb + tri(j, k)];
                    if j == k && self.logged(b) {
                        v.exp()
                    } else {
                        v
                    }
                }
            })
        })
    }
}

/// X = L Lᵀ + ε‖L‖²_F I with ε = [`CONDITION_FLOOR`]: positive definite with
/// cond(X) ≤ m/ε + 1 for every L, so that definiteness and the modes of the model are
/// numerically certain (a factor drifting to singular leaves a mass, damping or
/// stiffness floored at ε times the block's trace).
pub(crate) fn gram_lower(l: &Mat<f64>) -> Mat<f64> {
    let m = l.nrows();
    let trace: f64 = (0..m)
        .map(|i| (0..=i).map(|k| l[(i, k)] * l[(i, k)]).sum::<f64>())
        .sum();
    Mat::from_fn(m, m, |i, j| {
        let llt: f64 = (0..=i.min(j)).map(|k| l[(i, k)] * l[(j, k)]).sum();
        llt + if i == j { CONDITION_FLOOR * trace } else { 0.0 }
    })
}

/// Per-line LU of D(ω_i), the responses x and the cost.
pub(crate) struct Evaluation {
    /// LU factors of every line, column-major m×m each
    lu: Vec<c64>,
    /// row permutation of every line
    perm: Vec<usize>,
    /// model responses x_ij, layout of the data
    x: Vec<c64>,
    cost: f64,
    /// the log-magnitude objective's metric and gradient source at this point
    log: Option<LogTerms>,
}

/// Per column at the current point (log-magnitude objective): the metric
/// W = ½ Rᵀ diag(w²/|y|²) R (row-major m×m) and ρ = Rᵀ (w r ⊘ conj(y)), r the
/// entries' residuals, so that the gradient is Re Σ ρᴴ δx (in place of W (x − u)).
pub(crate) struct LogTerms {
    metric: Vec<f64>,
    rho: Vec<c64>,
}

/// Cost, W and ρ of one column (see [`LogTerms`]); infinite cost when a weighted
/// entry of y is zero or not finite.
fn log_column(
    lt: &LogTarget,
    m: usize,
    col: usize,
    log_u: &[f64],
    x: &[c64],
    metric: &mut [f64],
    rho: &mut [c64],
) -> f64 {
    let n = lt.n;
    metric.fill(0.0);
    rho.fill(c64::new(0.0, 0.0));
    let mut cost = 0.0;
    for e in 0..n {
        let w = lt.w[col * n + e];
        if w == 0.0 {
            continue;
        }
        let row = &lt.basis[e * m..(e + 1) * m];
        let y: c64 = row.iter().zip(x).map(|(a, b)| b * *a).sum();
        let y2 = y.norm_sqr();
        if !(y2 > 0.0 && y2.is_finite()) {
            return f64::INFINITY;
        }
        let r = w * (0.5 * y2.ln() - log_u[col * n + e]);
        cost += r * r;
        let g = y * (w * r / y2); // w r / conj(y)
        let h = 0.5 * w * w / y2;
        for a in 0..m {
            rho[a] += g * row[a];
            let ha = h * row[a];
            for b in 0..m {
                metric[a * m + b] += ha * row[b];
            }
        }
    }
    cost
}

pub(crate) fn dynamic_stiffness(mck: &[Mat<f64>; 3], w: f64, out: &mut [c64]) {
    let m = mck[0].nrows();
    for c in 0..m {
        for r in 0..m {
            out[c * m + r] = c64::new(mck[2][(r, c)] - w * w * mck[0][(r, c)], w * mck[1][(r, c)]);
        }
    }
}

/// Weighted residual r = T (x − u) of one column, and ‖r‖².
pub(crate) fn weighted_residual(
    t: Option<&[f64]>,
    w: f64,
    x: &[c64],
    u: &[c64],
    r: &mut [c64],
) -> f64 {
    let m = x.len();
    match t {
        None => {
            for k in 0..m {
                r[k] = (x[k] - u[k]) * w;
            }
        }
        Some(t) => {
            for a in 0..m {
                let mut acc = c64::new(0.0, 0.0);
                for k in 0..m {
                    acc += (x[k] - u[k]) * t[a * m + k];
                }
                r[a] = acc;
            }
        }
    }
    r.iter().map(|z| z.norm_sqr()).sum()
}

pub(crate) struct Problem<'a> {
    data: OeData<'a>,
    /// scaled ω, u, f
    w: Vec<f64>,
    u: Vec<c64>,
    f: Vec<c64>,
    /// ln|u_ije| of the scaled log-magnitude targets (empty for the other weights)
    log_u: Vec<f64>,
}

/// ln|u / su| of each log-magnitude target entry (0 where its weight is 0).
fn log_targets(weights: &Weights, su: f64) -> Vec<f64> {
    match weights {
        Weights::LogMagnitude(lt) => {
            lt.u.iter()
                .zip(lt.w)
                .map(|(z, w)| if *w > 0.0 { (z.norm() / su).ln() } else { 0.0 })
                .collect()
        }
        _ => Vec::new(),
    }
}

impl Problem<'_> {
    fn column_weight(&self, col: usize) -> (Option<&[f64]>, f64) {
        let m = self.data.m;
        match self.data.weights {
            Weights::Scalar(w) => (None, w[col]),
            Weights::Matrix(t) => (Some(&t[col * m * m..(col + 1) * m * m]), 1.0),
            Weights::LogMagnitude(_) => unreachable!("the log-magnitude cost is not T (x − u)"),
        }
    }

    /// LU of every line, the model responses and the cost (scaled units).
    fn evaluate(&self, mck: &[Mat<f64>; 3]) -> Result<Evaluation, PodidError> {
        self.evaluate_into(mck, Vec::new())
    }

    /// As [`Self::evaluate`], the LU factors written over `spare` where it has their size
    /// (every entry is written: its contents do not matter) — the refinement hands back
    /// the buffer of the evaluation it drops, instead of the kernel clearing a fresh
    /// s·m² one each time (320 MB at m = 100, 2000 lines).
    fn evaluate_into(
        &self,
        mck: &[Mat<f64>; 3],
        spare: Vec<c64>,
    ) -> Result<Evaluation, PodidError> {
        let (s, p, m) = (self.data.s(), self.data.p, self.data.m);
        let mut lu = if spare.len() == s * m * m {
            spare
        } else {
            crate::buffer::zeroed_c64(s * m * m)
        };
        let mut perm = vec![0usize; s * m];
        let mut x = self.f.clone();
        let costs: Vec<Option<f64>> = lu
            .par_chunks_mut(m * m)
            .zip(perm.par_chunks_mut(m))
            .zip(x.par_chunks_mut(p * m))
            .enumerate()
            .map(|(i, ((a, pr), xi))| {
                dynamic_stiffness(mck, self.w[i], a);
                let mut pinv = vec![0usize; m];
                let mut amat = MatMut::from_column_major_slice_mut(a, m, m);
                let mut mem = MemBuffer::new(lu_factor::lu_in_place_scratch::<usize, c64>(
                    m,
                    m,
                    Par::Seq,
                    Default::default(),
                ));
                let (info, _) = lu_factor::lu_in_place(
                    amat.as_mut(),
                    pr,
                    &mut pinv,
                    Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                );
                let _ = info;
                // a zero (or non-finite) pivot: D(ω_i) is singular, the model has a pole on the line
                let diag_ok = (0..m).all(|k| {
                    let d = amat[(k, k)];
                    d.norm_sqr() > 0.0 && d.re.is_finite() && d.im.is_finite()
                });
                if !diag_ok {
                    return None;
                }
                solve_lines(amat.as_ref(), pr, xi, m, p);
                if matches!(self.data.weights, Weights::LogMagnitude(_)) {
                    return Some(0.0); // costed below, with the metric
                }
                let mut r = vec![c64::new(0.0, 0.0); m];
                let mut cost = 0.0;
                for j in 0..p {
                    let col = i * p + j;
                    let (t, wt) = self.column_weight(col);
                    cost += weighted_residual(
                        t,
                        wt,
                        &xi[j * m..(j + 1) * m],
                        &self.u[col * m..(col + 1) * m],
                        &mut r,
                    );
                }
                Some(cost)
            })
            .collect();
        let mut cost = 0.0;
        for c in costs {
            match c {
                Some(v) if v.is_finite() => cost += v,
                _ => cost = f64::INFINITY,
            }
        }
        let mut log = None;
        if let (Weights::LogMagnitude(lt), true) = (self.data.weights, cost.is_finite()) {
            let mut metric = vec![0.0; s * p * m * m];
            let mut rho = vec![c64::new(0.0, 0.0); s * p * m];
            cost = metric
                .par_chunks_mut(m * m)
                .zip(rho.par_chunks_mut(m))
                .enumerate()
                .map(|(col, (w, r))| {
                    log_column(&lt, m, col, &self.log_u, &x[col * m..(col + 1) * m], w, r)
                })
                .sum();
            log = Some(LogTerms { metric, rho });
        }
        Ok(Evaluation {
            lu,
            perm,
            x,
            cost,
            log,
        })
    }
}

/// Solve D x_j = f_j in place for the p columns of one line (x holds f on entry).
pub(crate) fn solve_lines<T: faer::traits::ComplexField>(
    lu: MatRef<T>,
    perm: &[usize],
    x: &mut [T],
    m: usize,
    p: usize,
) {
    let pinv = inverse_perm(perm);
    let permref = faer::perm::PermRef::new_checked(perm, &pinv, m);
    let rhs = MatMut::from_column_major_slice_mut(x, m, p);
    let mut mem = MemBuffer::new(lu_solve::solve_in_place_scratch::<usize, T>(m, p, Par::Seq));
    lu_solve::solve_in_place(lu, lu, permref, rhs, Par::Seq, MemStack::new(&mut mem));
}

/// Solve D(ω) X = B in place for the p columns of B (m×p, column-major) in single
/// precision, from the double-precision LU of D (rounded to single first).
pub(crate) fn solve_lines_single(
    lu: MatRef<c64>,
    perm: &[usize],
    x: &mut [faer::c32],
    m: usize,
    p: usize,
) {
    let lu32 = Mat::<faer::c32>::from_fn(m, m, |i, j| {
        let z = lu[(i, j)];
        faer::c32::new(z.re as f32, z.im as f32)
    });
    solve_lines(lu32.as_ref(), perm, x, m, p);
}

/// Solve D(ω)ᴴ z = x in place for the p columns of x (m×p, column-major), from
/// the LU of D.
pub(crate) fn solve_lines_adjoint(
    lu: MatRef<c64>,
    perm: &[usize],
    x: &mut [c64],
    m: usize,
    p: usize,
) {
    let pinv = inverse_perm(perm);
    let permref = faer::perm::PermRef::new_checked(perm, &pinv, m);
    let rhs = MatMut::from_column_major_slice_mut(x, m, p);
    let mut mem = MemBuffer::new(lu_solve::solve_transpose_in_place_scratch::<usize, c64>(
        m,
        p,
        Par::Seq,
    ));
    lu_solve::solve_transpose_in_place_with_conj(
        lu,
        lu,
        permref,
        faer::Conj::Yes,
        rhs,
        Par::Seq,
        MemStack::new(&mut mem),
    );
}

fn inverse_perm(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (i, &p) in perm.iter().enumerate() {
        inv[p] = i;
    }
    inv
}

/// D⁻¹ of one line from its LU (column-major m×m).
pub(crate) fn inverse_of(lu: MatRef<c64>, perm: &[usize], m: usize) -> Vec<c64> {
    let mut inv = vec![c64::new(0.0, 0.0); m * m];
    for k in 0..m {
        inv[k * m + k] = c64::new(1.0, 0.0);
    }
    solve_lines(lu, perm, &mut inv, m, m);
    inv
}

/// Relative floor ε of every block: X = L Lᵀ + ε tr(L Lᵀ) I (see `gram_lower`).
pub const CONDITION_FLOOR: f64 = 1e-10;

/// Accepted steps over which the relative cost decrease is judged (see `ftol`).
pub const FTOL_WINDOW: usize = 10;

/// With [`OeOptions::curvature`], the parametrisation's curvature ([`curvature`]) is
/// left out of the next step when the last accepted step lowered the cost by at least
/// this fraction and no step from the new point was rejected yet (Fletcher & Xu's
/// hybrid rule): a fast-falling cost is the small-residual case, where Gauss–Newton
/// alone converges quadratically and the term, O(residual), would only slow the
/// directions the data hardly see (measured: exact data of an 8-DOF chain on a POD
/// basis with 1e-14 of the energy in two directions, 2.6e-6 from the truth with the
/// term at every step, 1.5e-8 with this rule, 1.6e-8 with Gauss–Newton alone). The
/// rule of NL2SOL instead (the model that predicted the last step better) was measured
/// on the beam: 0.69 / 0.91 dB at 50–300 / 20–800 Hz against 0.39 / 0.58 with this one.
pub const CURVATURE_SWITCH: f64 = 0.2;

/// Levenberg–Marquardt after a rejected step: μ ← μν, ν ← 2ν; true when μ has grown
/// past any use (no descent).
fn more_damping(mu: &mut f64, nu: &mut f64) -> bool {
    *mu *= *nu;
    *nu *= 2.0;
    *mu > 1e16
}

/// Whether the symmetric part of `x` has every eigenvalue at least ½ε tr(x) (ε =
/// [`CONDITION_FLOOR`]): true of every matrix the parametrisation gives back
/// (L Lᵀ + ε tr(L Lᵀ) I), false of a singular one.
fn has_condition_floor(x: MatRef<f64>) -> bool {
    let m = x.nrows();
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
    let tr: f64 = (0..m).map(|i| sym[(i, i)]).sum();
    match sym.self_adjoint_eigenvalues(Side::Lower) {
        Ok(ev) => tr > 0.0 && ev.iter().all(|&v| v >= 0.5 * CONDITION_FLOOR * tr),
        Err(_) => false,
    }
}

/// Least damping ratio of the start (of a C without the parametrisation's floor, see
/// [`has_condition_floor`]): C is raised (where it is lower) so that every
/// direction of Z = (2Ω)^-½ Φᵀ C Φ (2Ω)^-½ — Φ the undamped modes, Ω their
/// frequencies; Z's eigenvalues are damping ratios in modal terms — has at least
/// this much (see [`damping_floor`]).
pub const C_START_FLOOR: f64 = 1e-4;

/// C raised to the least damping ratio ζ₀ (scaled units; M, K ≻ 0): with the
/// mass-normalised undamped modes Φ = M^-½ V (V the eigenvectors of M^-½ K M^-½,
/// eigenvalues Ω²), Z = (2Ω)^-½ Φᵀ C Φ (2Ω)^-½ has its eigenvalues raised to ζ₀ and
/// C = Φ⁻ᵀ (2Ω)^½ Z (2Ω)^½ Φ⁻¹ formed back. A C that already has ζ₀ everywhere is
/// returned as it is. (A floor relative to the largest entry of M or K instead — the
/// earlier rule — added damping of ζ ~ 1 to a measured beam's modes, whose K spans
/// decades: the refinement then started far from its start.)
pub fn damping_floor(
    mass: MatRef<f64>,
    damping: MatRef<f64>,
    stiffness: MatRef<f64>,
    zeta0: f64,
) -> Result<Mat<f64>, PodidError> {
    let m = mass.nrows();
    let eig = |x: &Mat<f64>| {
        let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
        sym.self_adjoint_eigen(Side::Lower)
            .map_err(|e| PodidError::Invalid(format!("eigendecomposition failed: {e:?}")))
    };
    let scaled = |q: MatRef<f64>, d: &dyn Fn(usize) -> f64| {
        Mat::from_fn(m, m, |i, j| {
            (0..m).map(|k| q[(i, k)] * d(k) * q[(j, k)]).sum::<f64>()
        })
    };
    let em = eig(&mass.to_owned())?;
    let (qm, dm) = (em.U(), em.S().column_vector());
    if (0..m).any(|k| dm[k] <= 0.0 || !dm[k].is_finite()) {
        return Err(PodidError::Invalid(
            "M of the start is not positive definite".into(),
        ));
    }
    let m_half = scaled(qm, &|k| dm[k].sqrt());
    let m_inv_half = scaled(qm, &|k| 1.0 / dm[k].sqrt());
    let a = &m_inv_half * stiffness * &m_inv_half;
    let ek = eig(&a)?;
    let (v, w2) = (ek.U(), ek.S().column_vector());
    let wmax = (0..m).map(|k| w2[k].max(0.0).sqrt()).fold(0.0, f64::max);
    let floor = 1e-6 * wmax.max(f64::MIN_POSITIVE);
    // (2Ω)^½ per mode
    let d: Vec<f64> = (0..m)
        .map(|k| (2.0 * w2[k].max(0.0).sqrt().max(floor)).sqrt())
        .collect();
    let phi = &m_inv_half * v;
    let cm = phi.transpose() * damping * &phi;
    let z = Mat::from_fn(m, m, |i, j| cm[(i, j)] / (d[i] * d[j]));
    let ez = eig(&z)?;
    let (qz, dz) = (ez.U(), ez.S().column_vector());
    if (0..m).all(|k| dz[k] >= zeta0) {
        return Ok(damping.to_owned());
    }
    let zr = scaled(qz, &|k| dz[k].max(zeta0));
    let dzd = Mat::from_fn(m, m, |i, j| d[i] * zr[(i, j)] * d[j]);
    // Φ⁻ᵀ = M^½ V
    let left = &m_half * v;
    let c = &left * &dzd * left.transpose();
    Ok(Mat::from_fn(m, m, |i, j| 0.5 * (c[(i, j)] + c[(j, i)])))
}

/// Longest change of a log-diagonal in one step: a factor e² in the entry.
const LOG_STEP_MAX: f64 = 2.0;

fn log_step_too_long(params: &Params, step: &[f64]) -> bool {
    let nb = n_per_block(params.m);
    (0..3).any(|b| (0..params.m).any(|j| step[b * nb + tri(j, j)].abs() > LOG_STEP_MAX))
}

/// Scaling of the data (DESIGN §3): ω0 = RMS ω, s_u = RMS |u|, s_f = RMS |f|.
fn scaling_of(data: &OeData) -> Scaling {
    let nz = |x: f64| if x > 0.0 && x.is_finite() { x } else { 1.0 };
    let rms = |z: &[c64]| {
        let top = z
            .iter()
            .map(|v| v.re.abs().max(v.im.abs()))
            .fold(0.0, f64::max);
        if top == 0.0 {
            return 0.0;
        }
        top * (z.iter().map(|v| (v / top).norm_sqr()).sum::<f64>() / z.len() as f64).sqrt()
    };
    let w2 = data.omega.iter().map(|w| w * w).sum::<f64>() / data.s() as f64;
    Scaling {
        omega0: nz(w2.sqrt()),
        su: nz(rms(data.u)),
        sf: nz(rms(data.f)),
    }
}

/// The orthonormal basis the matrix-free modal step works in: the damping modes of the
/// start (C v = γ M v), most damped first, orthonormalised in that order.
///
/// With scalar weights the cost is the same in every orthonormal basis (u, f and the
/// model turned by V: the residual turns with them), but the factors are not: the
/// output-error optimum takes C toward the cone's edge in the least damped directions,
/// which the band hardly sees. In the caller's coordinates that edge is a direction
/// spread over all of C's pivots, approached by the steps in the factors in a long
/// creep; in this basis it lies in the last pivots. Measured (chain, 0.1 % noise,
/// `bench_refine.py` problem): m = 60, 1200 lines, 119–127 → 89 steps and m = 100, 2000
/// lines, 152–156 → 117–121 steps, each to a lower cost (0.141006 against 0.141008–
/// 0.141013, 0.223220 against 0.223276). The undamped modes lowest first took m = 60 to
/// 29 steps but stalled at m = 100 (cost 0.294–0.300), least damped first stalled too
/// (0.2287); the dense step (m ≤ 40) is left in the caller's basis: on the model-order
/// test's ill-conditioned exact data it stopped at 7e-4 from the truth instead of 4e-8.
fn damping_basis(l: &[Mat<f64>; 3]) -> Option<Mat<f64>> {
    use faer::linalg::triangular_solve::{
        solve_lower_triangular_in_place, solve_upper_triangular_in_place,
    };
    let (lm, m) = (&l[0], l[0].nrows());
    // Ĉ = L_M⁻¹ C L_M⁻ᵀ = Q Γ Qᵀ, modes L_M⁻ᵀ Q
    let mut a = gram_lower(&l[1]);
    solve_lower_triangular_in_place(lm.as_ref(), a.as_mut(), Par::Seq);
    let mut a = a.transpose().to_owned();
    solve_lower_triangular_in_place(lm.as_ref(), a.as_mut(), Par::Seq);
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = sym.self_adjoint_eigen(Side::Lower).ok()?;
    // the eigenvalues come in nondecreasing order: most damped first
    let mut modes = Mat::from_fn(m, m, |i, j| evd.U()[(i, m - 1 - j)]);
    solve_upper_triangular_in_place(lm.transpose(), modes.as_mut(), Par::Seq);
    let v = modes.qr().compute_Q();
    let finite = v.col_iter().all(|c| c.iter().all(|x| x.is_finite()));
    finite.then_some(v)
}

/// Each m-vector of `z` (column after column) by Vᵀ, or by V when `back`.
fn rotate_columns(z: &mut [c64], v: MatRef<f64>, back: bool) {
    let m = v.nrows();
    z.par_chunks_mut(m).for_each(|col| {
        let old = col.to_vec();
        for (i, out) in col.iter_mut().enumerate() {
            *out = (0..m)
                .map(|k| old[k] * if back { v[(i, k)] } else { v[(k, i)] })
                .sum();
        }
    });
}

/// The factor L' of the same model in the basis V: L' L'ᵀ = Vᵀ L Lᵀ V (the floor
/// ε tr(L Lᵀ) I is the same in every orthonormal basis).
fn rotated_factor(l: &Mat<f64>, v: MatRef<f64>) -> Result<Mat<f64>, PodidError> {
    let vl = v.transpose() * l;
    let x = &vl * vl.transpose();
    match x.llt(Side::Lower) {
        Ok(f) => Ok(f.L().to_owned()),
        Err(_) => psd_factor(x.as_ref(), 0.0),
    }
}

/// Refine the start model [M, C, K] (caller's units; symmetric, M, K ≻ 0, C ⪰ 0 —
/// eigenvalues below a tiny floor are raised to it) by Levenberg–Marquardt on the
/// output error. `progress` is called after every step with (iteration, cost).
pub fn refine(
    data: OeData,
    start: &[Mat<f64>; 3],
    opts: OeOptions,
    par: Par,
    mut progress: Option<Progress>,
) -> Result<OeReport, PodidError> {
    data.validate()?;
    let m = data.m;
    for (b, x) in start.iter().enumerate() {
        if x.nrows() != m || x.ncols() != m {
            return Err(PodidError::Invalid(format!(
                "start matrix {} must be {m}×{m}",
                ["M", "C", "K"][b]
            )));
        }
        if !(0..m).all(|i| (0..m).all(|j| x[(i, j)].is_finite())) {
            return Err(PodidError::Invalid(format!(
                "start matrix {} contains NaN or inf",
                ["M", "C", "K"][b]
            )));
        }
    }
    let t_total = Instant::now();
    let scaling = scaling_of(&data);
    let fac = scaling.block_factors();
    let pb = Problem {
        data,
        w: data.omega.iter().map(|w| w / scaling.omega0).collect(),
        u: data.u.iter().map(|z| z / scaling.su).collect(),
        f: data.f.iter().map(|z| z / scaling.sf).collect(),
        log_u: log_targets(&data.weights, scaling.su),
    };
    let params = Params {
        m,
        log_diagonal: opts.log_diagonal,
    };
    // start factors, scaled units; a tiny floor keeps a singular C factorable
    let scaled: Vec<Mat<f64>> = (0..3)
        .map(|b| Mat::from_fn(m, m, |i, j| start[b][(i, j)] / fac[b]))
        .collect();
    let top = |x: &Mat<f64>| {
        (0..m)
            .flat_map(|i| (0..m).map(move |j| (i, j)))
            .map(|(i, j)| x[(i, j)].abs())
            .fold(0.0, f64::max)
    };
    let ref_scale = top(&scaled[0]).max(top(&scaled[2])).max(f64::MIN_POSITIVE);
    // M and K with a tiny eigenvalue floor; C raised to the least damping ratio
    // C_START_FLOOR, so that no direction starts undamped — its factor would have no
    // gradient to leave 0
    // the parametrisation adds ε tr(L Lᵀ) I (`gram_lower`): take it off the start first,
    // so that a refined model given back as a start is the same model (X = L Lᵀ + ε
    // tr(L Lᵀ) I has tr X = (1 + mε) tr(L Lᵀ))
    let inner: Vec<Mat<f64>> = scaled
        .iter()
        .map(|x| {
            let tr: f64 = (0..m).map(|i| x[(i, i)]).sum();
            let shift = (CONDITION_FLOOR * tr / (1.0 + m as f64 * CONDITION_FLOOR)).max(0.0);
            Mat::from_fn(m, m, |i, j| x[(i, j)] - if i == j { shift } else { 0.0 })
        })
        .collect();
    let mut l = [0, 1, 2].map(|b| {
        if b == 1 {
            return Ok(Mat::zeros(0, 0)); // below, from the floored M and K
        }
        psd_factor(inner[b].as_ref(), 1e-12 * ref_scale)
    });
    if let (Ok(lm), Ok(lk)) = (&l[0], &l[2]) {
        let (mf, kf) = (lm * lm.transpose(), lk * lk.transpose());
        // a C with the parametrisation's own floor ε tr(C) I (a refined model given
        // back) is factored as it is; a singular one (a start made physical by
        // clipping) is raised to the least damping ratio first
        l[1] = if has_condition_floor(scaled[1].as_ref()) {
            psd_factor(inner[1].as_ref(), 1e-12 * ref_scale)
        } else {
            damping_floor(mf.as_ref(), inner[1].as_ref(), kf.as_ref(), C_START_FLOOR)
                .and_then(|c| psd_factor(c.as_ref(), 1e-12 * ref_scale))
        };
    }
    for (b, lb) in l.iter().enumerate() {
        if let Err(e) = lb {
            return Err(PodidError::Invalid(format!(
                "{} of the start: {e}",
                ["M", "C", "K"][b]
            )));
        }
    }
    let mut l0: [Mat<f64>; 3] =
        [0, 1, 2].map(|b| std::mem::replace(&mut l[b], Ok(Mat::zeros(0, 0))).unwrap());
    let (mut t_eval, mut t_normal, mut t_solve) = (0.0, 0.0, 0.0);
    // responses of the start as given (before the damping floor), for the report
    let given = [0, 1, 2].map(|b| scaled[b].clone());
    let responses_start = pb.evaluate(&given).ok().map(|e| e.x);
    // the matrix-free modal step works in the damping basis ([`damping_basis`])
    let mut pb = pb;
    let kind = opts.solver.resolve(m, data.s(), lines::terms_per_line(&pb));
    let basis = match data.weights {
        Weights::Scalar(_) if kind == StepKind::MatrixFree && opts.modal_metric => {
            damping_basis(&l0)
        }
        _ => None,
    };
    if let Some(v) = &basis {
        rotate_columns(&mut pb.u, v.as_ref(), false);
        rotate_columns(&mut pb.f, v.as_ref(), false);
        for lb in l0.iter_mut() {
            *lb = rotated_factor(lb, v.as_ref())?;
        }
    }
    let mut theta = params.pack(&l0);
    let mut lf = params.unpack(&theta);
    let mut mck = lf.clone().map(|x| gram_lower(&x));

    let t0 = Instant::now();
    let mut ev = pb.evaluate(&mck)?;
    t_eval += t0.elapsed().as_secs_f64();
    if !ev.cost.is_finite() {
        return Err(PodidError::Invalid(
            "the start model has a pole on a measured frequency line (D(ω) singular)".into(),
        ));
    }
    // the cost in the caller's units (the log-magnitude cost has none)
    let su2 = match data.weights {
        Weights::LogMagnitude(_) => 1.0,
        _ => scaling.su * scaling.su,
    };
    let cost_start = ev.cost;
    let mut history = vec![(0usize, cost_start * su2)];
    let mut mu = 0.0;
    let mut nu = 2.0;
    let mut iterations = 0;
    let mut accepted = 0;
    let mut stop = Stop::MaxIter;
    let mut fresh = true; // the step solver must be prepared at the new point
    let mut rejected_here = false; // a step from the current point was rejected
    let mut solver: Box<dyn StepSolver> = match kind {
        StepKind::MatrixFree => Box::new(
            matfree::MatrixFree::new(MAX_CG_ITER)
                .with_curvature(opts.curvature)
                .with_modal_metric(opts.modal_metric),
        ),
        _ => Box::new(DenseNormal::with_curvature(opts.curvature)),
    };
    let mut gth = Vec::new();
    // the LU buffer of the last evaluation dropped, for the next one
    let mut spare: Vec<c64> = Vec::new();
    while iterations < opts.max_iter {
        if fresh {
            let t0 = Instant::now();
            gth = solver.prepare(&pb, &params, &lf, &ev, par);
            t_normal += t0.elapsed().as_secs_f64();
            fresh = false;
            let gmax = gth.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if gmax == 0.0 || ev.cost == 0.0 {
                stop = Stop::GradientZero;
                break;
            }
        }
        if mu == 0.0 {
            mu = solver.initial_damping();
        }
        iterations += 1;
        // Gauss–Newton alone right after a step that lowered the cost fast, unless a
        // step from this point was already rejected ([`CURVATURE_SWITCH`])
        let falling_fast = history.len() >= 2 && {
            let (before, now) = (history[history.len() - 2].1, history[history.len() - 1].1);
            before - now >= CURVATURE_SWITCH * before
        };
        solver.set_curvature(opts.curvature && (rejected_here || !falling_fast));
        let t0 = Instant::now();
        let mut cancelled = false;
        let step = {
            let cost_now = ev.cost * su2;
            let mut poll = || {
                if let Some(cb) = progress.as_mut() {
                    cancelled |= cb(iterations, cost_now).is_break();
                }
                cancelled
            };
            solver.step(&gth, mu, par, &mut poll)
        };
        t_solve += t0.elapsed().as_secs_f64();
        if cancelled {
            return Err(PodidError::Interrupted);
        }
        // no step, or a long step in a log-diagonal (it can overflow the model in one
        // go): damp more
        let step = step.filter(|st| !(params.log_diagonal && log_step_too_long(&params, st)));
        let Some(step) = step else {
            rejected_here = true;
            if more_damping(&mut mu, &mut nu) {
                stop = Stop::NoDescent;
                break;
            }
            continue;
        };
        let trial: Vec<f64> = theta.iter().zip(&step).map(|(a, b)| a + b).collect();
        let lt = params.unpack(&trial);
        let mckt = lt.clone().map(|x| gram_lower(&x));
        let t0 = Instant::now();
        let evt = pb.evaluate_into(&mckt, std::mem::take(&mut spare))?;
        t_eval += t0.elapsed().as_secs_f64();
        let predicted = solver.predicted(&gth, &step, par);
        let actual = ev.cost - evt.cost;
        let snorm = step.iter().map(|v| v * v).sum::<f64>().sqrt();
        let tnorm = theta.iter().map(|v| v * v).sum::<f64>().sqrt();
        if evt.cost.is_finite() && actual > 0.0 {
            let rho = actual / predicted.max(f64::MIN_POSITIVE);
            theta = trial;
            lf = lt;
            mck = mckt;
            spare = std::mem::replace(&mut ev, evt).lu;
            accepted += 1;
            fresh = true;
            rejected_here = false;
            mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
            history.push((iterations, ev.cost * su2));
            if let Some(cb) = progress.as_mut() {
                if cb(iterations, ev.cost * su2).is_break() {
                    return Err(PodidError::Interrupted);
                }
            }
            let earlier = history[history.len().saturating_sub(FTOL_WINDOW + 1)].1;
            let full = history.len() > FTOL_WINDOW;
            if full && (earlier - ev.cost * su2) < FTOL_WINDOW as f64 * opts.ftol * earlier {
                stop = Stop::CostConverged;
                break;
            }
            if snorm <= opts.xtol * (tnorm + opts.xtol) {
                stop = Stop::StepConverged;
                break;
            }
        } else {
            spare = evt.lu;
            if snorm <= opts.xtol * (tnorm + opts.xtol) {
                stop = Stop::StepConverged;
                break;
            }
            rejected_here = true;
            if more_damping(&mut mu, &mut nu) {
                stop = Stop::NoDescent;
                break;
            }
            if let Some(cb) = progress.as_mut() {
                if cb(iterations, ev.cost * su2) == ControlFlow::Break(()) {
                    return Err(PodidError::Interrupted);
                }
            }
        }
    }
    if let Some(v) = &basis {
        // back to the caller's coordinates: X = V X' Vᵀ, x = V x'
        for x in mck.iter_mut() {
            let vx = v * &*x;
            *x = &vx * v.transpose();
        }
        rotate_columns(&mut ev.x, v.as_ref(), true);
    }
    let out = [0, 1, 2].map(|b| Mat::from_fn(m, m, |i, j| mck[b][(i, j)] * fac[b]));
    Ok(OeReport {
        mck: out,
        cost_start: cost_start * su2,
        cost: ev.cost * su2,
        iterations,
        accepted,
        stop,
        history,
        scaling,
        timings: [
            ("evaluate", t_eval),
            ("normal", t_normal),
            ("solve", t_solve),
            ("total", t_total.elapsed().as_secs_f64()),
        ]
        .into_iter()
        .chain(solver.timings())
        .collect(),
        solver: kind.name(),
        solver_stats: solver.stats(),
        responses_start: responses_start.map(|x| x.into_iter().map(|v| v * scaling.su).collect()),
        responses: ev.x.iter().map(|v| v * scaling.su).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic pseudo-random generator (no dev-dependencies).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        }
    }

    /// `x` with every entry off by up to `rel` (times 2), kept symmetric.
    fn perturbed(x: &[Mat<f64>; 3], rel: f64, rng: &mut Lcg) -> [Mat<f64>; 3] {
        x.clone().map(|x| {
            let m = x.nrows();
            let d = Mat::from_fn(m, m, |_, _| rel * rng.next());
            Mat::from_fn(m, m, |i, j| x[(i, j)] * (1.0 + d[(i, j)] + d[(j, i)]))
        })
    }

    /// The matrix-free product N v equals the dense N_θ (column-major) times v, for a
    /// random v (`scale` = the largest diagonal entry of N_θ).
    fn assert_products_match(
        mf: &mut matfree::MatrixFree,
        nth: &[f64],
        scale: f64,
        rng: &mut Lcg,
        tol: f64,
    ) {
        let n = (nth.len() as f64).sqrt().round() as usize;
        let v: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let nv = mf.apply(&v, Par::Seq);
        for a in 0..n {
            let want: f64 = (0..n).map(|b| nth[b * n + a] * v[b]).sum();
            assert!(
                (nv[a] - want).abs() <= tol * scale * n as f64,
                "(Nv)[{a}]: {} vs {want}",
                nv[a]
            );
        }
    }

    /// A stable symmetric system of order m (M, K ≻ 0, C ≻ 0), O(1) entries.
    fn system(m: usize, rng: &mut Lcg) -> [Mat<f64>; 3] {
        let spd = |rng: &mut Lcg, shift: f64| {
            let a = Mat::from_fn(m, m, |_, _| rng.next());
            Mat::from_fn(m, m, |i, j| {
                (0..m).map(|k| a[(i, k)] * a[(j, k)]).sum::<f64>()
                    + if i == j { shift } else { 0.0 }
            })
        };
        let mm = spd(rng, 1.0);
        let kk = spd(rng, 2.0);
        let cc = Mat::from_fn(m, m, |i, j| 0.05 * mm[(i, j)] + 0.02 * kk[(i, j)]);
        [mm, cc, kk]
    }

    /// Exact responses u = D⁻¹ f for random forces.
    fn exact_data(
        mck: &[Mat<f64>; 3],
        omega: &[f64],
        p: usize,
        rng: &mut Lcg,
    ) -> (Vec<c64>, Vec<c64>) {
        let m = mck[0].nrows();
        let s = omega.len();
        let f: Vec<c64> = (0..s * p * m)
            .map(|_| c64::new(rng.next(), rng.next()))
            .collect();
        let mut u = f.clone();
        for i in 0..s {
            let mut d = vec![c64::new(0.0, 0.0); m * m];
            dynamic_stiffness(mck, omega[i], &mut d);
            let dm = MatRef::from_column_major_slice(&d, m, m);
            let lu = dm.partial_piv_lu();
            let mut x = Mat::from_fn(m, p, |r, j| u[(i * p + j) * m + r]);
            use faer::linalg::solvers::Solve;
            lu.solve_in_place(x.as_mut());
            for j in 0..p {
                for r in 0..m {
                    u[(i * p + j) * m + r] = x[(r, j)];
                }
            }
        }
        (u, f)
    }

    fn residual_vector(pb: &Problem, mck: &[Mat<f64>; 3]) -> Vec<f64> {
        let ev = pb.evaluate(mck).unwrap();
        let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
        let mut out = Vec::new();
        let mut r = vec![c64::new(0.0, 0.0); m];
        for col in 0..s * p {
            let (t, w) = pb.column_weight(col);
            weighted_residual(
                t,
                w,
                &ev.x[col * m..(col + 1) * m],
                &pb.u[col * m..(col + 1) * m],
                &mut r,
            );
            out.extend(r.iter().map(|z| z.re));
            out.extend(r.iter().map(|z| z.im));
        }
        out
    }

    fn problem<'a>(data: OeData<'a>) -> Problem<'a> {
        Problem {
            data,
            w: data.omega.to_vec(),
            u: data.u.to_vec(),
            f: data.f.to_vec(),
            log_u: log_targets(&data.weights, 1.0),
        }
    }

    /// Data of a random system of order m on s lines with p load cases, the targets
    /// 10 % off (so that the residual is not zero), and random scalar and matrix
    /// weights: (ω, u, f, scalar weights, matrix weights).
    #[allow(clippy::type_complexity)]
    fn noisy_data(
        m: usize,
        p: usize,
        s: usize,
        rng: &mut Lcg,
    ) -> (Vec<f64>, Vec<c64>, Vec<c64>, Vec<f64>, Vec<f64>) {
        let truth = system(m, rng);
        let omega: Vec<f64> = (0..s).map(|i| 0.3 + 0.25 * i as f64).collect();
        let (u0, f) = exact_data(&truth, &omega, p, rng);
        let u: Vec<c64> = u0.iter().map(|z| z * (1.0 + 0.1 * rng.next())).collect();
        let wscal: Vec<f64> = (0..s * p).map(|_| 0.5 + rng.next()).collect();
        let wmat: Vec<f64> = (0..s * p * m * m).map(|_| rng.next()).collect();
        (omega, u, f, wscal, wmat)
    }

    /// The Jacobian of the stacked residual [Re r; Im r] (column by column through
    /// the tangent map: δx = −D⁻¹ δD x), and the residual: an independent reference.
    pub(crate) fn explicit_jacobian(
        pb: &Problem,
        params: &Params,
        l: &[Mat<f64>; 3],
        ev: &Evaluation,
    ) -> (Vec<Vec<f64>>, Vec<f64>) {
        let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
        let nb = n_per_block(m);
        let n = params.len();
        let rows = 2 * s * p * m;
        let mut r0 = vec![0.0; rows];
        let mut rr = vec![c64::new(0.0, 0.0); m];
        for col in 0..s * p {
            let (t, w) = pb.column_weight(col);
            weighted_residual(
                t,
                w,
                &ev.x[col * m..(col + 1) * m],
                &pb.u[col * m..(col + 1) * m],
                &mut rr,
            );
            for k in 0..m {
                r0[col * 2 * m + k] = rr[k].re;
                r0[col * 2 * m + m + k] = rr[k].im;
            }
        }
        let jac = (0..n)
            .map(|q| {
                let (b, qb) = (q / nb, q % nb);
                let mut e = vec![0.0; nb];
                e[qb] = 1.0;
                let dx = lines::tangent(params, &l[b], &e);
                let mut out = vec![0.0; rows];
                for i in 0..s {
                    let w = pb.w[i];
                    let phi = [c64::new(-w * w, 0.0), c64::new(0.0, w), c64::new(1.0, 0.0)][b];
                    let lu =
                        MatRef::from_column_major_slice(&ev.lu[i * m * m..(i + 1) * m * m], m, m);
                    for j in 0..p {
                        let col = i * p + j;
                        let x = &ev.x[col * m..(col + 1) * m];
                        let mut y: Vec<c64> = (0..m)
                            .map(|r| -(0..m).map(|c| x[c] * dx[(r, c)]).sum::<c64>() * phi)
                            .collect();
                        solve_lines(lu, &ev.perm[i * m..(i + 1) * m], &mut y, m, 1);
                        let (t, wt) = pb.column_weight(col);
                        let zero = vec![c64::new(0.0, 0.0); m];
                        weighted_residual(t, wt, &y, &zero, &mut rr);
                        for k in 0..m {
                            out[col * 2 * m + k] = rr[k].re;
                            out[col * 2 * m + m + k] = rr[k].im;
                        }
                    }
                }
                out
            })
            .collect();
        (jac, r0)
    }

    #[test]
    fn normal_matrix_matches_the_explicit_jacobian() {
        let mut rng = Lcg(5);
        for (m, p, log_diagonal, matrix) in [
            (1, 1, true, false),
            (2, 3, false, false),
            (4, 2, true, false),
            (5, 1, true, false),
            (3, 2, true, true),
        ] {
            let (omega, u, f, wscal, wmat) = noisy_data(m, p, 7, &mut rng);
            let weights = if matrix {
                Weights::Matrix(&wmat)
            } else {
                Weights::Scalar(&wscal)
            };
            let data = OeData {
                omega: &omega,
                u: &u,
                f: &f,
                weights,
                m,
                p,
            };
            let pb = problem(data);
            let params = Params { m, log_diagonal };
            let start = system(m, &mut rng);
            let lf = start.clone().map(|x| psd_factor(x.as_ref(), 0.0).unwrap());
            let mck = lf.clone().map(|x| gram_lower(&x));
            let ev = pb.evaluate(&mck).unwrap();
            let (nth, gth, _) =
                dense::normal_equations(&pb, &params, &lf, &ev, Par::Seq, &mut Default::default());
            let (jac, r0) = explicit_jacobian(&pb, &params, &lf, &ev);
            let n = params.len();
            let scale = (0..n).map(|i| nth[i * n + i].abs()).fold(0.0, f64::max);
            for a in 0..n {
                let g: f64 = jac[a].iter().zip(&r0).map(|(x, y)| x * y).sum();
                assert!(
                    (g - gth[a]).abs()
                        <= 1e-12 * scale.sqrt() * r0.iter().map(|v| v * v).sum::<f64>().sqrt(),
                    "m {m} g[{a}]: {g} vs {}",
                    gth[a]
                );
                for b in 0..n {
                    let v: f64 = jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum();
                    assert!(
                        (v - nth[b * n + a]).abs() <= 1e-12 * scale,
                        "m {m} N[{a},{b}]: {v} vs {}",
                        nth[b * n + a]
                    );
                }
            }
        }
    }

    #[test]
    fn matrix_free_products_and_diagonal_match_the_dense_matrix() {
        let mut rng = Lcg(9);
        for (m, p, log_diagonal, matrix) in [
            (1, 2, true, false),
            (3, 1, false, false),
            (4, 2, true, false),
            (3, 2, true, true),
        ] {
            let (omega, u, f, wscal, wmat) = noisy_data(m, p, 8, &mut rng);
            let weights = if matrix {
                Weights::Matrix(&wmat)
            } else {
                Weights::Scalar(&wscal)
            };
            let data = OeData {
                omega: &omega,
                u: &u,
                f: &f,
                weights,
                m,
                p,
            };
            let pb = problem(data);
            let params = Params { m, log_diagonal };
            let lf = system(m, &mut rng).map(|x| psd_factor(x.as_ref(), 0.0).unwrap());
            let mck = lf.clone().map(|x| gram_lower(&x));
            let ev = pb.evaluate(&mck).unwrap();
            let (nth, gth, _) =
                dense::normal_equations(&pb, &params, &lf, &ev, Par::Seq, &mut Default::default());
            let mut mf = matfree::MatrixFree::new(MAX_CG_ITER);
            let g2 = mf.prepare(&pb, &params, &lf, &ev, Par::Seq);
            let n = params.len();
            let scale = (0..n).map(|i| nth[i * n + i].abs()).fold(0.0, f64::max);
            for q in 0..n {
                assert!((g2[q] - gth[q]).abs() <= 1e-13 * scale.sqrt() * (1.0 + gth[q].abs()));
                // the damping diagonal leaves out the floor's O(ε) terms
                assert!(
                    (mf.diagonal()[q] - nth[q * n + q]).abs() <= 1e-9 * scale,
                    "m {m} diag[{q}]: {} vs {}",
                    mf.diagonal()[q],
                    nth[q * n + q]
                );
            }
            // the 3×3 blocks of the preconditioner
            let nb = n / 3;
            for t in 0..nb {
                for (b, bp) in [(0, 1), (0, 2), (1, 2)] {
                    let want = nth[(b * nb + t) * n + bp * nb + t];
                    assert!(
                        (mf.block(b, bp, t) - want).abs() <= 1e-9 * scale,
                        "m {m} block ({b}, {bp}) at {t}: {} vs {want}",
                        mf.block(b, bp, t)
                    );
                }
            }
            for _ in 0..3 {
                assert_products_match(&mut mf, &nth, scale, &mut rng, 1e-12);
            }
            // the modal metric of the same point
            let mut mm = matfree::MatrixFree::new(MAX_CG_ITER).with_modal_metric(true);
            mm.prepare(&pb, &params, &lf, &ev, Par::Seq);
            // with scalar weights from G_Y in single precision (the products and the
            // metric to its rounding, ~1e-7 relative), else in double
            let tol: f64 = if matrix { 1e-12 } else { 1e-6 };
            assert_modal_metric(&mm, &nth, &params, &lf, &mut rng, tol.max(1e-8));
            assert_products_match(&mut mm, &nth, scale, &mut rng, tol);
            // with the parametrisation's curvature both steps use the same N + H
            let mut dn = DenseNormal::with_curvature(true);
            dn.prepare(&pb, &params, &lf, &ev, Par::Seq);
            let mut mc = matfree::MatrixFree::new(MAX_CG_ITER).with_curvature(true);
            mc.prepare(&pb, &params, &lf, &ev, Par::Seq);
            dn.set_curvature(true);
            mc.set_curvature(true);
            let mut h_seen = 0.0f64;
            for _ in 0..3 {
                let v: Vec<f64> = (0..n).map(|_| rng.next()).collect();
                let hv = mc.apply(&v, Par::Seq);
                let (got, want) = (
                    v.iter().zip(&hv).map(|(a, b)| a * b).sum::<f64>(),
                    dn.quad(&v, Par::Seq),
                );
                // and H is there: N + H is not N
                let nv: f64 = (0..n)
                    .map(|a| v[a] * (0..n).map(|b| nth[b * n + a] * v[b]).sum::<f64>())
                    .sum();
                // H ⪰ 0
                assert!(want - nv >= -1e-11 * scale * n as f64);
                h_seen = h_seen.max(want - nv);
                assert!(
                    (got - want).abs() <= 1e-11 * scale * n as f64,
                    "m {m} vᵀ(N + H)v: {got} vs {want}"
                );
            }
            // and H is there (the data are noisy: the gradient in X is not 0)
            assert!(h_seen > 1e-9 * scale, "m {m}: H = 0");
        }
    }

    /// The modal metric at a point against the dense N_θ there (`nth`, n×n): B_θ = N_θ on
    /// every single modal unknown, a step taken in X lands on X + Pδθ (and one out of the
    /// cone is refused), B_θ symmetric positive definite with solve() its inverse.
    fn assert_modal_metric(
        mf: &matfree::MatrixFree,
        nth: &[f64],
        params: &Params,
        lf: &[Mat<f64>; 3],
        rng: &mut Lcg,
        tol: f64,
    ) {
        let m = params.m;
        let b = mf.modal().expect("the modal metric of a regular model");
        let n = params.len();
        let dot = |v: &[f64], w: &[f64]| -> f64 { v.iter().zip(w).map(|(x, y)| x * y).sum() };
        let nquad = |v: &[f64]| -> f64 {
            (0..n)
                .map(|a| v[a] * (0..n).map(|c| nth[c * n + a] * v[c]).sum::<f64>())
                .sum()
        };
        // on a single modal unknown, vᵀ B v is the Gauss–Newton matrix's vᵀ N v
        // (up to the parametrisation's O(ε) floor)
        for blk in 0..3 {
            for j in 0..m {
                for k in 0..=j {
                    let v = b.modal_direction(blk, j, k);
                    let (got, want) = (dot(&v, &b.apply(&v)), nquad(&v));
                    assert!(
                        (got - want).abs() <= tol * want.abs(),
                        "m {m} block {blk} ({j}, {k}): vᵀBv {got} vs vᵀNv {want}"
                    );
                }
            }
        }
        // a step taken in X lands on X + P δθ exactly (to rounding), where it stays
        // positive definite, and is refused where it leaves the cone
        let v: Vec<f64> = (0..n).map(|_| 1e-3 * rng.next()).collect();
        let th = params.pack(lf);
        let step = mf.retract(&v).expect("a small step stays in the cone");
        let moved: Vec<f64> = th.iter().zip(&step).map(|(a, c)| a + c).collect();
        let lm = params.unpack(&moved);
        let nb = n / 3;
        for blk in 0..3 {
            let want = lines::tangent(params, &lf[blk], &v[blk * nb..(blk + 1) * nb]);
            let (x0, x1) = (gram_lower(&lf[blk]), gram_lower(&lm[blk]));
            let top = (0..m).map(|i| x0[(i, i)].abs()).fold(0.0, f64::max);
            for i in 0..m {
                for j in 0..m {
                    let got = x1[(i, j)] - x0[(i, j)];
                    assert!(
                        (got - want[(i, j)]).abs() <= 1e-10 * top,
                        "m {m} block {blk}: δX[{i}][{j}] {got} vs {}",
                        want[(i, j)]
                    );
                }
            }
        }
        // δX_00 = 2 L_00 δL_00 (times L_00 on a logged diagonal) ≪ −X_00
        let mut out = vec![0.0; n];
        out[tri(0, 0)] = -1e4 * (1.0 + 1.0 / lf[0][(0, 0)].abs());
        assert!(mf.retract(&out).is_err(), "m {m}: X + δX left the cone");
        // symmetric, positive definite, and solve() is its inverse
        for _ in 0..3 {
            let v: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let w: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let (bv, bw) = (b.apply(&v), b.apply(&w));
            let (vbw, wbv) = (dot(&v, &bw), dot(&w, &bv));
            assert!((vbw - wbv).abs() <= 1e-10 * (vbw.abs() + wbv.abs()));
            assert!(dot(&v, &bv) > 0.0);
            let back = b.solve(&bv, 0.0);
            let vn = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            let err = back
                .iter()
                .zip(&v)
                .map(|(a, c)| (a - c).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(err <= 1e-8 * vn, "m {m}: ‖B⁻¹Bv − v‖ = {err:e}");
        }
        // the modal coordinates of the inner solve (δθ = R y): Rᵀ B_θ R = B_Y, and
        // the block solve inverts B_Y with the 1/(1 + μ) of the damping
        for _ in 0..3 {
            let y: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let (got, want) = (b.dual_y(&b.apply(&b.theta_of_y(&y))), b.block_apply(&y));
            let top = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() <= 1e-9 * top,
                    "m {m}: RᵀBR y {g} vs B_Y y {w}"
                );
            }
            let back = b.block_solve(&b.block_apply(&y), 3.0);
            for (g, w) in back.iter().zip(&y) {
                assert!(
                    (4.0 * g - w).abs() <= 1e-9 * w.abs().max(1.0),
                    "m {m}: B_Y⁻¹"
                );
            }
        }
    }

    #[test]
    fn gauss_newton_matrix_and_gradient_match_finite_differences() {
        let mut rng = Lcg(7);
        let m = 3;
        let p = 2;
        let (omega, u, f, wscal, wmat) = noisy_data(m, p, 9, &mut rng);
        for (weights, log_diagonal) in [
            (Weights::Scalar(&wscal), false),
            (Weights::Scalar(&wscal), true),
            (Weights::Matrix(&wmat), true),
        ] {
            let data = OeData {
                omega: &omega,
                u: &u,
                f: &f,
                weights,
                m,
                p,
            };
            let pb = problem(data);
            let params = Params { m, log_diagonal };
            let start = system(m, &mut rng);
            let l = start.clone().map(|x| psd_factor(x.as_ref(), 0.0).unwrap());
            let theta = params.pack(&l);
            let lf = params.unpack(&theta);
            let mck = lf.clone().map(|x| gram_lower(&x));
            let ev = pb.evaluate(&mck).unwrap();
            let (nth, gth, _) =
                dense::normal_equations(&pb, &params, &lf, &ev, Par::Seq, &mut Default::default());
            let n = theta.len();
            let r0 = residual_vector(&pb, &mck);
            let h = 1e-6;
            let jac: Vec<Vec<f64>> = (0..n)
                .map(|q| {
                    let mut tp = theta.clone();
                    let mut tm = theta.clone();
                    tp[q] += h;
                    tm[q] -= h;
                    let rp = residual_vector(&pb, &params.unpack(&tp).map(|x| gram_lower(&x)));
                    let rm = residual_vector(&pb, &params.unpack(&tm).map(|x| gram_lower(&x)));
                    rp.iter()
                        .zip(&rm)
                        .map(|(a, b)| (a - b) / (2.0 * h))
                        .collect()
                })
                .collect();
            let scale = (0..n).map(|i| nth[i * n + i].abs()).fold(0.0, f64::max);
            for a in 0..n {
                let g_fd: f64 = jac[a].iter().zip(&r0).map(|(x, y)| x * y).sum();
                assert!(
                    (g_fd - gth[a]).abs() < 1e-6 * scale.sqrt() * (1.0 + g_fd.abs()),
                    "g[{a}]: {g_fd} vs {}",
                    gth[a]
                );
                for b in 0..n {
                    let n_fd: f64 = jac[a].iter().zip(&jac[b]).map(|(x, y)| x * y).sum();
                    assert!(
                        (n_fd - nth[b * n + a]).abs() < 1e-6 * scale,
                        "N[{a},{b}]: {n_fd} vs {}",
                        nth[b * n + a]
                    );
                }
            }
        }
    }

    /// Log-magnitude targets on n entries y = R x of random data (10 % off), with
    /// random entry weights (one zero): (R, targets, weights).
    fn log_data(m: usize, n: usize, u: &[c64], rng: &mut Lcg) -> (Vec<f64>, Vec<c64>, Vec<f64>) {
        let cols = u.len() / m;
        let basis: Vec<f64> = (0..n * m).map(|_| rng.next()).collect();
        let target: Vec<c64> = (0..cols * n)
            .map(|q| {
                let (col, e) = (q / n, q % n);
                let y: c64 = (0..m).map(|a| u[col * m + a] * basis[e * m + a]).sum();
                y * (1.0 + 0.1 * rng.next())
            })
            .collect();
        let mut w: Vec<f64> = (0..cols * n).map(|_| 0.7 + rng.next()).collect();
        w[1] = 0.0;
        (basis, target, w)
    }

    #[test]
    fn log_magnitude_gradient_and_metric_match_finite_differences() {
        let mut rng = Lcg(13);
        let (m, p, n) = (3, 2, 5);
        let (omega, u, f, _, _) = noisy_data(m, p, 9, &mut rng);
        let (basis, target, lw) = log_data(m, n, &u, &mut rng);
        let lt = LogTarget {
            basis: &basis,
            n,
            u: &target,
            w: &lw,
        };
        let data = OeData {
            omega: &omega,
            u: &u,
            f: &f,
            weights: Weights::LogMagnitude(lt),
            m,
            p,
        };
        data.validate().unwrap();
        let pb = problem(data);
        let params = Params {
            m,
            log_diagonal: true,
        };
        let l = system(m, &mut rng).map(|x| psd_factor(x.as_ref(), 0.0).unwrap());
        let theta = params.pack(&l);
        let lf = params.unpack(&theta);
        let ev = pb.evaluate(&lf.clone().map(|x| gram_lower(&x))).unwrap();
        // the cost by hand: Σ w² (ln|R x| − ln|u|)²
        let mut by_hand = 0.0;
        for col in 0..omega.len() * p {
            for e in 0..n {
                let y: c64 = (0..m).map(|a| ev.x[col * m + a] * basis[e * m + a]).sum();
                let r = lw[col * n + e] * (y.norm().ln() - target[col * n + e].norm().ln());
                by_hand += r * r;
            }
        }
        assert!(
            (ev.cost - by_hand).abs() <= 1e-12 * by_hand,
            "{} vs {by_hand}",
            ev.cost
        );
        let (nth, gth, _) =
            dense::normal_equations(&pb, &params, &lf, &ev, Par::Seq, &mut Default::default());
        let nt = theta.len();
        let h = 1e-6;
        // entries y = R x at θ ± h e_q
        let entries = |th: &[f64]| -> (f64, Vec<c64>) {
            let e = pb
                .evaluate(&params.unpack(th).map(|x| gram_lower(&x)))
                .unwrap();
            let y = (0..omega.len() * p * n)
                .map(|q| {
                    let (col, k) = (q / n, q % n);
                    (0..m).map(|a| e.x[col * m + a] * basis[k * m + a]).sum()
                })
                .collect();
            (e.cost, y)
        };
        let (_, y0) = entries(&theta);
        // J_c[q] = w ∂y/∂θ_q / y (complex), by central differences
        let jc: Vec<Vec<c64>> = (0..nt)
            .map(|q| {
                let (mut tp, mut tm) = (theta.clone(), theta.clone());
                tp[q] += h;
                tm[q] -= h;
                let ((cp, yp), (cm, ym)) = (entries(&tp), entries(&tm));
                // g = ½ ∂cost/∂θ
                let g_fd = (cp - cm) / (4.0 * h);
                assert!(
                    (g_fd - gth[q]).abs() <= 1e-6 * (1.0 + g_fd.abs()),
                    "g[{q}]: {g_fd} vs {}",
                    gth[q]
                );
                (0..yp.len())
                    .map(|k| (yp[k] - ym[k]) / (2.0 * h) / y0[k] * lw[k])
                    .collect()
            })
            .collect();
        let scale = (0..nt).map(|i| nth[i * nt + i].abs()).fold(0.0, f64::max);
        for a in 0..nt {
            for b in 0..nt {
                // the step's matrix: ½ Re(J_cᴴ J_c)
                let want: f64 = 0.5
                    * jc[a]
                        .iter()
                        .zip(&jc[b])
                        .map(|(x, y)| (x.conj() * y).re)
                        .sum::<f64>();
                assert!(
                    (want - nth[b * nt + a]).abs() <= 1e-6 * scale,
                    "N[{a},{b}]: {want} vs {}",
                    nth[b * nt + a]
                );
            }
        }
        // the matrix-free step sees the same matrix and gradient
        let mut mf = matfree::MatrixFree::new(MAX_CG_ITER);
        let g2 = mf.prepare(&pb, &params, &lf, &ev, Par::Seq);
        for q in 0..nt {
            assert!((g2[q] - gth[q]).abs() <= 1e-12 * scale.sqrt() * (1.0 + gth[q].abs()));
            assert!((mf.diagonal()[q] - nth[q * nt + q]).abs() <= 1e-9 * scale);
        }
        assert_products_match(&mut mf, &nth, scale, &mut rng, 1e-12);
        // a weighted zero target is refused, a zero one with weight 0 is not
        let mut t0 = target.clone();
        t0[1] = c64::new(0.0, 0.0);
        let ok = OeData {
            weights: Weights::LogMagnitude(LogTarget { u: &t0, ..lt }),
            ..data
        };
        ok.validate().unwrap();
        t0[0] = c64::new(0.0, 0.0);
        let bad = OeData {
            weights: Weights::LogMagnitude(LogTarget { u: &t0, ..lt }),
            ..data
        };
        assert!(bad.validate().unwrap_err().to_string().contains("zero"));
    }

    #[test]
    fn log_magnitude_refinement_recovers_the_model_from_magnitudes() {
        // noise-free magnitudes on more entries than the order: the exact model is the
        // minimum (cost 0); from a start 5 % off LM returns to it
        let mut rng = Lcg(17);
        let (m, p, n) = (3, 1, 6);
        let truth = system(m, &mut rng);
        let omega: Vec<f64> = (0..40).map(|i| 0.2 + 0.07 * i as f64).collect();
        let (u, f) = exact_data(&truth, &omega, p, &mut rng);
        let basis: Vec<f64> = (0..n * m).map(|_| rng.next()).collect();
        let target: Vec<c64> = (0..omega.len() * p * n)
            .map(|q| {
                (0..m)
                    .map(|a| u[(q / n) * m + a] * basis[(q % n) * m + a])
                    .sum()
            })
            .collect();
        let lw = vec![1.0; target.len()];
        let data = OeData {
            omega: &omega,
            u: &u,
            f: &f,
            weights: Weights::LogMagnitude(LogTarget {
                basis: &basis,
                n,
                u: &target,
                w: &lw,
            }),
            m,
            p,
        };
        let start = perturbed(&truth, 0.05, &mut rng);
        for (solver, modal_metric) in [
            (StepKind::Dense, false),
            (StepKind::MatrixFree, false),
            (StepKind::MatrixFree, true),
        ] {
            let opts = OeOptions {
                solver,
                modal_metric,
                ..Default::default()
            };
            let rep = refine(data, &start, opts, Par::Seq, None).unwrap();
            assert!(
                rep.cost < 1e-10 * rep.cost_start,
                "{solver:?} (modal {modal_metric}): cost {} from {}",
                rep.cost,
                rep.cost_start
            );
            for (b, (got, want)) in rep.mck.iter().zip(&truth).enumerate() {
                let err = (0..m)
                    .flat_map(|i| (0..m).map(move |j| (i, j)))
                    .map(|(i, j)| (got[(i, j)] - want[(i, j)]).abs())
                    .fold(0.0, f64::max);
                let top = (0..m).map(|i| want[(i, i)].abs()).fold(0.0, f64::max);
                assert!(err <= 1e-6 * top, "{solver:?} block {b}: error {err}");
            }
        }
    }

    #[test]
    fn the_damping_basis_is_orthonormal_most_damped_first_and_turns_back_exactly() {
        let mut rng = Lcg(17);
        let m = 6;
        let mck = system(m, &mut rng);
        // C with one strongly damped direction added
        let e = Mat::from_fn(m, 1, |_, _| rng.next());
        let c = Mat::from_fn(m, m, |i, j| mck[1][(i, j)] + 50.0 * e[(i, 0)] * e[(j, 0)]);
        let l = [
            psd_factor(mck[0].as_ref(), 0.0).unwrap(),
            psd_factor(c.as_ref(), 0.0).unwrap(),
            psd_factor(mck[2].as_ref(), 0.0).unwrap(),
        ];
        let v = damping_basis(&l).unwrap();
        let vtv = v.transpose() * &v;
        let x = [0, 1, 2].map(|b| gram_lower(&l[b]));
        for i in 0..m {
            for j in 0..m {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((vtv[(i, j)] - want).abs() < 1e-12, "VᵀV[{i}, {j}]");
            }
        }
        // the first column is the most damped mode (M-normalised: largest vᵀCv / vᵀMv)
        let ratio = |w: MatRef<f64>| {
            let q = |x: &Mat<f64>| (w.transpose() * x * w)[(0, 0)];
            q(&x[1]) / q(&x[0])
        };
        let first = ratio(v.as_ref().subcols(0, 1));
        for j in 1..m {
            assert!(ratio(v.as_ref().subcols(j, 1)) < first);
        }
        // the rotated factors give Vᵀ X V, and vectors turn there and back
        for b in 0..3 {
            let lr = rotated_factor(&l[b], v.as_ref()).unwrap();
            let want = v.transpose() * &x[b] * &v;
            let got = gram_lower(&lr);
            for i in 0..m {
                for j in 0..m {
                    assert!((got[(i, j)] - want[(i, j)]).abs() < 1e-12 * want[(i, i)].abs());
                }
            }
        }
        let z0: Vec<c64> = (0..3 * m)
            .map(|_| c64::new(rng.next(), rng.next()))
            .collect();
        let mut z = z0.clone();
        rotate_columns(&mut z, v.as_ref(), false);
        let col0: c64 = (0..m).map(|k| z0[k] * v[(k, 2)]).sum();
        assert!((z[2] - col0).norm() < 1e-14);
        rotate_columns(&mut z, v.as_ref(), true);
        for (a, b) in z.iter().zip(&z0) {
            assert!((a - b).norm() < 1e-14);
        }
    }

    #[test]
    fn noise_free_data_give_the_exact_model_back() {
        let mut rng = Lcg(11);
        for (m, p, log_diagonal) in [(2, 1, true), (4, 2, true), (5, 3, false)] {
            let truth = system(m, &mut rng);
            // lines around the modes: scaled frequencies 0.2 … 3
            let omega: Vec<f64> = (0..40).map(|i| 100.0 * (0.2 + 0.07 * i as f64)).collect();
            // physical units: M ~ 1, K ~ 1e4 (ω ~ 100)
            let truth = [
                truth[0].clone(),
                Mat::from_fn(m, m, |i, j| 100.0 * truth[1][(i, j)]),
                Mat::from_fn(m, m, |i, j| 1e4 * truth[2][(i, j)]),
            ];
            let (u, f) = exact_data(&truth, &omega, p, &mut rng);
            let w = vec![1.0; omega.len() * p];
            let data = OeData {
                omega: &omega,
                u: &u,
                f: &f,
                weights: Weights::Scalar(&w),
                m,
                p,
            };
            let start = perturbed(&truth, 0.05, &mut rng);
            for (solver, modal_metric) in [
                (StepKind::Dense, false),
                (StepKind::MatrixFree, false),
                (StepKind::MatrixFree, true),
            ] {
                let opts = OeOptions {
                    log_diagonal,
                    solver,
                    modal_metric,
                    ..Default::default()
                };
                let rep = refine(data, &start, opts, Par::Seq, None).unwrap();
                assert!(rep.stop.converged(), "{:?}", rep.stop);
                assert_eq!(rep.solver, solver.name());
                for (b, (got, want)) in rep.mck.iter().zip(&truth).enumerate() {
                    let num: f64 = (0..m)
                        .flat_map(|i| (0..m).map(move |j| (i, j)))
                        .map(|(i, j)| (got[(i, j)] - want[(i, j)]).powi(2))
                        .sum();
                    let den: f64 = (0..m)
                        .flat_map(|i| (0..m).map(move |j| (i, j)))
                        .map(|(i, j)| want[(i, j)].powi(2))
                        .sum();
                    assert!(
                        (num / den).sqrt() < 1e-8,
                        "m {m} block {b} (modal {modal_metric}): {}",
                        (num / den).sqrt()
                    );
                }
                assert!(rep.cost < 1e-20 * rep.cost_start.max(1e-300) || rep.cost < 1e-24);
            }
        }
    }
}
