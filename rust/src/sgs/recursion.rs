//! The recursive triangular solve (D + L) y = r of the Gauss–Seidel split, and
//! (D + Lᵀ) y = r in reverse mode order ([`Sgs::solve`], [`Sgs::solve_with`]): the
//! modes split in halves, the diagonal blocks (Lyapunov-like) and the off-diagonal
//! ones (Sylvester-like) solved in turn, each coupling across halves one
//! single-precision GEMM of H̃, independent quarters forked as rayon tasks; the
//! leaves are [`super::leaf`]'s.

use super::couplings::{Sgs, SgsWork, LEAF, NO_LEAF};
use super::solve::{Ends, Modes, Ptrs, Solve};
use crate::precond::PairPrecond;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;

impl Sgs {
    /// Solve (D + L) y = r (`backward`: (D + Lᵀ) y = r) in packed coordinates;
    /// if `lower` is given, it receives L y (Lᵀ y), the couplings the solve
    /// subtracted, in the same coordinates.
    pub fn solve(
        &self,
        pre: &PairPrecond,
        r: &[f64],
        y: &mut [f64],
        lower: Option<&mut [f64]>,
        backward: bool,
        work: &mut SgsWork,
    ) {
        self.solve_with(pre, r, y, lower, None, backward, Ends::Plain, work);
    }

    /// [`Sgs::solve`] with the per-pair products of Eisenstat's split done in
    /// the leaves (saving passes over the vectors): with R the factor of D,
    /// the right-hand side is R r if `ends` is [`Ends::FactorIn`] (then `rty`,
    /// if given, receives Rᵀ y), and y is written as Rᵀ y + s for
    /// [`Ends::FactorOut`] (s = 0 if `None`). Only R⁻¹ is used: Rᵀ y of the
    /// first solve is its intermediate r − R⁻¹ w, so Rᵀ (y₂ + y₁) in a second
    /// solve is `FactorOut` with s = Rᵀ y₁ from the first.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_with(
        &self,
        pre: &PairPrecond,
        r: &[f64],
        y: &mut [f64],
        lower: Option<&mut [f64]>,
        rty: Option<&mut [f64]>,
        backward: bool,
        ends: Ends,
        work: &mut SgsWork,
    ) {
        let lay = self.layout;
        let n = lay.len();
        assert!(r.len() == n && y.len() == n && work.y.len() == 3 * lay.m * lay.m);
        assert!(lower.as_ref().is_none_or(|l| l.len() == n));
        assert!(rty.as_ref().is_none_or(|l| l.len() == n));
        if let Ends::FactorOut(Some(t)) = ends {
            assert!(t.len() == n);
        }
        work.w.par_iter_mut().for_each(|v| *v = 0.0);
        let next = self.next[backward as usize].get_or_init(|| self.leaf_order(pre, backward));
        let s = Solve {
            sgs: self,
            pre,
            r,
            ptr: Ptrs {
                ye: work.y.as_mut_ptr(),
                w: work.w.as_mut_ptr(),
                out: y.as_mut_ptr(),
                lower: lower.map_or(std::ptr::null_mut(), |l| l.as_mut_ptr()),
                rty: rty.map_or(std::ptr::null_mut(), |l| l.as_mut_ptr()),
                order: std::ptr::null_mut(),
            },
            next,
            backward,
            ends,
            n_pairs: lay.n_pairs(),
        };
        s.lyap(Modes { lo: 0, hi: lay.m });
    }

    /// The table `next` of one direction: the recursion run without arithmetic,
    /// recording its leaves.
    fn leaf_order(&self, pre: &PairPrecond, backward: bool) -> Vec<u32> {
        let tiles = self.layout.m.div_ceil(LEAF);
        let mut order: Vec<(u32, u32)> = Vec::new();
        let s = Solve {
            sgs: self,
            pre,
            r: &[],
            ptr: Ptrs {
                ye: std::ptr::null_mut(),
                w: std::ptr::null_mut(),
                out: std::ptr::null_mut(),
                lower: std::ptr::null_mut(),
                rty: std::ptr::null_mut(),
                order: &mut order,
            },
            next: &[],
            backward,
            ends: Ends::Plain,
            n_pairs: 0,
        };
        s.lyap(Modes {
            lo: 0,
            hi: self.layout.m,
        });
        let mut next = vec![NO_LEAF; tiles * tiles];
        for w in order.windows(2) {
            next[w[0].0 as usize * tiles + w[0].1 as usize] = (w[1].0 << 16) | w[1].1;
        }
        next
    }
}

impl Solve<'_> {
    /// The two halves of `r` in solve order, split at a tile boundary.
    fn split(&self, r: Modes) -> (Modes, Modes) {
        let mid = (r.lo + r.len() / 2 + LEAF / 2) / LEAF * LEAF;
        let mid = mid.clamp(r.lo + 1, r.hi - 1);
        let (a, b) = (Modes { lo: r.lo, hi: mid }, Modes { lo: mid, hi: r.hi });
        if self.backward {
            (b, a)
        } else {
            (a, b)
        }
    }

    /// W[dst, rows] += H̃[dst, src] · Y[src, rows]: the lower terms that the
    /// entries in rows `rows`, columns `dst` receive from columns `src`.
    fn update(&self, dst: Modes, src: Modes, rows: Modes) {
        self.update_pieces(dst, src, rows, 0);
    }

    /// [`Solve::update`], cut in halves (as rayon tasks) `depth` times so far.
    fn update_pieces(&self, dst: Modes, src: Modes, rows: Modes, depth: u32) {
        let (d, s, n) = (3 * dst.len(), 3 * src.len(), rows.len());
        if d == 0 || s == 0 || n == 0 || !self.ptr.order.is_null() {
            return;
        }
        let flops = 2.0 * d as f64 * s as f64 * n as f64;
        let split = flops >= self.sgs.split_flops && depth < self.sgs.split_depth;
        if split && !matches!(self.sgs.par, Par::Seq) {
            // halve the longer side: the halves share (read twice) the operand
            // of the other, H̃[dst, src] (3|dst|·3|src|) or Y[src, rows] (3|src|·n)
            let halves = |r: Modes| {
                let mid = r.lo + r.len() / 2;
                (Modes { lo: r.lo, hi: mid }, Modes { lo: mid, hi: r.hi })
            };
            if dst.len() >= 2 && (d >= n || n < 2) {
                let (d1, d2) = halves(dst);
                rayon::join(
                    || self.update_pieces(d1, src, rows, depth + 1),
                    || self.update_pieces(d2, src, rows, depth + 1),
                );
                return;
            }
            if n >= 2 {
                let (r1, r2) = halves(rows);
                rayon::join(
                    || self.update_pieces(dst, src, r1, depth + 1),
                    || self.update_pieces(dst, src, r2, depth + 1),
                );
                return;
            }
        }
        let ld = 3 * self.sgs.layout.m;
        // SAFETY: W[dst, rows] belongs to this branch and Y[src, rows] is final
        // (see `Ptrs`); both views lie inside the 3m×m buffers.
        let (w, y) = unsafe {
            (
                MatMut::from_raw_parts_mut(
                    self.ptr.w.add(rows.lo * ld + 3 * dst.lo),
                    d,
                    n,
                    1,
                    ld as isize,
                ),
                MatRef::from_raw_parts(
                    self.ptr.ye.add(rows.lo * ld + 3 * src.lo) as *const f32,
                    s,
                    n,
                    1,
                    ld as isize,
                ),
            )
        };
        let h = MatRef::from_column_major_slice(&self.sgs.hm[..], ld, ld);
        matmul(
            w,
            Accum::Add,
            h.submatrix(3 * dst.lo, 3 * src.lo, d, s),
            y,
            1.0f32,
            Par::Seq,
        );
    }

    /// Diagonal block r×r of Y.
    pub(super) fn lyap(&self, r: Modes) {
        if r.len() <= LEAF {
            return self.leaf(r, r);
        }
        let (a, b) = self.split(r);
        self.lyap(a);
        self.lyap_after(a, b);
    }

    /// The rest of the diagonal block a|b once its first block a×a is solved.
    fn lyap_after(&self, a: Modes, b: Modes) {
        self.update(b, a, a);
        let short = a.len().min(b.len());
        if short <= LEAF || short < self.sgs.fork {
            self.sylv(a, b);
            self.update(b, a, b);
            return self.lyap(b);
        }
        // sylv(a, b) up to its last quarter, which lyap(b₁) can run beside:
        // b₁'s diagonal block needs the entries (a, b₁) only
        let [_, a2, b1, b2] = self.sylv_head(a, b, true);
        self.both(
            || self.sylv(a2, b2),
            || {
                self.update(b1, a, b1);
                self.lyap(b1);
            },
        );
        // the rest of update(b, a, b), then lyap(b) after its first block
        self.update(b2, a, b1);
        self.update(b1, a, b2);
        self.update(b2, a, b2);
        self.lyap_after(b1, b2);
    }

    /// Run two independent parts, in parallel unless only recording the order.
    fn both(&self, x: impl FnOnce() + Send, y: impl FnOnce() + Send) {
        if self.ptr.order.is_null() {
            rayon::join(x, y);
        } else {
            x();
            y();
        }
    }

    /// [`Solve::sylv`] of two ranges longer than a leaf, all but its last quarter
    /// (i₂, c₂), whose lower terms it completes; the middle two quarters run in
    /// parallel if `fork`. Returns the halves [i₁, i₂, c₁, c₂].
    fn sylv_head(&self, ri: Modes, rc: Modes, fork: bool) -> [Modes; 4] {
        let (i1, i2) = self.split(ri);
        let (c1, c2) = self.split(rc);
        self.sylv(i1, c1);
        self.update(c2, c1, i1);
        self.update(i2, i1, c1);
        if fork {
            self.both(|| self.sylv(i1, c2), || self.sylv(i2, c1));
        } else {
            self.sylv(i1, c2);
            self.sylv(i2, c1);
        }
        self.update(c2, c1, i2);
        self.update(i2, i1, c2);
        [i1, i2, c1, c2]
    }

    /// Entries (i, c) and (c, i), i in `ri`, c in `rc`, `ri` wholly before `rc`.
    /// (i, c) depends on (i, l) for l before c, its mirror (c, i) on (c, l) for l
    /// before i: of the four quarters, (ri₂, rc₁) and (ri₁, rc₂) are independent.
    fn sylv(&self, ri: Modes, rc: Modes) {
        let (li, lc) = (ri.len(), rc.len());
        if li <= LEAF && lc <= LEAF {
            return self.leaf(ri, rc);
        }
        if li > LEAF && lc > LEAF {
            let [_, i2, _, c2] = self.sylv_head(ri, rc, li.min(lc) >= self.sgs.fork);
            self.sylv(i2, c2);
        } else if lc > LEAF {
            let (a, b) = self.split(rc);
            self.sylv(ri, a);
            // entries (i, c ∈ b) depend on (i, l ∈ a)
            self.update(b, a, ri);
            self.sylv(ri, b);
        } else {
            let (a, b) = self.split(ri);
            self.sylv(a, rc);
            // entries (c, i ∈ b) depend on (c, l ∈ a)
            self.update(b, a, rc);
            self.sylv(b, rc);
        }
    }
}
