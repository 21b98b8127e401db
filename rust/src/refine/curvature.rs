//! The curvature of the parametrisation X = L Lᵀ, added to the Gauss–Newton matrix.
//!
//! Gauss–Newton drops every second derivative, also those of the map θ → X. Where
//! the output-error optimum sits on the boundary of the cone X ⪰ 0 (C of noisy data
//! wants a negative eigenvalue in the out-of-band modes it cannot see), L Lᵀ is
//! degenerate there: JᵀJ vanishes along the directions that shrink L, the gradient
//! does not, and Levenberg–Marquardt crawls toward the boundary in short, often
//! rejected steps (m = 100, 2000 lines: 200 steps). The dropped term is cheap — it
//! needs only the gradient in X, Γ = ½(∂c/∂X) per block:
//!
//! ```text
//!     second-order part of ½c(θ + δ) = tr(Γ δL δLᵀ) + Σ_j (2ΓL)_jj L_jj δθ_jj² / 2
//! ```
//!
//! (δL = δθ on the strict lower triangle, L_jj δθ_jj on a logged diagonal; the
//! floor's O(ε) terms are left out). With S = 2Γ = G + Gᵀ (G = `gz`, the Z-gradient of
//! [`super::lines::gradient_z`]) this is ½δᵀHδ with
//!
//! ```text
//!     (Hδ)_jk = s_jk (S δL)_jk + [j = k] (S L)_jj L_jj δθ_jj,    s_jk = ∂L_jk/∂θ_jk.
//! ```
//!
//! H is indefinite away from the optimum (S is); the step uses the positive part:
//! S₊ (negative eigenvalues set to 0) and max((S L)_jj L_jj, 0) — positive
//! semidefinite, and equal to H where the constrained optimum's conditions hold
//! (S ⪰ 0 there: ∂c/∂X ⪰ 0 on the cone's boundary). |S| instead (negative
//! eigenvalues flipped) was measured worse: on noise-free data from a start 2 % off
//! (chain m = 5) the matrix-free step stalled at 1.5e-3 where S₊ converges in 18
//! steps. O(m³) per block to form and per product — nothing next to the s·m² of a
//! Gauss–Newton product. Measured (NumPy prototype, chain m = 30, 400 lines, 0.1 %
//! noise): the cost Gauss–Newton reaches in 40 steps this reaches in 15.
//! The refinement leaves it out right after a fast fall of the cost
//! ([`super::CURVATURE_SWITCH`]).

use super::lines::theta_scale;
use super::parametrisation::{n_per_block, tri, Params};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par, Side};
use rayon::prelude::*;

/// S₊ of each block and the logged-diagonal terms at one point.
#[derive(Clone)]
pub(crate) struct Curvature {
    /// S_b₊ (m × m) per block
    pos_s: [Mat<f64>; 3],
    /// max((S L)_jj L_jj, 0) per block and j (zeros without a logged diagonal)
    diag_terms: [Vec<f64>; 3],
    /// s_jk per block, lower triangle order
    scale: [Vec<f64>; 3],
}

impl Curvature {
    /// From the factors `l` and the Z-gradient `gz` (m × 3m) at the point; None if an
    /// eigendecomposition fails (the step then goes without the term).
    pub(crate) fn new(params: &Params, l: &[Mat<f64>; 3], gz: &Mat<f64>) -> Option<Curvature> {
        let m = params.m;
        let mut pos_s = [Mat::zeros(0, 0), Mat::zeros(0, 0), Mat::zeros(0, 0)];
        let mut diag_terms = [Vec::new(), Vec::new(), Vec::new()];
        let mut scale = [Vec::new(), Vec::new(), Vec::new()];
        for b in 0..3 {
            let s = Mat::from_fn(m, m, |i, j| gz[(i, b * m + j)] + gz[(j, b * m + i)]);
            let evd = s.self_adjoint_eigen(Side::Lower).ok()?;
            let (q, d) = (evd.U(), evd.S().column_vector());
            let qd = Mat::from_fn(m, m, |i, k| q[(i, k)] * d[k].max(0.0));
            let mut a = Mat::zeros(m, m);
            matmul(
                a.as_mut(),
                Accum::Replace,
                qd.as_ref(),
                q.transpose(),
                1.0,
                Par::Seq,
            );
            pos_s[b] = Mat::from_fn(m, m, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
            let lb = &l[b];
            diag_terms[b] = (0..m)
                .map(|j| {
                    if params.log_diagonal {
                        let sl: f64 = (j..m).map(|c| s[(j, c)] * lb[(c, j)]).sum();
                        (sl * lb[(j, j)]).max(0.0)
                    } else {
                        0.0
                    }
                })
                .collect();
            let mut sc = vec![0.0; n_per_block(m)];
            for j in 0..m {
                for k in 0..=j {
                    sc[tri(j, k)] = theta_scale(params, lb, j, k);
                }
            }
            scale[b] = sc;
        }
        if pos_s.iter().any(|a| !(0..m).all(|i| a[(i, i)].is_finite())) {
            return None;
        }
        Some(Curvature {
            pos_s,
            diag_terms,
            scale,
        })
    }

    fn m(&self) -> usize {
        self.pos_s[0].nrows()
    }

    /// out += H v.
    pub(crate) fn apply_add(&self, v: &[f64], out: &mut [f64]) {
        let m = self.m();
        let nb = n_per_block(m);
        // the three blocks side by side (O(m³) each; the rest of the step waits for them)
        out.par_chunks_mut(nb).enumerate().for_each(|(b, ob)| {
            let (vb, sc) = (&v[b * nb..(b + 1) * nb], &self.scale[b]);
            let dl = Mat::from_fn(m, m, |j, k| {
                if k > j {
                    0.0
                } else {
                    vb[tri(j, k)] * sc[tri(j, k)]
                }
            });
            let mut w = Mat::zeros(m, m);
            matmul(
                w.as_mut(),
                Accum::Replace,
                self.pos_s[b].as_ref(),
                dl.as_ref(),
                1.0,
                Par::Seq,
            );
            for j in 0..m {
                for k in 0..=j {
                    ob[tri(j, k)] += sc[tri(j, k)] * w[(j, k)];
                }
                ob[tri(j, j)] += self.diag_terms[b][j] * vb[tri(j, j)];
            }
        });
    }

    /// diag(H), block after block.
    pub(crate) fn diagonal(&self) -> Vec<f64> {
        let m = self.m();
        let mut d = vec![0.0; 3 * n_per_block(m)];
        let nb = n_per_block(m);
        for b in 0..3 {
            for j in 0..m {
                for k in 0..=j {
                    let s = self.scale[b][tri(j, k)];
                    d[b * nb + tri(j, k)] = s * s * self.pos_s[b][(j, j)]
                        + if j == k { self.diag_terms[b][j] } else { 0.0 };
                }
            }
        }
        d
    }

    /// nth += H, nth column-major n × n with n = 3 m(m+1)/2.
    pub(crate) fn dense_add(&self, nth: &mut [f64]) {
        let m = self.m();
        let nb = n_per_block(m);
        let n = 3 * nb;
        for b in 0..3 {
            let (a, sc) = (&self.pos_s[b], &self.scale[b]);
            for k in 0..m {
                for j in k..m {
                    let r = b * nb + tri(j, k);
                    for jp in k..m {
                        let c = b * nb + tri(jp, k);
                        nth[c * n + r] += sc[tri(j, k)] * a[(j, jp)] * sc[tri(jp, k)];
                    }
                }
            }
            for j in 0..m {
                let r = b * nb + tri(j, j);
                nth[r * n + r] += self.diag_terms[b][j];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// H of the module note checked against the definition: ½c's second-order part
    /// for c(X) = 2 tr(Γ X) linear in X (so that only the parametrisation curves it),
    /// by finite differences of c along θ, with S ⪰ 0 (S₊ = S then).
    #[test]
    fn curvature_is_the_second_derivative_of_a_linear_cost_through_the_factors() {
        let m = 4;
        for log_diagonal in [false, true] {
            let params = Params { m, log_diagonal };
            let l: [Mat<f64>; 3] = [0, 1, 2].map(|b| {
                Mat::from_fn(m, m, |i, j| {
                    if j > i {
                        0.0
                    } else if i == j {
                        1.0 + 0.3 * (b + i) as f64
                    } else {
                        0.1 * ((i * 7 + j * 3 + b) % 5) as f64 - 0.2
                    }
                })
            });
            // Γ positive definite, gz = Γ (then S = 2Γ)
            let gamma: [Mat<f64>; 3] = [0, 1, 2].map(|b| {
                Mat::from_fn(m, m, |i, j| {
                    (if i == j { 2.0 + b as f64 } else { 0.0 }) + 0.1 / (1.0 + (i + j) as f64)
                })
            });
            let gz = Mat::from_fn(m, 3 * m, |i, c| gamma[c / m][(i, c % m)]);
            let cv = Curvature::new(&params, &l, &gz).unwrap();
            let theta = params.pack(&l);
            let half_cost = |th: &[f64]| -> f64 {
                let lf = params.unpack(th);
                (0..3)
                    .map(|b| {
                        let x = crate::refine::parametrisation::gram_lower(&lf[b]);
                        (0..m)
                            .flat_map(|i| (0..m).map(move |j| (i, j)))
                            .map(|(i, j)| gamma[b][(i, j)] * x[(i, j)])
                            .sum::<f64>()
                    })
                    .sum()
            };
            let n = theta.len();
            let v: Vec<f64> = (0..n).map(|q| ((q * 37 % 11) as f64 - 5.0) / 7.0).collect();
            let h = 1e-4;
            let at = |t: f64| {
                let th: Vec<f64> = theta.iter().zip(&v).map(|(a, b)| a + t * b).collect();
                half_cost(&th)
            };
            // d²/dt² ½c(θ + t v) = vᵀ H v
            let fd = (at(h) - 2.0 * at(0.0) + at(-h)) / (h * h);
            let mut hv = vec![0.0; n];
            cv.apply_add(&v, &mut hv);
            let vhv: f64 = v.iter().zip(&hv).map(|(a, b)| a * b).sum();
            assert!(
                (vhv - fd).abs() <= 1e-5 * fd.abs(),
                "log_diagonal {log_diagonal}: vᵀHv {vhv} against finite differences {fd}"
            );
            // the diagonal and the dense matrix are the same H
            let mut dense = vec![0.0; n * n];
            cv.dense_add(&mut dense);
            let diag = cv.diagonal();
            for q in 0..n {
                let mut e = vec![0.0; n];
                e[q] = 1.0;
                let mut col = vec![0.0; n];
                cv.apply_add(&e, &mut col);
                assert!((col[q] - diag[q]).abs() <= 1e-12 * diag[q].abs().max(1.0));
                for r in 0..n {
                    assert!((col[r] - dense[q * n + r]).abs() <= 1e-12 * col[r].abs().max(1.0));
                }
            }
        }
    }
}
