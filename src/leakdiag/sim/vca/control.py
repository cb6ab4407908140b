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

from leakdiag._validation import check_positive
from leakdiag.sim.vca.params import VCAParams

__all__ = ["FixedGainController", "control_law", "linearized_position_plant",
           "position_only_controller", "loop_margins"]


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

    def position_loop_gain_per_s(self, params: VCAParams | None = None) -> float:
        r"""Gain of the sampled position loop, :math:`K_p k_v K_q / A` (1/s).

        The valve's spool gain :math:`k_v` and flow gain :math:`K_q = K_v w \sqrt{(P_s -
        P_t)/2}` (Eq. 2-2 at :math:`P_1 = P_2` mid-way, as :func:`linearized_position_plant`)
        over the piston area make the actuator an integrator from volts to position; with the
        proportional gain the loop is that integrator sampled at the control period :math:`T`
        through a zero-order hold, whose pole :math:`z = 1 - K T` leaves the unit circle at
        :math:`K T = 2`. :func:`~leakdiag.sim.simulate_vca` refuses sample rates at or below
        :math:`K/2` (the controller runs at the sample rate; docs/models.md, "Sample rate").

        Parameters
        ----------
        params : VCAParams, optional
            Table 2-1 by default.

        Returns
        -------
        float

        Examples
        --------
        >>> round(FixedGainController().position_loop_gain_per_s(), 1)  # stable above 45.6 Hz
        91.2
        """
        p = VCAParams() if params is None else params
        kq = p.valve_flow_gain_m1_5_per_kg0_5 * p.orifice_area_gradient_m * math.sqrt(
            max(p.supply_pressure_pa - p.tank_pressure_pa, 0.0) / 2.0)
        return self.position_gain_v_per_m * p.spool_gain_m_per_v * kq / p.piston_area_m2

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


@numba.njit(cache=True, error_model="numpy")
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


def linearized_position_plant(omega_rad_s, params: VCAParams | None = None,
                              sample_period_s: float = 1e-3) -> np.ndarray:
    r"""Frequency response :math:`X(j\omega)/U(j\omega)` of Eq. 2-1 linearised at the centre.

    Valve (second order, Table 2-1) -> spool -> flow gain :math:`K_q = K_v w \sqrt{P_s/2}`
    (Eq. 2-2 at :math:`P_1 = P_2 = P_s/2`, critically lapped: no flow-pressure coefficient at
    null) -> the actuator of Eq. 2-6 with its natural frequency and viscous damping, times the
    half-sample delay of the zero-order hold:

    .. math::

        P(s) = \frac{k_v \omega_v^2}{s^2 + 2\xi\omega_v s + \omega_v^2}
        \frac{K_q}{A} \frac{\omega_h^2}{s (s^2 + 2\zeta_h\omega_h s + \omega_h^2)}
        e^{-s T/2}

    Seal friction, the spring and a leak are left out: friction and leak add damping, so the
    leak-free, friction-free plant is the least damped member of the plant set (the worst
    case for a gain margin).

    Parameters
    ----------
    omega_rad_s : array_like
        Angular frequencies, rad/s (> 0).
    params : VCAParams, optional
        Table 2-1 by default.
    sample_period_s : float, default 1e-3
        Control period :math:`T` (zero-order hold).

    Returns
    -------
    numpy.ndarray of complex
        :math:`P(j\omega)` in m/V.

    Examples
    --------
    >>> round(float(abs(linearized_position_plant([1.0])[0])), 3)  # velocity gain k_v K_q / A
    0.114
    """
    p = VCAParams() if params is None else params
    w = np.asarray(omega_rad_s, dtype=np.float64)
    s = 1j * w
    kq = p.valve_flow_gain_m1_5_per_kg0_5 * p.orifice_area_gradient_m * math.sqrt(
        (p.supply_pressure_pa - p.tank_pressure_pa) / 2.0)
    wv = 2.0 * math.pi * p.valve_natural_frequency_hz
    xi = p.valve_damping_ratio
    wh = p.hydraulic_natural_frequency_rad_s
    zh = (p.viscous_damping_n_s_per_m * p.chamber_volume_m3 * wh
          / (4.0 * p.bulk_modulus_pa * p.piston_area_m2**2))
    valve = p.spool_gain_m_per_v * wv**2 / (s**2 + 2.0 * xi * wv * s + wv**2)
    actuator = kq / p.piston_area_m2 * wh**2 / (s * (s**2 + 2.0 * zh * wh * s + wh**2))
    return valve * actuator * np.exp(-s * sample_period_s / 2.0)


def loop_margins(gain_v_per_m: float, params: VCAParams | None = None,
                 sample_period_s: float = 1e-3) -> dict[str, float]:
    """Gain and phase margin of the loop ``K P(s)`` (:func:`linearized_position_plant`).

    Parameters
    ----------
    gain_v_per_m : float
        Proportional position gain :math:`K`, V/m.
    params : VCAParams, optional
        Table 2-1 by default.
    sample_period_s : float, default 1e-3
        Control period.

    Returns
    -------
    dict
        ``crossover_rad_s`` (``|K P| = 1``), ``phase_margin_deg``, ``phase_crossover_rad_s``
        (phase -180 deg), ``gain_margin_db``.

    Examples
    --------
    >>> m = loop_margins(100.0)
    >>> round(m["crossover_rad_s"], 1), m["phase_margin_deg"] > 80
    (11.4, True)
    """
    k = check_positive(gain_v_per_m, "gain_v_per_m")
    w = np.logspace(-1, 4.5, 400_000)
    resp = linearized_position_plant(w, params, sample_period_s)
    phase = np.unwrap(np.angle(resp))
    i180 = int(np.argmax(phase < -np.pi))
    ic = int(np.argmax(k * np.abs(resp) < 1.0))
    return {"crossover_rad_s": float(w[ic]),
            "phase_margin_deg": float(180.0 + np.degrees(phase[ic])),
            "phase_crossover_rad_s": float(w[i180]),
            "gain_margin_db": float(-20.0 * np.log10(k * np.abs(resp[i180])))}


def position_only_controller(gain_margin_db: float = 6.0, params: VCAParams | None = None,
                             sample_period_s: float = 1e-3) -> FixedGainController:
    """Position-only feedback of a QFT tracking loop's structure, with a stated gain margin.

    The rig's QFT controller (Karpenko and Sepehri, 2005) feeds back the encoder position
    only; its coefficients are not public (docs/models.md). This is the simplest member of
    that structure: proportional position feedback, no integral, no pressure feedback
    (``FixedGainController(K, 0, 0)``), with ``K`` chosen so that the least-damped plant of
    the set (no leak, no friction, :func:`linearized_position_plant`) keeps
    ``gain_margin_db`` at its phase crossover (just below the hydraulic resonance, Eq. 2-6).
    6 dB is the usual floor of a robust design. Nothing is fitted to a thesis number.

    Parameters
    ----------
    gain_margin_db : float, default 6
        Gain margin of the leak-free loop, dB (> 0).
    params : VCAParams, optional
        Table 2-1 by default.
    sample_period_s : float, default 1e-3
        Control period.

    Returns
    -------
    FixedGainController
        ``position_gain_v_per_m = K``, the other gains 0.

    Examples
    --------
    >>> round(position_only_controller().position_gain_v_per_m)
    135
    """
    gm = check_positive(gain_margin_db, "gain_margin_db")
    w = np.logspace(1, 4.5, 400_000)
    resp = linearized_position_plant(w, params, sample_period_s)
    i180 = int(np.argmax(np.unwrap(np.angle(resp)) < -np.pi))
    k = 10.0 ** (-gm / 20.0) / float(np.abs(resp[i180]))
    return FixedGainController(position_gain_v_per_m=k, integral_gain_v_per_m_s=0.0,
                               pressure_gain_v_per_pa=0.0)
