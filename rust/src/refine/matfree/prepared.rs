//! What the matrix-free step keeps of the current point ([`Prepared`]), and the
//! Gauss–Newton product N_θ v it applies from it: one GEMM over all columns for
//! δX x, per line y ↦ G y (or the two solves through the LU factors, with the weights
//! between them), one GEMM back, and the adjoint of the tangent map.

use crate::refine::line_solves::{solve_lines, solve_lines_adjoint};
use crate::refine::lines;
use crate::refine::parametrisation::{n_per_block, Params};
use faer::linalg::matmul::matmul;
use faer::{c32, c64, Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// What the matrix-free step keeps of the current point: the factors, the model's
/// responses and weights of every column, and per line the LU factors of D(ω) or the
/// Gram matrices G that the products apply.
pub(crate) struct Prepared {
    pub(crate) m: usize,
    pub(crate) p: usize,
    pub(crate) log_diagonal: bool,
    /// LU factors and row permutations of every line (from the evaluation)
    pub(crate) lu: Vec<c64>,
    pub(crate) perm: Vec<usize>,
    /// G = D⁻ᴴD⁻¹ of every line, row-major (scalar weights), instead of the LU factors
    pub(crate) use_gram: bool,
    pub(crate) gram: Vec<c64>,
    /// with the modal metric and scalar weights: G_Y = T⁻¹ G T⁻ᵀ of every line instead
    /// (row-major, single precision: [`super::sums::modal_sums_y`]), and T
    pub(crate) gram_y: Vec<c32>,
    pub(crate) gram_t: Option<Mat<f64>>,
    /// T of every column, row-major m×m (matrix weights only)
    pub(crate) tw: Option<Vec<f64>>,
    /// the metric W of every column at this point, row-major m×m (log-magnitude only)
    pub(crate) metric: Option<Vec<f64>>,
    /// model responses x of every column, and w² (1 with matrix weights)
    pub(crate) x: Vec<c64>,
    pub(crate) xw: Vec<f64>,
    /// scaled ω of every line
    pub(crate) w: Vec<f64>,
    /// Gram terms per line ([`lines::terms_per_line`])
    pub(crate) tpl: usize,
    /// the factors [L_M, L_C, L_K]
    pub(crate) l: [Mat<f64>; 3],
}

impl Prepared {
    /// Nothing prepared yet.
    pub(crate) fn empty() -> Self {
        Prepared {
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
            x: Vec::new(),
            xw: Vec::new(),
            w: Vec::new(),
            tpl: 1,
            l: [Mat::zeros(0, 0), Mat::zeros(0, 0), Mat::zeros(0, 0)],
        }
    }

    pub(crate) fn params(&self) -> Params {
        Params {
            m: self.m,
            log_diagonal: self.log_diagonal,
        }
    }

    /// N_θ v, the Gauss–Newton product at this point (the parametrisation's
    /// curvature is the caller's to add).
    pub(crate) fn product(&self, v: &[f64], par: Par) -> Vec<f64> {
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
        out
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
pub(crate) fn weight_twice(t: &[f64], v: &mut [c64], m: usize) {
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
