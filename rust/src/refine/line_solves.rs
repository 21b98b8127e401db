//! Solves with D(ω) of one line from its LU factors (those of an evaluation): for
//! several right-hand sides in double or single precision ([`solve_lines`],
//! [`solve_lines_single`]), with Dᴴ ([`solve_lines_adjoint`]), and D⁻¹ itself
//! ([`inverse_of`]).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::solve as lu_solve;
use faer::{c64, Mat, MatMut, MatRef, Par};

/// Solve D x_j = f_j in place for the p columns of one line (x holds f on entry).
pub(crate) fn solve_lines<T: faer::traits::ComplexField>(
    lu: MatRef<T>,
    perm: &[usize],
    x: &mut [T],
    m: usize,
    p: usize,
) {
    let pinv = inverse_perm(perm);
    let permref = faer::perm::PermRef::new_checked(perm, &pinv, m);
    let rhs = MatMut::from_column_major_slice_mut(x, m, p);
    let mut mem = MemBuffer::new(lu_solve::solve_in_place_scratch::<usize, T>(m, p, Par::Seq));
    lu_solve::solve_in_place(lu, lu, permref, rhs, Par::Seq, MemStack::new(&mut mem));
}

/// Solve D(ω) X = B in place for the p columns of B (m×p, column-major) in single
/// precision, from the double-precision LU of D (rounded to single first).
pub(crate) fn solve_lines_single(
    lu: MatRef<c64>,
    perm: &[usize],
    x: &mut [faer::c32],
    m: usize,
    p: usize,
) {
    let lu32 = Mat::<faer::c32>::from_fn(m, m, |i, j| {
        let z = lu[(i, j)];
        faer::c32::new(z.re as f32, z.im as f32)
    });
    solve_lines(lu32.as_ref(), perm, x, m, p);
}

/// Solve D(ω)ᴴ z = x in place for the p columns of x (m×p, column-major), from
/// the LU of D.
pub(crate) fn solve_lines_adjoint(
    lu: MatRef<c64>,
    perm: &[usize],
    x: &mut [c64],
    m: usize,
    p: usize,
) {
    let pinv = inverse_perm(perm);
    let permref = faer::perm::PermRef::new_checked(perm, &pinv, m);
    let rhs = MatMut::from_column_major_slice_mut(x, m, p);
    let mut mem = MemBuffer::new(lu_solve::solve_transpose_in_place_scratch::<usize, c64>(
        m,
        p,
        Par::Seq,
    ));
    lu_solve::solve_transpose_in_place_with_conj(
        lu,
        lu,
        permref,
        faer::Conj::Yes,
        rhs,
        Par::Seq,
        MemStack::new(&mut mem),
    );
}

fn inverse_perm(perm: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; perm.len()];
    for (i, &p) in perm.iter().enumerate() {
        inv[p] = i;
    }
    inv
}

/// D⁻¹ of one line from its LU (column-major m×m).
pub(crate) fn inverse_of(lu: MatRef<c64>, perm: &[usize], m: usize) -> Vec<c64> {
    let mut inv = vec![c64::new(0.0, 0.0); m * m];
    for k in 0..m {
        inv[k * m + k] = c64::new(1.0, 0.0);
    }
    solve_lines(lu, perm, &mut inv, m, m);
    inv
}
