"""The regularised orifice law shared by both rigs (Eqs. 2-2, 2-4, 3-9 to 3-12).

A turbulent orifice passes :math:`Q = k\\,\\mathrm{sgn}(\\Delta p)\\sqrt{|\\Delta p|}`. Its slope is
infinite at :math:`\\Delta p = 0`, so both simulators use the smooth form
:math:`\\Delta p / (\\Delta p^2 + p_{tr}^2)^{1/4}` (:func:`signed_sqrt`): exact to 0.25 % for
:math:`|\\Delta p| > 10 p_{tr}`, linear with slope :math:`1/\\sqrt{p_{tr}}` near 0
(``docs/models.md``). The VCA's valve orifices (Eq. 2-2) multiply :func:`signed_sqrt` by their
flow gain; the EHA's line orifices and check valves use :func:`orifice_flow`; the leak law of
both rigs is :func:`leakdiag.sim.leak.leak_flow`.

The two spellings ``k * signed_sqrt(dp)`` and ``orifice_flow(k, dp) = k dp / (...)^{1/4}``
are the same law; they are kept apart because they round differently in the last bit and each
rig's recordings are pinned bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["signed_sqrt", "orifice_flow"]


@numba.njit(cache=True, error_model="numpy")
def signed_sqrt(dp, transition_pa):
    """Regularised :math:`\\mathrm{sgn}(\\Delta p)\\sqrt{|\\Delta p|}`, laminar below ~``transition_pa``.

    Parameters
    ----------
    dp : float or numpy.ndarray
        Pressure difference, Pa.
    transition_pa : float
        Laminar-turbulent transition pressure :math:`p_{tr}`, Pa.

    Returns
    -------
    float or numpy.ndarray
        :math:`\\Delta p / (\\Delta p^2 + p_{tr}^2)^{1/4}`, Pa^0.5.

    Examples
    --------
    Turbulent far above the transition, linear (slope :math:`1/\\sqrt{p_{tr}}`) below it:

    >>> round(signed_sqrt(1e8, 1e4), 3), round(signed_sqrt(-1.0, 1e4), 6)
    (10000.0, -0.01)
    """
    return dp / np.sqrt(np.sqrt(dp * dp + transition_pa * transition_pa))


@numba.njit(cache=True, error_model="numpy")
def orifice_flow(coefficient, dp, transition_pa):
    """Turbulent orifice flow with a laminar core, ``k dp / (dp^2 + p_t^2)^(1/4)``.

    Parameters
    ----------
    coefficient : float
        ``C_d sqrt(2/rho) A``, m^3/(s sqrt(Pa)).
    dp : float
        Pressure drop across the orifice, Pa (flow is positive for ``dp > 0``).
    transition_pa : float
        Laminar-turbulent transition pressure :math:`p_t`, Pa.

    Returns
    -------
    float
        Flow in m^3/s.

    Notes
    -----
    For :math:`|dp| \\gg p_t` this is the orifice law of Eqs. 2-2, 3-9 to 3-12 and 2-4,
    :math:`k\\,\\mathrm{sgn}(dp)\\sqrt{|dp|}`; near zero it is linear with slope
    :math:`k/\\sqrt{p_t}`, which removes the infinite conductance of the square root at
    :math:`dp = 0` (a smooth regularisation, documented in ``docs/models.md``).

    Examples
    --------
    >>> round(orifice_flow(1e-6, 1e8, 1e4) / (1e-6 * 1e4), 6)   # sqrt(1e8) = 1e4
    1.0
    >>> orifice_flow(1e-6, 0.0, 1e4)
    0.0
    """
    return coefficient * dp / np.sqrt(np.sqrt(dp * dp + transition_pa * transition_pa))


@numba.njit(cache=True, error_model="numpy")
def _dorifice(coefficient, dp, transition_pa):
    """d orifice_flow / d dp."""
    r2 = dp * dp + transition_pa * transition_pa
    return coefficient * (0.5 * dp * dp + transition_pa * transition_pa) / (r2 * np.sqrt(np.sqrt(r2)))
