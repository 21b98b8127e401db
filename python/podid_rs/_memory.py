"""Refuse work that would not fit in memory, before anything is allocated.

Large systems (10⁵ DOFs) and large measurements (10⁴ points) make it easy to ask
for an array of hundreds of GB by accident — ``frf(omega)`` of a big model, a
correlation matrix of a big scan. Each place that allocates in proportion to a
user's sizes calls :func:`require_memory` first, so the user gets a
``MemoryError`` stating what is needed, not a swap storm or an OOM kill.
"""

from __future__ import annotations

from .identification import available_memory_bytes

#: Fraction of the available memory a single request may take.
FRACTION = 0.9
COMPLEX_BYTES = 16
FLOAT_BYTES = 8


def require_memory(nbytes: float, what: str, hint: str = "") -> None:
    """Raise ``MemoryError`` when ``nbytes`` exceed 90 % of the available memory.

    ``what`` names the request ("frf of 401 lines × 100000 × 100000 DOFs");
    ``hint`` says how to ask for less. Does nothing where the available memory
    cannot be read.
    """
    avail = available_memory_bytes()
    if avail is not None and nbytes > FRACTION * avail:
        raise MemoryError(
            f"{what} needs {nbytes / 1e9:.3g} GB but only {avail / 1e9:.3g} GB of memory is "
            "available" + (f"; {hint}" if hint else "")
        )
