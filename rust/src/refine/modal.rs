//! The modal metric of the matrix-free step: LM damping and CG preconditioner.
//!
//! In the modal coordinates of the current model (T: the M-orthonormal undamped
//! modes, TᵀMT = I, TᵀKT = Ω²) a change δY = Tᵀ δX T of M, C or K moves line i's
//! response by δx = −φ_b H (δY y), H = D⁻¹T⁻ᵀ, y = T⁻¹x. Near a resonance D is
//! nearly diagonal in these coordinates, so the Gauss–Newton matrix in Y is nearly
//! block diagonal: one 3×3 block per modal pair (j, k), coupling M, C, K,
//!
//! ```text
//!     B_jk = Σ β_jk [ω⁴ 0 −ω²; 0 ω² 0; −ω² 0 1],
//!     β_jk = w² (|y_k|² G_jj + |y_j|² G_kk + 2 Re(ȳ_k y_j G_jk))   (j > k),
//!     β_jj = w² |y_j|² G_jj,       G = Hᴴ H = T⁻¹ D⁻ᴴ D⁻¹ T⁻ᵀ  (per line and column)
//! ```
//!
//! (the M–C and C–K couplings Re(φ̄_b φ_b') vanish). Pulled back through the
//! factors, B_θ = P̃ᵀ 𝒯ᵀ B 𝒯 P̃ (P̃: δθ ↦ δL Lᵀ + L δLᵀ, 𝒯: δX ↦ Tᵀ δX T) is
//! symmetric positive definite, and B_θ⁻¹ = P̃⁻¹ 𝒯⁻¹ B⁻¹ 𝒯⁻ᵀ P̃⁻ᵀ costs O(m³):
//! P̃⁻¹ δX = L Φ(L⁻¹ δX L⁻ᵀ), Φ = the strict lower triangle plus half the diagonal.
//!
//! With [`super::OeOptions::modal_metric`] the matrix-free step uses it as the
//! preconditioner of (N + μB_θ) δ = −g and as the LM damping itself: the damping is
//! then proportional in every direction instead of μ·diag(N), which on a badly
//! conditioned N damps the weak directions far more than the strong ones and makes LM
//! crawl — and takes the step in X (`matfree/`). Measured in a NumPy prototype
//! (chain, m = 40, 1000 lines, 0.1 % noise): CG iterations to a relative residual of
//! 1e-2 / 1e-4: 29 / 55 against 187 / 896 with the 3×3 blocks of N_θ (and diag
//! damping); with exact solves LM converged in 13 steps (m = 20) where diag damping
//! was still crawling at 22. The whole refinement: benches/README.md, `bench_refine.py --parts
//! metric`.

use super::lines::theta_scale;
use super::parametrisation::{n_per_block, tri, Params};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::BlockStructure;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{c64, Accum, Mat, MatRef, Par, Side};
use rayon::prelude::*;

/// The modal metric at one point.
pub(crate) struct ModalMetric {
    m: usize,
    log_diagonal: bool,
    /// the factors L_b
    l: [Mat<f64>; 3],
    /// T (modes, columns) and T⁻¹ = Tᵀ M
    t: Mat<f64>,
    ti: Mat<f64>,
    /// A_b = L_b⁻¹ T⁻ᵀ: δY ↦ L⁻¹ δX L⁻ᵀ = A δY Aᵀ in one congruence
    a: [Mat<f64>; 3],
    /// Σβ, Σω²β, Σω⁴β per modal pair (j, k), index tri(j, k)
    sums: Vec<[f64; 3]>,
}

/// Inverse of a lower-triangular matrix; None when it is singular.
fn lower_inverse(l: &Mat<f64>) -> Option<Mat<f64>> {
    let m = l.nrows();
    let top = (0..m).map(|j| l[(j, j)].abs()).fold(0.0, f64::max);
    if !(0..m).all(|j| l[(j, j)].abs() > 1e-150 * top.max(f64::MIN_POSITIVE)) {
        return None;
    }
    let mut inv = Mat::<f64>::identity(m, m);
    solve_lower_triangular_in_place(l.as_ref(), inv.as_mut(), Par::Seq);
    let finite = inv.col_iter().all(|c| c.iter().all(|v| v.is_finite()));
    finite.then_some(inv)
}

fn mul(a: MatRef<f64>, b: MatRef<f64>) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, 1.0, Par::Seq);
    out
}

/// a b aᵀ
fn congruence(a: MatRef<f64>, b: MatRef<f64>) -> Mat<f64> {
    mul(mul(a, b).as_ref(), a.transpose())
}

/// The lower triangle of a b aᵀ (b symmetric; the strict upper triangle left 0): the
/// second product by half.
fn lower_congruence(a: MatRef<f64>, b: MatRef<f64>) -> Mat<f64> {
    let ab = mul(a, b);
    let mut out = Mat::<f64>::zeros(a.nrows(), a.nrows());
    faer::linalg::matmul::triangular::matmul(
        out.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        ab.as_ref(),
        BlockStructure::Rectangular,
        a.transpose(),
        BlockStructure::Rectangular,
        1.0,
        Par::Seq,
    );
    out
}

impl ModalMetric {
    /// The modes of the current model and the factors' inverses; None when a factor
    /// is numerically singular (the caller then uses the diagonal of N instead).
    pub(crate) fn new(params: &Params, l: &[Mat<f64>; 3]) -> Option<ModalMetric> {
        let m = params.m;
        let li = [
            lower_inverse(&l[0])?,
            lower_inverse(&l[1])?,
            lower_inverse(&l[2])?,
        ];
        // K̂ = L_M⁻¹ K L_M⁻ᵀ = (L_M⁻¹ L_K)(L_M⁻¹ L_K)ᵀ = Q Ω² Qᵀ; T = L_M⁻ᵀ Q
        let a = mul(li[0].as_ref(), l[2].as_ref());
        let khat = mul(a.as_ref(), a.transpose());
        let evd = khat.self_adjoint_eigen(Side::Lower).ok()?;
        let q = evd.U();
        let t = mul(li[0].transpose(), q);
        let ti = mul(q.transpose(), l[0].transpose());
        let finite = |x: &Mat<f64>| x.col_iter().all(|c| c.iter().all(|v| v.is_finite()));
        if !finite(&t) || !finite(&ti) {
            return None;
        }
        let a = [0, 1, 2].map(|b| mul(li[b].as_ref(), ti.transpose()));
        Some(ModalMetric {
            m,
            log_diagonal: params.log_diagonal,
            l: l.clone(),
            t,
            ti,
            a,
            sums: vec![[0.0; 3]; n_per_block(m)],
        })
    }

    /// T (the products in the modal coordinates).
    pub(crate) fn t(&self) -> MatRef<'_, f64> {
        self.t.as_ref()
    }

    /// T⁻¹ (for the per-line sums).
    pub(crate) fn ti(&self) -> MatRef<'_, f64> {
        self.ti.as_ref()
    }

    pub(crate) fn set_sums(&mut self, flat: &[f64]) {
        for (s, c) in self.sums.iter_mut().zip(flat.chunks(3)) {
            *s = [c[0], c[1], c[2]];
        }
    }

    fn scale(&self, b: usize, j: usize, k: usize) -> f64 {
        let params = Params {
            m: self.m,
            log_diagonal: self.log_diagonal,
        };
        theta_scale(&params, &self.l[b], j, k)
    }

    /// The 3×3 block at pair t, as its M–K 2×2 part [a, c; c, d] and its C entry.
    fn block(&self, t: usize) -> ([f64; 3], f64) {
        let [s0, s2, s4] = self.sums[t];
        ([s4, -s2, s0], s2)
    }

    /// Block b of a θ-vector as a lower-triangular m×m matrix, each entry combined with
    /// its θ-scale s_jk by `with` (δL = s·δθ; a dual divides).
    fn lower_of(&self, b: usize, v: &[f64], with: impl Fn(f64, f64) -> f64) -> Mat<f64> {
        let (m, nb) = (self.m, n_per_block(self.m));
        Mat::from_fn(m, m, |j, k| {
            if k > j {
                0.0
            } else {
                with(v[b * nb + tri(j, k)], self.scale(b, j, k))
            }
        })
    }

    /// B_θ v.
    pub(crate) fn apply(&self, v: &[f64]) -> Vec<f64> {
        let (m, nb) = (self.m, n_per_block(self.m));
        // δY_b = Tᵀ (δL Lᵀ + L δLᵀ) T
        let dy: Vec<Mat<f64>> = (0..3)
            .into_par_iter()
            .map(|b| {
                let dl = self.lower_of(b, v, |x, s| x * s);
                let x = mul(dl.as_ref(), self.l[b].transpose());
                let dx = Mat::from_fn(m, m, |i, j| x[(i, j)] + x[(j, i)]);
                congruence(self.t.transpose(), dx.as_ref())
            })
            .collect();
        let mut out = vec![0.0; 3 * nb];
        let mut gy = [0, 1, 2].map(|_| Mat::<f64>::zeros(m, m));
        for j in 0..m {
            for k in 0..=j {
                let t = tri(j, k);
                let ([a, c, d], e) = self.block(t);
                let (ym, yc, yk) = (dy[0][(j, k)], dy[1][(j, k)], dy[2][(j, k)]);
                gy[0][(j, k)] = a * ym + c * yk;
                gy[1][(j, k)] = e * yc;
                gy[2][(j, k)] = c * ym + d * yk;
            }
        }
        out.par_chunks_mut(nb).enumerate().for_each(|(b, ob)| {
            // G_X = T G_Y Tᵀ; (B_θ v)_jk = ((G_X + G_Xᵀ) L)_jk s_jk
            let gx = congruence(self.t.as_ref(), gy[b].as_ref());
            let sym = Mat::from_fn(m, m, |i, j| gx[(i, j)] + gx[(j, i)]);
            let r = mul(sym.as_ref(), self.l[b].as_ref());
            for j in 0..m {
                for k in 0..=j {
                    ob[tri(j, k)] = r[(j, k)] * self.scale(b, j, k);
                }
            }
        });
        out
    }

    /// B_θ⁻¹ r / (1 + shift): the preconditioner of N + μB_θ (shift = μ).
    pub(crate) fn solve(&self, r: &[f64], shift: f64) -> Vec<f64> {
        self.theta_of_y(&self.block_solve(&self.dual_y(r), shift))
    }

    /// Rᵀ r: a θ-dual r as the dual in the modal coordinates Y (R: δY ↦ δθ, so that
    /// B_θ = R⁻ᵀ B_Y R⁻¹), flat, pair t of block b at b·nb + t: c_jk = H_jk + H_kj
    /// (j > k), H_jj, with H = T⁻¹ L⁻ᵀ Φ*(Lᵀ R) L⁻¹ T⁻ᵀ.
    pub(crate) fn dual_y(&self, r: &[f64]) -> Vec<f64> {
        let (m, nb) = (self.m, n_per_block(self.m));
        let c: Vec<Mat<f64>> = (0..3)
            .into_par_iter()
            .map(|b| {
                // H = Φ*(Lᵀ R); c_jk + c_kj of c = Aᵀ H A is the lower triangle of
                // Aᵀ (H + Hᵀ) A (c_jj half its diagonal)
                let rr = self.lower_of(b, r, |x, s| x / s);
                let lr = mul(self.l[b].transpose(), rr.as_ref());
                let h = half_lower(&lr);
                let sym = Mat::from_fn(m, m, |i, j| h[(i, j)] + h[(j, i)]);
                lower_congruence(self.a[b].transpose(), sym.as_ref())
            })
            .collect();
        let mut out = vec![0.0; 3 * nb];
        for (b, cb) in c.iter().enumerate() {
            for j in 0..m {
                for k in 0..=j {
                    out[b * nb + tri(j, k)] = if j == k { 0.5 * cb[(j, j)] } else { cb[(j, k)] };
                }
            }
        }
        out
    }

    /// B_Y y on flat modal vectors (the 3×3 block of each pair).
    pub(crate) fn block_apply(&self, y: &[f64]) -> Vec<f64> {
        let nb = n_per_block(self.m);
        let mut out = vec![0.0; 3 * nb];
        for t in 0..nb {
            let ([a, c, d], e) = self.block(t);
            let (ym, yc, yk) = (y[t], y[nb + t], y[2 * nb + t]);
            out[t] = a * ym + c * yk;
            out[nb + t] = e * yc;
            out[2 * nb + t] = c * ym + d * yk;
        }
        out
    }

    /// B_Y⁻¹ c / (1 + shift) on flat modal vectors (a pair whose M–K block is
    /// numerically singular by its diagonal, a zero entry by 0).
    pub(crate) fn block_solve(&self, c: &[f64], shift: f64) -> Vec<f64> {
        let nb = n_per_block(self.m);
        let f = 1.0 / (1.0 + shift);
        let mut out = vec![0.0; 3 * nb];
        for t in 0..nb {
            let ([a, cc, d], e) = self.block(t);
            let det = a * d - cc * cc;
            let (cm, ck) = (c[t], c[2 * nb + t]);
            let (ym, yk) = if det > 1e-14 * (a * d).abs() && det.is_finite() {
                ((d * cm - cc * ck) / det, (a * ck - cc * cm) / det)
            } else {
                (safe_div(cm, a), safe_div(ck, d))
            };
            out[t] = f * ym;
            out[nb + t] = f * safe_div(c[nb + t], e);
            out[2 * nb + t] = f * yk;
        }
        out
    }

    /// R y: flat modal coordinates to θ.
    pub(crate) fn theta_of_y(&self, y: &[f64]) -> Vec<f64> {
        let (m, nb) = (self.m, n_per_block(self.m));
        let dy = [0, 1, 2].map(|b| Mat::from_fn(m, m, |i, j| y[b * nb + tri(i.max(j), i.min(j))]));
        self.theta_of(&dy)
    }

    /// δθ = P̃⁻¹ (T⁻ᵀ δY_b T⁻¹) for each block: W = L⁻¹ δX L⁻ᵀ = A δY Aᵀ (its lower
    /// triangle: Φ reads no more), δL = L Φ(W).
    fn theta_of(&self, dy: &[Mat<f64>; 3]) -> Vec<f64> {
        let (m, nb) = (self.m, n_per_block(self.m));
        let mut out = vec![0.0; 3 * nb];
        out.par_chunks_mut(nb).enumerate().for_each(|(b, ob)| {
            let w = lower_congruence(self.a[b].as_ref(), dy[b].as_ref());
            let dl = mul(self.l[b].as_ref(), half_lower(&w).as_ref());
            for j in 0..m {
                for k in 0..=j {
                    ob[tri(j, k)] = dl[(j, k)] / self.scale(b, j, k);
                }
            }
        });
        out
    }

    /// The θ direction of one modal unknown: δY_b = E_jk + E_kj (E_jj on the
    /// diagonal), the other blocks 0.
    #[cfg(test)]
    pub(crate) fn modal_direction(&self, b: usize, j: usize, k: usize) -> Vec<f64> {
        let m = self.m;
        let mut dy = [0, 1, 2].map(|_| Mat::<f64>::zeros(m, m));
        dy[b][(j, k)] = 1.0;
        dy[b][(k, j)] = 1.0;
        self.theta_of(&dy)
    }
}

/// Φ(A): the strict lower triangle of A and half its diagonal (Φ(Z + Zᵀ) = Z for a
/// lower-triangular Z; also the adjoint that pairs a lower-triangular dual with W).
fn half_lower(a: &Mat<f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |j, k| match j.cmp(&k) {
        std::cmp::Ordering::Greater => a[(j, k)],
        std::cmp::Ordering::Equal => 0.5 * a[(j, j)],
        std::cmp::Ordering::Less => 0.0,
    })
}

fn safe_div(a: f64, b: f64) -> f64 {
    if b > 0.0 && b.is_finite() {
        a / b
    } else {
        0.0
    }
}

/// Adds line i's part of the sums (Σβ, Σω²β, Σω⁴β per pair, `out` 3·nb) for one
/// Gram term G (row-major m×m Hermitian, D⁻ᴴ…D⁻¹) and its columns' responses x and
/// weights w² (`cols`: (x, w²) pairs), at scaled frequency `om`.
pub(crate) fn add_line_sums(
    ti: MatRef<f64>,
    g: &[c64],
    cols: &[(&[c64], f64)],
    om: f64,
    out: &mut [f64],
) {
    let m = ti.nrows();
    // G_Y = T⁻¹ G T⁻ᵀ by real products: T⁻¹ [Re G | Im G], then each half · T⁻ᵀ
    let gri = Mat::<f64>::from_fn(m, 2 * m, |r, c| {
        let z = g[r * m + (c % m)];
        if c < m {
            z.re
        } else {
            z.im
        }
    });
    let left = mul(ti, gri.as_ref());
    // G_Y is Hermitian (Re symmetric, Im antisymmetric) and the sums read only its lower
    // triangle: the second products by half
    let lower = |half: MatRef<f64>| {
        let mut out = Mat::<f64>::zeros(m, m);
        faer::linalg::matmul::triangular::matmul(
            out.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            half,
            BlockStructure::Rectangular,
            ti.transpose(),
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        out
    };
    let gyr = lower(left.as_ref().subcols(0, m));
    let gyi = lower(left.as_ref().subcols(m, m));
    add_sums_y(ti, |j, k| c64::new(gyr[(j, k)], gyi[(j, k)]), cols, om, out);
}

/// The sums of one line from its G_Y (entries (j, k), j ≥ k, by `gy`) and the columns'
/// x (y = T⁻¹ x).
pub(crate) fn add_sums_y(
    ti: MatRef<f64>,
    gy: impl Fn(usize, usize) -> c64,
    cols: &[(&[c64], f64)],
    om: f64,
    out: &mut [f64],
) {
    let m = ti.nrows();
    let (w2, w4) = (om * om, om * om * om * om);
    for &(x, wt) in cols {
        // y = T⁻¹ x
        let y: Vec<c64> = (0..m)
            .map(|r| (0..m).map(|c| x[c] * ti[(r, c)]).sum())
            .collect();
        for j in 0..m {
            let yj = y[j];
            let (yj2, gjj) = (yj.norm_sqr(), gy(j, j).re);
            for k in 0..=j {
                let beta = if j == k {
                    yj2 * gjj
                } else {
                    let yk = y[k];
                    yk.norm_sqr() * gjj + yj2 * gy(k, k).re + 2.0 * (yk.conj() * yj * gy(j, k)).re
                } * wt;
                let o = &mut out[3 * tri(j, k)..3 * tri(j, k) + 3];
                o[0] += beta;
                o[1] += w2 * beta;
                o[2] += w4 * beta;
            }
        }
    }
}
