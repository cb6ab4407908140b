"""Operating conditions a real VCA varies without any leak (all off by default).

The detection benchmark switches them on so that a detector that flags *any* change, rather
than a leak, fails. Each option states a realistic range (docs/models.md, section VCA).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np

from leakdiag.sim.leak import leak_multiplier
from leakdiag.sim.vca.model import (
    IN_BETA_SCALE, IN_DAMPING_SCALE, IN_DPS, IN_KLEAK, IN_SPRING_SCALE, IN_U,
)

__all__ = ["OperatingConditions", "fill_inputs"]

# Positions in :meth:`OperatingConditions.to_array` (module-level integers: Numba folds them).
(C_RIPPLE_PA, C_RIPPLE_HZ, C_TEMP_RISE_K, C_DURATION_S, C_BETA_PER_K, C_DAMPING_PER_K,
 C_SPRING_TIME_S, C_SPRING_FACTOR) = range(8)


@dataclass(frozen=True)
class OperatingConditions:
    """Leak-free variations of the operating point.

    Parameters
    ----------
    supply_ripple_pa : float, default 0.0
        Amplitude of a sinusoidal supply-pressure ripple (pump). Realistic: 0.05-0.5 MPa
        (0.3-3 % of 17.2 MPa).
    supply_ripple_hz : float, default 270.0
        Ripple frequency: a 9-piston pump at 1800 rpm gives 270 Hz; realistic 100-400 Hz.
    temperature_rise_k : float, default 0.0
        Fluid temperature rise over the run, linear from 0 at t = 0 to this value at
        ``duration``. Realistic: 0-15 K in a 400 s test on a warming rig; negative = cooling.
    bulk_modulus_per_k : float, default -0.005
        Relative change of the bulk modulus per kelvin (mineral oil: about -0.4 to -0.6 %/K).
    damping_per_k : float, default -0.02
        Relative change of the viscous damping per kelvin (follows viscosity, about -2 to
        -4 %/K for ISO VG 32-46 oil near 40 degC).
    spring_change_time_s : float or None, default None
        Time at which the spring stiffness changes (``load="spring"`` only).
    spring_change_factor : float, default 1.0
        Stiffness multiplier from ``spring_change_time_s`` on. Realistic: 0.7-1.3.

    Notes
    -----
    A different reference sequence is the simulator's ``reference_seed`` argument. The
    multipliers of bulk modulus and damping are floored at 0.1.

    Examples
    --------
    >>> OperatingConditions().is_nominal
    True
    >>> OperatingConditions(temperature_rise_k=10.0).is_nominal
    False
    """

    supply_ripple_pa: float = 0.0
    supply_ripple_hz: float = 270.0
    temperature_rise_k: float = 0.0
    bulk_modulus_per_k: float = -0.005
    damping_per_k: float = -0.02
    spring_change_time_s: float | None = None
    spring_change_factor: float = 1.0

    def __post_init__(self) -> None:
        from leakdiag.sim._checks import check_condition_numbers

        check_condition_numbers(self, optional=("spring_change_time_s",))
        if self.spring_change_time_s is not None and self.spring_change_time_s < 0:
            raise ValueError(f"spring_change_time_s={self.spring_change_time_s!r} must be None "
                             "or >= 0")
        if self.supply_ripple_pa < 0:
            raise ValueError(f"supply_ripple_pa={self.supply_ripple_pa!r} must be >= 0")
        if self.supply_ripple_hz <= 0:
            raise ValueError(f"supply_ripple_hz={self.supply_ripple_hz!r} must be > 0")
        if self.spring_change_factor < 0:
            raise ValueError(f"spring_change_factor={self.spring_change_factor!r} must be >= 0")

    @property
    def is_nominal(self) -> bool:
        """True if no option changes the nominal model."""
        return (self.supply_ripple_pa == 0 and self.temperature_rise_k == 0
                and (self.spring_change_time_s is None or self.spring_change_factor == 1.0))

    def to_dict(self) -> dict:
        """Field name -> value.

        Returns
        -------
        dict
            One entry per field, units as in the field names.
        """
        return asdict(self)

    def to_array(self, duration: float) -> np.ndarray:
        """Encode for :func:`fill_inputs`.

        Parameters
        ----------
        duration : float
            Run duration in s (the temperature ramp spans it).

        Returns
        -------
        numpy.ndarray
            ``[ripple_pa, ripple_hz, temp_rise_k, duration, beta_per_k, damping_per_k,
            spring_change_time_s (inf if None), spring_change_factor]``.
        """
        tc = math.inf if self.spring_change_time_s is None else float(self.spring_change_time_s)
        return np.array([self.supply_ripple_pa, self.supply_ripple_hz, self.temperature_rise_k,
                         float(duration), self.bulk_modulus_per_k, self.damping_per_k, tc,
                         self.spring_change_factor], dtype=np.float64)


@numba.njit(cache=True, error_model="numpy")
def fill_inputs(t, u, leak_coefficient, schedule, cond, inputs):
    """Write the ``vca_rhs`` inputs at time ``t`` into ``inputs`` (Numba-compiled).

    Parameters
    ----------
    t : float
        Time in s.
    u : float
        Control signal in V (held between samples).
    leak_coefficient : float
        Full leakage coefficient; multiplied by the schedule's multiplier at ``t``.
    schedule : numpy.ndarray
        :meth:`LeakSchedule.to_array`.
    cond : numpy.ndarray
        :meth:`OperatingConditions.to_array`.
    inputs : numpy.ndarray
        Output, shape ``(6,)``.

    Examples
    --------
    >>> from leakdiag.sim.leak import LeakSchedule
    >>> inp = np.zeros(6)
    >>> fill_inputs(5.0, 1.0, 2.0, LeakSchedule("step", onset_s=1.0).to_array(),
    ...             OperatingConditions().to_array(10.0), inp)
    >>> inp.tolist()
    [1.0, 2.0, 0.0, 1.0, 1.0, 1.0]
    """
    inputs[IN_U] = u
    inputs[IN_KLEAK] = leak_coefficient * leak_multiplier(t, schedule)
    if cond[C_RIPPLE_PA] != 0.0:
        inputs[IN_DPS] = cond[C_RIPPLE_PA] * np.sin(2.0 * np.pi * cond[C_RIPPLE_HZ] * t)
    else:
        inputs[IN_DPS] = 0.0
    if cond[C_TEMP_RISE_K] != 0.0:
        frac = t / cond[C_DURATION_S]
        if frac > 1.0:
            frac = 1.0
        dtemp = cond[C_TEMP_RISE_K] * frac
        inputs[IN_BETA_SCALE] = max(0.1, 1.0 + cond[C_BETA_PER_K] * dtemp)
        inputs[IN_DAMPING_SCALE] = max(0.1, 1.0 + cond[C_DAMPING_PER_K] * dtemp)
    else:
        inputs[IN_BETA_SCALE] = 1.0
        inputs[IN_DAMPING_SCALE] = 1.0
    inputs[IN_SPRING_SCALE] = cond[C_SPRING_FACTOR] if t >= cond[C_SPRING_TIME_S] else 1.0
