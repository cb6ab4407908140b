"""Sensor-consistency checks of the flow balance: the leak-free sum equation and single samples.

The VCA's two chamber continuity equations (Eq. 2-1) added give

.. math::

    Q_1 - Q_2 = \\frac{V_1 \\dot P_1 + V_2 \\dot P_2}{\\beta},

in which the internal leak and the piston's flow ``A dx/dt`` cancel (the leak leaves chamber
1 and enters chamber 2; the double-rod piston displaces as much from one chamber as it draws
into the other). Its window residual (``balance`` of
:func:`~leakdiag.detect._flow_balance_vca.vca_terms`: valve volume of the sum minus the
compressibility volumes, with the valve's null leakage) is therefore a check of the sensors and
the model that a leak does not move: a transducer's offset or gain, a command delay or a sign
error moves it, a leak does not (docs/detect.md 8.4, "Sensor and model consistency").

:class:`SumGate` holds its healthy spread (``s^2 = c0 + c1 F^2``, ``F`` the window's volume
through the valve), the largest ``|z|`` of the healthy recordings and the limit, judged only in
windows whose valve volume the healthy windows reached (a large leak makes the servo feed it
with valve volumes 2-4 times the healthy ones, where the valve model was never checked and the
sum's error grew to 3.5 times the healthy largest at 2 L/min); the EHA has
no such gate (its sum equation holds neither the pump's flow nor the position: they cancel as
well, so speed and position faults would not show in it).

:func:`spike_sizes` measures one-sample outliers (a sample away from both neighbours in the
same direction), :func:`longest_hold` the longest run of one exact value that is not a rail.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from leakdiag._holds import holds

__all__ = ["SumGate", "learn_sum_gate", "spike_sizes", "longest_hold", "SUM_GATE_FACTOR",
           "SPIKE_FACTOR", "SPIKE_CHANNELS", "STEP_FACTOR", "STEP_CHANNELS"]

#: Limit of the sum-equation check as a multiple of the largest ``|z|`` of the healthy
#: recordings' windows (leakdiag choice; docs/detect.md 8.4, "Sensor and model consistency"):
#: twice the largest ratio measured on held-out healthy and leaking runs of virtual machines
#: (1.78), rounded up to a half.
SUM_GATE_FACTOR = 4.0
#: Limit of a one-sample outlier as a multiple of the largest one in the healthy recordings
#: (leakdiag choice; docs/detect.md 8.4).
SPIKE_FACTOR = 4.0
#: Channels checked for one-sample outliers: the command (VCA) and the motor speed (EHA),
#: whose single samples carry a whole sample interval of valve or pump flow.
SPIKE_CHANNELS = ("u", "speed")
#: Limit of a one-sample step of the position as a multiple of the largest in the healthy
#: recordings (leakdiag choice, 2026-11-28; docs/detect.md 8.4, "Discontinuities"): the
#: healthy largest is the valve's saturated piston speed times the sample interval (1.68-1.77 mm
#: on the VCA, 0.15-0.18 mm on the EHA, 8 healthy 120-s runs each of units 3 and 17, both loads;
#: 1-1.5 L/min leaks stayed within it), while two runs spliced into one file jumped 3.3-10x
#: (VCA) and 200x (EHA) at the seam (flow-balance audit 2026-11-28, finding 2).
STEP_FACTOR = 2.0
#: Channels checked for one-sample steps: the position, whose step enters the balance as the
#: volume ``A dx`` of a piston motion that did not happen.
STEP_CHANNELS = ("x",)


@dataclass(frozen=True)
class SumGate:
    """Healthy spread of the leak-free sum equation's window residual (VCA) and its limit.

    Parameters
    ----------
    center_m3 : float
        Median healthy window residual (m^3).
    floor_m3_2 : float
        ``c0`` of ``s^2 = c0 + c1 F^2`` (m^6).
    flow_coefficient : float
        ``c1`` (dimensionless).
    healthy_max_z : float
        Largest ``|z|`` over the healthy recordings' windows.
    factor : float
        Limit as a multiple of ``healthy_max_z``.
    flow_max_m3 : float
        Largest volume through the valve in a healthy window (m^3): windows beyond it are
        not judged (:meth:`judged`).
    """

    center_m3: float
    floor_m3_2: float
    flow_coefficient: float
    healthy_max_z: float
    factor: float
    flow_max_m3: float = float("inf")

    def judged(self, flow) -> np.ndarray:
        """Windows the gate judges: valve volume within the healthy windows' (bool mask).

        Examples
        --------
        >>> SumGate(0.0, 1.0, 0.0, 2.0, 4.0, 5.0).judged([-5.0, 6.0]).tolist()
        [True, False]
        """
        return np.abs(np.asarray(flow, dtype=np.float64)) <= self.flow_max_m3

    @property
    def limit(self) -> float:
        """Largest ``|z|`` a judged window may reach."""
        return self.factor * self.healthy_max_z

    def z(self, balance, flow) -> np.ndarray:
        """Standardised sum-equation residual of each window.

        Parameters
        ----------
        balance : array_like
            Window residuals of the sum equation (m^3).
        flow : array_like
            Volume through the valve in each window (m^3).

        Returns
        -------
        numpy.ndarray
            ``(balance - center) / sqrt(c0 + c1 flow^2)``.

        Examples
        --------
        >>> SumGate(0.0, 4.0, 0.0, 2.0, 3.0).z([2.0, -6.0], [1.0, 1.0]).tolist()
        [1.0, -3.0]
        """
        b = np.asarray(balance, dtype=np.float64)
        f = np.asarray(flow, dtype=np.float64)
        return (b - self.center_m3) / np.sqrt(self.floor_m3_2 + self.flow_coefficient * f * f)


def learn_sum_gate(balances, flows, factor: float = SUM_GATE_FACTOR) -> SumGate:
    """Fit the healthy spread of the sum equation's window residual.

    Parameters
    ----------
    balances, flows : list of numpy.ndarray
        Per healthy recording, the window residuals of the sum equation and the volume through
        the valve (m^3), burn-in dropped.
    factor : float, default SUM_GATE_FACTOR
        Limit as a multiple of the healthy recordings' largest ``|z|``.

    Returns
    -------
    SumGate
        ``s^2 = c0 + c1 F^2`` by non-negative least squares of the squared centred residuals
        (columns scaled to unit RMS), ``c0`` at least the median squared residual's 1e-6 so
        that no window has zero spread.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> g = learn_sum_gate([rng.normal(0, 1e-8, 400)], [np.full(400, 1e-4)])
    >>> bool(2.5 < g.healthy_max_z < 4.0), g.factor, g.flow_max_m3
    (True, 4.0, 0.0001)
    """
    b = np.concatenate([np.asarray(v, dtype=np.float64) for v in balances])
    f = np.concatenate([np.asarray(v, dtype=np.float64) for v in flows])
    center = float(np.median(b))
    e2 = (b - center) ** 2
    x = np.column_stack([np.ones_like(f), f * f])
    col = np.sqrt(np.mean(x * x, axis=0))
    col[col == 0] = 1.0
    coef, _ = nnls(x / col, e2)
    coef = coef / col
    coef[0] = max(coef[0], 1e-6 * float(np.median(e2)), np.finfo(float).tiny)
    gate = SumGate(center, float(coef[0]), float(coef[1]), 0.0, float(factor))
    zmax = float(np.abs(gate.z(b, f)).max()) if len(b) else 0.0
    fmax = float(np.abs(f).max()) if len(f) else 0.0
    return SumGate(center, float(coef[0]), float(coef[1]), zmax, float(factor), fmax)


def spike_sizes(v) -> np.ndarray:
    """Size of each interior sample's one-sample excursion: the smaller of its distances to
    its two neighbours when it lies above both or below both, else 0.

    A step (a command jump that stays) scores 0 however large; a single wrong sample scores
    its own size.

    Parameters
    ----------
    v : array_like
        One channel, shape ``(n,)``.

    Returns
    -------
    numpy.ndarray
        Shape ``(max(n - 2, 0),)``; element ``i`` belongs to sample ``i + 1``.

    Examples
    --------
    >>> spike_sizes([0.0, 0.0, 10.0, 0.0, 5.0, 5.0, 5.0]).tolist()
    [0.0, 10.0, 5.0, 0.0, 0.0]
    """
    v = np.asarray(v, dtype=np.float64)
    if len(v) < 3:
        return np.zeros(0)
    d1 = v[1:-1] - v[:-2]
    d2 = v[1:-1] - v[2:]
    return np.where(np.sign(d1) * np.sign(d2) > 0, np.minimum(np.abs(d1), np.abs(d2)), 0.0)


def longest_hold(v, rails=None) -> tuple[int, int]:
    """Longest run of one exact value in ``v`` that is not a rail.

    A run at ``v``'s own smallest or largest value is a rail (a saturated command) and not
    counted, but only when that value lies within ``rails = (lo, hi)``, the range the healthy
    recordings reached: a dropout to a value they never reached is a hold like any other.

    Parameters
    ----------
    v : array_like
        One channel.
    rails : tuple of float, optional
        The healthy recordings' smallest and largest value; None: every extreme is a rail.

    Returns
    -------
    tuple of int
        ``(samples, first index)``; ``(0, 0)`` when every run is a rail.

    Examples
    --------
    >>> longest_hold(np.array([0.0, 2.0, 2.0, 2.0, 1.0, 1.0, 3.0, 3.0, 3.0, 3.0]))
    (3, 1)
    >>> longest_hold(np.array([0.0, 2.0, 2.0, 2.0, 1.0, 1.0, 3.0, 3.0, 3.0, 3.0]), (0.0, 2.5))
    (4, 6)
    """
    v = np.asarray(v, dtype=np.float64)
    if len(v) == 0:
        return 0, 0
    starts, lengths = holds(v)
    at = v[starts]
    rail = (at == v.min()) | (at == v.max())
    if rails is not None:
        rail &= (at >= rails[0]) & (at <= rails[1])
    inner = np.where(rail, 0, lengths)
    i = int(np.argmax(inner))
    return (int(inner[i]), int(starts[i])) if inner[i] else (0, 0)
