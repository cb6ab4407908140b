"""Calibration of a leak coefficient to a target mean leak (shared by both simulators).

The mean leak after the onset, :math:`q(k)`, is found by running the experiment
(``simulate_fn(k)``): :func:`calibrate_leak_coefficient` searches :math:`k` until a run lands
within the tolerance (2 % by default); :func:`calibrate_with_pilot` first measures the
pressures' reaction to the leak on one cheaper run; :func:`check_calibrated` verifies the
delivered run. Re-exported by :mod:`leakdiag.sim.leak`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable

from leakdiag._validation import check_positive

__all__ = [
    "CalibrationResult",
    "LeakCalibrationError",
    "calibrate_leak_coefficient",
    "calibrate_with_pilot",
    "check_calibrated",
    "reaction_step",
    "too_short_to_calibrate",
    "MIN_CALIBRATION_WINDOW_S",
    "SLOPE_PILOT_FRACTION",
    "MIN_SLOPE",
    "log_slope",
]

#: Shortest stretch after the onset, s, over which a mean leak is a usable calibration target:
#: a few reference steps (1-5 s holds, VCA) or input periods (pi/2 s, EHA). A calibration that
#: fails on a shorter stretch is reported as "too short to calibrate".
MIN_CALIBRATION_WINDOW_S = 10.0

#: Share of the window after the onset that a slope pilot reruns (``first_slope`` of
#: :func:`calibrate_leak_coefficient`; at least ``MIN_CALIBRATION_WINDOW_S``). Chosen on the VCA
#: without load (docs/models.md; 42 cases: seeds 0-5 x 0.005-0.5 L/min, 400-s runs, onset
#: 200 s): with 5 / 10 / 20 % the calibration needed a third post-onset run in 4 / 2 / 0 cases
#: (11 without a pilot) and 1.58 / 1.57 / 1.59 healthy runs of work on average (1.65).
SLOPE_PILOT_FRACTION = 0.1

#: Smallest log-log slope of the mean leak in the coefficient that a search step assumes (the
#: largest slope is 5): a step goes at most twice as far in log k as the proportional one.
#: Without load on the VCA the mean leak is nearly flat in k just below a knee where it jumps
#: (0.47-0.48 L/min for k = 6.3e-8 ... 7.4e-8, 0.53 at 8.3e-8, 120-s runs), and a slope
#: measured on the flat part sent the next run far past the knee; with 0.5 instead of 0.2 the
#: 0.5 L/min cases of the 42-case grid (docs/models.md) took 4.5 instead of 6.0 healthy runs of
#: work at 120 s, 2.0 instead of 2.1 at 400 s, the other sizes unchanged.
MIN_SLOPE = 0.5


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
    first_slope: Callable[[float, float], float | None] | None = None,
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
    first_slope : callable, optional
        ``first_slope(k0, k1) -> log-log slope`` of the mean leak between the first run's
        coefficient ``k0`` and the proportional step ``k1``, measured on a cheap pilot (e.g.
        the same run over a short stretch after the onset; :func:`log_slope`). When given, the
        correction after the first run is :math:`k_0 (q^*/q_0)^{1/s}` with that slope (clipped
        to [0.5, 5]; None: the proportional step) instead of ``first_step``; each call counts
        as one pilot run.

    Returns
    -------
    CalibrationResult
        Coefficient, achieved flow and the run history (``n_pilot_evaluations``: the calls of
        ``first_slope``).

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
    [:data:`MIN_SLOPE`, 5]). Typically 2-4 simulator runs are needed, so calibrating costs
    2-4 times one simulation; pass a shorter run to ``simulate_fn`` to make it cheaper (the
    mean leak then comes from fewer reference steps and generalises less exactly). With
    ``first_slope`` the first step uses the pilot's slope instead of 1, so that a mean leak
    whose slope is far from 1 is reached by the second run rather than the third or fourth.

    Examples
    --------
    A made-up simulator whose mean leak grows like :math:`k^{0.8}`:

    >>> res = calibrate_leak_coefficient(lambda k: 3.0 * k ** 0.8, 0.1, initial_coefficient=1.0)
    >>> abs(res.achieved_lpm - 0.1) <= 0.002
    True
    >>> res.n_evaluations <= 4
    True

    The same with a pilot that measures the slope (here exactly): the second run lands.

    >>> q = lambda k: 3.0 * k ** 0.8
    >>> slope = lambda k0, k1: math.log(q(k1) / q(k0)) / math.log(k1 / k0)
    >>> res = calibrate_leak_coefficient(q, 0.1, 1.0, first_slope=slope)
    >>> res.n_evaluations, res.n_pilot_evaluations
    (2, 1)
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
    n_pilot = 0
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
            measured = log_slope(*history[-2], *history[-1])
            if measured is not None:
                slope = min(max(measured, MIN_SLOPE), 5.0)
        bracket = _illinois(history, target, weights)
        if bracket is not None:
            k = bracket
        elif len(history) == 1 and first_slope is not None:
            n_pilot += 1
            slope = _pilot_slope(first_slope, k, k * target / q)
            k = k * math.exp((math.log(target) - math.log(q)) / slope)
        elif len(history) == 1 and first_step == "reaction":
            k = reaction_step(k, q, target)
        else:
            k = k * math.exp((math.log(target) - math.log(q)) / slope)
        q = run(k)
    return CalibrationResult(k, q, target, len(history), tuple(history), n_pilot)


def log_slope(k0: float, q0: float, k1: float, q1: float) -> float | None:
    """Log-log slope :math:`\\ln(q_1/q_0) / \\ln(k_1/k_0)` of the mean leak between two runs.

    Parameters
    ----------
    k0, q0, k1, q1 : float
        Two coefficients and their mean leaks (any one unit each).

    Returns
    -------
    float or None
        None when it is undefined: a value that is not positive and finite, equal
        coefficients, or equal means (the search then keeps the slope it had).

    Examples
    --------
    >>> round(log_slope(1.0, 2.0, 2.0, 2.0 * 2.0 ** 0.8), 12)
    0.8
    >>> log_slope(1.0, 2.0, 1.0, 3.0) is None
    True
    """
    vals = (k0, q0, k1, q1)
    if not all(v > 0 and math.isfinite(v) for v in vals) or k0 == k1 or q0 == q1:
        return None
    return math.log(q1 / q0) / math.log(k1 / k0)


def _pilot_slope(first_slope: Callable[[float, float], float | None], k0: float,
                 k1: float) -> float:
    """The pilot's slope between ``k0`` and ``k1`` clipped to [MIN_SLOPE, 5]; 1 (the
    proportional step) when it has none."""
    s = first_slope(k0, k1)
    if s is None:
        return 1.0
    s = float(s)
    if not math.isfinite(s):
        raise LeakCalibrationError(
            f"first_slope({k0:.6g}, {k1:.6g}) returned {s!r}; it must be a finite slope")
    return min(max(s, MIN_SLOPE), 5.0)


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
