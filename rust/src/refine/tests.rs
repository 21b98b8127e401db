//! Tests of the output-error refinement: the Gauss–Newton matrix and gradient of both
//! step solvers against an explicit Jacobian and finite differences, the modal metric,
//! the log-magnitude objective, the damping basis, and whole refinements on exact data.

use super::dense::DenseNormal;
use super::line_solves::solve_lines;
use super::objective::{dynamic_stiffness, log_targets, weighted_residual, Evaluation, Problem};
use super::parametrisation::{
    damping_basis, gram_lower, rotate_columns, rotated_factor, tri, Params,
};
use super::step_solver::StepSolver;
use super::*;
use faer::{c64, Mat, MatRef, Par};

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
            (0..m).map(|k| a[(i, k)] * a[(j, k)]).sum::<f64>() + if i == j { shift } else { 0.0 }
        })
    };
    let mm = spd(rng, 1.0);
    let kk = spd(rng, 2.0);
    let cc = Mat::from_fn(m, m, |i, j| 0.05 * mm[(i, j)] + 0.02 * kk[(i, j)]);
    [mm, cc, kk]
}

/// Exact responses u = D⁻¹ f for random forces.
fn exact_data(mck: &[Mat<f64>; 3], omega: &[f64], p: usize, rng: &mut Lcg) -> (Vec<c64>, Vec<c64>) {
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
                let lu = MatRef::from_column_major_slice(&ev.lu[i * m * m..(i + 1) * m * m], m, m);
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
        // Jᵀ of a change of the responses (the geodesic acceleration's), given x − u,
        // is the gradient
        let e: Vec<c64> = ev.x.iter().zip(&pb.u).map(|(x, u)| x - u).collect();
        let jt = lines::jt_of_responses(&pb, &params, &lf, &ev, &e, Par::Seq).unwrap();
        for a in 0..n {
            let g: f64 = jac[a].iter().zip(&r0).map(|(x, y)| x * y).sum();
            assert!(
                (g - jt[a]).abs()
                    <= 1e-12 * scale.sqrt() * r0.iter().map(|v| v * v).sum::<f64>().sqrt(),
                "m {m} Jᵀ(x − u)[{a}]: {g} vs {}",
                jt[a]
            );
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
    // a tiny but non-zero weighted target is a value, not a zero: |z|² underflows to 0
    // below 1.5e-162, |z| does not (a far point of a long scan)
    t0[0] = c64::new(1e-170, -1e-171);
    let tiny = OeData {
        weights: Weights::LogMagnitude(LogTarget { u: &t0, ..lt }),
        ..data
    };
    tiny.validate().unwrap();
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
        for (solver, modal_metric, acceleration) in [
            (StepKind::Dense, false, false),
            (StepKind::Dense, false, true),
            (StepKind::MatrixFree, false, false),
            (StepKind::MatrixFree, true, false),
        ] {
            let opts = OeOptions {
                log_diagonal,
                solver,
                modal_metric,
                acceleration,
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
