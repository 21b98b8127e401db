"""Shared fixtures: the real beam measurement in tests/data (see its README for provenance)."""

from __future__ import annotations

from pathlib import Path

import pytest

BEAM_UFF = Path(__file__).parent / "data" / "ufsc_beam" / "beam_roving_hammer.uff"


@pytest.fixture(scope="session")
def beam():
    """The roving-hammer beam (30 points, force at point 3 by reciprocity), all lines."""
    import podid_rs as pr

    return pr.read_uff(BEAM_UFF)
