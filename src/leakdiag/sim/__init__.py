"""Actuator simulators (:mod:`leakdiag.sim`): the valve-controlled actuator (VCA, thesis Ch. 2),
the electrohydrostatic actuator (EHA, thesis Ch. 3), leak schedules and sensor models.

Heavy parts (Numba kernels) compile on first use; ``import leakdiag.sim`` stays cheap.
"""

from __future__ import annotations

from leakdiag.sim.leak import (
    CalibrationResult,
    LeakCalibrationError,
    LeakSchedule,
    calibrate_leak_coefficient,
    leak_multiplier,
    lpm_to_m3s,
    m3s_to_lpm,
)

__all__ = [
    "CalibrationResult",
    "LeakCalibrationError",
    "LeakSchedule",
    "calibrate_leak_coefficient",
    "leak_multiplier",
    "lpm_to_m3s",
    "m3s_to_lpm",
]

# --- VCA (owner: VCA engineer) -------------------------------------------------------------
from leakdiag.sim.reference import (  # noqa: E402
    ChirpReference,
    PseudoRandomSteps,
    SampledReference,
    SineReference,
    as_reference,
)
from leakdiag.sim.sensors import SensorParams  # noqa: E402
from leakdiag.sim.vca_conditions import OperatingConditions  # noqa: E402
from leakdiag.sim.vca_control import FixedGainController  # noqa: E402
from leakdiag.sim.vca_integrator import integrate_closed_loop, rk4_advance  # noqa: E402
from leakdiag.sim.vca_model import default_inputs, vca_leak_flow, vca_rhs  # noqa: E402
from leakdiag.sim.vca_params import VCAParams  # noqa: E402
from leakdiag.sim.vca_simulate import simulate_vca  # noqa: E402

__all__ += [
    "ChirpReference",
    "FixedGainController",
    "OperatingConditions",
    "PseudoRandomSteps",
    "SampledReference",
    "SensorParams",
    "SineReference",
    "VCAParams",
    "as_reference",
    "default_inputs",
    "integrate_closed_loop",
    "rk4_advance",
    "simulate_vca",
    "vca_leak_flow",
    "vca_rhs",
]

# --- EHA (owner: EHA engineer): add `from leakdiag.sim.eha... import simulate_eha, EHAParams`
# and extend __all__ here. ---------------------------------------------------------------------
from leakdiag.sim.eha import simulate_eha  # noqa: E402
from leakdiag.sim.eha_drive import EHAConditions  # noqa: E402
from leakdiag.sim.eha_model import eha_rhs  # noqa: E402
from leakdiag.sim.eha_params import EHAParams  # noqa: E402

__all__ += ["EHAConditions", "EHAParams", "eha_rhs", "simulate_eha"]

# --- virtual machines: per-unit tolerances of both rigs -------------------------------------
from leakdiag.sim.machine import EHAMachine, VCAMachine, draw_machine  # noqa: E402

__all__ += ["EHAMachine", "VCAMachine", "draw_machine"]
