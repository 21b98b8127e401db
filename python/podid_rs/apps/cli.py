"""Command line: ``podid-rs <command> ...`` (also ``python -m podid_rs``).

Commands:

- ``paper`` — reproduce Section 6 of the paper: figures and a results table
  (:func:`podid_rs.apps.paper.run_paper_study`).
- ``identify`` — identify a reduced model from measured data (UFF 58 FRFs, time
  histories or a saved data set): model, FRF overlays and modal table
  (:func:`podid_rs.apps.identify.run_identify`).

Each command is one ``_add_<name>`` function that registers its sub-parser and
sets ``handler``, a function ``(args) -> int`` (bound to its sub-parser, for usage
errors); :func:`main` dispatches.
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
from collections.abc import Sequence

from .. import __version__
from ..identification.regularisation import RULES


def parse_lam(tokens: Sequence[str]) -> float | tuple[float, float, float] | str:
    """The ``--lam`` value: one λ for all three blocks, λ_M λ_C λ_K (paper eq. 40), or the
    name of a rule that chooses λ (``lcurve``, ``gcv``, ``discrepancy``; §4.2).

    Raises ``ValueError`` with a message fit for the command line.
    """
    if len(tokens) == 1 and tokens[0] in RULES:
        return tokens[0]
    if len(tokens) not in (1, 3):
        raise ValueError(
            f"--lam takes one value or three (lam_M lam_C lam_K), got {len(tokens)}"
        )
    values = []
    for tok in tokens:
        try:
            v = float(tok)
        except ValueError:
            raise ValueError(f"--lam: {tok!r} is not a number") from None
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"--lam: values must be finite and non-negative, got {tok!r}")
        values.append(v)
    return values[0] if len(values) == 1 else (values[0], values[1], values[2])


def _energy(text: str) -> float:
    try:
        k = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < k <= 1:
        raise argparse.ArgumentTypeError(f"must be a fraction in (0, 1], e.g. 0.99; got {text}")
    return k


def _integer_at_least(lo: int, kind: str):
    """argparse type: an integer ≥ ``lo``; ``kind`` names it in the error message."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if n < lo:
            raise argparse.ArgumentTypeError(f"must be {kind}, got {text}")
        return n

    return parse


_seed = _integer_at_least(0, "a non-negative integer")
_order = _integer_at_least(1, "a positive integer")
_chain_size = _integer_at_least(2, "an integer >= 2")


def _run_paper(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``podid-rs paper``: run the study, print its summary; 1 if it fails."""
    from .paper import run_paper_study  # the study's modules, loaded when it runs

    try:
        lam = parse_lam(args.lam)
    except ValueError as exc:
        parser.error(str(exc))
    try:
        study = run_paper_study(
            args.out, quick=args.quick, seed=args.seed, lam=lam, energy=args.energy,
            progress=not args.no_progress, n=args.n,
        )
    except (ValueError, MemoryError, OSError) as exc:
        print(f"podid-rs paper: error: {exc}", file=sys.stderr)
        return 1
    print(study.summary())
    return 0


def _add_paper(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "paper",
        help="reproduce the paper's Section 6: figures and a results table",
        description=(
            "Reproduce Section 6 of Khalil, Adhikari & Sarkar (2007) on the 100-DOF chain: "
            "simulate band-limited white noise in four bands, build the POD basis, identify "
            "reduced M, C, K noise-free and at SNR 20 and 10 dB, and compare FRFs with the "
            "original model. Writes the counterparts of Figs. 2-19 as PNG files, results.csv "
            "and results.md."
        ),
    )
    p.add_argument("--out", default="podid-results", metavar="DIR",
                   help="output folder (created if missing; default: %(default)s)")
    p.add_argument("--quick", action="store_true",
                   help="short record and coarse grids: finishes in seconds (for tests)")
    p.add_argument("--seed", type=_seed, default=0, metavar="N",
                   help="random seed of forces and noise (default: %(default)s)")
    p.add_argument("--lam", nargs="+", default=["100"], metavar="LAM",
                   help="symmetry regularisation: one value for λ_M = λ_C = λ_K, three "
                   "values λ_M λ_C λ_K, or a rule that chooses λ per band and noise level: "
                   "lcurve, gcv or discrepancy (default: the paper's 100)")
    p.add_argument("--energy", type=_energy, default=None, metavar="K",
                   help="choose m as the smallest order capturing this energy fraction of the "
                   "noise-free response (default: the paper's m = 2, 4, 10, 13)")
    p.add_argument("--n", type=_chain_size, default=100, metavar="N",
                   help="masses of the chain (default: the paper's %(default)s); FRFs are "
                   "compared at H(N/2, N/2) and H(0.6N, 0.4N), the paper's places at N = 100")
    p.add_argument("--no-progress", action="store_true", help="no progress line on stderr")
    p.set_defaults(handler=functools.partial(_run_paper, parser=p))


def _run_identify(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """``podid-rs identify``: identify, write the files, print the summary; 1 if it fails."""
    from .identify import run_identify  # the command's modules, loaded when it runs

    lo, hi = args.band_hz
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        parser.error(f"--band-hz needs 0 <= LO < HI in Hz, got {lo:g} {hi:g}")
    lam = None
    if args.lam is not None:
        try:
            lam = parse_lam(args.lam)
        except ValueError as exc:
            parser.error(str(exc))
    if args.physical and not args.paper_estimator:
        parser.error("--physical applies to --paper-estimator: the refined model is physical "
                     "by construction")
    if args.m_max is not None and (args.m is not None or args.paper_estimator):
        parser.error("--m-max bounds the order sweep: it goes without --m and --paper-estimator")
    try:
        run = run_identify(
            args.data, args.out, band_hz=(lo, hi), m=args.m, energy=args.energy, lam=lam,
            physical=args.physical, paper_estimator=args.paper_estimator, m_max=args.m_max,
            progress=not args.no_progress,
        )
    except (ValueError, MemoryError, OSError) as exc:
        print(f"podid-rs identify: error: {exc}", file=sys.stderr)
        return 1
    print(run.summary(), end="")
    print("wrote " + ", ".join(str(p) for p in run.files))
    return 0


def _add_identify(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        help="identify reduced M, C, K from measured FRFs or time histories",
        description=(
            "Identify a reduced model from measured data: a Universal File (.uff/.unv, "
            "dataset 58 FRFs; velocity and acceleration are converted to receptance), or an "
            ".npz with time histories (arrays forces, responses, dt, inputs; FRFs by H1 with "
            "Welch averaging) or a data set saved by podid_rs.save_data. Builds the POD basis "
            "of the responses in the band and identifies M, C, K: by default output-error "
            "models (M, C, K symmetric positive definite, stable, fitted to the measured "
            "FRFs) of order 1, 2, ... by continuation, the order chosen by the error on "
            "held-out lines; --paper-estimator gives the paper's least-squares estimator "
            "(eq. 49) alone. Writes model.npz, FRF overlays (frf_input<k>.png), the modal "
            "table and a summary with FRF errors and stability (modes.csv, modes.md), the "
            "order sweep (order.png, order.md), the model as a Universal File (model.uff), "
            "the stabilisation chart over the POD order (stabilisation.png, .csv) and the "
            "MAC between two orders (mac.png)."
        ),
    )
    p.add_argument("data", metavar="DATA", help="measured data file (.uff, .unv or .npz)")
    p.add_argument("--band-hz", nargs=2, type=float, required=True, metavar=("LO", "HI"),
                   help="frequency band in Hz; the lines in it are used")
    order = p.add_mutually_exclusive_group()
    order.add_argument("--m", type=_order, default=None, metavar="M",
                       help="reduced order (number of POD modes; default: chosen by the error "
                       "on held-out lines, or by energy 0.99 with --paper-estimator)")
    order.add_argument("--energy", type=_energy, default=None, metavar="K",
                       help="smallest order capturing this energy fraction of the response")
    p.add_argument("--m-max", type=_order, default=None, metavar="M",
                   help="highest order the sweep tries (default: 40, at most the POD modes)")
    p.add_argument("--paper-estimator", action="store_true",
                   help="write the paper's estimator (eq. 49) alone, without the output-error "
                   "refinement")
    p.add_argument("--lam", nargs="+", default=None, metavar="LAM",
                   help="symmetry regularisation of the paper's estimator: λ, or λ_M λ_C λ_K "
                   "(eq. 40; default: exactly symmetric M, C, K, the λ → ∞ limit)")
    p.add_argument("--physical", action="store_true",
                   help="with --paper-estimator: make M, K positive definite and C positive "
                   "semidefinite (nearest matrices), reporting the change in residual")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output folder (created if missing)")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar on stderr (none is drawn off a terminal anyway)")
    p.set_defaults(handler=functools.partial(_run_identify, parser=p))


def build_parser() -> argparse.ArgumentParser:
    """The ``podid-rs`` argument parser with all its sub-commands."""
    parser = argparse.ArgumentParser(
        prog="podid-rs",
        description="Identify reduced M, C, K from frequency responses on a POD basis "
        "(Khalil, Adhikari & Sarkar 2007).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_paper(sub)
    _add_identify(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``podid-rs``; returns the exit status (argparse exits 2 on bad usage)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.handler(args)
