"""Right-hand side of the VCA model, thesis Eqs. 2-1 to 2-5, as plain Numba functions.

State ``[x_p, v_p, P_1, P_2, x_v, v_v]`` (m, m/s, Pa, Pa, m, m/s). Inputs
``[u, k_l, dP_s, beta_scale, damping_scale, spring_scale]`` (see :data:`INPUT_INDEX`):
control signal (V), the leakage coefficient in force at that instant (Eq. 2-4 units
m^3/(s Pa^0.5), Eq. 2-5 units m^3/(s Pa)), a supply-pressure offset (Pa, pump ripple) and
multipliers of the bulk modulus, viscous damping and spring stiffness (operating conditions;
1 = nominal). ``params`` is :meth:`VCAParams.to_array`.
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.sim.friction import smooth_sign
from leakdiag.sim.leak import leak_flow
from leakdiag.sim.orifice import signed_sqrt
from leakdiag.sim.vca.params import (
    P_AREA, P_BETA, P_C_END, P_C_VALVE_LEAK, P_DAMPING, P_F_COULOMB, P_HALF_STROKE, P_K_END,
    P_K_SPRING, P_KV_FLOW, P_KV_SPOOL, P_LEAK_MODEL, P_MASS, P_OMEGA_V, P_PS, P_PT, P_PTR_LEAK,
    P_PTR_VALVE, P_V_COULOMB, P_VOLUME, P_W, P_ZETA_V,
)

__all__ = ["STATE_NAMES", "INPUT_INDEX", "vca_rhs", "vca_leak_flow", "default_inputs",
           "N_STATES", "N_INPUTS"]

#: Names of the six states, in order.
STATE_NAMES = ("x", "v", "p1", "p2", "xv", "vv")
S_X, S_V, S_P1, S_P2, S_XV, S_VV = range(6)
N_STATES = 6
#: Index of each input of ``vca_rhs``.
INPUT_INDEX = {"u": 0, "leak_coefficient": 1, "supply_offset_pa": 2, "beta_scale": 3,
               "damping_scale": 4, "spring_scale": 5}
IN_U, IN_KLEAK, IN_DPS, IN_BETA_SCALE, IN_DAMPING_SCALE, IN_SPRING_SCALE = range(6)
N_INPUTS = 6
_MIN_VOLUME_M3 = 1e-7  # guard against a volume <= 0 if an end stop is overrun


def default_inputs(u: float = 0.0, leak_coefficient: float = 0.0) -> np.ndarray:
    """Inputs array for nominal operating conditions.

    Parameters
    ----------
    u : float, default 0.0
        Control signal in V.
    leak_coefficient : float, default 0.0
        Leakage coefficient in force.

    Returns
    -------
    numpy.ndarray
        ``[u, leak_coefficient, 0, 1, 1, 1]``.

    Examples
    --------
    >>> default_inputs(1.5).tolist()
    [1.5, 0.0, 0.0, 1.0, 1.0, 1.0]
    """
    return np.array([u, leak_coefficient, 0.0, 1.0, 1.0, 1.0], dtype=np.float64)


@numba.njit(cache=True, error_model="numpy")
def vca_leak_flow(p1, p2, leak_coefficient, params):
    """Internal leakage flow from chamber 1 to chamber 2, Eq. 2-4 or Eq. 2-5 (m^3/s).

    Parameters
    ----------
    p1, p2 : float
        Chamber pressures in Pa.
    leak_coefficient : float
        :math:`k_l` in force.
    params : numpy.ndarray
        :meth:`VCAParams.to_array`; entry ``leak_model`` selects turbulent (0) or laminar (1).

    Returns
    -------
    float
        :math:`Q_l = k_l\\,\\mathrm{sgn}(P_1-P_2)\\sqrt{|P_1-P_2|}` (turbulent, regularised
        below ``ptr_leak``) or :math:`k_l (P_1 - P_2)` (laminar).

    Examples
    --------
    >>> from leakdiag.sim.vca.params import VCAParams
    >>> pa = VCAParams().to_array("laminar")
    >>> float(vca_leak_flow(2e6, 1e6, 1e-12, pa))
    1e-06
    """
    if leak_coefficient == 0.0:
        return 0.0
    return leak_flow(leak_coefficient, p1 - p2, params[P_PTR_LEAK], params[P_LEAK_MODEL] == 1.0)


@numba.njit(cache=True, error_model="numpy", inline="always")
def _rhs_into(t, s, inp, prm, out):
    x = s[S_X]
    v = s[S_V]
    p1 = s[S_P1]
    p2 = s[S_P2]
    xv = s[S_XV]
    vv = s[S_VV]
    area = prm[P_AREA]
    ps = prm[P_PS] + inp[IN_DPS]
    pt = prm[P_PT]
    half = prm[P_HALF_STROKE]
    # Mechanics, Eq. 2-1 + spring load, Coulomb friction, end stops (not in the thesis).
    force = (area * (p1 - p2) - prm[P_DAMPING] * inp[IN_DAMPING_SCALE] * v
             - prm[P_K_SPRING] * inp[IN_SPRING_SCALE] * x)
    if prm[P_F_COULOMB] > 0.0:
        force -= prm[P_F_COULOMB] * smooth_sign(v / prm[P_V_COULOMB])
    if x > half:
        force -= prm[P_K_END] * (x - half) + prm[P_C_END] * v
    elif x < -half:
        force -= prm[P_K_END] * (x + half) + prm[P_C_END] * v
    # Valve flows, Eq. 2-2 (critically lapped, matched orifices; Q2 leaves chamber 2).
    g = prm[P_KV_FLOW] * prm[P_W] * xv
    ptr = prm[P_PTR_VALVE]
    if xv >= 0.0:
        q1 = g * signed_sqrt(ps - p1, ptr)
        q2 = g * signed_sqrt(p2 - pt, ptr)
    else:
        q1 = g * signed_sqrt(p1 - pt, ptr)
        q2 = g * signed_sqrt(ps - p2, ptr)
    ql = vca_leak_flow(p1, p2, inp[IN_KLEAK], prm)
    beta = prm[P_BETA] * inp[IN_BETA_SCALE]
    v1 = prm[P_VOLUME] + area * x
    v2 = prm[P_VOLUME] - area * x
    if v1 < _MIN_VOLUME_M3:
        v1 = _MIN_VOLUME_M3
    if v2 < _MIN_VOLUME_M3:
        v2 = _MIN_VOLUME_M3
    # Spool-clearance leakage of the four metering lands (laminar; 0 for the ideal valve).
    c_vl = prm[P_C_VALVE_LEAK]
    if c_vl > 0.0:
        q1 += c_vl * (ps - p1) - c_vl * (p1 - pt)
        q2 -= c_vl * (ps - p2) - c_vl * (p2 - pt)
    dp1 = beta / v1 * (q1 - ql - area * v)
    dp2 = beta / v2 * (-q2 + ql + area * v)
    # Pressures bounded between tank and supply (cavitation / relief), not in Eq. 2-1.
    if (p1 >= ps and dp1 > 0.0) or (p1 <= pt and dp1 < 0.0):
        dp1 = 0.0
    if (p2 >= ps and dp2 > 0.0) or (p2 <= pt and dp2 < 0.0):
        dp2 = 0.0
    wv = prm[P_OMEGA_V]
    out[S_X] = v
    out[S_V] = force / prm[P_MASS]
    out[S_P1] = dp1
    out[S_P2] = dp2
    out[S_XV] = vv
    out[S_VV] = (-wv * wv * xv - 2.0 * prm[P_ZETA_V] * wv * vv
                 + prm[P_KV_SPOOL] * wv * wv * inp[IN_U])


@numba.njit(cache=True, error_model="numpy")
def vca_rhs(t, state, inputs, params):
    """Time derivative of the VCA state, Eqs. 2-1 to 2-5 (Numba-compiled).

    Parameters
    ----------
    t : float
        Time in s (unused: the model is time-invariant given ``inputs``).
    state : numpy.ndarray
        ``[x_p, v_p, P_1, P_2, x_v, v_v]`` in m, m/s, Pa, Pa, m, m/s.
    inputs : numpy.ndarray
        ``[u, k_l, dP_s, beta_scale, damping_scale, spring_scale]``, see
        :func:`default_inputs`.
    params : numpy.ndarray
        :meth:`VCAParams.to_array`.

    Returns
    -------
    numpy.ndarray
        Shape ``(6,)``, the derivatives.

    Notes
    -----
    .. math::

        \\dot x_p = v_p,\\quad
        m\\dot v_p = A(P_1 - P_2) - d v_p - k_s x_p - F_c\\tanh(v_p/v_c) + F_{stop}

        \\dot P_1 = \\frac{\\beta}{V + A x_p}(Q_1 - Q_l - A v_p),\\quad
        \\dot P_2 = \\frac{\\beta}{V - A x_p}(-Q_2 + Q_l + A v_p)   \\quad (2\\text{-}1)

        \\dot v_v = -\\omega_v^2 x_v - 2\\xi\\omega_v v_v + k_v\\omega_v^2 u

    with :math:`Q_1, Q_2` from Eq. 2-2 and :math:`Q_l` from Eq. 2-4 or 2-5. A pressure at its
    bound (tank or supply) does not move further outwards. A valve with spool-clearance
    leakage :math:`c_v` (``valve_leakage_m3_per_s_pa``, 0 in Table 2-1) adds
    :math:`c_v(P_s - P_i) - c_v(P_i - P_r)` to the flow into chamber :math:`i`. ``inputs[0]``
    is the signal the valve sees: the controller's command plus the valve's null offset, which
    :func:`~leakdiag.sim.vca.integrate.integrate_closed_loop` adds (``valve_null_v``).

    Examples
    --------
    >>> from leakdiag.sim.vca.params import VCAParams
    >>> p = VCAParams()
    >>> s = np.array([0.0, 0.0, 8.6e6, 8.6e6, 0.0, 0.0])
    >>> vca_rhs(0.0, s, default_inputs(), p.to_array()).tolist()  # at rest, valve closed
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    """
    out = np.empty(6)
    _rhs_into(t, state, inputs, params, out)
    return out
