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

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable

import numba
import numpy as np

from leakdiag._validation import check_positive
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
]

#: 1 m^3/s in L/min (1000 L/m^3 * 60 s/min).
LPM_PER_M3S = 60_000.0

#: Reference pressure difference at which the simulators also report a leak's flow
#: (``meta["leak_lpm_at_reference_dp"]``): 1 MPa, inside the load-pressure range of both rigs
#: (VCA spring load ~0.8 MPa typical, EHA 0.1-2 MPa), so a coefficient reads as a flow.
LEAK_REFERENCE_DP_PA = 1e6

#: Shortest stretch after the onset, s, over which a mean leak is a usable calibration target:
#: a few reference steps (1-5 s holds, VCA) or input periods (pi/2 s, EHA). A calibration that
#: fails on a shorter stretch is reported as "too short to calibrate".
MIN_CALIBRATION_WINDOW_S = 10.0

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


class LeakCalibrationError(RuntimeError):
    """The leak coefficient could not be calibrated to the target within the tolerance."""


@dataclass(frozen=True)
class CalibrationResult:
    """Outcome of :func:`calibrate_leak_coefficient`.

    Attributes
    ----------
    coefficient : float
        Calibrated leakage coefficient (units of the simulator's leak law).
    achieved_lpm : float
        Mean |Q_leak| after the onset with that coefficient, L/min.
    target_lpm : float
        Requested mean leak, L/min.
    n_evaluations : int
        Number of simulator runs used.
    history : tuple of (float, float)
        ``(coefficient, achieved_lpm)`` of every run, in order.
    n_pilot_evaluations : int
        Runs of a cheaper pilot model before the first full run
        (:func:`calibrate_with_pilot`), not counted in ``n_evaluations``.
    """

    coefficient: float
    achieved_lpm: float
    target_lpm: float
    n_evaluations: int
    history: tuple[tuple[float, float], ...] = field(default=())
    n_pilot_evaluations: int = 0

    @property
    def relative_error(self) -> float:
        """``|achieved - target| / target``."""
        return abs(self.achieved_lpm - self.target_lpm) / self.target_lpm


def reaction_step(coefficient: float, achieved_lpm: float, target_lpm: float) -> float:
    r"""Next coefficient when the first guess ignored a reaction that is first order in the leak.

    Parameters
    ----------
    coefficient : float
        The first guess :math:`k_0`, computed as if the pressures did not react to the leak
        (:math:`q(k) = c\,k` with :math:`c = q^*/k_0`).
    achieved_lpm : float
        Mean leak :math:`q_0` of the run with :math:`k_0`, L/min, > 0.
    target_lpm : float
        Target :math:`q^*`, L/min.

    Returns
    -------
    float
        :math:`k_1 = k_0 / (2 - q^*/q_0)`: the coefficient at which
        :math:`q(k) = c\,k\,(1 - \alpha q)` reaches :math:`q^*`, with :math:`\alpha` fitted
        to the run (:math:`1 - \alpha q_0 = q_0/q^*`). When :math:`q^*/q_0` lies outside
        [2/3, 1.5] (a reaction too strong for a first-order model) the proportional correction
        :math:`k_0 q^*/q_0` instead.

    Notes
    -----
    The model holds when the pressure difference that drives the leak falls in proportion to
    the leak flow, e.g. when a flow source feeds the actuator (the EHA's pump: the leak flow
    is taken from the flow that moves the piston). Measured on EHA runs (docs/models.md),
    :math:`1 - q/(c\,k)` is proportional to :math:`q` within a few per cent of itself.

    Examples
    --------
    >>> round(reaction_step(1.0, 0.9, 1.0), 6)       # 10 % low: 1 / (2 - 1/0.9)
    1.125
    >>> round(reaction_step(1.0, 0.5, 1.0), 6)       # 50 % low: proportional, 2x
    2.0
    """
    ratio = target_lpm / achieved_lpm
    if not 2.0 / 3.0 <= ratio <= 1.5:
        return coefficient * ratio
    return coefficient / (2.0 - ratio)


def calibrate_leak_coefficient(
    simulate_fn: Callable[[float], float],
    target_lpm: float,
    initial_coefficient: float,
    rtol: float = 0.02,
    max_evaluations: int = 12,
    first_step: str = "proportional",
) -> CalibrationResult:
    """Find the leakage coefficient whose simulated mean |Q_leak| after onset hits a target.

    Parameters
    ----------
    simulate_fn : callable
        ``simulate_fn(coefficient) -> mean |Q_leak| after the onset in L/min``. Must be
        deterministic (same seed every call) and increase with the coefficient.
    target_lpm : float
        Target mean leak in L/min, > 0.
    initial_coefficient : float
        First guess of the coefficient, > 0 (e.g. the target flow divided by the law evaluated
        at a typical pressure difference).
    rtol : float, default 0.02
        Accept when ``|achieved - target| <= rtol * target`` (the issue's 2 %); the first run
        that meets it ends the search.
    max_evaluations : int, default 12
        Maximum number of simulator runs.
    first_step : {"proportional", "reaction"}, default "proportional"
        The correction after the first run: ``"proportional"`` assumes the mean leak
        proportional to the coefficient; ``"reaction"`` assumes that ``initial_coefficient``
        ignored the pressures' reaction to the leak and that this reaction is first order in
        the leak flow (:func:`reaction_step`).

    Returns
    -------
    CalibrationResult
        Coefficient, achieved flow and the run history.

    Raises
    ------
    ValueError
        If ``target_lpm``, ``initial_coefficient`` or ``rtol`` is not positive, or
        ``first_step`` is unknown.
    LeakCalibrationError
        If ``simulate_fn`` returns a non-positive or non-finite flow, or the tolerance is not
        met within ``max_evaluations`` runs.

    Notes
    -----
    The mean leak is close to proportional to the coefficient (exactly so if the pressure
    difference did not react to the leak, Eqs. 2-4 and 2-5), so the search is a secant
    iteration on :math:`\\log q(\\log k)`: the first step is the proportional correction
    :math:`k_1 = k_0\\,q^*/q(k_0)`, later steps use the measured log-log slope (clipped to
    [0.2, 5]). Typically 2-4 simulator runs are needed, so calibrating costs 2-4 times one
    simulation; pass a shorter run to ``simulate_fn`` to make it cheaper (the mean leak then
    comes from fewer reference steps and generalises less exactly).

    Examples
    --------
    A made-up simulator whose mean leak grows like :math:`k^{0.8}`:

    >>> res = calibrate_leak_coefficient(lambda k: 3.0 * k ** 0.8, 0.1, initial_coefficient=1.0)
    >>> abs(res.achieved_lpm - 0.1) <= 0.002
    True
    >>> res.n_evaluations <= 4
    True
    """
    target = check_positive(target_lpm, "target_lpm")
    k = check_positive(initial_coefficient, "initial_coefficient")
    rtol = check_positive(rtol, "rtol")
    if first_step not in ("proportional", "reaction"):
        raise ValueError(f"first_step={first_step!r} must be 'proportional' or 'reaction'")
    history: list[tuple[float, float]] = []

    def run(coef: float) -> float:
        q = float(simulate_fn(coef))
        if not math.isfinite(q) or q <= 0:
            raise LeakCalibrationError(
                f"simulate_fn({coef:.6g}) returned mean leak {q!r} L/min; it must be finite and "
                "> 0 (is the onset inside the run and the schedule not 'none'?)"
            )
        history.append((coef, q))
        return q

    q = run(k)
    slope = 1.0
    weights: dict = {}
    while True:
        if abs(q - target) <= rtol * target:
            break
        if len(history) >= max_evaluations:
            raise LeakCalibrationError(
                f"leak calibration did not reach target_lpm={target} within rtol={rtol} after "
                f"{len(history)} runs; history (coefficient, L/min): {history}"
            )
        if len(history) >= 2:
            (k0, q0), (k1, q1) = history[-2], history[-1]
            if k0 != k1 and q0 != q1:
                slope = (math.log(q1) - math.log(q0)) / (math.log(k1) - math.log(k0))
                slope = min(max(slope, 0.2), 5.0)
        bracket = _illinois(history, target, weights)
        if bracket is not None:
            k = bracket
        elif len(history) == 1 and first_step == "reaction":
            k = reaction_step(k, q, target)
        else:
            k = k * math.exp((math.log(target) - math.log(q)) / slope)
        q = run(k)
    return CalibrationResult(k, q, target, len(history), tuple(history))


def _illinois(history, target: float, weights: dict) -> float | None:
    r"""Next coefficient once runs below and above the target bracket it, else None.

    Regula falsi on :math:`\log q(\log k)` between the closest runs on either side, with the
    Illinois modification (the end kept twice in a row has its residual halved, ``weights``
    carries that state between calls), so a strongly convex :math:`q(k)` cannot pin one end.
    When the last two runs are the bracket and no halving is due, this is the secant step.
    """
    below = [(k, q) for k, q in history if q < target]
    above = [(k, q) for k, q in history if q > target]
    if not below or not above:
        return None
    (k_lo, q_lo), (k_hi, q_hi) = max(below), min(above)
    side = 1 if history[-1][1] > target else -1
    if weights.get("side") == side:
        weights[-side] = weights.get(-side, 1.0) * 0.5
    else:
        weights[-side] = 1.0
    weights[side] = 1.0
    weights["side"] = side
    x_lo, x_hi = math.log(k_lo), math.log(k_hi)
    f_lo = (math.log(q_lo) - math.log(target)) * weights.get(-1, 1.0)
    f_hi = (math.log(q_hi) - math.log(target)) * weights.get(1, 1.0)
    return math.exp(x_lo - f_lo * (x_hi - x_lo) / (f_hi - f_lo))


def check_calibrated(achieved_lpm: float, target_lpm: float, rtol: float) -> float:
    """Verify a delivered run's mean leak against its target (the calibration's promise).

    Parameters
    ----------
    achieved_lpm : float
        Mean |Q_leak| after the onset of the delivered run, L/min.
    target_lpm : float
        Requested mean leak, L/min.
    rtol : float
        Relative tolerance.

    Returns
    -------
    float
        ``achieved_lpm``, unchanged.

    Raises
    ------
    LeakCalibrationError
        If ``|achieved - target| > rtol * target``.

    Examples
    --------
    >>> check_calibrated(0.0465, 0.047, 0.02)
    0.0465
    """
    if not abs(achieved_lpm - target_lpm) <= rtol * target_lpm:
        raise LeakCalibrationError(
            f"the delivered run's mean leak after the onset is {achieved_lpm:.6g} L/min, "
            f"{abs(achieved_lpm / target_lpm - 1):.2%} from the target {target_lpm} L/min "
            f"(tolerance {rtol:.0%})")
    return achieved_lpm


def too_short_to_calibrate(leak_lpm: float, window_s: float, cause: Exception,
                           history=()) -> LeakCalibrationError:
    """The error for a run whose stretch after the onset is too short to calibrate a leak.

    Parameters
    ----------
    leak_lpm : float
        Target mean leak, L/min.
    window_s : float
        Length of the run after the onset, s.
    cause : Exception
        What the calibration ran into.
    history : sequence of (float, float), optional
        ``(coefficient, L/min)`` of the runs tried.

    Returns
    -------
    LeakCalibrationError
        With a message that says the run is too short and what to do.

    Examples
    --------
    >>> str(too_short_to_calibrate(0.1, 1.0, RuntimeError("x")))[:60]
    'the run is too short to calibrate a 0.1 L/min leak: 1 s afte'
    """
    tried = ", ".join(f"{k:.3g} -> {q:.3g} L/min" for k, q in history)
    return LeakCalibrationError(
        f"the run is too short to calibrate a {leak_lpm} L/min leak: {window_s:g} s after the "
        f"onset, and a mean leak over fewer than {MIN_CALIBRATION_WINDOW_S:g} s depends on the "
        "few reference steps in it. Make the run longer or the onset earlier, or give "
        "leak_coefficient= instead of leak_lpm. "
        f"(Calibration stopped: {cause}{'; tried ' + tried if tried else ''})")


def calibrate_with_pilot(
    simulate_fn: Callable[[float], float],
    pilot_fn: Callable[[float], float],
    target_lpm: float,
    initial_coefficient: float,
    rtol: float = 0.02,
    max_evaluations: int = 12,
) -> CalibrationResult:
    """Measure the reaction to the leak on one cheap pilot run, then search on the full model.

    Parameters
    ----------
    simulate_fn : callable
        The delivered experiment: ``simulate_fn(k) -> mean |Q_leak| after the onset``, L/min.
    pilot_fn : callable
        A cheaper approximation of it (e.g. the same run with a looser solver tolerance); it
        only has to be close, the tolerance is checked on ``simulate_fn``.
    target_lpm : float
        Target mean leak, L/min.
    initial_coefficient : float
        First guess :math:`k_0`, > 0, computed as if the pressures did not react to the leak.
    rtol : float, default 0.02
        Tolerance on the full run.
    max_evaluations : int, default 12
        Limit of the full search.

    Returns
    -------
    CalibrationResult
        The full run's coefficient and mean; ``n_evaluations`` counts full runs,
        ``n_pilot_evaluations`` the pilot run (1); ``history`` lists the full runs.

    Raises
    ------
    ValueError
        If ``rtol`` is not positive.
    LeakCalibrationError
        If the pilot returns a non-positive or non-finite flow, or as
        :func:`calibrate_leak_coefficient`.

    Notes
    -----
    One pilot run at :math:`k_0`, then the full search of :func:`calibrate_leak_coefficient`
    from :func:`reaction_step` of the pilot's mean. When the reaction is first order in the
    leak flow and the pilot's bias is well inside ``rtol``, the first full run lands.

    Examples
    --------
    >>> full = lambda k: k * (1.0 - 0.2 * k)        # reaction first order in the leak flow
    >>> pilot = lambda k: 1.004 * full(k)           # a 0.4 % biased cheap model
    >>> res = calibrate_with_pilot(full, pilot, 0.5, initial_coefficient=0.5)
    >>> res.n_evaluations, res.n_pilot_evaluations, abs(res.achieved_lpm / 0.5 - 1) <= 0.02
    (1, 1, True)
    """
    rtol = check_positive(rtol, "rtol")
    k0 = check_positive(initial_coefficient, "initial_coefficient")
    target = check_positive(target_lpm, "target_lpm")
    q0 = float(pilot_fn(k0))
    if not math.isfinite(q0) or q0 <= 0:
        raise LeakCalibrationError(
            f"pilot_fn({k0:.6g}) returned mean leak {q0!r} L/min; it must be finite and > 0")
    full = calibrate_leak_coefficient(simulate_fn, target, reaction_step(k0, q0, target),
                                      rtol=rtol, max_evaluations=max_evaluations)
    return dataclasses.replace(full, n_pilot_evaluations=1)
