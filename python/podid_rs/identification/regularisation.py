"""Choosing the symmetry weight λ (paper §4.2): L-curve, GCV and the discrepancy principle.

One common λ = λ_M = λ_C = λ_K in the paper's units (eq. 40). :func:`lambda_curve`
returns the whole curve — on a grid of λ the residual ‖Ax − y‖ (eq. 28), the
penalty ‖Lx‖ = (Σ_b ‖X_b − X_bᵀ‖²_F)^½ (eq. 30) and GCV — with the λ each rule
chooses; ``identify(U, F, omega, lam="lcurve" | "gcv" | "discrepancy")`` uses it.

The rules (Section 4.2):

- ``"lcurve"``: the corner of (ln ‖Ax − y‖, ln ‖Lx‖), i.e. the point of maximum
  curvature, found on a fine grid and refined by a bounded scalar search. A
  :class:`NoCornerWarning` says when there is no clear corner: largest curvature
  below ``CORNER_MIN_CURVATURE`` (the curve bends less than a quarter circle of
  radius one decade, typical when the residual hardly depends on λ because the
  data are consistent with symmetric matrices), or largest at an end of the range.
- ``"gcv"``: the minimum of GCV(λ) = ‖Ax − y‖² / (2Nm − t(λ))² (eq. 34 for the real
  stacked problem: 2Nm real equations from N = s·p complex response vectors of
  order m), with t(λ) = tr(A G(λ)⁻¹ Aᵀ) = tr(G(λ)⁻¹ G_d) = 3m² − Σ λ²ν_i/(1 + λ²ν_i)
  the trace of the influence matrix (ν_i as in ``rust/src/sweep.rs``).
- ``"discrepancy"``: the λ with ‖Ax − y‖ = δ (eq. 33), solved on the continuous,
  increasing curve by root finding. δ is the expected norm of the noise part of
  the residual over all lines and load cases (complex 2-norm, the units of F):
  give it as ``delta``, or give the noise on the responses U — ``noise`` = σ, the
  RMS of the complex noise per entry of U (E|e|² = σ²), or ``snr_db`` =
  10 log10(mean |U|² / σ²) — and δ² = σ² Σ_i ‖D̂(ω_i)‖²_F, the noise e_i of each
  response vector seen through the dynamic stiffness D(ω) = −ω²M + iωC + K of the
  unregularised fit (λ = 0). For noise added to full-order responses and
  projected on an orthonormal POD basis, σ is the full-order per-DOF RMS noise.
  Expect δ just above the residual at λ → 0, which absorbs a fraction
  3m²/(2Nm) of the noise: a δ below it (a noise level stated too small, or one
  sample of noise smaller than its expectation) gives a warning and the smallest
  λ, a δ above the exactly symmetric fit's residual the largest.

How: the spectral sweep (Rust, ``rust/src/sweep.rs``) tridiagonalises once the
n_w×n_w skew block of G_d⁻¹ (n_w = 3m(m−1)/2, a quarter of the direct solve's
memory); then the curves cost O(n_w) per λ, exact values and M, C, K O(n_w²).
Where it does not apply — n_w² doubles would not fit in memory, or the
unregularised problem is rank deficient — the curve comes from repeated solves
(``solve``, by default the direct :func:`~podid_rs.identify`; the place where an
iterative solver plugs in): fewer points, the L-curve corner by golden-section
search on the Menger curvature of three points (Cultrera & Callegaro 2020), the
discrepancy λ by root finding; GCV needs the trace and is not available there.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .._memory import fits_in_memory, require_memory
from .._validation import FrequencyData, check_frequency_data
from .result import IdentificationResult, _check_threads, residual_norm
from .solvers import identify_fixed

if TYPE_CHECKING:
    from .._core import LambdaCurvePoints, LambdaSweep

RULES = ("lcurve", "gcv", "discrepancy")
Method = Literal["auto", "spectral", "repeated"]

#: Below this curvature of (ln ‖Ax − y‖, ln ‖Lx‖) the L-curve has no clear corner:
#: a quarter circle of radius one decade, 1/ln 10.
CORNER_MIN_CURVATURE = 1.0 / math.log(10.0)
#: Points per decade of λ of the fine grid the spectral rules search.
FINE_PER_DECADE = 40
#: The golden-section corner search stops when its bracket is this many decades wide.
CORNER_XTOL_DECADES = 0.02
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
_LN10 = math.log(10.0)


class LambdaSelectionWarning(UserWarning):
    """A rule could not choose λ cleanly; the message says why and what was returned.

    Parameters
    ----------
    message : str
        The rule, the problem and the λ returned.
    """


class NoCornerWarning(LambdaSelectionWarning):
    """The L-curve has no clear corner.

    Parameters
    ----------
    message : str
        Why (curvature too small, or largest at an end of the λ range) and the λ returned.
    """


@dataclass(frozen=True)
class LambdaCurve:
    """The λ-curves on a grid and the λ chosen by each rule (paper §4.2).

    What :func:`lambda_curve` returns; ``identify(..., lam=rule)`` keeps it in
    ``info["lambda_curve"]``.

    Attributes
    ----------
    lams : numpy.ndarray, (k,)
        The grid of λ, ascending, paper units (eq. 40); from repeated solves, the grid
        and every λ the searches for the corner and the discrepancy solved at.
    residual_norms : numpy.ndarray, (k,)
        ‖Ax − y‖ (eq. 28) at each λ, exact (solves).
    penalty_norms : numpy.ndarray, (k,)
        ‖Lx‖ = (Σ_b ‖X_b − X_bᵀ‖²_F)^½ (eq. 30) at each λ, exact.
    gcv : numpy.ndarray, (k,)
        GCV(λ) = ‖Ax − y‖²/(rows − trace)² (eq. 34); NaN from repeated solves.
    curvature : numpy.ndarray, (k,)
        Curvature of the L-curve in natural-log coordinates; NaN from repeated solves.
    lam : float
        The λ chosen by ``rule``.
    rule : str
        ``"lcurve"``, ``"gcv"`` or ``"discrepancy"``.
    choices : dict of str to float
        The λ of every rule that could be evaluated.
    problems : dict of str to list of str
        Why a rule's choice is doubtful (the chosen rule's are also issued as warnings).
    corner_curvature : float
        The curvature at the L-curve corner (NaN when not searched).
    target_residual : float or None
        The discrepancy δ (eq. 33), if a noise level was given.
    method : str
        ``"spectral"`` or ``"repeated"``.
    n_rows : int
        2·N·m real equations.
    n_unknowns : int
        3m².
    info : dict
        Timings (spectral) or the number of solves (repeated).
    """

    lams: np.ndarray
    residual_norms: np.ndarray
    penalty_norms: np.ndarray
    gcv: np.ndarray
    curvature: np.ndarray
    lam: float
    rule: str
    choices: dict[str, float]
    problems: dict[str, list[str]]
    corner_curvature: float
    target_residual: float | None
    method: str
    n_rows: int
    n_unknowns: int
    info: dict = field(default_factory=dict, repr=False)


# ---------------------------------------------------------------------------
# the two ways to evaluate the curve


class _Spectral:
    """Curves from the Rust sweep: O(n_w) per λ, exact values O(n_w²)."""

    method = "spectral"

    def __init__(self, sweep: LambdaSweep, threads: int) -> None:
        self.sweep = sweep
        self.threads = threads
        self.n_rows = int(sweep.n_rows)
        self.n_unknowns = int(sweep.n_unknowns)

    def default_range(self) -> tuple[float, float]:
        """From 0.1/√ν_max to 10/√ν_min: every skew direction goes from undamped to damped."""
        nu = np.asarray(self.sweep.eigenvalues)
        top = float(nu.max())
        if not top > 0:
            return 1e-3, 1e3
        low = float(nu[nu > top * 1e-15].min())
        return 0.1 / math.sqrt(top), 10.0 / math.sqrt(low)

    def fine(self, lams: np.ndarray) -> LambdaCurvePoints:
        return self.sweep.curve(np.ascontiguousarray(lams, dtype=float))

    def at(self, t: float) -> LambdaCurvePoints:
        """The spectral curves at the one λ = exp(t)."""
        return self.sweep.curve(np.array([math.exp(t)]))

    def exact(self, lams: np.ndarray) -> LambdaCurvePoints:
        lams = np.ascontiguousarray(lams, dtype=float)
        return self.sweep.curve(lams, exact=True, threads=self.threads)


class _Repeated:
    """Curves from one solve per λ (cached)."""

    method = "repeated"

    def __init__(self, solve: Callable[[float], IdentificationResult], data: FrequencyData):
        self.solve = solve
        self.n_rows = 2 * data.n_columns * data.m
        self.n_unknowns = 3 * data.m * data.m
        self.cache: dict[float, IdentificationResult] = {}
        self._data = data

    def result(self, lam: float) -> IdentificationResult:
        lam = float(lam)
        if lam not in self.cache:
            self.cache[lam] = self.solve(lam)
        return self.cache[lam]

    def point(self, lam: float) -> tuple[float, float]:
        r = self.result(lam)
        return r.residual_norm, r.penalty_norm

    def default_range(self) -> tuple[float, float]:
        """A range from the diagonal of the skew block D of G_d (unscaled, penalty 4λ²).

        The skew directions turn from undamped to damped at λ² = μ_i, the
        eigenvalues of S/4 with S = D − BᵀA⁻¹B ⪯ D; the range runs from three decades
        below the smallest to one above the largest of √(diag D/4). The upper end is
        close to the spectral sweep's; the lower is a heuristic (μ_min ≪ min diag),
        wide on the cases tested.
        """
        from .. import _core

        U, F, w = self._data.columns()
        H, _ = _core.gram(U, F, w)
        m = self._data.m
        d = np.diag(H).reshape(3, m)
        j, k = np.triu_indices(m, 1)
        diag = (d[:, j] + d[:, k]).ravel() / 8.0
        if diag.size == 0 or not diag.max() > 0:
            return 1e-3, 1e3
        return 1e-3 * math.sqrt(diag[diag > 0].min()), 10.0 * math.sqrt(diag.max())


# ---------------------------------------------------------------------------
# the rules on the spectral curve


def _fine_grid(lo: float, hi: float) -> np.ndarray:
    """λ from lo to hi (exactly) on FINE_PER_DECADE points per decade, at least 101."""
    decades = math.log10(hi / lo)
    return np.geomspace(lo, hi, max(101, int(FINE_PER_DECADE * decades) + 1))


def _refine(f: Callable[[float], float], t: np.ndarray, i: int) -> float:
    """Minimise f(t) over [t[i−1], t[i+1]] (bounded Brent); t[i] was the grid minimum."""
    res = minimize_scalar(f, bounds=(t[i - 1], t[i + 1]), method="bounded", options={"xatol": 1e-6})
    return float(res.x) if f(float(res.x)) <= f(float(t[i])) else float(t[i])


def _corner_spectral(ev: _Spectral, lo: float, hi: float) -> tuple[float, float, list[str]]:
    lam = _fine_grid(lo, hi)
    t = np.log(lam)
    kappa = ev.fine(lam).curvature
    if not np.any(np.isfinite(kappa)):
        return math.sqrt(lo * hi), math.nan, ["the L-curve is degenerate (zero penalty)"]
    i = int(np.nanargmax(kappa))
    problems = []
    if 0 < i < t.size - 1:
        lc = math.exp(_refine(lambda x: -float(ev.at(x).curvature[0]), t, i))
    else:
        lc = float(lam[i])
        problems.append("the curvature is largest at an end of the λ range")
    k = float(ev.at(math.log(lc)).curvature[0])
    if not k >= CORNER_MIN_CURVATURE:
        problems.append(
            f"its largest curvature {k:.3g} is below {CORNER_MIN_CURVATURE:.3g} (natural-log "
            "axes); the residual hardly depends on λ, as when the data are consistent with "
            "symmetric matrices (then symmetric=True is the natural choice)"
        )
    return lc, k, problems


def _gcv_spectral(ev: _Spectral, lo: float, hi: float) -> tuple[float, list[str]]:
    lam = _fine_grid(lo, hi)
    t = np.log(lam)
    g = ev.fine(lam).gcv
    i = int(np.nanargmin(g))
    if 0 < i < t.size - 1:
        return math.exp(_refine(lambda x: float(ev.at(x).gcv[0]), t, i)), []
    return float(lam[i]), ["GCV is smallest at an end of the λ range (no interior minimum)"]


def _discrepancy(
    residual: Callable[[float], float], grid: np.ndarray, delta: float
) -> tuple[float, list[str]]:
    """λ with residual(λ) = δ on the increasing curve: bracket on ``grid``, then Brent."""
    r = np.array([residual(lam) for lam in grid])
    if delta <= r[0]:
        return float(grid[0]), [
            f"the target residual δ = {delta:.4g} is below the residual {r[0]:.4g} at the "
            "smallest λ: the stated noise level is too small for these data"
        ]
    if delta >= r[-1]:
        return float(grid[-1]), [
            f"the target residual δ = {delta:.4g} is above the residual {r[-1]:.4g} at the "
            "largest λ: at this noise level the data are consistent with symmetric "
            "matrices (symmetric=True)"
        ]
    j = int(np.argmax(r >= delta))
    ln_delta = math.log(delta)
    root = brentq(
        lambda x: math.log(residual(math.exp(x))) - ln_delta,
        math.log(grid[j - 1]),
        math.log(grid[j]),
        xtol=1e-12,
        rtol=1e-12,
    )
    return math.exp(root), []


# ---------------------------------------------------------------------------
# the L-curve corner from repeated solves


def _menger(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> float:
    """Signed curvature of the circle through three points (positive turning left)."""
    a, b, c = q - p, r - q, r - p
    cross = a[0] * b[1] - a[1] * b[0]
    den = math.hypot(*a) * math.hypot(*b) * math.hypot(*c)
    return 2.0 * cross / den if den > 0 else math.nan


def _corner_golden(ev: _Repeated, grid: np.ndarray) -> tuple[float, float, list[str]]:
    """Golden-section search of the Menger curvature (Cultrera & Callegaro 2020)."""

    def pt(t: float) -> np.ndarray:
        res, pen = ev.point(math.exp(t))
        return np.log([res, pen])

    t = np.log(grid)
    pts = [pt(x) for x in t]
    if any(not np.all(np.isfinite(p)) for p in pts):
        return (
            float(grid[grid.size // 2]),
            math.nan,
            ["the L-curve is degenerate (zero penalty or residual)"],
        )
    kappa = [_menger(pts[i - 1], pts[i], pts[i + 1]) for i in range(1, t.size - 1)]
    i = 1 + int(np.nanargmax(kappa))
    t1, t4 = t[i - 1], t[i + 1]
    t2, t3 = t4 - _GOLDEN * (t4 - t1), t1 + _GOLDEN * (t4 - t1)
    while t4 - t1 > CORNER_XTOL_DECADES * _LN10:
        c2 = _menger(pt(t1), pt(t2), pt(t3))
        c3 = _menger(pt(t2), pt(t3), pt(t4))
        if c2 > c3:
            t4, t3 = t3, t2
            t2 = t4 - _GOLDEN * (t4 - t1)
        else:
            t1, t2 = t2, t3
            t3 = t1 + _GOLDEN * (t4 - t1)
    c2, c3 = _menger(pt(t1), pt(t2), pt(t3)), _menger(pt(t2), pt(t3), pt(t4))
    tc, k = (t2, c2) if c2 > c3 else (t3, c3)
    problems = []
    if not t[1] <= tc <= t[-2]:
        problems.append("the curvature is largest in an end interval of the λ range")
    if not k >= CORNER_MIN_CURVATURE:
        problems.append(
            f"its largest curvature {k:.3g} is below {CORNER_MIN_CURVATURE:.3g} (natural-log "
            "axes); the residual hardly depends on λ"
        )
    return math.exp(tc), k, problems


# ---------------------------------------------------------------------------
# inputs


def _check_rule(rule: object) -> str:
    if not isinstance(rule, str) or rule not in RULES:
        raise ValueError(
            f"lam={rule!r} is not a selection rule; use one of {', '.join(map(repr, RULES))}, "
            "or give a number"
        )
    return rule


def _check_grid(lams: object) -> np.ndarray:
    try:
        a = np.asarray(lams, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"lams must be a 1-D array of positive numbers, got {lams!r}") from None
    a = np.unique(a)
    if a.ndim != 1 or a.size < 3 or not np.all(np.isfinite(a)) or a[0] <= 0:
        raise ValueError("lams must hold at least 3 distinct finite positive values")
    return a


def _target_residual(
    data: FrequencyData, noise: float | None, snr_db: float | None, delta: float | None
) -> float | None:
    """δ from exactly one of ``delta``, ``noise`` (σ on U) and ``snr_db`` (module doc)."""
    values = {"delta": delta, "noise": noise, "snr_db": snr_db}
    given = [k for k, v in values.items() if v is not None]
    if len(given) > 1:
        raise ValueError(f"give at most one of delta, noise and snr_db, got {', '.join(given)}")
    if not given:
        return None
    name = given[0]
    value = float(values[name])
    if not math.isfinite(value) or (name != "snr_db" and value <= 0):
        raise ValueError(f"{name} must be a finite number (positive unless snr_db), got {value!r}")
    if name == "delta":
        return value
    if name == "noise":
        sigma = value
    else:
        sigma = math.sqrt(float(np.mean(np.abs(data.U) ** 2)) * 10.0 ** (-value / 10.0))
    pilot = identify_fixed(data.U, data.F, data.omega, 0.0)
    w = data.omega[:, None, None]
    D = -(w**2) * pilot.M + 1j * w * pilot.C + pilot.K  # (s, m, m)
    return sigma * math.sqrt(data.p * float(np.sum(np.abs(D) ** 2)))


# ---------------------------------------------------------------------------


def _evaluator(
    data: FrequencyData,
    method: str,
    solve: Callable[[float], IdentificationResult] | None,
    threads: int,
    backend: str = "rust",
) -> _Spectral | _Repeated:
    from .. import _core

    if method not in ("auto", "spectral", "repeated"):
        raise ValueError(f"method must be 'auto', 'spectral' or 'repeated', got {method!r}")
    if solve is None:

        def solve(lam: float) -> IdentificationResult:
            # 0 is the core's "all cores", which identify_fixed takes as None
            return identify_fixed(
                data.U, data.F, data.omega, lam, backend=backend, threads=threads or None
            )

    if method == "repeated":
        return _Repeated(solve, data)
    need = int(_core.sweep_memory_bytes(data.m))
    if method == "spectral":
        require_memory(need, "the spectral λ sweep", "use method='repeated'")
    elif not fits_in_memory(need):
        return _Repeated(solve, data)
    U, F, w = data.columns()
    sweep = _core.lambda_sweep(U, F, w, threads=threads)
    if sweep is None:
        if method == "spectral":
            raise ValueError(
                "the spectral λ sweep needs the unregularised problem to be well posed, and "
                "its Gram matrix H is numerically singular; use method='repeated'"
            )
        warnings.warn(
            "the unregularised problem is rank deficient, so the λ-curve comes from "
            "repeated solves (fewer points, no GCV)",
            LambdaSelectionWarning,
            stacklevel=3,
        )
        return _Repeated(solve, data)
    return _Spectral(sweep, threads)


def _check_options(
    rule: str, target: float | None, n: object, lams: object
) -> tuple[int | None, np.ndarray | None]:
    """The cheap checks, before anything is factorised: (n, the grid or None)."""
    if rule == "discrepancy" and target is None:
        raise ValueError("lam='discrepancy' needs the noise level: noise=, snr_db= or delta=")
    if n is not None and (isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 3):
        raise ValueError(f"n must be an integer >= 3, got {n!r}")
    return (None if n is None else int(n)), (None if lams is None else _check_grid(lams))


def _curve(
    rule: str,
    grid: np.ndarray | None,
    n: int | None,
    target: float | None,
    ev: _Spectral | _Repeated,
) -> LambdaCurve:
    if grid is None:
        lo, hi = ev.default_range()
        grid = np.geomspace(lo, hi, n or (50 if ev.method == "spectral" else 12))
    else:
        lo, hi = float(grid[0]), float(grid[-1])
    choices: dict[str, float] = {}
    problems: dict[str, list[str]] = {}
    if isinstance(ev, _Spectral):
        choices["lcurve"], corner_k, problems["lcurve"] = _corner_spectral(ev, lo, hi)
        choices["gcv"], problems["gcv"] = _gcv_spectral(ev, lo, hi)
        if target is not None:
            choices["discrepancy"], problems["discrepancy"] = _discrepancy(
                lambda lam: float(ev.at(math.log(lam)).residual_norm[0]),
                _fine_grid(lo, hi),
                target,
            )
        vals = ev.exact(grid)
        res, pen = vals.residual_norm, vals.penalty_norm
        gcv, kappa = vals.gcv, vals.curvature
    else:
        if rule == "gcv":
            raise ValueError(
                "GCV needs the trace of the influence matrix, which the repeated-solve "
                "λ sweep does not have; use 'lcurve' or 'discrepancy'"
            )
        if rule == "lcurve":
            choices["lcurve"], corner_k, problems["lcurve"] = _corner_golden(ev, grid)
        else:
            corner_k = math.nan
        if target is not None:
            choices["discrepancy"], problems["discrepancy"] = _discrepancy(
                lambda lam: ev.point(lam)[0], grid, target
            )
        grid = np.array(sorted(set(ev.cache) | set(grid.tolist())))
        res, pen = (np.array([ev.point(lam)[k] for lam in grid]) for k in (0, 1))
        gcv = kappa = np.full(grid.size, math.nan)
    if problems.get(rule):
        cls = NoCornerWarning if rule == "lcurve" else LambdaSelectionWarning
        msg = "; ".join(problems[rule])
        warnings.warn(f"{rule}: {msg}; λ = {choices[rule]:.4g} returned", cls, stacklevel=3)
    info = (
        {"timings": dict(ev.sweep.timings)}
        if isinstance(ev, _Spectral)
        else {"solves": len(ev.cache)}
    )
    return LambdaCurve(
        lams=grid,
        residual_norms=np.asarray(res, dtype=float),
        penalty_norms=np.asarray(pen, dtype=float),
        gcv=np.asarray(gcv, dtype=float),
        curvature=np.asarray(kappa, dtype=float),
        lam=float(choices[rule]),
        rule=rule,
        choices=choices,
        problems=problems,
        corner_curvature=float(corner_k),
        target_residual=target,
        method=ev.method,
        n_rows=ev.n_rows,
        n_unknowns=ev.n_unknowns,
        info=info,
    )


def _prepare(U, F, omega, rule, threads):
    data = check_frequency_data(U, F, omega)
    rule = _check_rule(rule)
    nthreads = _check_threads(threads)
    if data.m < 2:
        raise ValueError("order m = 1: a 1×1 matrix is symmetric, there is no λ to choose")
    return data, rule, nthreads


def lambda_curve(
    U: np.ndarray,
    F: np.ndarray,
    omega: np.ndarray,
    lams: np.ndarray | None = None,
    *,
    rule: str = "lcurve",
    n: int | None = None,
    noise: float | None = None,
    snr_db: float | None = None,
    delta: float | None = None,
    method: Method = "auto",
    solve: Callable[[float], IdentificationResult] | None = None,
    threads: int | None = None,
) -> LambdaCurve:
    """The λ-curves of one common symmetry weight and the λ chosen by ``rule`` (paper §4.2).

    One λ = λ_M = λ_C = λ_K in the paper's units (eq. 40); the rules are described in
    the module docstring.

    Parameters
    ----------
    U, F, omega : array_like
        As for :func:`~podid_rs.identify`; the order m must be at least 2.
    lams : array_like, optional
        Grid of λ (paper units) to report, at least 3 distinct positive values; by
        default ``n`` points spanning every skew direction from undamped to damped.
        The rules search the continuous curve between its ends.
    rule : {"lcurve", "gcv", "discrepancy"}
        The rule whose λ is ``lam``.
    n : int, optional
        Points of the default grid, ≥ 3 (default 50 spectral, 12 repeated).
    noise, snr_db, delta : float, optional
        The noise level for the discrepancy principle (at most one): σ, the RMS
        noise per entry of U; 10 log10(mean |U|² / σ²); or δ itself (eq. 33). With
        another rule it adds ``choices["discrepancy"]``.
    method : {"auto", "spectral", "repeated"}
        ``"spectral"`` (one eigendecomposition), ``"repeated"`` (one ``solve`` per
        point) or ``"auto"``: spectral unless its n_w² doubles would not fit in
        memory or the unregularised problem is rank deficient.
    solve : callable, optional
        ``solve(lam) -> IdentificationResult`` for the repeated path; default the
        fixed-λ solve of ``identify(U, F, omega, lam)``. The direct solve needs four
        times the sweep's memory, so where the sweep does not fit only an iterative
        solver will: it plugs in here.
    threads : int, optional
        Worker threads for the Rust core (None = all cores).

    Returns
    -------
    LambdaCurve
        The curves and every rule's λ.

    Raises
    ------
    ValueError
        For malformed data or options, m = 1, an unknown rule, ``"discrepancy"``
        without a noise level, more than one noise level, ``"gcv"`` on the
        repeated path (it needs the sweep's trace), or ``method="spectral"`` on a
        rank-deficient unregularised problem.
    MemoryError
        With ``method="spectral"``, when the sweep would not fit.

    Warns
    -----
    LambdaSelectionWarning
        When the chosen rule has no clean answer (:class:`NoCornerWarning` for the
        L-curve); the λ returned is then its best effort. Also when ``"auto"`` falls
        back to repeated solves on a rank-deficient problem.
    """
    data, rule, nthreads = _prepare(U, F, omega, rule, threads)
    target = _target_residual(data, noise, snr_db, delta)
    n, grid = _check_options(rule, target, n, lams)
    ev = _evaluator(data, method, solve, nthreads)
    return _curve(rule, grid, n, target, ev)


def choose_lambda(
    U: np.ndarray, F: np.ndarray, omega: np.ndarray, rule: str = "lcurve", **kwargs
) -> float:
    """The common λ (paper units, eq. 40) chosen by ``rule``.

    Parameters
    ----------
    U, F, omega : array_like
        As for :func:`~podid_rs.identify`.
    rule : {"lcurve", "gcv", "discrepancy"}
        The rule (paper §4.2).
    **kwargs
        As for :func:`lambda_curve`.

    Returns
    -------
    float
        ``lambda_curve(U, F, omega, rule=rule, **kwargs).lam``.

    Raises
    ------
    ValueError, MemoryError
        As for :func:`lambda_curve`.
    """
    return lambda_curve(U, F, omega, rule=rule, **kwargs).lam


def identify_with_rule(
    U: np.ndarray,
    F: np.ndarray,
    omega: np.ndarray,
    rule: str,
    *,
    symmetric: bool = False,
    backend: str = "rust",
    threads: int | None = None,
    noise: float | None = None,
    snr_db: float | None = None,
) -> IdentificationResult:
    """``identify(U, F, omega, lam=rule)``: choose λ by ``rule``, identify at it.

    The result's ``lam`` is (λ, λ, λ) and ``info["lambda_curve"]`` the
    :class:`LambdaCurve`. On the spectral path with the Rust backend M, C, K come
    from the sweep itself (method ``"spectral-sweep"``, no second factorisation);
    otherwise from a solve at the chosen λ.
    """
    if symmetric:
        raise ValueError(
            f"lam={rule!r} chooses the symmetry weight; symmetric=True has none to choose"
        )
    if backend not in ("rust", "numpy"):
        raise ValueError(f"backend must be 'rust' or 'numpy', got {backend!r}")
    data, rule, nthreads = _prepare(U, F, omega, rule, threads)
    target = _target_residual(data, noise, snr_db, None)
    _check_options(rule, target, None, None)
    ev = _evaluator(data, "auto", None, nthreads, backend)
    curve = _curve(rule, None, None, target, ev)
    lam = curve.lam
    if isinstance(ev, _Repeated):
        res = ev.result(lam)
    elif backend == "numpy":
        res = identify_fixed(data.U, data.F, data.omega, lam, backend="numpy")
    else:
        M, C, K = ev.sweep.solve(lam, threads=nthreads)
        pen = tuple(float(np.linalg.norm(X - X.T)) for X in (M, C, K))
        res = IdentificationResult(
            M=M,
            C=C,
            K=K,
            lam=(lam, lam, lam),
            symmetric=False,
            residual_norm=residual_norm(M, C, K, data),
            penalty_norms=(pen[0], pen[1], pen[2]),
            method="spectral-sweep",
            rank=ev.n_unknowns,
            n_unknowns=ev.n_unknowns,
            min_pivot_ratio=float(ev.sweep.min_pivot_ratio),
            backend="rust",
            info={"scaling": tuple(ev.sweep.scaling), "timings": dict(ev.sweep.timings)},
        )
    return dataclasses.replace(res, info={**res.info, "lambda_curve": curve})
