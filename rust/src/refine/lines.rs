//! Pieces of the Gauss–Newton step shared by the dense and the matrix-free solver:
//! the per-line Gram matrices G = Aᴴ A, the gradient, and the tangent map
//! P: δθ ↦ δX = δL Lᵀ + L δLᵀ + 2ε⟨L, δL⟩ I with its adjoint.

use super::input::Weights;
use super::line_solves::inverse_of;
use super::objective::{Evaluation, Problem};
use super::parametrisation::{n_per_block, tri, Params, CONDITION_FLOOR};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::BlockStructure;
use faer::traits::Conjugate;
use faer::{c64, Accum, Mat, MatMut, MatRef, Par};

/// Terms of the Gauss–Newton matrix per line: 1 with scalar weights (one G per
/// line, each column's w² goes with its response), p with matrix weights.
pub(crate) fn terms_per_line(pb: &Problem) -> usize {
    match pb.data.weights {
        Weights::Scalar(_) => 1,
        Weights::Matrix(_) | Weights::LogMagnitude(_) => pb.data.p,
    }
}

/// Weight of column `col`'s response in its term: w² with scalar weights, 1 with
/// matrix weights (T is inside G then).
pub(crate) fn response_weight(pb: &Problem, col: usize) -> f64 {
    match pb.data.weights {
        Weights::Scalar(w) => w[col] * w[col],
        Weights::Matrix(_) | Weights::LogMagnitude(_) => 1.0,
    }
}

/// Line `i` at the current point: G of each term, row-major m×m Hermitian, into `g`
/// (terms·m² values: D⁻ᴴD⁻¹ with scalar weights, (T D⁻¹)ᴴ(T D⁻¹) with matrix
/// weights, D⁻ᴴ W D⁻¹ with the log-magnitude metric W), and a_j = A_jᴴ r_j of each
/// load case into `a` (p·m values; D⁻ᴴ ρ_j for the log-magnitude objective), so that
/// the gradient in Z is −Re Σ a v̂ᴴ.
pub(crate) fn line_pieces(pb: &Problem, ev: &Evaluation, i: usize, g: &mut [c64], a: &mut [c64]) {
    let (p, m) = (pb.data.p, pb.data.m);
    let mm = m * m;
    let lu = MatRef::from_column_major_slice(&ev.lu[i * mm..(i + 1) * mm], m, m);
    let dinv = inverse_of(lu, &ev.perm[i * m..(i + 1) * m], m);
    let dm = MatRef::from_column_major_slice(&dinv, m, m);
    let zero = c64::new(0.0, 0.0);
    match pb.data.weights {
        Weights::Scalar(w) => {
            let gm = MatMut::from_row_major_slice_mut(&mut g[..mm], m, m);
            gram_into(gm, dm);
            for j in 0..p {
                let col = i * p + j;
                let w2 = w[col] * w[col];
                let (x, u) = (&ev.x[col * m..(col + 1) * m], &pb.u[col * m..(col + 1) * m]);
                for k in 0..m {
                    // a = w² D⁻ᴴ (x − u)
                    let mut acc = zero;
                    for row in 0..m {
                        acc += dinv[k * m + row].conj() * (x[row] - u[row]);
                    }
                    a[j * m + k] = acc * w2;
                }
            }
        }
        Weights::Matrix(t) => {
            let mut am = Mat::<c64>::zeros(m, m);
            for j in 0..p {
                let col = i * p + j;
                let tc = &t[col * mm..(col + 1) * mm];
                let tm = Mat::<c64>::from_fn(m, m, |r, c| c64::new(tc[r * m + c], 0.0));
                // A = T D⁻¹, G = Aᴴ A
                mul_into(am.as_mut(), tm.as_ref(), dm);
                let gm = MatMut::from_row_major_slice_mut(&mut g[j * mm..(j + 1) * mm], m, m);
                gram_into(gm, am.as_ref());
                let (x, u) = (&ev.x[col * m..(col + 1) * m], &pb.u[col * m..(col + 1) * m]);
                // r = T (x − u), a = Aᴴ r
                let r: Vec<c64> = (0..m)
                    .map(|row| (0..m).map(|q| (x[q] - u[q]) * tc[row * m + q]).sum())
                    .collect();
                for k in 0..m {
                    a[j * m + k] = (0..m).map(|row| am[(row, k)].conj() * r[row]).sum();
                }
            }
        }
        Weights::LogMagnitude(_) => {
            let terms = ev
                .log
                .as_ref()
                .expect("a log-magnitude evaluation carries its metric");
            let mut wd = Mat::<c64>::zeros(m, m);
            for j in 0..p {
                let col = i * p + j;
                let wc = &terms.metric[col * mm..(col + 1) * mm];
                let wm = Mat::<c64>::from_fn(m, m, |r, c| c64::new(wc[r * m + c], 0.0));
                // G = D⁻ᴴ (W D⁻¹)
                mul_into(wd.as_mut(), wm.as_ref(), dm);
                let gm = MatMut::from_row_major_slice_mut(&mut g[j * mm..(j + 1) * mm], m, m);
                mul_into(gm, dm.adjoint(), wd.as_ref());
                let rho = &terms.rho[col * m..(col + 1) * m];
                for k in 0..m {
                    a[j * m + k] = (0..m).map(|row| dinv[k * m + row].conj() * rho[row]).sum();
                }
            }
        }
    }
}

/// out = aᴴ a (Hermitian; double or single precision): the lower triangle by one
/// triangular product (half the flops of a full one), the upper filled by conjugation.
pub(crate) fn gram_into<T: faer::traits::ComplexField<Canonical = T> + Copy>(
    mut out: MatMut<T>,
    a: MatRef<T>,
) {
    faer::linalg::matmul::triangular::matmul(
        out.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        a.adjoint(),
        BlockStructure::Rectangular,
        a,
        BlockStructure::Rectangular,
        T::one_impl(),
        Par::Seq,
    );
    let m = out.nrows();
    for j in 0..m {
        for i in 0..j {
            out[(i, j)] = T::conj_impl(&out[(j, i)]);
        }
    }
}

/// out = a b (one thread: the callers run per line in parallel).
fn mul_into<A, B>(out: MatMut<c64>, a: MatRef<A>, b: MatRef<B>)
where
    A: Conjugate<Canonical = c64>,
    B: Conjugate<Canonical = c64>,
{
    matmul(out, Accum::Replace, a, b, c64::new(1.0, 0.0), Par::Seq);
}

/// v̂ = [−ω² x; iω x; x] of one column.
#[inline]
pub(crate) fn vhat(w: f64, x: &[c64], out: &mut [c64]) {
    let m = x.len();
    for q in 0..m {
        out[q] = x[q] * (-w * w);
        out[m + q] = x[q] * c64::new(0.0, w);
        out[2 * m + q] = x[q];
    }
}

/// Gradient in Z (m × 3m, row-major entries Z[row, c]): −Re Σ_cols a v̂ᴴ, by one GEMM.
pub(crate) fn gradient_z(pb: &Problem, ev: &Evaluation, a: &[c64], par: Par) -> Mat<f64> {
    let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
    let n = s * p;
    // [Re a | Im a] (m × 2n) and [Re v̂ | Im v̂] (3m × 2n)
    let mut left = Mat::<f64>::zeros(m, 2 * n);
    let mut right = Mat::<f64>::zeros(3 * m, 2 * n);
    let mut v = vec![c64::new(0.0, 0.0); 3 * m];
    for col in 0..n {
        vhat(pb.w[col / p], &ev.x[col * m..(col + 1) * m], &mut v);
        for k in 0..m {
            left[(k, col)] = a[col * m + k].re;
            left[(k, n + col)] = a[col * m + k].im;
        }
        for c in 0..3 * m {
            right[(c, col)] = v[c].re;
            right[(c, n + col)] = v[c].im;
        }
    }
    let mut gz = Mat::<f64>::zeros(m, 3 * m);
    matmul(
        gz.as_mut(),
        Accum::Replace,
        left.as_ref(),
        right.as_ref().transpose(),
        -1.0,
        par,
    );
    gz
}

/// Scale of θ_(j,k) in δL: L_jj for a logged diagonal, else 1.
#[inline]
pub(crate) fn theta_scale(params: &Params, l: &Mat<f64>, j: usize, k: usize) -> f64 {
    if j == k && params.log_diagonal {
        l[(j, j)]
    } else {
        1.0
    }
}

/// Adjoint of the tangent map on block b: for a dual G (m×m, entries of δX_b) the
/// vector Pᵀ G: ((G + Gᵀ) L)_jk + 2ε tr(G) L_jk, times L_jj on a logged diagonal.
pub(crate) fn tangent_adjoint(
    params: &Params,
    l: &Mat<f64>,
    g: impl Fn(usize, usize) -> f64,
    out: &mut [f64],
) {
    let m = params.m;
    let trace: f64 = (0..m).map(|c| g(c, c)).sum();
    let sym = Mat::from_fn(m, m, |i, j| g(i, j) + g(j, i));
    for j in 0..m {
        for k in 0..=j {
            let mut acc = 2.0 * CONDITION_FLOOR * trace * l[(j, k)];
            for c in k..m {
                acc += sym[(j, c)] * l[(c, k)];
            }
            out[tri(j, k)] = acc * theta_scale(params, l, j, k);
        }
    }
}

/// The tangent map on block b: δX = δL Lᵀ + L δLᵀ + 2ε⟨L, δL⟩ I for the block's
/// part of δθ (symmetric m×m).
#[cfg_attr(not(test), allow(dead_code))] // the matrix-free step uses it next
pub(crate) fn tangent(params: &Params, l: &Mat<f64>, dth: &[f64]) -> Mat<f64> {
    let m = params.m;
    let dl = Mat::from_fn(m, m, |j, k| {
        if k > j {
            0.0
        } else {
            dth[tri(j, k)] * theta_scale(params, l, j, k)
        }
    });
    let inner: f64 = (0..m)
        .map(|j| (0..=j).map(|k| l[(j, k)] * dl[(j, k)]).sum::<f64>())
        .sum();
    let mut x = Mat::<f64>::zeros(m, m);
    matmul(
        x.as_mut(),
        Accum::Replace,
        dl.as_ref(),
        l.transpose(),
        1.0,
        Par::Seq,
    );
    Mat::from_fn(m, m, |i, j| {
        x[(i, j)]
            + x[(j, i)]
            + if i == j {
                2.0 * CONDITION_FLOOR * inner
            } else {
                0.0
            }
    })
}

/// θ-gradient g_θ = Pᵀ g_Z from the gradient in Z (m × 3m).
pub(crate) fn theta_gradient(params: &Params, l: &[Mat<f64>; 3], gz: &Mat<f64>) -> Vec<f64> {
    let (m, nb) = (params.m, n_per_block(params.m));
    let mut out = vec![0.0; 3 * nb];
    for b in 0..3 {
        tangent_adjoint(
            params,
            &l[b],
            |r, c| gz[(r, b * m + c)],
            &mut out[b * nb..(b + 1) * nb],
        );
    }
    out
}

/// Jᵀ applied to the weighted change `e` of the responses (layout of `ev.x`) at the
/// current point: the gradient's formula with e in place of x − u, so that
/// Jᵀ r(x − u) is the gradient itself. None for the log-magnitude objective, whose
/// residual is not linear in the responses.
pub(crate) fn jt_of_responses(
    pb: &Problem,
    params: &Params,
    l: &[Mat<f64>; 3],
    ev: &Evaluation,
    e: &[c64],
    par: Par,
) -> Option<Vec<f64>> {
    use rayon::prelude::*;
    if matches!(pb.data.weights, Weights::LogMagnitude(_)) {
        return None;
    }
    let (s, p, m) = (pb.data.s(), pb.data.p, pb.data.m);
    let mm = m * m;
    let zero = c64::new(0.0, 0.0);
    let mut a_all = vec![zero; s * p * m];
    a_all.par_chunks_mut(p * m).enumerate().for_each(|(i, a)| {
        let lu = MatRef::from_column_major_slice(&ev.lu[i * mm..(i + 1) * mm], m, m);
        let dinv = inverse_of(lu, &ev.perm[i * m..(i + 1) * m], m);
        let mut weighted = vec![zero; m];
        for j in 0..p {
            let col = i * p + j;
            let ec = &e[col * m..(col + 1) * m];
            // w² e with scalar weights, Tᵀ T e with matrix weights
            match pb.data.weights {
                Weights::Scalar(w) => {
                    let w2 = w[col] * w[col];
                    for (out, v) in weighted.iter_mut().zip(ec) {
                        *out = v * w2;
                    }
                }
                Weights::Matrix(t) => {
                    let tc = &t[col * mm..(col + 1) * mm];
                    let te: Vec<c64> = (0..m)
                        .map(|row| (0..m).map(|q| ec[q] * tc[row * m + q]).sum())
                        .collect();
                    for (k, out) in weighted.iter_mut().enumerate() {
                        *out = (0..m).map(|row| te[row] * tc[row * m + k]).sum();
                    }
                }
                Weights::LogMagnitude(_) => unreachable!("refused above"),
            }
            // a = D⁻ᴴ (the weighted change), as in line_pieces
            for k in 0..m {
                a[j * m + k] = (0..m)
                    .map(|row| dinv[k * m + row].conj() * weighted[row])
                    .sum();
            }
        }
    });
    let gz = gradient_z(pb, ev, &a_all, par);
    Some(theta_gradient(params, l, &gz))
}
