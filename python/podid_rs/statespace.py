"""An identified second-order model as a first-order state-space model.

``M q̈ + C q̇ + K q = Rᵀ f``, ``y = R q`` (paper eqs. 14–19 on the POD basis R)
becomes, with the state x = [q; q̇],

    ẋ = A x + B f,   A = [[0, I], [−M⁻¹K, −M⁻¹C]],   B = [[0], [M⁻¹Rᵀ]],
    y = C x,         C = [R, 0],                      D = 0,

whose transfer function is ``C (sI − A)⁻¹ B = R (s²M + sC + K)⁻¹ Rᵀ``: at
s = iω the model's receptance on the measured DOFs, ``R H_m(ω) Rᵀ``. Without R
the inputs are the reduced forces and the outputs the reduced displacements q.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.signal

from ._arrays import as_array, as_basis

#: M is refused as singular when its 2-norm condition number exceeds this
#: (M⁻¹ would carry no correct digit).
MAX_MASS_CONDITION = 1e14


def state_space_matrices(
    M: object, C: object, K: object, basis: object = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) of ``M q̈ + C q̇ + K q = Rᵀ f``, ``y = R q``, state [q; q̇].

    ``basis`` R is real ``(n, m)``; None means R = I (reduced forces and
    displacements). Raises ``ValueError`` for a basis of the wrong shape or a
    singular M.
    """
    mats = [as_array(X, name, real=True) for X, name in ((M, "M"), (C, "C"), (K, "K"))]
    m = mats[0].shape[0]
    for X, name in zip(mats, "MCK", strict=True):
        if X.shape != (m, m) or m == 0:
            raise ValueError(f"{name} must be a non-empty ({m}, {m}) matrix, got {X.shape}")
    Mm, Cm, Km = mats
    R = as_basis(basis, m)
    cond = np.linalg.cond(Mm)
    if not np.isfinite(cond) or cond > MAX_MASS_CONDITION:
        raise ValueError(
            f"M is singular (condition number {cond:.3g}): the model has no state-space form "
            "with state [q; q̇]"
        )
    lu = scipy.linalg.lu_factor(Mm, check_finite=False)
    MinvK, MinvC, MinvRt = (scipy.linalg.lu_solve(lu, X) for X in (Km, Cm, R.T))
    zero, eye = np.zeros((m, m)), np.eye(m)
    A = np.block([[zero, eye], [-MinvK, -MinvC]])
    B = np.vstack([np.zeros((m, R.shape[0])), MinvRt])
    Cout = np.hstack([R, np.zeros((R.shape[0], m))])
    D = np.zeros((R.shape[0], R.shape[0]))
    return A, B, Cout, D


def state_space(
    M: object, C: object, K: object, basis: object = None
) -> scipy.signal.StateSpace:
    """The continuous ``scipy.signal.StateSpace`` of :func:`state_space_matrices`."""
    return scipy.signal.StateSpace(*state_space_matrices(M, C, K, basis))
