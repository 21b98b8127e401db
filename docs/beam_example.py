"""``podid-rs identify`` on the real roving-hammer test of a steel beam (UFSC).

Runs the command on ``beam_roving_hammer.uff`` (30 hammer points, one
accelerometer at point 3) and copies its stabilisation chart into ``docs/``
(the README's figure). Until ``read_uff`` reads a roving-hammer file by reciprocity,
the script writes a transposed copy first, H(k, 3) = H(3, k) (Maxwell): the 30
points become the responses and point 3 the driven DOF.

    python docs/beam_example.py [path/to/beam_roving_hammer.uff] [--out DIR]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import pyuff

from podid_rs import read_uff
from podid_rs.cli import main

DEFAULT = Path(__file__).resolve().parents[2] / "shared/data/ufsc_beam/beam_roving_hammer.uff"


def transposed_copy(source: Path, target: Path) -> Path:
    """The file with every FRF's response and reference swapped (reciprocity)."""
    uff = pyuff.UFF(str(source))
    sets = uff.read_sets()
    for d in sets:
        if d["type"] == 58:
            d["rsp_node"], d["ref_node"] = d["ref_node"], d["rsp_node"]
            d["rsp_dir"], d["ref_dir"] = d["ref_dir"], d["rsp_dir"]
    target.unlink(missing_ok=True)
    pyuff.UFF(str(target)).write_sets(sets, "add")
    return target


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("uff", nargs="?", type=Path, default=DEFAULT)
    ap.add_argument("--out", type=Path, default=Path("beam-results"))
    ap.add_argument("--band-hz", nargs=2, type=float, default=(50.0, 300.0))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.uff
    try:
        read_uff(path)
    except ValueError as exc:
        print(f"read_uff: {exc}\n-> analysing a transposed copy (reciprocity)")
        path = transposed_copy(path, args.out / "beam_reciprocal.uff")
    lo, hi = args.band_hz
    status = main(["identify", str(path), "--band-hz", f"{lo:g}", f"{hi:g}",
                   "--out", str(args.out / "identify")])
    docs = Path(__file__).resolve().parent
    shutil.copy(args.out / "identify" / "stabilisation.png", docs / "beam_stabilisation.png")
    raise SystemExit(status)
