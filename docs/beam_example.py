"""``podid-rs identify`` on the real roving-hammer test of a steel beam (UFSC).

Runs the command (the default: output-error models, the order chosen on held-out
lines) on ``tests/data/ufsc_beam/beam_roving_hammer.uff`` — 30 hammer points, one
accelerometer at point 3, read by reciprocity as the FRF column of a force at point
3 — in a band, and copies its FRF overlay, order sweep and stabilisation chart into
``docs/`` as ``beam_<lo>_<hi>_{frf,order,stabilisation}.png`` (the README's figures).

    python docs/beam_example.py [path/to/file.uff] [--band-hz LO HI] [--out DIR]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from podid_rs.apps.cli import main

DEFAULT = Path(__file__).resolve().parents[1] / "tests/data/ufsc_beam/beam_roving_hammer.uff"

if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("uff", nargs="?", type=Path, default=DEFAULT)
    ap.add_argument("--out", type=Path, default=Path("beam-results"))
    ap.add_argument("--band-hz", nargs=2, type=float, default=(50.0, 300.0))
    args = ap.parse_args()
    lo, hi = args.band_hz
    out = args.out / f"identify_{lo:g}_{hi:g}"
    status = main(["identify", str(args.uff), "--band-hz", f"{lo:g}", f"{hi:g}",
                   "--out", str(out)])
    docs = Path(__file__).resolve().parent
    for name, target in (("frf_input1", "frf"), ("order", "order"),
                         ("stabilisation", "stabilisation")):
        shutil.copy(out / f"{name}.png", docs / f"beam_{lo:g}_{hi:g}_{target}.png")
    raise SystemExit(status)
