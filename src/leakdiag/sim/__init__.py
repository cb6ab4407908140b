"""Actuator simulators (:mod:`leakdiag.sim`): the valve-controlled actuator (VCA, thesis Ch. 2,
:mod:`leakdiag.sim.vca`), the electrohydrostatic actuator (EHA, thesis Ch. 3,
:mod:`leakdiag.sim.eha`), and what both share: leak schedules and calibration
(:mod:`~leakdiag.sim.leak`), references and structured excitation, sensor models and virtual
machines.

Heavy parts (Numba kernels) compile on first use; ``import leakdiag.sim`` stays cheap.
"""

from __future__ import annotations

from leakdiag._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any kernel is defined (leakdiag._numba_cache)

from leakdiag.sim.eha.drive import EHAConditions
from leakdiag.sim.eha.model import eha_rhs
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.eha.simulate import simulate_eha
from leakdiag.sim.leak import (
    CalibrationResult,
    LeakCalibrationError,
    LeakSchedule,
    calibrate_leak_coefficient,
    leak_multiplier,
    lpm_to_m3s,
    m3s_to_lpm,
)
from leakdiag.sim.machine import EHAMachine, VCAMachine, draw_machine
from leakdiag.sim.reference import (
    ChirpReference,
    PseudoRandomSteps,
    SampledReference,
    SineReference,
    as_reference,
)
from leakdiag.sim.sensors import SensorParams
from leakdiag.sim.vca.conditions import OperatingConditions
from leakdiag.sim.vca.control import FixedGainController
from leakdiag.sim.vca.integrate import integrate_closed_loop, rk4_advance
from leakdiag.sim.vca.model import default_inputs, vca_leak_flow, vca_rhs
from leakdiag.sim.vca.params import VCAParams
from leakdiag.sim.vca.simulate import simulate_vca

__all__ = [
    # shared: leak schedule and calibration
    "CalibrationResult",
    "LeakCalibrationError",
    "LeakSchedule",
    "calibrate_leak_coefficient",
    "leak_multiplier",
    "lpm_to_m3s",
    "m3s_to_lpm",
    # shared: references, sensors, virtual machines
    "ChirpReference",
    "PseudoRandomSteps",
    "SampledReference",
    "SineReference",
    "as_reference",
    "SensorParams",
    "EHAMachine",
    "VCAMachine",
    "draw_machine",
    # VCA
    "FixedGainController",
    "OperatingConditions",
    "VCAParams",
    "default_inputs",
    "integrate_closed_loop",
    "rk4_advance",
    "simulate_vca",
    "vca_leak_flow",
    "vca_rhs",
    # EHA
    "EHAConditions",
    "EHAParams",
    "eha_rhs",
    "simulate_eha",
]
