"""The memory guards of POD and simulation: what each request is said to need, exactly.

Every place that allocates in proportion to the user's sizes asks
``podid_rs._memory.require_memory`` first, and the ``MemoryError`` states the bytes
it needs. Those counts are the guard: an undercount lets an impossible request
through to the allocator, an overcount refuses work that fits. Here the available
memory is faked to one byte, so each request is refused by its own guard, and its
message is compared with the count written out by hand (3 significant digits).
"""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

import podid_rs._memory as memory
from podid_rs import mass_spring_chain, simulate_white_noise
from podid_rs.pod import correlation_from_frf, pod, pod_from_frf, pod_from_spectra

FLOAT, COMPLEX = 8, 16


def refusal(what: str, nbytes: float, hint: str = "") -> str:
    """The exact MemoryError message for ``nbytes`` against 1 byte available."""
    text = f"{what} needs {nbytes / 1e9:.3g} GB but only 1e-09 GB of memory is available"
    return "^" + re.escape(text + (f"; {hint}" if hint else "")) + "$"


@pytest.fixture
def one_byte(monkeypatch):
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1)


def test_gram_matrix_of_the_snapshots(one_byte):
    k, n = 30, 500  # 30 snapshots of 500 DOFs: the Gram side
    with pytest.raises(MemoryError, match=refusal(
        f"the {k} × {k} Gram matrix of the POD snapshots", 3 * FLOAT * k**2,
        "use fewer snapshots (lines, load cases) or method='correlation'",
    )):
        pod(np.ones((k, n)), method="snapshots")


def test_correlation_matrix(one_byte):
    n = 700
    with pytest.raises(MemoryError, match=refusal(
        f"the {n} × {n} correlation matrix and its eigenvectors", 3 * FLOAT * n**2,
        "use method='snapshots' (POD from the snapshots' Gram matrix)",
    )):
        pod(np.ones((3, n)), method="correlation")
    # from an FRF the matrix is n × n in the responses, whatever the inputs (3 here)
    with pytest.raises(MemoryError, match=refusal(
        f"the {n} × {n} correlation matrix and its eigenvectors", 3 * FLOAT * n**2,
        "use method='snapshots' (POD from the snapshots' Gram matrix)",
    )):
        correlation_from_frf(np.ones((2, n, 3), dtype=complex), [1.0, 2.0])
    # and from spectra on the correlation side: asked before the (smaller) stacked
    # snapshots are formed
    with pytest.raises(MemoryError, match=refusal(
        f"the {n} × {n} correlation matrix and its eigenvectors", 3 * FLOAT * n**2,
        "use method='snapshots' (POD from the snapshots' Gram matrix)",
    )):
        pod_from_spectra(np.ones((2, n, 3), dtype=complex), 100, method="correlation")


def test_stacked_real_snapshots_of_spectra(one_byte):
    s, n, p = 7, 50, 3
    X = np.ones((s, n, p), dtype=complex)
    what = f"the POD snapshots of {s} × {p} × {n} values"
    with pytest.raises(MemoryError, match=refusal(what, 2 * 2 * FLOAT * s * n * p)):
        pod_from_spectra(X, 100, method="snapshots")
    with pytest.raises(MemoryError, match=refusal(what, 2 * 2 * FLOAT * s * n * p)):
        pod_from_frf(X, np.arange(1.0, s + 1), method="snapshots")


def test_snapshot_modes_are_counted_when_formed(monkeypatch):
    rng = np.random.default_rng(0)
    P = pod(rng.standard_normal((6, 400)), method="snapshots")
    P.basis(2)  # forms two modes while memory is plentiful
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1)
    np.testing.assert_array_equal(P.basis(1), P.basis(2)[:, :1])  # formed already: no request
    with pytest.raises(MemoryError, match=refusal("5 POD modes of 400 DOFs", FLOAT * 400 * 5)):
        P.basis(5)


@pytest.mark.parametrize("histories", [True, False])
def test_simulation(monkeypatch, histories):
    n, dt, duration, band = 6, 1 / 256, 4.0, (5.0, 60.0)
    chain = mass_spring_chain(n)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1)
    r = round(duration / dt)
    f = np.fft.rfftfreq(r, dt)
    s = int(np.sum((f >= band[0]) & (f <= band[1])))
    spectra_bytes = 3 * COMPLEX * s * n
    if histories:
        nbytes = spectra_bytes + 2 * FLOAT * r * n + COMPLEX * (r // 2 + 1) * n
        what = f"simulating {n} DOFs over {s} lines with {r}-sample histories"
        hint = "pass histories=False to keep only the in-band spectra"
    else:
        nbytes, what, hint = spectra_bytes, f"simulating {n} DOFs over {s} lines", ""
    with pytest.raises(MemoryError, match=refusal(what, nbytes, hint)):
        simulate_white_noise(chain, band, dt, duration, histories=histories)


@pytest.mark.parametrize("histories", [True, False])
def test_simulation_counts_every_byte_of_a_tiny_record(monkeypatch, histories):
    # 5 samples at 1 s (odd): lines 0.2 and 0.4 Hz in the band; one DOF. Forces and
    # response spectra and the solver's copy, 3·16·s; with histories 2·8·r for them and
    # 16·(r // 2 + 1) for the full spectrum they are made from
    from podid_rs import SecondOrderSystem

    one = SecondOrderSystem([[1.0]], [[0.1]], [[4.0]])
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1)
    r, s = 5, 2
    if histories:
        nbytes = 3 * COMPLEX * s + 2 * FLOAT * r + COMPLEX * (r // 2 + 1)  # 224
        what, hint = f"simulating 1 DOFs over {s} lines with {r}-sample histories", (
            "pass histories=False to keep only the in-band spectra")
    else:
        nbytes, what, hint = 3 * COMPLEX * s, f"simulating 1 DOFs over {s} lines", ""
    with pytest.raises(MemoryError, match=refusal(what, nbytes, hint)):
        simulate_white_noise(one, (0.1, 0.45), 1.0, 5.0, histories=histories)


def test_a_request_of_exactly_the_allowed_fraction_fits(monkeypatch):
    # 1000 bytes available: 90 % is 900 (0.9 · 1000 rounds to exactly 900.0)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 1000)
    assert memory.fits_in_memory(900) and not memory.fits_in_memory(901)
    memory.require_memory(900, "x")
    with pytest.raises(MemoryError, match=r"^x needs 9\.01e-07 GB but only 1e-06 GB"):
        memory.require_memory(901, "x")
    # a fraction asked for is the one applied (the dense normal matrix asks for half)
    assert memory.fits_in_memory(500, 0.5) and not memory.fits_in_memory(501, 0.5)


def test_available_memory_is_read_from_meminfo_in_kib(monkeypatch):
    meminfo = "MemTotal:        4000 kB\nMemFree:         1500 kB\nMemAvailable:    2000 kB\n"
    monkeypatch.setattr(memory, "open", lambda *a, **k: io.StringIO(meminfo), raising=False)
    assert memory.available_memory_bytes() == 2000 * 1024
