//! The objective: the output error of a model on the scaled data ([`Problem`]). One
//! evaluation ([`Problem::evaluate`]) factors D(ω) = −ω²M + iωC + K of every line,
//! solves for the model's responses x and sums the cost — Σ‖T(x − u)‖² over the
//! columns ([`weighted_residual`]), or for the log-magnitude objective Σ w²(ln|y| −
//! ln|u|)² with the metric and gradient terms of its Gauss–Newton step ([`LogTerms`]).

use super::input::{LogTarget, OeData, Weights};
use super::line_solves::solve_lines;
use crate::data::Scaling;
use crate::error::PodidError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor as lu_factor;
use faer::{c64, Mat, MatMut, Par};
use rayon::prelude::*;

/// Per-line LU of D(ω_i), the responses x and the cost.
pub(crate) struct Evaluation {
    /// LU factors of every line, column-major m×m each
    pub(crate) lu: Vec<c64>,
    /// row permutation of every line
    pub(crate) perm: Vec<usize>,
    /// model responses x_ij, layout of the data
    pub(crate) x: Vec<c64>,
    pub(crate) cost: f64,
    /// the log-magnitude objective's metric and gradient source at this point
    pub(crate) log: Option<LogTerms>,
}

/// Per column at the current point (log-magnitude objective): the metric
/// W = ½ Rᵀ diag(w²/|y|²) R (row-major m×m) and ρ = Rᵀ (w r ⊘ conj(y)), r the
/// entries' residuals, so that the gradient is Re Σ ρᴴ δx (in place of W (x − u)).
pub(crate) struct LogTerms {
    pub(crate) metric: Vec<f64>,
    pub(crate) rho: Vec<c64>,
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
        // |y| by hypot: |y|² would underflow below 1.5e-162 and make a finite cost infinite
        let ay = y.norm();
        let inv = 1.0 / ay;
        if !(ay > 0.0 && inv.is_finite() && (inv * inv).is_finite()) {
            return f64::INFINITY;
        }
        let r = w * (ay.ln() - log_u[col * n + e]);
        cost += r * r;
        let g = y * (w * r * inv * inv); // w r / conj(y)
        let h = 0.5 * w * w * inv * inv;
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
    pub(crate) data: OeData<'a>,
    /// scaled ω, u, f
    pub(crate) w: Vec<f64>,
    pub(crate) u: Vec<c64>,
    pub(crate) f: Vec<c64>,
    /// ln|u_ije| of the scaled log-magnitude targets (empty for the other weights)
    pub(crate) log_u: Vec<f64>,
}

/// ln|u / su| of each log-magnitude target entry (0 where its weight is 0).
pub(crate) fn log_targets(weights: &Weights, su: f64) -> Vec<f64> {
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

impl<'a> Problem<'a> {
    /// The objective on `data` scaled by `scaling`: ω/ω0, u/s_u, f/s_f.
    pub(crate) fn new(data: OeData<'a>, scaling: &Scaling) -> Problem<'a> {
        Problem {
            data,
            w: data.omega.iter().map(|w| w / scaling.omega0).collect(),
            u: data.u.iter().map(|z| z / scaling.su).collect(),
            f: data.f.iter().map(|z| z / scaling.sf).collect(),
            log_u: log_targets(&data.weights, scaling.su),
        }
    }

    pub(crate) fn column_weight(&self, col: usize) -> (Option<&[f64]>, f64) {
        let m = self.data.m;
        match self.data.weights {
            Weights::Scalar(w) => (None, w[col]),
            Weights::Matrix(t) => (Some(&t[col * m * m..(col + 1) * m * m]), 1.0),
            Weights::LogMagnitude(_) => unreachable!("the log-magnitude cost is not T (x − u)"),
        }
    }

    /// LU of every line, the model responses and the cost (scaled units).
    pub(crate) fn evaluate(&self, mck: &[Mat<f64>; 3]) -> Result<Evaluation, PodidError> {
        self.evaluate_into(mck, Vec::new())
    }

    /// As [`Self::evaluate`], the LU factors written over `spare` where it has their size
    /// (every entry is written: its contents do not matter) — the refinement hands back
    /// the buffer of the evaluation it drops, instead of the kernel clearing a fresh
    /// s·m² one each time (320 MB at m = 100, 2000 lines).
    pub(crate) fn evaluate_into(
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
