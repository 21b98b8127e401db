"""What limits the refined model under response noise: the POD basis or the fit.

On the paper's chain (Section 6 settings, one band, SNR 10 dB on the responses, the
paper's order m), the same identification and refinement as ``podid-rs paper`` on the
four pairings of basis and responses, in one run:

* POD basis from the noise-free or the noisy responses (eqs. 3–7), or from the
  noisy ones less the noise variance their SNR implies (``PODResult.without_noise``,
  the basis ``podid-rs paper`` refines on for its noisy rows);
* the responses projected on it noise-free or noisy (eqs. 45–46).

Printed per pairing: median |dB| error at H(50,50) / H(60,40) against the original
chain for the paper's estimator (λ = 100, eq. 49), the refined model (what the study
does: relative, then uniform weights) and the POD-projected model RᵀMR, RᵀCR, RᵀKR.
If the refined model on the *noise-free* basis with *noisy* responses is back at its
noise-free error, the refinement has removed the noise's bias, and what is left is the
basis.

    python3 benches/bench_noise_basis.py [--band B] [--seed S]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import podid_rs as pr  # noqa: E402
from _common import load_average, markdown_table, write_report  # noqa: E402
from podid_rs.apps import paper  # noqa: E402
from podid_rs.pod import pod_from_spectra  # noqa: E402

SNR_DB = 10.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--band", type=int, default=3, choices=(1, 2, 3, 4))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="bench-results/noise_basis.md")
    args = ap.parse_args()
    t0 = time.perf_counter()
    b, seed = args.band, args.seed
    cfg = paper._settings(False, seed, (paper.PAPER_LAMBDA,) * 3, None, paper.PAPER_N)
    system = pr.mass_spring_chain(cfg.n, sparse=True)
    band = paper.BANDS_HZ[b - 1]
    # the study's own simulation and noise (the same sub-seeds as run_paper_study)
    sim = pr.simulate_white_noise(system, band, cfg.dt, cfg.duration, 1.0,
                                  seed=paper._sub_seed(seed, b), histories=False)
    entries = paper.chain_entries(cfg.n)
    H_orig = paper.frf_entries(system, sim.omega, entries)
    m = paper.PAPER_ORDERS[b - 1]
    k = paper.NOISE_LEVELS.index(SNR_DB)
    responses = {
        "noise-free": sim.response_spectrum,
        f"SNR {SNR_DB:g} dB": paper._band_limited_noisy_spectrum(
            sim, SNR_DB, paper._sub_seed(seed, b, k)),
    }
    bases = {name: pod_from_spectra(U_n, sim.n_samples) for name, U_n in responses.items()}
    noisy = responses[f"SNR {SNR_DB:g} dB"]
    bases[f"SNR {SNR_DB:g} dB, noise-corrected"] = bases[f"SNR {SNR_DB:g} dB"].without_noise(
        paper._noise_variance(noisy, sim.n_samples, SNR_DB))

    def errors(system_m, R) -> str:
        e = paper._errors(paper.frf_entries(system_m, sim.omega, entries, basis=R), H_orig)
        return f"{e[0]:.2f} / {e[2]:.2f}"

    rows = []
    for basis_name, P in bases.items():
        R = P.basis(m)
        projected = errors(system.project(R), R)
        for u_name, U_n in responses.items():
            U, F = P.project(U_n, m), P.project(sim.force_spectrum, m)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                estimator = pr.identify(U, F, sim.omega, lam=paper.PAPER_LAMBDA)
                refined = paper._refine_row(estimator, U, F, sim.omega)
            rows.append([basis_name, u_name, errors(estimator.system(), R),
                         errors(refined.system(), R), projected])
    header = ["POD basis from", "responses", "paper's estimator H(50,50) / H(60,40) dB",
              "refined dB", "projected dB"]
    load = load_average()
    text = (f"# Noise: basis or fit? Chain band {b} ({band[0]:g}–{band[1]:g} Hz), m = {m}, "
            f"seed {seed}\n\n{markdown_table(header, rows)}\n\nMedian |dB| error against the "
            f"original chain. {time.perf_counter() - t0:.0f} s, load average "
            f"{load if load is None else f'{load:.1f}'}; command "
            f"`python3 benches/bench_noise_basis.py --band {b} --seed {seed}`.\n")
    write_report(text, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
