//! The leaves of the recursive solve: the pairs of one or two tiles of [`LEAF`]
//! modes solved entry by entry, with their couplings within the tiles and the
//! per-pair blocks of D ([`block_solve`]), compiled for the ends, direction and
//! mode, and for AVX2 where the CPU has it; each leaf prefetches its data and the
//! next leaf's.

use super::couplings::{TileBlocks, LEAF, NO_LEAF};
use super::solve::{Ends, Modes, Solve};
use crate::pairs::Layout;
use crate::precond::inv_mul;
use std::f64::consts::FRAC_1_SQRT_2 as RSQRT2;

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

impl Solve<'_> {
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
    pub(super) fn leaf(&self, ri: Modes, rc: Modes) {
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
