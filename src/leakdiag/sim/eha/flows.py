"""Flow laws of the EHA model: line orifices (Eqs. 3-9 to 3-12) and accumulator check valves.

Each law is a Numba scalar function of the pressure drop built on the shared regularised
orifice law (:mod:`leakdiag.sim.orifice`); the ``_d*`` functions are their derivatives, used
by the analytic Jacobian (:mod:`leakdiag.sim.eha.jacobian`).
"""

from __future__ import annotations

import numba

from leakdiag.sim.orifice import _dorifice, orifice_flow

__all__ = ["orifice_flow", "line_orifice_flow", "check_valve_flow"]


@numba.njit(cache=True, error_model="numpy")
def _smoothstep(r):
    """C1 switch: 0 for ``r <= 0``, ``3r^2 - 2r^3`` on ``(0, 1)``, 1 for ``r >= 1``."""
    if r <= 0.0:
        return 0.0
    if r >= 1.0:
        return 1.0
    return r * r * (3.0 - 2.0 * r)


@numba.njit(cache=True, error_model="numpy")
def line_orifice_flow(k_free, k_restricted, dp, transition_pa):
    """Flow through a line orifice with a free and a restricted direction (Eqs. 3-9 to 3-12).

    Parameters
    ----------
    k_free, k_restricted : float
        ``C_d sqrt(2/rho) A_line`` and ``C_d sqrt(2/rho) k A_line``, m^3/(s sqrt(Pa)).
    dp : float
        Pressure drop in the free direction, Pa.
    transition_pa : float
        Transition pressure :math:`p_t`, Pa.

    Returns
    -------
    float
        Flow in m^3/s, positive in the free direction.

    Notes
    -----
    The coefficient moves from restricted to free by a C1 smoothstep over
    :math:`-p_t < dp < p_t` instead of jumping at ``dp = 0``, so that the right-hand side is
    smooth enough for second-order convergence; outside that band the laws are exactly
    Eqs. 3-9 to 3-12 (with the laminar core of :func:`orifice_flow`).

    Examples
    --------
    >>> round(line_orifice_flow(1.0, 0.1, 1e6, 1e3) / 1e3, 4)
    1.0
    >>> round(line_orifice_flow(1.0, 0.1, -1e6, 1e3) / 1e3, 4)
    -0.1
    """
    blend = _smoothstep(0.5 * (dp + transition_pa) / transition_pa)
    k = k_restricted + (k_free - k_restricted) * blend
    return orifice_flow(k, dp, transition_pa)


@numba.njit(cache=True, error_model="numpy")
def check_valve_flow(coefficient, dp, opening_pa, transition_pa):
    """Flow through an accumulator check valve, closed for ``dp <= 0``.

    Parameters
    ----------
    coefficient : float
        ``C_d sqrt(2/rho) A_cv`` of the fully open valve, m^3/(s sqrt(Pa)).
    dp : float
        Accumulator pressure minus line pressure, Pa.
    opening_pa : float
        Pressure difference over which the poppet goes from closed to fully open, Pa.
    transition_pa : float
        Laminar transition pressure of :func:`orifice_flow`, Pa.

    Returns
    -------
    float
        Flow into the line, m^3/s; exactly 0 for ``dp <= 0``, never negative.

    Notes
    -----
    The open area grows with a C1 smoothstep from 0 at ``dp = 0`` to the full area at
    ``dp = opening_pa``; the flow is monotone in ``dp`` and has no backward leakage.

    Examples
    --------
    >>> check_valve_flow(1e-6, -1e6, 2e4, 1e3)
    0.0
    >>> round(check_valve_flow(1e-6, 1e6, 2e4, 1e3) * 1e3, 4)
    1.0
    """
    if dp <= 0.0:
        return 0.0
    return _smoothstep(dp / opening_pa) * orifice_flow(coefficient, dp, transition_pa)


@numba.njit(cache=True, error_model="numpy")
def _dsmoothstep(r):
    if r <= 0.0 or r >= 1.0:
        return 0.0
    return 6.0 * r * (1.0 - r)


@numba.njit(cache=True, error_model="numpy")
def _dline_orifice(k_free, k_restricted, dp, transition_pa):
    """d line_orifice_flow / d dp."""
    r = 0.5 * (dp + transition_pa) / transition_pa
    k = k_restricted + (k_free - k_restricted) * _smoothstep(r)
    dk = (k_free - k_restricted) * _dsmoothstep(r) * 0.5 / transition_pa
    return _dorifice(k, dp, transition_pa) + dk * orifice_flow(1.0, dp, transition_pa)


@numba.njit(cache=True, error_model="numpy")
def _dcheck_valve(coefficient, dp, opening_pa, transition_pa):
    """d check_valve_flow / d dp."""
    if dp <= 0.0:
        return 0.0
    r = dp / opening_pa
    return (_dsmoothstep(r) / opening_pa * orifice_flow(coefficient, dp, transition_pa)
            + _smoothstep(r) * _dorifice(coefficient, dp, transition_pa))
