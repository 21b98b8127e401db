"""The output-error problem of ``podid_rs.identification.refinement.refine`` written in NumPy.

The same parametrisation as the Rust core (``rust/src/refine``): data scaled as in
docs/design.md §3 (ω by its RMS, u and f by their RMS), θ = the lower triangles of the
Cholesky factors of M̃, C̃, K̃ (row by row, diagonals as log|L_jj| with
``log_diagonal``), X = L Lᵀ + 1e-10·‖L‖²_F·I, the start factored after raising its
eigenvalues to the same floors, and the residual r = w·(D(ω)⁻¹ f − u) per column
stacked as [Re r, Im r]. The cost Σ‖r‖² times s_u² is the cost ``refine`` reports.

Used by ``bench_refine.py`` to give ``scipy.optimize.least_squares`` exactly the
problem podid_rs solves, with the analytic Jacobian (checked against finite
differences by :func:`check_jacobian`).
"""

from __future__ import annotations

import numpy as np

#: X = L Lᵀ + CONDITION_FLOOR·tr(L Lᵀ)·I (rust/src/refine/parametrisation.rs)
CONDITION_FLOOR = 1e-10
#: least damping ratio of the start's C (rust/src/refine/start.rs ``damping_floor``)
C_START_FLOOR = 1e-4


def _rms(z: np.ndarray) -> float:
    v = float(np.sqrt(np.mean(np.abs(z) ** 2)))
    return v if v > 0 and np.isfinite(v) else 1.0


def _psd_factor(x: np.ndarray, floor: float) -> np.ndarray:
    d, q = np.linalg.eigh(0.5 * (x + x.T))
    y = (q * np.maximum(d, floor)) @ q.T
    return np.linalg.cholesky(0.5 * (y + y.T))


def damping_floor(M: np.ndarray, C: np.ndarray, K: np.ndarray, zeta0: float) -> np.ndarray:
    """C raised so that Z = (2Ω)^-½ Φᵀ C Φ (2Ω)^-½ (Φ the mass-normalised undamped
    modes) has eigenvalues ≥ ζ₀; C itself when it has (as the Rust core does)."""
    dm, qm = np.linalg.eigh(0.5 * (M + M.T))
    m_half, m_inv_half = (qm * np.sqrt(dm)) @ qm.T, (qm / np.sqrt(dm)) @ qm.T
    w2, V = np.linalg.eigh(0.5 * (m_inv_half @ K @ m_inv_half + (m_inv_half @ K @ m_inv_half).T))
    w = np.sqrt(np.maximum(w2, 0.0))
    d = np.sqrt(2 * np.maximum(w, 1e-6 * max(w.max(), np.finfo(float).tiny)))
    phi = m_inv_half @ V
    Z = (phi.T @ C @ phi) / np.outer(d, d)
    dz, qz = np.linalg.eigh(0.5 * (Z + Z.T))
    if np.all(dz >= zeta0):
        return C
    Zr = (qz * np.maximum(dz, zeta0)) @ qz.T
    left = m_half @ V
    Cr = left @ (np.outer(d, d) * Zr) @ left.T
    return 0.5 * (Cr + Cr.T)


class OutputError:
    """Residual, Jacobian and cost of the output error in θ (scaled units).

    ``U``, ``F`` are ``(s, m, p)``, ``w`` the scalar weight per column ``(s, p)``.
    """

    def __init__(self, U, F, omega, w, log_diagonal: bool = True) -> None:
        self.omega0 = float(np.sqrt(np.mean(omega**2)))
        self.su, self.sf = _rms(U), _rms(F)
        self.fac = np.array(
            [self.sf / (self.su * self.omega0**2), self.sf / (self.su * self.omega0),
             self.sf / self.su]
        )  # fmt: skip
        self.w = omega / self.omega0
        self.u = U / self.su
        self.f = F / self.sf
        self.wt = np.asarray(w, dtype=float)
        self.log_diagonal = log_diagonal
        s, m, p = U.shape
        self.m = m
        self.rows, self.cols = np.tril_indices(m)  # row-major order of the lower triangle
        self.nb = len(self.rows)
        self.diag = self.rows == self.cols
        # φ_b(ω): δD = −ω² δM + iω δC + δK
        self.phi = np.stack([-(self.w**2) + 0j, 1j * self.w, np.ones_like(self.w) + 0j])

    # --- parametrisation -------------------------------------------------------------
    def theta_from_model(self, M, C, K) -> np.ndarray:
        """θ of a physical start (caller's units), as the Rust core builds it."""
        sc = [X / f for X, f in zip((M, C, K), self.fac, strict=True)]
        ref = max(np.abs(sc[0]).max(), np.abs(sc[2]).max())
        # take off the parametrisation's floor ε tr(L Lᵀ) I (tr X = (1 + mε) tr(L Lᵀ))
        m = len(M)
        sc = [
            X - max(CONDITION_FLOOR * np.trace(X) / (1 + m * CONDITION_FLOOR), 0.0) * np.eye(m)
            for X in sc
        ]
        Lm, Lk = _psd_factor(sc[0], 1e-12 * ref), _psd_factor(sc[2], 1e-12 * ref)
        sc[1] = damping_floor(Lm @ Lm.T, sc[1], Lk @ Lk.T, C_START_FLOOR)
        th = []
        for X in sc:
            L = _psd_factor(X, 1e-12 * ref)
            t = L[self.rows, self.cols].copy()
            if self.log_diagonal:
                t[self.diag] = np.log(np.maximum(np.abs(t[self.diag]), np.finfo(float).tiny))
            th.append(t)
        return np.concatenate(th)

    def factors(self, theta: np.ndarray) -> list[np.ndarray]:
        out = []
        for b in range(3):
            t = theta[b * self.nb : (b + 1) * self.nb].copy()
            if self.log_diagonal:
                t[self.diag] = np.exp(t[self.diag])
            L = np.zeros((self.m, self.m))
            L[self.rows, self.cols] = t
            out.append(L)
        return out

    @staticmethod
    def gram(L: np.ndarray) -> np.ndarray:
        return L @ L.T + CONDITION_FLOOR * np.sum(L * L) * np.eye(len(L))

    def model(self, theta: np.ndarray) -> list[np.ndarray]:
        """M, C, K in the caller's units."""
        return [self.gram(L) * f for L, f in zip(self.factors(theta), self.fac, strict=True)]

    # --- residual, Jacobian ----------------------------------------------------------
    def _solve(self, theta: np.ndarray):
        Ls = self.factors(theta)
        X = [self.gram(L) for L in Ls]
        D = (self.phi[0][:, None, None] * X[0] + self.phi[1][:, None, None] * X[1]
             + X[2][None].astype(complex))  # fmt: skip
        Dinv = np.linalg.inv(D)
        x = Dinv @ self.f  # (s, m, p)
        return Ls, Dinv, x

    def residual(self, theta: np.ndarray) -> np.ndarray:
        _, _, x = self._solve(theta)
        r = self.wt[:, None, :] * (x - self.u)
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    def cost(self, theta: np.ndarray) -> float:
        """Σ‖w(x − u)‖² in the caller's units (as ``refine`` reports it)."""
        return float(np.sum(self.residual(theta) ** 2)) * self.su**2

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """∂r/∂θ, (2·s·m·p) × 3·m(m+1)/2: δx = −D⁻¹ δD x, δX = δL Lᵀ + L δLᵀ + floor."""
        Ls, Dinv, x = self._solve(theta)
        s, m, p = x.shape
        blocks = []
        dx = Dinv @ x  # D⁻¹ x, for the floor term
        r, c = self.rows, self.cols
        for b, L in enumerate(Ls):
            a = np.einsum("ck,scp->skp", L, x)  # (Lᵀx)_k
            dinv_l = Dinv @ L  # (D⁻¹L)[:, k]
            # δX x for θ=(j,k): e_j (Lᵀx)_k + ℓ_k x_j + 2ε L_jk x; J = −wφ D⁻¹ (δX x),
            # built on the lower triangle only: t[s, row, p, q] for q = (j, k) = (r_q, c_q)
            t = (Dinv[:, :, None, r] * a[:, None, c, :].transpose(0, 1, 3, 2)
                 + dinv_l[:, :, None, c] * x[:, None, r, :].transpose(0, 1, 3, 2))  # fmt: skip
            t += 2 * CONDITION_FLOOR * dx[:, :, :, None] * L[r, c]
            if self.log_diagonal:
                t[..., self.diag] *= np.diag(L)
            t *= -(self.wt[:, None, :, None] * self.phi[b][:, None, None, None])
            blocks.append(t.reshape(s * m * p, self.nb))
        J = np.concatenate(blocks, axis=1)
        return np.concatenate([J.real, J.imag], axis=0)


def check_jacobian(pb: OutputError, theta: np.ndarray, h: float = 1e-6, n: int = 12) -> float:
    """Largest relative difference of ``n`` Jacobian columns against central differences."""
    J = pb.jacobian(theta)
    rng = np.random.default_rng(0)
    worst = 0.0
    for q in rng.choice(len(theta), size=min(n, len(theta)), replace=False):
        tp, tm = theta.copy(), theta.copy()
        tp[q] += h
        tm[q] -= h
        fd = (pb.residual(tp) - pb.residual(tm)) / (2 * h)
        worst = max(worst, float(np.linalg.norm(fd - J[:, q]) / max(np.linalg.norm(fd), 1e-300)))
    return worst
