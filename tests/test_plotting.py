"""The lines an FRF figure draws: fewer, and the same picture."""

from __future__ import annotations

import numpy as np

from podid_rs.plotting import display_lines


def _bins(freq: np.ndarray, bins: int) -> np.ndarray:
    return np.minimum(((freq - freq[0]) / (freq[-1] - freq[0]) * bins).astype(int), bins - 1)


def test_a_short_test_keeps_every_line():
    freq = np.linspace(10.0, 100.0, 400)
    np.testing.assert_array_equal(display_lines(freq, [np.ones(400)], bins=100), np.arange(400))


def test_each_bin_keeps_its_ends_and_every_curve_s_extremes():
    """Per bin, the kept lines span what every line spans, for each curve: the
    rendered polyline covers the same pixels. A peak one line wide keeps its height."""
    rng = np.random.default_rng(3)
    s, bins = 46_751, 512
    freq = np.linspace(65.0, 1000.0, s)
    a = np.abs(rng.standard_normal(s)) + 1.0
    a[12_345] = 1e4  # a resonance one line wide
    b = np.exp(rng.standard_normal((s, 2)))
    b[:100, 1] = np.nan  # an entry not measured there
    b[50, 1] = np.nan
    keep = display_lines(freq, [a, b], bins=bins)
    assert keep.size < s / 4
    assert np.all(np.diff(keep) > 0) and keep[0] == 0 and keep[-1] == s - 1
    assert 12_345 in keep
    ids, kept_ids = _bins(freq, bins), _bins(freq[keep], bins)
    for v in (a, b[:, 0], b[:, 1]):
        for k in range(bins):
            full, shown = v[ids == k], v[keep][kept_ids == k]
            if np.isnan(full).all():  # nothing to draw in this bin
                assert np.isnan(shown).all()
                continue
            assert np.nanmax(full) == np.nanmax(shown) and np.nanmin(full) == np.nanmin(shown)
            assert (np.flatnonzero(ids == k)[[0, -1]] == keep[kept_ids == k][[0, -1]]).all()
