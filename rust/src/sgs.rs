//! Symmetric Gauss–Seidel over entry pairs: the preconditioner of the matrix-free
//! solver (DESIGN §4, issue 13), applied with Eisenstat's trick by [`crate::cg`].
//!
//! In the Q basis of [`crate::precond`] the normal operator splits as
//! G = D + L + Lᵀ: D the pair blocks of [`PairPrecond`] (3×3 per diagonal entry,
//! 3×3 or 6×6 per pair (j, k)), L the couplings of each pair to the pairs before
//! it in column-major pair order (larger index k first, then j). Every coupling
//! outside D comes from the row operator Z ↦ Z H̃ with the mode-diagonal 3×3
//! blocks of H̃ removed; written on the entry matrix Y (Y_ic ∈ ℝ³, one value per
//! block) it is
//!
//! ```text
//!   (L Y)_ic = Σ_{l<c} Y_il H̃(l, c)        (H̃(l, c) the 3×3 block of modes l, c)
//! ```
//!
//! i.e. the strictly block-upper part U of H̃ (in mode-major order) acting from
//! the right, Y ↦ Y U; the entry (i, c) and its mirror (c, i) meet only in D.
//! The penalty, which can exceed the data by 10¹⁵, lives in D alone, and D is
//! solved in the sym/skew coordinates (σ, τ), so it never touches the entries.
//!
//! The triangular solve (D + L) y = r is a triangular Lyapunov/Sylvester
//! equation; it is done recursively (RECSY style): split the modes in halves
//! a|b, solve the a×a part, update the accumulated lower terms of what depends on
//! it by one GEMM, solve the a×b and b×a entries (a triangular Sylvester problem,
//! split the same way), update, solve b×b. All couplings across halves are
//! GEMMs in single precision (H̃ in f32, ≈ 9m³ flops per solve: half an operator
//! GEMM); only those within leaves of [`LEAF`] modes are done entry by entry.
//! The solve (D + Lᵀ) is the same recursion in reverse mode order. The two
//! threads share the work as rayon tasks only: independent Sylvester quarters,
//! and large GEMMs cut in halves (each piece on one thread). Each leaf asks for
//! the data of the next one in the sequential order before it computes.
//!
//! The entries are kept in a 3m×m matrix, column i holding row i of Y in
//! mode-major order (Y_il[b] at row 3l + b), so that both the GEMMs and the
//! dot products of the leaves read contiguous memory.

use crate::gram::HBlocks;
use crate::pairs::Layout;
use crate::precond::{inv_mul, PairPrecond};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;
use std::f64::consts::FRAC_1_SQRT_2 as RSQRT2;

/// Modes per leaf of the recursion (entry-by-entry substitution below this):
/// the tiles of the pair numbering, so that a leaf's pair data are contiguous.
pub const LEAF: usize = crate::pairs::TILE;

/// Products of at least this many flops are cut in halves run as rayon tasks,
/// the pieces on one thread each (default of [`Sgs::split_flops`]). faer's own
/// parallel product synchronises its threads at every block: at m = 1000 its
/// threads spent a third of the CPU time of the solves waiting at barriers, and
/// tasks took 25–40 % less CPU time for the same work (2 threads, loaded host).
/// With [`SPLIT_DEPTH`] and [`FORK`] tuned together by `benches/bench_sgs_tasks.py`
/// (one apply, 2 threads, round-robin minima): 8e6 flops, 8 pieces and quarters
/// forked from 32 modes took 7.0 / 66 ms at m = 400 / 1000 (exact-symmetric);
/// 2e6 flops, 2 pieces and forks from 12 modes 5.6 / 59 ms (most of the gain is
/// the fork: 2 pieces from 2e6 flops but forks from 32 modes took 6.6 / 61 ms).
const SPLIT_FLOPS: f64 = 2e6;

/// At most 2^SPLIT_DEPTH pieces per product: one per thread. With forks from
/// 12 modes, 4 pieces took the same time within 2 %, 8 pieces (forks from 16)
/// 7–8 % longer: their tasks compete with the forked quarters for two threads.
const SPLIT_DEPTH: u32 = 1;

/// H̃ in mode-major order, single precision, for the triangular solves.
pub struct Sgs {
    layout: Layout,
    /// Sylvester blocks with both sides at least this long fork ([`FORK`])
    pub fork: usize,
    /// 3m×3m, column-major: H̃(l, c)[b', b] at row 3l + b', column 3c + b
    hm: Vec<f32>,
    /// the couplings within each tile: tiles[t][u][v] = H̃(l, c) for the modes
    /// l = t·LEAF + u, c = t·LEAF + v (the leaves read these, not `hm`)
    tiles: Vec<TileBlocks>,
    par: Par,
    /// products of at least this many flops are cut in halves run as rayon tasks
    pub split_flops: f64,
    /// at most 2^split_depth pieces per product
    pub split_depth: u32,
    /// the leaves may run their AVX2 build where the CPU has it (tests turn this
    /// off to compare the two builds)
    pub simd: bool,
    /// for each leaf (tile row, tile column) of the forward [0] and backward [1]
    /// solves, the leaf that follows it in the sequential solve order, packed as
    /// (row << 16) | column ([`NO_LEAF`] for the last); filled on first use
    next: [std::sync::OnceLock<Vec<u32>>; 2],
}

const NO_LEAF: u32 = u32::MAX;

/// The LEAF×LEAF blocks H̃(l, c) (3×3, [b'][b]) of one tile, each row padded
/// with a zero to four lanes, so that a leaf's coupling is 128-bit vector work.
type TileBlocks = [[[[f32; 4]; 3]; LEAF]; LEAF];

/// Scratch of one solve: the entries Y and their accumulated lower terms W,
/// both 3m×m column-major (column i = row i of the entry matrix, mode-major).
pub struct SgsWork {
    y: Vec<f32>,
    w: Vec<f32>,
}

impl SgsWork {
    pub fn new(m: usize) -> SgsWork {
        SgsWork {
            y: vec![0.0; 3 * m * m],
            w: vec![0.0; 3 * m * m],
        }
    }
}

/// Prefetch the cache lines of `len` values from `ptr` into L1 (a hint only).
#[inline]
fn prefetch<T>(ptr: *const T, len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let bytes = len * std::mem::size_of::<T>();
        let start = ptr as usize & !63;
        let end = ptr as usize + bytes;
        let mut line = start;
        while line < end {
            // SAFETY: a prefetch never faults, whatever the address
            unsafe { _mm_prefetch(line as *const i8, _MM_HINT_T0) };
            line += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (ptr, len);
}

/// A contiguous range of modes.
#[derive(Clone, Copy, Debug)]
struct Modes {
    lo: usize,
    hi: usize,
}

impl Modes {
    fn len(self) -> usize {
        self.hi - self.lo
    }
}

impl Sgs {
    /// From H̃ (by its blocks, block layout: row b·m + l) in the Q basis.
    pub fn new(ht: &HBlocks, layout: Layout, par: Par) -> Sgs {
        let n = 3 * layout.m;
        let mut hm = vec![0.0f32; n * n];
        hm.par_chunks_mut(n).enumerate().for_each(|(c, col)| {
            // column c = 3·mode + b of hm: column `mode` of the blocks (b', b)
            let (mode, b) = (c / 3, c % 3);
            let blocks = [0, 1, 2].map(|bp| ht.block(bp, b));
            for (l, v3) in col.chunks_exact_mut(3).enumerate() {
                for (v, (blk, sign)) in v3.iter_mut().zip(&blocks) {
                    *v = (sign * blk[(l, mode)]) as f32;
                }
            }
        });
        let tiles = (0..layout.m.div_ceil(LEAF))
            .map(|t| {
                let mut blocks = [[[[0.0f32; 4]; 3]; LEAF]; LEAF];
                let lo = t * LEAF;
                let len = LEAF.min(layout.m - lo);
                for (u, row) in blocks.iter_mut().enumerate().take(len) {
                    for (v, blk) in row.iter_mut().enumerate().take(len) {
                        for (bp, r) in blk.iter_mut().enumerate() {
                            for (b, x) in r.iter_mut().enumerate().take(3) {
                                *x = hm[(3 * (lo + v) + b) * n + 3 * (lo + u) + bp];
                            }
                        }
                    }
                }
                blocks
            })
            .collect();
        Sgs {
            layout,
            fork: FORK,
            hm,
            tiles,
            par,
            split_flops: SPLIT_FLOPS,
            split_depth: SPLIT_DEPTH,
            simd: true,
            next: Default::default(),
        }
    }

    /// Bytes held (for the memory estimate): H̃ in f32, one [`SgsWork`] and
    /// the two tables of the leaf order.
    pub fn bytes(m: usize) -> usize {
        let tiles = m.div_ceil(LEAF);
        4 * (9 * m * m + 6 * m * m + 2 * tiles * tiles)
    }

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

/// Where one solve writes: the entries Y and lower terms W (3m×m each), the
/// solution and the lower terms in packed coordinates (null if not wanted).
///
/// Safety: the recursion of [`Solve`] runs two branches at once only on
/// disjoint sets of entries (i, c) and their mirrors (c, i); each branch writes
/// Y, W and the packed outputs of its own entries only, and reads Y only of its
/// own entries or of entries finished before the branches were forked. The
/// buffers outlive the solve (they are borrowed by [`Sgs::solve`]).
#[derive(Clone, Copy)]
struct Ptrs {
    ye: *mut f32,
    w: *mut f32,
    out: *mut f64,
    lower: *mut f64,
    /// Rᵀ y of a [`Ends::FactorIn`] solve (null if not wanted)
    rty: *mut f64,
    /// not null: only record the leaves (tile row, tile column) in solve order
    order: *mut Vec<(u32, u32)>,
}

unsafe impl Send for Ptrs {}
unsafe impl Sync for Ptrs {}

/// Per-pair products at the ends of a solve, see [`Sgs::solve_with`].
#[derive(Clone, Copy)]
pub enum Ends<'a> {
    Plain,
    FactorIn,
    FactorOut(Option<&'a [f64]>),
}

/// One triangular solve in progress (cheap to copy into a parallel branch).
#[derive(Clone, Copy)]
struct Solve<'a> {
    sgs: &'a Sgs,
    pre: &'a PairPrecond,
    r: &'a [f64],
    ptr: Ptrs,
    /// [`Sgs::next`] of this direction
    next: &'a [u32],
    backward: bool,
    ends: Ends<'a>,
    n_pairs: usize,
}

/// Both ranges of a Sylvester block at least this long: its two independent
/// quarters run in parallel (12 modes, three leaves: 32 left a thread idle
/// through the long sequential runs of small leaves; 8 and 16 took from 2 %
/// less to 6 % more, `benches/bench_sgs_tasks.py`).
const FORK: usize = 12;

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
    fn lyap(&self, r: Modes) {
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

    /// Ask for every cache line the leaf (ri, rc) will touch before it starts:
    /// its pairs' packed coordinates and factors are small contiguous runs far
    /// from the previous leaf's, and loaded one pair at a time their misses
    /// would not overlap.
    fn prefetch_leaf(&self, ri: Modes, rc: Modes) {
        let lay = self.sgs.layout;
        let (m, n_pairs) = (lay.m, self.n_pairs);
        let (lo, hi) = if ri.lo < rc.lo { (ri, rc) } else { (rc, ri) };
        let diagonal = ri.lo == rc.lo;
        let (p_lo, p_hi) = if diagonal && lo.len() < 2 {
            (0, 0)
        } else if diagonal {
            (
                lay.pair(lo.lo, lo.lo + 1),
                lay.pair(lo.hi - 2, lo.hi - 1) + 1,
            )
        } else {
            (lay.pair(lo.lo, hi.lo), lay.pair(lo.hi - 1, hi.hi - 1) + 1)
        };
        let pairs = 3 * (p_hi - p_lo);
        let runs = [
            (3 * m + 3 * p_lo, pairs),
            (
                3 * m + 3 * n_pairs + 3 * p_lo,
                if lay.symmetric { 0 } else { pairs },
            ),
            (3 * lo.lo, if diagonal { 3 * lo.len() } else { 0 }),
        ];
        let t = match self.ends {
            Ends::FactorOut(Some(t)) => t.as_ptr(),
            _ => std::ptr::null(),
        };
        for (at, len) in runs.into_iter().filter(|&(_, len)| len > 0) {
            for base in [
                self.r.as_ptr(),
                self.ptr.out as *const f64,
                self.ptr.lower,
                self.ptr.rty,
                t,
            ] {
                if !base.is_null() {
                    // SAFETY: [at, at + len) lies inside the packed vectors
                    prefetch(unsafe { base.add(at) }, len);
                }
            }
        }
        let f = self.pre.pair_factors(p_lo, p_hi);
        prefetch(f.as_ptr(), f.len());
        if diagonal {
            let f = self.pre.diag_factors(lo.lo, lo.hi);
            prefetch(f.as_ptr(), f.len());
        }
        // the lower terms and entries of the leaf: (i, c ∈ rc) and (c, i ∈ ri)
        let ld = 3 * m;
        for (rows, cols) in [(ri, rc), (rc, ri)] {
            for col in cols.lo..cols.hi {
                for buf in [self.ptr.w, self.ptr.ye] {
                    // SAFETY: inside the 3m×m buffers
                    prefetch(unsafe { buf.add(col * ld + 3 * rows.lo) }, 3 * rows.len());
                }
            }
        }
    }

    /// [`Solve::leaf_body`], compiled for AVX2 where the CPU has it (the crate
    /// is built for baseline x86-64, SSE2): the same arithmetic (no fused
    /// multiply-adds are formed), in wider registers.
    fn leaf(&self, ri: Modes, rc: Modes) {
        #[cfg(target_arch = "x86_64")]
        if self.sgs.simd && std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked above)
            return unsafe { self.leaf_avx2(ri, rc) };
        }
        self.leaf_kind(ri, rc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn leaf_avx2(&self, ri: Modes, rc: Modes) {
        self.leaf_kind(ri, rc)
    }

    /// [`Solve::leaf_body`] compiled for the ends, the direction and the mode,
    /// and for a whole off-diagonal tile (the common leaf) with its loop bounds
    /// and pair numbers known: the same arithmetic in fewer instructions (one
    /// m = 400 application 6 % faster, exact-symmetric, one thread).
    #[inline(always)]
    fn leaf_kind(&self, ri: Modes, rc: Modes) {
        match self.ends {
            Ends::Plain => self.leaf_shape::<0>(ri, rc),
            Ends::FactorIn => self.leaf_shape::<1>(ri, rc),
            Ends::FactorOut(_) => self.leaf_shape::<2>(ri, rc),
        }
    }

    /// (`E`: 0, 1, 2 for [`Ends::Plain`], [`Ends::FactorIn`], [`Ends::FactorOut`].)
    #[inline(always)]
    fn leaf_shape<const E: u8>(&self, ri: Modes, rc: Modes) {
        let full = ri.lo != rc.lo && ri.len() == LEAF && rc.len() == LEAF;
        match (full, self.backward, self.sgs.layout.symmetric) {
            (true, false, true) => self.leaf_body::<E, true, false, true>(ri, rc),
            (true, false, false) => self.leaf_body::<E, true, false, false>(ri, rc),
            (true, true, true) => self.leaf_body::<E, true, true, true>(ri, rc),
            (true, true, false) => self.leaf_body::<E, true, true, false>(ri, rc),
            (false, false, true) => self.leaf_body::<E, false, false, true>(ri, rc),
            (false, false, false) => self.leaf_body::<E, false, false, false>(ri, rc),
            (false, true, true) => self.leaf_body::<E, false, true, true>(ri, rc),
            (false, true, false) => self.leaf_body::<E, false, true, false>(ri, rc),
        }
    }

    /// Entry by entry: the pairs (i, c), i in `ri`, c in `rc`, `ri` wholly
    /// before `rc`, or (`ri` = `rc`) the diagonal block: pairs i before c and
    /// the diagonal entries. Both ranges are tiles. Local indices count in solve
    /// order; what the leaf touches of Y and W is copied into small arrays.
    #[inline(always)]
    fn leaf_body<const E: u8, const FULL: bool, const BACK: bool, const SYM: bool>(
        &self,
        ri: Modes,
        rc: Modes,
    ) {
        if !self.ptr.order.is_null() {
            // SAFETY: only [`Sgs::leaf_order`] sets it, sequentially, to its own vector
            unsafe { (*self.ptr.order).push(((ri.lo / LEAF) as u32, (rc.lo / LEAF) as u32)) };
            return;
        }
        // the next leaf's data arrive while this one computes (measured at
        // m = 1000: the leaves took 12 % less time; its own data are asked for
        // again, for the first leaf of a parallel branch)
        let tiles = self.sgs.layout.m.div_ceil(LEAF);
        let nx = self.next[(ri.lo / LEAF) * tiles + rc.lo / LEAF];
        if nx != NO_LEAF {
            let m = self.sgs.layout.m;
            let tile = |t: u32| Modes {
                lo: t as usize * LEAF,
                hi: (t as usize * LEAF + LEAF).min(m),
            };
            self.prefetch_leaf(tile(nx >> 16), tile(nx & 0xffff));
        }
        self.prefetch_leaf(ri, rc);
        let diagonal = !FULL && ri.lo == rc.lo;
        let (ni, nc) = if FULL {
            (LEAF, LEAF)
        } else {
            (ri.len(), rc.len())
        };
        let back = BACK;
        // the mode of local index k of range r, and its index within its tile
        let mode = |r: Modes, k: usize| if back { r.hi - 1 - k } else { r.lo + k };
        let tile_i = &self.sgs.tiles[ri.lo / LEAF];
        let tile_c = &self.sgs.tiles[rc.lo / LEAF];
        let at_i = |k: usize| mode(ri, k) - ri.lo;
        let at_c = |k: usize| mode(rc, k) - rc.lo;
        let ld = 3 * self.sgs.layout.m;
        let load = |src: *const f32, row: usize, col: usize| -> [f32; 3] {
            // SAFETY: entry (row, col) belongs to this leaf (see `Ptrs`)
            unsafe { *(src.add(row * ld + 3 * col) as *const [f32; 3]) }
        };
        // x[a][k]: entry (row i_a, col c_k); z[k][a]: its mirror (row c_k, col i_a)
        let mut wx = [[[0.0f32; 3]; LEAF]; LEAF];
        let mut wz = [[[0.0f32; 3]; LEAF]; LEAF];
        for a in 0..ni {
            for k in 0..nc {
                if !diagonal || a <= k {
                    wx[a][k] = load(self.ptr.w, mode(ri, a), mode(rc, k));
                    wz[k][a] = load(self.ptr.w, mode(rc, k), mode(ri, a));
                }
            }
        }
        let mut x = [[[0.0f32; 3]; LEAF]; LEAF];
        let mut z = [[[0.0f32; 3]; LEAF]; LEAF];
        // acc += Σ_l H̃(l, c)ᵀ y_l over the earlier local indices l < k of a tile
        #[inline(always)]
        fn couple(
            acc: &mut [f32; 3],
            tile: &TileBlocks,
            at: &dyn Fn(usize) -> usize,
            k: usize,
            y: &dyn Fn(usize) -> [f32; 3],
        ) {
            let c = at(k);
            // four lanes (the fourth is zero), the same sums in the same order
            let mut a4 = [acc[0], acc[1], acc[2], 0.0];
            for l in 0..k {
                let (h, v) = (&tile[at(l)][c], y(l));
                let s: [f32; 4] =
                    std::array::from_fn(|b| h[0][b] * v[0] + h[1][b] * v[1] + h[2][b] * v[2]);
                for (out, s) in a4.iter_mut().zip(s) {
                    *out += s;
                }
            }
            *acc = [a4[0], a4[1], a4[2]];
        }
        let m = self.sgs.layout.m;
        let symmetric = SYM;
        // SAFETY (both): the packed coordinates of this leaf's pairs belong to it
        let out = |at: usize, v: &[f64]| unsafe {
            std::ptr::copy_nonoverlapping(v.as_ptr(), self.ptr.out.add(at), v.len())
        };
        let lower = |at: usize, v: &[f64]| {
            if !self.ptr.lower.is_null() {
                unsafe {
                    std::ptr::copy_nonoverlapping(v.as_ptr(), self.ptr.lower.add(at), v.len())
                }
            }
        };
        let rty = |at: usize, v: &[f64]| {
            if !self.ptr.rty.is_null() {
                // SAFETY: as `lower`
                unsafe { std::ptr::copy_nonoverlapping(v.as_ptr(), self.ptr.rty.add(at), v.len()) }
            }
        };
        // the right-hand side and s (Ends::FactorOut) at coordinate `at`
        let three = |v: &[f64], at: usize| -> [f64; 3] { *v[at..].first_chunk().unwrap() };
        let rhs = |at: usize| three(self.r, at);
        let s_vec = match self.ends {
            Ends::FactorOut(Some(t)) if E == 2 => Some(t),
            _ => None,
        };
        let t3 = |at: usize| s_vec.map(|t| three(t, at));
        let cat = |a: [f64; 3], b: [f64; 3]| [a[0], a[1], a[2], b[0], b[1], b[2]];
        let ends = match E {
            0 => Ends::Plain,
            1 => Ends::FactorIn,
            _ => self.ends,
        };
        let p_tile = if FULL {
            let (j, k) = if BACK { (rc.lo, ri.lo) } else { (ri.lo, rc.lo) };
            self.sgs.layout.pair(j, k)
        } else {
            0
        };
        // the entries in solve order: (a, k), or in a diagonal leaf with a = k the
        // diagonal entry (c, c)
        let mut order = [(0u8, 0u8); LEAF * LEAF + LEAF];
        let mut len = 0;
        if diagonal {
            for k in 0..nc {
                for a in 0..if diagonal { k + 1 } else { ni } {
                    order[len] = (a as u8, k as u8);
                    len += 1;
                }
            }
        } else {
            // by antidiagonals: (a, k) depends on (a, l < k) and (l < a, k) only, so
            // the entries of one antidiagonal are independent and their dependency
            // chains (couplings, small solves, conversions) overlap in the core
            for d in 0..ni + nc - 1 {
                for a in d.saturating_sub(nc - 1)..ni.min(d + 1) {
                    order[len] = (a as u8, (d - a) as u8);
                    len += 1;
                }
            }
        }
        for &(a, k) in &order[..len] {
            let (a, k) = (a as usize, k as usize);
            let c = mode(rc, k);
            if diagonal && a == k {
                // (c, c): the columns before c in row c, i.e. z[k][l] for l < k
                let mut ad = wx[k][k];
                couple(&mut ad, tile_c, &at_c, k, &|l| z[k][l]);
                let wd = [ad[0] as f64, ad[1] as f64, ad[2] as f64];
                let at = 3 * c;
                let (v, o, rv) = block_solve(ends, self.pre.diag_factor(c), rhs(at), wd, t3(at));
                out(at, &o);
                rty(at, &rv);
                lower(at, &wd);
                x[k][k] = [v[0] as f32, v[1] as f32, v[2] as f32];
                continue;
            }
            let i = mode(ri, a);
            // entry (i, c) sees the columns of rc before c; its mirror (c, i)
            // the columns of ri before i
            let mut ax = wx[a][k];
            let mut az = wz[k][a];
            if diagonal {
                // one range: (i, l) for l before c is x[a][l] (l > a), the
                // diagonal (a = l) or the mirror z[a][l] (l < a)
                couple(&mut ax, tile_c, &at_c, k, &|l| {
                    if l > a {
                        x[a][l]
                    } else if l == a {
                        x[a][a]
                    } else {
                        z[a][l]
                    }
                });
                couple(&mut az, tile_i, &at_i, a, &|l| z[k][l]);
            } else {
                couple(&mut ax, tile_c, &at_c, k, &|l| x[a][l]);
                couple(&mut az, tile_i, &at_i, a, &|l| z[k][l]);
            }
            let (j, kk) = (i.min(c), i.max(c));
            let (wu, wl) = if i < c { (ax, az) } else { (az, ax) };
            let p = if FULL {
                let (row, col) = if BACK {
                    (LEAF - 1 - k, LEAF - 1 - a)
                } else {
                    (a, k)
                };
                Layout::in_tile(p_tile, row, col)
            } else {
                self.sgs.layout.pair(j, kk)
            };
            let s0 = 3 * m + 3 * p;
            let t0 = 3 * m + 3 * self.n_pairs + 3 * p;
            // the small arrays are built by from_fn or by hand, not `[_; 3].map`: LLVM
            // left map's `try_map` out of line in the AVX2 leaf, a call per entry
            // (1.5 % of the solves' samples at m = 400)
            let ls: [f64; 3] = std::array::from_fn(|b| (wu[b] as f64 + wl[b] as f64) * RSQRT2);
            let factor = self.pre.pair_factor(p);
            let (upper, low) = if symmetric {
                let (v, o, rv) = block_solve(ends, factor, rhs(s0), ls, t3(s0));
                out(s0, &o);
                rty(s0, &rv);
                let y: [f32; 3] = std::array::from_fn(|b| (v[b] * RSQRT2) as f32);
                (y, y)
            } else {
                let lt: [f64; 3] = std::array::from_fn(|b| (wu[b] as f64 - wl[b] as f64) * RSQRT2);
                let t6 = t3(s0).zip(t3(t0)).map(|(a, b)| cat(a, b));
                let (v, o, rv) = block_solve(ends, factor, cat(rhs(s0), rhs(t0)), cat(ls, lt), t6);
                out(s0, &o[..3]);
                out(t0, &o[3..]);
                rty(s0, &rv[..3]);
                rty(t0, &rv[3..]);
                lower(t0, &lt);
                (
                    std::array::from_fn(|b| ((v[b] + v[b + 3]) * RSQRT2) as f32),
                    std::array::from_fn(|b| ((v[b] - v[b + 3]) * RSQRT2) as f32),
                )
            };
            lower(s0, &ls);
            // Y[j, kk] is the upper entry, Y[kk, j] the lower one
            let (ex, ez) = if i < c { (upper, low) } else { (low, upper) };
            x[a][k] = ex;
            z[k][a] = ez;
        }
        let store = |row: usize, col: usize, v: [f32; 3]| {
            // SAFETY: as `load`
            unsafe { *(self.ptr.ye.add(row * ld + 3 * col) as *mut [f32; 3]) = v }
        };
        for a in 0..ni {
            for k in 0..nc {
                if !diagonal || a < k {
                    store(mode(ri, a), mode(rc, k), x[a][k]);
                    store(mode(rc, k), mode(ri, a), z[k][a]);
                } else if a == k {
                    store(mode(ri, a), mode(rc, k), x[a][k]);
                }
            }
        }
    }
}

/// One block of D in a leaf, with W = R⁻¹ its stored inverse factor (D = R Rᵀ),
/// right-hand side r and lower terms w: y = D⁻¹(r − w), or D⁻¹(R r − w) for
/// [`Ends::FactorIn`]; returns y, what is written out (y, or for
/// [`Ends::FactorOut`] Rᵀ y + s), and Rᵀ y for `FactorIn`. Products with W
/// only: D⁻¹(R r − w) = Wᵀ(r − W w) with Rᵀ y = r − W w, and Rᵀ D⁻¹(r − w) =
/// W(r − w). (With R itself these were substitutions, chains of dependent
/// steps, and the penalty mode's 6×6 blocks made the leaves latency-bound.)
#[inline(always)]
fn block_solve<const N: usize, T: Copy + Into<f64>>(
    ends: Ends,
    l: &[T],
    r: [f64; N],
    w: [f64; N],
    s: Option<[f64; N]>,
) -> ([f64; N], [f64; N], [f64; N]) {
    match ends {
        Ends::FactorIn => {
            let ww = inv_mul::<N, T>(l, &w, false);
            let rty: [f64; N] = std::array::from_fn(|q| r[q] - ww[q]);
            let y = inv_mul::<N, T>(l, &rty, true);
            (y, y, rty)
        }
        _ => {
            let d: [f64; N] = std::array::from_fn(|q| r[q] - w[q]);
            let u = inv_mul::<N, T>(l, &d, false);
            let y = inv_mul::<N, T>(l, &u, true);
            let o = match (ends, s) {
                (Ends::FactorOut(_), Some(s)) => std::array::from_fn(|q| u[q] + s[q]),
                (Ends::FactorOut(_), None) => u,
                _ => y,
            };
            (y, o, u)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cg::Operator;
    use crate::gram::random_blocks;
    use faer::Mat;

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
}
