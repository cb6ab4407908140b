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
# (simulate_vca, VCAParams ... are added below once written)

# --- EHA (owner: EHA engineer): add `from leakdiag.sim.eha... import simulate_eha, EHAParams`
# and extend __all__ here. ---------------------------------------------------------------------
