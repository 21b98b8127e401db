//! Time one application of the CG preconditioner at order m: the two triangular
//! solves of the Gauss–Seidel split with the per-pair factor products, as
//! `cg::pcg` runs them each iteration, in both modes (exact-symmetric, and the
//! penalty mode with a penalty 10⁶ above the data). H̃ of random data; the
//! checksum shows whether a change altered the arithmetic.
//!
//! cargo run --release --example sgs_apply -- [m=1000] [threads=1] [repeats=5]
//!
//! The environment variables SGS_FORK, SGS_SPLIT_FLOPS and SGS_SPLIT_DEPTH
//! override the solves' task knobs ([`Sgs::fork`], [`Sgs::split_flops`],
//! [`Sgs::split_depth`]).

use faer::Par;
use podid_rs::gram::random_blocks;
use podid_rs::pairs::Layout;
use podid_rs::precond::PairPrecond;
use podid_rs::sgs::{Ends, Sgs, SgsWork};
use std::time::Instant;

fn main() {
    let arg = |i: usize, default: usize| {
        std::env::args()
            .nth(i)
            .map_or(default, |s| s.parse().expect("an integer"))
    };
    let (m, threads, repeats) = (arg(1, 1000), arg(2, 1), arg(3, 5));
    let knob = |name: &str| {
        std::env::var(name)
            .ok()
            .map(|s| s.parse::<f64>().expect("a number"))
    };
    let h = random_blocks(m, 1);
    for (symmetric, pen) in [(true, [0.0; 3]), (false, [0.3, 2.0, 1e6])] {
        let lay = Layout::new(m, symmetric);
        let n = lay.len();
        let pre = PairPrecond::new(&h, lay, pen);
        let mut sgs = Sgs::new(&h, lay, Par::rayon(0));
        // the task knobs, for tuning them (benches/bench_sgs_tasks.py)
        if let Some(v) = knob("SGS_FORK") {
            sgs.fork = v as usize;
        }
        if let Some(v) = knob("SGS_SPLIT_FLOPS") {
            sgs.split_flops = v;
        }
        if let Some(v) = knob("SGS_SPLIT_DEPTH") {
            sgs.split_depth = v as u32;
        }
        let v: Vec<f64> = (0..n)
            .map(|i| ((i * 31 % 23) as f64 - 11.0) / 7.0)
            .collect();
        let (mut q, mut t) = (vec![0.0; n], vec![0.0; n]);
        let (mut w, mut rt) = (vec![0.0; n], vec![0.0; n]);
        let mut work = SgsWork::new(m);
        let best = podid_rs::with_threads(threads, || {
            let mut best = f64::INFINITY;
            for _ in 0..repeats {
                let start = Instant::now();
                let ends = Ends::FactorIn;
                let (wo, rto) = (Some(&mut w[..]), Some(&mut rt[..]));
                sgs.solve_with(&pre, &v, &mut t, wo, rto, false, ends, &mut work);
                pre.correct(&t, &mut w);
                let ends = Ends::FactorOut(Some(&rt));
                sgs.solve_with(&pre, &w, &mut q, None, None, true, ends, &mut work);
                best = best.min(start.elapsed().as_secs_f64());
            }
            best
        })
        .expect("a thread pool");
        let checksum: f64 = q.iter().sum();
        let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
        let load = load.split_whitespace().next().unwrap_or("?");
        println!(
            "m = {m}, {}, {threads} thread(s): best of {repeats} {best:.6} s per apply \
             (checksum {checksum:.12e}, load {load})",
            if symmetric { "exact-sym" } else { "penalty" }
        );
    }
}
