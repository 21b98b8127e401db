//! The sums over lines that the matrix-free step forms once per point, O(s·m³) flops
//! and O(m²) memory per thread: the 3×3 blocks of N_θ coupling M, C, K at each
//! unknown (its diagonal, the LM damping and the block-Jacobi preconditioner:
//! [`diagonal`]), or the sums of the modal metric ([`modal_sums`], [`modal_sums_y`]).

use super::prepared::Prepared;
use crate::refine::line_solves::solve_lines_single;
use crate::refine::lines::{self, line_pieces};
use crate::refine::modal::{add_line_sums, add_sums_y, ModalMetric};
use crate::refine::objective::{Evaluation, Problem};
use crate::refine::parametrisation::{n_per_block, tri};
use faer::linalg::matmul::matmul;
use faer::{c32, c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Σ over lines of `term(i, tl, G, out)` for every Gram term G of every line
/// (`width` sums; G formed, used, and kept in `gram` when it is not empty, else
/// dropped: O(s·m³) flops, O(m²) memory per thread).
fn line_sums(
    prep: &Prepared,
    pb: &Problem,
    ev: &Evaluation,
    gram: &mut [c64],
    width: usize,
    term: impl Fn(usize, usize, &[c64], &mut [f64]) + Sync,
) -> Vec<f64> {
    let (m, p, tpl) = (prep.m, prep.p, prep.tpl);
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
        (0..prep.w.len())
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

/// The sums of the modal metric ([`crate::refine::modal`]): 3 per modal pair (j, k).
pub(crate) fn modal_sums(
    prep: &Prepared,
    pb: &Problem,
    ev: &Evaluation,
    gram: &mut [c64],
    modal: &ModalMetric,
) -> Vec<f64> {
    let (m, p, tpl) = (prep.m, prep.p, prep.tpl);
    let ti = modal.ti();
    line_sums(prep, pb, ev, gram, 3 * n_per_block(m), |i, tl, g, out| {
        let cols: Vec<(&[c64], f64)> = (0..p)
            .filter(|&j| tpl == 1 || j == tl)
            .map(|j| {
                let col = i * p + j;
                (&prep.x[col * m..(col + 1) * m], prep.xw[col])
            })
            .collect();
        add_line_sums(ti, g, &cols, prep.w[i], out);
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
pub(crate) fn modal_sums_y(
    prep: &Prepared,
    ev: &Evaluation,
    gram: &mut [c32],
    modal: &ModalMetric,
) -> Vec<f64> {
    let (m, p) = (prep.m, prep.p);
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
                        (&prep.x[col * m..(col + 1) * m], prep.xw[col])
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
                    prep.w[i],
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
pub(crate) fn diagonal(
    prep: &Prepared,
    pb: &Problem,
    ev: &Evaluation,
    gram: &mut [c64],
) -> Vec<f64> {
    let m = prep.m;
    let nb = n_per_block(m);
    // [L_M L_C L_K] (m × 3m)
    let l3 = Mat::<f64>::from_fn(m, 3 * m, |r, c| prep.l[c / m][(r, c % m)]);
    let mut d = line_sums(prep, pb, ev, gram, 6 * nb, |i, tl, g, out| {
        line_diagonal(prep, i, tl, g, &l3, out)
    });
    // the log scales s_b,jk s_b',jk
    let sc = |b: usize, j: usize, k: usize| lines::theta_scale(&prep.params(), &prep.l[b], j, k);
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
fn line_diagonal(prep: &Prepared, i: usize, tl: usize, g: &[c64], l3: &Mat<f64>, out: &mut [f64]) {
    let (m, p, tpl) = (prep.m, prep.p, prep.tpl);
    let nb = n_per_block(m);
    let om = prep.w[i];
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
            let l = &prep.l[b];
            (0..m)
                .map(|k| (k..m).map(|j| glc(j, bp, k) * l[(j, k)]).sum())
                .collect()
        })
        .collect();
    for &col in &cols {
        let x = &prep.x[col * m..(col + 1) * m];
        let a: Vec<Vec<c64>> = (0..3)
            .map(|b| {
                let l = &prep.l[b];
                (0..m)
                    .map(|k| (k..m).map(|c| x[c] * l[(c, k)]).sum())
                    .collect()
            })
            .collect();
        for (q, &(b, bp)) in PAIRS.iter().enumerate() {
            let sc = phi[b].conj() * phi[bp] * prep.xw[col];
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

/// Block pairs (b, b') of the 3×3 blocks of N_θ kept per unknown (j, k): the
/// diagonal first, then M–C, M–K, C–K.
pub(crate) const PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
