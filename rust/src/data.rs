//! Measured columns (u_i, f_i, ω_i) and their scaling (docs/design.md §3).
//!
//! The data are N = s·p complex response vectors u_i ∈ Cᵐ with forces f_i and
//! angular frequencies ω_i, stored frequency-first (row i is column i of the
//! paper's U). Before any Gram product we scale ω by ω0 (RMS of ω) and U, F by
//! their RMS, so that every matrix formed later is O(1); λ and the answer are
//! converted with [`Scaling`].

use crate::error::PodidError;
use faer::{c64, Mat, MatRef};
use rayon::prelude::*;

/// Borrowed, validated measurement columns.
#[derive(Clone, Copy)]
pub struct Columns<'a> {
    /// responses, row-major (N, m)
    pub u: &'a [c64],
    /// forces, row-major (N, m)
    pub f: &'a [c64],
    /// angular frequency of each row (N,)
    pub omega: &'a [f64],
    pub m: usize,
}

impl<'a> Columns<'a> {
    pub fn new(u: &'a [c64], f: &'a [c64], omega: &'a [f64], m: usize) -> Result<Self, PodidError> {
        let n = omega.len();
        if m == 0 || n == 0 {
            return Err(PodidError::Invalid(format!(
                "empty data: N = {n} columns of order m = {m}"
            )));
        }
        if u.len() != n * m || f.len() != n * m {
            return Err(PodidError::Invalid(format!(
                "U and F must both hold N·m = {}·{} values; got {} and {}",
                n,
                m,
                u.len(),
                f.len()
            )));
        }
        let finite = |z: &c64| z.re.is_finite() && z.im.is_finite();
        if !u.iter().all(finite) || !f.iter().all(finite) {
            return Err(PodidError::Invalid("U or F contains NaN or inf".into()));
        }
        if !omega.iter().all(|w| w.is_finite() && *w > 0.0) {
            return Err(PodidError::Invalid(
                "omega must be finite and strictly positive".into(),
            ));
        }
        Ok(Self { u, f, omega, m })
    }

    /// Number of complex response vectors N.
    pub fn len(&self) -> usize {
        self.omega.len()
    }

    pub fn is_empty(&self) -> bool {
        self.omega.is_empty()
    }
}

/// Reference scales: ω = ω0·ω̃, U = s_u·Ũ, F = s_f·F̃.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    pub omega0: f64,
    pub su: f64,
    pub sf: f64,
}

/// RMS of |z|, computed on z / max|z| so that it cannot overflow (|z| up to f64::MAX).
fn rms_c(z: &[c64]) -> f64 {
    let top = z
        .iter()
        .map(|v| v.re.abs().max(v.im.abs()))
        .fold(0.0, f64::max);
    if top == 0.0 || !top.is_finite() {
        return top;
    }
    let s: f64 = z.iter().map(|v| (v / top).norm_sqr()).sum();
    top * (s / z.len() as f64).sqrt()
}

impl Scaling {
    /// No scaling at all (used to test the Gram products against plain NumPy).
    pub const IDENTITY: Scaling = Scaling {
        omega0: 1.0,
        su: 1.0,
        sf: 1.0,
    };

    /// ω0 = RMS of ω, s_u = RMS of |U|, s_f = RMS of |F| (1 where a scale is 0).
    pub fn of(cols: &Columns) -> Scaling {
        let nz = |x: f64| if x > 0.0 && x.is_finite() { x } else { 1.0 };
        let w2: f64 = cols.omega.iter().map(|w| w * w).sum::<f64>() / cols.len() as f64;
        Scaling {
            omega0: nz(w2.sqrt()),
            su: nz(rms_c(cols.u)),
            sf: nz(rms_c(cols.f)),
        }
    }

    /// Factor c_b with X_b = c_b·X̃_b for blocks b = M, C, K:
    /// s_f/(s_u ω0²), s_f/(s_u ω0), s_f/s_u.
    pub fn block_factors(&self) -> [f64; 3] {
        let base = self.sf / self.su;
        [base / (self.omega0 * self.omega0), base / self.omega0, base]
    }

    /// λ in the scaled problem: λ̃_b = λ_b·c_b/s_f, i.e. λ_M/(s_u ω0²), λ_C/(s_u ω0), λ_K/s_u.
    pub fn scaled_lam(&self, lam: [f64; 3]) -> [f64; 3] {
        let c = self.block_factors();
        [0, 1, 2].map(|b| lam[b] * c[b] / self.sf)
    }
}

/// Scaled real stacked data: Y = [Re U; Im U]/s_u and G = [Re F; Im F]/s_f, both
/// (2N × m), and w = ω/ω0 (N).
pub struct Stacked {
    pub y: Mat<f64>,
    pub g: Mat<f64>,
    pub w: Vec<f64>,
}

/// [Re Z; Im Z]·scale (2n×m, column-major) of Z given line by line (n×m,
/// row-major), by blocks of columns: each line's run of the block is read once
/// (the entry-by-entry fill read one entry per cache line, a column apart).
fn stack(z: &[c64], n: usize, m: usize, scale: f64) -> Mat<f64> {
    const COLS: usize = 16;
    let mut out = Mat::zeros(2 * n, m);
    out.as_mut()
        .par_col_chunks_mut(COLS)
        .enumerate()
        .for_each(|(k, mut blk)| {
            let c0 = k * COLS;
            for r in 0..n {
                for (j, v) in z[r * m + c0..r * m + c0 + blk.ncols()].iter().enumerate() {
                    blk[(r, j)] = scale * v.re;
                    blk[(n + r, j)] = scale * v.im;
                }
            }
        });
    out
}

impl Stacked {
    pub fn new(cols: &Columns, sc: &Scaling) -> Stacked {
        let (n, m) = (cols.len(), cols.m);
        let (iu, iff) = (1.0 / sc.su, 1.0 / sc.sf);
        let (y, g) = rayon::join(|| stack(cols.u, n, m, iu), || stack(cols.f, n, m, iff));
        let w = cols.omega.iter().map(|w| w / sc.omega0).collect();
        Stacked { y, g, w }
    }
}

/// Scale the columns ([`Scaling::of`]) and apply `products` (the Gram products:
/// [`crate::gram::gram`], or [`crate::gram::gram_blocks`]) to the scaled, stacked data.
pub(crate) fn scaled<T>(cols: &Columns, products: impl FnOnce(&Stacked) -> T) -> (Scaling, T) {
    let scaling = Scaling::of(cols);
    let out = products(&Stacked::new(cols, &scaling));
    (scaling, out)
}

/// M, C, K in the caller's units from the scaled Z = [X_M X_C X_K] (m×3m).
pub(crate) fn unscale(z: MatRef<f64>, scaling: &Scaling) -> [Mat<f64>; 3] {
    let m = z.nrows();
    let f = scaling.block_factors();
    [0, 1, 2].map(|b| Mat::from_fn(m, m, |i, j| f[b] * z[(i, b * m + j)]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stacked data by column blocks equal the entry-by-entry definition
    /// (m across the block width, several lines).
    #[test]
    fn stacked_data_are_real_then_imaginary_parts_scaled() {
        for (n, m) in [(1, 1), (3, 15), (5, 16), (4, 37)] {
            let z: Vec<c64> = (0..n * m)
                .map(|k| c64::new(k as f64 - 3.5, 0.25 * k as f64 + 1.0))
                .collect();
            let got = stack(&z, n, m, 0.5);
            for r in 0..2 * n {
                for c in 0..m {
                    let v = z[(r % n) * m + c];
                    let want = 0.5 * if r < n { v.re } else { v.im };
                    assert_eq!(got[(r, c)], want, "n = {n}, m = {m}, ({r}, {c})");
                }
            }
        }
    }

    #[test]
    fn scales_do_not_overflow_or_underflow() {
        for big in [1e-300, 1.0, 1e200, 1e300] {
            let u = [c64::new(3.0 * big, 4.0 * big), c64::new(0.0, 0.0)];
            let rms = rms_c(&u);
            assert!(
                (rms / big - 5.0 / 2f64.sqrt()).abs() < 1e-14,
                "{big}: {rms}"
            );
        }
    }
}
