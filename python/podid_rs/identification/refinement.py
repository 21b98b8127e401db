"""Output-error refinement: reduced M, C, K that reproduce the measured responses.

The paper's estimator (eq. 49) minimises the *equation error*
Σ‖(−ω²M + iωC + K)u − f‖²: it weighs each line by |D(ω)|² (off-resonance and
high-frequency lines dominate), treats the measured u as exact (noise on u biases
it), and guarantees nothing physical — on real data its models can be unstable
and many dB off the measurement (docs/design.md §6). :func:`refine` starts from such a
model and minimises the *output error*

    Σ_ij ‖W_ij (D(ω_i)⁻¹ f_ij − u_ij)‖²

over all lines i and load cases j by Levenberg–Marquardt with the analytic
Jacobian, in the Rust core (one complex LU per line per iteration, parallel over
lines, GIL released, Ctrl-C interruptible). M, C, K are parametrised by Cholesky
factors (M = L_M L_Mᵀ, …), with the diagonals of L_M and L_K as exponentials, so
every refined model is symmetric with M, K positive definite and C positive
semidefinite: stable by construction. Weights W:

* ``"relative"`` (default): 1/‖u_ij‖ per column (on the measured DOFs when a basis
  is given) — each line counts alike, close to a fit of the log-magnitude, which is
  how FRFs are read;
* ``"uniform"``: 1 — maximum likelihood for white noise on the outputs;
* an array: per line ``(s,)``, per column ``(s, p)``, or, with ``basis`` and data
  on the measured DOFs, per entry ``(s, n)``/``(s, n, p)`` (e.g. the coherence).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from .._arrays import as_array
from .._validation import FrequencyData, check_frequency_data
from ..systems import SecondOrderSystem
from .holes import check_measured, measured_metric
from .latent import gauge_dimension, observation_matrix, observed_count
from .result import ConvergenceWarning, IdentificationResult, _check_threads, residual_norm

if TYPE_CHECKING:
    from .._core import ColumnWeights, LogMagnitudeWeights, MatrixWeights

WeightSpec = Literal["relative", "uniform"] | np.ndarray

#: default iteration limit of :func:`refine`
REFINE_MAX_ITER = 200
#: default: :func:`refine` stops when ten accepted steps together lowered the cost by
#: less than ten times this, relative. 1e-4 over ten steps is far below what shows in a
#: dB error (on the beam, 700 more steps past it moved the median by 0.0001 dB); exact
#: data still converge to round-off, because there each step gains orders of magnitude.
REFINE_FTOL = 1e-5
#: the log-magnitude objective leaves out entries below this fraction of the largest
#: entry of their line and load case (240 dB: no measurement resolves them)
LOG_DYNAMIC_RANGE = 1e-12


class StartWarning(UserWarning):
    """The start model of :func:`refine` had to be changed, or is of doubtful quality.

    Parameters
    ----------
    message : str
        What was changed (the eigenvalues raised), or why the start is doubtful.
    """


class _RefineBar:
    """Refinement progress as a tqdm bar on stderr: steps taken and the current cost."""

    def __init__(self, max_iter: int) -> None:
        from .._progress import progress_bar

        self.bar = progress_bar(max_iter, desc="output error", unit="step", leave=True)

    def __call__(self, iteration: int, cost: float) -> None:
        self.bar.n = iteration
        self.bar.set_postfix_str(f"cost {cost:.4g}", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()


def db_errors(X: np.ndarray, U: np.ndarray, measured: np.ndarray | None = None) -> np.ndarray:
    """|20 log10(|X| / |U|)| elementwise (dB), over the entries where both are non-zero
    and, with ``measured`` (an ``(n, p)`` mask of ``(s, n, p)`` arrays), that were measured."""
    a, b = np.abs(X), np.abs(U)
    keep = (a > 0) & (b > 0)
    if measured is not None:
        keep &= measured
    # a difference of logarithms: the ratio of a model value to a 1e-300 one overflows
    return np.abs(20.0 * (np.log10(a[keep]) - np.log10(b[keep])))


def _start_matrices(model: object) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
    """M, C, K of the start, and a note if it came from a rank-deficient solve."""
    if isinstance(model, IdentificationResult):
        note = None
        if not model.well_posed and model.method != "cg":
            note = (
                f"the start model comes from a rank-deficient identification (rank "
                f"{model.rank} of {model.n_unknowns} unknowns): its undetermined part is "
                "arbitrary, and the refinement keeps what the data do not fix"
            )
        return model.M, model.C, model.K, note
    if isinstance(model, SecondOrderSystem):
        return model.M, model.C, model.K, None
    if isinstance(model, tuple | list) and len(model) == 3:
        M, C, K = (as_array(x, name, real=True) for x, name in zip(model, "MCK", strict=True))
        for X, name in ((M, "M"), (C, "C"), (K, "K")):
            if X.ndim != 2 or X.shape[0] != X.shape[1]:
                raise ValueError(f"the start model's {name} must be square, got shape {X.shape}")
        return M, C, K, None
    raise ValueError(
        "model must be an IdentificationResult, a SecondOrderSystem or a tuple (M, C, K), "
        f"got {type(model).__name__}"
    )


#: M or K whose eigenvalues are all at least this fraction of the largest are kept as
#: they are by :func:`physical_start`: the Rust core's floor ε = 1e-10 (X = L Lᵀ +
#: ε tr(L Lᵀ) I has every eigenvalue ≥ ε tr X ≥ ε ‖X‖₂), so a refined model given
#: back as a start is the same model
START_KEEP = 1e-10


def physical_start(
    M: np.ndarray, C: np.ndarray, K: np.ndarray, rtol: float = 1e-8
) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], dict]:
    """A start with M, K ≻ 0 and C ⪰ 0 for the refinement, and what it changed.

    Each matrix's symmetric part Q diag(d) Qᵀ gets its negative eigenvalues replaced by
    their magnitude, |d| (M and K: at least ``rtol`` of the largest; C: at least 0). Not
    the nearest matrix (:func:`~podid_rs.physical.nearest_psd` raises them to the
    floor): a direction the estimator got with the wrong sign keeps its size, where
    the nearest one puts it on the cone's edge, whose Cholesky factor has a pivot
    near 0 and a gradient near 0 that the refinement then climbs away from for
    hundreds of steps (chain m = 100, 2000 lines, ``metric="modal"`` with 8 inner
    iterations: cost 0.225 after 25 steps from |d|, 0.320 after 27 from the floor).

    M or K with every eigenvalue at least ``START_KEEP`` of its largest is kept as it
    is (a refined model given back); C with none negative likewise.

    Raises ``ValueError`` naming the matrix when M or K has no positive part to keep
    (then it is no stiffness or mass at all).
    """
    out, raised, change = [], [], []
    for X, name, tol in ((M, "M", rtol), (C, "C", 0.0), (K, "K", rtol)):
        sym = 0.5 * (X + X.T)
        d, Q = np.linalg.eigh(sym)
        if name != "C" and not np.any(d > 0):
            raise ValueError(
                f"the start model's {name} has no positive eigenvalue (largest "
                f"{d.max():.3g}): it cannot be made positive definite; identify with "
                "symmetric=True, or a lower order m"
            )
        keep = d.min() >= (START_KEEP * np.abs(d).max() if name != "C" else 0.0)
        if keep:
            Y, k = sym, 0  # positive definite to the core's floor (C: semidefinite)
        else:
            floor = tol * float(np.abs(d).max())
            Y = (Q * np.maximum(np.abs(d), floor)) @ Q.T
            Y, k = 0.5 * (Y + Y.T), int(np.sum(d < floor))
        out.append(Y)
        raised.append(k)
        change.append(float(np.linalg.norm(Y - X) / max(np.linalg.norm(X), np.finfo(float).tiny)))
    report = {"eigenvalues_raised": tuple(raised), "relative_change": tuple(change)}
    return (out[0], out[1], out[2]), report


def _column_weights(
    weights: object, data: FrequencyData, measured: np.ndarray | None = None,
) -> tuple[np.ndarray, str]:
    """Scalar weight per column (s·p,), line-major, and a label for the report.

    "relative" is 1/‖u‖ of each column of ``measured`` (the responses on the measured
    DOFs, ``(s, n, p)``) when given, else of the reduced data.
    """
    s, p = data.s, data.p
    if isinstance(weights, str):
        if weights == "uniform":
            return np.ones(s * p), "uniform"
        if weights == "relative":
            base = data.U if measured is None else measured
            norms = np.linalg.norm(base, axis=1).reshape(-1)  # (s·p,), line-major
            w = np.zeros_like(norms)
            nz = norms > 0
            w[nz] = 1.0 / norms[nz]
            return w, "relative"
        raise ValueError(f"weights must be 'relative', 'uniform' or an array, got {weights!r}")
    w = as_array(weights, "weights", real=True)
    if w.shape == (s,):
        w = np.repeat(w, p)
    elif w.shape == (s, p):
        w = w.reshape(-1)
    else:
        raise ValueError(
            f"weights must have shape (s,) = ({s},) or (s, p) = ({s}, {p}) for reduced data "
            f"(per-entry weights need basis=), got {w.shape}"
        )
    if np.any(w < 0):
        raise ValueError(f"weights must be non-negative (found {w.min():.3g})")
    if not np.any(w > 0):
        raise ValueError("weights are all zero: there is nothing to fit")
    return w, "user"


def _scalar_weights(w: np.ndarray, m: int, observed: int) -> ColumnWeights | MatrixWeights:
    """The core's weighting for a scalar weight per column: the weights themselves,
    or — with latent coordinates, whose response is not measured — the matrix w·S per
    column, S = diag(1, …, 1, 0, …, 0) selecting the ``observed`` coordinates."""
    from .. import _core

    if observed == m:
        return _core.ColumnWeights(np.ascontiguousarray(w))
    T = np.zeros((w.size, m, m))
    idx = np.arange(observed)
    T[:, idx, idx] = w[:, None]
    return _core.MatrixWeights(T.reshape(w.size, m * m))


def _log_magnitude_targets(
    weights: object, data: FrequencyData, R: np.ndarray | None, U_n: np.ndarray | None,
    measured: np.ndarray | None = None,
) -> tuple[LogMagnitudeWeights, str]:
    """The core's log-magnitude weighting: R (n, m), targets (s·p, n) and entry weights
    (s·p, n), line-major, and a label. Entries with u = 0, below LOG_DYNAMIC_RANGE
    of the largest of their line and load case, or not ``measured``, get weight 0."""
    from .. import _core

    s, m, p = data.s, data.m, data.p
    if R is None:
        R, U_n = np.eye(m), data.U
    assert U_n is not None
    n = R.shape[0]
    if isinstance(weights, str):
        if weights not in ("relative", "uniform"):
            raise ValueError(
                f"weights must be 'relative', 'uniform' or an array, got {weights!r}"
            )
        W = np.ones((s, n, p))
        label = "log-magnitude, uniform per entry"
    else:
        W = as_array(weights, "weights", real=True)
        if W.shape == (s,):
            W = np.broadcast_to(W[:, None, None], (s, n, p))
        elif W.shape == (s, p) and W.shape != (s, n):
            W = np.broadcast_to(W[:, None, :], (s, n, p))
        elif W.shape == (s, n):
            W = np.broadcast_to(W[:, :, None], (s, n, p))
        elif W.shape != (s, n, p):
            raise ValueError(
                f"weights for the log-magnitude objective must be (s,), (s, p) or per entry "
                f"(s, n) / (s, n, p) with n = {n} entries, got {W.shape}"
            )
        if np.any(W < 0):
            raise ValueError(f"weights must be non-negative (found {W.min():.3g})")
        label = "log-magnitude, user per entry"
    # entries far below the largest of their line and load case — beyond any measurement's
    # dynamic range (a far point of a long scan) — would make ln|y| meaningless: weight 0
    A = np.abs(U_n)
    W = np.where(A > LOG_DYNAMIC_RANGE * A.max(axis=1, keepdims=True), W, 0.0)
    if measured is not None:
        W = W * measured  # an entry that was not measured weighs nothing
    if not np.any(W > 0):
        raise ValueError("no weighted entry with a non-zero response: there is nothing to fit")
    line_major = lambda X: np.ascontiguousarray(X.transpose(0, 2, 1).reshape(s * p, n))  # noqa: E731
    weighting = _core.LogMagnitudeWeights(
        np.ascontiguousarray(R, dtype=np.float64),
        line_major(U_n.astype(np.complex128)),
        line_major(W.astype(np.float64)),
    )
    return weighting, label


def _entry_metric(
    W: np.ndarray, R: np.ndarray, U_n: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Per-column reduced metric for per-entry weights on the n measured DOFs.

    ‖W (R x − U)‖² = ‖T (x − y)‖² + c with TᵀT = Rᵀ W² R: returns T (s·p, m·m)
    row-major, the targets y (s, m, p) and the constant c.
    """
    s, n, p = U_n.shape
    m = R.shape[1]
    T = np.empty((s, p, m, m))
    Y = np.empty((s, m, p), dtype=np.complex128)
    const = 0.0
    for i in range(s):
        for j in range(p):
            w2 = W[i, :, j] ** 2
            Q = R.T @ (w2[:, None] * R)
            b = R.T @ (w2 * U_n[i, :, j])
            lam, V = np.linalg.eigh(Q)
            keep = lam > 1e-12 * max(lam.max(), 0.0)
            y = V[:, keep] @ ((V[:, keep].T @ b) / lam[keep])
            T[i, j] = (np.sqrt(np.clip(lam, 0.0, None))[:, None] * V.T)
            Y[i, :, j] = y
            full = float(np.sum(w2 * np.abs(U_n[i, :, j]) ** 2))
            const += full - float(np.real(np.vdot(y, Q @ y)))
    return T.reshape(s * p, m * m), Y, max(const, 0.0)


def refine(
    model: IdentificationResult | SecondOrderSystem | tuple[np.ndarray, np.ndarray, np.ndarray],
    U: np.ndarray,
    F: np.ndarray,
    omega: np.ndarray,
    *,
    weights: WeightSpec = "relative",
    basis: np.ndarray | None = None,
    max_iter: int = REFINE_MAX_ITER,
    ftol: float = REFINE_FTOL,
    log_diagonal: bool = True,
    progress: bool | Callable[[int, float], object] = False,
    threads: int | None = None,
    solver: Literal["auto", "dense", "matrix-free"] = "auto",
    objective: Literal["complex", "log-magnitude"] = "complex",
    curvature: bool = False,
    metric: Literal["auto", "diagonal", "modal"] = "auto",
    measured: np.ndarray | None = None,
    acceleration: bool = False,
) -> IdentificationResult:
    """Refine ``model`` to the least output error on the data (docs/design.md §6).

    Parameters
    ----------
    model : IdentificationResult, SecondOrderSystem or tuple (M, C, K)
        The start, e.g. ``identify(U, F, omega, symmetric=True)``. One that is not
        physical is first made so, M, K ≻ 0 and C ⪰ 0, by :func:`physical_start`
        (a :class:`StartWarning` says what it changed).
    U, F : array_like, complex, (s, m) or (s, m, p)
        Reduced responses and forces (eqs. 45–46), frequency-first — or, with
        ``basis``, ``(s, n[, p])`` on the n measured DOFs, projected here
        (``Rᵀ U``, ``Rᵀ F``).
    omega : array_like, (s,)
        Angular frequencies (rad/s), all > 0.
    weights : {"relative", "uniform"} or array_like
        ``"relative"`` (1/‖u‖ per column, default), ``"uniform"``, or an array:
        ``(s,)`` per line, ``(s, p)`` per column, or with ``basis`` per measured
        entry ``(s, n)``/``(s, n, p)``. Non-negative.
    basis : array_like, (n, k), optional
        R with orthonormal columns (the POD modes), when U, F are given on the
        measured DOFs; it may end in zero columns (an observation matrix returned by
        :func:`~podid_rs.final_fit`). A start of order m above its k orthonormal
        columns has m − k **latent coordinates**: unobserved and unforced, the model's
        responses on the measured DOFs are ``[R, 0] x``
        (:mod:`podid_rs.identification.latent`, :func:`observation_matrix`). Without
        ``basis``, reduced data of order k below the start's m mean the same with
        R = I_k.
    max_iter, ftol : int, float
        At most ``max_iter`` Levenberg–Marquardt steps; stop when ten accepted
        steps together lower the cost by less than 10·``ftol`` relative.
    log_diagonal : bool
        Diagonals of L_M, L_K as exp(θ) (M, K ≻ 0 for every iterate).
    progress : bool or callable
        ``True`` draws a progress line on stderr; a callable is called as
        ``progress(iteration, cost)``. Ctrl-C stops the refinement and propagates.
    threads : int, optional
        Worker threads (None = all cores).
    solver : {"auto", "dense", "matrix-free"}
        How each Gauss–Newton step is solved: ``"dense"`` forms and factors the
        normal matrix (fastest for small m, but (3m(m+1)/2)² doubles),
        ``"matrix-free"`` runs preconditioned CG on products line by line (memory
        O(s·m²)), ``"auto"`` (default) dense up to m = 40, matrix-free beyond
        (measured: ``benches/bench_refine.py --crossover``). Both reach the same
        model.
    objective : {"complex", "log-magnitude"}
        ``"complex"`` (default) minimises Σ‖W(x − u)‖², the complex output error;
        ``"log-magnitude"`` minimises Σ w² (ln|y| − ln|u|)² over the measured
        entries y = R x (the reduced coordinates without ``basis``) — the dB error a
        person reads off an FRF plot, every entry alike whatever its level, phase
        ignored. There ``"relative"`` and ``"uniform"`` both mean w = 1 per entry,
        an array gives w per entry ``(s, n[, p])`` (or per line/column), and
        entries with u = 0, or 240 dB below the largest of their line and load case
        (``LOG_DYNAMIC_RANGE``), are left out. Its Gauss–Newton step uses the Hermitian
        half of the normal matrix (the fast paths; the exact gradient), so it takes
        more steps.
    curvature : bool
        Add the curvature of the parametrisation X = L Lᵀ to the Gauss–Newton
        matrix (its positive part, O(m³) per step; left out right after a step that
        lowered the cost by 20 % or more). Gauss–Newton alone crawls where the
        optimum puts C on the edge of positive semidefiniteness — the usual case on
        measured data, for the damping of modes the band hardly sees: on the beam of
        ``benches/bench_measured.py`` it found models 0.82 → 0.39 dB (50–300 Hz) and
        0.94 → 0.58 dB (20–800 Hz) off the measurement. Off by default: on
        noise-free data from a start a few per cent off it can take more steps. The
        order sweep and the final fit (:mod:`podid_rs.identification.order`) turn it
        on.
    metric : {"auto", "diagonal", "modal"}
        The matrix-free step's LM damping and CG preconditioner. ``"diagonal"``:
        μ·diag(N) and the 3×3 M–C–K blocks of N. ``"modal"``: the Gauss–Newton
        matrix's blocks in the current model's undamped modes, pulled back through
        the factors (O(m³) per use), as both — and each step taken in X = L Lᵀ
        itself (Cholesky of X + δX; the step in the factors, with their curvature,
        where X + δX leaves the cone); implies ``solver="matrix-free"``. ``"auto"``
        (default): ``"modal"`` wherever the step is matrix-free (the dense step,
        m ≤ 40 with ``solver="auto"``, damps by μ·diag(N) either way). Measured
        (``benches/bench_refine.py --parts metric`` and ``--parts large``, chain
        with 0.1 % noise, whole calls; ninth session): m = 40 at 1000 lines 1.94 s
        in 33 steps (``"diagonal"`` 41.3 s and 200 steps; dense 16.9 s), m = 60 at
        1200 lines 10.2 s against 176 s, m = 100 at 2000 lines 52–54 s, converged
        in 105–110 steps to 0.22324, against the diagonal metric's 776 s and 200
        steps (the cap) to 0.23281 (seventh session). The modal step works in the
        damping modes of the start (an orthonormal basis: the same cost,
        better-placed factors).
    measured : array_like of bool, (n, p), optional
        With ``basis``: True where the response of measured DOF n in load case p was
        measured (:attr:`podid_rs.MeasuredData.measured`); the other entries weigh
        nothing — in the complex objective through one metric
        ``Rᵀ diag(measured[:, j]) R`` per load case
        (:mod:`podid_rs.identification.holes`), in the log-magnitude one and in the
        reported dB errors by an entry weight 0. Default: every entry.
    acceleration : bool
        Add the geodesic acceleration to each dense step (Transtrum & Sethna 2012):
        the second-order correction a = −(N + μ diag N)⁻¹ Jᵀ r_vv, r_vv the residual's
        second derivative along the step v by two more evaluations of the model, so
        that the step v + a/2 follows a curved valley instead of leaving it (a step
        with 2‖a‖ > 0.75‖v‖ is rejected and damped more). On the beam of
        ``benches/bench_measured.py`` (m = 35, 50–300 Hz, the final fit's complex
        pass) the cost after 300 steps fell to 0.673 instead of 0.776, a level the
        plain step reaches after about 720. No effect on a matrix-free step
        (m > 40 with ``solver="auto"``) or on the log-magnitude objective. Off by
        default; the final fit (:func:`podid_rs.identification.order.final_fit`)
        turns it on.

    Returns
    -------
    IdentificationResult
        ``method="output-error"``, ``symmetric=True``, ``iterations`` and, in
        ``info["refinement"]``: ``cost_start``, ``cost`` (the weighted output error
        Σ‖W(x − u)‖², or the log-magnitude cost, before and after), ``objective``,
        ``stop``, ``converged``, ``accepted`` steps, ``history`` [(iteration,
        cost)], the median and 95th-percentile |dB| error of the model's responses
        against ``U`` before and after (``db_before``, ``db_after``: (median,
        p95)), the weights used, how the start was made physical, and the step
        ``solver`` used with its ``solver_stats`` (CG products for the matrix-free
        step), and the ``coordinates``: observed, latent and the dimension of the
        latent coordinates' gauge (``rank`` is the number of factor parameters less
        that gauge). ``residual_norm`` is the equation error ‖Ax − y‖ (eq. 28) of the
        refined model, for comparison with the paper's estimator — NaN with latent
        coordinates, whose responses are not measured.

    Raises
    ------
    ValueError
        For malformed data, weights or options, a start that cannot be made
        physical, or a start with a pole on a measured line.

    Warns
    -----
    StartWarning
        When the start had to be made physical, or comes from a rank-deficient
        identification.
    ConvergenceWarning
        When ``max_iter`` ends the iteration with the cost still falling.
    """
    from .. import _core

    M0, C0, K0, start_note = _start_matrices(model)
    m_model = M0.shape[0]
    if basis is None and np.ndim(U) >= 2 and np.shape(U)[1] < m_model:
        # reduced data of order k < m: the first k coordinates are observed, the rest latent
        basis = np.eye(np.shape(U)[1])
    if basis is not None:
        Un, Fn = as_array(U, "U"), as_array(F, "F")
        R = as_array(basis, "basis", real=True)
        if R.ndim != 2 or Un.ndim not in (2, 3) or Un.shape[1] != R.shape[0]:
            raise ValueError(
                f"basis must be (n, m) with n = the measured DOFs of U (s, n[, p]); "
                f"got basis {R.shape} and U {Un.shape}"
            )
        # the observed columns, then a zero column per latent coordinate of the model
        R = observation_matrix(R, max(m_model, observed_count(R)))
        if Fn.shape != Un.shape:
            raise ValueError(f"F must have the shape of U {Un.shape}, got {Fn.shape}")
        U3 = Un if Un.ndim == 3 else Un[:, :, None]
        F3 = Fn if Fn.ndim == 3 else Fn[:, :, None]
        mask = check_measured(measured, U3.shape[1], U3.shape[2])
        if mask is not None:
            U3 = np.where(mask, U3, 0.0)  # what the holes hold never enters (a fresh array)
        data = check_frequency_data(
            np.einsum("nm,snp->smp", R, U3), np.einsum("nm,snp->smp", R, F3), omega
        )
    else:
        R, U3, mask = None, None, None
        data = check_frequency_data(U, F, omega)
    if measured is not None and R is None:
        raise ValueError("measured (a mask over the measured DOFs) needs basis=")
    observed = data.m if R is None else observed_count(R)
    latent = data.m - observed
    m, p = data.m, data.p
    for X, name in ((M0, "M"), (C0, "C"), (K0, "K")):
        if X.shape != (m, m):
            raise ValueError(f"the start model's {name} is {X.shape}, the data have order m = {m}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, int | np.integer) or max_iter < 1:
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}")
    ftol = float(ftol)
    if not (0.0 < ftol < 1.0):
        raise ValueError(f"ftol must lie in (0, 1), got {ftol!r}")
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(
            f"progress must be a bool or a callable(iteration, cost), got {progress!r}"
        )
    threads = _check_threads(threads)
    if solver not in ("auto", "dense", "matrix-free"):
        raise ValueError(f"solver must be 'auto', 'dense' or 'matrix-free', got {solver!r}")
    if metric not in ("auto", "diagonal", "modal"):
        raise ValueError(f"metric must be 'auto', 'diagonal' or 'modal', got {metric!r}")
    if metric == "modal":
        if solver == "dense":
            raise ValueError("metric='modal' is the matrix-free step's: give solver='auto' "
                             "or 'matrix-free'")  # fmt: skip
        solver = "matrix-free"
    if objective not in ("complex", "log-magnitude"):
        raise ValueError(f"objective must be 'complex' or 'log-magnitude', got {objective!r}")

    # weights: a scalar per column, or per-entry weights reduced to a metric per column
    const = 0.0
    targets = data
    weighting: ColumnWeights | MatrixWeights | LogMagnitudeWeights
    if objective == "log-magnitude":
        weighting, label = _log_magnitude_targets(weights, data, R, U3, mask)
    elif R is not None and not isinstance(weights, str):
        Wa = as_array(weights, "weights", real=True)
        if Wa.ndim == 2 and Wa.shape == U3.shape[:2]:
            Wa = np.repeat(Wa[:, :, None], p, axis=2)
        if Wa.shape == U3.shape:
            if mask is not None:
                Wa = Wa * mask  # an entry that was not measured weighs nothing
            if np.any(Wa < 0) or not np.any(Wa > 0):
                raise ValueError("weights must be non-negative and not all zero")
            T, Y, const = _entry_metric(Wa, R, U3.astype(np.complex128))
            targets = check_frequency_data(Y, data.F, data.omega)
            weighting = _core.MatrixWeights(np.ascontiguousarray(T))
            label = "user, per entry"
        else:
            w, label = _column_weights(Wa, data)
            weighting = _scalar_weights(w, m, observed)
    else:
        w, label = _column_weights(weights, data, U3)
        weighting = _scalar_weights(w, m, observed)
    if mask is not None and objective == "complex" and not label.endswith("per entry"):
        # a scalar weight per column over the measured entries only: one metric per load
        # case, Rᵀ diag(mask_j) R, and the targets that best reproduce the measured entries
        T, Y, const = measured_metric(w, R, U3.astype(np.complex128), mask)
        targets = check_frequency_data(Y, data.F, data.omega)
        weighting = _core.MatrixWeights(np.ascontiguousarray(T))
        label += ", measured entries"

    (M1, C1, K1), start_report = physical_start(M0, C0, K0)
    changed = any(start_report["eigenvalues_raised"]) or any(
        v > 1e-12 for v in start_report["relative_change"]
    )
    if start_note:
        warnings.warn(start_note, StartWarning, stacklevel=2)
    if changed:
        warnings.warn(
            "the start model was not physical: its negative eigenvalues replaced by their "
            f"magnitude, so that M, K are positive definite and C positive semidefinite "
            f"(eigenvalues changed in M, C, K: "
            f"{start_report['eigenvalues_raised']}; relative change "
            + ", ".join(f"{v:.2g}" for v in start_report["relative_change"])
            + ")",
            StartWarning,
            stacklevel=2,
        )

    options = _core.RefineOptions(
        max_iter=int(max_iter),
        ftol=ftol,
        log_diagonal=bool(log_diagonal),
        solver=solver,
        curvature=bool(curvature),
        modal_metric=metric != "diagonal",  # used only by a matrix-free step
        acceleration=bool(acceleration),
    )
    Uc, Fc, _ = targets.columns()
    bar = _RefineBar(int(max_iter)) if progress is True else None
    callback = bar if bar is not None else (progress if callable(progress) else None)
    try:
        out = _core.refine_output_error(
            Uc, Fc, targets.omega, p, (M1, C1, K1), weighting, options,
            progress=callback, threads=threads,
        )
    finally:
        if bar is not None:
            bar.close()
    M, C, K = (np.asarray(X, dtype=np.float64) for X in (out.M, out.C, out.K))
    M, C, K = (0.5 * (X + X.T) for X in (M, C, K))

    def responses(Mx: np.ndarray, Cx: np.ndarray, Kx: np.ndarray) -> np.ndarray:
        X = SecondOrderSystem(Mx, Cx, Kx).response(data.omega, data.F)
        return X if R is None else np.einsum("nm,smp->snp", R, X)

    def returned(rows: np.ndarray) -> np.ndarray:  # the core's (s·p, m) responses, as (s, m, p)
        X = rows.reshape(data.s, p, m).transpose(0, 2, 1)
        return X if R is None else np.einsum("nm,smp->snp", R, X)

    measured = data.U if R is None else U3
    start_rows = out.responses_start
    X0 = returned(start_rows) if start_rows is not None else responses(M1, C1, K1)
    before = db_errors(X0, measured, mask)
    after = db_errors(returned(out.responses), measured, mask)
    summary = lambda e: (float(np.median(e)), float(np.percentile(e, 95)))  # noqa: E731
    report = {
        "cost_start": float(out.cost_start) + const,
        "cost": float(out.cost) + const,
        "stop": str(out.stop),
        "converged": bool(out.converged),
        "accepted": int(out.accepted),
        "history": [(int(i), float(c) + const) for i, c in out.history],
        "db_before": summary(before),
        "db_after": summary(after),
        "weights": label,
        "objective": objective,
        "coordinates": {"observed": observed, "latent": latent,
                        "gauge": gauge_dimension(m, observed)},
        "start": start_report,
        "timings": dict(out.timings),
        "scaling": tuple(out.scaling),
        "solver": str(out.solver),
        "metric": ("diagonal" if metric == "diagonal" else "modal")
        if str(out.solver) == "matrix-free"
        else "dense",
        "solver_stats": dict(out.solver_stats),
    }
    if out.stop == "max_iter reached":
        warnings.warn(
            f"the output-error refinement stopped at max_iter = {max_iter} with the cost still "
            f"falling ({report['cost_start']:.4g} → {report['cost']:.4g}); raise max_iter",
            ConvergenceWarning,
            stacklevel=2,
        )
    ref_norm = float(np.sqrt(report["cost_start"]))
    base = model if isinstance(model, IdentificationResult) else None
    n_unk = 3 * m * (m + 1) // 2
    result = IdentificationResult(
        M=M,
        C=C,
        K=K,
        lam=(math.inf, math.inf, math.inf),
        symmetric=True,
        # the equation error needs every coordinate's response: latent ones have none
        residual_norm=residual_norm(M, C, K, data) if latent == 0 else math.nan,
        penalty_norms=(0.0, 0.0, 0.0),
        method="output-error",
        rank=n_unk - gauge_dimension(m, observed),
        n_unknowns=n_unk,
        min_pivot_ratio=math.nan,
        backend="rust",
        info={
            **({} if base is None else {"start_method": base.method}),
            "refinement": report,
            "timings": dict(out.timings),
        },
        iterations=int(out.iterations),
        relative_residual=float(np.sqrt(report["cost"])) / ref_norm if ref_norm > 0 else 0.0,
    )
    return replace(result)
