"""Drive signals and operating conditions of the EHA experiment (thesis Sec. 4.6).

:func:`build_inputs` turns the experiment settings into the input matrix read by
:func:`~leakdiag.sim.eha.model.eha_rhs`, one row per output sample: the open-loop command
``3 sin 4t`` V (Sec. 4.6) or, in closed-loop mode, the position reference; the load spring; the
temperature multipliers of bulk modulus and damping; and the scheduled leak coefficient.
:class:`EHAConditions` holds the leak-free variations of the operating point (all off by
default, realistic ranges in ``docs/models.md``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from leakdiag.sim.eha.model import (
    IN_BETA_SCALE, IN_FV_SCALE, IN_KLEAK, IN_SPRING, IN_U, IN_XREF, N_INPUTS,
)
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.leak import LeakSchedule

__all__ = ["EHAConditions", "build_inputs", "LOADS", "MODES"]

LOADS = ("none", "spring")
MODES = ("open-loop", "closed-loop")
#: Smallest multiplier of amplitude, frequency, bulk modulus or damping (guards extreme draws).
MIN_MULTIPLIER = 0.1


@dataclass(frozen=True)
class EHAConditions:
    """Leak-free variations of the EHA operating point (all off by default).

    Parameters
    ----------
    temperature_rise_k : float, default 0.0
        Fluid temperature change over the run, linear from 0 at t = 0 to this value at the end.
        Realistic: 0-10 K in a 180 s run on a warming rig (negative: cooling).
    bulk_modulus_per_k : float, default -0.005
        Relative change of the bulk modulus per kelvin (mineral oil: -0.4 to -0.6 %/K).
    damping_per_k : float, default -0.02
        Relative change of the viscous damping per kelvin (follows the viscosity: -2 to -4 %/K
        for ISO VG 32-46 oil near 40 degC).
    spring_change_time_s : float or None, default None
        Time from which the spring stiffness is multiplied by ``spring_change_factor``
        (``load="spring"`` only).
    spring_change_factor : float, default 1.0
        Stiffness multiplier after the change. Realistic: 0.7-1.3.
    amplitude_variation : float, default 0.0
        Standard deviation of a slow random relative variation of the input amplitude
        (Ornstein-Uhlenbeck, time constant ``variation_time_constant_s``). Realistic: 0-0.1.
    frequency_variation : float, default 0.0
        Same for the input frequency. Realistic: 0-0.1.
    variation_time_constant_s : float, default 20.0
        Correlation time of the amplitude and frequency variations, s.

    Raises
    ------
    ValueError
        If a value is out of range (the message names it).

    Examples
    --------
    >>> EHAConditions().is_nominal
    True
    >>> EHAConditions(temperature_rise_k=5.0).is_nominal
    False
    """

    temperature_rise_k: float = 0.0
    bulk_modulus_per_k: float = -0.005
    damping_per_k: float = -0.02
    spring_change_time_s: float | None = None
    spring_change_factor: float = 1.0
    amplitude_variation: float = 0.0
    frequency_variation: float = 0.0
    variation_time_constant_s: float = 20.0

    def __post_init__(self) -> None:
        from leakdiag.sim._checks import check_condition_numbers

        check_condition_numbers(self, optional=("spring_change_time_s",))
        for name in ("amplitude_variation", "frequency_variation"):
            v = float(getattr(self, name))
            if not (0.0 <= v < 1.0):
                raise ValueError(f"{name}={v!r} must be in [0, 1)")
        if not (math.isfinite(self.spring_change_factor) and self.spring_change_factor >= 0):
            raise ValueError(
                f"spring_change_factor={self.spring_change_factor!r} must be a finite number >= 0")
        if self.spring_change_time_s is not None and not (
                math.isfinite(self.spring_change_time_s) and self.spring_change_time_s >= 0):
            raise ValueError(
                f"spring_change_time_s={self.spring_change_time_s!r} must be None or >= 0")
        if not (math.isfinite(self.variation_time_constant_s)
                and self.variation_time_constant_s > 0):
            raise ValueError(f"variation_time_constant_s={self.variation_time_constant_s!r} "
                             "must be a finite number > 0")

    @property
    def is_nominal(self) -> bool:
        """True if no variation is switched on."""
        return (self.temperature_rise_k == 0.0 and self.amplitude_variation == 0.0
                and self.frequency_variation == 0.0
                and (self.spring_change_time_s is None or self.spring_change_factor == 1.0))

    def to_dict(self) -> dict:
        """Field name -> value (for recording metadata).

        Returns
        -------
        dict
        """
        return asdict(self)


def _slow_variation(n: int, dt: float, std: float, tau: float,
                    rng: np.random.Generator) -> np.ndarray:
    """Stationary Ornstein-Uhlenbeck samples with standard deviation ``std``, time constant tau."""
    out = np.zeros(n)
    if std == 0.0 or n == 0:
        return out
    phi = math.exp(-dt / tau)
    e = rng.standard_normal(n)
    out[0] = std * e[0]
    c = std * math.sqrt(1.0 - phi * phi)
    for i in range(1, n):
        out[i] = phi * out[i - 1] + c * e[i]
    return out


def build_inputs(time: np.ndarray, params: EHAParams, mode: str = "open-loop",
                 load: str = "none", amplitude: float = 3.0, frequency_rad_s: float = 4.0,
                 conditions: EHAConditions | None = None, leak_coefficient: float = 0.0,
                 leak_schedule: LeakSchedule | None = None,
                 rng: np.random.Generator | None = None) -> np.ndarray:
    """Input matrix of the EHA model at the sample times.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times in s, shape ``(n,)``.
    params : EHAParams
        Rig parameters (spring stiffness).
    mode : {"open-loop", "closed-loop"}, default "open-loop"
        Open loop: ``amplitude`` in V drives the motor (Sec. 4.6, ``3 sin 4t``). Closed loop:
        ``amplitude`` in m is the position reference around mid-stroke.
    load : {"none", "spring"}, default "none"
        No load, or the spring of ``params.spring_stiffness_n_per_m``.
    amplitude : float, default 3.0
        Sine amplitude, V (open loop) or m (closed loop).
    frequency_rad_s : float, default 4.0
        Sine frequency, rad/s (Sec. 4.6: 4 rad/s).
    conditions : EHAConditions, optional
        Leak-free variations; default nominal.
    leak_coefficient : float, default 0.0
        Leak coefficient :math:`k_l` of Eq. 2-4, m^3/(s sqrt(Pa)).
    leak_schedule : LeakSchedule, optional
        When the leak is on; default none.
    rng : numpy.random.Generator, optional
        Source of the amplitude/frequency variations (needed only if they are on).

    Returns
    -------
    numpy.ndarray
        Shape ``(n, N_INPUTS)``.

    Raises
    ------
    ValueError
        If ``mode`` or ``load`` is unknown, or variations are on without ``rng``.

    Examples
    --------
    >>> t = np.arange(4) * (np.pi / 8)               # 4t = 0, pi/2, pi, 3 pi/2
    >>> u = build_inputs(t, EHAParams())
    >>> np.round(u[:, 0], 12).tolist()
    [0.0, 3.0, 0.0, -3.0]
    """
    if mode not in MODES:
        raise ValueError(f"mode={mode!r} must be one of {list(MODES)}")
    if load not in LOADS:
        raise ValueError(f"load={load!r} must be one of {list(LOADS)}")
    cond = EHAConditions() if conditions is None else conditions
    t = np.ascontiguousarray(time, dtype=np.float64)
    n = t.shape[0]
    dt = float(t[1] - t[0]) if n > 1 else 1.0
    if (cond.amplitude_variation or cond.frequency_variation) and rng is None:
        raise ValueError("amplitude/frequency variations need an rng")
    tau = cond.variation_time_constant_s
    amp = amplitude * np.maximum(
        1.0 + _slow_variation(n, dt, cond.amplitude_variation, tau, rng), MIN_MULTIPLIER)
    if cond.frequency_variation:
        omega = frequency_rad_s * np.maximum(
            1.0 + _slow_variation(n, dt, cond.frequency_variation, tau, rng), MIN_MULTIPLIER)
        # phase = integral of the instantaneous frequency (trapezoidal)
        phase = t[0] * omega[0] + np.concatenate(
            ([0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * np.diff(t))))
    else:
        phase = frequency_rad_s * t
    signal = amp * np.sin(phase)

    inputs = np.zeros((n, N_INPUTS))
    if mode == "open-loop":
        inputs[:, IN_U] = signal
    else:
        inputs[:, IN_XREF] = signal
    duration = float(t[-1] - t[0]) + dt if n else 0.0
    frac = (t - t[0]) / duration if n else t
    temp = cond.temperature_rise_k * frac
    inputs[:, IN_BETA_SCALE] = np.maximum(1.0 + cond.bulk_modulus_per_k * temp, MIN_MULTIPLIER)
    inputs[:, IN_FV_SCALE] = np.maximum(1.0 + cond.damping_per_k * temp, MIN_MULTIPLIER)
    if load == "spring":
        k = np.full(n, params.spring_stiffness_n_per_m)
        if cond.spring_change_time_s is not None:
            k[t >= cond.spring_change_time_s] *= cond.spring_change_factor
        inputs[:, IN_SPRING] = k
    if leak_schedule is not None and leak_coefficient:
        inputs[:, IN_KLEAK] = leak_coefficient * leak_schedule.multipliers(t)
    return inputs
