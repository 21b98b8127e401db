"""Preconditioner variants for the matrix-free CG that did not help.

Dense NumPy models at small m, built like ``benches/cg_spectrum.py`` (the scaled H̃
of docs/design.md §2–4, the exact-symmetric operator G in pair coordinates, dense CG to tol
1e-11 on a random right-hand side), each printing CG iterations:

- ``--part basis``: the pair-block symmetric Gauss–Seidel of ``rust/src/sgs/`` in
  other mode bases Q: the solver's (eigenvectors of the summed diagonal blocks,
  ascending), that basis descending or shuffled, each diagonal block's own
  eigenvectors, the sum of the blocks scaled to unit trace, and real Schur vectors
  of the skew blocks T₁, T₃ (which would put their couplings inside 2×2 mode
  blocks); with pair blocks and with 2- and 4-mode tiles solved exactly.
- ``--part dilu``: SGS with the pair blocks replaced by DILU's
  D'_p = D_p − Σ_{q<p} G_pq D'_q⁻¹ G_qp (or relaxed, D − ω(D − D')), which keeps
  the cost of an iteration; reports whether D' stays positive definite.
- ``--part split``: the coordinates of each pair changed to (M, C, P = K − M) — in the
  scaled units (ω0 = 1) W = P + iC is the dynamic stiffness at the band's centre, whose
  block of G is nearly complex-linear, so a complex basis would diagonalise it and its
  skew couplings with it — and the whole {C, P} block solved *exactly* against the M
  block: block Jacobi and block SGS over these two (or three) big blocks, an upper bound
  for any preconditioner built on that idea.
- ``--part ssor``: symmetric SOR, the solver's pair-block SGS with D scaled to D/ω
  (Eisenstat's trick carries over at the same cost per iteration): iterations and
  κ(M⁻¹G) for ω from 0.9 to 1.7.
- ``--part rows``: the exact inverse of the row operator Z ↦ Z H̃ (one Cholesky of
  H̃, X ↦ X H̃⁻¹) as the preconditioner of the penalty mode (λ = 100 on every block)
  and, symmetrised, of the exact-symmetric mode; prints κ(H̃) and the scaled
  penalties 4λ̃² of docs/design.md §3.

    python3 benches/cg_variants.py --m 30 --part basis
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as sl

sys.path.insert(0, str(Path(__file__).parent))
from _common import chain_problem  # noqa: E402
from cg_spectrum import BANDS, block_sgs, cg_iterations, pair_operator, tiled  # noqa: E402


def scaled(U, F, omega):
    """H̃ (3m×3m), B̃ (m×3m) in the caller's basis and the scales (ω0, s_u, s_f)."""
    w0 = np.sqrt(np.mean(omega**2))
    su, sf = np.sqrt(np.mean(np.abs(U) ** 2)), np.sqrt(np.mean(np.abs(F) ** 2))
    w, u, f = omega / w0, U / su, F / sf
    V = np.concatenate([-(w**2)[:, None] * u, 1j * w[:, None] * u, u], axis=1)
    Vr, Fr = np.concatenate([V.real, V.imag]), np.concatenate([f.real, f.imag])
    return Vr.T @ Vr, Fr.T @ Vr, (w0, su, sf)


def sgs_iterations(H, Q, m, tiles=(1,)):
    """Dense CG iterations of block SGS in basis Q: pair blocks (t = 1) or t-mode tiles."""
    Q3 = np.kron(np.eye(3), Q)
    G, pairs = pair_operator(Q3.T @ H @ Q3, m)
    b = np.random.default_rng(0).standard_normal(G.shape[0])
    out = []
    for t in tiles:
        if t == 1:
            out.append(cg_iterations(block_sgs(G, [3] * len(pairs))[0], b))
        else:
            idx, sizes = tiled(pairs, t)
            out.append(cg_iterations(block_sgs(G[np.ix_(idx, idx)], sizes)[0], b[idx]))
    return out


def solver_operator(H, m):
    """G in the solver's pair coordinates (Q: eigenvectors of the summed diagonal
    blocks) and the random right-hand side every part uses."""
    _, Q = np.linalg.eigh(sum(H[b * m : (b + 1) * m, b * m : (b + 1) * m] for b in range(3)))
    Q3 = np.kron(np.eye(3), Q)
    G, _ = pair_operator(Q3.T @ H @ Q3, m)
    return G, np.random.default_rng(0).standard_normal(G.shape[0])


def part_basis(H, m):
    blk = [H[b * m : (b + 1) * m, b * m : (b + 1) * m] for b in range(3)]
    T3, T1 = H[m : 2 * m, :m], H[2 * m :, m : 2 * m]
    _, Q = np.linalg.eigh(blk[0] + blk[1] + blk[2])
    cases = {
        "sum of the diagonal blocks, ascending (the solver's)": Q,
        "the same, descending": Q[:, ::-1],
        "the same, shuffled": Q[:, np.random.default_rng(1).permutation(m)],
        "diagonal blocks scaled to unit trace, summed": np.linalg.eigh(
            sum(b / (np.trace(b) / m) for b in blk)
        )[1],
    }
    for name, b in zip("MCK", blk, strict=True):
        cases[f"eigenvectors of H̃_{name}{name}"] = np.linalg.eigh(b)[1]
    for name, T in (("T₁", T1), ("T₃", T3)):
        cases[f"real Schur vectors of {name}"] = sl.schur(T, output="real")[1]
    for name, Qc in cases.items():
        it = sgs_iterations(H, Qc, m, tiles=(1, 2, 4))
        print(f"{name}: pair blocks {it[0]}, tiles of 2 / 4 modes {it[1]} / {it[2]} it", flush=True)


def part_dilu(H, m):
    G, b = solver_operator(H, m)
    n, P = G.shape[0], G.shape[0] // 3
    low = np.tril(G, -1)
    for p in range(P):
        low[3 * p : 3 * p + 3, 3 * p : 3 * p + 3] = 0.0
    D = [G[3 * p : 3 * p + 3, 3 * p : 3 * p + 3].copy() for p in range(P)]
    Dp, inv = [], []
    for p in range(P):
        acc = D[p].copy()
        for q in range(p):
            g = G[3 * p : 3 * p + 3, 3 * q : 3 * q + 3]
            if np.any(g):
                acc -= g @ inv[q] @ g.T
        Dp.append(acc)
        inv.append(np.linalg.inv(acc))
    print(f"DILU pair blocks: smallest eigenvalue {min(np.linalg.eigvalsh(d)[0] for d in Dp):.3g}")
    for om in (0.0, 0.05, 0.1, 0.2, 0.5, 1.0):
        Dm = np.zeros_like(G)
        for p in range(P):
            Dm[3 * p : 3 * p + 3, 3 * p : 3 * p + 3] = D[p] - om * (D[p] - Dp[p])
        try:
            R = np.linalg.cholesky(Dm)
        except np.linalg.LinAlgError:
            print(f"ω = {om}: D' not positive definite")
            continue
        C = (Dm + low) @ sl.solve_triangular(R, np.eye(n), lower=True).T
        Gh = sl.solve_triangular(C, sl.solve_triangular(C, G, lower=True).T, lower=True)
        print(f"ω = {om}: {cg_iterations(0.5 * (Gh + Gh.T), b)} it", flush=True)


def part_split(H, m):
    G, b = solver_operator(H, m)
    P = G.shape[0] // 3
    print(f"pair-block SGS (the solver's): {cg_iterations(block_sgs(G, [3] * P)[0], b)} it")
    S = np.kron(np.eye(P), np.array([[1.0, 0, 0], [0, 1, 0], [1, 0, 1]]))  # (M, C, P) → (M, C, K)
    Gy = S.T @ G @ S
    iM = 3 * np.arange(P)
    iC, iP = iM + 1, iM + 2
    iCP = np.sort(np.r_[iC, iP])

    def jacobi(groups):
        L = np.zeros_like(Gy)
        for g in groups:
            L[np.ix_(g, g)] = np.linalg.cholesky(Gy[np.ix_(g, g)])
        Gh = sl.solve_triangular(L, sl.solve_triangular(L, Gy, lower=True).T, lower=True)
        return cg_iterations(0.5 * (Gh + Gh.T), b)

    print(f"block Jacobi, exact {{C, P}} and {{M}}: {jacobi([iCP, iM])} it")
    print(f"block Jacobi, exact {{C}}, {{P}}, {{M}}: {jacobi([iC, iP, iM])} it")
    for first, second, name in ((iCP, iM, "{C, P} then {M}"), (iM, iCP, "{M} then {C, P}")):
        order = np.r_[first, second]
        Gs = block_sgs(Gy[np.ix_(order, order)], [len(first), len(second)])[0]
        print(f"block SGS, exact {name}: {cg_iterations(Gs, b[order])} it", flush=True)


def part_ssor(H, m):
    G, b = solver_operator(H, m)
    for om in (0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7):
        Gh = block_sgs(G, [3] * (G.shape[0] // 3), omega=om)[0]
        ev = np.linalg.eigvalsh(Gh)
        print(f"ω = {om}: {cg_iterations(Gh, b)} it, κ = {ev[-1] / ev[0]:.3g}", flush=True)


def pcg(op, prec, B, tol=1e-11, max_iter=3000):
    X, R = np.zeros_like(B), B.copy()
    Z = prec(R)
    P, rz, bn = Z.copy(), np.vdot(R, Z), np.linalg.norm(B)
    for it in range(1, max_iter + 1):
        Q = op(P)
        a = rz / np.vdot(P, Q)
        X += a * P
        R -= a * Q
        if np.linalg.norm(R) / bn <= tol:
            return it
        Z = prec(R)
        rz, old = np.vdot(R, Z), rz
        P = Z + rz / old * P
    return max_iter


def part_rows(H, B, m, scales, lam=100.0):
    w0, su, _ = scales
    ev = np.linalg.eigvalsh(H)
    pen = 4 * (np.array([lam / (su * w0**2), lam / (su * w0), lam / su])) ** 2
    print(f"H̃: eigenvalues [{ev[0]:.3g}, {ev[-1]:.3g}], κ = {ev[-1] / ev[0]:.3g}; 4λ̃² = {pen}")
    cf = sl.cho_factor(H)

    def op_pen(X):
        Y = X @ H
        for b in range(3):
            Xb = X[:, b * m : (b + 1) * m]
            Y[:, b * m : (b + 1) * m] += 0.5 * pen[b] * (Xb - Xb.T)
        return Y

    def sym(X):
        return np.concatenate(
            [0.5 * (X[:, b * m : (b + 1) * m] + X[:, b * m : (b + 1) * m].T) for b in range(3)],
            axis=1,
        )

    rows = lambda R: sl.cho_solve(cf, R.T).T  # noqa: E731
    print(f"penalty mode, X ↦ X H̃⁻¹: {pcg(op_pen, rows, B)} it (of at most 3000)")
    it = pcg(lambda X: sym(X @ H), lambda R: sym(rows(R)), sym(B))
    print(f"exact-symmetric, sym(X H̃⁻¹): {it} it (of at most 3000)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--m", type=int, default=30)
    ap.add_argument("--band", default="narrow", choices=sorted(BANDS))
    ap.add_argument("--part", default="basis", choices=["basis", "dilu", "split", "ssor", "rows"])
    args = ap.parse_args()
    _, U, F, omega = chain_problem(args.m, BANDS[args.band], 2 * args.m)
    H, B, scales = scaled(U, F, omega)
    print(f"m = {args.m}, {args.band} band, {2 * args.m} lines", flush=True)
    if args.part == "basis":
        part_basis(H, args.m)
    elif args.part == "dilu":
        part_dilu(H, args.m)
    elif args.part == "split":
        part_split(H, args.m)
    elif args.part == "ssor":
        part_ssor(H, args.m)
    else:
        part_rows(H, B, args.m, scales)


if __name__ == "__main__":
    main()
