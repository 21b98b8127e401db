//! The couplings of the symmetric Gauss–Seidel split in single precision ([`Sgs`]):
//! H̃ in mode-major order for the GEMMs of the recursion, and per tile of [`LEAF`]
//! modes the 3×3 blocks the leaves read; with the task knobs of the solves and the
//! scratch of one solve ([`SgsWork`]).

use crate::gram::HBlocks;
use crate::pairs::Layout;
use faer::Par;
use rayon::prelude::*;

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

/// Both ranges of a Sylvester block at least this long: its two independent
/// quarters run in parallel (12 modes, three leaves: 32 left a thread idle
/// through the long sequential runs of small leaves; 8 and 16 took from 2 %
/// less to 6 % more, `benches/bench_sgs_tasks.py`).
const FORK: usize = 12;

/// H̃ in mode-major order, single precision, for the triangular solves.
pub struct Sgs {
    pub(super) layout: Layout,
    /// Sylvester blocks with both sides at least this long fork ([`FORK`])
    pub fork: usize,
    /// 3m×3m, column-major: H̃(l, c)[b', b] at row 3l + b', column 3c + b
    pub(super) hm: Vec<f32>,
    /// the couplings within each tile: tiles[t][u][v] = H̃(l, c) for the modes
    /// l = t·LEAF + u, c = t·LEAF + v (the leaves read these, not `hm`)
    pub(super) tiles: Vec<TileBlocks>,
    pub(super) par: Par,
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
    pub(super) next: [std::sync::OnceLock<Vec<u32>>; 2],
}

pub(super) const NO_LEAF: u32 = u32::MAX;

/// The LEAF×LEAF blocks H̃(l, c) (3×3, [b'][b]) of one tile, each row padded
/// with a zero to four lanes, so that a leaf's coupling is 128-bit vector work.
pub(super) type TileBlocks = [[[[f32; 4]; 3]; LEAF]; LEAF];

/// Scratch of one solve: the entries Y and their accumulated lower terms W,
/// both 3m×m column-major (column i = row i of the entry matrix, mode-major).
pub struct SgsWork {
    pub(super) y: Vec<f32>,
    pub(super) w: Vec<f32>,
}

impl SgsWork {
    pub fn new(m: usize) -> SgsWork {
        SgsWork {
            y: vec![0.0; 3 * m * m],
            w: vec![0.0; 3 * m * m],
        }
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
}
