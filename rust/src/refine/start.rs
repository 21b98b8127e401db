//! The start of the refinement: the data's scaling ([`scaling_of`]) and the start
//! model made into factors the iteration can move — checked, scaled, the
//! parametrisation's floor taken off, M and K with a tiny eigenvalue floor, and C
//! raised to a least damping ratio ([`damping_floor`]) unless it is a refined model
//! given back ([`start_factors`]).

use super::input::OeData;
use super::parametrisation::{has_condition_floor, psd_factor, CONDITION_FLOOR};
use crate::data::Scaling;
use crate::error::PodidError;
use faer::{c64, Mat, MatRef, Side};

/// The names of the blocks, for messages.
const BLOCKS: [&str; 3] = ["M", "C", "K"];

/// The start matrices must be m×m and finite.
pub(crate) fn check_start(start: &[Mat<f64>; 3], m: usize) -> Result<(), PodidError> {
    for (b, x) in start.iter().enumerate() {
        if x.nrows() != m || x.ncols() != m {
            return Err(PodidError::Invalid(format!(
                "start matrix {} must be {m}×{m}",
                BLOCKS[b]
            )));
        }
        if !(0..m).all(|i| (0..m).all(|j| x[(i, j)].is_finite())) {
            return Err(PodidError::Invalid(format!(
                "start matrix {} contains NaN or inf",
                BLOCKS[b]
            )));
        }
    }
    Ok(())
}

/// The start [M, C, K] in scaled units, as given.
pub(crate) fn scaled_start(start: &[Mat<f64>; 3], scaling: &Scaling) -> [Mat<f64>; 3] {
    let fac = scaling.block_factors();
    let m = start[0].nrows();
    [0, 1, 2].map(|b| Mat::from_fn(m, m, |i, j| start[b][(i, j)] / fac[b]))
}

/// The factors [L_M, L_C, L_K] of the start `scaled` (scaled units, [`scaled_start`]):
/// M and K with a tiny eigenvalue floor; C raised to the least damping ratio
/// [`C_START_FLOOR`], so that no direction starts undamped — its factor would have no
/// gradient to leave 0. The parametrisation adds ε tr(L Lᵀ) I
/// ([`super::parametrisation::gram_lower`]): it is taken off the start first, so that
/// a refined model given back as a start is the same model (X = L Lᵀ + ε tr(L Lᵀ) I
/// has tr X = (1 + mε) tr(L Lᵀ)).
pub(crate) fn start_factors(scaled: &[Mat<f64>; 3]) -> Result<[Mat<f64>; 3], PodidError> {
    let m = scaled[0].nrows();
    let top = |x: &Mat<f64>| {
        (0..m)
            .flat_map(|i| (0..m).map(move |j| (i, j)))
            .map(|(i, j)| x[(i, j)].abs())
            .fold(0.0, f64::max)
    };
    let ref_scale = top(&scaled[0]).max(top(&scaled[2])).max(f64::MIN_POSITIVE);
    let inner: Vec<Mat<f64>> = scaled
        .iter()
        .map(|x| {
            let tr: f64 = (0..m).map(|i| x[(i, i)]).sum();
            let shift = (CONDITION_FLOOR * tr / (1.0 + m as f64 * CONDITION_FLOOR)).max(0.0);
            Mat::from_fn(m, m, |i, j| x[(i, j)] - if i == j { shift } else { 0.0 })
        })
        .collect();
    let mut l = [0, 1, 2].map(|b| {
        if b == 1 {
            return Ok(Mat::zeros(0, 0)); // below, from the floored M and K
        }
        psd_factor(inner[b].as_ref(), 1e-12 * ref_scale)
    });
    if let (Ok(lm), Ok(lk)) = (&l[0], &l[2]) {
        let (mf, kf) = (lm * lm.transpose(), lk * lk.transpose());
        // a C with the parametrisation's own floor ε tr(C) I (a refined model given
        // back) is factored as it is; a singular one (a start made physical by
        // clipping) is raised to the least damping ratio first
        l[1] = if has_condition_floor(scaled[1].as_ref()) {
            psd_factor(inner[1].as_ref(), 1e-12 * ref_scale)
        } else {
            damping_floor(mf.as_ref(), inner[1].as_ref(), kf.as_ref(), C_START_FLOOR)
                .and_then(|c| psd_factor(c.as_ref(), 1e-12 * ref_scale))
        };
    }
    for (b, lb) in l.iter().enumerate() {
        if let Err(e) = lb {
            return Err(PodidError::Invalid(format!(
                "{} of the start: {e}",
                BLOCKS[b]
            )));
        }
    }
    Ok([0, 1, 2].map(|b| std::mem::replace(&mut l[b], Ok(Mat::zeros(0, 0))).unwrap()))
}

/// Least damping ratio of the start (of a C without the parametrisation's floor, see
/// [`has_condition_floor`]): C is raised (where it is lower) so that every
/// direction of Z = (2Ω)^-½ Φᵀ C Φ (2Ω)^-½ — Φ the undamped modes, Ω their
/// frequencies; Z's eigenvalues are damping ratios in modal terms — has at least
/// this much (see [`damping_floor`]).
pub const C_START_FLOOR: f64 = 1e-4;

/// C raised to the least damping ratio ζ₀ (scaled units; M, K ≻ 0): with the
/// mass-normalised undamped modes Φ = M^-½ V (V the eigenvectors of M^-½ K M^-½,
/// eigenvalues Ω²), Z = (2Ω)^-½ Φᵀ C Φ (2Ω)^-½ has its eigenvalues raised to ζ₀ and
/// C = Φ⁻ᵀ (2Ω)^½ Z (2Ω)^½ Φ⁻¹ formed back. A C that already has ζ₀ everywhere is
/// returned as it is. (A floor relative to the largest entry of M or K instead — the
/// earlier rule — added damping of ζ ~ 1 to a measured beam's modes, whose K spans
/// decades: the refinement then started far from its start.)
pub fn damping_floor(
    mass: MatRef<f64>,
    damping: MatRef<f64>,
    stiffness: MatRef<f64>,
    zeta0: f64,
) -> Result<Mat<f64>, PodidError> {
    let m = mass.nrows();
    let eig = |x: &Mat<f64>| {
        let sym = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
        sym.self_adjoint_eigen(Side::Lower)
            .map_err(|e| PodidError::Invalid(format!("eigendecomposition failed: {e:?}")))
    };
    let scaled = |q: MatRef<f64>, d: &dyn Fn(usize) -> f64| {
        Mat::from_fn(m, m, |i, j| {
            (0..m).map(|k| q[(i, k)] * d(k) * q[(j, k)]).sum::<f64>()
        })
    };
    let em = eig(&mass.to_owned())?;
    let (qm, dm) = (em.U(), em.S().column_vector());
    if (0..m).any(|k| dm[k] <= 0.0 || !dm[k].is_finite()) {
        return Err(PodidError::Invalid(
            "M of the start is not positive definite".into(),
        ));
    }
    let m_half = scaled(qm, &|k| dm[k].sqrt());
    let m_inv_half = scaled(qm, &|k| 1.0 / dm[k].sqrt());
    let a = &m_inv_half * stiffness * &m_inv_half;
    let ek = eig(&a)?;
    let (v, w2) = (ek.U(), ek.S().column_vector());
    let wmax = (0..m).map(|k| w2[k].max(0.0).sqrt()).fold(0.0, f64::max);
    let floor = 1e-6 * wmax.max(f64::MIN_POSITIVE);
    // (2Ω)^½ per mode
    let d: Vec<f64> = (0..m)
        .map(|k| (2.0 * w2[k].max(0.0).sqrt().max(floor)).sqrt())
        .collect();
    let phi = &m_inv_half * v;
    let cm = phi.transpose() * damping * &phi;
    let z = Mat::from_fn(m, m, |i, j| cm[(i, j)] / (d[i] * d[j]));
    let ez = eig(&z)?;
    let (qz, dz) = (ez.U(), ez.S().column_vector());
    if (0..m).all(|k| dz[k] >= zeta0) {
        return Ok(damping.to_owned());
    }
    let zr = scaled(qz, &|k| dz[k].max(zeta0));
    let dzd = Mat::from_fn(m, m, |i, j| d[i] * zr[(i, j)] * d[j]);
    // Φ⁻ᵀ = M^½ V
    let left = &m_half * v;
    let c = &left * &dzd * left.transpose();
    Ok(Mat::from_fn(m, m, |i, j| 0.5 * (c[(i, j)] + c[(j, i)])))
}

/// Scaling of the data: ω0 = RMS ω, s_u = RMS |u|, s_f = RMS |f| (1 where a scale is 0),
/// so that the refinement works on O(1) numbers.
pub(crate) fn scaling_of(data: &OeData) -> Scaling {
    let nz = |x: f64| if x > 0.0 && x.is_finite() { x } else { 1.0 };
    let rms = |z: &[c64]| {
        let top = z
            .iter()
            .map(|v| v.re.abs().max(v.im.abs()))
            .fold(0.0, f64::max);
        if top == 0.0 {
            return 0.0;
        }
        top * (z.iter().map(|v| (v / top).norm_sqr()).sum::<f64>() / z.len() as f64).sqrt()
    };
    let w2 = data.omega.iter().map(|w| w * w).sum::<f64>() / data.s() as f64;
    Scaling {
        omega0: nz(w2.sqrt()),
        su: nz(rms(data.u)),
        sf: nz(rms(data.f)),
    }
}
