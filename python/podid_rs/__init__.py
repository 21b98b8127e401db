"""podid_rs: identify reduced mass, damping and stiffness matrices from frequency
responses on a proper-orthogonal-decomposition basis.

Khalil, Adhikari & Sarkar (2007), "Linear system identification using proper
orthogonal decomposition", MSSP 21, 3123–3145 — with a Rust core that never forms
the paper's Kronecker matrix. The pipeline, one module per stage:

- :mod:`podid_rs.systems` — second-order systems (dense or sparse), the paper's
  mass–spring chain, a 2-D lattice;
- :mod:`podid_rs.simulation` — white-noise forcing, responses, spectra, H1 FRFs;
- :mod:`podid_rs.pod` — correlation matrices, POD basis, projection (eqs. 3–18);
- :mod:`podid_rs.identification` — :func:`identify` (eqs. 19–49);
- :mod:`podid_rs.regularisation` — choosing λ: L-curve, GCV, discrepancy (§4.2);
- :mod:`podid_rs.reference` — the paper's literal Kronecker formulation (the oracle);
- :mod:`podid_rs.measurements` — measured data in: UFF 58 FRFs, time histories, ``.npz``;
- :mod:`podid_rs.refinement` — output-error refinement: models that reproduce the data;
- :mod:`podid_rs.model_order` — the order on measured data, chosen on held-out lines;
- :mod:`podid_rs.physical` — SPD/PSD correction, modal parameters, stability;
- :mod:`podid_rs.modes` — mode shapes on the measured DOFs, the MAC;
- :mod:`podid_rs.stabilisation` — stabilisation chart over the POD order;
- :mod:`podid_rs.uff` — the model out as a Universal File (datasets 15, 55, 58);
- :mod:`podid_rs.statespace` — the model as a ``scipy.signal.StateSpace``.
"""

from .identification import (
    ConvergenceWarning,
    IdentificationResult,
    RankDeficientWarning,
    identify,
)
from .measurements import MeasuredData, load_data, load_model, read_uff, save_data, save_model
from .model_order import OrderSweep, final_fit, plot_order_sweep, sweep_orders
from .modes import ModeShapes, mac, mode_shapes, plot_mac, shape_mac
from .physical import make_physical, modal_parameters
from .pod import (
    PODResult,
    correlation_from_frf,
    correlation_from_snapshots,
    pod,
    pod_from_correlation,
    pod_from_frf,
    pod_from_spectra,
)
from .refinement import StartWarning, refine
from .regularisation import (
    LambdaCurve,
    LambdaSelectionWarning,
    NoCornerWarning,
    choose_lambda,
    lambda_curve,
    plot_lambda_curve,
)
from .simulation import Simulation, add_noise, frf_h1, simulate_white_noise, spectra
from .stabilisation import (
    StabilisationChart,
    is_physical,
    plot_stabilisation,
    stabilisation_chart,
)
from .systems import SecondOrderSystem, mass_spring_chain, mass_spring_lattice
from .uff import read_uff_geometry, read_uff_modes, write_uff

__version__ = "0.1.0"

__all__ = [
    "ConvergenceWarning",
    "IdentificationResult",
    "LambdaCurve",
    "LambdaSelectionWarning",
    "MeasuredData",
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
    "frf_h1",
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
