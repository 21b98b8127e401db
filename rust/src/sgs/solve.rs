//! One triangular solve of the Gauss–Seidel split in progress ([`Solve`]): the
//! couplings and pair factors it reads, where it writes ([`Ptrs`]), the products at
//! its ends ([`Ends`]), and the ranges of modes the recursion cuts it into
//! ([`Modes`]).

use super::couplings::Sgs;
use crate::precond::PairPrecond;

/// A contiguous range of modes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Modes {
    pub(super) lo: usize,
    pub(super) hi: usize,
}

impl Modes {
    pub(super) fn len(self) -> usize {
        self.hi - self.lo
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
pub(super) struct Ptrs {
    pub(super) ye: *mut f32,
    pub(super) w: *mut f32,
    pub(super) out: *mut f64,
    pub(super) lower: *mut f64,
    /// Rᵀ y of a [`Ends::FactorIn`] solve (null if not wanted)
    pub(super) rty: *mut f64,
    /// not null: only record the leaves (tile row, tile column) in solve order
    pub(super) order: *mut Vec<(u32, u32)>,
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
pub(super) struct Solve<'a> {
    pub(super) sgs: &'a Sgs,
    pub(super) pre: &'a PairPrecond,
    pub(super) r: &'a [f64],
    pub(super) ptr: Ptrs,
    /// [`Sgs::next`] of this direction
    pub(super) next: &'a [u32],
    pub(super) backward: bool,
    pub(super) ends: Ends<'a>,
    pub(super) n_pairs: usize,
}
