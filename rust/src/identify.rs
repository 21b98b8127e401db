//! The whole direct identification: scale, Gram products, normal equations in
//! the symmetric/skew basis, solve, map back to M, C, K in the caller's units.

use crate::buffer::DenseBuf;
use crate::data::{scaled, unscale, Columns};
use crate::direct::{cholesky_solve, eigen_min_norm_solve, Solution};
use crate::error::PodidError;
use crate::gram::{gram, Gram};
use crate::normal::{n_unknowns, Basis};
use crate::residual::residual_norm;
use crate::solution::{check_lam, Identified};
use faer::{Mat, Par};
use std::time::Instant;

/// True when no block is penalised: the problem splits into m rows sharing H.
fn unregularised(lam: [f64; 3], symmetric: bool) -> bool {
    !symmetric && lam.iter().all(|&l| l == 0.0)
}

/// Bytes of the largest dense matrix the direct path allocates.
pub fn dense_bytes(m: usize, lam: [f64; 3], symmetric: bool) -> u128 {
    let m = m as u128;
    let n = if unregularised(lam, symmetric) {
        3 * m
    } else if symmetric {
        3 * m * (m + 1) / 2
    } else {
        3 * m * m
    };
    n * n * 8
}

/// Solve with Cholesky, falling back to the minimum-norm eigen solution.
/// Returns the solution and the time spent forming G.
fn solve_dense(
    form: impl Fn(&mut [f64]),
    n: usize,
    rhs: &[f64],
    par: Par,
    what: &str,
) -> Result<(Solution, f64), PodidError> {
    let start = Instant::now();
    let mut g = DenseBuf::zeroed(n * n, what)?;
    form(&mut g);
    let form_seconds = start.elapsed().as_secs_f64();
    if let Some(sol) = cholesky_solve(&mut g, n, rhs, par) {
        return Ok((sol, form_seconds));
    }
    // the factor overwrote g: form it again for the rank-revealing solve
    g.iter_mut().for_each(|v| *v = 0.0);
    form(&mut g);
    let sol = eigen_min_norm_solve(&g, n, rhs).map_err(PodidError::Invalid)?;
    Ok((sol, form_seconds))
}

/// λ = 0 everywhere: Z H = B, one 3m×3m factorisation for all m rows.
fn solve_rows(gm: &Gram, m: usize, par: Par) -> Result<(Mat<f64>, Solution, f64), PodidError> {
    let n = 3 * m;
    let h = &gm.h;
    let form = |g: &mut [f64]| {
        for j in 0..n {
            for i in 0..n {
                g[j * n + i] = h[(i, j)];
            }
        }
    };
    // columns of Bᵀ are the rows of B
    let rhs: Vec<f64> = (0..m)
        .flat_map(|r| (0..n).map(move |c| gm.b[(r, c)]))
        .collect();
    let (mut sol, form_seconds) = solve_dense(form, n, &rhs, par, "the 3m×3m Gram matrix")?;
    let z = Mat::from_fn(m, n, |r, c| sol.x[r * n + c]);
    sol.rank *= m;
    Ok((z, sol, form_seconds))
}

/// General case: the full normal matrix in the symmetric/skew basis.
fn solve_coords(
    gm: &Gram,
    m: usize,
    lam_scaled: [f64; 3],
    symmetric: bool,
    par: Par,
) -> Result<(Mat<f64>, Solution, f64), PodidError> {
    let basis = Basis::new(m, symmetric);
    let n = basis.len();
    let rhs = basis.rhs(gm.b.as_ref());
    let form = |g: &mut [f64]| basis.assemble(gm.h.as_ref(), lam_scaled, g);
    let what = format!("the {n}×{n} normal matrix");
    let (sol, form_seconds) = solve_dense(form, n, &rhs, par, &what)?;
    Ok((basis.to_blocks(&sol.x), sol, form_seconds))
}

/// Identify M, C, K from the columns (paper eq. 49, solved in the symmetric/skew
/// basis). `lam` is (λ_M, λ_C, λ_K) in the paper's units; `symmetric` is the
/// exact λ → ∞ limit.
pub fn identify(
    cols: &Columns,
    lam: [f64; 3],
    symmetric: bool,
    par: Par,
) -> Result<Identified, PodidError> {
    check_lam(lam)?;
    let start = Instant::now();
    let m = cols.m;
    let (scaling, gm) = scaled(cols, |data| gram(data, par));
    let gram_seconds = start.elapsed().as_secs_f64();
    let (z, sol, form_seconds) = if unregularised(lam, symmetric) {
        solve_rows(&gm, m, par)?
    } else {
        solve_coords(&gm, m, scaling.scaled_lam(lam), symmetric, par)?
    };
    drop(gm);
    let t = Instant::now();
    let residual_norm = residual_norm(cols, &scaling, z.as_ref());
    let residual_seconds = t.elapsed().as_secs_f64();
    Ok(Identified {
        mck: unscale(z.as_ref(), &scaling),
        method: sol.method,
        rank: sol.rank,
        n_unknowns: n_unknowns(m, symmetric),
        min_pivot_ratio: sol.min_pivot_ratio,
        scaling,
        timings: vec![
            ("gram", gram_seconds),
            ("form", form_seconds),
            ("factor", sol.factor_seconds),
            ("residual", residual_seconds),
            ("total", start.elapsed().as_secs_f64()),
        ],
        cg: None,
        residual_norm,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::direct::Method;
    use faer::c64;
    use faer::prelude::Solve;

    /// A small non-symmetric system with exact data: every mode recovers it.
    pub(crate) fn truth(m: usize) -> [Mat<f64>; 3] {
        let mm = Mat::from_fn(m, m, |i, j| {
            if i == j {
                1.0 + i as f64
            } else {
                0.1 / (1 + i + 2 * j) as f64
            }
        });
        let cc = Mat::from_fn(m, m, |i, j| {
            if i == j {
                2.0
            } else {
                0.05 * (i as f64 - j as f64)
            }
        });
        let kk = Mat::from_fn(m, m, |i, j| {
            if i == j {
                400.0
            } else if i.abs_diff(j) == 1 {
                -100.0
            } else {
                0.0
            }
        });
        [mm, cc, kk]
    }

    /// u_i = D(ω_i)⁻¹ f_i for m load cases per line with unit forces.
    pub(crate) fn data(t: &[Mat<f64>; 3], omegas: &[f64]) -> (Vec<c64>, Vec<c64>, Vec<f64>) {
        let m = t[0].nrows();
        let (mut u, mut f, mut w) = (Vec::new(), Vec::new(), Vec::new());
        for &om in omegas {
            let d = Mat::from_fn(m, m, |i, j| {
                c64::new(-om * om * t[0][(i, j)] + t[2][(i, j)], om * t[1][(i, j)])
            });
            let lu = d.partial_piv_lu();
            for load in 0..m {
                let mut rhs = Mat::<c64>::zeros(m, 1);
                rhs[(load, 0)] = c64::new(1.0, 0.5);
                let sol = lu.solve(&rhs);
                for i in 0..m {
                    u.push(sol[(i, 0)]);
                    f.push(rhs[(i, 0)]);
                }
                w.push(om);
            }
        }
        (u, f, w)
    }

    pub(crate) fn rel_err(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        (a - b).norm_l2() / b.norm_l2()
    }

    #[test]
    fn exact_data_recovers_truth_without_regularisation() {
        let m = 4;
        let t = truth(m);
        let omegas: Vec<f64> = (0..12).map(|i| 3.0 + 2.0 * i as f64).collect();
        let (u, f, w) = data(&t, &omegas);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        let id = identify(&cols, [0.0; 3], false, Par::Seq).unwrap();
        assert_eq!(id.method, Method::Cholesky);
        for (b, (x, want)) in id.mck.iter().zip(&t).enumerate() {
            assert!(rel_err(x, want) < 1e-10, "block {b}");
        }
        // the general assembly with λ = (0, 0, tiny) gives the same answer
        let id2 = identify(&cols, [0.0, 0.0, 1e-300], false, Par::Seq).unwrap();
        for (b, (x, want)) in id2.mck.iter().zip(&t).enumerate() {
            assert!(rel_err(x, want) < 1e-10, "block {b}");
        }
    }

    #[test]
    fn symmetric_mode_returns_symmetric_matrices() {
        let m = 3;
        let mut t = truth(m);
        for x in t.iter_mut() {
            *x = Mat::from_fn(m, m, |i, j| 0.5 * (x[(i, j)] + x[(j, i)]));
        }
        let omegas: Vec<f64> = (0..10).map(|i| 4.0 + 3.0 * i as f64).collect();
        let (u, f, w) = data(&t, &omegas);
        let cols = Columns::new(&u, &f, &w, m).unwrap();
        for (lam, sym) in [([0.0; 3], true), ([100.0; 3], false)] {
            let id = identify(&cols, lam, sym, Par::Seq).unwrap();
            for (b, (x, want)) in id.mck.iter().zip(&t).enumerate() {
                assert!(rel_err(x, want) < 1e-10, "block {b} sym={sym}");
                if sym {
                    assert_eq!(x, &x.transpose().to_owned());
                }
            }
        }
    }

    #[test]
    fn dense_bytes_does_not_wrap() {
        assert_eq!(dense_bytes(100, [1.0; 3], false), 30_000u128 * 30_000 * 8);
        assert_eq!(dense_bytes(100, [0.0; 3], false), 300u128 * 300 * 8);
        assert!(dense_bytes(usize::MAX / 2, [1.0; 3], true) > u64::MAX as u128);
    }

    #[test]
    fn too_little_data_is_flagged_rank_deficient() {
        let m = 4;
        let t = truth(m);
        let (u, f, w) = data(&t, &[5.0]);
        // one line × one load case: 2·4 real equations per row for 12 unknowns
        let cols = Columns::new(&u[..m], &f[..m], &w[..1], m).unwrap();
        let id = identify(&cols, [0.0; 3], false, Par::Seq).unwrap();
        assert_eq!(id.method, Method::EigenMinNorm);
        assert!(id.rank < id.n_unknowns);
    }
}
