"""podid_rs: identify reduced mass, damping and stiffness matrices from frequency
responses on a proper-orthogonal-decomposition basis.

Khalil, Adhikari & Sarkar (2007), "Linear system identification using proper
orthogonal decomposition", MSSP 21, 3123–3145 — with a Rust core that never forms
the paper's Kronecker matrix. The pipeline, one home per stage, lowest first:

- :mod:`podid_rs.systems` — second-order systems (dense or sparse), the paper's
  mass–spring chain, a 2-D lattice;
- :mod:`podid_rs.simulation` — white-noise forcing, responses, spectra, H1 FRFs;
- :mod:`podid_rs.pod` — correlation matrices, POD basis, projection (eqs. 3–18);
- :mod:`podid_rs.identification` — fitting models to data: :func:`identify`
  (eqs. 19–49), choosing λ (§4.2), the paper's literal Kronecker formulation (the
  oracle), output-error refinement, the order on measured data;
- :mod:`podid_rs.measured` — measured data in memory (:class:`MeasuredData`);
- :mod:`podid_rs.physical` — SPD/PSD correction, modal parameters, stability;
- :mod:`podid_rs.modes` — mode shapes on the measured DOFs, the MAC;
- :mod:`podid_rs.stabilisation` — stabilisation chart over the POD order;
- :mod:`podid_rs.uncertainty` — confidence intervals on the modes, FRFs and M, C, K
  of a refined model;
- :mod:`podid_rs.statespace` — the model as a ``scipy.signal.StateSpace``;
- :mod:`podid_rs.io` — files: Universal Files (datasets 15, 55, 58) and ``.npz``;
- :mod:`podid_rs.plotting` — every figure;
- :mod:`podid_rs.apps` — what the ``podid-rs`` command line runs.

Everything a user calls is importable from ``podid_rs`` itself (``__all__``).
"""

from .identification import (
    ConvergenceWarning,
    IdentificationResult,
    LambdaCurve,
    LambdaSelectionWarning,
    NoCornerWarning,
    OrderSweep,
    RankDeficientWarning,
    StartWarning,
    choose_lambda,
    final_fit,
    identify,
    lambda_curve,
    observation_matrix,
    refine,
    sweep_orders,
)
from .io.npz import load_data, load_model, save_data, save_model
from .io.uff import read_uff, read_uff_geometry, read_uff_modes, write_uff
from .measured import DataWarning, MeasuredData
from .modes import ModeShapes, mac, mode_shapes, shape_mac
from .physical import make_physical, modal_parameters
from .plotting import plot_lambda_curve, plot_mac, plot_order_sweep, plot_stabilisation
from .pod import (
    PODResult,
    correlation_from_frf,
    correlation_from_snapshots,
    pod,
    pod_from_correlation,
    pod_from_frf,
    pod_from_spectra,
)
from .simulation import (
    H1Coherence,
    Simulation,
    add_noise,
    frf_h1,
    h1_coherence,
    simulate_white_noise,
    spectra,
)
from .stabilisation import StabilisationChart, is_physical, stabilisation_chart
from .systems import SecondOrderSystem, mass_spring_chain, mass_spring_lattice
from .uncertainty import (
    FRFBand,
    MatrixIntervals,
    ModeIntervals,
    ModelUncertainty,
    fit_uncertainty,
    model_uncertainty,
)

__version__ = "0.1.0"

__all__ = [
    "ConvergenceWarning",
    "DataWarning",
    "FRFBand",
    "H1Coherence",
    "IdentificationResult",
    "LambdaCurve",
    "LambdaSelectionWarning",
    "MatrixIntervals",
    "MeasuredData",
    "ModeIntervals",
    "ModelUncertainty",
    "ModeShapes",
    "NoCornerWarning",
    "OrderSweep",
    "PODResult",
    "RankDeficientWarning",
    "SecondOrderSystem",
    "Simulation",
    "StabilisationChart",
    "StartWarning",
    "add_noise",
    "choose_lambda",
    "correlation_from_frf",
    "correlation_from_snapshots",
    "final_fit",
    "fit_uncertainty",
    "frf_h1",
    "h1_coherence",
    "identify",
    "is_physical",
    "lambda_curve",
    "load_data",
    "load_model",
    "mac",
    "make_physical",
    "mass_spring_chain",
    "mass_spring_lattice",
    "modal_parameters",
    "model_uncertainty",
    "observation_matrix",
    "mode_shapes",
    "plot_lambda_curve",
    "plot_mac",
    "plot_order_sweep",
    "plot_stabilisation",
    "pod",
    "pod_from_correlation",
    "pod_from_frf",
    "pod_from_spectra",
    "read_uff",
    "read_uff_geometry",
    "read_uff_modes",
    "refine",
    "save_data",
    "save_model",
    "shape_mac",
    "simulate_white_noise",
    "spectra",
    "stabilisation_chart",
    "sweep_orders",
    "write_uff",
]
