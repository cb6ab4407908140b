"""Right-hand side of the EHA model, thesis Eqs. 3-1 to 3-19 (Numba-compiled).

The model is a plain function ``eha_rhs(t, state, inputs, params)`` in the python-control
convention. Positions in the three vectors are named integers:

* ``state`` (``N_STATES``): ``S_X`` piston position (m, 0 at mid-stroke), ``S_V`` velocity (m/s),
  ``S_P1``/``S_P2`` chamber pressures (Pa; thesis :math:`P_A, P_B`, recording channels ``p1``,
  ``p2``), ``S_PA``/``S_PB`` pump-side line pressures (Pa; thesis :math:`P_1, P_2`, channels
  ``pa``, ``pb``), ``S_I`` motor current (A), ``S_W`` motor speed (rad/s), ``S_Z`` integral of
  the speed error (rad).
* ``inputs`` (``N_INPUTS``): ``IN_U`` command voltage (V, open loop), ``IN_XREF`` position
  reference (m, closed loop), ``IN_BETA_SCALE`` and ``IN_FV_SCALE`` multipliers of the bulk
  modulus and the viscous damping (temperature), ``IN_SPRING`` load-spring stiffness (N/m),
  ``IN_KLEAK`` leak coefficient in force :math:`s(t) k_l` of Eq. 2-4 (m^3/(s sqrt(Pa))):
  the integrator (:func:`~leakdiag.sim.eha.integrate.integrate_fast` with ``leak_schedule``)
  multiplies the calibrated coefficient of the input rows by the schedule of
  :mod:`leakdiag.sim.leak`, as the VCA kernel does.
* ``params``: :meth:`leakdiag.sim.eha.params.EHAParams.to_array`.
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.sim.eha.flows import check_valve_flow, line_orifice_flow
from leakdiag.sim.eha.params import (
    P_AREA, P_BETA, P_BM, P_CE, P_CEXT, P_CINT, P_CLOSED, P_CM, P_CSTOP, P_FPR, P_FV,
    P_JM, P_KCV, P_KFREE, P_KI, P_KP, P_KRESTR, P_KSTOP, P_KW, P_KX, P_LC, P_M, P_PACC,
    P_PCV, P_PTR, P_QB, P_RC, P_STROKE, P_UMAX, P_V0, P_VLINE, P_VMAX, P_VTH, P_WMAX,
)
from leakdiag.sim.friction import smooth_sign
from leakdiag.sim.leak import leak_flow

__all__ = [
    "eha_rhs",
    "eha_command",
    "eha_leak_flow",
    "N_STATES",
    "N_INPUTS",
    "STATE_NAMES",
]

S_X, S_V, S_P1, S_P2, S_PA, S_PB, S_I, S_W, S_Z = range(9)
N_STATES = 9
STATE_NAMES = ("x", "v", "p1", "p2", "pa", "pb", "current", "motor_speed", "speed_error_integral")
IN_U, IN_XREF, IN_BETA_SCALE, IN_FV_SCALE, IN_SPRING, IN_KLEAK = range(6)
N_INPUTS = 6
TWO_PI = 2.0 * np.pi
MIN_VOLUME_FRACTION = 0.05  # chamber volume floor (fraction of V) if an end stop is overrun


@numba.njit(cache=True, error_model="numpy")
def eha_command(state, inputs, params):
    """Command voltage seen by the drive: ``u`` (open loop) or ``K_x (x_ref - x)`` (closed loop).

    Parameters
    ----------
    state : numpy.ndarray
        State vector, shape ``(N_STATES,)``.
    inputs : numpy.ndarray
        Input vector, shape ``(N_INPUTS,)``.
    params : numpy.ndarray
        Parameter vector from ``EHAParams.to_array``.

    Returns
    -------
    float
        Command in V, saturated at ``+-command_limit_v``.

    Examples
    --------
    >>> from leakdiag.sim.eha.params import EHAParams
    >>> p = EHAParams().to_array(closed_loop=True)
    >>> x = np.zeros(N_STATES); x[S_X] = 0.01
    >>> u = np.zeros(N_INPUTS); u[IN_XREF] = 0.015
    >>> round(eha_command(x, u, p), 6)      # 400 V/m * 5 mm
    2.0
    """
    if params[P_CLOSED] != 0.0:
        u = params[P_KX] * (inputs[IN_XREF] - state[S_X])
    else:
        u = inputs[IN_U]
    umax = params[P_UMAX]
    if u > umax:
        return umax
    if u < -umax:
        return -umax
    return u


@numba.njit(cache=True, error_model="numpy")
def eha_leak_flow(state, inputs, params):
    """Internal leakage flow from chamber 1 to chamber 2, m^3/s (Eq. 2-4, turbulent).

    Parameters
    ----------
    state : numpy.ndarray
        State vector.
    inputs : numpy.ndarray
        Input vector; ``inputs[IN_KLEAK]`` is the scheduled leak coefficient.
    params : numpy.ndarray
        Parameter vector (for the laminar transition pressure).

    Returns
    -------
    float
        :math:`s(t)\\,k_l\\,g(P_A - P_B)` in m^3/s, :func:`leakdiag.sim.leak.leak_flow`.

    Examples
    --------
    >>> from leakdiag.sim.eha.params import EHAParams
    >>> p = EHAParams().to_array()
    >>> x = np.zeros(N_STATES); x[S_P1] = 2e6 + 1e8; x[S_P2] = 2e6
    >>> u = np.zeros(N_INPUTS); u[IN_KLEAK] = 1e-8
    >>> round(eha_leak_flow(x, u, p) * 1e4, 6)      # 1e-8 * sqrt(1e8)
    1.0
    """
    k = inputs[IN_KLEAK]
    if k == 0.0:
        return 0.0
    return leak_flow(k, state[S_P1] - state[S_P2], params[P_PTR], False)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rhs_into(t, y, inputs, p, out):
    """Write dy/dt into ``out`` (no allocation); see :func:`eha_rhs`."""
    x = y[S_X]
    v = y[S_V]
    p1 = y[S_P1]
    p2 = y[S_P2]
    pa = y[S_PA]
    pb = y[S_PB]
    cur = y[S_I]
    w = y[S_W]
    z = y[S_Z]
    area = p[P_AREA]
    beta = p[P_BETA] * inputs[IN_BETA_SCALE]
    ptr = p[P_PTR]

    # --- drive: speed set-point and PI speed loop (Eqs. 3-1, 3-2), motor (Eqs. 3-3, 3-4)
    u = eha_command(y, inputs, p)
    wd = p[P_KW] * u
    if wd > p[P_WMAX]:
        wd = p[P_WMAX]
    elif wd < -p[P_WMAX]:
        wd = -p[P_WMAX]
    err = wd - w
    volt = p[P_KP] * err + p[P_KI] * z
    dz = err
    if volt > p[P_VMAX]:
        volt = p[P_VMAX]
        if err > 0.0:
            dz = 0.0  # anti-windup: no integration into the saturation
    elif volt < -p[P_VMAX]:
        volt = -p[P_VMAX]
        if err < 0.0:
            dz = 0.0
    qrad = p[P_QB] / TWO_PI
    dcur = (volt - p[P_RC] * cur - p[P_CE] * w) / p[P_LC]
    dw = (p[P_CM] * cur - p[P_BM] * w - qrad * (pa - pb)) / p[P_JM]  # Eqs. 3-4, 3-5

    # --- pump (Eq. 3-6), pump leakage, accumulator check valves
    q_pump = qrad * w
    q_int = p[P_CINT] * (pa - pb)
    pacc = p[P_PACC]
    q_acc_a = -p[P_CEXT] * (pa - pacc)
    q_acc_b = -p[P_CEXT] * (pb - pacc)
    q_acc_a += check_valve_flow(p[P_KCV], pacc - pa, p[P_PCV], ptr)
    q_acc_b += check_valve_flow(p[P_KCV], pacc - pb, p[P_PCV], ptr)

    # --- line orifices (Eqs. 3-9 to 3-12): free into chamber 1 and out of chamber 2
    q_a = line_orifice_flow(p[P_KFREE], p[P_KRESTR], pa - p1, ptr)
    q_b = line_orifice_flow(p[P_KFREE], p[P_KRESTR], p2 - pb, ptr)

    # --- internal leak between the chambers (Eq. 2-4)
    q_leak = eha_leak_flow(y, inputs, p)

    # --- pressures (Eqs. 3-16 to 3-19) with chamber volumes that follow the piston
    v0 = p[P_V0]
    vmin = MIN_VOLUME_FRACTION * v0
    va = v0 + area * x
    vb = v0 - area * x
    if va < vmin:
        va = vmin
    if vb < vmin:
        vb = vmin
    out[S_P1] = beta / va * (q_a - area * v - q_leak)
    out[S_P2] = beta / vb * (-q_b + area * v + q_leak)
    out[S_PA] = beta / p[P_VLINE] * (q_pump - q_a - q_int + q_acc_a)
    out[S_PB] = beta / p[P_VLINE] * (q_b - q_pump + q_int + q_acc_b)

    # --- piston (Eqs. 3-13 to 3-15): preload friction with velocity threshold, viscous
    # damping, load spring, end stops
    force = (p1 - p2) * area - p[P_FPR] * smooth_sign(v / p[P_VTH]) - p[P_FV] * inputs[IN_FV_SCALE] * v
    force -= inputs[IN_SPRING] * x
    half = 0.5 * p[P_STROKE]
    if x > half:
        force -= p[P_KSTOP] * (x - half) + p[P_CSTOP] * v
    elif x < -half:
        force -= p[P_KSTOP] * (x + half) + p[P_CSTOP] * v
    out[S_X] = v
    out[S_V] = force / p[P_M]
    out[S_I] = dcur
    out[S_W] = dw
    out[S_Z] = dz


@numba.njit(cache=True, error_model="numpy")
def eha_rhs(t, state, inputs, params):
    """Time derivative of the EHA state (Numba-compiled; callable from Python and Numba).

    Parameters
    ----------
    t : float
        Time in s.
    state : numpy.ndarray
        State vector, shape ``(N_STATES,)``, float64 (see the module docstring).
    inputs : numpy.ndarray
        Input vector, shape ``(N_INPUTS,)``, float64.
    params : numpy.ndarray
        ``EHAParams.to_array(...)``.

    Returns
    -------
    numpy.ndarray
        ``d state / dt``, shape ``(N_STATES,)``.

    Notes
    -----
    Motor and PI speed loop (Eqs. 3-1 to 3-4, the integral of Eq. 3-2 as the state ``z``):

    .. math::

        V = k_p(\\omega_d - \\omega) + K_i z,\\quad
        L_c \\dot i = V - R_c i - C_e \\omega,\\quad
        J_M \\dot\\omega = C_m i - B_M \\omega - \\frac{q_b}{2\\pi}(P_1 - P_2)

    with :math:`\\omega_d = K_\\omega u`. Pump :math:`Q_1 = q_b\\omega/2\\pi` (Eq. 3-6), line
    orifices with free area :math:`A_{line}` into chamber A and out of chamber B, restricted area
    :math:`kA_{line}` the other way (Eqs. 3-7 to 3-12), pressures (Eqs. 3-16 to 3-19) with
    :math:`V_A = V + A x`, :math:`V_B = V - A x`, the leak :math:`Q_l` (Eq. 2-4) from A to B,
    and the piston (Eqs. 3-13 to 3-15)
    :math:`M\\dot v = (P_A - P_B)A - F_{pr}\\tanh(v/V_{th}) - F_v v - k_s x - F_{stop}`.

    References
    ----------
    Thesis Ch. 3 (after Thakur, 2011); leak law Eq. 2-4 (Karpenko and Sepehri, 2010).

    Examples
    --------
    At the accumulator pressure with zero input nothing changes:

    >>> from leakdiag.sim.eha.params import EHAParams
    >>> p = EHAParams().to_array()
    >>> y = np.zeros(N_STATES); y[S_P1:S_PB + 1] = EHAParams().accumulator_pressure_pa
    >>> u = np.array([0.0, 0.0, 1.0, 1.0, 0.0, 0.0])
    >>> float(np.abs(eha_rhs(0.0, y, u, p)).max())
    0.0
    """
    out = np.empty(N_STATES)
    _rhs_into(t, state, inputs, params, out)
    return out
