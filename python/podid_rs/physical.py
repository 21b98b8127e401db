"""Physical structure of an identified model: definiteness, modal parameters, stability.

A passive structure has M and K symmetric positive definite and C symmetric
positive semidefinite; then every eigenvalue of the quadratic pencil
``(λ² M + λ C + K) φ = 0`` (paper eq. 1, free vibration) has ``Re λ ≤ 0``.
Least squares on noisy or truncated data (eq. 49) guarantees none of this.

* :func:`make_physical` replaces M, C, K by the nearest matrices with that
  structure in the Frobenius norm (Higham 1988: the symmetric part with its
  negative eigenvalues raised to a floor) and reports what it costs in the data
  residual ‖Ax − y‖ (eq. 28). Start from ``identify(..., symmetric=True)``: the
  correction then only touches definiteness.
* :func:`modal_parameters` solves the pencil through the first-order companion
  form ``[[0, I], [−K, −C]] z = λ [[I, 0], [0, M]] z`` and returns natural
  frequencies ``|λ| / 2π``, damping ratios ``−Re λ / |λ|`` and stability.
* :func:`compare_modes` pairs identified modes with those of a known system.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg

from ._arrays import as_array, as_scalar
from ._validation import check_frequency_data
from .identification.result import IdentificationResult, residual_norm
from .systems import SecondOrderSystem


def _square_matrix(A: object, name: str) -> np.ndarray:
    """``A`` as a real, finite, non-empty square float64 array, refused under ``name``."""
    a = as_array(A, name, real=True)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise ValueError(f"{name} must be a non-empty square matrix, got shape {a.shape}")
    return a


def nearest_psd(A: object, floor: float = 0.0, name: str = "A") -> np.ndarray:
    """Nearest symmetric matrix to ``A`` whose eigenvalues are all ``>= floor`` (Frobenius).

    Higham (1988): take the symmetric part ``(A + Aᵀ)/2 = Q diag(d) Qᵀ`` and raise
    ``d`` to ``max(d, floor)``. The result is exactly symmetric.
    """
    a = _square_matrix(A, name)
    floor = as_scalar(floor, "floor", allow_zero=True)
    d, Q = np.linalg.eigh(0.5 * (a + a.T))
    B = (Q * np.maximum(d, floor)) @ Q.T
    return 0.5 * (B + B.T)


def _raise_eigenvalues(X: np.ndarray, rtol: float, name: str) -> tuple[np.ndarray, int]:
    """Nearest symmetric matrix with eigenvalues >= rtol·‖X‖₂, and how many were raised.

    ``rtol > 0`` asks for a positive definite answer, which a zero X cannot give. A NaN
    or complex entry (a result built by hand) is refused under ``name`` before the
    eigenvalues, which LAPACK may fail to converge on, and so is a matrix that is not
    square (a column would broadcast against its transpose into a square one).
    """
    X = _square_matrix(X, name)
    d = np.linalg.eigvalsh(0.5 * (X + X.T))
    floor = rtol * float(np.max(np.abs(d)))
    if rtol > 0 and floor == 0.0:
        raise ValueError(f"{name} is zero: there is no positive definite matrix near it")
    return nearest_psd(X, floor, name), int(np.sum(d < floor))


def make_physical(
    result: IdentificationResult,
    U: object,
    F: object,
    omega: object,
    *,
    rtol: float = 1e-8,
) -> IdentificationResult:
    """The nearest model with M, K symmetric positive definite and C symmetric PSD.

    M and K get eigenvalues at least ``rtol`` times their largest, C at least 0
    (:func:`nearest_psd`, Higham 1988), and the cost is measured in the data residual.

    Parameters
    ----------
    result : IdentificationResult
        The model, e.g. of ``identify(..., symmetric=True)`` (then the correction only
        touches definiteness).
    U, F, omega : array_like
        The reduced data it was identified from (as for :func:`podid_rs.identify`).
    rtol : float
        The floor of M's and K's eigenvalues, relative to their largest, > 0.

    Returns
    -------
    IdentificationResult
        The corrected model, with the residual ‖Ax − y‖ (eq. 28) of the corrected
        matrices; ``info["physical"]`` records the residual before and after, the
        relative change of each matrix and the number of eigenvalues raised.

    Raises
    ------
    ValueError
        For a result that is not an :class:`IdentificationResult`, malformed data or
        data of another order, a non-positive ``rtol``, a matrix that is not square
        (a result built by hand), or a zero M or K.
    """
    if not isinstance(result, IdentificationResult):
        raise ValueError(f"result must be an IdentificationResult, got {type(result).__name__}")
    data = check_frequency_data(U, F, omega)
    if data.m != result.m:
        raise ValueError(f"the data have order m = {data.m} but the model has m = {result.m}")
    rtol = as_scalar(rtol, "rtol")
    M, moved_M = _raise_eigenvalues(result.M, rtol, "M")
    C, moved_C = _raise_eigenvalues(result.C, 0.0, "C")
    K, moved_K = _raise_eigenvalues(result.K, rtol, "K")
    before = residual_norm(result.M, result.C, result.K, data)
    after = residual_norm(M, C, K, data)
    change = [
        float(np.linalg.norm(new - old) / max(np.linalg.norm(old), np.finfo(float).tiny))
        for new, old in ((M, result.M), (C, result.C), (K, result.K))
    ]
    report = {
        "residual_before": before,
        "residual_after": after,
        "relative_change": tuple(change),
        "eigenvalues_raised": (moved_M, moved_C, moved_K),
        "rtol": rtol,
    }
    return replace(
        result,
        M=M,
        C=C,
        K=K,
        residual_norm=after,
        penalty_norms=(0.0, 0.0, 0.0),
        info={**result.info, "physical": report},
    )


@dataclass(frozen=True)
class ModalParameters:
    """Modes of ``(λ² M + λ C + K) φ = 0`` from the companion form.

    Attributes
    ----------
    eigenvalues : numpy.ndarray, complex, (k,)
        One per mode, sorted by ``|λ|`` — the one with ``Im λ > 0`` of each complex
        pair, and every real (overdamped) eigenvalue.
    frequencies_hz : numpy.ndarray, (k,)
        ``|λ| / 2π`` (undamped natural frequency).
    damping_ratios : numpy.ndarray, (k,)
        ``−Re λ / |λ|`` (1 for a stable real root, < 0 unstable).
    n_infinite : int
        The number of infinite eigenvalues (of a singular M).
    max_real_part : float
        Largest ``Re λ`` (−inf without finite eigenvalues).
    stable : bool
        Asymptotically stable: every finite eigenvalue has ``Re λ < 0``, none infinite.
    """

    eigenvalues: np.ndarray
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    n_infinite: int

    @property
    def max_real_part(self) -> float:
        """Largest ``Re λ`` (−inf without finite eigenvalues)."""
        return float(np.max(self.eigenvalues.real)) if self.eigenvalues.size else -np.inf

    @property
    def stable(self) -> bool:
        """Asymptotically stable: every finite eigenvalue has ``Re λ < 0``, none infinite."""
        return self.n_infinite == 0 and self.max_real_part < 0.0


def _matrices(model: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if isinstance(model, IdentificationResult | SecondOrderSystem):
        return model.M, model.C, model.K
    raise ValueError(
        f"model must be an IdentificationResult or a SecondOrderSystem, got {type(model).__name__}"
    )


def companion_modes(
    model: IdentificationResult | SecondOrderSystem, vectors: bool = False
) -> tuple[np.ndarray, np.ndarray | None, int]:
    """One eigenvalue per mode of the pencil, sorted by ``|λ|``, and its vector φ.

    Poles of exactly equal ``|λ|`` keep the eigensolver's order (a stable sort).

    Generalised eigenvalues of ``A z = λ B z``, ``A = [[0, I], [−K, −C]]``,
    ``B = [[I, 0], [0, M]]`` (``scipy.linalg.eig``), z = [φ; λφ]: the one with
    ``Im λ > 0`` of each complex pair and every real one. Returns the eigenvalues
    ``(k,)``, the vectors φ ``(m, k)`` (None unless ``vectors``) and the number of
    infinite eigenvalues. A model whose M, C and K are not square matrices of one
    shape (a result built by hand) is refused with their shapes: ``A`` and ``B``
    could otherwise be formed from a non-square C and K whose widths add up to 2m.
    """
    M, C, K = (np.asarray(X, dtype=np.float64) for X in _matrices(model))
    n = M.shape[0] if M.ndim == 2 else -1  # (-1, -1): no array's shape
    if any(X.shape != (n, n) for X in (M, C, K)):
        raise ValueError(
            "the model's M, C and K must be square matrices of one shape, got "
            f"{M.shape}, {C.shape} and {K.shape}"
        )
    eye, zero = np.eye(n), np.zeros((n, n))
    A = np.block([[zero, eye], [-K, -C]])
    B = np.block([[eye, zero], [zero, M]])
    if vectors:
        lam, Z = scipy.linalg.eig(A, B)
    else:
        lam, Z = scipy.linalg.eig(A, B, right=False), None
    finite = np.isfinite(lam)
    pick = np.flatnonzero(finite & (lam.imag >= 0))
    pick = pick[np.argsort(np.abs(lam[pick]), kind="stable")]
    return lam[pick], None if Z is None else Z[:n, pick], int(np.sum(~finite))


def modal_parameters(model: IdentificationResult | SecondOrderSystem) -> ModalParameters:
    """Natural frequencies, damping ratios and stability of ``M ü + C u̇ + K u = 0`` (eq. 1).

    The modes of :func:`companion_modes`: the generalised eigenvalues of the
    first-order companion form ``[[0, I], [−K, −C]] z = λ [[I, 0], [0, M]] z``.

    Parameters
    ----------
    model : IdentificationResult or SecondOrderSystem
        The model (dense M, C, K).

    Returns
    -------
    ModalParameters
        Eigenvalues, frequencies, damping ratios, stability.

    Raises
    ------
    ValueError
        For a model of another type, or whose M, C and K are not square matrices of
        one shape.
    """
    keep, _, n_infinite = companion_modes(model)
    mag = np.abs(keep)
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(mag > 0, -keep.real / mag, 0.0)
    return ModalParameters(
        eigenvalues=keep,
        frequencies_hz=mag / (2 * np.pi),
        damping_ratios=zeta,
        n_infinite=n_infinite,
    )


def compare_modes(identified: ModalParameters, truth: ModalParameters) -> list[dict[str, float]]:
    """Pair each identified mode with the true mode nearest in log-frequency.

    One row per identified mode: its frequency and damping ratio, the paired true
    ones and the relative frequency error.
    """
    if not isinstance(identified, ModalParameters) or not isinstance(truth, ModalParameters):
        raise ValueError("compare_modes takes two ModalParameters")
    f_true = truth.frequencies_hz
    if f_true.size == 0 or np.any(f_true <= 0):
        raise ValueError("the true system has no mode with a positive frequency to compare with")
    rows = []
    for f, z in zip(identified.frequencies_hz, identified.damping_ratios, strict=True):
        j = int(np.argmin(np.abs(np.log(f_true) - np.log(f)))) if f > 0 else 0
        rows.append(
            {
                "f_hz": float(f),
                "zeta": float(z),
                "f_true_hz": float(f_true[j]),
                "zeta_true": float(truth.damping_ratios[j]),
                "f_rel_error": float((f - f_true[j]) / f_true[j]),
            }
        )
    return rows


def modal_table(
    model: IdentificationResult | SecondOrderSystem,
    truth: SecondOrderSystem | None = None,
    kinds: np.ndarray | None = None,
) -> list[dict[str, float | int | str]]:
    """Rows of the modal report: mode, f (Hz), ζ, Re λ, stability; the kind of each
    pole if given (:func:`podid_rs.modes.mode_kinds`); truth columns if given."""
    modes = modal_parameters(model)
    pairs = compare_modes(modes, modal_parameters(truth)) if truth is not None else None
    if kinds is not None and len(kinds) != modes.eigenvalues.size:
        raise ValueError(f"kinds has {len(kinds)} entries for {modes.eigenvalues.size} modes")
    rows: list[dict[str, float | int | str]] = []
    for k, lam in enumerate(modes.eigenvalues):
        row: dict[str, float | int | str] = {
            "mode": k + 1,
            "f_hz": float(modes.frequencies_hz[k]),
            "zeta": float(modes.damping_ratios[k]),
            "re_lambda": float(lam.real),
            "stable": "yes" if lam.real < 0 else "no",
        }
        if kinds is not None:
            row["kind"] = str(kinds[k])
        if pairs is not None:
            p = pairs[k]
            row.update(
                f_true_hz=p["f_true_hz"], zeta_true=p["zeta_true"], f_rel_error=p["f_rel_error"]
            )
        rows.append(row)
    return rows


def table_csv(rows: list[dict[str, float | int | str]]) -> str:
    """The rows of :func:`modal_table` as CSV text (full precision)."""
    out = io.StringIO()
    if rows:
        w = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return out.getvalue()


def table_markdown(rows: list[dict[str, float | int | str]]) -> str:
    """The rows of :func:`modal_table` as a Markdown table (4 significant digits)."""
    if not rows:
        return "(no modes)\n"
    keys = list(rows[0])
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)  # noqa: E731
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines) + "\n"
