"""``identify()``: the public entry point of the paper's estimator (eq. 49).

A number or a triple λ goes to the fixed-λ solvers (:mod:`.solvers`), the name of
a rule that chooses λ to :mod:`.regularisation`, which itself solves through
:mod:`.solvers`. Neither of them imports this module.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .regularisation import identify_with_rule
from .result import IdentificationResult
from .solvers import CG_MAX_ITER, CG_TOL, Backend, Solver, identify_fixed


def identify(
    U: np.ndarray,
    F: np.ndarray,
    omega: np.ndarray,
    lam: float | tuple[float, float, float] | str = 0.0,
    symmetric: bool = False,
    *,
    backend: Backend = "rust",
    threads: int | None = None,
    noise: float | None = None,
    snr_db: float | None = None,
    solver: Solver = "auto",
    tol: float = CG_TOL,
    max_iter: int = CG_MAX_ITER,
    progress: bool | Callable[[int, float], object] = False,
) -> IdentificationResult:
    """Identify reduced M, C, K from responses U and forces F (paper eq. 49).

    Parameters
    ----------
    U, F : array_like, complex, (s, m) or (s, m, p)
        Reduced responses and forces (eqs. 45–46), frequency-first, p load cases.
    omega : array_like, (s,)
        Angular frequencies in rad/s, all > 0.
    lam : float, (λ_M, λ_C, λ_K), or {"lcurve", "gcv", "discrepancy"}
        Symmetry regularisation in the paper's units (eq. 40); 0 = plain least
        squares. A rule chooses one common λ (paper §4.2,
        :mod:`podid_rs.identification.regularisation`); the result's ``lam`` holds
        it and ``info["lambda_curve"]`` the whole curve.
    symmetric : bool
        Solve the exact λ → ∞ limit (M, C, K exactly symmetric).
    backend : {"rust", "numpy"}
        The same equations either way; ``"rust"`` (default) is faster.
    threads : int, optional
        Worker threads for the Rust backend (None = all cores).
    noise, snr_db : float, optional
        The noise on U for ``lam="discrepancy"`` (at most one): RMS σ per entry, or
        10 log10(mean |U|² / σ²).
    solver : {"auto", "direct", "cg"}
        ``"direct"`` (dense normal matrix, Cholesky), ``"cg"`` (matrix-free
        preconditioned conjugate gradients, Rust backend only: O(m²) memory, about
        18m³ flops per iteration) or ``"auto"``: direct when the problem is
        unregularised (a 3m×3m system), or when it has at most
        ``AUTO_DIRECT_MAX_UNKNOWNS`` = 300 unknowns (m ≤ 10 with a penalty,
        m ≤ 13 exact-symmetric) and its dense matrix takes at most half the
        available memory; CG otherwise. Measured on the full-order chain
        (``benches/bench_cg.py --auto``, s = 2m lines, both modes, 20 % and
        50–150 Hz bands, whole calls): CG is faster from 100–170 unknowns on
        (1.3–4.7× at 300–650 unknowns, 4–20× at 1200–1900), except on 50–150 Hz
        exact-symmetric, where it needs 80–300 iterations at m ≤ 17 and is level
        with the direct path up to about 460 unknowns (0.87–1.3×). Up to 300
        unknowns both take under 1.5 ms, and the direct path also reveals rank
        deficiency, which CG cannot: where CG stops by itself above ``tol`` and the
        problem has at most ``AUTO_FALLBACK_MAX_UNKNOWNS`` = 4800 unknowns, ``auto``
        redoes it by the direct path (``info["stalled_cg"]`` then says what CG
        reached).
    tol : float
        CG stops when the relative residual of the scaled normal equations is
        ≤ ``tol`` (default ``CG_TOL`` = 1e-11, which matched the direct answer to
        3e-9 in our tests).
    max_iter : int
        CG iteration limit (default 10 000).
    progress : bool or callable
        CG only: ``True`` draws a tqdm progress bar (iterations, residual) on stderr
        when it is a terminal; a callable is called as ``progress(iteration,
        residual)`` about every 0.1 s and after the last iteration (residual: the
        iteration's recursively updated one). Ctrl-C, or an exception raised by the
        callable, stops the solve and propagates.

    Returns
    -------
    IdentificationResult
        M, C, K and what the solver saw (method, rank, residual ‖Ax − y‖ of eq. 28).

    Raises
    ------
    ValueError
        For malformed data or options, a problem with fewer equations than
        unknowns, ``noise``/``snr_db`` without ``lam="discrepancy"``, or a rule with
        ``symmetric=True``.
    MemoryError
        When the chosen solver's memory would not fit.

    Warns
    -----
    RankDeficientWarning
        A numerically singular problem (direct path): the minimum-norm answer is
        returned, and the warning states the rank.
    ConvergenceWarning
        CG stopped at ``max_iter`` (or at its attainable accuracy) above ``tol``: its
        answer is returned, and the warning states the achieved residual.
    LambdaSelectionWarning
        A rule could not choose λ cleanly (:class:`NoCornerWarning` for the L-curve).
    """
    if isinstance(lam, str):
        return identify_with_rule(
            U,
            F,
            omega,
            lam,
            symmetric=symmetric,
            backend=backend,
            threads=threads,
            noise=noise,
            snr_db=snr_db,
        )
    if noise is not None or snr_db is not None:
        raise ValueError("noise and snr_db set the discrepancy target; they need lam='discrepancy'")
    return identify_fixed(
        U,
        F,
        omega,
        lam,
        symmetric,
        backend=backend,
        threads=threads,
        solver=solver,
        tol=tol,
        max_iter=max_iter,
        progress=progress,
        stacklevel=3,
    )
