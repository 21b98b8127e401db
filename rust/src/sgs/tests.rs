//! Tests of the Gauss–Seidel solves: they split the operator as Eisenstat's trick
//! needs, do not depend on the thread count or the AVX2 build, and the fused factor
//! products match separate ones.

use super::*;
use crate::cg::Operator;
use crate::gram::random_blocks;
use crate::pairs::Layout;
use crate::precond::PairPrecond;
use faer::{Mat, Par};

/// Columns f(e_q) of a linear map on packed vectors.
fn matrix(n: usize, mut f: impl FnMut(&[f64], &mut [f64])) -> Mat<f64> {
    let mut a = Mat::zeros(n, n);
    let (mut e, mut out) = (vec![0.0; n], vec![0.0; n]);
    for q in 0..n {
        e.iter_mut().for_each(|v| *v = 0.0);
        e[q] = 1.0;
        f(&e, &mut out);
        for (p, v) in out.iter().enumerate() {
            a[(p, q)] = *v;
        }
    }
    a
}

/// With S_f = (D + L)⁻¹ and S_b = (D + Lᵀ)⁻¹ as the two solves: S_b = S_fᵀ,
/// and G = (D + L) + (D + Lᵀ) − D for the operator G (checked as
/// S_b + S_f − S_b D S_f = S_b G S_f), which is what Eisenstat's trick needs;
/// the returned lower terms are r − D y. Sizes across several leaves and
/// odd splits (and whole tiles only, 3·LEAF), both modes, a penalty 10⁶ above
/// the data.
#[test]
fn triangular_solves_split_the_operator() {
    for m in [1, 2, 5, LEAF + 3, 3 * LEAF, 2 * LEAF + 3, 4 * LEAF + 1] {
        let h = random_blocks(m, 7);
        for (symmetric, pen) in [(true, [0.0; 3]), (false, [0.3, 2.0, 1e6])] {
            let lay = Layout::new(m, symmetric);
            let n = lay.len();
            let pre = PairPrecond::new(&h, lay, pen);
            let mut sgs = Sgs::new(&h, lay, Par::Seq);
            sgs.fork = LEAF + 1; // exercise the parallel branches
            let mut op = Operator::new(&h, lay, pen, Par::Seq);
            let mut work = SgsWork::new(m);
            let mut lower = vec![0.0; n];
            let mut worst = 0.0f64;
            let mut solve = |backward: bool| {
                matrix(n, |r, y| {
                    sgs.solve(&pre, r, y, Some(&mut lower), backward, &mut work);
                    // lower = r − D y
                    let mut t = vec![0.0; n];
                    let mut dy = vec![0.0; n];
                    pre.mul_factor(y, &mut t, true);
                    pre.mul_factor(&t, &mut dy, false);
                    for ((l, r), d) in lower.iter().zip(r).zip(&dy) {
                        worst = worst.max((l - (r - d)).abs());
                    }
                })
            };
            let sf = solve(false);
            let sb = solve(true);
            assert!(
                worst < 1e-4,
                "m={m} sym={symmetric}: lower terms off by {worst}"
            );
            let d = matrix(n, |v, out| {
                let mut t = vec![0.0; n];
                pre.mul_factor(v, &mut t, true);
                pre.mul_factor(&t, out, false);
            });
            let g = matrix(n, |v, out| op.apply(v, out));
            let size = sf.norm_max();
            // single-precision couplings: relative 1e-5
            let tr = (&sb - sf.transpose()).norm_max();
            assert!(tr < 1e-5 * size, "m={m} sym={symmetric}: S_b − S_fᵀ = {tr}");
            let lhs = &sb + &sf - &sb * &d * &sf;
            let rhs = &sb * &g * &sf;
            let err = (&lhs - &rhs).norm_max();
            assert!(err < 1e-4 * rhs.norm_max(), "m={m} sym={symmetric}: {err}");
        }
    }
}

/// The solves do the same arithmetic on any number of threads, with either
/// build of the leaves.
#[test]
fn solves_do_not_depend_on_the_thread_count() {
    let m = 9 * LEAF + 5;
    let h = random_blocks(m, 7);
    for (symmetric, pen) in [(true, [0.0; 3]), (false, [0.3, 2.0, 1e6])] {
        let lay = Layout::new(m, symmetric);
        let pre = PairPrecond::new(&h, lay, pen);
        let mut sgs = Sgs::new(&h, lay, Par::rayon(0));
        sgs.fork = 2 * LEAF;
        sgs.split_flops = 1e3; // exercise the products cut into tasks
        let (r, t) = (vector(lay.len(), 3), vector(lay.len(), 4));
        // each direction with each kind of ends (the leaves are compiled per kind)
        let run = |sgs: &Sgs, threads: usize| {
            crate::with_threads(threads, || {
                let mut work = SgsWork::new(m);
                let mut out = Vec::new();
                for backward in [false, true] {
                    for ends in [Ends::Plain, Ends::FactorIn, Ends::FactorOut(Some(&t))] {
                        let n = lay.len();
                        let (mut y, mut l, mut rt) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                        let (lo, rto) = (Some(&mut l[..]), Some(&mut rt[..]));
                        sgs.solve_with(&pre, &r, &mut y, lo, rto, backward, ends, &mut work);
                        out.push((y, l, rt));
                    }
                }
                out
            })
        };
        let two = run(&sgs, 2);
        assert_eq!(run(&sgs, 1), two, "symmetric={symmetric}");
        // and the AVX2 build of the leaves does the baseline's arithmetic
        sgs.simd = false;
        assert_eq!(run(&sgs, 2), two, "symmetric={symmetric}, baseline leaves");
    }
}

/// The per-pair products fused into the solves are those of `mul_factor`.
#[test]
fn fused_factor_products_match_separate_ones() {
    let m = 2 * LEAF + 3;
    let h = random_blocks(m, 7);
    for (symmetric, pen) in [(true, [0.0; 3]), (false, [0.3, 2.0, 1e6])] {
        let lay = Layout::new(m, symmetric);
        let n = lay.len();
        let pre = PairPrecond::new(&h, lay, pen);
        let sgs = Sgs::new(&h, lay, Par::Seq);
        let mut work = SgsWork::new(m);
        let (r, t) = (vector(n, 1), vector(n, 2));
        let close = |a: &[f64], b: &[f64]| {
            let d = a
                .iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max);
            let s = b.iter().map(|x| x.abs()).fold(0.0, f64::max);
            assert!(d <= 1e-12 * s, "symmetric={symmetric}: {d} vs {s}");
        };
        // FactorIn: the solve of R r, and Rᵀ y
        let mut rr = vec![0.0; n];
        pre.mul_factor(&r, &mut rr, false);
        let (mut a, mut b, mut rty) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        sgs.solve(&pre, &rr, &mut a, None, false, &mut work);
        let ends = Ends::FactorIn;
        sgs.solve_with(
            &pre,
            &r,
            &mut b,
            None,
            Some(&mut rty),
            false,
            ends,
            &mut work,
        );
        close(&b, &a);
        let mut want = vec![0.0; n];
        pre.mul_factor(&a, &mut want, true);
        close(&rty, &want);
        // FactorOut: Rᵀ y + s
        sgs.solve(&pre, &r, &mut a, None, true, &mut work);
        pre.mul_factor(&a, &mut want, true);
        let sum: Vec<f64> = want.iter().zip(&t).map(|(y, t)| y + t).collect();
        let ends = Ends::FactorOut(Some(&t));
        sgs.solve_with(&pre, &r, &mut b, None, None, true, ends, &mut work);
        close(&b, &sum);
    }
}

fn vector(n: usize, seed: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (((i * 31 + seed * 17) % 23) as f64 - 11.0) / 7.0)
        .collect()
}
