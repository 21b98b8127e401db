"""The frequency lines that carry a measurement's information, for the order sweep.

A test at fine line spacing — 0.02 Hz over a kilohertz, tens of thousands of lines —
puts most of its lines where the response changes slowly: between the resonances and
anti-resonances, a smooth curve that a few lines pin down as well as thousands. The
order sweep (:mod:`.order`) fits dozens of models; each of its Levenberg–Marquardt
steps costs in proportion to the lines. :func:`informative_lines` keeps every line
where the response changes quickly and thins the rest, so the sweep fits a few
thousand lines that hold what the data say, and the final fit
(:func:`.order.final_fit`) refits the chosen order on them, judged on every line.

How a line earns its place: the band is cut into blocks of equal length; a block's
*activity* is the range of ln|U| plus the range of the unwrapped phase over its lines,
averaged over the measured entries — a resonance or anti-resonance inside the block
moves both by the order of ln(1/ζ) and π, a smooth stretch barely moves them, and
noise adds the same small amount to every block. Every block keeps at least one line
(the band stays covered); the remaining budget goes to the blocks in proportion to
their activity above the typical (median) block's, a block keeping at most all its
lines. Inside a block the kept lines are evenly spaced and include the lines where
Σ|U| is largest and smallest (the peak and the dip). The selection depends on the
data only, never on a model.
"""

from __future__ import annotations

import numpy as np

#: the order sweep (and the final fit) fit about this many lines of a longer test. Median
#: error over every line with 1000 / 2000 / 4000 lines: 0.0669 / 0.0668 / 0.0668 dB on a
#: 46 750-line, 4-mode test (sweep 3.8 / 10.8 / 18.1 s); 0.0416 / 0.0414 / 0.0414 dB on a
#: 22 000-line, 12-mode lattice test, every mode found each time (sweep 11.9 / 21.3 / 40.8 s)
SWEEP_LINES = 1000
#: blocks per kept line of the budget: a quarter of the budget covers the band evenly
BLOCKS_PER_LINE = 0.25


def informative_lines(U: np.ndarray, target: int = SWEEP_LINES) -> np.ndarray:
    """A mask of at most about ``target`` lines that keeps the data's information.

    Parameters
    ----------
    U : numpy.ndarray, complex, (s, n, p)
        The measured responses (FRFs), frequency-first.
    target : int
        The number of lines to keep; with ``s <= target`` every line is kept.

    Returns
    -------
    numpy.ndarray of bool, (s,)
        True for a kept line; the first and last lines are always kept.

    Raises
    ------
    ValueError
        If ``U`` is not 3-D or not finite, or ``target`` is below 16.
    """
    if U.ndim != 3:
        raise ValueError(f"U must be (s, n, p), got shape {U.shape}")
    if not np.all(np.isfinite(U)):  # a NaN line would leave every block one line
        raise ValueError("U must be finite (no NaN or inf)")
    if isinstance(target, bool) or not isinstance(target, int | np.integer) or target < 16:
        raise ValueError(f"target must be an integer of at least 16, got {target!r}")
    s = U.shape[0]
    keep = np.zeros(s, dtype=bool)
    if s <= target:
        keep[:] = True
        return keep
    flat = U.reshape(s, -1)
    flat = flat[:, np.any(flat != 0, axis=0)]  # entries that were measured
    tiny = np.finfo(float).tiny
    logmag = np.log(np.maximum(np.abs(flat), tiny))
    phase = np.unwrap(np.angle(flat), axis=0)
    level = np.abs(flat).sum(axis=1)

    n_blocks = max(int(target * BLOCKS_PER_LINE), 1)
    edges = np.linspace(0, s, n_blocks + 1).round().astype(int)
    starts, stops = edges[:-1], edges[1:]
    activity = np.empty(n_blocks)
    for j, (a, b) in enumerate(zip(starts, stops, strict=True)):
        activity[j] = np.mean(np.ptp(logmag[a:b], axis=0) + np.ptp(phase[a:b], axis=0))
    excess = np.maximum(activity - np.median(activity), 0.0)
    sizes = stops - starts
    count = np.ones(n_blocks, dtype=np.int64)
    budget = target - n_blocks
    # water-filling: share the budget by excess activity, no block above its size; each pass
    # hands out at least one line, so the budget bounds the passes
    free = count < sizes
    for _ in range(budget):
        if budget <= 0 or not np.any(free & (excess > 0)):
            break
        share = np.where(free, excess, 0.0)
        extra = np.floor(budget * share / share.sum()).astype(np.int64)
        if not extra.any():
            extra[np.argmax(share)] = 1
        new = np.minimum(count + extra, sizes)
        budget -= int((new - count).sum())
        count = new
        free = count < sizes
    for a, b, c in zip(starts, stops, count, strict=True):
        if c >= b - a:
            keep[a:b] = True
            continue
        idx = np.linspace(a, b - 1, c).round().astype(int)
        keep[idx] = True
        if c >= 3:  # the block's peak and dip are worth two of its evenly spaced lines
            keep[a + int(np.argmax(level[a:b]))] = True
            keep[a + int(np.argmin(level[a:b]))] = True
    keep[0] = keep[-1] = True
    return keep
