"""Fitting reduced M, C, K to frequency-domain data (paper §3–5, eqs. 19–49).

- :mod:`.result` — :class:`IdentificationResult`, the warnings, ‖Ax − y‖ (eq. 28):
  what every fitter returns and shares;
- :mod:`.solvers` — the fixed-λ solvers of eq. 49 (NumPy dense, Rust direct, Rust CG);
- :mod:`.regularisation` — the rules that choose λ (§4.2): L-curve, GCV, discrepancy;
- :mod:`.estimator` — :func:`identify`, the entry point: a number λ goes to the
  solvers, a rule's name to the regularisation;
- :mod:`.reference` — the paper's literal Kronecker formulation (the oracle);
- :mod:`.refinement` — output-error refinement: models that reproduce the data;
- :mod:`.latent` — latent coordinates: models with more DOFs than measured points;
- :mod:`.holes`, :mod:`.lines` — entries not measured; the informative lines of a long test;
- :mod:`.modal_start` — the final fit's modal start, rebuilt from the in-band poles;
- :mod:`.order` — the order on measured data, chosen on held-out lines.

This package re-exports the public names of its modules that ``podid_rs`` offers.
"""

from .estimator import identify
from .latent import observation_matrix
from .order import OrderSweep, final_fit, sweep_orders
from .refinement import StartWarning, refine
from .regularisation import (
    LambdaCurve,
    LambdaSelectionWarning,
    NoCornerWarning,
    choose_lambda,
    lambda_curve,
)
from .result import ConvergenceWarning, IdentificationResult, RankDeficientWarning

__all__ = [
    "ConvergenceWarning",
    "IdentificationResult",
    "LambdaCurve",
    "LambdaSelectionWarning",
    "NoCornerWarning",
    "OrderSweep",
    "RankDeficientWarning",
    "StartWarning",
    "choose_lambda",
    "final_fit",
    "identify",
    "lambda_curve",
    "observation_matrix",
    "refine",
    "sweep_orders",
]
