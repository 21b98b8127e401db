//! Direct solution of the symmetric normal equations G x = b.
//!
//! First choice: faer's Cholesky in place (no second copy of G). If a pivot is
//! non-positive, or so small relative to its diagonal entry that the factor is
//! numerically rank deficient, the caller re-forms G and takes the
//! minimum-norm solution from its eigendecomposition, reporting the numerical
//! rank — never a silent answer from a singular factor.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{MatMut, MatRef, Par, Side};

/// How the system was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Cholesky,
    /// minimum-norm solution from the eigendecomposition (rank deficient G)
    EigenMinNorm,
    /// matrix-free preconditioned conjugate gradients ([`crate::cg`]); the rank
    /// is not measured
    ConjugateGradient,
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Cholesky => "cholesky",
            Method::EigenMinNorm => "eigen-min-norm",
            Method::ConjugateGradient => "cg",
        }
    }
}

#[derive(Clone, Debug)]
pub struct Solution {
    pub x: Vec<f64>,
    pub method: Method,
    /// numerical rank of G (n when Cholesky succeeded)
    pub rank: usize,
    /// min over i of L_ii² / G_ii: near 1 for a well-conditioned G, and a lower
    /// bound on 1/cond(G) up to a modest factor
    pub min_pivot_ratio: f64,
    /// wall time of the factorisation (Cholesky or eigendecomposition), seconds
    pub factor_seconds: f64,
}

/// Pivots below this fraction of their diagonal entry count as zero: n·ε.
pub fn pivot_tolerance(n: usize) -> f64 {
    (n.max(1) as f64) * f64::EPSILON
}

/// Cholesky of G (column-major n×n, lower triangle read) in place, then solve for
/// the right-hand sides b (column-major n×k). Returns `None` when G is not
/// numerically positive definite.
pub fn cholesky_solve(g: &mut [f64], n: usize, b: &[f64], par: Par) -> Option<Solution> {
    assert_eq!(g.len(), n * n);
    assert!(n > 0 && b.len().is_multiple_of(n));
    let nrhs = b.len() / n;
    let diag: Vec<f64> = (0..n).map(|i| g[i * n + i]).collect();
    if diag.iter().any(|d| d.is_nan() || *d <= 0.0) {
        return None;
    }
    let start = std::time::Instant::now();
    let mut a = MatMut::from_column_major_slice_mut(g, n, n);
    let params = Default::default();
    let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
        n, par, params,
    ));
    let ok = llt::factor::cholesky_in_place(
        a.as_mut(),
        Default::default(),
        par,
        MemStack::new(&mut mem),
        params,
    );
    if ok.is_err() {
        return None;
    }
    let factor_seconds = start.elapsed().as_secs_f64();
    let min_ratio = (0..n)
        .map(|i| a[(i, i)] * a[(i, i)] / diag[i])
        .fold(f64::INFINITY, f64::min);
    if min_ratio.is_nan() || min_ratio <= pivot_tolerance(n) {
        return None;
    }
    let mut x = b.to_vec();
    let rhs = MatMut::from_column_major_slice_mut(&mut x, n, nrhs);
    let mut mem = MemBuffer::new(llt::solve::solve_in_place_scratch::<f64>(n, nrhs, par));
    llt::solve::solve_in_place(a.as_ref(), rhs, par, MemStack::new(&mut mem));
    Some(Solution {
        x,
        method: Method::Cholesky,
        rank: n,
        min_pivot_ratio: min_ratio,
        factor_seconds,
    })
}

/// Minimum-norm solution x = Σ_{σ_i > tol} q_i q_iᵀ b / σ_i from the symmetric
/// eigendecomposition of G (lower triangle read), tol = n·ε·σ_max, for the
/// right-hand sides b (column-major n×k).
pub fn eigen_min_norm_solve(g: &[f64], n: usize, b: &[f64]) -> Result<Solution, String> {
    assert!(n > 0 && b.len().is_multiple_of(n));
    let start = std::time::Instant::now();
    let a = MatRef::from_column_major_slice(g, n, n);
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| format!("eigendecomposition of the normal matrix failed: {e:?}"))?;
    let factor_seconds = start.elapsed().as_secs_f64();
    let (u, s) = (evd.U(), evd.S().column_vector());
    let smax = (0..n).map(|i| s[i].abs()).fold(0.0, f64::max);
    let tol = pivot_tolerance(n) * smax;
    let mut x = vec![0.0; b.len()];
    let rank = (0..n).filter(|&i| s[i] > tol).count();
    for (xc, bc) in x.chunks_mut(n).zip(b.chunks(n)) {
        for i in (0..n).filter(|&i| s[i] > tol) {
            let coef = (0..n).map(|r| u[(r, i)] * bc[r]).sum::<f64>() / s[i];
            for (r, xr) in xc.iter_mut().enumerate() {
                *xr += coef * u[(r, i)];
            }
        }
    }
    let smin = (0..n).map(|i| s[i]).fold(f64::INFINITY, f64::min);
    Ok(Solution {
        x,
        method: Method::EigenMinNorm,
        rank,
        min_pivot_ratio: if smax > 0.0 {
            smin.max(0.0) / smax
        } else {
            0.0
        },
        factor_seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd(n: usize) -> Vec<f64> {
        // G = Aᵀ A + I with a fixed A
        let a: Vec<f64> = (0..n * n)
            .map(|i| ((i * 7 + 3) % 11) as f64 / 11.0 - 0.5)
            .collect();
        let mut g = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let s: f64 = (0..n).map(|k| a[k * n + i] * a[k * n + j]).sum();
                g[j * n + i] = s + if i == j { 1.0 } else { 0.0 };
            }
        }
        g
    }

    fn matvec(g: &[f64], n: usize, x: &[f64]) -> Vec<f64> {
        (0..n)
            .map(|i| (0..n).map(|j| g[j * n + i] * x[j]).sum())
            .collect()
    }

    #[test]
    fn cholesky_solves_spd_system() {
        let n = 40;
        let g = spd(n);
        let xt: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let b = matvec(&g, n, &xt);
        let mut work = g.clone();
        let sol = cholesky_solve(&mut work, n, &b, Par::Seq).expect("SPD");
        assert_eq!(sol.method, Method::Cholesky);
        for (a, e) in sol.x.iter().zip(&xt) {
            assert!((a - e).abs() < 1e-12);
        }
    }

    #[test]
    fn singular_system_falls_back_to_min_norm() {
        // G = diag(2, 1, 0): Cholesky refuses, min-norm gives x3 = 0
        let n = 3;
        let g = vec![2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let b = [4.0, 3.0, 0.0];
        assert!(cholesky_solve(&mut g.clone(), n, &b, Par::Seq).is_none());
        let sol = eigen_min_norm_solve(&g, n, &b).unwrap();
        assert_eq!(sol.rank, 2);
        assert!((sol.x[0] - 2.0).abs() < 1e-14 && (sol.x[1] - 3.0).abs() < 1e-14);
        assert!(sol.x[2].abs() < 1e-14);
    }

    #[test]
    fn nearly_singular_pivot_is_refused() {
        // rank-one 2×2 [[1,1],[1,1+1e-17]] rounds to exactly singular
        let n = 2;
        let mut g = vec![1.0, 1.0, 1.0, 1.0 + 1e-17];
        assert!(cholesky_solve(&mut g, n, &[1.0, 1.0], Par::Seq).is_none());
    }
}
