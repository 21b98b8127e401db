//! The λ-curves of one common symmetry weight λ = λ_M = λ_C = λ_K from one
//! eigendecomposition (paper §4.2, docs/design.md §4): residual ‖Ax − y‖, penalty ‖Lx‖,
//! the trace of the influence matrix, GCV and the L-curve's curvature at any λ
//! for O(n_w) each, exact values and the identified M, C, K at any λ for O(n_w²).
//!
//! In the scaled symmetric/skew coordinates x = [x_s; x_w] the normal matrix is
//! G(λ) = G_d + λ² diag(0, W), with w_b = 4(c_b/s_f)² on the skew coordinates of
//! block b, so that λ is in the paper's units ([`Scaling::scaled_lam`]). Since
//! G_d = Tᵀ(I⊗H)T with T orthogonal, G_d⁻¹ = Tᵀ(I⊗H⁻¹)T, and its skew block — the
//! inverse of the Schur complement S = D − BᵀA⁻¹B of the symmetric unknowns — is
//!
//! ```text
//!     K = T_wᵀ (I⊗H⁻¹) T_w,
//! ```
//!
//! assembled like G from the 3m×3m H⁻¹ and applied to a vector in O(m³), with no
//! factorisation of G at all. With x_0 the unregularised solution (λ = 0),
//! z = W^½ x_w and K̃ = W^½ K W^½:
//!
//! ```text
//!     G(λ)x = b  ⇔  x = x_0 − λ² G_d⁻¹ W̄ x  ⇒  (I + λ²K̃) z = z_0,
//! ```
//!
//! so with K̃ = V diag(ν) Vᵀ and d = Vᵀz_0 (s_f converts to the paper's units):
//!
//! ```text
//!     ‖Lx‖²     = s_f² ‖z‖²  = s_f² Σ d_i² / (1 + λ²ν_i)²          (Σ_b ‖X_b − X_bᵀ‖²_F)
//!     ‖Ax − y‖² = s_f² (ρ_0² + λ⁴ zᵀK̃z) = s_f² (ρ_0² + λ⁴ Σ d_i² ν_i / (1 + λ²ν_i)²)
//!     tr(G(λ)⁻¹ G_d) = n_u − Σ λ²ν_i / (1 + λ²ν_i)
//! ```
//!
//! with ρ_0 the residual at λ = 0, computed from the data. The residual identity
//! is φ(x) = φ(x_0) + (x − x_0)ᵀG_d(x − x_0): every term is positive, so there is
//! no cancellation however small the residual. Only ν and d are needed, not V:
//! K̃ = Q T Qᵀ by Householder tridiagonalisation, then implicit QL on T rotates
//! Qᵀz_0 into d in O(n_w²). H must be positive definite (the unregularised
//! problem well posed); otherwise [`Sweep::new`] returns `None`.
//!
//! Accuracy. K̃ is strongly graded: w_M : w_C : w_K = 1 : ω0² : ω0⁴, so with one
//! λ in the paper's units its eigenvalues span cond(H)·ω0⁴ (10¹³ on the paper's
//! chain), and a normwise backward-stable eigensolver returns the small ones —
//! the skew parts of M, which a common λ damps last — with no correct digit. The
//! skew coordinates are therefore ordered by decreasing weight, the Householder
//! reduction starts at the heavy end and QL runs on T reversed (heavy end last):
//! the spectral formulas are then good to about 1e-8 relative, plenty to locate
//! a λ. Values reported at given λ ([`Sweep::exact_points`], [`Sweep::solve`])
//! come from solves: z = Q₁(I + λ²B)⁻¹Q₁ᵀz₀ through the band B of the
//! tridiagonalisation ([`Tridiagonal::solve_shifted`], O(n_w b²) per λ after
//! O(n_w²) for Q₁), then one step of iterative refinement against the exact,
//! structured K̃ — as accurate as a direct solve.

use crate::buffer::DenseBuf;
use crate::data::{Columns, Scaling, Stacked};
use crate::direct::cholesky_solve;
use crate::error::PodidError;
use crate::gram::gram;
use crate::normal::{n_unknowns, Basis};
use crate::tridiag::Tridiagonal;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;
use std::time::Instant;

/// One point of the λ-curves, in the paper's units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// ‖Ax − y‖ (eq. 28)
    pub residual: f64,
    /// ‖Lx‖ = (Σ_b ‖X_b − X_bᵀ‖²_F)^½ (eq. 30 with L = [L_M; L_C; L_K])
    pub penalty: f64,
    /// tr(A G(λ)⁻¹ Aᵀ) = tr(G(λ)⁻¹ G_d): the effective number of parameters
    pub trace: f64,
    /// ‖Ax − y‖² / (rows − trace)² (eq. 34 for the real stacked problem)
    pub gcv: f64,
    /// signed curvature of (ln ‖Ax − y‖, ln ‖Lx‖) traced with increasing λ;
    /// positive where the curve turns like the corner of an L
    pub curvature: f64,
}

/// Everything needed to evaluate the λ-curves and solve at any λ.
pub struct Sweep {
    m: usize,
    /// real equations: 2·N·m
    n_rows: usize,
    scaling: Scaling,
    /// H⁻¹ (3m×3m, scaled)
    hinv: Mat<f64>,
    /// unregularised solution Z̃_0 = B H⁻¹ (m×3m, scaled)
    z0: Mat<f64>,
    /// ‖Ã x_0 − ỹ‖² (scaled)
    rho0_sq: f64,
    skew: Basis,
    /// √w per skew coordinate
    root_w: Vec<f64>,
    /// z_0 = W^½ x_{0,w}
    z0w: Vec<f64>,
    /// K̃ = Q T Qᵀ
    tri: Tridiagonal,
    /// eigenvalues ν_i ≥ 0 of K̃ and the squared weights d_i²
    nu: Vec<f64>,
    d2: Vec<f64>,
    /// min L_ii²/H_ii of the Cholesky factor of H
    min_pivot_ratio: f64,
    timings: Vec<(&'static str, f64)>,
}

/// Bytes of the largest matrix [`Sweep::new`] allocates and keeps: the n_w×n_w
/// K̃, n_w = 3m(m−1)/2 (a quarter of the direct path's 3m²×3m²); the band and
/// the other work arrays are O(n_w·b).
pub fn sweep_bytes(m: usize) -> u128 {
    let nw = Basis::skew(m).len() as u128;
    nw * nw * 8
}

/// ‖Z̃ṽ_i − f̃_i‖² summed over the columns (scaled), from the stacked data.
fn residual_sq(data: &Stacked, z: MatRef<f64>, par: Par) -> f64 {
    let (n, m) = (data.w.len(), data.y.ncols());
    // P_b = Y X_bᵀ: row i is (X_b u_i)ᵀ for the real and imaginary halves
    let prod = |b: usize| {
        let mut p = Mat::zeros(2 * n, m);
        let xb = z.subcols(b * m, m);
        matmul(
            p.as_mut(),
            Accum::Replace,
            data.y.as_ref(),
            xb.transpose(),
            1.0,
            par,
        );
        p
    };
    let (pm, pc, pk) = (prod(0), prod(1), prod(2));
    let mut acc = 0.0;
    for c in 0..m {
        for (i, &w) in data.w.iter().enumerate() {
            let (re, im) = (i, n + i);
            let r = -w * w * pm[(re, c)] - w * pc[(im, c)] + pk[(re, c)] - data.g[(re, c)];
            let s = -w * w * pm[(im, c)] + w * pc[(re, c)] + pk[(im, c)] - data.g[(im, c)];
            acc += r * r + s * s;
        }
    }
    acc
}

/// The skew coordinates of [`Basis::skew`], block by block in order of decreasing
/// weight `unit[b]` (ties keep M, C, K order).
fn graded_skew_basis(m: usize, unit: [f64; 3]) -> Basis {
    let mut basis = Basis::skew(m);
    basis
        .coords
        .sort_by(|a, b| unit[b.block].total_cmp(&unit[a.block]));
    basis
}

/// Eigenvalues ν of the symmetric tridiagonal matrix T = (diag, sub) and the
/// coordinates Uᵀv of v in its eigenvectors: implicit QL with Wilkinson shifts that
/// applies its rotations to the one row vector vᵀ instead of accumulating U
/// (O(n²), not O(n³)). QL deflates from the top, so it suits T graded with its
/// large entries at the bottom right.
pub fn tridiagonal_spectrum(
    diag: &[f64],
    sub: &[f64],
    v: &[f64],
) -> Result<(Vec<f64>, Vec<f64>), PodidError> {
    let n = diag.len();
    let mut d = diag.to_vec();
    // e[i] couples i and i + 1; e[n − 1] = 0
    let mut e = sub.to_vec();
    e.resize(n, 0.0);
    // vᵀU, rotated along
    let mut z = v.to_vec();
    for l in 0..n {
        let mut iterations = 0;
        loop {
            let mut mm = l;
            while mm + 1 < n && e[mm].abs() > f64::EPSILON * (d[mm].abs() + d[mm + 1].abs()) {
                mm += 1;
            }
            if mm == l {
                break;
            }
            iterations += 1;
            if iterations > 60 {
                return Err(PodidError::Invalid(format!(
                    "the tridiagonal eigenvalue iteration did not converge (eigenvalue {l} of {n})"
                )));
            }
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = g.hypot(1.0);
            g = d[mm] - d[l] + e[l] / (g + r.copysign(g));
            let (mut s, mut c, mut p) = (1.0, 1.0, 0.0);
            let mut deflated = false;
            for i in (l..mm).rev() {
                let f = s * e[i];
                let b = c * e[i];
                r = f.hypot(g);
                e[i + 1] = r;
                if r == 0.0 {
                    // underflow: the matrix splits at i + 1; restart at l
                    d[i + 1] -= p;
                    e[mm] = 0.0;
                    deflated = true;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                let zi1 = z[i + 1];
                z[i + 1] = s * z[i] + c * zi1;
                z[i] = c * z[i] - s * zi1;
            }
            if !deflated {
                d[l] -= p;
                e[l] = g;
                e[mm] = 0.0;
            }
        }
    }
    Ok((d, z))
}

/// One step of iterative refinement takes the banded solve (good to ~1e-8 on
/// graded K̃) to the accuracy of a direct solve.
const REFINEMENT_STEPS: usize = 1;

/// Band width of the two-stage tridiagonalisation ([`Tridiagonal`]) of order n:
/// narrow where the chase and the banded solves (O(n b) and O(n b²) per λ)
/// dominate, wider where stage 1's matrix products do (measured at n = 570,
/// 2340 and 5310 on two cores).
fn band_width(n: usize) -> usize {
    if n < 2000 {
        16
    } else {
        32
    }
}

impl Sweep {
    /// Factor once: Gram products, H⁻¹, the unregularised solution, K̃ and its
    /// spectrum. `Ok(None)` when H is not numerically positive definite (too few or
    /// degenerate data for the unregularised problem): use repeated solves then.
    pub fn new(cols: &Columns, par: Par) -> Result<Option<Sweep>, PodidError> {
        let start = Instant::now();
        let m = cols.m;
        let n3 = 3 * m;
        let scaling = Scaling::of(cols);
        let data = Stacked::new(cols, &scaling);
        let gm = gram(&data, par);
        let gram_seconds = start.elapsed().as_secs_f64();

        // H⁻¹ and Z_0ᵀ = H⁻¹Bᵀ from one Cholesky factorisation
        let mut h: Vec<f64> = (0..n3 * n3).map(|k| gm.h[(k % n3, k / n3)]).collect();
        let mut rhs = vec![0.0; n3 * (n3 + m)];
        for j in 0..n3 {
            rhs[j * n3 + j] = 1.0;
        }
        for r in 0..m {
            for c in 0..n3 {
                rhs[(n3 + r) * n3 + c] = gm.b[(r, c)];
            }
        }
        let Some(sol) = cholesky_solve(&mut h, n3, &rhs, par) else {
            return Ok(None);
        };
        let hinv = Mat::from_fn(n3, n3, |i, j| sol.x[j * n3 + i]);
        let z0 = Mat::from_fn(m, n3, |r, c| sol.x[(n3 + r) * n3 + c]);
        let rho0_sq = residual_sq(&data, z0.as_ref(), par);

        // K̃ = W^½ T_wᵀ(I⊗H⁻¹)T_w W^½ and z_0 = W^½ x_{0,w}
        let assemble_start = Instant::now();
        let unit = scaling.scaled_lam([1.0; 3]);
        let skew = graded_skew_basis(m, unit);
        let nw = skew.len();
        let root_w: Vec<f64> = skew.coords.iter().map(|c| 2.0 * unit[c.block]).collect();
        let what = format!("the {nw}×{nw} skew block of the inverse normal matrix");
        let mut trid = DenseBuf::zeroed(nw * nw, &what)?;
        if nw > 0 {
            skew.assemble(hinv.as_ref(), [0.0; 3], &mut trid);
            trid.par_chunks_mut(nw).enumerate().for_each(|(q, col)| {
                for p in q..nw {
                    col[p] *= root_w[p] * root_w[q];
                }
            });
        }
        let z0w: Vec<f64> = skew
            .rhs(z0.as_ref())
            .iter()
            .zip(&root_w)
            .map(|(x, r)| x * r)
            .collect();
        let assemble_seconds = assemble_start.elapsed().as_secs_f64();

        let mut t = Mat::from_fn(nw, 1, |i, _| z0w[i]);
        let tri = Tridiagonal::new(trid, nw, band_width(nw), t.as_mut(), par);
        let [band_seconds, chase_seconds] = tri.seconds;

        // QL on T reversed, so that its heavy end comes last; t = Qᵀz_0 becomes d
        let spectrum_start = Instant::now();
        let rev =
            |v: &mut dyn DoubleEndedIterator<Item = &f64>| v.rev().copied().collect::<Vec<_>>();
        let (mut nu, d) = tridiagonal_spectrum(
            &rev(&mut tri.diag.iter()),
            &rev(&mut tri.sub.iter()),
            &rev(&mut t.col(0).iter()),
        )?;
        // K̃ is positive semidefinite: negative eigenvalues are rounding
        nu.iter_mut().for_each(|v| *v = v.max(0.0));
        let d2 = d.iter().map(|v| v * v).collect();
        let spectrum_seconds = spectrum_start.elapsed().as_secs_f64();
        Ok(Some(Sweep {
            m,
            n_rows: 2 * cols.len() * m,
            scaling,
            hinv,
            z0,
            rho0_sq,
            skew,
            root_w,
            z0w,
            tri,
            nu,
            d2,
            min_pivot_ratio: sol.min_pivot_ratio,
            timings: vec![
                ("gram", gram_seconds),
                ("assemble", assemble_seconds),
                ("band", band_seconds),
                ("chase", chase_seconds),
                ("spectrum", spectrum_seconds),
                ("total", start.elapsed().as_secs_f64()),
            ],
        }))
    }

    pub fn m(&self) -> usize {
        self.m
    }

    /// Real equations 2·N·m of the stacked problem.
    pub fn n_rows(&self) -> usize {
        self.n_rows
    }

    /// Unknowns 3m².
    pub fn n_unknowns(&self) -> usize {
        n_unknowns(self.m, false)
    }

    pub fn scaling(&self) -> Scaling {
        self.scaling
    }

    /// Eigenvalues ν_i of K̃ (in no particular order), in 1/λ² units: the skew
    /// direction i is damped by 1/(1 + λ²ν_i).
    pub fn eigenvalues(&self) -> &[f64] {
        &self.nu
    }

    /// min L_ii²/H_ii of the Cholesky factor of H (≈ 1/cond(H) up to a modest factor).
    pub fn min_pivot_ratio(&self) -> f64 {
        self.min_pivot_ratio
    }

    /// Wall time per phase, seconds: gram, assemble (H⁻¹, K̃), band and chase (the
    /// two stages of the tridiagonalisation), spectrum (QL), total.
    pub fn timings(&self) -> &[(&'static str, f64)] {
        &self.timings
    }

    /// The λ-curves at one λ ≥ 0 (paper units) from the spectrum, O(n_w).
    pub fn spectral_point(&self, lam: f64) -> Point {
        let s = lam * lam;
        // sums over the spectrum, q = 1/(1 + sν)
        let (mut pen, mut res, mut a1, mut rtt, mut ptt) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (&nu, &d2) in self.nu.iter().zip(&self.d2) {
            let q = 1.0 / (1.0 + s * nu);
            let q2 = q * q;
            pen += d2 * q2;
            res += d2 * nu * q2;
            a1 += d2 * nu * q2 * q;
            rtt += d2 * nu * (2.0 - s * nu) * q2 * q2;
            ptt += d2 * nu * (2.0 * s * nu - 1.0) * q2 * q2;
        }
        // scaled R = ‖Ax−y‖², P = ‖Lx‖² and their derivatives in t = ln λ
        let (r, p) = (self.rho0_sq + s * s * res, pen);
        let (r_t, p_t) = (4.0 * s * s * a1, -4.0 * s * a1);
        let (r_tt, p_tt) = (8.0 * s * s * rtt, 8.0 * s * ptt);
        let (x_t, y_t) = (r_t / (2.0 * r), p_t / (2.0 * p));
        let x_tt = (r_tt * r - r_t * r_t) / (2.0 * r * r);
        let y_tt = (p_tt * p - p_t * p_t) / (2.0 * p * p);
        let curvature = (x_t * y_tt - x_tt * y_t) / (x_t * x_t + y_t * y_t).powf(1.5);
        self.finish(lam, r, p, curvature)
    }

    /// A [`Point`] from the scaled R = ‖Ax−y‖², P = ‖Lx‖² at λ (trace from the spectrum).
    fn finish(&self, lam: f64, r: f64, p: f64, curvature: f64) -> Point {
        let s = lam * lam;
        let damped: f64 = self.nu.iter().map(|&nu| s * nu / (1.0 + s * nu)).sum();
        let trace = self.n_unknowns() as f64 - damped;
        let sf2 = self.scaling.sf * self.scaling.sf;
        let dof = self.n_rows as f64 - trace;
        Point {
            residual: (sf2 * r).sqrt(),
            penalty: (sf2 * p).sqrt(),
            trace,
            gcv: sf2 * r / (dof * dof),
            curvature,
        }
    }

    /// The λ-curves at each λ with residual and penalty from refined solves,
    /// O(n_w²) each (trace and curvature from the spectrum).
    pub fn exact_points(&self, lams: &[f64], par: Par) -> Vec<Point> {
        let (z, kz) = self.skew_parts(lams, par);
        lams.iter()
            .enumerate()
            .map(|(j, &lam)| {
                let s = lam * lam;
                let p = z.col(j).squared_norm_l2();
                let zkz: f64 = z
                    .col(j)
                    .iter()
                    .zip(kz.col(j).iter())
                    .map(|(a, b)| a * b)
                    .sum();
                let curvature = self.spectral_point(lam).curvature;
                self.finish(lam, self.rho0_sq + s * s * zkz, p, curvature)
            })
            .collect()
    }

    /// K̃ times each column of z, through H⁻¹: O(m³) per column.
    fn apply_k(&self, z: MatRef<f64>, par: Par) -> Mat<f64> {
        let (m, k) = (self.m, z.ncols());
        // the columns' m×3m blocks stacked, times H⁻¹ in one product
        let mut stacked = Mat::zeros(k * m, 3 * m);
        for j in 0..k {
            let x: Vec<f64> = z
                .col(j)
                .iter()
                .zip(&self.root_w)
                .map(|(a, r)| a * r)
                .collect();
            stacked
                .as_mut()
                .subrows_mut(j * m, m)
                .copy_from(self.skew.to_blocks(&x));
        }
        let mut prod = Mat::zeros(k * m, 3 * m);
        matmul(
            prod.as_mut(),
            Accum::Replace,
            stacked.as_ref(),
            self.hinv.as_ref(),
            1.0,
            par,
        );
        let mut out = Mat::zeros(z.nrows(), k);
        for j in 0..k {
            let coords = self.skew.rhs(prod.as_ref().subrows(j * m, m));
            for ((o, v), r) in out.col_mut(j).iter_mut().zip(coords).zip(&self.root_w) {
                *o = v * r;
            }
        }
        out
    }

    /// z_j = (I + λ_j²K̃)⁻¹ z_0 for each λ_j (columns), by the band and refined
    /// against the structured K̃, and K̃ z_j.
    fn skew_parts(&self, lams: &[f64], par: Par) -> (Mat<f64>, Mat<f64>) {
        let shifts: Vec<f64> = lams.iter().map(|l| l * l).collect();
        let nw = self.z0w.len();
        let mut z = Mat::from_fn(nw, lams.len(), |i, _| self.z0w[i]);
        self.tri.solve_shifted(&shifts, z.as_mut(), par);
        let mut kz = self.apply_k(z.as_ref(), par);
        for _ in 0..REFINEMENT_STEPS {
            let mut r = Mat::from_fn(nw, lams.len(), |i, j| {
                self.z0w[i] - z[(i, j)] - shifts[j] * kz[(i, j)]
            });
            self.tri.solve_shifted(&shifts, r.as_mut(), par);
            z += &r;
            kz = self.apply_k(z.as_ref(), par);
        }
        (z, kz)
    }

    /// M, C, K at λ (paper units), O(n_w²): the refined z gives the skew parts,
    /// Z = Z_0 − λ² (W x_w) H⁻¹ the symmetric parts.
    pub fn solve(&self, lam: f64, par: Par) -> [Mat<f64>; 3] {
        let (m, s) = (self.m, lam * lam);
        let (z, _) = self.skew_parts(&[lam], par);
        let z = z.col(0);
        let xw: Vec<f64> = z.iter().zip(&self.root_w).map(|(a, r)| a / r).collect();
        let wx: Vec<f64> = z.iter().zip(&self.root_w).map(|(a, r)| a * r).collect();
        let skew_part = self.skew.to_blocks(&xw);
        let mut full = self.z0.clone();
        let omega = self.skew.to_blocks(&wx);
        matmul(
            full.as_mut(),
            Accum::Add,
            omega.as_ref(),
            self.hinv.as_ref(),
            -s,
            par,
        );
        let f = self.scaling.block_factors();
        [0, 1, 2].map(|b| {
            Mat::from_fn(m, m, |i, j| {
                let (ij, ji) = (full[(i, b * m + j)], full[(j, b * m + i)]);
                f[b] * (0.5 * (ij + ji) + skew_part[(i, b * m + j)])
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::identify;
    use crate::random::Lcg;
    use faer::c64;
    use faer::prelude::Solve;

    /// Solve (I + s T) y = y in place for the symmetric tridiagonal T (diag, sub)
    /// positive semidefinite and s ≥ 0 (no pivoting needed).
    fn solve_shifted_tridiagonal(diag: &[f64], sub: &[f64], s: f64, y: &mut [f64]) {
        let n = y.len();
        if n == 0 {
            return;
        }
        let mut piv = vec![0.0; n];
        piv[0] = 1.0 + s * diag[0];
        for i in 1..n {
            let off = s * sub[i - 1];
            let l = off / piv[i - 1];
            piv[i] = 1.0 + s * diag[i] - l * off;
            y[i] -= l * y[i - 1];
        }
        y[n - 1] /= piv[n - 1];
        for i in (0..n - 1).rev() {
            y[i] = (y[i] - s * sub[i] * y[i + 1]) / piv[i];
        }
    }

    /// A non-symmetric system, two load cases per line, responses with 5 % noise;
    /// frequencies 0.5…15 rad/s times `band` (C, K scaled to keep the resonances in
    /// it), so that the blocks' weights differ by about (9·band)⁴.
    fn noisy_data(m: usize, lines: usize, seed: u64, band: f64) -> (Vec<c64>, Vec<c64>, Vec<f64>) {
        let mut rng = Lcg(seed);
        let mut mat = |diag: f64, off: f64| {
            Mat::from_fn(
                m,
                m,
                |i, j| if i == j { diag } else { 0.0 } + off * rng.uniform(),
            )
        };
        let (mm, cc, kk) = (
            mat(1.0, 0.1),
            mat(0.2 * band, 0.05 * band),
            mat(50.0, 5.0) * (band * band),
        );
        let (mut u, mut f, mut w) = (Vec::new(), Vec::new(), Vec::new());
        for l in 0..lines {
            let om = band * (0.5 + 14.5 * l as f64 / lines as f64);
            let d = Mat::from_fn(m, m, |i, j| {
                c64::new(-om * om * mm[(i, j)] + kk[(i, j)], om * cc[(i, j)])
            });
            let lu = d.partial_piv_lu();
            for _ in 0..2 {
                let rhs = Mat::from_fn(m, 1, |_, _| c64::new(rng.uniform(), rng.uniform()));
                let x = lu.solve(&rhs);
                let scale = x.norm_l2() / (m as f64).sqrt();
                for i in 0..m {
                    let noise = c64::new(rng.uniform(), rng.uniform()) * (0.05 * scale);
                    u.push(x[(i, 0)] + noise);
                    f.push(rhs[(i, 0)]);
                }
                w.push(om);
            }
        }
        (u, f, w)
    }

    /// ‖Ax − y‖ and ‖Lx‖ of M, C, K computed from the data, paper units.
    fn norms(cols: &Columns, mck: &[Mat<f64>; 3]) -> (f64, f64) {
        let m = cols.m;
        let mut res = 0.0;
        for (i, &om) in cols.omega.iter().enumerate() {
            for r in 0..m {
                let mut acc = -cols.f[i * m + r];
                for c in 0..m {
                    let d = c64::new(
                        -om * om * mck[0][(r, c)] + mck[2][(r, c)],
                        om * mck[1][(r, c)],
                    );
                    acc += d * cols.u[i * m + c];
                }
                res += acc.norm_sqr();
            }
        }
        let pen: f64 = mck
            .iter()
            .map(|x| (x - x.transpose()).norm_l2().powi(2))
            .sum();
        (res.sqrt(), pen.sqrt())
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Spectral values to 1e-6, refined values and solutions to 1e-10, also with
    /// block weights 10¹⁴ apart (band = 100).
    #[test]
    fn curves_and_solutions_match_direct_solves() {
        for (m, seed, band) in [
            (2, 1, 1.0),
            (3, 2, 1.0),
            (7, 3, 1.0),
            (4, 4, 100.0),
            (7, 5, 100.0),
        ] {
            let (u, f, w) = noisy_data(m, 8 * m, seed, band);
            let cols = Columns::new(&u, &f, &w, m).unwrap();
            let sweep = Sweep::new(&cols, Par::Seq).unwrap().expect("H is PD");
            let lams: Vec<f64> = (-4..=8).map(|k| 10f64.powi(k) / band).collect();
            let exact = sweep.exact_points(&lams, Par::Seq);
            for (&lam, pt) in lams.iter().zip(&exact) {
                let direct = identify(&cols, [lam; 3], false, Par::Seq).unwrap();
                let (res, pen) = norms(&cols, &direct.mck);
                let msg = format!("m={m} band={band} λ={lam}");
                // ‖X − Xᵀ‖ of the direct answer loses ε‖X‖ to cancellation
                let floor = 1e-14 * direct.mck.iter().map(|x| x.norm_l2()).sum::<f64>();
                let close = |a: f64, b: f64, tol: f64| (a - b).abs() <= tol * b + floor;
                assert!(
                    rel(pt.residual, res) < 1e-10,
                    "{msg}: {} vs {res}",
                    pt.residual
                );
                assert!(
                    close(pt.penalty, pen, 1e-10),
                    "{msg}: {} vs {pen}",
                    pt.penalty
                );
                let sp = sweep.spectral_point(lam);
                assert!(
                    rel(sp.residual, res) < 1e-6 && close(sp.penalty, pen, 1e-6),
                    "{msg}"
                );
                assert_eq!((sp.trace, sp.curvature), (pt.trace, pt.curvature));
                let mck = sweep.solve(lam, Par::Seq);
                for (x, want) in mck.iter().zip(&direct.mck) {
                    assert!((x - want).norm_l2() < 1e-10 * want.norm_l2(), "{msg}");
                }
            }
        }
    }

    /// tr(G(λ)⁻¹ G_d) from dense matrices assembled in the symmetric/skew basis.
    #[test]
    fn trace_matches_dense_influence_matrix() {
        let m = 3;
        let (u, f, w) = noisy_data(m, 20, 7, 1.0);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        let sweep = Sweep::new(&cols, Par::Seq).unwrap().unwrap();
        let sc = Scaling::of(&cols);
        let gm = gram(&Stacked::new(&cols, &sc), Par::Seq);
        let basis = Basis::new(m, false);
        let n = basis.len();
        let dense = |lam: f64| {
            let mut g = vec![0.0; n * n];
            basis.assemble(gm.h.as_ref(), sc.scaled_lam([lam; 3]), &mut g);
            Mat::from_fn(n, n, |i, j| g[i.min(j) * n + i.max(j)])
        };
        let gd = dense(0.0);
        for lam in [0.01, 0.3, 3.0, 100.0] {
            let inf = dense(lam).partial_piv_lu().solve(&gd);
            let trace: f64 = (0..n).map(|i| inf[(i, i)]).sum();
            let got = sweep.spectral_point(lam).trace;
            assert!(
                (got - trace).abs() < 1e-9 * n as f64,
                "λ={lam}: {got} vs {trace}"
            );
        }
        assert_eq!(sweep.spectral_point(0.0).trace, n as f64);
    }

    /// The curvature is that of (ln residual, ln penalty) against ln λ.
    #[test]
    fn curvature_matches_finite_differences() {
        let m = 4;
        let (u, f, w) = noisy_data(m, 30, 11, 1.0);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        let sweep = Sweep::new(&cols, Par::Seq).unwrap().unwrap();
        let curve = |t: f64| {
            let p = sweep.spectral_point(t.exp());
            (p.residual.ln(), p.penalty.ln())
        };
        for lam in [0.03_f64, 0.5, 4.0, 50.0] {
            let (t, h) = (lam.ln(), 1e-3);
            let ((x0, y0), (x1, y1), (x2, y2)) = (curve(t - h), curve(t), curve(t + h));
            let (xt, yt) = ((x2 - x0) / (2.0 * h), (y2 - y0) / (2.0 * h));
            let (xtt, ytt) = (
                (x2 - 2.0 * x1 + x0) / (h * h),
                (y2 - 2.0 * y1 + y0) / (h * h),
            );
            let want = (xt * ytt - xtt * yt) / (xt * xt + yt * yt).powf(1.5);
            let got = sweep.spectral_point(lam).curvature;
            assert!(
                (got - want).abs() < 1e-4 * (1.0 + want.abs()),
                "λ={lam}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn tridiagonal_spectrum_matches_dense_eigendecomposition() {
        let mut rng = Lcg(5);
        for n in [1, 2, 7, 40] {
            let diag: Vec<f64> = (0..n).map(|_| 2.0 + rng.uniform()).collect();
            // a zero coupling splits the matrix; repeated values test deflation
            let sub: Vec<f64> = (1..n)
                .map(|i| if i == 3 { 0.0 } else { rng.uniform() })
                .collect();
            let v: Vec<f64> = (0..n).map(|_| rng.uniform()).collect();
            let (vals, d) = tridiagonal_spectrum(&diag, &sub, &v).unwrap();
            let t = Mat::from_fn(n, n, |i, j| {
                if i == j {
                    diag[i]
                } else if i == j + 1 {
                    sub[j]
                } else if j == i + 1 {
                    sub[i]
                } else {
                    0.0
                }
            });
            let evd = t.self_adjoint_eigen(faer::Side::Lower).unwrap();
            let (mut want, mut got) =
                ((0..n).map(|i| evd.S()[i]).collect::<Vec<_>>(), vals.clone());
            want.sort_by(f64::total_cmp);
            got.sort_by(f64::total_cmp);
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).abs() < 1e-13, "n={n}");
            }
            // d = Uᵀv: vᵀ (I + sT)⁻¹ v = Σ d_i² / (1 + sν_i) for a few s
            for s in [0.1, 1.0, 10.0] {
                let mut y = v.clone();
                solve_shifted_tridiagonal(&diag, &sub, s, &mut y);
                let want: f64 = v.iter().zip(&y).map(|(a, b)| a * b).sum();
                let quad: f64 = vals
                    .iter()
                    .zip(&d)
                    .map(|(l, c)| c * c / (1.0 + s * l))
                    .sum();
                assert!((quad - want).abs() < 1e-13, "n={n} s={s}");
            }
        }
    }

    #[test]
    fn order_one_has_no_skew_part() {
        let (u, f, w) = noisy_data(1, 6, 3, 1.0);
        let cols = Columns::new(&u, &f, &w, 1).unwrap();
        let sweep = Sweep::new(&cols, Par::Seq).unwrap().unwrap();
        let (p, q) = (sweep.spectral_point(0.0), sweep.spectral_point(1e3));
        assert_eq!(p.penalty, 0.0);
        assert_eq!(p.residual, q.residual);
        let direct = identify(&cols, [0.0; 3], false, Par::Seq).unwrap();
        for (x, want) in sweep.solve(5.0, Par::Seq).iter().zip(&direct.mck) {
            assert!((x - want).norm_l2() < 1e-12 * want.norm_l2());
        }
    }

    #[test]
    fn singular_gram_gives_none() {
        // a single line and load case: 2m real equations for 3m unknowns per row
        let (u, f, w) = noisy_data(3, 1, 1, 1.0);
        let cols = Columns::new(&u[..3], &f[..3], &w[..1], 3).unwrap();
        assert!(Sweep::new(&cols, Par::Seq).unwrap().is_none());
    }
}
