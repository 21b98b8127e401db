"""Entries of the response grid that were not measured: what the fit does without them.

A multi-reference test does not always measure every response for every force: a
channel lost in one run, or two campaigns combined (a shaker column and a
roving-hammer row, :func:`podid_rs.read_uff`), leave holes in the n × p grid of
responses × load cases. :class:`podid_rs.MeasuredData` marks the entries that were
measured with a mask ``measured`` ``(n, p)`` and stores zeros in the holes; the
fitters here take that mask, and an entry that was not measured weighs nothing:

* the complex output error Σ_j w_j² Σ_n mask_nj |(R x_j)_n − u_nj|² of load case j
  is, for every line, ‖T_j (x_j − y_j)‖² + c with T_jᵀT_j = w_j² Rᵀ diag(mask_j) R
  and y_j the reduced response that best reproduces the measured entries
  (:func:`measured_metric`) — one m × m metric per load case, the same on every
  line, so forming it costs p eigendecompositions, not one per line;
* the reduced data of the paper's estimator (:meth:`podid_rs.MeasuredData.project`)
  are those y_j (:func:`measured_targets`): Rᵀ u_j for a complete column (R
  orthonormal), the least-squares fit of the measured entries otherwise — a hole is
  not read as a response of zero. The order sweep's starts
  (:func:`~podid_rs.identification.order.sweep_orders`) see instead Rᵀ u_j with the
  holes filled by the previous order's prediction: on a 6-DOF chain with two forces and
  four FRFs removed, the least-squares targets of an order-6 basis (rank 3–5 per
  column) left the sweep at 1.9 dB held-out and the final fit 0.8–8 dB off per entry,
  the filled ones at 0.9 dB and 0.001–0.009 dB;
* errors in dB count measured entries only
  (:func:`podid_rs.identification.refinement.db_errors`).

With ``measured=None`` (complete data) every function here computes exactly what
the fitters did before masks existed.
"""

from __future__ import annotations

import numpy as np


def check_measured(measured: object, n: int, p: int) -> np.ndarray | None:
    """The mask of measured entries as a fresh ``(n, p)`` bool array, None if complete.

    Parameters
    ----------
    measured : array_like of bool, (n, p), or None
        True where response n of load case p was measured.
    n, p : int
        Measured DOFs and load cases.

    Returns
    -------
    numpy.ndarray of bool or None
        The mask, or None when it is None or every entry is True (complete data take
        the code paths they always took).

    Raises
    ------
    ValueError
        For a mask that is not boolean of shape (n, p), or one with a load case or a
        DOF that has no measured entry.
    """
    if measured is None:
        return None
    mask = np.asarray(measured)
    if mask.dtype != np.bool_ or mask.shape != (n, p):
        raise ValueError(
            f"measured must be a boolean mask of shape (n, p) = ({n}, {p}) (True where "
            f"the response was measured), got {mask.dtype} {mask.shape}"
        )
    empty = np.flatnonzero(~mask.any(axis=0))
    if empty.size:
        raise ValueError(
            f"load case(s) {empty.tolist()} have no measured response: there is nothing "
            "to fit them to; leave them out"
        )
    unseen = np.flatnonzero(~mask.any(axis=1))
    if unseen.size:
        raise ValueError(
            f"measured DOF(s) {unseen.tolist()} are not measured in any load case: "
            "leave them out of the data"
        )
    return None if mask.all() else mask.copy()


def _column_solve(R: np.ndarray, mask_j: np.ndarray):
    """Q = Rᵀ diag(mask_j) R by its eigenpairs: (λ, V, kept) with kept λ > 1e-12 λ_max."""
    d = mask_j.astype(np.float64)
    Q = R.T @ (d[:, None] * R)
    lam, V = np.linalg.eigh(0.5 * (Q + Q.T))
    keep = lam > 1e-12 * max(float(lam.max()), 0.0)
    return d, lam, V, keep


def measured_targets(U_n: np.ndarray, R: np.ndarray, measured: np.ndarray | None) -> np.ndarray:
    """Reduced responses ``(s, m, p)`` that best reproduce the measured entries.

    Complete data (``measured=None``): ``Rᵀ U`` (eq. 45). With holes, per load case
    j the least-squares y_j = argmin Σ_n mask_nj |(R y)_n − u_nj|², the minimum-norm
    one where the measured entries do not fix every coordinate.

    Parameters
    ----------
    U_n : numpy.ndarray, complex, (s, n, p)
        The responses on the measured DOFs, zeros in the holes.
    R : numpy.ndarray, (n, m)
        The basis (an observation matrix may end in zero columns).
    measured : numpy.ndarray of bool, (n, p), or None
        The mask (:func:`check_measured`).

    Returns
    -------
    numpy.ndarray, complex, (s, m, p)
        The reduced responses.
    """
    if measured is None:
        return np.einsum("nm,snp->smp", R, U_n)
    s, _, p = U_n.shape
    Y = np.zeros((s, R.shape[1], p), dtype=np.complex128)
    for j in range(p):
        d, lam, V, keep = _column_solve(R, measured[:, j])
        B = (R * d[:, None]).T @ U_n[:, :, j].T  # (m, s): Rᵀ diag(mask_j) u
        Vk = V[:, keep]
        Y[:, :, j] = (Vk @ ((Vk.T @ B) / lam[keep, None])).T
    return Y


def measured_metric(
    w: np.ndarray, R: np.ndarray, U_n: np.ndarray, measured: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """The complex output error over the measured entries as one metric per column.

    Σ_ij w_ij² Σ_n mask_nj |(R x_ij)_n − u_nij|² = Σ_ij ‖T_ij (x_ij − y_ij)‖² + c,
    with T_ij = w_ij · diag(√λ_j) V_jᵀ from Rᵀ diag(mask_j) R = V_j diag(λ_j) V_jᵀ
    (the same for every line of load case j) and y the targets of
    :func:`measured_targets`.

    Parameters
    ----------
    w : numpy.ndarray, (s·p,)
        Weight per column, line-major (line i, load case j at i·p + j).
    R : numpy.ndarray, (n, m)
        The observation matrix.
    U_n : numpy.ndarray, complex, (s, n, p)
        The responses on the measured DOFs, zeros in the holes.
    measured : numpy.ndarray of bool, (n, p)
        The mask.

    Returns
    -------
    T : numpy.ndarray, (s·p, m·m)
        The metric of every column, row-major, as the core's matrix weights take it.
    Y : numpy.ndarray, complex, (s, m, p)
        The targets.
    const : float
        The part of the cost no model can change (the measured entries outside the
        range of R).
    """
    s, _, p = U_n.shape
    m = R.shape[1]
    W = np.asarray(w, dtype=np.float64).reshape(s, p)
    T = np.empty((s, p, m, m))
    Y = measured_targets(U_n, R, measured)
    const = 0.0
    for j in range(p):
        d, lam, V, _ = _column_solve(R, measured[:, j])
        L = np.sqrt(np.clip(lam, 0.0, None))[:, None] * V.T  # LᵀL = Rᵀ diag(mask_j) R
        T[:, j] = W[:, j, None, None] * L
        Q = L.T @ L
        y = Y[:, :, j]
        full = np.sum(d[None, :] * np.abs(U_n[:, :, j]) ** 2, axis=1)  # (s,)
        fitted = np.real(np.einsum("sa,ab,sb->s", y.conj(), Q, y))
        const += float(np.sum(W[:, j] ** 2 * (full - fitted)))
    return T.reshape(s * p, m * m), Y, max(const, 0.0)
