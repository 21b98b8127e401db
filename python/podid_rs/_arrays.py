"""Input checks shared by the modules: arrays, frequencies, counts, bases, DOF labels.

Each helper returns a fresh array, so callers can never modify what the user
passed, and raises ``ValueError`` naming the argument when the input is unusable.
"""

from __future__ import annotations

import numpy as np


def as_array(x: object, name: str, *, real: bool = False) -> np.ndarray:
    """Fresh float64 (complex128 for complex input) copy of ``x``, checked finite.

    With ``real=True`` complex input is refused.
    """
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} could not be read as a numeric array: {exc}") from None
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name} must be a numeric array, got dtype {a.dtype}")
    if np.iscomplexobj(a):
        if real:
            raise ValueError(f"{name} must be real, got complex dtype {a.dtype}")
        a = np.array(a, dtype=np.complex128, copy=True)
    else:
        a = np.array(a, dtype=np.float64, copy=True)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values (NaN or inf)")
    return a


def as_omega(omega: object) -> np.ndarray:
    """Angular frequencies in rad/s: a fresh 1-D float64 array, non-empty, all > 0."""
    w = as_array(omega, "omega", real=True)
    if w.ndim != 1 or w.size == 0:
        raise ValueError(f"omega must be a non-empty 1-D array (rad/s), got shape {w.shape}")
    if np.any(w <= 0):
        i = int(np.argmax(w <= 0))
        raise ValueError(f"omega must be strictly positive (rad/s); omega[{i}] = {float(w[i])!r}")
    return w


def as_scalar(x: object, name: str, *, allow_zero: bool = False) -> float:
    """A finite real scalar, strictly positive (or non-negative with ``allow_zero``)."""
    a = as_array(x, name, real=True)
    if a.ndim != 0 or a < 0 or (a == 0 and not allow_zero):
        kind = "a non-negative" if allow_zero else "a positive"
        raise ValueError(f"{name} must be {kind} number, got {x!r}")
    return float(a)


def as_count(x: object, name: str, lo: int, hi: int | None = None) -> int:
    """An integer in ``[lo, hi]`` (``hi=None``: no upper bound); bools are refused."""
    if isinstance(x, bool) or not isinstance(x, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {x!r}")
    if x < lo or (hi is not None and x > hi):
        bounds = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
        raise ValueError(f"{name} must be {bounds}, got {x}")
    return int(x)


def as_basis(basis: object, m: int) -> np.ndarray:
    """A real ``(n, m)`` basis R mapping an order-m model to n DOFs; None → I_m."""
    if basis is None:
        return np.eye(m)
    R = as_array(basis, "basis", real=True)
    if R.ndim != 2 or R.shape[1] != m or R.shape[0] == 0:
        raise ValueError(
            f"basis must have shape (n, m) with m = {m} (the model's order), got {R.shape}"
        )
    return R


def as_dof_labels(dofs: object, n: int) -> np.ndarray:
    """(n, 2) int64 (node, direction) labels; ``None`` gives (k, 1), k = 1…n."""
    if dofs is None:
        return np.stack([np.arange(1, n + 1), np.ones(n, dtype=np.int64)], axis=1)
    d = as_array(dofs, "dofs", real=True)
    if d.shape != (n, 2):
        raise ValueError(f"dofs must have shape (n, 2) = ({n}, 2) (node, direction), got {d.shape}")
    if np.any(d != np.round(d)) or np.any(np.abs(d) > 2**53):
        raise ValueError("dofs must hold integer (node, direction) labels")
    labels = d.astype(np.int64)
    if len({tuple(r) for r in labels.tolist()}) != n:
        raise ValueError("dofs must not repeat a (node, direction) label")
    return labels


def as_array_nocopy(x: object, name: str) -> np.ndarray:
    """``x`` as float64 or complex128, checked numeric and finite, copied only if its
    dtype must change — for large read-only inputs (spectra of 10⁵ DOFs), where a
    defensive copy would double the memory. Callers must not write to the result.
    """
    try:
        a = np.asarray(x)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} could not be read as a numeric array: {exc}") from None
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"{name} must be a numeric array, got dtype {a.dtype}")
    a = a.astype(np.complex128 if np.iscomplexobj(a) else np.float64, copy=False)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values (NaN or inf)")
    return a
