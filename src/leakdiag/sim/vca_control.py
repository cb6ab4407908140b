"""Fixed-gain position controller of the VCA (stands in for the thesis's QFT controller).

The thesis used a robust fixed-gain QFT controller (Karpenko and Sepehri, 2005; Sec. 4.5) whose
transfer function it does not print. :class:`FixedGainController` is a documented substitute:
proportional position feedback plus load-pressure feedback (active damping of the hydraulic
resonance of Eq. 2-6) and a small integral term, all computed from the *measured* signals at
the sample rate, held constant between samples (zero-order hold) and saturated at the valve's
input limit.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np

__all__ = ["FixedGainController", "control_law"]


@dataclass(frozen=True)
class FixedGainController:
    """Gains of the fixed-gain controller.

    Parameters
    ----------
    position_gain_v_per_m : float, default 800.0
        :math:`K_p`, volts per metre of position error.
    integral_gain_v_per_m_s : float, default 3000.0
        :math:`K_i`, volts per metre-second of integrated error (removes the steady error
        that a spring load or a leak would cause); 0 disables it.
    pressure_gain_v_per_pa : float, default 3e-7
        :math:`K_{\\Delta p}`, volts per pascal of measured load pressure :math:`P_1 - P_2`,
        subtracted from the command (damps the hydraulic resonance).

    Notes
    -----
    With :math:`e_k = x_{ref,k} - x_{m,k}` at sample :math:`k` (period :math:`T`):

    .. math::

        I_k = I_{k-1} + e_k T, \\qquad
        u_k = \\mathrm{sat}_{u_{max}}\\big(K_p e_k + K_i I_k - K_{\\Delta p}(P_{1m} - P_{2m})\\big)

    The integrator is frozen while the output saturates (anti-windup). The defaults were chosen
    by simulation on Table 2-1's actuator with 200 N seal friction (docs/models.md): position
    error below 0.2 mm 0.3 s after a 2-20 mm step and below 0.03 mm after 0.8 s, overshoot
    below 4 %, with and without the spring. They are not fitted to any thesis figure.

    Examples
    --------
    >>> FixedGainController().to_array().tolist()
    [800.0, 3000.0, 3e-07]
    """

    position_gain_v_per_m: float = 800.0
    integral_gain_v_per_m_s: float = 3000.0
    pressure_gain_v_per_pa: float = 3e-7

    def __post_init__(self) -> None:
        for name, v in asdict(self).items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"{name}={v!r} must be a finite number >= 0")

    def to_array(self) -> np.ndarray:
        """``[K_p, K_i, K_dp]`` as float64.

        Returns
        -------
        numpy.ndarray
            Shape ``(3,)``: position gain V/m, integral gain V/(m s), pressure gain V/Pa.
        """
        return np.array([self.position_gain_v_per_m, self.integral_gain_v_per_m_s,
                         self.pressure_gain_v_per_pa], dtype=np.float64)

    def to_dict(self) -> dict[str, float]:
        """Field name -> value.

        Returns
        -------
        dict
            One entry per gain, units as in the field names.
        """
        return asdict(self)


@numba.njit(cache=True)
def control_law(error, integral, load_pressure, dt, gains, u_max):
    """One step of the fixed-gain control law (Numba-compiled).

    Parameters
    ----------
    error : float
        Measured position error :math:`x_{ref} - x_m` in m.
    integral : float
        Integrated error up to the previous sample, m s.
    load_pressure : float
        Measured :math:`P_1 - P_2` in Pa.
    dt : float
        Sample period in s.
    gains : numpy.ndarray
        :meth:`FixedGainController.to_array`.
    u_max : float
        Saturation in V.

    Returns
    -------
    u : float
        Control signal in V.
    integral : float
        Updated integrated error (unchanged while saturated).

    Examples
    --------
    >>> control_law(0.01, 0.0, 0.0, 0.001, np.array([300.0, 0.0, 0.0]), 10.0)
    (3.0, 1e-05)
    """
    new_int = integral + error * dt
    u = gains[0] * error + gains[1] * new_int - gains[2] * load_pressure
    if u > u_max:
        return u_max, integral
    if u < -u_max:
        return -u_max, integral
    return u, new_int
