"""Mid-frequency scale: sparse models of 10⁵ DOFs, measurements of 10⁴ points.

Every case runs in its own process (time of the call, peak resident memory VmHWM):

- ``paper``: ``podid-rs paper --quick --n N`` (the paper's study on a chain of N
  masses), N = 100 and 100 000; the N = 100 table is compared with the one the
  dense code of before produced (``benches/reference/paper_quick_seed0.csv``);
- ``identify``: ``podid-rs identify`` on FRFs measured at n = 1 000 and 10 000
  points (401 lines, 2 driven DOFs, ``--m 20``), a data set written by
  ``podid_rs.save_data`` from a ``mass_spring_lattice`` (generated once, outside
  the timing, and kept in ``--data``);
- ``lattice``: the 100 × 100 lattice (n = 10 000) through simulate → POD →
  identify (m by energy 0.99, exactly symmetric, CG where large) → FRF error of the
  identified and the POD-projected model at a driving point and a cross entry.

    python benches/bench_scale.py                      # all cases (≈ 15 min on 2 cores)
    python benches/bench_scale.py --only paper,identify
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import (  # noqa: E402
    fmt,
    load_average,
    markdown_table,
    ratio,
    run_worker,
    timed,
    val,
    worker_main,
)

HERE = Path(__file__).resolve().parent
REFERENCE = HERE / "reference" / "paper_quick_seed0.csv"
TIME_COLUMNS = {"t_simulate_s", "t_pod_s", "t_identify_s", "t_frf_s"}

# identify: a lattice of (nx, ny) points, FRFs for two driven DOFs over 401 lines
ID_SIZES = {1000: (40, 25), 10000: (100, 100)}
ID_BAND_HZ = (20.0, 40.0)
ID_LINES = 401
ID_M = 20

# lattice pipeline
LAT_SHAPE = (100, 100)
LAT_BAND_HZ, LAT_DT, LAT_DURATION = (40.0, 50.0), 1 / 128, 40.0
LAT_ENERGY = 0.99


def _lattice(nx: int, ny: int):
    from podid_rs.systems import mass_spring_lattice

    return mass_spring_lattice(nx, ny, mass_variation=0.05, stiffness_variation=0.05, seed=0)


def paper_case(case: dict) -> dict:
    from podid_rs.apps.cli import main

    out = Path(case["out"])
    code, secs = timed(lambda: main(["paper", "--quick", "--n", str(case["n"]),
                                     "--out", str(out), "--no-progress"]))
    res = {"seconds": secs, "exit": code}
    if case["n"] == 100 and REFERENCE.is_file():
        res["max_rel_change"] = _table_change(out / "results.csv", REFERENCE)
    return res


def _table_change(path: Path, reference: Path) -> float:
    """Largest relative change of any number of the table (timings aside); inf if the
    rows or text differ."""
    def rows(p):
        with open(p, newline="") as fh:
            return list(csv.DictReader(fh))

    worst = 0.0
    for a, b in zip(rows(path), rows(reference), strict=True):
        for k, v in b.items():
            if k in TIME_COLUMNS:
                continue
            try:
                x, y = float(a[k]), float(v)
            except ValueError:
                if a[k] != v:
                    return math.inf
                continue
            if not (math.isnan(x) and math.isnan(y)):
                worst = max(worst, abs(x - y) / max(abs(y), 1e-300))
    return worst


def identify_data(n: int, folder: Path) -> Path:
    """FRF data set of the lattice for n points (generated once)."""
    path = folder / f"lattice_frf_n{n}.npz"
    if path.is_file():
        return path
    from podid_rs.io.npz import save_data
    from podid_rs.measured import from_frf

    nx, ny = ID_SIZES[n]
    system = _lattice(nx, ny)
    inputs = [(ny // 3) * nx + nx // 3, (ny // 2) * nx + (2 * nx) // 3]
    omega = 2 * np.pi * np.linspace(*ID_BAND_HZ, ID_LINES)
    H = system.frf(omega, cols=inputs)
    dofs = np.stack([np.arange(1, n + 1), np.full(n, 3)], axis=1)
    folder.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    save_data(tmp, from_frf(H, omega, inputs=inputs, dofs=dofs))
    tmp.rename(path)
    return path


def identify_case(case: dict) -> dict:
    from podid_rs.apps.cli import main

    args = ["identify", case["data"], "--band-hz", str(ID_BAND_HZ[0]), str(ID_BAND_HZ[1]),
            "--m", str(ID_M), "--out", case["out"]]
    code, secs = timed(lambda: main(args))
    return {"seconds": secs, "exit": code}


def lattice_case(case: dict) -> dict:
    import warnings

    from podid_rs import identify, simulate_white_noise

    nx, ny = LAT_SHAPE
    system = _lattice(nx, ny)
    n = system.n
    t = {}
    t0 = time.perf_counter()
    sim = simulate_white_noise(system, LAT_BAND_HZ, LAT_DT, LAT_DURATION, seed=0,
                               histories=False)
    t["simulate"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    P = sim.pod()
    m = P.order_for_energy(LAT_ENERGY)
    R = P.basis(m)
    U, F = P.project(sim.response_spectrum, m), P.project(sim.force_spectrum, m)
    t["pod"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = identify(U, F, sim.omega, symmetric=True)
    t["identify"] = time.perf_counter() - t0

    # FRF error at a driving point (centre of a quarter) and a cross entry
    a, b = (ny // 4) * nx + nx // 4, (ny // 2) * nx + (3 * nx) // 5
    t0 = time.perf_counter()
    H = system.frf(sim.omega, rows=[a, b], cols=[a])[:, :, 0]
    t["frf_original"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    errors = {}
    for label, model in (("identified", res.system()), ("projected", system.project(R))):
        Hm = model.frf(sim.omega)  # (s, m, m): reduced
        Hn = np.einsum("km,smp,p->sk", R[[a, b]], Hm, R[a])
        db = np.abs(20 * np.log10(np.abs(Hn) / np.abs(H)))
        errors[label] = [float(v) for v in np.median(db, axis=0)] + [
            float(v) for v in np.percentile(db, 95, axis=0)]
    t["frf_models"] = time.perf_counter() - t0
    return {
        "n": n, "lines": int(sim.omega.size), "m": m,
        "energy": float(P.energy_fraction[m - 1]), "unknowns": res.n_unknowns,
        "method": res.method, "iterations": res.iterations,
        "warnings": [str(w.message)[:120] for w in caught],
        "times": t, "seconds": sum(t.values()), "errors": errors,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="paper,identify,lattice")
    ap.add_argument("--paper-sizes", default="100,100000")
    ap.add_argument("--data", type=Path, default=Path("bench-results/scale-data"))
    ap.add_argument("--out", type=Path, default=Path("bench-results/scale.md"))
    args = ap.parse_args()
    only = set(args.only.split(","))
    me = str(Path(__file__).resolve())
    work = Path(tempfile.mkdtemp(prefix="bench-scale-"))
    lines = [f"# Scale benchmark — {time.strftime('%Y-%m-%d %H:%M')}", ""]
    loads = []

    def run(case: dict) -> dict:
        loads.append(load_average())
        r = run_worker(me, case, timeout=7200)
        loads.append(load_average())
        if "error" in r:
            print(f"{case['kind']} {case}: {r['error']}", file=sys.stderr)
        return r

    if "paper" in only:
        sizes = [int(s) for s in args.paper_sizes.split(",")]
        res = {n: run({"kind": "paper", "n": n, "out": str(work / f"paper{n}")}) for n in sizes}
        base = val(res.get(100), "seconds")
        rows = [[f"{n:,}", fmt(val(r, "seconds"), ".1f"),
                 fmt(ratio(val(r, "seconds"), base), ".1f"), fmt(val(r, "peak_gb"), ".2f"),
                 fmt(val(r, "max_rel_change"), ".1e")]
                for n, r in res.items()]
        lines += ["## `podid-rs paper --quick --n N`", "",
                  markdown_table(["N", "time s", "× N = 100", "peak GB",
                                  "N = 100 table: largest relative change vs the dense code"],
                                 rows), ""]
    if "identify" in only:
        res = {}
        for n in ID_SIZES:
            data = identify_data(n, args.data)
            res[n] = run({"kind": "identify", "data": str(data), "out": str(work / f"id{n}")})
        base = val(res[1000], "seconds")
        rows = [[f"{n:,}", str(ID_LINES), "2", str(ID_M), fmt(val(r, "seconds"), ".1f"),
                 fmt(ratio(val(r, "seconds"), base), ".1f"), fmt(val(r, "peak_gb"), ".2f")]
                for n, r in res.items()]
        lines += [f"## `podid-rs identify` on lattice FRFs, {ID_BAND_HZ[0]:g}–{ID_BAND_HZ[1]:g} Hz",
                  "", markdown_table(["points n", "lines", "inputs", "m", "time s",
                                      "× n = 1 000", "peak GB"], rows), ""]
    if "lattice" in only:
        r = run({"kind": "lattice"})
        if "error" not in r:
            t, e = r["times"], r["errors"]
            rows = [[f"{LAT_SHAPE[0]} × {LAT_SHAPE[1]}", f"{r['n']:,}", str(r["lines"]),
                     str(r["m"]), f"{r['energy']:.4f}", f"{r['unknowns']:,}",
                     f"{r['method']}" + (f" ({r['iterations']} it)" if r["iterations"] else ""),
                     " / ".join(f"{t[k]:.1f}" for k in ("simulate", "pod", "identify",
                                                          "frf_original", "frf_models")),
                     f"{r['seconds']:.1f}", f"{r['peak_gb']:.2f}",
                     f"{e['identified'][0]:.2f} / {e['identified'][2]:.1f}",
                     f"{e['identified'][1]:.2f} / {e['identified'][3]:.1f}",
                     f"{e['projected'][0]:.2f} / {e['projected'][2]:.1f}",
                     f"{e['projected'][1]:.2f} / {e['projected'][3]:.1f}"]]
            lines += [f"## Lattice: simulate → POD → identify, {LAT_BAND_HZ[0]:g}–"
                      f"{LAT_BAND_HZ[1]:g} Hz, energy {LAT_ENERGY}", "",
                      markdown_table(["lattice", "n", "lines", "m", "energy", "unknowns",
                                      "solver", "time s: simulate / POD / identify / "
                                      "original FRF / model FRFs", "total s", "peak GB",
                                      "identified driving pt. dB median / p95",
                                      "identified cross", "projected driving pt.",
                                      "projected cross"], rows), ""]
            if r["warnings"]:
                lines += ["Warnings: " + "; ".join(r["warnings"]), ""]
    lo = [x for x in loads if x is not None]
    lines.append(f"Load average (1 min) during the run: {min(lo):.1f}–{max(lo):.1f}"
                 if lo else "Load average: unavailable")
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker_main({"paper": paper_case, "identify": identify_case, "lattice": lattice_case})
    else:
        main()
