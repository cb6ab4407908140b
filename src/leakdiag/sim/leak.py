"""Leak schedules and leak-coefficient calibration, shared by the VCA and EHA simulators.

A leak is described in two parts:

* a *schedule*, the dimensionless multiplier :math:`s(t) \\in [0, 1]` of the leakage coefficient
  (none, a step at the onset time, or a linear ramp that models progressing seal wear), and
* a *coefficient* :math:`k_l` (turbulent Eq. 2-4 or laminar Eq. 2-5), found by
  :func:`calibrate_leak_coefficient` so that the simulated mean :math:`|Q_{leak}|` after the onset
  equals a target given in L/min (the thesis's unit, Sec. 4.5: "the mean of the leak after 200
  seconds").

The leakage flow inside a simulator is then :math:`Q_l(t) = s(t)\\,k_l\\,g(P_1 - P_2)` with
:math:`g` the turbulent or laminar law. :meth:`LeakSchedule.to_array` encodes the schedule as a
small float array that :func:`leak_multiplier` (a Numba function) evaluates inside a compiled
integrator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from leakdiag._validation import check_positive
from leakdiag.sim.calibration import (  # noqa: F401  (re-exported: the leak API in one place)
    MIN_CALIBRATION_WINDOW_S,
    MIN_SLOPE,
    SLOPE_PILOT_FRACTION,
    CalibrationResult,
    LeakCalibrationError,
    calibrate_leak_coefficient,
    calibrate_with_pilot,
    check_calibrated,
    log_slope,
    reaction_step,
    too_short_to_calibrate,
)
from leakdiag.sim.orifice import orifice_flow

__all__ = [
    "LPM_PER_M3S",
    "LEAK_KINDS",
    "leak_flow",
    "LeakSchedule",
    "leak_multiplier",
    "lpm_to_m3s",
    "m3s_to_lpm",
    "CalibrationResult",
    "LeakCalibrationError",
    "calibrate_leak_coefficient",
    "check_calibrated",
    "calibrate_with_pilot",
    "reaction_step",
    "too_short_to_calibrate",
    "LEAK_REFERENCE_DP_PA",
    "MIN_CALIBRATION_WINDOW_S",
    "SLOPE_PILOT_FRACTION",
    "MIN_SLOPE",
    "log_slope",
]

#: 1 m^3/s in L/min (1000 L/m^3 * 60 s/min).
LPM_PER_M3S = 60_000.0

#: Reference pressure difference at which the simulators also report a leak's flow
#: (``meta["leak_lpm_at_reference_dp"]``): 1 MPa, inside the load-pressure range of both rigs
#: (VCA spring load ~0.8 MPa typical, EHA 0.1-2 MPa), so a coefficient reads as a flow.
LEAK_REFERENCE_DP_PA = 1e6

#: Schedule kinds and their integer code in :meth:`LeakSchedule.to_array`.
LEAK_KINDS: dict[str, int] = {"none": 0, "step": 1, "ramp": 2}


def lpm_to_m3s(lpm: float) -> float:
    """Convert a flow from L/min to m^3/s.

    Parameters
    ----------
    lpm : float
        Flow in L/min.

    Returns
    -------
    float
        Flow in m^3/s.

    Examples
    --------
    >>> lpm_to_m3s(0.6)
    1e-05
    """
    return float(lpm) / LPM_PER_M3S


def m3s_to_lpm(m3s: float) -> float:
    """Convert a flow from m^3/s to L/min.

    Parameters
    ----------
    m3s : float
        Flow in m^3/s.

    Returns
    -------
    float
        Flow in L/min.

    Examples
    --------
    >>> m3s_to_lpm(1e-5)
    0.6
    """
    return float(m3s) * LPM_PER_M3S


@numba.njit(cache=True, error_model="numpy")
def leak_flow(coefficient, dp, transition_pa, laminar):
    """Internal leakage flow from chamber 1 to chamber 2, the leak law of both rigs (m^3/s).

    Parameters
    ----------
    coefficient : float or numpy.ndarray
        :math:`s(t)\\,k_l`, the coefficient in force (Eq. 2-4: m^3/(s Pa^0.5), Eq. 2-5:
        m^3/(s Pa)).
    dp : float or numpy.ndarray
        :math:`P_1 - P_2`, Pa.
    transition_pa : float
        Laminar core of the turbulent law (:func:`~leakdiag.sim.orifice.signed_sqrt`), Pa.
    laminar : bool
        Eq. 2-5 instead of Eq. 2-4.

    Returns
    -------
    float or numpy.ndarray
        :math:`k_l\\,\\mathrm{sgn}(\\Delta p)\\sqrt{|\\Delta p|}` (Eq. 2-4, regularised below
        ``transition_pa``) or :math:`k_l\\,\\Delta p` (Eq. 2-5).

    Examples
    --------
    >>> float(leak_flow(1e-12, 1e6, 1e4, True))
    1e-06
    >>> round(float(leak_flow(1e-8, 1e8, 1e4, False)) * 1e4, 6)     # 1e-8 * sqrt(1e8)
    1.0
    """
    if laminar:
        return coefficient * dp
    return orifice_flow(coefficient, dp, transition_pa)


@dataclass(frozen=True)
class LeakSchedule:
    """When and how the leakage coefficient is switched on.

    Parameters
    ----------
    kind : {"none", "step", "ramp"}, default "none"
        ``"none"``: no leak. ``"step"``: the full coefficient from ``onset_s`` on (the thesis's
        needle valve opened at about 200 s, Sec. 4.5). ``"ramp"``: the multiplier grows linearly
        from 0 at ``onset_s`` to 1 at ``onset_s + ramp_duration_s`` and then stays at 1
        (progressing seal wear).
    onset_s : float, default 200.0
        Onset time in seconds (Sec. 4.5: no leak for the first 200 s of a 400 s run).
    ramp_duration_s : float, default 100.0
        Duration of the ramp in seconds (``kind="ramp"`` only); must be > 0.

    Raises
    ------
    ValueError
        If ``kind`` is unknown, ``onset_s`` is negative or not finite, or ``ramp_duration_s``
        is not positive.

    Examples
    --------
    >>> s = LeakSchedule("ramp", onset_s=10.0, ramp_duration_s=4.0)
    >>> [s.multiplier(t) for t in (9.0, 10.0, 12.0, 14.0, 20.0)]
    [0.0, 0.0, 0.5, 1.0, 1.0]
    >>> LeakSchedule("step", onset_s=1.0).to_array().tolist()
    [1.0, 1.0, 0.0]
    """

    kind: str = "none"
    onset_s: float = 200.0
    ramp_duration_s: float = 100.0

    def __post_init__(self) -> None:
        if self.kind not in LEAK_KINDS:
            raise ValueError(f"kind={self.kind!r} must be one of {sorted(LEAK_KINDS)}")
        onset = float(self.onset_s)
        if not math.isfinite(onset) or onset < 0:
            raise ValueError(f"onset_s={self.onset_s!r} must be a finite number >= 0")
        object.__setattr__(self, "onset_s", onset)
        object.__setattr__(
            self, "ramp_duration_s", check_positive(self.ramp_duration_s, "ramp_duration_s")
        )

    @property
    def active(self) -> bool:
        """True unless ``kind == "none"``."""
        return self.kind != "none"

    def to_array(self) -> np.ndarray:
        """Encode as ``[kind_code, onset_s, ramp_duration_s]`` (float64) for :func:`leak_multiplier`.

        For ``kind="step"`` the ramp duration is stored as 0.

        Returns
        -------
        numpy.ndarray
            Shape ``(3,)``.
        """
        ramp = self.ramp_duration_s if self.kind == "ramp" else 0.0
        return np.array([float(LEAK_KINDS[self.kind]), self.onset_s, ramp], dtype=np.float64)

    def multiplier(self, t: float) -> float:
        """Leak-coefficient multiplier at time ``t`` (s); see :func:`leak_multiplier`.

        Parameters
        ----------
        t : float
            Time in seconds.

        Returns
        -------
        float
            Multiplier in [0, 1].
        """
        return float(leak_multiplier(float(t), self.to_array()))

    def multipliers(self, time: np.ndarray) -> np.ndarray:
        """Multiplier at each time of ``time`` (s).

        Parameters
        ----------
        time : numpy.ndarray
            Times in seconds.

        Returns
        -------
        numpy.ndarray
            Multipliers in [0, 1], same shape as ``time``.
        """
        t = np.asarray(time, dtype=np.float64)
        return _multipliers(np.ascontiguousarray(t.ravel()), self.to_array()).reshape(t.shape)

    def coefficients(self, coefficient: float, time: np.ndarray) -> np.ndarray:
        """The coefficient in force, :math:`k_l\\,s(t)`, at each time of ``time`` (s).

        Parameters
        ----------
        coefficient : float
            Full leakage coefficient :math:`k_l`.
        time : numpy.ndarray
            Times in seconds.

        Returns
        -------
        numpy.ndarray
            ``coefficient * multipliers(time)``, same shape as ``time``.

        Examples
        --------
        >>> LeakSchedule("ramp", onset_s=1.0, ramp_duration_s=2.0).coefficients(
        ...     4.0, np.array([0.0, 2.0, 5.0])).tolist()
        [0.0, 2.0, 4.0]
        """
        return float(coefficient) * self.multipliers(time)


@numba.njit(cache=True, error_model="numpy")
def leak_multiplier(t, schedule):
    """Leak-coefficient multiplier at time ``t`` from an encoded schedule (Numba-compiled).

    Parameters
    ----------
    t : float
        Time in seconds.
    schedule : numpy.ndarray
        ``[kind_code, onset_s, ramp_duration_s]`` from :meth:`LeakSchedule.to_array`.

    Returns
    -------
    float
        0 before the onset (and always for ``kind="none"``), 1 after a step, and
        ``clip((t - onset) / ramp_duration, 0, 1)`` for a ramp.

    Examples
    --------
    >>> leak_multiplier(5.0, LeakSchedule("step", onset_s=2.0).to_array())
    1.0
    """
    kind = schedule[0]
    if kind == 0.0 or t < schedule[1]:
        return 0.0
    if kind == 1.0:
        return 1.0
    r = (t - schedule[1]) / schedule[2]
    return r if r < 1.0 else 1.0


@numba.njit(cache=True, error_model="numpy")
def _multipliers(t, schedule):
    """:func:`leak_multiplier` at each time of the 1-D array ``t``."""
    out = np.empty(t.shape[0])
    for i in range(t.shape[0]):
        out[i] = leak_multiplier(t[i], schedule)
    return out
