"""Latent coordinates: models with more degrees of freedom than measured points.

The POD basis R_p ``(n, k)`` of a test spans at most its n measured DOFs, so a model
on that basis alone has at most n degrees of freedom — on a three-point hammer test,
three modes, however many the band holds. A model of order m > k keeps the k POD
coordinates, observed through R_p, and adds l = m − k **latent coordinates** that no
sensor sees and no measured force drives. Its observation matrix is

    R = [R_p, 0]  (n × m),    H(ω) = R (−ω²M + iωC + K)⁻¹ Rᵀ  on the measured DOFs,

and M, C, K (m × m, symmetric, M, K ≻ 0, C ⪰ 0 as every refined model) are the
matrices of generalised coordinates observed through R — not the POD projection of
physical matrices (docs/design.md §11).

Zero latent columns lose nothing: when the POD basis spans every measured DOF (k = n,
which is when latent coordinates are needed), any observation matrix [R_p, R_l]
equals [R_p, 0] after the change of coordinates q_p ← q_p + R_pᵀR_l q_l, which leaves
H(ω) unchanged. What remains free — the gauge — is every change q = T q' with
T = [[I, 0], [T_lp, T_ll]] (l·k + l² directions): it maps M, C, K to TᵀMT, TᵀCT,
TᵀKT and leaves R, the forces and H(ω) as they are. The refinement does not fix it:
Levenberg–Marquardt's damping keeps the step finite along those directions, where
the cost is flat, and everything a user reads — the FRFs, natural frequencies,
damping ratios and mode shapes on the measured DOFs — is the same along them.

:func:`latent_starts` makes the starts of an order with one latent coordinate more:
one mode at a peak of the previous model's residual, with its shape at the sensors
taken from the residual there (the counterpart on latent coordinates of the
order sweep's residual-peak start), or one below or above the band standing in for a
residual term.
"""

from __future__ import annotations

import numpy as np

from .._arrays import as_array
from ..systems import SecondOrderSystem

#: a column of the observation matrix counts as zero (latent) below this norm
ZERO_COLUMN = 1e-12
#: residual peaks tried per new latent coordinate, and the damping ratios tried at each
PEAKS = 4
PEAK_ZETAS = (0.002, 0.005, 0.01, 0.03)
#: relative offsets of the natural frequency tried around a peak's line (between lines)
PEAK_OFFSETS = (-0.003, 0.0, 0.003)
#: no latent start when the weighted residual is below this fraction of the weighted
#: data (round-off); none from a mode whose modal mass exceeds MAX_MASS_RATIO times the
#: model's largest mass eigenvalue (it would explain next to nothing, and wreck the
#: conditioning of M: the new mass enters the observed block as μφφᵀ)
NOTHING_LEFT = 1e-20
MAX_MASS_RATIO = 1e8
#: a residual term: a mode at this factor below the band's lowest line and above its
#: highest, with this damping ratio
RESIDUAL_FACTOR = 2.0
RESIDUAL_ZETA = 0.05


def observation_matrix(basis: object, m: int) -> np.ndarray:
    """The observation matrix R ``(n, m)`` of an order-m model on ``basis``.

    ``basis`` is ``(n, k)``: k orthonormal columns (POD modes), possibly followed by
    zero columns (an observation matrix returned earlier). For m ≥ k the result is
    ``[R_p, 0]``: the first k coordinates are observed through the orthonormal columns,
    the other m − k are latent.

    Parameters
    ----------
    basis : array_like, ``(n, k)``
        Orthonormal columns, then zero columns (latent coordinates), if any.
    m : int
        Order of the model, at least the number of orthonormal columns.

    Returns
    -------
    numpy.ndarray
        ``(n, m)`` float64, the orthonormal columns then ``m − k_obs`` zero columns.

    Raises
    ------
    ValueError
        If ``basis`` is not 2-D, its nonzero columns are not orthonormal or not
        first, or m is not an integer (a bool is not) or is below their number.
    """
    R = as_array(basis, "basis", real=True)
    if R.ndim != 2 or R.shape[0] == 0 or R.shape[1] == 0:
        raise ValueError(f"basis must be a non-empty (n, k) array, got shape {R.shape}")
    k = observed_count(R)
    if isinstance(m, bool) or not isinstance(m, int | np.integer):
        raise ValueError(f"the model's order m must be an integer, got {m!r}")
    if m < k:
        raise ValueError(
            f"the model's order m = {m} is below the {k} observed coordinates of the basis"
        )
    out = np.zeros((R.shape[0], int(m)))
    out[:, :k] = R[:, :k]
    return out


def observed_count(R: np.ndarray) -> int:
    """Number k of observed coordinates of an observation matrix ``[R_p, 0]``.

    Parameters
    ----------
    R : numpy.ndarray
        ``(n, m)`` real.

    Returns
    -------
    int
        The number of leading orthonormal columns; the rest are zero.

    Raises
    ------
    ValueError
        If a nonzero column follows a zero one, or the nonzero columns are not
        orthonormal (RᵀR = I to 1e-8).
    """
    norms = np.linalg.norm(R, axis=0)
    nonzero = norms > ZERO_COLUMN
    k = int(np.sum(nonzero))
    if not np.all(nonzero[:k]):
        raise ValueError(
            "basis must have its orthonormal (observed) columns first and its zero "
            "(latent) columns last"
        )
    Rp = R[:, :k]
    if not np.allclose(Rp.T @ Rp, np.eye(k), atol=1e-8):
        raise ValueError("basis must have orthonormal columns (RᵀR = I), as POD modes do")
    return k


def gauge_dimension(m: int, k: int) -> int:
    """Directions of M, C, K (in the 3m(m+1)/2 of their factors) that leave every
    response on the measured DOFs unchanged: l·k + l² for l = m − k latent coordinates."""
    latent = max(m - k, 0)
    return latent * k + latent * latent


def free_parameters(m: int, k: int) -> int:
    """Parameters of an order-m model with k observed coordinates that the data can
    determine at most: 3m(m+1)/2 less the gauge, :func:`gauge_dimension`."""
    return 3 * m * (m + 1) // 2 - gauge_dimension(m, k)


def _with_mode(
    model: tuple[np.ndarray, np.ndarray, np.ndarray],
    shape: np.ndarray,
    mode: tuple[float, float, float],
) -> tuple[np.ndarray, ...]:
    """(M, C, K) of order m + 1: the model plus one mode on a new latent coordinate.

    In coordinates y = [q; η] (the model's and the mode's) the new model is
    diag(M, μ), diag(C, γ), diag(K, κ); the mode shows at the observed coordinates
    with ``shape`` φ, x = T y with T = [[I, φ̂], [0, 1]] (φ̂ = φ on the observed
    coordinates, 0 on the latent ones), so the matrices are T⁻ᵀ diag(·) T⁻¹ — still
    symmetric positive definite — and the new coordinate x_m = η is latent: no
    sensor sees it and no measured force drives it.
    """
    m = model[0].shape[0]
    T = np.eye(m + 1)
    T[: shape.size, m] = shape
    Ti = np.linalg.inv(T)
    out = []
    for X, v in zip(model, mode, strict=True):
        Y = np.zeros((m + 1, m + 1))
        Y[:m, :m] = X
        Y[m, m] = v
        Z = Ti.T @ Y @ Ti
        out.append(0.5 * (Z + Z.T))
    return tuple(out)


def latent_starts(
    model: tuple[np.ndarray, np.ndarray, np.ndarray],
    U_n: np.ndarray,
    F_n: np.ndarray,
    omega: np.ndarray,
    R: np.ndarray,
    weights: np.ndarray,
    measured: np.ndarray | None = None,
) -> list[tuple[float, tuple[np.ndarray, ...], str]]:
    """Starts of order m + 1 that add one latent coordinate to ``model`` (order m).

    Where the data exceed the model most — the lines where ‖U − R x‖² / ‖R x‖² has
    its ``PEAKS`` largest local maxima (a resonance the model lacks: measured response
    far above the model's) — one mode is added at that line's frequency (and
    ``PEAK_OFFSETS`` around it), with its shape at the observed coordinates the
    dominant direction of the residual there, Re(r rᴴ)'s leading eigenvector, and
    ``PEAK_ZETAS`` damping; its modal mass comes from linear least squares on the
    weighted residual. Beside those, a mode ``RESIDUAL_FACTOR`` below the band's
    lowest line and above its highest (a residual term) with the residual's shape at
    the band's edge. Of each candidate frequency the best by that cost is kept (its
    immediate gain may be small: Levenberg–Marquardt then moves the mode where it fits).

    Parameters
    ----------
    model : tuple of numpy.ndarray
        (M, C, K) of order m, symmetric positive definite.
    U_n, F_n : numpy.ndarray
        ``(s, n, p)`` measured responses and the forces on the measured DOFs.
    omega : numpy.ndarray
        ``(s,)`` rad/s.
    R : numpy.ndarray
        ``(n, m)`` observation matrix of ``model`` (:func:`observation_matrix`).
    weights : numpy.ndarray
        ``(s, p)`` non-negative weight of each line and load case.
    measured : numpy.ndarray of bool, (n, p), optional
        The entries that were measured: the residual counts only those (default all).

    Returns
    -------
    list of (float, tuple of numpy.ndarray, str)
        ``(cost, (M, C, K) of order m + 1, what was added)``, one per candidate
        frequency; empty when no candidate fits with a positive modal mass of at most
        ``MAX_MASS_RATIO`` times the model's largest, or the model already reproduces
        the data to round-off.
    """
    s = omega.size
    k = observed_count(R)
    Rp = R[:, :k]
    X = np.einsum("nm,smp->snp", R,
                  SecondOrderSystem(*model).response(omega, np.einsum("nm,snp->smp", R, F_n)))
    if measured is not None:
        X = X * measured  # a hole is no residual: the model's response there is not compared
    residual = U_n - X
    r = np.einsum("nk,snp->skp", Rp, residual)  # the residual in the observed coordinates
    f = np.einsum("nk,snp->skp", Rp, F_n)
    w2 = weights**2
    base = float(np.sum(w2[:, None, :] * np.abs(r) ** 2))  # the cost without a new mode
    scale = float(np.sum(w2[:, None, :] * np.abs(np.einsum("nk,snp->skp", Rp, U_n)) ** 2))
    if base <= NOTHING_LEFT * scale:
        return []  # the model already reproduces the data to round-off: nothing to add
    max_mass = MAX_MASS_RATIO * float(np.linalg.eigvalsh(0.5 * (model[0] + model[0].T))[-1])
    excess = np.sum(np.abs(residual) ** 2, axis=(1, 2)) / np.maximum(
        np.sum(np.abs(X) ** 2, axis=(1, 2)), np.finfo(float).tiny
    )
    inner = np.flatnonzero((excess[1:-1] >= excess[:-2]) & (excess[1:-1] >= excess[2:])) + 1
    peaks = inner[np.argsort(excess[inner])[::-1][:PEAKS]]
    candidates = [(int(i), [omega[i] * (1 + d) for d in PEAK_OFFSETS], PEAK_ZETAS, "peak")
                  for i in peaks]
    candidates += [
        (0, [omega[0] / RESIDUAL_FACTOR], (RESIDUAL_ZETA,), "residual term below the band"),
        (s - 1, [omega[-1] * RESIDUAL_FACTOR], (RESIDUAL_ZETA,), "residual term above the band"),
    ]
    out = []
    for i, frequencies, zetas, kind in candidates:
        _, V = np.linalg.eigh(np.real(r[i] @ r[i].conj().T))
        shape = V[:, -1]
        modal_force = np.einsum("k,skp->sp", shape, f)  # φᵀ f per line and load case
        best = None
        for wc in frequencies:
            for zeta in zetas:
                d = wc**2 - omega**2 + 2j * zeta * wc * omega
                g = shape[None, :, None] * (modal_force / d[:, None])[:, None, :]  # × 1/μ
                num = float(np.sum(w2[:, None, :] * np.real(np.conj(g) * r)))
                den = float(np.sum(w2[:, None, :] * np.abs(g) ** 2))
                if den <= 0 or num <= 0:
                    continue  # no positive modal mass fits
                a = num / den
                if 1.0 / a > max_mass:
                    continue  # the mode explains next to nothing
                cost = float(np.sum(w2[:, None, :] * np.abs(a * g - r) ** 2))
                if best is None or cost < best[0]:
                    mu = 1.0 / a
                    name = (f"latent DOF at {wc / (2 * np.pi):.4g} Hz" if kind == "peak"
                            else f"latent DOF: {kind}")
                    best = (cost, (mu, 2 * zeta * wc * mu, wc**2 * mu), name)
        if best is not None:
            cost, mode, name = best
            out.append((cost, _with_mode(model, shape, mode), name))
    return out
