"""The modal start: a model rebuilt from its in-band poles, shapes by linear least squares.

An output-error fit continued order by order (:mod:`.order`) can reach a good model of
the band's resonances and still stall in a poor local minimum for what lies outside
it: on a structure with damping ratios of 10⁻⁴ (peaks one line wide) it holds the four
in-band modes to 10⁻⁵ in frequency while standing in for a mode 45 % above the band
with a pair of damped poles in the band's top decade, 1–1.4 dB off there
(``benches/bench_measured.py``, the high-resolution case). The Levenberg–Marquardt
iteration cannot move such poles far: each step is local.

:func:`modal_start` keeps what the fit knows well — its poles in the band — and
rebuilds the rest, as a modal-fit tool (LSFD) would:

1. the poles of ``model`` whose natural frequency lies in the band and whose damping
   ratio is below ``ZETA_MAX`` are kept; one pole below the band
   (ω_lo / ``RESIDUAL_FACTOR``) and one above (ω_hi · ``RESIDUAL_FACTOR``, both at
   ζ = ``RESIDUAL_ZETA``) stand in for the modes outside it, where the order leaves
   room;
2. with those poles fixed, the FRFs are linear in the modal constants: for every
   load case (a unit force at one measured DOF),
   u_c(ω) ≈ Σ_k r_k,c / (ω_k² − ω² + 2iζ_kω_kω), fitted by least squares with the
   refinement's relative weights (1/‖u_c‖ per line), real residues r_k,c ∈ ℝⁿ (real
   normal modes);
3. each mode's residues over the load cases are the rank-one product φ_k φ_k[inputs]ᵀ
   of its shape at the measured DOFs (the leading singular pair; a mode whose
   driving-point residue comes out negative gets a zero shape);
4. the model is the modal one written in the order's coordinates: with A ``(m, m)``
   such that R A = Φ (R the observation matrix), M = A⁻ᵀA⁻¹, K = A⁻ᵀ diag(ω_k²) A⁻¹,
   C = A⁻ᵀ diag(2ζ_kω_k) A⁻¹ — symmetric, M, K ≻ 0, C ⪰ 0 by construction. The
   directions R A leaves empty (latent coordinates, fewer modes than m, shapes the
   basis does not hold) are completed by the SVD of A, the missing modes placed far
   above the band (``FILL_FACTOR`` · ω_hi and up); a mode that would not show on the
   measured DOFs is seen slightly at one of them (``FILL_SEEN``).

The final fit (:func:`~podid_rs.final_fit`) starts from this model when its weighted
output error is lower than the held-out fit's, and otherwise from the held-out fit.
"""

from __future__ import annotations

import numpy as np

from .holes import check_measured

#: poles of the model kept: in the band, damping ratio below this (residual terms above)
ZETA_MAX = 0.2
#: the residual poles: below the band at ω_lo / RESIDUAL_FACTOR, above at ω_hi · it
RESIDUAL_FACTOR = 1.5
RESIDUAL_ZETA = 0.01
#: completing modes start at FILL_FACTOR · ω_hi; one that would not show on the measured
#: DOFs is seen at one of them with FILL_SEEN times the typical scale of the shapes
FILL_FACTOR = 10.0
FILL_SEEN = 0.1
#: alternating least-squares sweeps of a mode's rank-one residues over a grid with holes
RANK_ONE_ITER = 500
#: a start whose change of coordinates A is this badly conditioned is not built
MAX_CONDITION = 1e12


def _poles_in_band(model: object, w_lo: float, w_hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies (rad/s) and damping ratios of ``model``'s underdamped poles
    in ``[w_lo, w_hi]`` with ζ < ZETA_MAX, by the state matrix (M ≻ 0)."""
    M, C, K = (np.asarray(getattr(model, name), dtype=float) for name in ("M", "C", "K"))
    if not (M.ndim == 2 and M.shape[0] == M.shape[1] and M.shape == C.shape == K.shape):
        # else a stack of one matrix would be read as that matrix, other shapes fail in numpy
        raise ValueError(
            f"the model's M, C and K must be square matrices of one shape, got {M.shape}, "
            f"{C.shape} and {K.shape}"
        )
    m = M.shape[0]
    state = np.block([
        [np.zeros((m, m)), np.eye(m)],
        [-np.linalg.solve(M, K), -np.linalg.solve(M, C)],
    ])  # fmt: skip
    lam = np.linalg.eigvals(state)
    lam = lam[lam.imag > 0]
    wn = np.abs(lam)
    zeta = -lam.real / np.where(wn > 0, wn, 1.0)
    keep = (wn >= w_lo) & (wn <= w_hi) & (zeta < ZETA_MAX) & (zeta >= 0)
    order = np.argsort(wn[keep])
    return wn[keep][order], zeta[keep][order]


def _unit_inputs(F_n: np.ndarray) -> np.ndarray | None:
    """The measured DOF each load case drives with a unit force on every line, or None
    when the forces are not of that kind (then no modal start is built)."""
    p = F_n.shape[2]
    inputs = np.empty(p, dtype=np.int64)
    for j in range(p):
        nonzero = np.flatnonzero(np.any(F_n[:, :, j] != 0, axis=0))
        if nonzero.size != 1 or not np.all(F_n[:, nonzero[0], j] == 1):
            return None
        inputs[j] = nonzero[0]
    return inputs


def _residues(U_n, omega, wk, zk, measured) -> np.ndarray:
    """Real residues ``(N, n, p)`` of the modal sum at fixed poles, by weighted least
    squares per load case (relative weights); entries not measured are left at 0."""
    s, n, p = U_n.shape
    den = wk[None, :] ** 2 - omega[:, None] ** 2 + 2j * (zk * wk)[None, :] * omega[:, None]
    out = np.zeros((wk.size, n, p))
    for j in range(p):
        rows = np.ones(n, dtype=bool) if measured is None else measured[:, j]
        u = U_n[:, rows, j]
        norm = np.linalg.norm(u, axis=1)
        w = np.divide(1.0, norm, out=np.zeros_like(norm), where=norm > 0)
        G = w[:, None] / den
        design = np.vstack([G.real, G.imag])
        target = np.vstack([(w[:, None] * u).real, (w[:, None] * u).imag])
        out[:, rows, j] = np.linalg.lstsq(design, target, rcond=None)[0]
    return out


def _shape(residue: np.ndarray, inputs: np.ndarray, known: np.ndarray | None) -> np.ndarray:
    """φ with φ φ[inputs]ᵀ closest to ``residue`` ``(n, p)`` on the ``known`` entries
    (the leading singular pair; with holes, alternating least squares from that of
    the known entries); a zero shape where φ[inputs]² < 0."""
    # the start from the known entries only: a value at a hole left in the SVD can
    # dominate its leading pair, and the sweeps then crawl from there
    u, sv, vt = np.linalg.svd(residue if known is None else known * residue,
                              full_matrices=False)
    a, b = u[:, 0] * sv[0], vt[0]
    if known is not None:  # rank one on the known entries: a_i b_j ≈ r_ij
        w = known.astype(float)
        for _ in range(RANK_ONE_ITER):
            a_next = (w * residue) @ b / np.maximum(w @ b**2, np.finfo(float).tiny)
            b = (w * residue).T @ a_next / np.maximum(w.T @ a_next**2, np.finfo(float).tiny)
            done = np.linalg.norm(a_next - a) <= 1e-15 * np.linalg.norm(a_next)
            a = a_next
            if done:
                break
    # φ = c a with φ[inputs] ≈ b / c: c² = (a[inputs] · b) / ‖a[inputs]‖²
    at_inputs = a[inputs]
    scale2 = float(at_inputs @ b) / max(float(at_inputs @ at_inputs), np.finfo(float).tiny)
    return np.sqrt(max(scale2, 0.0)) * a


def modal_start(
    model: object,
    R: np.ndarray,
    U_n: np.ndarray,
    F_n: np.ndarray,
    omega: np.ndarray,
    measured: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``model`` rebuilt from its poles in the band, with shapes fitted linearly.

    Parameters
    ----------
    model : IdentificationResult or SecondOrderSystem
        A physical model of order m (M ≻ 0), e.g. the order sweep's held-out fit.
    R : numpy.ndarray, (n, m)
        Its observation matrix on the measured DOFs (``[R_p, 0]``, docs/design.md §11).
    U_n, F_n : numpy.ndarray, (s, n, p)
        Measured responses and forces on the measured DOFs, on the lines to fit.
    omega : numpy.ndarray, (s,)
        Those lines (rad/s); their range is the band.
    measured : numpy.ndarray of bool, (n, p), optional
        The entries measured (holes weigh nothing).

    Returns
    -------
    (M, C, K) or None
        The modal start (symmetric, M, K ≻ 0, C ⪰ 0), or None where it does not apply:
        forces that are not a unit force at one measured DOF per load case (FRFs), or
        a change of coordinates too badly conditioned to write down.

    Raises
    ------
    ValueError
        For forces ``F_n`` of another shape than the responses ``U_n``, or a model whose
        M, C and K are not square matrices of one shape.
    """
    U_n = np.asarray(U_n)
    F_n = np.asarray(F_n)
    s, n, p = U_n.shape
    if F_n.shape != (s, n, p):  # else the forces' DOFs and load cases would be read as U_n's
        raise ValueError(f"F_n must have the shape of U_n {U_n.shape}, got {F_n.shape}")
    m = R.shape[1]
    measured = check_measured(measured, n, p)
    inputs = _unit_inputs(F_n)
    if inputs is None or s < 2:
        return None
    w_lo, w_hi = float(np.min(omega)), float(np.max(omega))
    wk, zk = _poles_in_band(model, w_lo, w_hi)
    wk, zk = wk[:m], zk[:m]
    residual = ([w_lo / RESIDUAL_FACTOR] if w_lo > 0 else []) + [w_hi * RESIDUAL_FACTOR]
    room = m - wk.size
    wk = np.concatenate([wk, residual[:room]])
    zk = np.concatenate([zk, np.full(min(room, len(residual)), RESIDUAL_ZETA)])
    residues = _residues(U_n, np.asarray(omega, dtype=float), wk, zk, measured)
    shapes = np.stack([_shape(r, inputs, measured) for r in residues], axis=1)  # (n, N)
    seen = np.linalg.norm(shapes, axis=0) > 0  # a mode with no shape is a completing one
    wk, zk, shapes = wk[seen], zk[seen], shapes[:, seen]
    # coordinates × modes: R A = Φ on the observed coordinates, completed to invertible
    observed = np.linalg.norm(R, axis=0) > 0
    A = np.zeros((m, m))
    A[np.ix_(observed, np.arange(wk.size))] = R[:, observed].T @ shapes
    u, sv, vt = np.linalg.svd(A)
    rank = int(np.sum(sv > 1e-3 * sv[0])) if sv[0] > 0 else 0
    scale = float(np.median(sv[:rank])) if rank else 1.0
    A = A + scale * u[:, rank:] @ vt[rank:]
    rows = np.flatnonzero(observed)
    unseen = np.flatnonzero(np.linalg.norm(A[observed], axis=0) < 1e-3 * scale)
    A[rows[np.arange(unseen.size) % rows.size], unseen] += FILL_SEEN * scale
    if not np.all(np.isfinite(A)) or np.linalg.cond(A) > MAX_CONDITION:
        return None
    # the completing modes lie far above the band
    w_all = np.concatenate([wk, FILL_FACTOR * w_hi * (1.0 + np.arange(m - wk.size))])
    z_all = np.concatenate([zk, np.full(m - wk.size, RESIDUAL_ZETA)])
    A_inv = np.linalg.inv(A)
    M = A_inv.T @ A_inv
    K = A_inv.T @ (w_all[:, None] ** 2 * A_inv)
    C = A_inv.T @ ((2.0 * z_all * w_all)[:, None] * A_inv)
    return (M + M.T) / 2, (C + C.T) / 2, (K + K.T) / 2
