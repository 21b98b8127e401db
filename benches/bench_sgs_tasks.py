"""How the triangular solves of CG's preconditioner share two threads.

Times one preconditioner application (the two triangular solves of the
Gauss–Seidel split, as each CG iteration runs them; `examples/sgs_apply.rs`) on 2
threads for several settings of the solves' task knobs (`Sgs::split_depth`,
`Sgs::fork`, `Sgs::split_flops`), round-robin over the settings so that a slow
moment of the shared host hits them alike, and keeps each setting's fastest
application. The first setting is the reference the ratios are taken against
(by default the knobs before the tenth session: 8 pieces per product from 8e6
flops, Sylvester quarters forked from 32 modes); "default" is what `Sgs::new`
now uses.

    python3 benches/bench_sgs_tasks.py --sizes 200,400,1000
    python3 benches/bench_sgs_tasks.py --sizes 400 --settings "3,32,8e6 1,12,2e6 2,12,2e6"
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _common import load_average, markdown_table, write_report  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SETTINGS = "3,32,8e6 default 2,12,2e6 1,32,2e6 1,16,2e6 1,8,2e6 1,12,1e6 1,12,8e6"
LINE = re.compile(r"m = \d+, (exact-sym|penalty), .*best of \d+ ([0-9.]+) s per apply")


def example() -> Path:
    """Build `examples/sgs_apply.rs` (release) and return the binary's path."""
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "--example", "sgs_apply"],
        cwd=ROOT,
        check=True,
    )
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "examples" / "sgs_apply"


def apply_times(binary: Path, m: int, repeats: int, setting: str) -> dict[str, float]:
    """Fastest of `repeats` applications in both modes for one setting."""
    env = dict(os.environ)
    if setting != "default":
        depth, fork, flops = setting.split(",")
        env |= {"SGS_SPLIT_DEPTH": depth, "SGS_FORK": fork, "SGS_SPLIT_FLOPS": flops}
    out = subprocess.run(
        [str(binary), str(m), "2", str(repeats)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return {mode: float(t) for mode, t in LINE.findall(out)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="200,400,1000")
    ap.add_argument("--settings", default=SETTINGS, help="'depth,fork,flops' or 'default'")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default="bench-results/sgs_tasks.md")
    args = ap.parse_args()
    binary = example()
    settings = args.settings.split()
    rows = []
    loads = [load_average()]
    for m in [int(x) for x in args.sizes.split(",")]:
        repeats = max(5, int(1e10 / (18 * m**3)))  # about 10 GFLOP of applies per call
        best: dict[str, dict[str, float]] = {s: {} for s in settings}
        for _ in range(args.rounds):
            for s in settings:
                for mode, t in apply_times(binary, m, repeats, s).items():
                    best[s][mode] = min(best[s].get(mode, t), t)
        loads.append(load_average())
        ref = best[settings[0]]
        for s in settings:
            b = best[s]
            sym, pen = b["exact-sym"], b["penalty"]
            rows.append(
                [
                    str(m),
                    s,
                    f"{1e3 * sym:.2f}",
                    f"{1e3 * pen:.2f}",
                    f"{ref['exact-sym'] / sym:.2f}",
                    f"{ref['penalty'] / pen:.2f}",
                ]
            )
            print(
                f"m = {m:5d}  {s:>10}: exact-sym {1e3 * sym:7.2f} ms, penalty {1e3 * pen:7.2f} ms",
                flush=True,
            )
    seen = [x for x in loads if x is not None]
    span = f"{min(seen):.1f}–{max(seen):.1f}" if seen else "unknown"
    text = (
        "One preconditioner application (two triangular solves), 2 threads, fastest of "
        f"{args.rounds} round-robin calls per setting (synthetic SPD H̃ of "
        "`examples/sgs_apply.rs`); setting = split_depth, fork (modes), split_flops. "
        f"Ratios: the first setting's time over this one's. Load average {span}.\n\n"
        + markdown_table(
            ["m", "setting", "exact-sym ms", "penalty ms", "× first, sym", "× first, pen"], rows
        )
    )
    write_report(text, args.out)


if __name__ == "__main__":
    main()
