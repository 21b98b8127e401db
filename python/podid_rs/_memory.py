"""The one memory check: refuse work that would not fit in memory, before anything is allocated.

Large systems (10⁵ DOFs) and large measurements (10⁴ points) make it easy to ask
for an array of hundreds of GB by accident — ``frf(omega)`` of a big model, a
correlation matrix of a big scan, the normal matrix of a high order. Each place
that allocates in proportion to a user's sizes calls :func:`require_memory` first,
so the user gets a ``MemoryError`` stating what is needed, not a swap storm or an
OOM kill; a place that can take another path instead asks :func:`fits_in_memory`.
Both read the available memory through :func:`available_memory_bytes`, the one
place to fake it in a test.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

#: Fraction of the available memory a single request may take.
FRACTION = 0.9
COMPLEX_BYTES = 16
FLOAT_BYTES = 8


def available_memory_bytes() -> int | None:
    """MemAvailable from /proc/meminfo (Linux), or None where it cannot be read."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def _fits(nbytes: float, available: int | None, fraction: float) -> bool:
    return available is None or nbytes <= fraction * available


def fits_in_memory(nbytes: float, fraction: float = FRACTION) -> bool:
    """True when ``nbytes`` take at most ``fraction`` of the available memory.

    Also True where the available memory cannot be read.
    """
    return _fits(nbytes, available_memory_bytes(), fraction)


def require_memory(nbytes: float, what: str, hint: str = "") -> None:
    """Raise ``MemoryError`` when ``nbytes`` exceed 90 % of the available memory.

    ``what`` names the request ("frf of 401 lines × 100000 × 100000 DOFs");
    ``hint`` says how to ask for less. Does nothing where the available memory
    cannot be read.
    """
    avail = available_memory_bytes()
    if not _fits(nbytes, avail, FRACTION):
        raise MemoryError(
            f"{what} needs {nbytes / 1e9:.3g} GB but only {avail / 1e9:.3g} GB of memory is "
            "available" + (f"; {hint}" if hint else "")
        )


@functools.lru_cache(maxsize=1)
def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another C library, or none found)."""
    try:
        name = ctypes.util.find_library("c")
        trim = ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None
    if trim is not None:
        trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def release_free_memory() -> None:
    """Give the C heap's free pages back to the operating system (glibc's
    ``malloc_trim(0)``; nothing elsewhere).

    glibc keeps what earlier work freed resident: once an array above its mmap threshold
    has been freed it raises the threshold (up to 32 MiB), so that arrays up to that size
    come from the heap, where freed pages stay resident until trimmed. Long computations
    after a large one (the matrix-free intervals after a refinement) call this before
    they start and between their phases, so that their own peak is what they hold.
    """
    trim = _malloc_trim()
    if trim is not None:
        trim(0)
