//! The parametrisation of the model by Cholesky factors: θ packs the lower
//! triangles of L_M, L_C, L_K ([`Params`]; with `log_diagonal` their diagonals as
//! logarithms), and X = L Lᵀ + ε tr(L Lᵀ) I ([`gram_lower`]) is positive definite for
//! every θ. Also the factor of a given symmetric matrix ([`psd_factor`]), and the
//! orthonormal basis of the start's damping modes that the matrix-free modal step
//! turns the problem into ([`damping_basis`], [`rotate_columns`], [`rotated_factor`]).

use crate::error::PodidError;
use faer::{c64, Mat, MatRef, Par, Side};
use rayon::prelude::*;

/// Unknowns per block: the lower triangle of L.
pub fn n_per_block(m: usize) -> usize {
    m * (m + 1) / 2
}

/// Index of L[j][k] (j ≥ k) in a block's parameters.
#[inline]
pub(crate) fn tri(j: usize, k: usize) -> usize {
    j * (j + 1) / 2 + k
}

/// Lower-triangular factor of a symmetric matrix, with eigenvalues below `floor`
/// raised to it first (so a PSD matrix with zero eigenvalues still factors).
pub fn psd_factor(x: MatRef<f64>, floor: f64) -> Result<Mat<f64>, PodidError> {
    let m = x.nrows();
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| PodidError::Invalid(format!("eigendecomposition failed: {e:?}")))?;
    let (q, d) = (evd.U(), evd.S().column_vector());
    let raised = Mat::from_fn(m, m, |i, j| {
        (0..m)
            .map(|k| q[(i, k)] * d[k].max(floor) * q[(j, k)])
            .sum::<f64>()
    });
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (raised[(i, j)] + raised[(j, i)]));
    let l = sym.llt(Side::Lower).map_err(|_| {
        PodidError::Invalid(
            "the start model could not be factored: it is not positive semidefinite".into(),
        )
    })?;
    Ok(l.L().to_owned())
}

/// Parameters θ of three factors (scaled units).
pub(crate) struct Params {
    pub(crate) m: usize,
    pub(crate) log_diagonal: bool,
}

impl Params {
    pub(crate) fn len(&self) -> usize {
        3 * n_per_block(self.m)
    }

    /// θ from the factors [L_M, L_C, L_K].
    pub(crate) fn pack(&self, l: &[Mat<f64>; 3]) -> Vec<f64> {
        let nb = n_per_block(self.m);
        let mut th = vec![0.0; 3 * nb];
        for (b, lb) in l.iter().enumerate() {
            for j in 0..self.m {
                for k in 0..=j {
                    let v = lb[(j, k)];
                    th[b * nb + tri(j, k)] = if j == k && self.logged(b) {
                        // the sign of a column of L is free: log|L_jj|
                        v.abs().max(f64::MIN_POSITIVE).ln()
                    } else {
                        v
                    };
                }
            }
        }
        th
    }

    pub(crate) fn logged(&self, _b: usize) -> bool {
        self.log_diagonal
    }

    /// The factors from θ.
    pub(crate) fn unpack(&self, th: &[f64]) -> [Mat<f64>; 3] {
        let (m, nb) = (self.m, n_per_block(self.m));
        [0, 1, 2].map(|b| {
            Mat::from_fn(m, m, |j, k| {
                if k > j {
                    0.0
                } else {
                    let v = th[b * nb + tri(j, k)];
                    if j == k && self.logged(b) {
                        v.exp()
                    } else {
                        v
                    }
                }
            })
        })
    }
}

/// X = L Lᵀ + ε‖L‖²_F I with ε = [`CONDITION_FLOOR`]: positive definite with
/// cond(X) ≤ m/ε + 1 for every L, so that definiteness and the modes of the model are
/// numerically certain (a factor drifting to singular leaves a mass, damping or
/// stiffness floored at ε times the block's trace).
pub(crate) fn gram_lower(l: &Mat<f64>) -> Mat<f64> {
    let m = l.nrows();
    let trace: f64 = (0..m)
        .map(|i| (0..=i).map(|k| l[(i, k)] * l[(i, k)]).sum::<f64>())
        .sum();
    Mat::from_fn(m, m, |i, j| {
        let llt: f64 = (0..=i.min(j)).map(|k| l[(i, k)] * l[(j, k)]).sum();
        llt + if i == j { CONDITION_FLOOR * trace } else { 0.0 }
    })
}

/// Relative floor ε of every block: X = L Lᵀ + ε tr(L Lᵀ) I (see `gram_lower`).
pub const CONDITION_FLOOR: f64 = 1e-10;

/// Whether the symmetric part of `x` has every eigenvalue at least ½ε tr(x) (ε =
/// [`CONDITION_FLOOR`]): true of every matrix the parametrisation gives back
/// (L Lᵀ + ε tr(L Lᵀ) I), false of a singular one.
pub(crate) fn has_condition_floor(x: MatRef<f64>) -> bool {
    let m = x.nrows();
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
    let tr: f64 = (0..m).map(|i| sym[(i, i)]).sum();
    match sym.self_adjoint_eigenvalues(Side::Lower) {
        Ok(ev) => tr > 0.0 && ev.iter().all(|&v| v >= 0.5 * CONDITION_FLOOR * tr),
        Err(_) => false,
    }
}

/// Longest change of a log-diagonal in one step: a factor e² in the entry.
pub(crate) const LOG_STEP_MAX: f64 = 2.0;

pub(crate) fn log_step_too_long(params: &Params, step: &[f64]) -> bool {
    let nb = n_per_block(params.m);
    (0..3).any(|b| (0..params.m).any(|j| step[b * nb + tri(j, j)].abs() > LOG_STEP_MAX))
}

/// The orthonormal basis the matrix-free modal step works in: the damping modes of the
/// start (C v = γ M v), most damped first, orthonormalised in that order.
///
/// With scalar weights the cost is the same in every orthonormal basis (u, f and the
/// model turned by V: the residual turns with them), but the factors are not: the
/// output-error optimum takes C toward the cone's edge in the least damped directions,
/// which the band hardly sees. In the caller's coordinates that edge is a direction
/// spread over all of C's pivots, approached by the steps in the factors in a long
/// creep; in this basis it lies in the last pivots. Measured (chain, 0.1 % noise,
/// `bench_refine.py` problem): m = 60, 1200 lines, 119–127 → 89 steps and m = 100, 2000
/// lines, 152–156 → 117–121 steps, each to a lower cost (0.141006 against 0.141008–
/// 0.141013, 0.223220 against 0.223276). The undamped modes lowest first took m = 60 to
/// 29 steps but stalled at m = 100 (cost 0.294–0.300), least damped first stalled too
/// (0.2287); the dense step (m ≤ 40) is left in the caller's basis: on the model-order
/// test's ill-conditioned exact data it stopped at 7e-4 from the truth instead of 4e-8.
pub(crate) fn damping_basis(l: &[Mat<f64>; 3]) -> Option<Mat<f64>> {
    use faer::linalg::triangular_solve::{
        solve_lower_triangular_in_place, solve_upper_triangular_in_place,
    };
    let (lm, m) = (&l[0], l[0].nrows());
    // Ĉ = L_M⁻¹ C L_M⁻ᵀ = Q Γ Qᵀ, modes L_M⁻ᵀ Q
    let mut a = gram_lower(&l[1]);
    solve_lower_triangular_in_place(lm.as_ref(), a.as_mut(), Par::Seq);
    let mut a = a.transpose().to_owned();
    solve_lower_triangular_in_place(lm.as_ref(), a.as_mut(), Par::Seq);
    let sym = Mat::from_fn(m, m, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = sym.self_adjoint_eigen(Side::Lower).ok()?;
    // the eigenvalues come in nondecreasing order: most damped first
    let mut modes = Mat::from_fn(m, m, |i, j| evd.U()[(i, m - 1 - j)]);
    solve_upper_triangular_in_place(lm.transpose(), modes.as_mut(), Par::Seq);
    let v = modes.qr().compute_Q();
    let finite = v.col_iter().all(|c| c.iter().all(|x| x.is_finite()));
    finite.then_some(v)
}

/// Each m-vector of `z` (column after column) by Vᵀ, or by V when `back`.
pub(crate) fn rotate_columns(z: &mut [c64], v: MatRef<f64>, back: bool) {
    let m = v.nrows();
    z.par_chunks_mut(m).for_each(|col| {
        let old = col.to_vec();
        for (i, out) in col.iter_mut().enumerate() {
            *out = (0..m)
                .map(|k| old[k] * if back { v[(i, k)] } else { v[(k, i)] })
                .sum();
        }
    });
}

/// The factor L' of the same model in the basis V: L' L'ᵀ = Vᵀ L Lᵀ V (the floor
/// ε tr(L Lᵀ) I is the same in every orthonormal basis).
pub(crate) fn rotated_factor(l: &Mat<f64>, v: MatRef<f64>) -> Result<Mat<f64>, PodidError> {
    let vl = v.transpose() * l;
    let x = &vl * vl.transpose();
    match x.llt(Side::Lower) {
        Ok(f) => Ok(f.L().to_owned()),
        Err(_) => psd_factor(x.as_ref(), 0.0),
    }
}
