"""Analytic Jacobian of the EHA right-hand side (:func:`leakdiag.sim.eha.model.eha_rhs`).

Used by the ROS2 integrator (:mod:`leakdiag.sim.eha.integrate`) at every step; tested against
central differences of the right-hand side in ``tests/sim/eha/test_model.py``.
"""

from __future__ import annotations

import numba

from leakdiag.sim.eha.flows import (
    _dcheck_valve, _dline_orifice, _dorifice, line_orifice_flow,
)
from leakdiag.sim.eha.model import (
    IN_BETA_SCALE, IN_FV_SCALE, IN_KLEAK, IN_SPRING, IN_U, IN_XREF, MIN_VOLUME_FRACTION,
    N_STATES, S_I, S_P1, S_P2, S_PA, S_PB, S_V, S_W, S_X, S_Z, TWO_PI, eha_leak_flow,
)
from leakdiag.sim.eha.params import (
    P_AREA, P_BETA, P_BM, P_CE, P_CEXT, P_CINT, P_CLOSED, P_CM, P_CSTOP, P_FPR, P_FV, P_JM,
    P_KCV, P_KFREE, P_KI, P_KP, P_KRESTR, P_KSTOP, P_KW, P_KX, P_LC, P_M, P_PACC, P_PCV,
    P_PTR, P_QB, P_RC, P_STROKE, P_UMAX, P_V0, P_VLINE, P_VMAX, P_VTH, P_WMAX,
)
from leakdiag.sim.friction import smooth_sign

__all__: list[str] = []


@numba.njit(cache=True, error_model="numpy", inline="always")
def _jacobian_into(t, y, inputs, p, jac):
    """Write the analytic Jacobian d f / d y of :func:`_rhs_into` into ``jac`` (9 x 9)."""
    for r in range(N_STATES):
        for c in range(N_STATES):
            jac[r, c] = 0.0
    x = y[S_X]
    v = y[S_V]
    p1 = y[S_P1]
    p2 = y[S_P2]
    pa = y[S_PA]
    pb = y[S_PB]
    w = y[S_W]
    z = y[S_Z]
    area = p[P_AREA]
    beta = p[P_BETA] * inputs[IN_BETA_SCALE]
    ptr = p[P_PTR]

    # drive: derivatives of the motor voltage and of z' through the saturations
    closed = p[P_CLOSED] != 0.0
    if closed:
        u = p[P_KX] * (inputs[IN_XREF] - x)
        du_dx = -p[P_KX]
    else:
        u = inputs[IN_U]
        du_dx = 0.0
    if u > p[P_UMAX] or u < -p[P_UMAX]:
        u = p[P_UMAX] if u > 0.0 else -p[P_UMAX]
        du_dx = 0.0
    wd = p[P_KW] * u
    dwd_dx = p[P_KW] * du_dx
    if wd > p[P_WMAX] or wd < -p[P_WMAX]:
        wd = p[P_WMAX] if wd > 0.0 else -p[P_WMAX]
        dwd_dx = 0.0
    err = wd - w
    volt = p[P_KP] * err + p[P_KI] * z
    dv_dw = -p[P_KP]
    dv_dz = p[P_KI]
    dv_dx = p[P_KP] * dwd_dx
    integrate = True
    if volt > p[P_VMAX] or volt < -p[P_VMAX]:
        dv_dw = 0.0
        dv_dz = 0.0
        dv_dx = 0.0
        if (volt > 0.0 and err > 0.0) or (volt < 0.0 and err < 0.0):
            integrate = False
    lc = p[P_LC]
    jac[S_I, S_I] = -p[P_RC] / lc
    jac[S_I, S_W] = (dv_dw - p[P_CE]) / lc
    jac[S_I, S_Z] = dv_dz / lc
    jac[S_I, S_X] = dv_dx / lc
    if integrate:
        jac[S_Z, S_W] = -1.0
        jac[S_Z, S_X] = dwd_dx
    qrad = p[P_QB] / TWO_PI
    jm = p[P_JM]
    jac[S_W, S_I] = p[P_CM] / jm
    jac[S_W, S_W] = -p[P_BM] / jm
    jac[S_W, S_PA] = -qrad / jm
    jac[S_W, S_PB] = qrad / jm

    # flows and their slopes
    dqa = _dline_orifice(p[P_KFREE], p[P_KRESTR], pa - p1, ptr)
    dqb = _dline_orifice(p[P_KFREE], p[P_KRESTR], p2 - pb, ptr)
    kl = inputs[IN_KLEAK]
    dql = _dorifice(kl, p1 - p2, ptr) if kl != 0.0 else 0.0
    pacc = p[P_PACC]
    dcva = _dcheck_valve(p[P_KCV], pacc - pa, p[P_PCV], ptr)
    dcvb = _dcheck_valve(p[P_KCV], pacc - pb, p[P_PCV], ptr)
    cint = p[P_CINT]
    cext = p[P_CEXT]

    # chambers
    v0 = p[P_V0]
    vmin = MIN_VOLUME_FRACTION * v0
    va = v0 + area * x
    vb = v0 - area * x
    ga = beta / va if va > vmin else beta / vmin
    gb = beta / vb if vb > vmin else beta / vmin
    q_a = line_orifice_flow(p[P_KFREE], p[P_KRESTR], pa - p1, ptr)
    q_b = line_orifice_flow(p[P_KFREE], p[P_KRESTR], p2 - pb, ptr)
    q_l = eha_leak_flow(y, inputs, p)
    jac[S_P1, S_P1] = ga * (-dqa - dql)
    jac[S_P1, S_P2] = ga * dql
    jac[S_P1, S_PA] = ga * dqa
    jac[S_P1, S_V] = -ga * area
    if va > vmin:
        jac[S_P1, S_X] = -ga / va * area * (q_a - area * v - q_l)
    jac[S_P2, S_P2] = gb * (-dqb - dql)
    jac[S_P2, S_P1] = gb * dql
    jac[S_P2, S_PB] = gb * dqb
    jac[S_P2, S_V] = gb * area
    if vb > vmin:
        jac[S_P2, S_X] = gb / vb * area * (-q_b + area * v + q_l)

    # lines
    gl = beta / p[P_VLINE]
    jac[S_PA, S_W] = gl * qrad
    jac[S_PA, S_PA] = gl * (-dqa - cint - cext - dcva)
    jac[S_PA, S_P1] = gl * dqa
    jac[S_PA, S_PB] = gl * cint
    jac[S_PB, S_W] = -gl * qrad
    jac[S_PB, S_PB] = gl * (-dqb - cint - cext - dcvb)
    jac[S_PB, S_P2] = gl * dqb
    jac[S_PB, S_PA] = gl * cint

    # piston
    m = p[P_M]
    th = smooth_sign(v / p[P_VTH])
    dfdv = -p[P_FPR] * (1.0 - th * th) / p[P_VTH] - p[P_FV] * inputs[IN_FV_SCALE]
    dfdx = -inputs[IN_SPRING]
    half = 0.5 * p[P_STROKE]
    if x > half or x < -half:
        dfdx -= p[P_KSTOP]
        dfdv -= p[P_CSTOP]
    jac[S_X, S_V] = 1.0
    jac[S_V, S_P1] = area / m
    jac[S_V, S_P2] = -area / m
    jac[S_V, S_V] = dfdv / m
    jac[S_V, S_X] = dfdx / m
