"""The smoothed Coulomb friction shared by both rigs, ``F tanh(v / v_s)``.

The VCA's seal friction (``coulomb_friction_n`` over ``coulomb_velocity_m_per_s``, a choice
beyond Eq. 2-1) and the EHA's preload friction with its velocity threshold (Eqs. 3-13 to 3-15,
``F_pr tanh(v / V_th)``) are the same smooth sign. :func:`smooth_sign` evaluates
:math:`\\tanh z` as :math:`\\mathrm{sgn}(z)(1 - e)/(1 + e)` with :math:`e = \\exp(-2|z|)`:
one ``exp`` (about 4.5 ns against 15 ns for the C library's ``tanh`` on this machine, where
the friction was a third of a healthy VCA run's time; docs/models.md, "Speed"). Its absolute
error is at most 2.3e-16 (one rounding of ``e`` near 1), so the friction force is exact to
``F * 2.3e-16`` (4.6e-14 N for the VCA's 200 N), the size of one rounding of the force sum
it enters; the relative error, about :math:`10^{-16}/|z|`, grows as :math:`z \\to 0`,
where the friction is a vanishing part of that sum. It is exactly 0 at 0, odd, and
:math:`\\pm 1` beyond :math:`|z| \\approx 19`, as ``tanh`` is in double precision.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["smooth_sign"]


@numba.njit(cache=True, error_model="numpy")
def smooth_sign(z):
    """:math:`\\tanh z` from one exponential, for the friction laws (Numba-compiled).

    Parameters
    ----------
    z : float
        Velocity over the smoothing velocity, dimensionless.

    Returns
    -------
    float
        :math:`\\mathrm{sgn}(z)\\,(1 - e^{-2|z|})/(1 + e^{-2|z|})`, within 2.3e-16 of
        :math:`\\tanh z`.

    Examples
    --------
    >>> smooth_sign(0.0), smooth_sign(50.0), smooth_sign(-50.0)
    (0.0, 1.0, -1.0)
    >>> abs(smooth_sign(0.3) - float(np.tanh(0.3))) <= 2.3e-16
    True
    """
    e = np.exp(-2.0 * abs(z))
    t = (1.0 - e) / (1.0 + e)
    return t if z >= 0.0 else -t
