//! The Levenberg–Marquardt iteration of the output-error refinement ([`refine`]).
//!
//! From the start factors ([`super::start`]) each iteration prepares the step solver
//! at a new point (the gradient, and what the solver keeps of the Gauss–Newton
//! matrix), solves the damped Gauss–Newton step, evaluates the model at the trial
//! point, and accepts the step if the cost fell (damping less, by the gain ratio) or
//! rejects it (damping more), until the cost or the step stops changing, the
//! gradient vanishes, no damping finds a descent, or `max_iter` steps were taken.

use super::dense::DenseNormal;
use super::geodesic::{accelerated_step, second_difference, GEODESIC_H};
use super::input::{OeData, Weights};
use super::lines;
use super::matfree::MatrixFree;
use super::objective::{Evaluation, Problem};
use super::options::{OeOptions, StepKind, MAX_CG_ITER};
use super::parametrisation::{
    damping_basis, gram_lower, log_step_too_long, rotate_columns, rotated_factor, Params,
};
use super::report::{OeReport, Stop};
use super::start::{check_start, scaled_start, scaling_of, start_factors};
use super::step_solver::StepSolver;
use crate::data::Scaling;
use crate::error::PodidError;
use crate::Progress;
use faer::{c64, Mat, MatRef, Par};
use std::time::Instant;

/// Accepted steps over which the relative cost decrease is judged (see `ftol`).
pub const FTOL_WINDOW: usize = 10;

/// With [`OeOptions::curvature`], the parametrisation's curvature ([`super::curvature`]) is
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
    check_start(start, data.m)?;
    let t_total = Instant::now();
    let scaling = scaling_of(&data);
    let mut pb = Problem::new(data, &scaling);
    let given = scaled_start(start, &scaling);
    let mut factors = start_factors(&given)?;
    // responses of the start as given (before the damping floor), for the report
    let responses_start = pb.evaluate(&given).ok().map(|e| e.x);
    let kind = opts
        .solver
        .resolve(data.m, data.s(), lines::terms_per_line(&pb));
    // the matrix-free modal step works in the damping basis ([`damping_basis`])
    let basis = match data.weights {
        Weights::Scalar(_) if kind == StepKind::MatrixFree && opts.modal_metric => {
            damping_basis(&factors)
        }
        _ => None,
    };
    if let Some(v) = &basis {
        turn_to_basis(&mut pb, &mut factors, v.as_ref())?;
    }
    let params = Params {
        m: data.m,
        log_diagonal: opts.log_diagonal,
    };
    // the cost in the caller's units (the log-magnitude cost has none)
    let su2 = match data.weights {
        Weights::LogMagnitude(_) => 1.0,
        _ => scaling.su * scaling.su,
    };
    // the acceleration needs the dense step's factor and a residual linear in the
    // responses: elsewhere it is not attempted (not two evaluations per step for nothing)
    let opts = OeOptions {
        acceleration: opts.acceleration
            && kind == StepKind::Dense
            && !matches!(data.weights, Weights::LogMagnitude(_)),
        ..opts
    };
    let mut lm = LevenbergMarquardt::new(&pb, params, &factors, opts, par, su2)?;
    let mut solver = step_solver(kind, &opts);
    let stop = lm.run(solver.as_mut(), &mut progress)?;
    let finish = Finish {
        stop,
        basis: basis.as_ref(),
        scaling,
        kind,
        responses_start,
        t_total,
    };
    Ok(lm.into_report(finish, solver.as_ref()))
}

/// The step solver of `kind` (dense or matrix-free, [`StepKind::resolve`]d).
fn step_solver(kind: StepKind, opts: &OeOptions) -> Box<dyn StepSolver> {
    match kind {
        StepKind::MatrixFree => Box::new(
            MatrixFree::new(MAX_CG_ITER)
                .with_curvature(opts.curvature)
                .with_modal_metric(opts.modal_metric),
        ),
        _ => Box::new(DenseNormal::with_curvature(opts.curvature)),
    }
}

/// The problem and the start factors turned into the orthonormal basis `v`: the
/// data's columns by vᵀ, each factor to that of vᵀ X v.
fn turn_to_basis(
    pb: &mut Problem,
    factors: &mut [Mat<f64>; 3],
    v: MatRef<f64>,
) -> Result<(), PodidError> {
    rotate_columns(&mut pb.u, v, false);
    rotate_columns(&mut pb.f, v, false);
    for lb in factors.iter_mut() {
        *lb = rotated_factor(lb, v)?;
    }
    Ok(())
}

/// Levenberg–Marquardt after a rejected step: μ ← μν, ν ← 2ν; true when μ has grown
/// past any use (no descent).
fn more_damping(mu: &mut f64, nu: &mut f64) -> bool {
    *mu *= *nu;
    *nu *= 2.0;
    *mu > 1e16
}

/// A point of the iteration: θ, its factors, the model X = L Lᵀ + ε tr(L Lᵀ) I of
/// each block, and its evaluation (scaled units).
struct Point {
    theta: Vec<f64>,
    factors: [Mat<f64>; 3],
    mck: [Mat<f64>; 3],
    ev: Evaluation,
}

impl Point {
    /// The point at `theta` on `pb`, its LU factors written over `spare`
    /// ([`Problem::evaluate_into`]), and the seconds the evaluation took.
    fn at(
        pb: &Problem,
        params: &Params,
        theta: Vec<f64>,
        spare: Vec<c64>,
    ) -> Result<(Point, f64), PodidError> {
        let factors = params.unpack(&theta);
        let mck = factors.clone().map(|x| gram_lower(&x));
        let t0 = Instant::now();
        let ev = pb.evaluate_into(&mck, spare)?;
        let seconds = t0.elapsed().as_secs_f64();
        let point = Point {
            theta,
            factors,
            mck,
            ev,
        };
        Ok((point, seconds))
    }
}

/// The Levenberg–Marquardt iteration in progress (scaled units).
struct LevenbergMarquardt<'p, 'a> {
    pb: &'p Problem<'a>,
    params: Params,
    opts: OeOptions,
    par: Par,
    /// the current point
    point: Point,
    /// the gradient at the current point, once the step solver is prepared there
    gradient: Vec<f64>,
    /// the step solver is still to be prepared at the current point
    fresh: bool,
    /// a step from the current point was rejected
    rejected_here: bool,
    /// the damping μ (0 until the first step) and its growth factor ν
    mu: f64,
    nu: f64,
    /// Gauss–Newton steps taken (accepted or rejected), and accepted
    iterations: usize,
    accepted: usize,
    /// the cost at the start, and (iteration, cost) after every accepted step in the
    /// caller's units
    cost_start: f64,
    history: Vec<(usize, f64)>,
    /// a cost in the caller's units per scaled cost (1 for the log-magnitude cost,
    /// which has no units)
    su2: f64,
    /// the LU buffer of the last evaluation dropped, for the next one
    spare: Vec<c64>,
    /// wall time evaluating the model, preparing the step solver, solving for steps
    t_eval: f64,
    t_normal: f64,
    t_solve: f64,
}

/// What the report needs besides the iteration's own state.
struct Finish<'v> {
    stop: Stop,
    /// the damping basis the problem was turned into, if any
    basis: Option<&'v Mat<f64>>,
    scaling: Scaling,
    kind: StepKind,
    /// the responses of the start as given (scaled), None with a pole on a line
    responses_start: Option<Vec<c64>>,
    t_total: Instant,
}

impl<'p, 'a> LevenbergMarquardt<'p, 'a> {
    /// The iteration at the start `factors`; an error when the start model has a pole
    /// on a measured line. `su2`: a cost in the caller's units per scaled cost.
    fn new(
        pb: &'p Problem<'a>,
        params: Params,
        factors: &[Mat<f64>; 3],
        opts: OeOptions,
        par: Par,
        su2: f64,
    ) -> Result<Self, PodidError> {
        let theta = params.pack(factors);
        let (point, t_eval) = Point::at(pb, &params, theta, Vec::new())?;
        if !point.ev.cost.is_finite() {
            return Err(PodidError::Invalid(
                "the start model has a pole on a measured frequency line (D(ω) singular)".into(),
            ));
        }
        let cost_start = point.ev.cost;
        Ok(LevenbergMarquardt {
            pb,
            params,
            opts,
            par,
            point,
            gradient: Vec::new(),
            fresh: true,
            rejected_here: false,
            mu: 0.0,
            nu: 2.0,
            iterations: 0,
            accepted: 0,
            cost_start,
            history: vec![(0, cost_start * su2)],
            su2,
            spare: Vec::new(),
            t_eval,
            t_normal: 0.0,
            t_solve: 0.0,
        })
    }

    /// Iterate until a stopping rule holds; Ctrl-C (a `progress` that breaks) is
    /// [`PodidError::Interrupted`].
    fn run(
        &mut self,
        solver: &mut dyn StepSolver,
        progress: &mut Option<Progress>,
    ) -> Result<Stop, PodidError> {
        while self.iterations < self.opts.max_iter {
            if self.fresh && self.prepare(solver) {
                return Ok(Stop::GradientZero);
            }
            if self.mu == 0.0 {
                self.mu = solver.initial_damping();
            }
            self.iterations += 1;
            // Gauss–Newton alone right after a step that lowered the cost fast, unless
            // a step from this point was already rejected ([`CURVATURE_SWITCH`])
            solver.set_curvature(
                self.opts.curvature && (self.rejected_here || !self.cost_falling_fast()),
            );
            let step = self.solve_for_step(solver, progress)?;
            // no step, or a long step in a log-diagonal (it can overflow the model in
            // one go): damp more
            let Some(step) = step.filter(|st| !self.too_long(st)) else {
                if self.reject() {
                    return Ok(Stop::NoDescent);
                }
                continue;
            };
            // the Gauss–Newton model's decrease for v; the step taken may be v + a/2
            let predicted = solver.predicted(&self.gradient, &step, self.par);
            let step = match self.opts.acceleration {
                true => self.accelerated(solver, step)?,
                false => Some(step),
            };
            // an acceleration too large against the step, or a long accelerated step
            // in a log-diagonal: damp more
            let Some(step) = step.filter(|st| !self.too_long(st)) else {
                if self.reject() {
                    return Ok(Stop::NoDescent);
                }
                continue;
            };
            let trial = self.try_step(&step)?;
            let small = self.step_is_small(&step);
            if trial.ev.cost.is_finite() && self.point.ev.cost - trial.ev.cost > 0.0 {
                self.accept(trial, predicted);
                self.report_progress(progress)?;
                if self.cost_converged() {
                    return Ok(Stop::CostConverged);
                }
                if small {
                    return Ok(Stop::StepConverged);
                }
            } else {
                self.spare = trial.ev.lu;
                if small {
                    return Ok(Stop::StepConverged);
                }
                if self.reject() {
                    return Ok(Stop::NoDescent);
                }
                self.report_progress(progress)?;
            }
        }
        Ok(Stop::MaxIter)
    }

    /// Prepare the step solver at the current point (its gradient); true at a
    /// stationary point: the gradient vanished, or the fit is exact.
    fn prepare(&mut self, solver: &mut dyn StepSolver) -> bool {
        let t0 = Instant::now();
        let at = &self.point;
        self.gradient = solver.prepare(self.pb, &self.params, &at.factors, &at.ev, self.par);
        self.t_normal += t0.elapsed().as_secs_f64();
        self.fresh = false;
        let gmax = self.gradient.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        gmax == 0.0 || self.point.ev.cost == 0.0
    }

    /// The last accepted step lowered the cost by at least [`CURVATURE_SWITCH`].
    fn cost_falling_fast(&self) -> bool {
        let h = &self.history;
        h.len() >= 2 && {
            let (before, now) = (h[h.len() - 2].1, h[h.len() - 1].1);
            before - now >= CURVATURE_SWITCH * before
        }
    }

    /// The damped Gauss–Newton step from the current point (None if the solver found
    /// none); `progress` is polled during the solve.
    fn solve_for_step(
        &mut self,
        solver: &mut dyn StepSolver,
        progress: &mut Option<Progress>,
    ) -> Result<Option<Vec<f64>>, PodidError> {
        let t0 = Instant::now();
        let mut cancelled = false;
        let step = {
            let (iterations, cost_now) = (self.iterations, self.point.ev.cost * self.su2);
            let mut poll = || {
                if let Some(cb) = progress.as_mut() {
                    cancelled |= cb(iterations, cost_now).is_break();
                }
                cancelled
            };
            solver.step(&self.gradient, self.mu, self.par, &mut poll)
        };
        self.t_solve += t0.elapsed().as_secs_f64();
        if cancelled {
            return Err(PodidError::Interrupted);
        }
        Ok(step)
    }

    /// The step `v` with its geodesic acceleration ([`super::geodesic`]): v + a/2, None
    /// when a is too large against v; v itself where the solver or the objective
    /// gives no acceleration, or the model has a pole on a line at θ ± hv.
    fn accelerated(
        &mut self,
        solver: &mut dyn StepSolver,
        v: Vec<f64>,
    ) -> Result<Option<Vec<f64>>, PodidError> {
        let h = GEODESIC_H;
        let theta = &self.point.theta;
        let plus: Vec<f64> = theta.iter().zip(&v).map(|(a, b)| a + h * b).collect();
        let minus: Vec<f64> = theta.iter().zip(&v).map(|(a, b)| a - h * b).collect();
        let ahead = self.evaluate_at(plus)?;
        self.spare = ahead.ev.lu;
        let behind = self.evaluate_at(minus)?;
        self.spare = behind.ev.lu;
        if !(ahead.ev.cost.is_finite() && behind.ev.cost.is_finite()) {
            return Ok(Some(v));
        }
        let x_vv = second_difference(&ahead.ev.x, &self.point.ev.x, &behind.ev.x, h);
        let at = &self.point;
        let Some(jt) =
            lines::jt_of_responses(self.pb, &self.params, &at.factors, &at.ev, &x_vv, self.par)
        else {
            return Ok(Some(v));
        };
        let rhs: Vec<f64> = jt.iter().map(|x| -x).collect();
        match solver.solve_again(&rhs, self.par) {
            Some(a) => Ok(accelerated_step(&v, &a)),
            None => Ok(Some(v)),
        }
    }

    /// A step that changes a log-diagonal by more than the parametrisation allows.
    fn too_long(&self, step: &[f64]) -> bool {
        self.params.log_diagonal && log_step_too_long(&self.params, step)
    }

    /// The model at θ + `step`, evaluated.
    fn try_step(&mut self, step: &[f64]) -> Result<Point, PodidError> {
        let theta = &self.point.theta;
        let trial: Vec<f64> = theta.iter().zip(step).map(|(a, b)| a + b).collect();
        self.evaluate_at(trial)
    }

    /// The point at `theta` (its LU factors written over the spare buffer).
    fn evaluate_at(&mut self, theta: Vec<f64>) -> Result<Point, PodidError> {
        let spare = std::mem::take(&mut self.spare);
        let (point, seconds) = Point::at(self.pb, &self.params, theta, spare)?;
        self.t_eval += seconds;
        Ok(point)
    }

    /// ‖δθ‖ ≤ xtol·(‖θ‖ + xtol) at the current point.
    fn step_is_small(&self, step: &[f64]) -> bool {
        let snorm = step.iter().map(|v| v * v).sum::<f64>().sqrt();
        let tnorm = self.point.theta.iter().map(|v| v * v).sum::<f64>().sqrt();
        snorm <= self.opts.xtol * (tnorm + self.opts.xtol)
    }

    /// Move to `trial`, which lowered the cost, and damp less by the gain ratio of
    /// the actual to the `predicted` decrease.
    fn accept(&mut self, trial: Point, predicted: f64) {
        let actual = self.point.ev.cost - trial.ev.cost;
        let rho = actual / predicted.max(f64::MIN_POSITIVE);
        self.spare = std::mem::replace(&mut self.point, trial).ev.lu;
        self.accepted += 1;
        self.fresh = true;
        self.rejected_here = false;
        self.mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
        self.nu = 2.0;
        self.history
            .push((self.iterations, self.point.ev.cost * self.su2));
    }

    /// A step from the current point was rejected: damp more; true when the damping
    /// has grown past any use (no descent).
    fn reject(&mut self) -> bool {
        self.rejected_here = true;
        more_damping(&mut self.mu, &mut self.nu)
    }

    /// The last [`FTOL_WINDOW`] accepted steps together lowered the cost by less than
    /// `FTOL_WINDOW · ftol` relative.
    fn cost_converged(&self) -> bool {
        let h = &self.history;
        let earlier = h[h.len().saturating_sub(FTOL_WINDOW + 1)].1;
        let full = h.len() > FTOL_WINDOW;
        full && (earlier - self.point.ev.cost * self.su2)
            < FTOL_WINDOW as f64 * self.opts.ftol * earlier
    }

    /// Tell `progress` the iteration and the current cost; it may stop the iteration.
    fn report_progress(&self, progress: &mut Option<Progress>) -> Result<(), PodidError> {
        if let Some(cb) = progress.as_mut() {
            if cb(self.iterations, self.point.ev.cost * self.su2).is_break() {
                return Err(PodidError::Interrupted);
            }
        }
        Ok(())
    }

    /// The report: the model turned back out of the damping basis and in the caller's
    /// units.
    fn into_report(mut self, finish: Finish, solver: &dyn StepSolver) -> OeReport {
        let m = self.pb.data.m;
        let mut mck = self.point.mck;
        if let Some(v) = finish.basis {
            // back to the caller's coordinates: X = V X' Vᵀ, x = V x'
            for x in mck.iter_mut() {
                let vx = v * &*x;
                *x = &vx * v.transpose();
            }
            rotate_columns(&mut self.point.ev.x, v.as_ref(), true);
        }
        let scaling = finish.scaling;
        let fac = scaling.block_factors();
        let out = [0, 1, 2].map(|b| Mat::from_fn(m, m, |i, j| mck[b][(i, j)] * fac[b]));
        OeReport {
            mck: out,
            cost_start: self.cost_start * self.su2,
            cost: self.point.ev.cost * self.su2,
            iterations: self.iterations,
            accepted: self.accepted,
            stop: finish.stop,
            history: self.history,
            scaling,
            timings: [
                ("evaluate", self.t_eval),
                ("normal", self.t_normal),
                ("solve", self.t_solve),
                ("total", finish.t_total.elapsed().as_secs_f64()),
            ]
            .into_iter()
            .chain(solver.timings())
            .collect(),
            solver: finish.kind.name(),
            solver_stats: solver.stats(),
            responses_start: finish
                .responses_start
                .map(|x| x.into_iter().map(|v| v * scaling.su).collect()),
            responses: self.point.ev.x.iter().map(|v| v * scaling.su).collect(),
        }
    }
}
