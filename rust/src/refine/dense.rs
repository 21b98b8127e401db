//! The dense Gauss–Newton step: N_θ formed explicitly (DESIGN §6), factored by
//! Cholesky. Memory: the Kronecker sum S (m(m+1)/2 × 9m²) and N_θ ((3m(m+1)/2)²),
//! so for orders up to a few tens.

use super::{
    inverse_of, n_per_block, tri, weighted_residual, Evaluation, Params, Problem, StepSolver,
    Weights, CONDITION_FLOOR,
};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::matmul;
use faer::{c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// N_θ of the current point, column-major.
#[derive(Default)]
pub(crate) struct DenseNormal {
    nth: Vec<f64>,
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
        let (nth, g) = normal_equations(pb, params, l, ev, par);
        self.nth = nth;
        g
    }

    fn step(&mut self, g: &[f64], mu: f64, par: Par) -> Option<Vec<f64>> {
        let n = g.len();
        let dmax = (0..n).map(|i| self.nth[i * n + i]).fold(0.0f64, f64::max);
        let floor = 1e-12 * dmax.max(f64::MIN_POSITIVE);
        damped_step(&self.nth, g, mu, floor, par)
    }

    fn quad(&mut self, x: &[f64], _par: Par) -> f64 {
        let n = x.len();
        (0..n)
            .map(|j| x[j] * (0..n).map(|i| self.nth[j * n + i] * x[i]).sum::<f64>())
            .sum()
    }
}

/// Lines processed together when forming the normal matrix (bounds memory).
const NORMAL_CHUNK: usize = 256;

/// Gauss–Newton matrix N_θ (column-major, n×n) and gradient g_θ = Jᵀr at the
/// current point (scaled units).
pub(crate) fn normal_equations(
    pb: &Problem,
    params: &Params,
    l: &[Mat<f64>; 3],
    ev: &Evaluation,
    par: Par,
) -> (Vec<f64>, Vec<f64>) {
    let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
    let mm = m * m;
    let m3 = 3 * m;
    let vv = m3 * m3;
    // pairs r ≤ r' of the row index of G
    let pairs: Vec<(usize, usize)> = (0..m).flat_map(|r| (r..m).map(move |q| (r, q))).collect();
    let np = pairs.len();
    let matrix_weights = matches!(pb.data.weights, Weights::Matrix(_));
    // one "term" (G, V̄) per line (scalar weights: G shared by its load cases) or per column
    let terms_per_line = if matrix_weights { p } else { 1 };

    let mut s_mat = Mat::<f64>::zeros(np, vv); // S[(r≤r'), (c,c')]
    let mut grad_z = Mat::<f64>::zeros(m, m3);

    for start in (0..s).step_by(NORMAL_CHUNK) {
        let lines = NORMAL_CHUNK.min(s - start);
        let k = lines * terms_per_line;
        // columns: [Re G_1 … Re G_k, −Im G_1 … −Im G_k] and [Re V̄ …, Im V̄ …]
        let mut xg = Mat::<f64>::zeros(np, 2 * k);
        let mut yv = Mat::<f64>::zeros(vv, 2 * k);
        let per_line: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = (start..start + lines)
            .into_par_iter()
            .map(|i| {
                let lu = MatRef::from_column_major_slice(&ev.lu[i * mm..(i + 1) * mm], m, m);
                let dinv = inverse_of(lu, &ev.perm[i * m..(i + 1) * m], m);
                let w = pb.w[i];
                let mut gvals = Vec::with_capacity(terms_per_line * 2 * np);
                let mut vvals = Vec::with_capacity(terms_per_line * 2 * vv);
                let mut grad = vec![0.0; m * m3];
                let mut vbar = vec![c64::new(0.0, 0.0); vv];
                let mut g = vec![c64::new(0.0, 0.0); mm];
                let mut a = vec![c64::new(0.0, 0.0); mm];
                let mut r = vec![c64::new(0.0, 0.0); m];
                let mut ahr = vec![c64::new(0.0, 0.0); m];
                let mut vhat = vec![c64::new(0.0, 0.0); m3];
                let push = |g: &[c64], vbar: &[c64], gvals: &mut Vec<f64>, vvals: &mut Vec<f64>| {
                    gvals.extend(pairs.iter().map(|&(r1, r2)| g[r1 * m + r2].re));
                    gvals.extend(pairs.iter().map(|&(r1, r2)| -g[r1 * m + r2].im));
                    vvals.extend(vbar.iter().map(|z| z.re));
                    vvals.extend(vbar.iter().map(|z| z.im));
                };
                // G = Aᴴ A (row-major); with scalar weights the line's G is (D⁻¹)ᴴ D⁻¹ and
                // each column's w² goes into the line's V̄
                let gram_of = |a: &[c64], g: &mut [c64], row_major: bool| {
                    for r1 in 0..m {
                        for r2 in 0..m {
                            g[r1 * m + r2] = (0..m)
                                .map(|row| {
                                    let (x1, x2) = if row_major {
                                        (a[row * m + r1], a[row * m + r2])
                                    } else {
                                        (a[r1 * m + row], a[r2 * m + row])
                                    };
                                    x1.conj() * x2
                                })
                                .sum();
                        }
                    }
                };
                if !matrix_weights {
                    gram_of(&dinv, &mut g, false);
                }
                for j in 0..p {
                    let col = i * p + j;
                    let (t, wt) = pb.column_weight(col);
                    let x = &ev.x[col * m..(col + 1) * m];
                    weighted_residual(t, wt, x, &pb.u[col * m..(col + 1) * m], &mut r);
                    // A = T D⁻¹ (row-major a[row·m + k]); dinv is column-major
                    for row in 0..m {
                        for kk in 0..m {
                            a[row * m + kk] = match t {
                                None => dinv[kk * m + row] * wt,
                                Some(t) => (0..m).map(|q| dinv[kk * m + q] * t[row * m + q]).sum(),
                            };
                        }
                    }
                    for kk in 0..m {
                        ahr[kk] = (0..m).map(|row| a[row * m + kk].conj() * r[row]).sum();
                    }
                    for q in 0..m {
                        vhat[q] = x[q] * (-w * w);
                        vhat[m + q] = x[q] * c64::new(0.0, w);
                        vhat[2 * m + q] = x[q];
                    }
                    // gradient in Z: −Re((Aᴴ r) v̂ᴴ)
                    for row in 0..m {
                        for c in 0..m3 {
                            grad[row * m3 + c] -= (ahr[row] * vhat[c].conj()).re;
                        }
                    }
                    let scale = if matrix_weights { 1.0 } else { wt * wt };
                    if matrix_weights {
                        gram_of(&a, &mut g, true);
                        vbar.iter_mut().for_each(|z| *z = c64::new(0.0, 0.0));
                    }
                    for c1 in 0..m3 {
                        let a1 = vhat[c1].conj() * scale;
                        for c2 in 0..m3 {
                            vbar[c1 * m3 + c2] += a1 * vhat[c2];
                        }
                    }
                    if matrix_weights {
                        push(&g, &vbar, &mut gvals, &mut vvals);
                    }
                }
                if !matrix_weights {
                    push(&g, &vbar, &mut gvals, &mut vvals);
                }
                (gvals, vvals, grad)
            })
            .collect();
        for (li, (gvals, vvals, grad)) in per_line.iter().enumerate() {
            for t in 0..terms_per_line {
                let col = li * terms_per_line + t;
                let gv = &gvals[t * 2 * np..(t + 1) * 2 * np];
                let vvv = &vvals[t * 2 * vv..(t + 1) * 2 * vv];
                for q in 0..np {
                    xg[(q, col)] = gv[q];
                    xg[(q, k + col)] = gv[np + q];
                }
                for q in 0..vv {
                    yv[(q, col)] = vvv[q];
                    yv[(q, k + col)] = vvv[vv + q];
                }
            }
            for row in 0..m {
                for c in 0..m3 {
                    grad_z[(row, c)] += grad[row * m3 + c];
                }
            }
        }
        matmul(
            s_mat.as_mut(),
            Accum::Add,
            xg.as_ref(),
            yv.as_ref().transpose(),
            1.0,
            par,
        );
    }

    // pair index of (r, r'), and whether it is transposed
    let mut pair_of = vec![0usize; mm];
    for (q, &(r1, r2)) in pairs.iter().enumerate() {
        pair_of[r1 * m + r2] = q;
        pair_of[r2 * m + r1] = q;
    }
    // N_Z block (b, b'), row-major entry index (r·m + col): S[(r,r'),(bm+col, b'm+col')],
    // read as S[(r',r),(b'm+col', bm+col)] when r > r'
    let nz_block = |b: usize, bp: usize| -> Mat<f64> {
        Mat::from_fn(mm, mm, |row, colp| {
            let (r1, c1) = (row / m, row % m);
            let (r2, c2) = (colp / m, colp % m);
            let q = pair_of[r1 * m + r2];
            if r1 <= r2 {
                s_mat[(q, (b * m + c1) * m3 + bp * m + c2)]
            } else {
                s_mat[(q, (bp * m + c2) * m3 + b * m + c1)]
            }
        })
    };
    // tangent maps P_b (m² × n_b): vec_rowmajor(δX_b) = P_b δθ_b
    let nb = n_per_block(m);
    let tangents: Vec<Mat<f64>> = (0..3)
        .map(|b| {
            let lb = &l[b];
            let mut pm = Mat::<f64>::zeros(mm, nb);
            for j in 0..m {
                for k in 0..=j {
                    let col = tri(j, k);
                    let scale = if j == k && params.logged(b) {
                        lb[(j, j)]
                    } else {
                        1.0
                    };
                    for c in 0..m {
                        pm[(j * m + c, col)] += scale * lb[(c, k)];
                        pm[(c * m + j, col)] += scale * lb[(c, k)];
                        // the floor ε‖L‖²_F I
                        pm[(c * m + c, col)] += scale * 2.0 * CONDITION_FLOOR * lb[(j, k)];
                    }
                }
            }
            pm
        })
        .collect();
    let n = params.len();
    let mut nth = vec![0.0; n * n];
    for b in 0..3 {
        for bp in b..3 {
            let blk = nz_block(b, bp);
            let mut tmp = Mat::<f64>::zeros(mm, nb);
            matmul(
                tmp.as_mut(),
                Accum::Replace,
                blk.as_ref(),
                tangents[bp].as_ref(),
                1.0,
                par,
            );
            let mut out = Mat::<f64>::zeros(nb, nb);
            matmul(
                out.as_mut(),
                Accum::Replace,
                tangents[b].as_ref().transpose(),
                tmp.as_ref(),
                1.0,
                par,
            );
            for jc in 0..nb {
                for ir in 0..nb {
                    let (gi, gj) = (b * nb + ir, bp * nb + jc);
                    nth[gj * n + gi] = out[(ir, jc)];
                    nth[gi * n + gj] = out[(ir, jc)];
                }
            }
        }
    }
    // g_θ,b[(j,k)] = ((g_b + g_bᵀ) L_b)[j,k] (times L_jj for a logged diagonal)
    let mut gth = vec![0.0; n];
    for b in 0..3 {
        let lb = &l[b];
        for j in 0..m {
            for k in 0..=j {
                let trace_g: f64 = (0..m).map(|c| grad_z[(c, b * m + c)]).sum();
                let mut acc = 2.0 * CONDITION_FLOOR * trace_g * lb[(j, k)];
                for c in 0..m {
                    acc += (grad_z[(j, b * m + c)] + grad_z[(c, b * m + j)]) * lb[(c, k)];
                }
                if j == k && params.logged(b) {
                    acc *= lb[(j, j)];
                }
                gth[b * nb + tri(j, k)] = acc;
            }
        }
    }
    (nth, gth)
}

/// Solve (N + μ diag(N)) δ = −g by Cholesky; None if it is not positive definite.
fn damped_step(nth: &[f64], g: &[f64], mu: f64, floor: f64, par: Par) -> Option<Vec<f64>> {
    let n = g.len();
    let mut a = nth.to_vec();
    for i in 0..n {
        a[i * n + i] += mu * nth[i * n + i].max(floor);
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
    x.iter().all(|v| v.is_finite()).then_some(x)
}
