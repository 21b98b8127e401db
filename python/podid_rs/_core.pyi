"""The compiled Rust core of podid_rs (``rust/src/python/``): typed bindings over the
plain Rust functions.

Arrays go in validated and C-contiguous (the package's callers see to it); results
are classes with read-only attributes. ``progress`` and ``threads`` (0: all cores)
are keyword-only; ``progress(iteration, value)`` is called about every 0.1 s, and
Ctrl-C or an exception in it stops an iterative solve. A Rust error is a
``ValueError``, ``MemoryError`` or ``KeyboardInterrupt``; a Rust panic a
``RuntimeError``.

Every function, class, attribute and argument of the module is described here;
``tests/test_core_stub.py`` fails when the two drift apart.
"""

from collections.abc import Callable
from typing import final

import numpy as np
from numpy.typing import NDArray

_Float1 = NDArray[np.float64]
_Float2 = NDArray[np.float64]
_Complex2 = NDArray[np.complex128]
_Progress = Callable[[int, float], object]
_Triple = tuple[float, float, float]

__version__: str

# ---------------------------------------------------------------------------
# identification at a fixed λ (rust/src/python/identify.rs)

@final
class Identified:
    """M, C, K identified at a fixed λ, in the caller's units, with what the solver
    saw. ``iterations``, ``relative_residual`` and ``converged`` are None for the
    direct solve. Built by the core only."""

    @property
    def M(self) -> _Float2:
        """the mass matrix M (m×m)"""

    @property
    def C(self) -> _Float2:
        """the damping matrix C (m×m)"""

    @property
    def K(self) -> _Float2:
        """the stiffness matrix K (m×m)"""

    @property
    def method(self) -> str:
        """how the normal equations were solved: "cholesky", "eigen-min-norm" or "cg\""""

    @property
    def rank(self) -> int:
        """numerical rank of the normal matrix (= n_unknowns when well posed)"""

    @property
    def n_unknowns(self) -> int: ...
    @property
    def min_pivot_ratio(self) -> float:
        """smallest pivot (or eigenvalue) of the normal matrix over its largest (NaN for CG)"""

    @property
    def scaling(self) -> _Triple:
        """(ω0, s_u, s_f): the scales of frequency, responses and forces"""

    @property
    def residual_norm(self) -> float:
        """the data misfit ‖Ax − y‖ of the answer (eq. 28)"""

    @property
    def timings(self) -> dict[str, float]:
        """wall time per phase, seconds"""

    @property
    def iterations(self) -> int | None:
        """CG iterations taken"""

    @property
    def relative_residual(self) -> float | None:
        """the true relative residual ‖b − A x‖/‖b‖ of the answer (scaled problem)"""

    @property
    def converged(self) -> bool | None:
        """whether CG reached its tolerance"""

def gram(
    u: _Complex2, f: _Complex2, omega: _Float1, *, threads: int = 0
) -> tuple[_Float2, _Float2]:
    """Gram products H = Re(V Vᴴ) (3m×3m) and B = Re(F Vᴴ) (m×3m), unscaled.
    u, f: complex (N, m) rows u_i, f_i; omega: (N,)."""

def identify_direct(
    u: _Complex2,
    f: _Complex2,
    omega: _Float1,
    lam: _Triple,
    symmetric: bool,
    *,
    threads: int = 0,
) -> Identified:
    """Direct identification (paper eq. 49 in the symmetric/skew basis)."""

def identify_cg(
    u: _Complex2,
    f: _Complex2,
    omega: _Float1,
    lam: _Triple,
    symmetric: bool,
    tol: float,
    max_iter: int,
    *,
    progress: _Progress | None = None,
    threads: int = 0,
) -> Identified:
    """Matrix-free identification by preconditioned CG, to the relative residual
    ``tol`` in at most ``max_iter`` iterations; ``progress(iteration, recursive
    relative residual)``."""

def direct_memory_bytes(m: int, lam: _Triple, symmetric: bool) -> int:
    """Bytes of the largest dense matrix the direct path would allocate."""

def cg_memory_bytes(m: int, symmetric: bool) -> int:
    """Bytes of the matrix-free solver's working set."""

def operator_gemm_gflops(m: int, repeat: int = 3, threads: int = 0) -> float:
    """GFLOP/s of faer's GEMM in the shape of one CG operator apply (m×3m by
    3m×3m), best of ``repeat``: the benchmarks' floor."""

# ---------------------------------------------------------------------------
# the λ sweep (rust/src/python/sweep.rs)

@final
class LambdaCurvePoints:
    """The λ-curves at each λ asked for, one array per quantity. Built by the core only."""

    @property
    def residual_norm(self) -> _Float1:
        """‖Ax − y‖ (eq. 28)"""

    @property
    def penalty_norm(self) -> _Float1:
        """‖Lx‖, the symmetry penalty (eq. 30)"""

    @property
    def trace(self) -> _Float1:
        """tr(A G(λ)⁻¹ Aᵀ): the effective number of parameters"""

    @property
    def gcv(self) -> _Float1:
        """the generalised cross-validation function (eq. 34)"""

    @property
    def curvature(self) -> _Float1:
        """signed curvature of the L-curve (natural-log axes)"""

@final
class LambdaSweep:
    """The λ-curves of one common symmetry weight from one eigendecomposition.
    Built by :func:`lambda_sweep`; holds n_w² doubles."""

    @property
    def m(self) -> int:
        """The order m."""

    @property
    def n_rows(self) -> int:
        """Real equations 2·N·m of the stacked problem."""

    @property
    def n_unknowns(self) -> int:
        """Unknowns 3m²."""

    @property
    def eigenvalues(self) -> _Float1:
        """ν_i (1/λ² units): skew direction i is damped by 1/(1 + λ²ν_i)."""

    @property
    def min_pivot_ratio(self) -> float:
        """min L_ii²/H_ii of the Cholesky factor of H (≈ 1/cond(H) up to a modest factor)."""

    @property
    def scaling(self) -> _Triple:
        """(ω0, s_u, s_f): the scales of frequency, responses and forces."""

    @property
    def timings(self) -> dict[str, float]:
        """Wall time per phase of the factorisation, seconds."""

    def curve(self, lams: _Float1, *, exact: bool = False, threads: int = 0) -> LambdaCurvePoints:
        """The λ-curves at each λ of ``lams`` (paper units); ``exact`` refines residual
        and penalty by solves."""

    def solve(self, lam: float, *, threads: int = 0) -> tuple[_Float2, _Float2, _Float2]:
        """(M, C, K) at λ (paper units)."""

def lambda_sweep(
    u: _Complex2, f: _Complex2, omega: _Float1, *, threads: int = 0
) -> LambdaSweep | None:
    """Factor once for the λ-curves; None when H is not positive definite."""

def sweep_memory_bytes(m: int) -> int:
    """Bytes of the largest matrix :func:`lambda_sweep` allocates."""

# ---------------------------------------------------------------------------
# output-error refinement (rust/src/python/refine.rs)

@final
class RefineOptions:
    """How the Levenberg–Marquardt iteration runs; the defaults are the Rust defaults."""

    def __init__(
        self,
        *,
        max_iter: int = 200,
        ftol: float = 1e-7,
        xtol: float = 1e-12,
        log_diagonal: bool = True,
        solver: str = "auto",
        curvature: bool = False,
        modal_metric: bool = False,
        acceleration: bool = False,
    ) -> None: ...
    @property
    def max_iter(self) -> int:
        """most Gauss–Newton steps (accepted or not)"""

    @property
    def ftol(self) -> float:
        """converged when the last accepted steps lowered the cost by less than this,
        relative, per step"""

    @property
    def xtol(self) -> float:
        """converged when ‖δθ‖ ≤ xtol·(‖θ‖ + xtol)"""

    @property
    def log_diagonal(self) -> bool:
        """the factors' diagonals as exp(θ): M, C, K positive definite for every θ"""

    @property
    def solver(self) -> str:
        """the step's linear algebra: "dense", "matrix-free" or "auto\""""

    @property
    def curvature(self) -> bool:
        """add the curvature of the parametrisation to the Gauss–Newton matrix"""

    @property
    def modal_metric(self) -> bool:
        """matrix-free step only: damp and precondition by the modal metric"""

    @property
    def acceleration(self) -> bool:
        """dense step only: add the geodesic acceleration to each step"""

@final
class ColumnWeights:
    """One scalar weight w_ij ≥ 0 per column: the cost Σ w_ij² ‖x_ij − u_ij‖²."""

    def __init__(self, weights: _Float1) -> None: ...
    @property
    def weights(self) -> _Float1:
        """(s·p,) the weight of each column, line-major"""

@final
class MatrixWeights:
    """One real m×m matrix T_ij per column: the cost Σ ‖T_ij (x_ij − u_ij)‖²."""

    def __init__(self, matrices: _Float2) -> None: ...
    @property
    def matrices(self) -> _Float2:
        """(s·p, m·m) the T_ij of each column, row-major"""

@final
class LogMagnitudeWeights:
    """The log-magnitude output error on n measured entries y = R x: the cost
    Σ w_ije² (ln|y_ije| − ln|u_ije|)²."""

    def __init__(self, basis: _Float2, targets: _Complex2, entry_weights: _Float2) -> None: ...
    @property
    def basis(self) -> _Float2:
        """R (n, m): the measured entries of a reduced response x are R x"""

    @property
    def targets(self) -> _Complex2:
        """(s·p, n) the measured responses u_ije on the entries"""

    @property
    def entry_weights(self) -> _Float2:
        """(s·p, n) the weight w_ije ≥ 0 of each entry (0: not measured)"""

@final
class Refined:
    """The refined model and what the iteration did. Built by the core only."""

    @property
    def M(self) -> _Float2:
        """the refined mass matrix M (m×m)"""

    @property
    def C(self) -> _Float2:
        """the refined damping matrix C (m×m)"""

    @property
    def K(self) -> _Float2:
        """the refined stiffness matrix K (m×m)"""

    @property
    def cost_start(self) -> float:
        """the cost of the start, caller's units"""

    @property
    def cost(self) -> float:
        """the cost of the answer, caller's units"""

    @property
    def iterations(self) -> int:
        """Gauss–Newton steps taken (accepted or rejected)"""

    @property
    def accepted(self) -> int:
        """Gauss–Newton steps accepted"""

    @property
    def stop(self) -> str:
        """why the iteration stopped"""

    @property
    def converged(self) -> bool:
        """false only when max_iter ended the iteration"""

    @property
    def history(self) -> list[tuple[int, float]]:
        """(iteration, cost) after every accepted step, caller's units"""

    @property
    def scaling(self) -> _Triple:
        """(ω0, s_u, s_f): the scales of frequency, responses and forces"""

    @property
    def timings(self) -> dict[str, float]:
        """wall time per phase, seconds"""

    @property
    def solver(self) -> str:
        """the step solver used: "dense" or "matrix-free\""""

    @property
    def solver_stats(self) -> dict[str, float]:
        """counts of the step solver's work"""

    @property
    def responses_start(self) -> _Complex2 | None:
        """(s·p, m) the model responses of the start as given, in the layout of u;
        None when the start has a pole on a measured line"""

    @property
    def responses(self) -> _Complex2:
        """(s·p, m) the model responses of the answer"""

def refine_output_error(
    u: _Complex2,
    f: _Complex2,
    omega: _Float1,
    p: int,
    start: tuple[_Float2, _Float2, _Float2],
    weighting: ColumnWeights | MatrixWeights | LogMagnitudeWeights,
    options: RefineOptions,
    *,
    progress: _Progress | None = None,
    threads: int = 0,
) -> Refined:
    """Output-error refinement of the start model (M, C, K) on reduced data: u, f
    complex (s·p, m) rows (line-major, load cases inner), omega (s,), p load cases;
    ``progress(iteration, cost)``."""
