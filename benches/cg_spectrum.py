"""Where CG's slow components live: the spectrum of the preconditioned operator.

A dense NumPy model of the matrix-free solver at small m (exact-symmetric mode):
the normal operator G in the pair coordinates of ``rust/src/pairs.rs`` (Q basis of
the summed diagonal blocks of H, sym coordinates, pairs (j ≤ k) in column-major
order), its pair blocks D and the symmetric Gauss–Seidel preconditioner
M = (D + L) D⁻¹ (D + Lᵀ) of ``rust/src/sgs/``. Prints the spectrum of M⁻¹G
(extremes, how many eigenvalues lie outside a central band), dense CG iterations
to tol 1e-11 (random right-hand side), where the eigenvectors of the slowest
eigenvalues live (their weight on each mode of Q), what exact deflation of the k
smallest eigenvectors would save (an upper bound for any deflation or coarse
correction), how many iterations the operator without its skew blocks H̃_MC,
H̃_CK would need (the couplings the pair blocks always drop), and block SGS with
the pairs of each tile of t modes solved together (t = 4 is the leaf of
``rust/src/sgs/leaf.rs``).

    python benches/cg_spectrum.py --m 60 --band narrow
    python benches/cg_spectrum.py --m 30 --tiles 2,4,8 --deflate ""
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg

sys.path.insert(0, str(Path(__file__).parent))
from _common import chain_problem, load_average  # noqa: E402

BANDS = {"narrow": (102.8, 122.8), "wide": (50.0, 150.0)}


def scaled_blocks(U, F, omega):
    """H̃ (3m×3m) in the Q basis and Q's eigenvalues, scaled as docs/design.md §2–4."""
    w0 = np.sqrt(np.mean(omega**2))
    su = np.sqrt(np.mean(np.abs(U) ** 2))
    w, u = omega / w0, U / su
    m = u.shape[1]
    V = np.concatenate([-(w**2)[:, None] * u, 1j * w[:, None] * u, u], axis=1)
    Vr = np.concatenate([V.real, V.imag])
    H = Vr.T @ Vr
    blk = [H[b * m : (b + 1) * m, b * m : (b + 1) * m] for b in range(3)]
    evals, Q = np.linalg.eigh(blk[0] + blk[1] + blk[2])
    Q3 = np.kron(np.eye(3), Q)
    return Q3.T @ H @ Q3, evals


def pair_operator(Ht: np.ndarray, m: int):
    """Dense G on the sym coordinates, pairs (j ≤ k) ordered by k then j, 3 per pair."""
    pairs = [(j, k) for k in range(m) for j in range(k + 1)]
    n = 3 * len(pairs)
    # P: coordinates → Z (m×3m, row-major), orthonormal sym basis
    P = np.zeros((3 * m * m, n))
    for p, (j, k) in enumerate(pairs):
        for b in range(3):
            if j == k:
                P[j * 3 * m + b * m + k, 3 * p + b] = 1.0
            else:
                P[j * 3 * m + b * m + k, 3 * p + b] = np.sqrt(0.5)
                P[k * 3 * m + b * m + j, 3 * p + b] = np.sqrt(0.5)
    # (I_m ⊗ H̃) P: row j of Z times H̃
    KP = np.einsum("jcn,cd->jdn", P.reshape(m, 3 * m, n), Ht).reshape(3 * m * m, n)
    G = P.T @ KP
    return 0.5 * (G + G.T), pairs


def cg_iterations(A, b, tol=1e-11, max_iter=5000, apply_m=None):
    """Plain PCG on dense A; returns iterations to ‖b − Ax‖/‖b‖ ≤ tol."""
    x = np.zeros_like(b)
    r = b.copy()
    z = apply_m(r) if apply_m else r
    p = z.copy()
    rz = r @ z
    bn = np.linalg.norm(b)
    for it in range(1, max_iter + 1):
        q = A @ p
        a = rz / (p @ q)
        x += a * p
        r -= a * q
        if np.linalg.norm(r) / bn <= tol:
            return it
        z = apply_m(r) if apply_m else r
        rz, rz_old = r @ z, rz
        p = z + (rz / rz_old) * p
    return max_iter


def block_sgs(
    G: np.ndarray, blocks: list[int], omega: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Ĝ = C⁻¹ G C⁻ᵀ of block SGS over consecutive diagonal blocks of the given sizes,
    C = (D + L) R_D⁻ᵀ (C Cᵀ = M = (D + L) D⁻¹ (D + Lᵀ)); returns (Ĝ, C). With
    ``omega`` ≠ 1 block SSOR: D/ω in place of D, C = (D/ω + L) R_D⁻ᵀ √ω."""
    n = G.shape[0]
    Dm = np.zeros_like(G)
    s = 0
    for size in blocks:
        Dm[s : s + size, s : s + size] = G[s : s + size, s : s + size]
        s += size
    Rd = np.linalg.cholesky(Dm)
    C = (
        (Dm / omega + np.tril(G) - np.tril(Dm))
        @ scipy.linalg.solve_triangular(Rd, np.eye(n), lower=True).T
        * np.sqrt(omega)
    )
    X = scipy.linalg.solve_triangular(C, G, lower=True)
    Gh = scipy.linalg.solve_triangular(C, X.T, lower=True)
    return 0.5 * (Gh + Gh.T), C


def tiled(pairs: list[tuple[int, int]], t: int) -> tuple[np.ndarray, list[int]]:
    """Coordinate order with the pairs grouped in tiles of t modes (tile columns, then
    tile rows, column-major inside, as ``pairs.rs``) and the tiles' sizes."""
    key = [(k // t, j // t, k, j) for j, k in pairs]
    order = sorted(range(len(pairs)), key=lambda p: key[p])
    sizes: list[int] = []
    for i, p in enumerate(order):
        if i and key[p][:2] == key[order[i - 1]][:2]:
            sizes[-1] += 3
        else:
            sizes.append(3)
    return np.concatenate([[3 * p, 3 * p + 1, 3 * p + 2] for p in order]), sizes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--m", type=int, default=60)
    ap.add_argument("--band", default="narrow", choices=sorted(BANDS))
    ap.add_argument("--deflate", default="5,10,20,40,80")
    ap.add_argument("--tiles", default="2,4", help="tile sizes of the exact-tile variant")
    args = ap.parse_args()
    m = args.m
    t0 = time.perf_counter()
    _, U, F, omega = chain_problem(m, BANDS[args.band], 2 * m)
    Ht, _ = scaled_blocks(U, F, omega)
    G, pairs = pair_operator(Ht, m)
    n = G.shape[0]
    Gh, C = block_sgs(G, [3] * len(pairs))
    lam, V = np.linalg.eigh(Gh)
    b = np.random.default_rng(0).standard_normal(n)
    it_sgs = cg_iterations(Gh, b)
    print(
        f"m = {m}, {args.band}, n = {n}: SGS-preconditioned spectrum "
        f"[{lam[0]:.3g}, {lam[-1]:.3g}], κ = {lam[-1] / lam[0]:.3g}; dense CG {it_sgs} it",
        flush=True,
    )
    qs = np.quantile(lam, [0.01, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99])
    print("quantiles 1/5/25/50/75/95/99 %: " + ", ".join(f"{q:.3g}" for q in qs))
    print("smallest 12: " + ", ".join(f"{x:.3g}" for x in lam[:12]))
    for c in (0.1, 0.2, 0.5):
        print(f"eigenvalues below {c}: {int(np.sum(lam < c))}")
    # where the slowest eigenvectors live: weight of each mode (Q's ascending order)
    # in the coordinates x = C⁻ᵀ v (the change of X̃), each pair counted for j and k
    w_mode = np.zeros((12, m))
    for i in range(12):
        x2 = scipy.linalg.solve_triangular(C.T, V[:, i], lower=False).reshape(-1, 3) ** 2
        for p, (j, k) in enumerate(pairs):
            w_mode[i, j] += x2[p].sum()
            w_mode[i, k] += x2[p].sum()
        w_mode[i] /= w_mode[i].sum()
    top = np.argsort(-w_mode.sum(axis=0))[:10]
    print(
        "modes carrying the 12 slowest eigenvectors (index in Q's ascending order, weight): "
        + ", ".join(f"{k} ({w_mode[:, k].sum() / 12:.2f})" for k in top)
    )
    part = 1.0 / np.sum(w_mode**2, axis=1)
    print("effective modes per slow eigenvector: " + ", ".join(f"{x:.1f}" for x in part))
    for k in [int(x) for x in args.deflate.split(",") if x]:
        W, lamk = V[:, :k], lam[:k]
        it = cg_iterations(
            Gh, b, apply_m=lambda r, W=W, lamk=lamk: r + W @ ((1 / lamk - 1) * (W.T @ r))
        )
        print(f"exact deflation of the {k} smallest: {it} it (without: {it_sgs})", flush=True)
    del Gh, C, V
    # the skew blocks H̃_MC, H̃_CK (zero diagonal in any basis: never in the pair blocks)
    d = np.sqrt(np.diag(Ht))
    Hs = Ht / np.outer(d, d)  # scaled as the pair blocks see it
    sizes = []
    for a, c, name in (
        (0, 0, "MM"),
        (1, 1, "CC"),
        (2, 2, "KK"),
        (0, 2, "MK"),
        (0, 1, "MC"),
        (1, 2, "CK"),
    ):
        B = Hs[a * m : (a + 1) * m, c * m : (c + 1) * m]
        sizes.append(f"{name} {np.linalg.norm(B - np.diag(np.diag(B))):.3g}")
    print("off-diagonal Frobenius norms of the scaled blocks of H̃: " + ", ".join(sizes))
    H0 = Ht.copy()
    for a, c in ((0, 1), (1, 0), (1, 2), (2, 1)):
        H0[a * m : (a + 1) * m, c * m : (c + 1) * m] = 0.0
    it0 = cg_iterations(block_sgs(pair_operator(H0, m)[0], [3] * len(pairs))[0], b)
    print(f"the same SGS on the operator without the skew blocks: {it0} it", flush=True)
    for t in [int(x) for x in args.tiles.split(",") if x]:
        idx, sizes = tiled(pairs, t)
        Gt = G[np.ix_(idx, idx)]
        it_pairs = cg_iterations(block_sgs(Gt, [3] * len(pairs))[0], b[idx])
        it_tiles = cg_iterations(block_sgs(Gt, sizes)[0], b[idx])
        print(
            f"tiles of {t} modes: pair blocks {it_pairs} it, each tile's pairs solved "
            f"together {it_tiles} it",
            flush=True,
        )
    print(f"{time.perf_counter() - t0:.0f} s, load {load_average()}")


if __name__ == "__main__":
    main()
