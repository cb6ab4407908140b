"""Physics-based leak detector: the chamber flow balance (Eq. 2-1; EHA Eqs. 3-6, 3-16 to 3-19).

:class:`FlowBalanceDetector` removes the piston's mechanics from the chamber continuity
equations, integrates what remains over windows (noise enters at the window end points),
regresses the window residual volumes on the integral of the leak law's pressure term (Eq. 2-4
by default) and tests the leak coefficient with a one-sided window-limited GLR. The valve (VCA)
or pump (EHA) of each machine is identified on its healthy recordings in :meth:`fit`. See
``docs/detect.md`` ("Flow balance") for the equations, the leak-law assumption and the limits.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import nnls
from scipy.stats import norm
from threadpoolctl import ThreadpoolController

from leakdiag._format import seconds
from leakdiag._validation import check_number, check_positive
from leakdiag.detect import _flow_balance_eha as eha
from leakdiag.detect import _flow_balance_vca as vca
from leakdiag.detect._flow_balance_checks import (
    SPIKE_CHANNELS,
    SPIKE_FACTOR,
    STEP_CHANNELS,
    STEP_FACTOR,
    learn_sum_gate,
    longest_hold,
    spike_sizes,
)
from leakdiag.detect._flow_balance_offset import leak_law_at, profile_offset
from leakdiag.detect._flow_balance_size import (FLEET_BAND_MISSES, SIZE_ERROR_MODEL, band_words,
                                               size_band)
from leakdiag.detect._flow_balance_search import (
    GLRThreshold,
    TargetBeyondNullError,
    calibrate_glr,
    change_point,
    glr_alarm_count,
    glr_profile,
    step_information,
)
from leakdiag.detect._rig_units import check_flow_scale, check_rig_units
from leakdiag.detect.base import (Detector, TooShortToJudge, Verdict, _as_recordings,
                                  check_healthy, check_params_unchanged, check_recording_type,
                                  fingerprint, healthy_info, params_snapshot)
from leakdiag.detect.threshold import (
    InsufficientHealthyDataError,
    ReferenceMaxima,
    ThresholdBasis,
    binned_maxima,
    conformal_threshold,
    count_segments,
    min_maxima,
)
from leakdiag.features.series import FeatureSeries
from leakdiag.io.checks import same_rate
from leakdiag.io.recording import RecordingError, load_name, machine_unit
from leakdiag.sim.leak import LPM_PER_M3S

__all__ = ["FlowBalanceDetector", "FlowBalanceVerdict", "LEAK_LAWS", "SYSTEMS",
           "glr_segment_maxima", "RefusedAlarm", "AlarmNotConfirmed", "AlarmAtStart"]


class RefusedAlarm(RecordingError):
    """The test alarmed, but the leak estimated after its onset does not confirm it: no
    verdict on a leak (the base of :class:`AlarmNotConfirmed` and :class:`AlarmAtStart`;
    raised itself when the coefficient since the onset is not positive and neither applies:
    "the flow balance does not describe this recording well").

    Attributes
    ----------
    alarm_time_s, onset_s : float
        The alarm and the onset the test placed (s).
    """

    def __init__(self, message: str, alarm_time_s: float, onset_s: float):
        super().__init__(message)
        self.alarm_time_s = float(alarm_time_s)
        self.onset_s = float(onset_s)


class AlarmNotConfirmed(RefusedAlarm):
    """The test alarmed, but the leak estimated from its onset to the recording's end is not
    significantly above zero: no verdict on a leak.

    Besides a chance crossing or a fault, an alarm late in a recording (a segment of
    ``leakdiag monitor --segment``) has too little data after it to confirm a real leak; the
    next segment then finds the leak from its own start, and says when this one alarmed.
    """


class AlarmAtStart(RefusedAlarm):
    """The test alarmed with its onset in the first windows judged, but the leak coefficient
    estimated from there to the end is not positive: no verdict on a leak.

    A leak present from the recording's start is fitted into the per-recording null offset and
    gain (docs/detect.md 8.5), so the coefficient estimated after it can come out negative,
    with a small standard error, though the test's score is far above its level. An audit
    (2026-11-29) found ``leakdiag monitor --segment 35`` reading the last 15 s of a 0.5 L/min
    leak from 25 s "not positive (-6.95e-10 +- 5.8e-11) ... a sensor fault?" at a score of 328;
    the monitor now says that the leak it found earlier was present from the segment's start.
    """


#: Leak laws the regression can assume: Eq. 2-4 (turbulent) or Eq. 2-5 (laminar).
LEAK_LAWS = ("turbulent", "laminar")
#: Rigs with a flow balance.
SYSTEMS = ("vca", "eha")
#: Span lengths (windows) of the healthy dispersion check (leakdiag choice).
_DISPERSION_SPANS = (1, 3, 10, 30)


#: How far beyond the healthy recordings' range of a channel (1st-99th percentile, in multiples
#: of that range) a judged recording may reach before it is refused (leakdiag choice). Measured
#: on drawn units 3 and 17, both loads, leaks up to 2 L/min (VCA) and 1.63 L/min (EHA), with
#: and without temperature rise, supply ripple, drive variation and a 1.3x spring change: the
#: pressures, position and speed went at most 0.26 (VCA) and 0.48 (EHA) of their range beyond
#: it; a unit error moves a channel by 10^3-10^6 of it.
OPERATION_MARGIN = 1.0
#: Wider margins for channels that the leak itself moves: the VCA's servo opens the valve to
#: feed the leak, so ``u`` left its healthy range by up to 18.5 ranges at 2 L/min (no load).
OPERATION_MARGINS = {"u": 100.0}
#: How many times longer than in the healthy recordings a channel may hold one exact value in a
#: judged recording before it is refused as frozen (leakdiag choice). A hold at the recording's
#: own smallest or largest value of the channel (a rail: a saturated command) is not counted.
#: Measured on drawn units 17, 23 and 101, both loads, fits on 4 healthy runs of 60 s, judged
#: runs with leaks up to 2 L/min (VCA) and 1.6 L/min (EHA), a 10 K temperature rise and (VCA)
#: 0.3 MPa supply ripple: a judged run's longest hold was at most 1.48 times the healthy
#: recordings' (VCA ``u``; pressures 1.4, EHA ``speed`` 1.1). Freezing a healthy run's channel
#: gave a false LEAK from a 0.1-s hold of ``u`` (VCA) or ``speed`` (EHA) and a 0.3-s hold of
#: a VCA pressure: 3-10 times the healthy holds (18-22, 9-23 and 10-14 samples at 1 kHz). The
#: limit is an extreme of the healthy data and grows with it (``u`` of unit 17: 54 ms from 4
#: runs of 60 s, 108 ms from 20 runs of 120 s), and a shorter freeze of ``u`` across a command
#: step can still alarm (docs/detect.md 8.4, "Stuck sensors").
HOLD_FACTOR = 3.0
#: Channels of the VCA without the hold check: the position is counted by an encoder, which
#: holds its count whenever the piston rests or creeps (VCA healthy runs: holds of up to 3.4
#: s), so its holds measure the motion, not the sensor. Only a position constant over the
#: whole judged part is refused. The EHA's position is held to a limit (``HOLD_FACTORS``).
HOLD_EXEMPT = ("x",)
#: Channels without the hold check, per rig.
HOLD_EXEMPT_BY_SYSTEM = {"vca": HOLD_EXEMPT, "eha": ()}
#: Hold factors other than ``HOLD_FACTOR`` (leakdiag choice): the EHA's position, whose
#: encoder holds its count while the piston rests (healthy holds 20-22 ms at 1 kHz, longer
#: under a large leak without load; docs/detect.md 8.4, "Stuck sensors").
HOLD_FACTORS = {("eha", "x"): 6.0}


#: How close to the modelled VCA's tank or supply pressure (a fraction of the difference) a
#: chamber pressure counts as at that bound, where the simulator clips it (cavitation,
#: relief) and a real chamber cavitates or relieves: there the chamber continuity (Eq. 2-1)
#: does not hold (leakdiag choice: wider than a unit's +-2 % supply, docs/models.md; the
#: balance's pressures under the spring stay 4-12 MPa from the 17.2 MPa supply).
PRESSURE_BOUND_MARGIN = 0.03
#: Share of the samples after the burn-in with a chamber at a bound above which a failed
#: identification names it as the likely cause (leakdiag choice).
PRESSURE_BOUND_SHARE = 0.01


def _at_bounds_note(recs, nominal, skip_s: float) -> str | None:
    """Why a VCA flow balance may not be identifiable on ``recs``: a chamber pressure at the
    tank or supply level in a share of the samples after the burn-in (None when under
    :data:`PRESSURE_BOUND_SHARE`).

    A session-23 review found healthy runs of unit 17 under the spring driven around 0.2 m
    (where the spring's force holds P2 near tank, below 0.1 MPa in most of the run) refused
    with a flow-gain factor of 0.14 "likely in another unit than stated"; the units were right,
    the chamber cavitated.
    """
    lo, hi = float(nominal.tank_pressure_pa), float(nominal.supply_pressure_pa)
    band = PRESSURE_BOUND_MARGIN * (hi - lo)
    n = bad = 0
    for r in recs:
        p = np.vstack([_after(r, c, skip_s) for c in ("p1", "p2")])
        at = ((p <= lo + band) | (p >= hi - band)).any(axis=0)
        n, bad = n + at.size, bad + int(at.sum())
    if not n or bad < PRESSURE_BOUND_SHARE * n:
        return None
    return (f"But here a chamber pressure is within {band / 1e6:.2g} MPa of the tank "
            f"({lo / 1e6:.3g} MPa) or supply ({hi / 1e6:.3g} MPa) pressure in {100 * bad / n:.0f} "
            "% of the samples after the burn-in: a cavitating or relieving chamber, where the "
            "chamber continuity (Eq. 2-1) the balance rests on does not hold, is the likelier "
            "cause; fit on operation that keeps both chambers between tank and supply (a "
            "load that does not hold the piston against them)")


def _after(rec, c: str, skip_s: float) -> np.ndarray:
    """Channel ``c`` of ``rec`` after its first ``skip_s`` seconds (the burn-in)."""
    return np.asarray(rec[c], dtype=np.float64)[int(round(skip_s * rec.sample_rate)):]


def _longest_hold(v: np.ndarray, rails=None) -> tuple[int, int]:
    """Longest run of one exact value in ``v`` that is not a rail (``_flow_balance_checks.
    longest_hold``: a run at ``v``'s smallest or largest value, when that value lies within
    ``rails``, the healthy recordings' range).

    Examples
    --------
    >>> _longest_hold(np.array([0.0, 2.0, 2.0, 2.0, 1.0, 1.0, 3.0, 3.0, 3.0, 3.0]))
    (3, 1)
    """
    return longest_hold(v, rails)


def _operation(recs, channels, skip_s: float = 0.0) -> dict:
    """Machine unit and load common to ``recs`` (None when unknown or mixed), and each
    channel's 1st-99th percentile range (``ranges``) and smallest and largest value
    (``extremes``) over all of them after ``skip_s`` (the burn-in)."""
    out: dict = {}
    machines = {machine_unit(r.meta) for r in recs}
    out["n_machines"] = len(machines - {None})  # distinct known units (a fleet fit: > 1)
    out["machine"] = machines.pop() if len(machines) == 1 else None
    loads = {load_name(r.meta.get("load")) for r in recs}
    out["load"] = loads.pop() if len(loads) == 1 else None
    ranges, extremes = {}, {}
    for c in channels:
        xs = [_after(r, c, skip_s) for r in recs if c in r.channels]
        xs = [x for x in xs if len(x)]
        if xs:
            q = np.array([np.percentile(x, [1.0, 99.0]) for x in xs])
            ranges[c] = (float(q[:, 0].min()), float(q[:, 1].max()))
            extremes[c] = (float(min(x.min() for x in xs)), float(max(x.max() for x in xs)))
    out["ranges"] = ranges
    out["extremes"] = extremes
    out["longest_s"] = max((float(r.duration) for r in recs), default=None)
    return out


@dataclass(frozen=True)
class FlowBalanceVerdict(Verdict):
    """:class:`~leakdiag.detect.base.Verdict` plus the physical leak estimate.

    Attributes
    ----------
    leak_coefficient : float or None
        Estimated increase of the leak-law coefficient over the healthy baseline since the
        onset (m^3/(s Pa^0.5) turbulent, m^3/(s Pa) laminar), None without an alarm.
    leak_coefficient_se : float or None
        Its standard error.
    leak_lpm_at_reference : float or None
        Leak flow at ``reference_dp_pa`` (L/min), from the coefficient.
    reference_dp_pa : float
        Reference pressure difference (Pa).
    leak_law : str
        Leak law assumed.
    pressure_offset_pa : float or None
        The effective differential pressure offset found on the leak's own windows (Pa),
        subtracted from the measured :math:`P_1` in the leak law for the size: the EHA, and the
        VCA without load or under an unknown load; None for the VCA with the spring and without
        an alarm. It stands for the chamber transducers' zero error :math:`o_1 - o_2` and
        whatever else shifts the leak law's pressure difference at the working pressure (gain
        errors, the healthy fit's model error), so it is not a measurement of the zero error:
        an API audit (2026-11-30) found +17 kPa where the unit's o1 - o2 was -2.6 kPa, with
        the size right (docs/detect.md 8.5).
    leak_lpm_interval_holds : str or None
        What ``leak_lpm_interval`` holds, in words (None without an alarm); with an alarm but
        no size (``leak_lpm`` None: the VCA without load and a leak there from the start), why
        no size is given.
    leak_lpm_interval_statistical : tuple of float or None
        The statistical part of ``leak_lpm_interval`` (L/min, level ``interval_level``: the
        coefficient's standard error and, where profiled, the transducers' zero error), before
        the model error measured on virtual machines widened it; None without a size.
    recent_leak_lpm : float or None
        For a leak recognised as growing (``GROWTH_MEASURED``: the VCA with the spring; the
        coefficient's second half since the onset at least ``GROWTH_RATIO`` times its first),
        the mean leak flow over the last ``RECENT_WINDOWS`` windows (L/min), which then exceeds
        the mean since the onset (``leak_lpm``); None otherwise.
    detectable_lpm : float or None
        Without an alarm: the smallest step leak (mean L/min) that, begun at
        ``detectable_from_s`` and lasting to the end, the test reaches its threshold on with
        probability about :data:`DETECTABLE_POWER`: the error model's size
        (:func:`step_information`) times :data:`DETECTABLE_FACTOR`, measured on virtual
        machines; None with an alarm, or when the windows do not determine a step.
    detectable_from_s : float or None
        Start of that step: the last ``max_span_s`` judged (or the first window the test can
        judge, for a shorter recording).
    detectable_why : str or None
        Without an alarm: what ``detectable_lpm`` rests on, or why it is not given.
    transient_alarms : str or None
        With an alarm: the earlier alarm episodes judged transient, in words (alarm time,
        onset and the test: no leak between that onset and this one, a step up at this one;
        :meth:`FlowBalanceDetector._lasting_alarm`); None when the first alarm is the verdict's.
    """

    leak_coefficient: float | None = None
    leak_coefficient_se: float | None = None
    leak_lpm_at_reference: float | None = None
    reference_dp_pa: float = 1e6
    leak_law: str = "turbulent"
    pressure_offset_pa: float | None = None
    leak_lpm_interval_holds: str | None = None
    leak_lpm_interval_statistical: tuple[float, float] | None = None
    recent_leak_lpm: float | None = None
    detectable_lpm: float | None = None
    detectable_from_s: float | None = None
    detectable_why: str | None = None
    transient_alarms: str | None = None

    def __str__(self) -> str:
        """The verdict in words, with what the size interval holds (a NO LEAK: the smallest
        leak it would have seen)."""
        text = super().__str__()
        if self.leak and self.transient_alarms:
            text += f"\n  earlier alarm: {self.transient_alarms}"
        if self.leak and self.leak_lpm_interval_holds:
            what = "interval" if self.leak_lpm is not None else "size"
            text += f"\n  {what}: {self.leak_lpm_interval_holds}"
        elif not self.leak and self.detectable_why:
            text += f"\n  sensitivity: {self.detectable_why}"
        return text

    def as_dict(self) -> dict:
        """Fields as a flat dict (interval split in two columns).

        Returns
        -------
        dict
        """
        d = super().as_dict()
        stat = self.leak_lpm_interval_statistical or (None, None)
        d.update({"leak_coefficient": self.leak_coefficient,
                  "leak_coefficient_se": self.leak_coefficient_se,
                  "leak_lpm_at_reference": self.leak_lpm_at_reference,
                  "reference_dp_pa": self.reference_dp_pa, "leak_law": self.leak_law,
                  "pressure_offset_pa": self.pressure_offset_pa,
                  "leak_lpm_interval_holds": self.leak_lpm_interval_holds,
                  "leak_lpm_statistical_low": stat[0], "leak_lpm_statistical_high": stat[1],
                  "recent_leak_lpm": self.recent_leak_lpm,
                  "detectable_lpm": self.detectable_lpm,
                  "detectable_from_s": self.detectable_from_s,
                  "detectable_why": self.detectable_why,
                  "transient_alarms": self.transient_alarms})
        return d


@functools.lru_cache(maxsize=1)
def _blas_controller() -> ThreadpoolController:
    """The BLAS thread pools loaded in this process, found once (at the first call, after
    this module has imported NumPy's and SciPy's linear algebra): ``threadpool_limits``
    searches the loaded libraries on every call, 1.4 ms each on this host, a tenth of a VCA
    ``predict`` on a 60-s recording; ``ThreadpoolController.limit`` reuses what it found
    (9 us)."""
    return ThreadpoolController()


def _one_blas_thread(method):
    """Run ``method`` with one BLAS thread: the flow balance's linear algebra is small
    (thousands of rows by tens of columns, 3x3 matrix exponentials), where a threaded BLAS
    only adds synchronisation; on a loaded 2-core host it made a 40-recording identification
    7.5x slower (90 s against 12 s) and a 3x3 ``expm`` 370x slower."""

    @functools.wraps(method)
    def run(*args, **kwargs):
        with _blas_controller().limit(limits=1):
            return method(*args, **kwargs)

    return run


def glr_segment_maxima(g, per_segment: int) -> np.ndarray:
    """Largest GLR value in each complete segment of ``per_segment`` consecutive windows.

    Segments are counted in windows, not seconds: window boundaries may move a little (quiet
    boundaries, ``docs/detect.md`` 8.4), the number of windows of a run does not.

    Parameters
    ----------
    g : array_like
        GLR statistic per window after the burn-in, shape ``(m,)``.
    per_segment : int
        Windows per segment (>= 1); ``m // per_segment`` complete segments are used, the
        remainder is left out.

    Returns
    -------
    numpy.ndarray
        One maximum per complete segment.

    Raises
    ------
    ValueError
        If ``per_segment < 1``.

    Examples
    --------
    >>> glr_segment_maxima([1.0, 3.0, 2.0, 0.5, 9.0], 2).tolist()
    [3.0, 2.0]
    """
    g = np.asarray(g, dtype=np.float64)
    if int(per_segment) != per_segment or per_segment < 1:
        raise ValueError(f"per_segment={per_segment!r} must be a whole number >= 1")
    m = len(g) // int(per_segment)
    return g[:m * int(per_segment)].reshape(m, int(per_segment)).max(axis=1) if m else np.zeros(0)


#: A healthy recording whose cross-fit GLR maximum (judged by the model identified on the other
#: half of the healthy runs) exceeds this many times the fitted threshold is refused by ``fit``
#: (leakdiag choice, measured 2026-11-27: the healthy runs of 7 fits of 4-8 runs, VCA and EHA,
#: with and without load, at 0.48-0.85 times their threshold; a leaking or another rig's run
#: among healthy ones at 21-29 times, in the audit's fits).
ODD_ONE_OUT_FACTOR = 5.0

#: Smallest ratio of the piston's volume to the valve model's, since an alarm's onset, that a
#: verdict accepts (VCA; leakdiag choice, docs/detect.md 8.4, "Command sign"): 1 on healthy
#: recordings, between 0 and 1 with a leak (the valve feeds it: measured 0.91-0.98 at 0.1,
#: 0.35-0.49 at 0.5, -0.04 to 0.05 at 2 and -0.003 to 0.02 at 4 L/min on unit 17, both loads),
#: -0.74 to -0.77 with the command's sign reversed from 50 s of 120-s runs; a quarter below the
#: physical bound of 0. The EHA's piston against the pump model's volume likewise (since
#: 2026-11-30, an API audit: a healthy run with the position's sign reversed read LEAK 0.8
#: L/min): unit 17, 60-s runs, 1.000 healthy, 0.97-0.98 at 0.5, 0.45-0.78 at 2 and 0.28-0.63
#: at 2.7 L/min (75 % of the pump's mean flow, the simulator's largest); -0.98 to -0.28 with
#: the position's sign reversed, both loads.
MIN_PISTON_VALVE_RATIO = -0.25
#: Windows after the alarm that its own ratio needs (leakdiag choice: the GLR's history minimum).
PISTON_VALVE_MIN_WINDOWS = 5


#: An alarm this close to the judged span's end (s) has few windows after it to size a leak
#: that began there: a refusal says so (leakdiag choice: a CLI audit, 2026-11-28, finding 8,
#: found a leak from 58 s refused in the segment 30-60 s with its interval reaching zero).
LATE_ALARM_S = 10.0

#: A refused alarm whose score is within this factor of the level it crossed is named a
#: possible false alarm first (leakdiag choice: a CLI audit, 2026-11-28, finding 7, found a
#: healthy unit's chance alarm at 25 per hour blamed on its sensors only; a leak-sized score,
#: 299 against 3.75, is no chance crossing).
CHANCE_SCORE_FACTOR = 2.0


def _chance_words(score: float, level: float) -> str:
    """The first cause a refused alarm names: a chance crossing when the score is within
    :data:`CHANCE_SCORE_FACTOR` of the level, else none."""
    if not score <= CHANCE_SCORE_FACTOR * level:
        return ""
    return (f"a false alarm: the score is within {CHANCE_SCORE_FACTOR:g}x the level, as healthy "
            "runs cross it at the rate it was fitted for; ")


def _piston_valve_ratio(t: dict, j: int) -> float | None:
    """Least-squares ratio of the piston's and compressibility volumes to the valve model's
    (VCA) or the pump model's (EHA) volume over windows ``j`` on: ``1 - sum(r G) / sum(G^2)``
    with ``G`` the model's supplied volume of the difference equation and ``r`` the window
    residual (``G - r`` is what the piston and the compressibility took). None without such
    a volume or any flow."""
    vol = t.get("valve_volume", t.get("pump_volume"))
    if vol is None:
        return None
    g, r = vol[j:], t["residual"][j:]
    den = float(g @ g)
    return None if not den > 0.0 else 1.0 - float(r @ g) / den


#: Rig and load under which the leak coefficient and the flow at the reference pressure
#: difference were measured to hold (audit 2026-11-27, delayed step leaks, 20-run fits of units
#: 17, 23, 101, 102): ``leak_lpm_at_reference`` 0.98-1.02x the truth with the VCA's spring,
#: 0.967-1.015x on the EHA (both loads). Without load the VCA gave 0.13-1.05x (median 0.50-0.64
#: by size; the coefficient a median of 21-447 of its own standard errors off): the
#: errors-in-variables bias of the leak law taken on a small, noisy P1 - P2. With the
#: transducers' differential zero error profiled (2026-11-29), 0.41-1.24x (median 1.07) on the
#: size band's 68 machines (``perf/flow_balance_coefficient_no_load.py``), and no band measured
#: for it. An unknown load is one where it was measured to hold only on a rig where every load
#: measured holds it (the EHA).
COEFFICIENT_MEASURED = {"vca": ("spring",), "eha": ("none", "spring")}
#: Factor on the error model's size (``(h + z) / sqrt(I)``, :meth:`_detectable`) that a NO
#: LEAK states as the smallest leak it would have seen (``detectable_lpm``), per rig and load.
#: Measured 2026-11-28 (``perf/flow_balance_detectable.py``: 8 virtual machines, units 3, 5,
#: 17, 23, 31, 42, 57, 64, 5 seeds each, 120-s runs, each unit fitted on 4 own healthy runs at
#: 1 false alarm per hour; per healthy run read NO LEAK, step leaks of 1, 2, 3, 4 times the
#: model's size simulated on the same seed from ``detectable_from_s``; docs/detect.md 8.5).
#: With the spring the model's size alarmed in 38 of 38 VCA and 40 of 40 EHA runs: factor 1.
#: Without load the leak term the test sees is a fraction of the true one on some units (the
#: VCA's coefficient measured 0.13-1.05x the truth, COEFFICIENT_MEASURED; on the EHA the
#: transducers' differential offset on a small P1 - P2): 21 of 38 (VCA) and 26 of 40 (EHA)
#: alarmed at 1x, 36 and 35 at 2x, all at 3x. The factor is the smallest of 1-4 at which the
#: units 3, 5, 17, 23 alarmed in at least 90 % of runs for both rigs (3: 20 of 20 each; 2: 15 of
#: 20 on the EHA); on the held-out units 31, 42, 57, 64 it gave 18 of 18 (VCA) and 20 of 20.
#: An unknown load (a CSV without metadata) takes the larger factor.
DETECTABLE_FACTOR = {("vca", "spring"): 1.0, ("vca", "none"): 3.0,
                     ("eha", "spring"): 1.0, ("eha", "none"): 3.0}
#: ``(alarmed, judged)`` at the stated size (the factor above), the same runs.
DETECTABLE_RUNS = {("vca", "spring"): (38, 38), ("vca", "none"): (38, 38),
                   ("eha", "spring"): (40, 40), ("eha", "none"): (40, 40)}
#: ``(alarmed, judged)`` at the error model's own size (factor 1), the same runs.
DETECTABLE_MODEL_RUNS = {("vca", "spring"): (38, 38), ("vca", "none"): (21, 38),
                         ("eha", "spring"): (40, 40), ("eha", "none"): (26, 40)}
#: Probability of an alarm at which ``detectable_lpm`` is stated (leakdiag choice).
DETECTABLE_POWER = 0.9
#: Onset windows (counted from the first judged, after the burn-in) within which an onset is
#: reported as censored, "at or before" (leakdiag choice, measured 2026-11-27, docs/detect.md
#: 8.5): leaks present from the start were placed in windows 0-5 (48 of 48 VCA runs, both
#: loads; without load the per-recording nuisance fitted on leaking windows moves the step
#: later), leaks from 10 and 20 s in windows 7-21 (but 2 of 96 at window 0, an onset error).
#: The GLR's best span starting at the first window added no from-start run and censored 2 of
#: 48 no-load leaks from 20 s: not used. Raised from 6 to 10 on 2026-11-28: a flow-balance
#: audit's detectors fitted by ``leakdiag fit`` (5-s burn-in) placed 6 of 24 VCA leaks present
#: from the first sample in windows 6-9 ("onset 10.8-14.2 s", not flagged). An onset counted
#: as censored is an upper bound, true for a leak that began there as well.
CENSOR_WINDOWS = 10
#: How far below the bootstrap null's resolution (one alarm episode in its simulated hours) a
#: long run's level may rest on the null's fitted exponential tail (:meth:`run_level`;
#: leakdiag choice, 2026-11-28: one decade, so that a detector fitted for 1 per hour on 120-s
#: runs, whose null simulates 120 h, judges runs up to about 40 h; beyond, INCONCLUSIVE).
RUN_LEVEL_MAX_EXTRAPOLATION = 10.0
#: Windows after the onset window the EHA's size needs (its transducers' differential offset is
#: profiled on them; leakdiag choice, 2026-11-28): a flow-balance audit cut EHA runs 2.5-5 s
#: after a 1 L/min leak began and got 0.48 L/min [0.44, 0.49] from 1-2 windows and 0.98 [0.90,
#: 0.998] from 4, against 1.0; the size band was measured with 60 s after the onset.
OFFSET_MIN_WINDOWS = 10
#: Windows after a censored onset's window (a leak perhaps present from the start) that its
#: VCA size needs (leakdiag choice, measured 2026-11-29, session 23; first set to 15 on a CLI
#: audit's few cases). A study of 264 spring runs (machines 3, 17, 42 with 26 seeds, 5, 23,
#: 31, 57, 64 with 6; 0.01-0.05 L/min present from the first sample; 80-s runs cut at 9-45 s
#: from 0, 15 or 35 s: 10,536 censored sizes; detectors fitted on 8 own 120-s runs) found the
#: interval holding the true mean leak since the onset in 81.5 % of the cases at 15 windows
#: (95 % CI 78.1-84.6), 88.2 % at 16-18, 94.6 % at 19-22, 97.0 % at 23-27 (96.0-97.9) and
#: 98.7-99.9 % beyond; of all sizes at or above 15 windows 94.7 % with 23 gross errors (size
#: under 0.5x or over 2x the truth), at or above 25 98.8 % with none. 25 is where the per-bin
#: coverage reaches the band's stated probability (>= 0.97). The cases share seeds (about 78
#: references in effect), so the intervals are narrower than the evidence (perf/censored_size.py,
#: rows in docs/flow_balance_study/censored_size/).
CENSORED_SIZE_MIN_WINDOWS = 25
#: Windows after a located onset's window that a VCA size needs (leakdiag choice, 2026-11-29,
#: a flow-balance audit): sizes from fewer missed the truth, confidently. VCA unit 31, 0.05
#: and 0.2 L/min from 60 s, 4 seeds, 90-s runs cut 1.5-10 s after the onset: the interval held
#: the true mean leak since the onset in 15 of 23 sized no-load verdicts (one 2.61 L/min
#: [1.58, 20.8] for 0.124, a late onset 21.3 [12.9, 170] for 0.2) and 41 of 48 with the spring
#: (1.12-1.23x), cut 30 s after it 16 of 16. By windows after the onset: 1.5-6 s 34 of 47
#: held (no load 7 of 15), 10 s 14 of 15, 30 s 16 of 16. 10, as the EHA's minimum: before the
#: onset the healthy windows hold the null offset and gain (a censored onset has none, hence
#: its 25). Between 10 and 30 windows coverage was measured on 15 cases only.
VCA_SIZE_MIN_WINDOWS = 10


#: Rig and load under which the size is weighted by the error model at the valve's leak-free
#: end-point flows (``_size_sigma``): the VCA with the spring, where it took 0.2 L/min ramps
#: from 0.59-0.71x to 0.89-1.18x the mean since the onset and moved step leaks by at most
#: 0.4 %; without load it moved delayed step leaks of 0.2 L/min from a median of 0.82-1.03x
#: to 0.62x (audit runs of 2026-11-27, docs/detect.md 8.5).
LEAK_FREE_WEIGHTS = {"vca": ("spring",), "eha": ()}
#: Rig and load under which a growing leak is recognised (``_growth``): the VCA with the
#: spring, where the ratio of the coefficient on the second to the first half of the windows
#: since the onset was 0.980-1.032 on 96 step leaks (onsets 0-20 s) and 1.99-3.35 on 48 ramps
#: (0.02-0.2 L/min; audit 2026-11-27 runs, docs/detect.md 8.5). Without load the step leaks
#: reached 2.29 and the ramps went down to 1.70: no ratio separates them there.
GROWTH_MEASURED = {"vca": ("spring",), "eha": ()}
#: Smallest half-to-half ratio read as a growing leak (leakdiag choice: about the geometric
#: mean of 1.03 and 1.99, the measured extremes above).
GROWTH_RATIO = 1.4
#: Smallest z of the half-to-half difference read as growing (leakdiag choice).
GROWTH_Z = 3.0
#: Windows of the "recent" leak flow reported for a growing leak (leakdiag choice: 10 s).
RECENT_WINDOWS = 10
#: Fewest windows between an alarm's onset window and a later alarm episode's onset for the
#: first alarm to be judged transient (:meth:`FlowBalanceDetector._lasting_alarm`; leakdiag
#: choice: 10 s, as ``CENSOR_WINDOWS``; nearer onsets are one change, placed twice).
TRANSIENT_MIN_WINDOWS = 10
#: Smallest ratio of the leak coefficient after a later alarm's onset to that between the
#: first alarm's onset and it for the first alarm to be passed over (leakdiag choice: above
#: the 2.29 that the halves since a true step leak's onset reached without load, GROWTH_RATIO).
TRANSIENT_RATIO = 3.0


def _coefficient_withheld(system: str, load: str | None) -> str:
    """Why the verdict gives no leak coefficient (empty: it gives one): the rig's loads where
    it was measured to hold are :data:`COEFFICIENT_MEASURED`; an unknown load is taken as one
    where it was not, unless it held under every load of the rig measured (the EHA).

    Examples
    --------
    >>> _coefficient_withheld("vca", "spring"), _coefficient_withheld("eha", None)
    ('', '')
    >>> _coefficient_withheld("vca", "none").startswith("no leak coefficient")
    True
    """
    measured = COEFFICIENT_MEASURED[system]
    if load in measured or (load is None and set(SIZE_ERROR_MODEL[system]) <= set(measured)):
        return ""
    if system == "vca" and load in ("none", None):
        return ("no leak coefficient nor flow at the reference pressure difference: on the VCA "
                f"{_load_words(load)}{' (sized as without load)' if load is None else ''} the "
                "coefficient was measured 0.41-1.24x "
                "the truth on 68 virtual machines with no band for it, and P1 - P2 there has a "
                "median of about 8 kPa, so the flow at the reference difference would "
                "extrapolate the assumed leak law far beyond the pressures measured "
                "(docs/detect.md 8.5); only the mean leak and its interval are given")
    return ("no leak coefficient nor flow at the reference pressure difference: on the "
            f"{system.upper()} {_load_words(load)} they were not measured (docs/detect.md "
            "8.5), so only the mean leak and its interval are given")


def _load_words(load: str | None) -> str:
    return ("without load" if load == "none" else
            "under an unknown load" if load is None else f"under load {load!r}")


def _size_withheld(system: str, load: str | None, censored: bool) -> str:
    """Why the verdict gives no leak size (empty: it gives one): the VCA without load (or
    under an unknown load) with a censored onset, where the size band was never measured and
    leaks from the start were sized 1.25-1.5x (up to 2.8x) with the band missing 15 of 72.

    Examples
    --------
    >>> _size_withheld("vca", "none", True).startswith("no size")
    True
    >>> _size_withheld("vca", "spring", True), _size_withheld("vca", "none", False)
    ('', '')
    """
    if not censored or system != "vca" or load == "spring":
        return ""
    return (f"no size: the onset lies within the first {CENSOR_WINDOWS} windows judged, where "
            "a leak present from the start cannot be told from one that began there, and on the "
            f"VCA {_load_words(load)} a leak present from the start is sized up to 2.8x its mean "
            "(the per-recording null offset and gain are then fitted on leaking windows), "
            "outside the model-error band, which was measured on leaks starting mid-run "
            "(docs/detect.md 8.5); a recording that starts well before the leak is sized")


def _leak_law_value(dp: float, law: str, ptr: float) -> float:
    if law == "laminar":
        return dp
    return dp / math.sqrt(math.sqrt(dp * dp + ptr * ptr))


class FlowBalanceDetector(Detector):
    """Leak detector from the chamber flow balance of one machine (VCA or EHA).

    Parameters
    ----------
    system : {"vca", "eha"}, default "vca"
        Rig: valve-controlled (Eqs. 2-1, 2-2; channels ``p1 p2 x u``) or electrohydrostatic
        (Eqs. 3-6, 3-16 to 3-19; channels ``p1 p2 x speed pa pb``).
    false_alarms_per_hour : float, default 1.0
        Target false alarms (alarm episodes) per hour of healthy operation; below one per
        segment (``segment_s``), and below the GLR null's rate at its lowest level, which
        :meth:`fit` says when refused.
    window_s : float, default 1.0
        Window over which the balance is integrated (s).
    max_span_s : float, default 30.0
        Longest span the GLR combines (s): longer finds smaller leaks, later.
    leak_law : {"turbulent", "laminar"}, default "turbulent"
        Leak law of the regression: Eq. 2-4 (``k sgn(dp) sqrt|dp|``) or Eq. 2-5 (``k dp``).
    params : VCAParams or EHAParams, optional
        Design values of the unit (default Table 2-1 / Table 3-1); :meth:`fit` identifies the
        uncertain ones from healthy data, never from a recording's metadata.
    fit_bandwidth : bool, default False
        VCA: also identify the valve natural frequency (weakly identifiable, see docs).
    fit_bulk_modulus : bool, default False
        Also identify the bulk modulus (weakly identifiable, see docs).
    burn_in_s : float, default 2.0
        Seconds left out at the start of each recording (valve/filter start-up).
    reference_dp_pa : float, default 1e6
        Pressure difference at which the leak flow is also reported.
    interval_level : float, default 0.95
        Level of the *statistical* part of the leak-size interval (the coefficient's standard
        error; EHA: and the transducers' zero error). The reported interval is its union with
        the model-error band measured on virtual machines (``_flow_balance_size``), whose own
        probability (>= 0.97 for a machine like them) is what the interval holds whatever this
        level: a level above it does not make the interval hold more, one below it does not
        make it narrower than the band (docs/detect.md 8.5, "Size interval").
    alarm : None
        Not used, and refused when given (:meth:`fit` raises): the flow balance takes its
        false-alarm target, burn-in, segment and confidence from its own parameters above and
        always estimates the onset from the GLR; ``leakdiag.bench.registry.make_detector``
        copies an :class:`~leakdiag.detect.base.Alarm`'s settings into them. Kept in the
        signature for parameter-compatible construction (``alarm=None``).
    quiet_boundaries : bool, default True
        VCA: move each window boundary, within a quarter window of its nominal place, to where
        the modelled spool (from ``u``) is at rest, so that command-step transients never
        straddle a boundary (docs/detect.md, section 8.4). Windows then last 0.5-1.5
        ``window_s``. The EHA always uses fixed windows.
    fit_valve_timing : bool, default False
        VCA: identify the valve's timing error against Table 2-1 (``model_.valve_lead_s``, a
        bandwidth error acts as a lead or lag of ~0.2 ms) as a linear term; ignored with
        ``fit_bandwidth=True`` and by the EHA. Identifiable on fixed windows (0.19 ms found for
        0.21 ms), hardly on quiet ones, where it matters less (docs/detect.md, section 8.3).
    segment_s : float or None, default None
        Duration (s) of the monitored segments whose GLR maxima set the conformal level, as
        :class:`~leakdiag.detect.base.Alarm`'s ``segment_s``: a window belongs to the segment
        its end falls in, counted from the burn-in; the false-alarm target per segment is
        ``false_alarms_per_hour * segment_s / 3600``. None: the shortest healthy run's
        monitored *complete windows* (``segment_windows_``), which can be a window shorter
        than its monitored span (docs/detect.md, section 8.4).
    profile_flow_gain : bool, default True
        VCA: a recording's own valve flow-gain factor is a nuisance of the test, profiled like
        its null offset and drift (the residual is linear in the gain): the flow gain of a
        recording moves with temperature and supply, and an unprofiled gain error left the
        first tested windows of no-load runs alternating with the valve volume, which the
        offset and drift turned into a leak-like estimate (docs/detect.md, section 8.4).
        Ignored by the EHA.
    confidence : float or None, default None
        Choose the conformal rank calibration-conditionally, as
        :class:`~leakdiag.detect.base.Alarm`'s ``confidence``: with this probability over the
        healthy maxima the level's own rate is at most the target (e.g. 0.95 needs 299 maxima
        for 1 % per segment). None: ``k = floor(alpha (n + 1))``.

    Attributes
    ----------
    model_ : VCAValveModel or EHAPumpModel
        Identified machine model; ``model_std_`` its standard errors (dict).
    error_model_ : numpy.ndarray
        Healthy error model of a window residual, ``s^2 = c0 + c1 F^2 + c2 (Q_a^2 + Q_b^2) +
        c3 C^2`` with ``F`` the volume through the valve/pump in the window, ``Q_a, Q_b`` the
        flows at its end samples (timing errors of the valve model act there) and ``C`` its
        compressibility volume (bulk-modulus errors); ``noise_floor_m3_ = sqrt(c0)`` and
        ``flow_error_fraction_ = sqrt(c1)``.
    dispersion_ : float
        Factor (>= 1) by which healthy span estimates scatter more than the error model says;
        multiplies every standard error.
    healthy_maxima_, cross_fit_maxima_ : numpy.ndarray
        GLR maxima of the healthy runs in-sample and out-of-fold (two-fold cross-fitting, with
        at least 4 runs); the latter set ``alarm_threshold_.scale``.
    threshold_ : float
        GLR alarm level (z scale) in use: ``threshold_basis_.threshold``.
    threshold_basis_ : ThresholdBasis
        How the level was set: ``"conformal"`` (``k``-th largest of ``n`` out-of-fold and
        reference segment maxima, at most ``k / (n + 1)`` false alarms per segment for an
        exchangeable healthy segment) or ``"glr-model"`` (the bootstrap level below, not
        distribution-free; ``supported=False``).
    alarm_threshold_ : GLRThreshold
        The model-based level of the healthy-residual bootstrap and its simulated null.
    n_healthy_, healthy_hours_ : int, float
        Healthy data used.
    sample_rate_ : float
        Sample rate (Hz) of the healthy recordings; a recording at another rate is refused
        (absent from detectors saved before 2026-11-27, which do not check it).

    Notes
    -----
    VCA (Eq. 2-1 minus its mirror, mechanics-free):

    .. math::

        \\int_w Q_l\\,dt = \\int_w \\frac{Q_1 + Q_2}{2} dt - A\\,\\Delta x
        - \\frac{1}{2\\beta}\\Big(\\int_w V_1\\,dP_1 - \\int_w V_2\\,dP_2\\Big)

    with :math:`Q_1, Q_2` of Eq. 2-2 and :math:`Q_l = k\\,\\phi(P_1 - P_2)` (Eq. 2-4 or 2-5).
    The window residual ``e_w`` is regressed on :math:`\\Phi_w = \\int_w \\phi\\,dt`; the
    one-sided GLR over spans of up to ``max_span_s`` tests :math:`k > 0`. Its threshold comes
    from a Monte-Carlo null of the fitted error model, which is the same for every machine
    once standardised (pivotal). The mean leak flow is :math:`\\hat k` times the mean
    :math:`|\\phi|` since the onset (the thesis's "mean leak after the onset").

    Examples
    --------
    >>> FlowBalanceDetector(system="vca", false_alarms_per_hour=0.3).get_params()["window_s"]
    1.0
    """

    #: Its GLR is not restarted at segment boundaries: beyond a recording's first healthy
    #: segment its per-segment rate is not guaranteed (docs/detect.md section 2).
    restarts_per_segment = False

    #: Read by predict only (the size interval's level, the flow's reference pressure
    #: difference): they may change after fit (``check_params_unchanged``).
    predict_time_params = ("interval_level", "reference_dp_pa")

    def __init__(self, system="vca", false_alarms_per_hour=1.0, window_s=1.0, max_span_s=30.0,
                 leak_law="turbulent", params=None, fit_bandwidth=False, fit_bulk_modulus=False,
                 burn_in_s=2.0, reference_dp_pa=1e6, interval_level=0.95, alarm=None,
                 quiet_boundaries=True, fit_valve_timing=False, segment_s=None,
                 profile_flow_gain=True, confidence=None):
        self.system = system
        self.false_alarms_per_hour = false_alarms_per_hour
        self.window_s = window_s
        self.max_span_s = max_span_s
        self.leak_law = leak_law
        self.params = params
        self.fit_bandwidth = fit_bandwidth
        self.fit_bulk_modulus = fit_bulk_modulus
        self.burn_in_s = burn_in_s
        self.reference_dp_pa = reference_dp_pa
        self.interval_level = interval_level
        self.alarm = alarm
        self.quiet_boundaries = quiet_boundaries
        self.fit_valve_timing = fit_valve_timing
        self.segment_s = segment_s
        self.profile_flow_gain = profile_flow_gain
        self.confidence = confidence

    # ------------------------------------------------------------------ validation
    def _validate(self) -> None:
        if self.system not in SYSTEMS:
            raise ValueError(f"system={self.system!r} must be one of {SYSTEMS}")
        if self.leak_law not in LEAK_LAWS:
            raise ValueError(f"leak_law={self.leak_law!r} must be one of {LEAK_LAWS}")
        for name in ("false_alarms_per_hour", "window_s", "max_span_s", "reference_dp_pa",
                     "burn_in_s", "interval_level", "segment_s", "confidence"):
            if getattr(self, name) is not None:  # text refused: get_params would keep it
                check_number(getattr(self, name), name)
        check_positive(self.false_alarms_per_hour, "false_alarms_per_hour")
        check_positive(self.window_s, "window_s")
        check_positive(self.max_span_s, "max_span_s")
        check_positive(self.reference_dp_pa, "reference_dp_pa")
        if not (np.isfinite(self.burn_in_s) and self.burn_in_s >= 0):
            raise ValueError(f"burn_in_s={self.burn_in_s!r} must be a finite number >= 0")
        if not 0 < self.interval_level < 1:
            raise ValueError(f"interval_level={self.interval_level!r} must be in (0, 1)")
        if self.segment_s is not None:
            check_positive(self.segment_s, "segment_s")
        if self.confidence is not None and not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence={self.confidence!r} must be in (0, 1) or None")
        if self.max_span_s < self.window_s:
            raise ValueError(f"max_span_s={self.max_span_s!r} must be >= window_s={self.window_s!r}")
        if self.alarm is not None:
            raise ValueError(
                f"alarm is not used by FlowBalanceDetector (given: {type(self.alarm).__name__}): "
                "give its settings as the detector's own false_alarms_per_hour, burn_in_s, "
                "segment_s and confidence (leakdiag.bench.registry.make_detector("
                "'flow-balance', system, alarm) does); the onset is always the GLR's")

    def _backend(self):

        return vca if self.system == "vca" else eha

    @property
    def channels(self) -> tuple[str, ...]:
        """Channels the balance reads (VCA: p1, p2, x, u; EHA: p1, p2, x, speed, pa, pb)."""
        return tuple(self._backend().CHANNELS)

    def _nominal(self):
        be = self._backend()
        return be.default_params() if self.params is None else be.check_params(self.params)

    def _check_recording(self, rec, where: str, rate: float | None = None) -> None:
        """Refuse a recording of another system, without a channel the balance needs, with a
        non-finite sample, or sampled at another rate than ``rate`` (fit: the first healthy
        recording's) or, when fitted, the fit's ``sample_rate_``: the spike, hold and sum-gate
        limits and the false-alarm level were learned at that rate (a 1-kHz fit refused 4 of
        6 healthy 600-Hz runs as "spikes" and scored 2-kHz ones above its healthy maxima;
        docs/detect.md 8.5, "Sample rate")."""
        source = rec.meta.get("source", "<recording>")
        system = rec.meta.get("system")
        if system is not None and system != self.system:
            raise RecordingError(f"{where}: {source}: recording is system={system!r}, the "
                                 f"detector system={self.system!r}")
        fitted = rate if rate is not None else getattr(self, "sample_rate_", None)
        # None: a detector saved before the rate was recorded (no check)
        if fitted is not None and not same_rate(rec.sample_rate, fitted):
            what = ("the first healthy recording is sampled at" if rate is not None
                    else "the detector was fitted at")
            raise RecordingError(
                f"{where}: {source}: sample rate {float(rec.sample_rate):g} Hz, but {what} "
                f"{float(fitted):g} Hz: the flow balance's spike, hold and consistency limits "
                "and its false-alarm level are learned at one rate; resample the recording or "
                "fit on healthy recordings at this rate")
        missing = [c for c in self._backend().CHANNELS if c not in rec.channels]
        if missing:
            raise RecordingError(
                f"{where}: {source}: the flow balance ({self.system}) needs channel(s) "
                f"{missing}, missing from this recording; available: {sorted(rec.channels)}")
        for c in self._backend().CHANNELS:
            v = rec[c]
            bad = np.flatnonzero(~np.isfinite(v))
            if bad.size:
                raise RecordingError(f"{where}: {source}: channel {c!r} is not finite at row "
                                     f"{int(bad[0])} ({bad.size} such rows)")
        # a position or pressures that cannot be metres and pascals for the modelled rig (a
        # unit left unstated: mm read as m gave 330 L/min for 0.3; detect/_rig_units.py)
        nominal = self._nominal()
        check_rig_units(rec, where, float(nominal.stroke_m), float(
            nominal.supply_pressure_pa if self.system == "vca"
            else nominal.accumulator_pressure_pa), f"the flow balance ({self.system})")

    def _check_operation(self, rec, where: str) -> None:
        """Refuse a recording that the fitted flow balance does not describe: another machine
        or load than every healthy recording (when both carry it in their metadata), or a
        channel far outside the healthy recordings' range (a unit error, another rig)."""
        op = getattr(self, "operation_", None)  # None: a file saved before this check
        if op is None:
            return
        source = rec.meta.get("source", "<recording>")
        mine = _operation([rec], ())
        for key, what in (("machine", "machine unit"), ("load", "load")):
            fitted, here = op.get(key), mine.get(key)
            if fitted is not None and here is not None and fitted != here:
                raise RecordingError(
                    f"{where}: {source}: recording of {what} {here!r}, but the detector was "
                    f"fitted on healthy recordings of {what} {fitted!r}: the flow balance is "
                    "identified per machine and operation; fit one on healthy recordings of "
                    "this machine under this load")
        fit_len = op.get("longest_s")  # None: a file saved before 2026-11-28
        for c, (lo, hi) in op.get("ranges", {}).items():
            if c not in rec.channels or not hi > lo:
                continue
            x = _after(rec, c, float(self.burn_in_s))  # as the test: after the burn-in
            if not len(x):
                continue
            q_lo, q_hi = np.percentile(x, [1.0, 99.0])
            span, margin = hi - lo, OPERATION_MARGINS.get(c, OPERATION_MARGIN)
            if q_lo < lo - margin * span or q_hi > hi + margin * span:
                raise RecordingError(
                    f"{where}: {source}: channel {c!r} spans {q_lo:.4g} to {q_hi:.4g} (1st-99th "
                    f"percentile after the burn-in), far outside the healthy recordings the detector was fitted "
                    f"on ({lo:.4g} to {hi:.4g}, allowed {margin:g}x that span beyond either "
                    "end): another unit (Pa, m, V, rad/s expected; see --col CH=COL:UNIT), "
                    "another rig, or operation the detector was not fitted for"
                    + (f", or a slow drift (an open-loop position, a temperature) that goes "
                       f"further in a recording {rec.duration / fit_len:.3g}x as long as the "
                       "longest healthy one: judge parts as long as the healthy recordings, or "
                       "fit on longer ones" if fit_len and rec.duration > 1.5 * fit_len else ""))
        # single samples far outside the healthy recordings' full range: the percentiles above
        # ignore under 1 % of a run (a dropout, a burst of wrong samples)
        first = int(round(float(self.burn_in_s) * rec.sample_rate))
        for c, (lo, hi) in op.get("extremes", {}).items():
            if c not in rec.channels or not hi > lo:
                continue
            x = _after(rec, c, float(self.burn_in_s))
            span, margin = hi - lo, OPERATION_MARGINS.get(c, OPERATION_MARGIN)
            out = np.flatnonzero((x < lo - margin * span) | (x > hi + margin * span))
            if out.size:
                i = int(out[0])
                raise RecordingError(
                    f"{where}: {source}: channel {c!r} reads {x[i]:.6g} at row {first + i} "
                    f"({out.size} such rows after the burn-in), far outside the healthy "
                    f"recordings' full range ({lo:.6g} to {hi:.6g}, allowed {margin:g}x that "
                    "span beyond either end): a dropout, a spike or a wrong unit (sensor or "
                    "acquisition fault?)")

    def _check_constant(self, rec, where: str, name: str | None = None) -> None:
        """Refuse a recording in which a channel the balance reads is constant after the
        burn-in (zero variance: a stuck sensor or a channel that was not recorded). Read as a
        measurement, a constant pressure, position, command or speed is flow that is not
        there: a healthy run with ``p1`` held at its median was judged LEAK at p = 8e-5. Also
        one whose channels the backend finds swapped (``wiring_problem``: the EHA's line
        pressures)."""
        name = name or rec.meta.get("source", "<recording>")
        burn = float(self.burn_in_s)
        first = int(round(burn * rec.sample_rate))
        for c in self._backend().CHANNELS:
            x = _after(rec, c, burn)
            if len(x) and x.min() == x.max():
                raise RecordingError(
                    f"{where}: {name}: channel {c!r} is constant (stuck sensor?): all "
                    f"{len(x)} samples after the {burn:g}-s burn-in (rows {first} to "
                    f"{first + len(x) - 1}) are {x[0]:.6g}; the flow balance reads it as a "
                    "measurement and cannot use a recording without one")
        why = self._backend().wiring_problem(rec, first)
        if why:
            raise RecordingError(f"{where}: {name}: {why}")

    def _limited_channels(self, rec, attribute: str):
        """``(channel, limit, samples after the burn-in, row of the first)`` for each channel
        of ``rec`` with a limit in the fitted ``attribute`` (none for a file saved before it)."""
        limits = getattr(self, attribute, None) or {}
        burn = float(self.burn_in_s)
        first = int(round(burn * rec.sample_rate))
        for c, limit in limits.items():
            if c in rec.channels:
                yield c, limit, _after(rec, c, burn), first

    def _check_holds(self, rec, where: str) -> None:
        """Refuse a recording in which a channel holds one exact value for longer than
        ``HOLD_FACTOR`` times the longest the healthy recordings held one (after the burn-in,
        not counting holds at the channel's smallest or largest value in the recording, nor
        the position: ``HOLD_EXEMPT``): a sensor that froze part-way."""
        # a hold at the recording's own extreme is a rail only at a value the healthy
        # recordings reached (a file saved before "extremes": every extreme is a rail)
        extremes = (getattr(self, "operation_", None) or {}).get("extremes", {})
        source = rec.meta.get("source", "<recording>")
        for c, limit, x, first in self._limited_channels(rec, "hold_limits_s_"):
            n, i = _longest_hold(x, extremes.get(c))
            if n > limit * rec.sample_rate + 1e-6:  # in samples: a hold of the limit is kept
                factor = HOLD_FACTORS.get((self.system, c), HOLD_FACTOR)
                raise RecordingError(
                    f"{where}: {source}: channel {c!r} holds one value ({x[i]:.6g}) for "
                    f"{n / rec.sample_rate:.4g} s, rows {first + i} to {first + i + n - 1} "
                    f"(stuck sensor?): longer than the {limit:.3g} s allowed, {factor:g}x "
                    f"the longest the healthy recordings held one value of it "
                    f"({self.longest_hold_s_[c]:.3g} s, not counting their smallest and "
                    "largest values)")

    def _check_spikes(self, rec, where: str) -> None:
        """Refuse a recording with a one-sample outlier of the command or the motor speed
        (``SPIKE_CHANNELS``) larger than ``SPIKE_FACTOR`` times the largest in the healthy
        recordings: one sample carries a whole sample interval of valve or pump flow (a
        single +10 V sample of ``u`` made 11 of 12 healthy VCA runs LEAK)."""
        source = rec.meta.get("source", "<recording>")
        for c, limit, x, first in self._limited_channels(rec, "spike_limits_"):
            sz = spike_sizes(x)
            bad = np.flatnonzero(sz > limit)
            if bad.size:
                i = int(bad[0]) + 1
                raise RecordingError(
                    f"{where}: {source}: channel {c!r} has a one-sample outlier at row "
                    f"{first + i}: {x[i]:.6g} between {x[i - 1]:.6g} and {x[i + 1]:.6g}, "
                    f"{sz[i - 1]:.4g} away from both ({bad.size} such rows after the burn-in); "
                    f"more than the {limit:.4g} allowed, {SPIKE_FACTOR:g}x the largest in the "
                    f"healthy recordings ({self.largest_spike_[c]:.4g}): a spike (sensor or "
                    "acquisition fault?)")

    def _check_steps(self, rec, where: str) -> None:
        """Refuse a recording whose position steps between two samples by more than
        ``STEP_FACTOR`` times the largest step of the healthy recordings (the valve's saturated
        piston speed): a discontinuity, such as two runs spliced into one file, enters the
        balance as the volume of a piston motion that did not happen (a flow-balance audit,
        2026-11-28: no healthy VCA splice read NO LEAK, 5 of 12 read LEAK with a size)."""
        source = rec.meta.get("source", "<recording>")
        for c, limit, x, first in self._limited_channels(rec, "step_limits_"):
            d = np.abs(np.diff(x))
            bad = np.flatnonzero(d > limit)
            if bad.size:
                i = int(bad[0])
                at = float(rec.start_time) + (first + i + 1) / rec.sample_rate
                raise RecordingError(
                    f"{where}: {source}: channel {c!r} steps by {d[i]:.4g} between rows "
                    f"{first + i} and {first + i + 1} (at {seconds(at, 6)} s; {bad.size} such "
                    "step(s) "
                    f"after the burn-in): more than the {limit:.4g} allowed, {STEP_FACTOR:g}x "
                    f"the largest step of the healthy recordings ({self.largest_step_[c]:.4g}), "
                    "faster than the piston moved there: a discontinuity (a stop and restart "
                    "spliced into one file, a re-zeroed encoder, a sensor fault?); judge the "
                    "parts on either side separately")

    def _check_sum_gate(self, rec, t: dict, where: str) -> None:
        """Refuse a recording whose leak-free sum equation (VCA) is off by more than the
        gate's limit in some window: a sensor or model inconsistency that a leak does not
        cause (``_flow_balance_checks``; docs/detect.md 8.4)."""
        gate = getattr(self, "sum_gate_", None)  # None: the EHA, or a file saved before it
        if gate is None or "balance" not in t:
            return
        z = gate.z(t["balance"], t["flow"])
        # only where the valve volume stays within the healthy windows' (a large leak's
        # windows go beyond, where the valve model was never checked)
        bad = np.flatnonzero((np.abs(z) > gate.limit) & gate.judged(t["flow"]))
        if not bad.size:
            return
        source = rec.meta.get("source", "<recording>")
        worst = int(bad[np.argmax(np.abs(z[bad]))])
        a, b = int(bad[0]), int(bad[-1])
        raise RecordingError(
            f"{where}: {source}: sensor or model inconsistency from {t['start'][a]:.4g} to "
            f"{seconds(t['end'][b])} s ({bad.size} window(s)): the leak-free sum of the chamber "
            f"balances (Q1 - Q2 = (V1 dP1 + V2 dP2)/beta, which a leak does not enter) is off "
            f"by up to {abs(z[worst]):.3g} healthy spreads ({t['balance'][worst] * 1e9:+.4g} uL "
            f"in the window {seconds(t['start'][worst])}-{seconds(t['end'][worst])} s), where the "
            f"healthy recordings reached {gate.healthy_max_z:.3g} and {gate.limit:.3g} is "
            f"allowed ({gate.factor:g}x): a transducer offset/gain, a command delay or sign, "
            "or operation the fit did not see; no verdict on a leak")

    def _monitored_windows(self, rec) -> int:
        """Windows after the burn-in, counted before the balance is computed: fixed and quiet
        boundaries alike cut ``(n - 1) // window`` windows of ``n`` samples, the first
        ``_skip`` of them the burn-in."""
        n_win = max(0, (rec.n_samples - 1) // self._window(rec))
        return n_win - min(self._skip(rec), n_win)

    def shortest_run_s(self) -> float:
        """About the shortest recording the test can judge (s): the burn-in and the windows
        the test needs before its first statistic (``leakdiag monitor --segment`` refuses a
        shorter segment up front).

        Returns
        -------
        float
        """
        return float(self.burn_in_s + self._MIN_HISTORY * self.window_s)

    def _too_short(self, rec, n_win: int) -> str:
        """Why a recording of ``n_win`` monitored windows cannot be tested (words)."""
        return (f"{rec.duration:.4g} s gives {n_win} window(s) of {self.window_s:g} s after the "
                f"{self.burn_in_s:g}-s burn-in, and the flow-balance test starts at the "
                f"{self._MIN_HISTORY}th (a recording longer than about "
                f"{self.shortest_run_s():.3g} s)")

    def _check_healthy(self, recs: list) -> None:
        """Refuse healthy recordings that cannot be tested or hold a constant channel, and
        (:func:`~leakdiag.detect.base.check_healthy`) those that leak by their metadata or
        repeat one another on the balance's channels (``fit``)."""
        chans = tuple(self._backend().CHANNELS)
        for i, r in enumerate(recs):
            name = f"healthy recording {i + 1} ({r.meta.get('source', '<recording>')})"
            n_win = self._monitored_windows(r)
            if n_win < self._MIN_HISTORY:
                raise RecordingError(
                    f"fit: {name} is too short to use: {self._too_short(r, n_win)}; "
                    "untested, it would add GLR maxima of 0 to the level")
            self._check_constant(r, "fit", name)
        check_healthy([healthy_info(r, chans) for r in recs])
        # so that none of them is judged against this threshold (refuse_own_healthy)
        self.healthy_fingerprints_ = frozenset(fingerprint(r, chans) for r in recs)
        self.fingerprint_channels_ = chans
        self.healthy_shapes_ = frozenset((int(r.n_samples), float(r.sample_rate))
                                         for r in recs)

    def _check_target(self, recs: list) -> float:
        """The segment (s) of the level; refuses a target of one false alarm or more per
        segment (``false_alarms_per_hour * segment_s / 3600 >= 1``)."""
        seg = self._fixed_segment()
        n_win = min(self._monitored_windows(r) for r in recs)
        segment_s = n_win * float(self.window_s) if seg is None else seg
        what = (f"the shortest healthy recording's {n_win} monitored windows of "
                f"{self.window_s:g} s" if seg is None else "segment_s")
        per_segment = float(self.false_alarms_per_hour) * segment_s / 3600.0
        if per_segment >= 1.0:
            raise ValueError(
                f"fit: false_alarms_per_hour={self.false_alarms_per_hour:g} is {per_segment:.4g} "
                f"false alarms per {segment_s:g}-s segment ({what}), the unit of the level: "
                "one or more per segment sets no level; the largest accepted value is below "
                f"{3600.0 / segment_s:.6g} per hour")
        return segment_s

    def _window(self, rec) -> int:
        w = int(round(self.window_s * rec.sample_rate))
        if w < 2:
            raise ValueError(f"window_s={self.window_s} is under 2 samples at "
                             f"{rec.sample_rate} Hz")
        return w

    def _skip(self, rec) -> int:
        return int(math.ceil(self.burn_in_s / self.window_s - 1e-9))

    # ------------------------------------------------------------------ terms
    @_one_blas_thread
    def _terms(self, rec, drift_windows: int | None = None) -> dict:
        """Window terms with the fitted model, burn-in dropped, plus window times;
        ``drift_windows``: the VCA's per-recording null drift fitted on the recording's
        windows before this one (burn-in included) only (``_scan``)."""
        be = self._backend()
        w = self._window(rec)
        # a detector saved before quiet boundaries existed was fitted on fixed windows
        quiet = bool(getattr(self, "quiet_boundaries", False))
        extra = {} if drift_windows is None else {"drift_windows": drift_windows}
        terms = be.terms(rec, self._nominal(), self.model_, w, self.leak_law == "laminar",
                         quiet=quiet, **extra)
        n_win = len(terms["residual"])
        bounds = terms.pop("bounds", np.arange(n_win + 1) * w)
        terms["start"] = rec.start_time + bounds[:-1] / rec.sample_rate
        terms["end"] = rec.start_time + bounds[1:] / rec.sample_rate
        # nuisance regressors: null offset and its linear drift (VCA), none (EHA)
        psi = terms.pop("nuisance", None)
        gain = terms.pop("gain_sensitivity", None)
        mid = 0.5 * (terms["start"] + terms["end"])
        if gain is not None:  # the model's valve volume per window (_piston_valve_ratio)
            terms["valve_volume"] = self.model_.flow_gain_factor * gain
        cols = [] if psi is None else [psi, psi * (mid - mid.mean())]
        # a file saved before the option existed did not profile the gain
        if gain is not None and getattr(self, "profile_flow_gain", False):
            cols.append(gain)
        terms["nuisance"] = np.column_stack(cols) if cols else np.zeros((n_win, 0))
        sk = min(self._skip(rec), n_win)
        return {k: np.asarray(v)[sk:] for k, v in terms.items()}

    @staticmethod
    def _error_regressors(terms: dict) -> np.ndarray:
        return np.column_stack([np.ones_like(terms["flow"]), terms["flow"] ** 2,
                                terms["edge_flow2"], terms["compressibility"] ** 2])

    def _sigma(self, terms: dict) -> np.ndarray:
        s2 = self._error_regressors(terms) @ self.error_model_
        return np.sqrt(s2) * self.dispersion_

    def _ab(self, terms: dict) -> tuple[np.ndarray, np.ndarray]:
        s = self._sigma(terms)
        return terms["phi"] * terms["residual"] / s**2, (terms["phi"] / s) ** 2

    #: Windows before the first test when nuisance regressors are profiled (leakdiag choice).
    _MIN_HISTORY = 5

    def _glr(self, terms: dict, residual=None):
        s = self._sigma(terms)
        r = terms["residual"] if residual is None else residual
        return glr_profile(terms["phi"], r, 1.0 / s**2, terms["nuisance"], self._max_span(),
                           self._MIN_HISTORY)

    @staticmethod
    def _profiled(terms: dict) -> np.ndarray:
        """Residual with its least-squares fit on the nuisance regressors removed."""
        nu = terms["nuisance"]
        if nu.shape[1] == 0 or len(nu) <= nu.shape[1]:
            return terms["residual"]
        coef, *_ = np.linalg.lstsq(nu, terms["residual"], rcond=None)
        return terms["residual"] - nu @ coef

    def _max_span(self) -> int:
        return max(1, int(round(self.max_span_s / self.window_s)))

    # ------------------------------------------------------------------ fit
    def _cross_fit_glr(self, recs: list) -> list:
        """GLR traces of each half of the healthy runs under a model fitted on the other half.

        Returns the GLR per window of each run, in the order of ``recs`` (empty with < 4 runs).
        """
        from sklearn.base import clone

        if len(recs) < 4:
            return []
        idx = (list(range(0, len(recs), 2)), list(range(1, len(recs), 2)))
        out: list = [None] * len(recs)
        for a, b in (idx, idx[::-1]):
            other = clone(self)
            other._fit([recs[i] for i in a], _no_cross=True, _like=self.model_)
            for i in b:
                t = other._terms(recs[i])
                g, _ = other._glr(t)
                out[i] = g
        return out

    def reference_direction(self) -> str:
        """Label of this detector's statistic in :class:`ReferenceMaxima` (``direction`` field).

        Returns
        -------
        str
            ``"glr(window_s=..., max_span_s=..., leak_law=...)"``: reference maxima pool only
            with a detector whose label is the same (``drift`` is 0 for the GLR).
        """
        return (f"glr(window_s={self.window_s:g}, max_span_s={self.max_span_s:g}, "
                f"leak_law={self.leak_law})")

    def reference_settings(self) -> dict:
        """Settings that reference maxima for this detector must carry (after :meth:`fit`).

        Returns
        -------
        dict
            ``segment_s`` (the fitted segment), ``drift`` 0, ``direction``
            (:meth:`reference_direction`) and ``burn_in_s``.
        """
        self._check_fitted()
        return {"segment_s": self.threshold_basis_.segment_s, "drift": 0.0,
                "direction": self.reference_direction(), "burn_in_s": float(self.burn_in_s)}

    def _threshold_basis(self, own: np.ndarray, segment_s: float, reference, h_model: float):
        """Conformal basis when the maxima support the target, else the model-based level."""
        alpha = float(self.false_alarms_per_hour) * segment_s / 3600.0
        conf = getattr(self, "confidence", None)  # absent from detectors saved before it
        if reference is not None:
            if not isinstance(reference, ReferenceMaxima):
                raise TypeError(f"reference_maxima must be a ReferenceMaxima, got "
                                f"{type(reference).__name__}")
            reference.check_compatible(segment_s, 0.0, self.reference_direction(),
                                       float(self.burn_in_s))
        if 0.0 < alpha < 1.0:
            try:
                b = conformal_threshold(own, alpha, segment_s=segment_s, reference=reference,
                                        confidence=conf)
                return replace(b, statistic="GLR")
            except InsufficientHealthyDataError:
                pass
        ref = reference.maxima if reference is not None else np.zeros(0)
        pooled = np.sort(np.concatenate([own, ref]))[::-1]
        n = len(pooled)
        seg_h = segment_s / 3600.0
        # never below the largest healthy out-of-fold maximum, M_(1), as the run level
        # (_model_run_tail): the model is used because the target is rarer than 1 / (n + 1),
        # the rate the maxima give M_(1), so a level below it contradicts the data (a
        # statistics audit, 2026-11-30, 132 fits: the 14 whose level lay below M_(1) crossed
        # on 8.0 % of held-out healthy runs, at the limit of their mean promise of 8.05 %, one
        # unit's 20 of 100 against 9.8 %; the other 118 on 0.9 % against 8.1 %)
        h = max(float(h_model), float(pooled[0])) if n else float(h_model)
        # no data-backed bound: the model level's rate rests on the error model (NaN, not alpha)
        return ThresholdBasis(
            "glr-model", h, n, len(own), len(ref), 0, float(segment_s), alpha,
            float("nan"), alpha / seg_h, float("nan"), float("nan"), False,
            min_maxima(alpha, conf) if 0 < alpha < 1 else 0,
            reference.source if reference is not None else "", pooled, "GLR",
            float("nan") if conf is None else float(conf))

    def fit(self, recordings, y=None, reference_maxima=None) -> "FlowBalanceDetector":
        """Identify the machine on healthy recordings and set the alarm level.

        The level is **conformal** (distribution-free) when the healthy GLR maxima support
        the target: the out-of-fold segment maxima of the runs (two-fold cross-fitting, from
        4 runs), pooled with ``reference_maxima``, give the ``k``-th largest with ``k =
        floor(alpha (n + 1)) >= 1``, ``alpha = false_alarms_per_hour * segment_s / 3600`` and
        ``segment_s`` the shortest run's monitored span. Otherwise it is the **model-based**
        level of the healthy-residual bootstrap (``threshold_basis_.method == "glr-model"``,
        ``supported=False``: its rate rests on the error model, see ``docs/detect.md`` 8.4).

        Parameters
        ----------
        recordings : list of Recording
            Healthy runs of this machine (a single Recording is accepted).
        y : ignored
            scikit-learn compatibility.
        reference_maxima : ReferenceMaxima, optional
            Out-of-sample GLR segment maxima of other units fitted the same way (their
            ``direction`` is :meth:`reference_direction`, ``drift`` 0, same ``burn_in_s`` and
            segment), pooled with this unit's own.

        Returns
        -------
        FlowBalanceDetector
            ``self`` with ``model_``, ``model_std_``, the error model, ``dispersion_``,
            ``threshold_``, ``threshold_basis_`` and ``alarm_threshold_``.

        Raises
        ------
        leakdiag.io.RecordingError
            If a recording lacks a channel the balance needs (the message names it), holds a
            non-finite value, has a channel that is constant after the burn-in, is too short
            to be tested (fewer than 5 windows after the burn-in), leaks by its metadata
            (``meta["leak_lpm"] > 0``), or holds the same samples as another one.
        ValueError
            For a bad setting (also a given ``alarm``), no recordings, a recording of another
            system, a healthy recording that a model fitted on the others reads as leaking
            (``ODD_ONE_OUT_FACTOR``), too little healthy data, reference maxima made with other settings, or a
            ``false_alarms_per_hour`` of one alarm or more per segment or at least the GLR
            null's rate at its lowest level (the message gives the largest accepted value).
        TypeError
            If ``reference_maxima`` is not a ReferenceMaxima.
        """
        return self._fit(recordings, reference_maxima=reference_maxima)

    @_one_blas_thread
    def _fit(self, recordings, _no_cross: bool = False, reference_maxima=None,
             _like=None) -> "FlowBalanceDetector":
        self._validate()
        if not _no_cross:  # fitting anew: no settings to hold it to (check_params_unchanged)
            self.__dict__.pop("fitted_params_", None)
        recs = list(_as_recordings(recordings))
        for r in recs:  # (recs[0] is checked to be a recording before its rate is read)
            check_recording_type(r, "fit")
            self._check_recording(r, "fit", rate=float(recs[0].sample_rate))
        if not _no_cross:  # a cross-fit half holds recordings fit has checked
            self._check_healthy(recs)
            segment_s = self._check_target(recs)
        self.operation_ = _operation(recs, self._backend().CHANNELS, float(self.burn_in_s))
        be = self._backend()
        nominal = self._nominal()
        self.model_, self.model_std_ = be.identify(
            recs, nominal, [self._window(r) for r in recs], self.leak_law == "laminar",
            [self._skip(r) for r in recs], self.fit_bandwidth, self.fit_bulk_modulus,
            quiet=bool(self.quiet_boundaries),
            fit_valve_timing=bool(self.fit_valve_timing), like=_like)
        if not _no_cross:  # the fit the user asked for, not a cross-fit half of it (an
            # audit, 2026-11-29: one half of a chirp-driven fit gave -0.018 where the whole fit
            # gave 1.03, and refused it): a position or pressure in another unit scales the
            # identified flow (cm read as mm gave a factor 0.12 and every leak size a tenth)
            scale = "flow_gain_factor" if self.system == "vca" else "displacement_factor"
            try:
                check_flow_scale(getattr(self.model_, scale),
                                 self.model_std_.get(scale, float("nan")), "fit",
                                 f"the flow balance ({self.system})",
                                 "flow-gain factor" if self.system == "vca" else
                                 "pump displacement factor", len(recs))
            except ValueError as exc:  # a chamber at a bound breaks the balance, not a unit
                note = (_at_bounds_note(recs, nominal, float(self.burn_in_s))
                        if self.system == "vca" else None)
                if note is None:
                    raise
                raise ValueError(f"{exc}. {note}") from None
        terms = [self._terms(r) for r in recs]
        e = np.concatenate([self._profiled(t) for t in terms])
        if len(e) < 10:
            raise ValueError(f"fit: only {len(e)} windows of {self.window_s} s after the burn-in "
                             f"in {len(recs)} healthy recording(s); give at least 10")
        # error model s^2 = c0 + c1 F^2 + c2 (Q_start^2 + Q_end^2) + c3 C^2: non-negative least
        # squares of e^2 on the regressors (each column scaled to unit RMS for conditioning)
        x = np.concatenate([self._error_regressors(t) for t in terms])
        col = np.sqrt(np.mean(x * x, axis=0))
        col[col == 0] = 1.0
        coef, _ = nnls(x / col, e * e)
        coef = coef / col
        if not coef[0] > 0:
            coef[0] = float(np.median(e * e))  # the floor must be positive: no zero-variance window
        self.error_model_ = coef
        self.noise_floor_m3_ = float(np.sqrt(coef[0]))
        self.flow_error_fraction_ = float(np.sqrt(coef[1]))
        self.dispersion_ = 1.0
        self.dispersion_ = self._dispersion(terms)
        if _no_cross:  # a cross-fit half: only the model and error model score the other half
            return self
        # the longest hold of one value per channel: a longer one in a judged recording is a
        # frozen sensor (_check_holds; HOLD_FACTOR)
        exempt = HOLD_EXEMPT_BY_SYSTEM[self.system]
        self.longest_hold_s_ = {
            c: max(_longest_hold(_after(r, c, float(self.burn_in_s)))[0] / r.sample_rate
                   for r in recs)
            for c in be.CHANNELS if c not in exempt}
        self.hold_limits_s_ = {c: HOLD_FACTORS.get((self.system, c), HOLD_FACTOR) * v
                               for c, v in self.longest_hold_s_.items() if v > 0}
        # the largest one-sample outlier of the command / speed: a far larger one in a judged
        # recording is a spike (_check_spikes; SPIKE_FACTOR)
        self.largest_spike_ = {
            c: max(float(spike_sizes(_after(r, c, float(self.burn_in_s))).max(initial=0.0))
                   for r in recs)
            for c in be.CHANNELS if c in SPIKE_CHANNELS}
        self.spike_limits_ = {c: SPIKE_FACTOR * v for c, v in self.largest_spike_.items()
                              if v > 0}
        # the largest one-sample step of the position: a far larger one in a judged recording
        # is a discontinuity (_check_steps; STEP_FACTOR)
        self.largest_step_ = {
            c: max(float(np.abs(np.diff(_after(r, c, float(self.burn_in_s)))).max(initial=0.0))
                   for r in recs)
            for c in be.CHANNELS if c in STEP_CHANNELS}
        self.step_limits_ = {c: STEP_FACTOR * v for c, v in self.largest_step_.items() if v > 0}
        # the leak-free sum equation's healthy spread (VCA; _check_sum_gate)
        self.sum_gate_ = (learn_sum_gate([t["balance"] for t in terms],
                                         [t["flow"] for t in terms])
                          if all("balance" in t for t in terms) else None)
        runs = [(t["phi"], self._sigma(t), t["nuisance"]) for t in terms]
        pool = np.concatenate([self._profiled(t) / self._sigma(t) for t in terms])
        try:
            h, grid, rate, hours, null_max = calibrate_glr(
                runs, self.window_s, self._max_span(), float(self.false_alarms_per_hour),
                self._MIN_HISTORY, pool=pool)
        except TargetBeyondNullError as exc:
            raise ValueError(
                f"fit: false_alarms_per_hour={self.false_alarms_per_hour:g} is at least the "
                f"rate of alarm episodes of the GLR's healthy null at its lowest level (z = "
                f"{exc.lowest_level:g}: {exc.largest_per_hour:.4g} per hour for these healthy "
                "recordings), so its level would be extrapolated below the simulated ones; the "
                "largest accepted value is below "
                f"{min(exc.largest_per_hour, 3600.0 / segment_s):.4g} per hour") from None
        self.healthy_hours_ = float(sum(len(t["residual"]) for t in terms) * self.window_s / 3600)
        gs = [self._glr(t)[0] for t in terms]
        self.healthy_maxima_ = np.array([float(g.max()) if len(g) else 0.0 for g in gs])
        # scale check on data the model was not fitted on: two-fold cross-fitting (identify on
        # one half of the healthy runs, GLR maxima on the other); against the simulated maxima
        # (medians, robust with few runs); the level is raised, never lowered
        cross = self._cross_fit_glr(recs)
        self.cross_fit_maxima_ = np.array([float(g.max()) if len(g) else 0.0 for g in cross])
        ref = (self.cross_fit_maxima_ if len(self.cross_fit_maxima_) >= 2
               else self.healthy_maxima_)
        scale = max(1.0, float(np.median(ref)) / float(np.median(null_max)))
        h = h * scale
        self.alarm_threshold_ = GLRThreshold(h, float(self.false_alarms_per_hour),
                                             "healthy-residual-bootstrap", hours,
                                             self.healthy_hours_,
                                             sum(glr_alarm_count(g, h) for g in gs), grid, rate,
                                             scale)
        # distribution-free level from out-of-fold segment maxima (+ reference) when supported
        # one segment = the shortest run's monitored windows (one segment per run when equal)
        # or segment_s of monitored time (windows by their end), as the Alarm's segment_s
        self.segment_windows_ = max(1, min(len(t["residual"]) for t in terms))
        own = (np.concatenate([self._maxima(g, t, r) for g, t, r in zip(cross, terms, recs)])
               if cross else np.zeros(0))
        self.threshold_basis_ = self._threshold_basis(own, segment_s, reference_maxima, h)
        self.threshold_ = float(self.threshold_basis_.threshold)
        self._check_odd_one_out(recs)
        self.n_healthy_ = len(recs)
        self.sample_rate_ = float(recs[0].sample_rate)  # _check_recording refuses other rates
        self.feature_name_ = "flow_balance"
        self.fitted_params_ = params_snapshot(self)  # what predict holds the fit to
        return self

    def _check_odd_one_out(self, recs: list) -> None:
        """Refuse healthy recordings that a model fitted on the others reads as leaking.

        The cross-fit judges each healthy run with the model identified on the other half
        (``cross_fit_maxima_``); a run whose GLR maximum there is above
        :data:`ODD_ONE_OUT_FACTOR` times the threshold is no healthy run of this machine: a
        leaking one, another machine's or another rig's. Metadata catch such runs only when
        the files carry them; an audit (2026-11-27) fitted five healthy CSV exports with one
        leaking 0.01 L/min (cross-fit maxima 0.18-3.13 and 63.7, threshold 2.79), and four
        with one EHA run (2.07-2.52 and 96.0): both fits were silent, and their detectors read
        0.005-0.02 L/min leaks NO LEAK that the clean fit detected (scores 31-127).
        """
        cm = getattr(self, "cross_fit_maxima_", np.zeros(0))
        # a model-based level is floored at the largest out-of-fold maximum (_threshold_basis),
        # which an odd recording's own maximum would raise: it is judged against the model's
        # level before that floor
        level = (float(self.alarm_threshold_.threshold)
                 if self.threshold_basis_.method == "glr-model" else float(self.threshold_))
        limit = ODD_ONE_OUT_FACTOR * level
        odd = [i for i, m in enumerate(cm) if m > limit]
        if not odd or len(cm) != len(recs):
            return
        rest = [m for i, m in enumerate(cm) if i not in odd]
        names = "; ".join(f"recording {i + 1} ({recs[i].meta.get('source', '<recording>')}): "
                          f"{cm[i]:.3g}" for i in odd)
        others = f"the others at most {max(rest):.3g}" if rest else "no other below it"
        raise ValueError(
            f"fit: {len(odd)} of the {len(recs)} healthy recordings do not read as healthy to "
            f"a model identified on the other half of them (GLR maximum, against the "
            f"threshold {level:.3g}; {others}): {names}. A leaking recording, or one "
            "of another machine, load or rig? Leave it out of the healthy recordings")

    def _fixed_segment(self) -> float | None:
        """``segment_s`` in seconds, or None (also for a detector saved before it existed)."""
        seg = getattr(self, "segment_s", None)
        return None if seg is None else float(seg)

    def _maxima(self, g, t: dict, rec) -> np.ndarray:
        """GLR maxima of the complete segments of one recording's trace ``g``."""
        seg = self._fixed_segment()
        if seg is None:
            return glr_segment_maxima(g, self.segment_windows_)
        burn = float(self.burn_in_s)
        return binned_maxima(g, t["end"], seg, rec.start_time + burn, rec.duration - burn)

    def _dispersion(self, terms: list[dict]) -> float:
        """sqrt of the largest variance of healthy span z-scores over several span lengths."""
        worst = 1.0
        for span in _DISPERSION_SPANS:
            zs = []
            for t in terms:
                a, b = self._ab({**t, "residual": self._profiled(t)})
                m = len(a) // span
                if m == 0:
                    continue
                sa = a[:m * span].reshape(m, span).sum(1)
                sb = b[:m * span].reshape(m, span).sum(1)
                ok = sb > 0
                zs.append(sa[ok] / np.sqrt(sb[ok]))
            z = np.concatenate(zs) if zs else np.array([])
            if len(z) >= 10:
                worst = max(worst, float(np.mean(z * z)))
        return float(np.sqrt(worst))

    # ------------------------------------------------------------------ outputs
    def _check_fitted(self) -> None:
        if not hasattr(self, "threshold_"):
            from sklearn.exceptions import NotFittedError  # a ValueError and AttributeError

            raise NotFittedError("FlowBalanceDetector is not fitted; call "
                                 "fit(healthy_recordings) first")
        check_params_unchanged(self)

    def _scan(self, rec, where: str, consistency: bool = True, level: float | None = None):
        """Window terms, per-window GLR sums and GLR trace of a checked recording;
        ``consistency=False`` skips the sum-equation gate (healthy reference runs, whose
        refusal would stop a benchmark's reference maxima, ``segment_maxima``)."""
        self._check_fitted()
        check_recording_type(rec, where)
        self._check_recording(rec, where)
        n_win = self._monitored_windows(rec)
        if n_win < self._MIN_HISTORY:  # the GLR tests from its _MIN_HISTORY-th window on
            source = rec.meta.get("source", "<recording>")
            raise TooShortToJudge(
                f"{where}: {source}: too short to judge: {self._too_short(rec, n_win)}")
        self._check_constant(rec, where)
        self._check_operation(rec, where)
        self._check_holds(rec, where)
        self._check_spikes(rec, where)
        self._check_steps(rec, where)
        t = self._terms(rec)
        a, b = self._ab(t)
        g, arg = self._glr(t)
        if consistency and getattr(self._backend(), "DRIFT_ITERATIONS", 0):
            t, a, b, g, arg = self._causal_drift(rec, t, a, b, g, arg, level)
        if consistency:
            self._check_sum_gate(rec, t, where)
        return t, a, b, g, arg

    #: Refits of the recording's null drift after an alarm (``_causal_drift``).
    _DRIFT_REFITS = 3

    def _causal_drift(self, rec, t, a, b, g, arg, level: float | None = None):
        """The scan again with the recording's null drift fitted before the first alarm's span.

        The VCA backend linearises each recording at its own null offset and drift, fitted on
        all its windows (:func:`leakdiag.detect._flow_balance_vca.terms`). A large leak later in
        the recording moves that fit, and through the valve flows' nonlinearity in the null
        every earlier window's residual: an audit (2026-11-27) found 1 and 2 L/min leaks from
        60 s alarming at 19-50 s (4 of 8 and 6 of 8 runs) with sizes of 0.4-0.5 L/min, while
        the same recording cut before the onset read NO LEAK. So when the test alarms, the
        drift is fitted again on the windows before the alarm's best span (which the test found
        leak-free) and the recording scanned again. That scan is taken when its first alarm
        comes later (the whole-recording fit had moved the alarm early), or when it has none; a
        further refit (on the windows before the new span, more of them) is taken unless its
        alarm comes earlier; at most :attr:`_DRIFT_REFITS` refits. A scan whose first alarm
        stays put keeps the whole-recording fit, the better linearisation when nothing moved
        it (a 0.2 L/min ramp was sized 0.88x with the offset from the 5 windows before it).
        Only a scan that alarmed is redone, and a run can only lose or delay an alarm by this:
        false alarms stay within the rate the threshold was calibrated for.
        """
        # at the level the verdict is judged at (a run level above the threshold: a statistics
        # audit, 2026-11-30, found the refit keyed to the threshold there)
        h, skip = (self.threshold_ if level is None else float(level)), self._skip(rec)
        above = np.flatnonzero(g >= h)
        if not len(above):
            return t, a, b, g, arg
        first, strict = int(above[0]), True
        start = int(arg[first])
        for _ in range(self._DRIFT_REFITS):
            t2 = self._terms(rec, drift_windows=skip + start)  # windows before the span
            a2, b2 = self._ab(t2)
            g2, arg2 = self._glr(t2)
            above = np.flatnonzero(g2 >= h)
            if not len(above):  # the alarm was the drift fit's
                return t2, a2, b2, g2, arg2
            first2 = int(above[0])
            if first2 < first or (strict and first2 == first):
                break
            t, a, b, g, arg = t2, a2, b2, g2, arg2
            start2 = int(arg2[first2])
            if start2 <= start:  # no more windows before the span to fit on
                break
            first, start, strict = first2, start2, False
        return t, a, b, g, arg

    def score(self, recording) -> FeatureSeries:
        """The GLR statistic over time (z scale); an alarm where it reaches ``threshold_``.

        Parameters
        ----------
        recording : Recording
            Recording of the fitted machine.

        Returns
        -------
        FeatureSeries
            One value per window (time = window end), after the burn-in.
        """
        t, _, _, g, _ = self._scan(recording, "score")
        return FeatureSeries(t["end"], g, "glr[flow_balance]", {"threshold": self.threshold_},
                             window=self._window(recording) + 1,
                             sample_rate=recording.sample_rate)

    def standardize(self, recording) -> FeatureSeries:
        """Per-window standardised leak-coefficient estimate ``k_w / se_w``.

        Parameters
        ----------
        recording : Recording
            Recording of the fitted machine.

        Returns
        -------
        FeatureSeries
            Standard normal on healthy windows (by construction of the error model); 0 where
            the window has no leak-law pressure term.
        """
        t, a, b, _, _ = self._scan(recording, "standardize")
        z = np.where(b > 0, a / np.sqrt(np.where(b > 0, b, 1.0)), 0.0)
        return FeatureSeries(t["end"], z, "z[flow_balance]", window=self._window(recording) + 1,
                             sample_rate=recording.sample_rate)

    def leak_estimates(self, recording):
        """Per-window leak estimates as a tidy table.

        Parameters
        ----------
        recording : Recording
            Recording of the fitted machine.

        Returns
        -------
        pandas.DataFrame
            Columns ``start_s``, ``end_s``, ``residual_m3``, ``phi``, ``leak_coefficient``,
            ``leak_coefficient_se`` (NaN where ``phi = 0``), ``z``, ``glr``.
        """
        import pandas as pd

        t, a, b, g, _ = self._scan(recording, "leak_estimates")
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(b > 0, a / b, np.nan)
            se = np.where(b > 0, 1.0 / np.sqrt(b), np.nan)
        return pd.DataFrame({"start_s": t["start"], "end_s": t["end"],
                             "residual_m3": t["residual"], "phi": t["phi"],
                             "leak_coefficient": k, "leak_coefficient_se": se,
                             "z": k / se, "glr": g})

    def run_level(self, span_s: float, n_segments: int | None = None
                  ) -> tuple[float, float] | None:
        """The level that holds a run of ``span_s`` to the false-alarm rate of one segment.

        The fitted threshold holds ``alpha = false_alarms_per_hour * segment / 3600`` per
        healthy segment; a run of ``m`` segments expects ``m`` times as many false alarms at it.
        The run level expects at most ``alpha`` in the whole run (docs/detect.md section 6,
        "Long runs"):

        * conformal basis: the ``k'``-th largest healthy maximum, ``k' = floor(alpha (n + 1) /
          m)`` (union bound ``m k' / (n + 1) <= alpha``), when ``k' >= 1``; a
          calibration-conditional basis (``confidence`` given) the conditional rank for
          ``alpha / m`` per segment (:meth:`Detector._run_rank`);
        * otherwise, as :meth:`fit` falls back for one segment, the model-based level: the
          lowest level (on a 0.01 grid, from the fitted threshold and from the largest healthy
          maximum, with the null's tail raised to agree with the healthy maxima there:
          :meth:`_model_run_tail`) above which the bootstrap null's rate stays at most
          ``alpha / hours`` (:meth:`GLRThreshold.tail_rate`: beyond the null's last levels
          with 3 or more alarm episodes, its fitted exponential tail, which over-states the
          rate of a Gaussian-like statistic), not guaranteed by data; None when that rate is
          more than :data:`RUN_LEVEL_MAX_EXTRAPOLATION` times below one episode in the null's
          simulated hours.

        Like the fitted level's, the run level's rate is not guaranteed beyond the first
        segment (the GLR carries its state over segment boundaries:
        :func:`leakdiag.detect.decision.per_run_rate`).

        Parameters
        ----------
        span_s : float
            The judged span (duration minus ``burn_in_s``), s.
        n_segments : int, optional
            Segments the span covers (``Verdict.n_segments``); default ``span_s`` over the
            basis's segment.

        Returns
        -------
        (level, expected) or None
            The level (at least ``threshold_``) and the false alarms it expects in the run.
        """
        # distribution-free when the healthy maxima support the run (a higher rank of them:
        # Detector.run_level), else the model-based level, as fit chooses between them for
        # one segment
        found = super().run_level(span_s, n_segments)
        if found is not None:
            return found
        alpha = float(self.threshold_basis_.target_per_segment)
        hours = span_s / 3600.0
        th = self.alarm_threshold_
        floor, scale = self._model_run_tail()
        target = alpha / hours / scale if hours > 0 else float("inf")  # for the null's tail
        if target < 1.0 / (RUN_LEVEL_MAX_EXTRAPOLATION * th.simulated_hours):
            return None  # too far beyond the null's resolution for its fitted tail
        top = float(th.grid[-1]) * th.scale + 10.0
        hs = np.arange(floor, top, 0.01)
        rates = np.array([th.tail_rate(h) for h in hs])
        over = np.flatnonzero(rates > target)
        if len(over) == len(hs):
            return None
        level = float(hs[over[-1] + 1]) if len(over) else float(hs[0])
        return level, scale * th.tail_rate(level) * hours

    def _model_run_tail(self) -> tuple[float, float]:
        """Where a model-based run level starts, and the factor on the null's tail.

        Returns
        -------
        floor : float
            The fitted threshold, and where the basis keeps healthy maxima no lower than the
            largest of them, ``M_(1)``. Below it the healthy data speak for themselves: at the
            ``k``-th largest they expect ``m k / (n + 1)`` false alarms in a run of ``m``
            segments, more than the run's target whenever the maxima cannot resolve the run.
        scale : float
            At least 1: the factor that makes the bootstrap null's fitted tail
            (:meth:`GLRThreshold.tail_rate`) no lighter at ``M_(1)`` than the healthy maxima
            are there, a rate ``-log(1 - 1 / (n + 1))`` per segment (the rank's chance that a
            new segment's maximum exceeds the largest of ``n``, as Poisson episodes); 1 without
            maxima.

        Notes
        -----
        Two statistics audits (2026-11-29): the model's level sat at the fitted threshold (the
        2nd largest of 24 maxima), where a run "expects about 0.059" by the model and 0.32 by
        the maxima, in one line (the floor, session 22); and where the floor then set the level,
        the null's tail said "about 0.011" for 90-s runs of which 14 of 100 alarmed: the tail
        is lighter than the healthy data exactly where the floor binds (the scale). The floor
        and the scale hold for a model-based basis with maxima too (4 of 20 of its run levels
        lay below a healthy maximum).
        """
        floor = float(self.threshold_)
        b = getattr(self, "threshold_basis_", None)
        if b is None or not len(b.maxima) or not float(b.segment_s) > 0:
            return floor, 1.0
        top = float(np.max(b.maxima))
        floor = max(floor, top)
        data = -math.log1p(-1.0 / (len(b.maxima) + 1)) / (float(b.segment_s) / 3600.0)
        model = self.alarm_threshold_.tail_rate(top)
        return floor, (max(1.0, data / model) if 0.0 < model < float("inf") else 1.0)

    def predict(self, recording, level: float | None = None) -> FlowBalanceVerdict:
        """Verdict: leak or not, alarm time, onset, leak size (mean L/min with an interval).

        Parameters
        ----------
        recording : Recording
            Recording of the fitted machine.
        level : float, optional
            Alarm level to judge at instead of ``threshold_`` (at least ``threshold_``): the
            :meth:`run_level` of a run that expects a false alarm or more at the threshold.
            The verdict's p-value (``confidence``) then comes from the basis the run level
            comes from (the model-based null when the healthy maxima cannot hold the run).

        Returns
        -------
        FlowBalanceVerdict
            Without an alarm ``leak=False`` and no size. With one, the onset is the
            maximum-likelihood step of the leak coefficient over all windows, among those up to
            the first alarm, with the nuisance fitted before the GLR's best span (``_onset``),
            the leak coefficient is estimated on every window
            after the onset window to the end of the recording, the mean leak flow is that
            coefficient times the mean ``|phi|`` from the onset to the end (L/min) with an
            ``interval_level`` interval, and ``leak_lpm_at_reference`` the flow at ``reference_dp_pa``.
            EHA, and the VCA without load (or under an unknown load): the size is taken at
            the differential pressure-transducer offset that fits the leak's windows best
            (``pressure_offset_pa``, searched within +-200 kPa, widened up to +-800 kPa while
            the best is at the edge), and its interval also holds the offsets the data allow (docs/detect.md 8.5; ``leak_lpm_interval_holds`` names them
            and flags an offset beyond +-200 kPa).

        Raises
        ------
        leakdiag.io.RecordingError
            When the recording cannot be judged (``leakdiag detect`` shows INCONCLUSIVE):
            too short, a missing, non-finite or constant channel, another machine or load, a
            channel outside the healthy range or a sample far outside its full range, a
            channel holding one value too long (not at a rail the healthy recordings
            reached), a one-sample outlier of ``u`` / ``speed``, the leak-free sum equation
            (VCA) off by more than its limit in some window (a sensor or model
            inconsistency), an alarm since whose onset the piston moved against the valve's
            or the pump's flow (a reversed command, speed or position sign), line pressures
            nearer the other chamber (EHA: ``pa`` and ``pb`` swapped), an alarm whose leak
            coefficient since the onset is not positive (docs/detect.md 8.4), or (the EHA's
            high-side balance) leak-free windows that read a leak significantly below zero,
            without an alarm or with one within ``CHANCE_SCORE_FACTOR`` of the level
            (``_negative_leak``; docs/detect.md 8.5).
        """
        level = self._check_level(level)
        t, a, b, g, arg = self._scan(recording, "predict", level=level)
        h = self.threshold_ if level is None else level
        smax = float(g.max()) if len(g) else 0.0
        above = np.flatnonzero(g >= h)
        i = int(above[0]) if len(above) else None
        j = None if i is None else self._onset(t, i, int(arg[i]))
        # leak-free: all windows, or those before the first alarm's onset window (or its span)
        # with a window's margin (a leak's first, partly leaking window read -112 standard
        # errors on a benchmark run of 1.63 L/min)
        biased = self._negative_leak(recording, t, smax, h, len(g) if i is None else
                                     min(j, int(arg[i])) - 1, None if i is None else
                                     float(t["end"][i]))
        confidence, floor = self._p_value(smax, t, recording, run=level is not None)
        common = dict(confidence=confidence, confidence_floor=floor, leak_lpm_in_range=None,
                      score_max=smax, threshold=h,
                      onset_method="glr", detector="flow_balance",
                      n_segments=self._n_segments(t, recording), n_windows=len(g),
                      reference_dp_pa=float(self.reference_dp_pa), leak_law=self.leak_law)
        if i is None:
            lpm, start, why = self._detectable(t, recording)
            return FlowBalanceVerdict(leak=False, onset_s=None, alarm_time_s=None, leak_lpm=None,
                                      leak_lpm_interval=None, shift=None, detectable_lpm=lpm,
                                      detectable_from_s=start, detectable_why=why, **common)
        i, j, transient = self._lasting_alarm(t, g, h, arg, i, j, self._load_of(recording))
        if transient:
            common["transient_alarms"] = transient
        # k from the first window wholly after the onset window (the leak starts somewhere
        # inside window j; counting all of it as leaking biases k low by the leak-free part);
        # the mean |phi| over the whole time since the onset (the thesis's mean leak)
        first = j + 1 if j + 1 < len(g) else j
        dur = float(t["duration"][j:].sum())
        be = self._backend()
        load = self._load_of(recording)
        profiled = be.size_profiles_pressure_offset(load)
        if profiled:
            # the leak law's pressure difference carries the transducers' differential zero
            # error, which the healthy recordings cannot identify: profiled out on the leak's
            # own windows (_flow_balance_offset)
            prof = self._offset_profile(recording, t, first, j, dur)
            k, se, mean_phi, offset = (prof.coefficient, prof.coefficient_se,
                                       prof.mean_abs_law, prof.offset_pa)
            offset_range = prof.offset_interval_pa
            interval = tuple(v * LPM_PER_M3S for v in prof.size_interval)
            size_sigma = None  # the growth check is not measured where the offset is profiled
        else:
            size_sigma = self._size_sigma(t, first, load)
            k, se, mean_phi, interval = self._measured_size(t, first, j, dur, size_sigma)
            offset = offset_range = None
        # what the refusal rules below read: the size's own estimate, except where the offset
        # is profiled for the size but poorly determined (the EHA under the spring): there the
        # measured pressures' (a free offset confirmed a unit's model error as a lasting leak;
        # the backends' confirms_with_offset_profile, docs/detect.md 8.5)
        ck, cse, cint = k, se, interval
        if profiled and not be.confirms_with_offset_profile(load):
            ck, cse, _, cint = self._measured_size(t, first, j, dur,
                                                   self._size_sigma(t, first, load))
        onset, alarm = float(t["start"][j]), float(t["end"][i])
        # an onset in the first windows judged: the data cannot tell it from a leak there from
        # the start, so it is only an upper bound
        censored = j < CENSOR_WINDOWS
        common["onset_censored"] = censored
        if censored and j > 0:
            common["onset_why"] = (
                f"the onset lies within the first {CENSOR_WINDOWS} windows judged (from "
                f"{seconds(t['start'][0])} s), where a leak present from the start is placed "
                "as well, and where a recording of another machine than the one fitted alarms "
                "(the data cannot tell them apart: state the machine in the file's metadata or "
                "the map's [file] table; docs/detect.md 8.5)")
        # since the onset, and since the alarm (an onset placed before a sign change dilutes
        # the first; the second needs windows enough to mean anything)
        ratios = [_piston_valve_ratio(t, j)] + (
            [_piston_valve_ratio(t, i)] if len(g) - i >= PISTON_VALVE_MIN_WINDOWS else [])
        ratio = min((x for x in ratios if x is not None), default=None)
        if ratio is not None and ratio < MIN_PISTON_VALVE_RATIO:
            src, signs = (("valve", "command's") if self.system == "vca" else
                          ("pump", "motor speed's"))
            raise RecordingError(
                f"predict: {recording.meta.get('source', '<recording>')}: the test alarmed at "
                f"{seconds(alarm)} s, but after the onset ({seconds(onset)} s) the piston moved "
                "against "
                f"the {src}'s flow: the piston's volume is {ratio:.2f} times the {src} "
                f"model's (1 on a healthy recording; a leak takes part of the {src}'s flow, "
                f"between 0 and 1; below {MIN_PISTON_VALVE_RATIO:g} no leak explains it): the "
                f"{signs} or the position's sign is reversed against the fit runs; no "
                "verdict on a leak")
        end = float(t["end"][-1])
        said = (f"predict: {recording.meta.get('source', '<recording>')}: the test alarmed at "
                f"{seconds(alarm)} s (score {smax:.3g}, level {h:.3g})")
        if ck > 0.0 and not cint[0] > 0.0:  # alarmed, but since the onset no evidence
            # (an audit, 2026-11-28: a healthy file with a seam where the position matched, and
            # a healthy CSV resampled from jittered stamps, read LEAK with intervals below 0)
            late = (f"; {end - alarm:.3g} s of data after the alarm, too few to confirm a leak "
                    "that began there" if end - alarm < LATE_ALARM_S else "")
            raise AlarmNotConfirmed(
                f"{said}, but the leak estimated from the onset ({seconds(onset)} s) to the end "
                "is "
                f"not significantly above zero (its interval {cint[0]:.3g} to "
                f"{cint[1]:.3g} L/min reaches zero){late}: "
                "the alarm is not a leak that lasts (" + _chance_words(smax, h) + "a seam or "
                "discontinuity, resampled time stamps, a sensor fault?); no verdict on a leak",
                alarm, onset)
        if not ck > 0.0 and censored:  # a leak from the start, fitted into the null offset
            raise AlarmAtStart(
                f"{said} with its onset within the first {CENSOR_WINDOWS} windows judged (at or "
                f"before {seconds(onset)} s), but the leak coefficient estimated from there to "
                "the end "
                f"is not positive ({ck:.3g} +- {cse:.2g}): a leak present from the recording's "
                "start is fitted into the per-recording null offset and gain, so the data "
                "cannot size it nor tell it from a disturbance at the start ("
                + _chance_words(smax, h) + "a seam, a sensor fault, or a recording of another "
                "machine than the one fitted, whose valve differs: state the unit as machine in "
                "the map's [file] table or the file's metadata to have it checked?); judge a "
                "recording that starts before the leak (docs/detect.md 8.5); no verdict on a "
                "leak", alarm, onset)
        if not ck > 0.0 and end - alarm < LATE_ALARM_S:  # too few windows after a late alarm
            # (an audit, 2026-11-29: a 0.5 L/min leak from 25 s alarmed at 28.07 s in the
            # segment 0-30 s, k -2.7e-9 +- 1.8e-10, was "a sensor fault?"; that k came from
            # the transducers' zero error, and with it profiled the case reads LEAK)
            raise AlarmNotConfirmed(
                f"{said}, but the leak coefficient estimated from the onset "
                f"({seconds(onset)} s) to "
                f"the end is not positive ({ck:.3g} +- {cse:.2g}); {end - alarm:.3g} s of data "
                "after the alarm, too few to confirm a leak that began there ("
                + _chance_words(smax, h) + "a seam or discontinuity, a sensor fault?); no "
                "verdict on a leak", alarm, onset)
        if not ck > 0.0:  # the test alarmed on a span, but since the onset k is not a leak
            raise RefusedAlarm(
                f"{said}, but the leak coefficient estimated from the onset "
                f"({seconds(onset)} s) to "
                f"the end is not positive ({ck:.3g} +- {cse:.2g}): the flow balance does not "
                "describe this recording well (" + _chance_words(smax, h) + "a sensor fault, "
                "the channels' units, another machine or operation?); no verdict on a leak",
                alarm, onset)
        lpm = k * mean_phi * LPM_PER_M3S
        ptr = be.leak_transition_pa(self._nominal())
        at_ref = k * _leak_law_value(float(self.reference_dp_pa), self.leak_law, ptr) * LPM_PER_M3S
        # the coefficient (and the flow at the reference dp from it) only where it was measured
        # to hold: the VCA without load gives it 0.41-1.24x the truth (docs/detect.md 8.5)
        coef_why = _coefficient_withheld(self.system, load)
        coef = dict(leak_coefficient=None if coef_why else k,
                    leak_coefficient_se=None if coef_why else se,
                    leak_lpm_at_reference=None if coef_why else float(at_ref),
                    pressure_offset_pa=offset)
        no_size = _size_withheld(self.system, load, censored) or biased
        if biased:  # the coefficient is as biased as the size
            coef = dict(leak_coefficient=None, leak_coefficient_se=None,
                        leak_lpm_at_reference=None, pressure_offset_pa=None)
        n_after = len(g) - first
        if self._step_undetermined(t, i, int(arg[i])):
            # the recording locates no onset: said as what is known, an onset at or before the
            # alarm, and no size (an API audit, 2026-11-29: "at or before 2.2 s", present from
            # the start, for a leak from 30 s in no-load runs cut a few seconds after the alarm)
            onset = alarm
            common["onset_censored"] = True
            common["onset_why"] = (
                "the windows after the alarm show no lasting step of the leak coefficient from "
                "any onset (the change-point profile over the whole recording has no positive "
                "Z), so the recording does not locate the onset, only that the leak began "
                "before the alarm (docs/detect.md 8.4, \"Onset\")")
            no_size = no_size or (
                "no size: the recording does not locate the onset (the windows after the alarm "
                "show no lasting step), and a size needs it; a recording that goes on longer "
                "after the alarm is sized")
            coef = dict(leak_coefficient=None, leak_coefficient_se=None,
                        leak_lpm_at_reference=None, pressure_offset_pa=None)
        if not no_size and censored and self.system == "vca" and \
                n_after < CENSORED_SIZE_MIN_WINDOWS:  # (the EHA: OFFSET_MIN_WINDOWS below)
            no_size = (
                f"no size: the onset lies within the first {CENSOR_WINDOWS} windows judged, "
                "where a leak present from the start cannot be told from one that began there, "
                f"and only {n_after} window(s) follow it: a leak present from the start was "
                f"sized within its band with {CENSORED_SIZE_MIN_WINDOWS} or more (the "
                "per-recording null offset and gain are fitted on the leaking windows; "
                "docs/detect.md 8.5); a longer recording is sized")
            coef = dict(leak_coefficient=None, leak_coefficient_se=None,
                        leak_lpm_at_reference=None, pressure_offset_pa=None)
        elif not no_size and self.system == "vca" and n_after < VCA_SIZE_MIN_WINDOWS:
            no_size = (
                f"no size: only {n_after} window(s) follow the onset window before the "
                f"recording ends, and a VCA size needs {VCA_SIZE_MIN_WINDOWS}: from fewer it "
                "missed the truth (a 0.124 L/min leak sized 2.61 [1.58, 20.8] L/min 4 s after "
                "its onset; docs/detect.md 8.5); a recording that goes on longer after the "
                "onset is sized")
            coef = dict(leak_coefficient=None, leak_coefficient_se=None,
                        leak_lpm_at_reference=None, pressure_offset_pa=None)
        elif not no_size and profiled and n_after < OFFSET_MIN_WINDOWS:
            no_size = (
                f"no size: only {n_after} window(s) follow the onset window before the "
                f"recording ends, and the size profiles the chamber transducers' differential "
                f"offset on the leak's own windows, which takes at least {OFFSET_MIN_WINDOWS} "
                "(docs/detect.md 8.5); a recording that goes on longer after the onset is sized")
            coef = dict(leak_coefficient=None, leak_coefficient_se=None,
                        leak_lpm_at_reference=None, pressure_offset_pa=None)
        if no_size:  # no size, so no offset found for it either
            return FlowBalanceVerdict(
                leak=True, onset_s=onset, alarm_time_s=alarm, leak_lpm=None,
                leak_lpm_interval=None, shift=float(k / se), leak_lpm_interval_holds=no_size,
                **{**coef, "pressure_offset_pa": None}, **common)
        # the model error the statistical interval does not hold: the band measured on
        # virtual machines (_flow_balance_size; docs/detect.md 8.5, "Size interval")
        statistical = (float(interval[0]), float(interval[1]))
        band = size_band(self.system, load, float(lpm), statistical)
        interval = (min(statistical[0], band[0]), max(statistical[1], band[1]))
        holds = (f"{be.size_interval_holds(offset, offset_range)} (that part alone: "
                 f"{statistical[0]:.3g}-{statistical[1]:.3g} L/min), "
                 f"{band_words(self.system, load, band)}")
        n_units = (getattr(self, "operation_", None) or {}).get("n_machines", 0)
        if n_units > 1:
            holds += (f"; measured with each machine's own fit, while this detector was fitted "
                      f"on {n_units} machines: with such fleet fits {FLEET_BAND_MISSES[0]} of "
                      f"{FLEET_BAND_MISSES[1]} benchmark runs fell outside it, so it is no "
                      "promise here")
        holds += (f"; interval_level {float(self.interval_level):g} is the level of the "
                  "statistical part only, which knows no model error: the band's probability "
                  "is what the whole interval is promised to hold")
        growth = (self._growth(t, first, size_sigma)
                  if load in GROWTH_MEASURED[self.system] and size_sigma is not None else None)
        recent = None
        if growth is not None and growth[0] >= GROWTH_RATIO and growth[1] >= GROWTH_Z:
            recent = growth[2] * float(t["phi_abs"][-RECENT_WINDOWS:].sum()) / float(
                t["duration"][-RECENT_WINDOWS:].sum()) * LPM_PER_M3S
            span = float(t["end"][-1] - t["start"][-RECENT_WINDOWS])
            holds += (f"; the leak is growing: its coefficient on the second half of the "
                      f"time since the onset is {growth[0]:.2f}x that on the first (step "
                      f"leaks: 0.98-1.03x), and over the last {span:.3g} s it leaked about "
                      f"{recent:.3g} L/min; the size is its mean since the onset, and the band "
                      "was measured on step leaks, so for a growing leak it is no promise (on "
                      "48 simulated ramps under the spring it held 45)")
        if coef_why:
            holds += f"; {coef_why}"
        return FlowBalanceVerdict(
            leak=True, onset_s=onset, alarm_time_s=alarm,
            leak_lpm=float(lpm), leak_lpm_interval=(float(interval[0]), float(interval[1])),
            shift=float(k / se), leak_lpm_interval_holds=holds,
            leak_lpm_interval_statistical=statistical,
            recent_leak_lpm=None if recent is None else float(recent), **coef, **common)

    def _negative_leak(self, rec, t: dict, smax: float, h: float, stop: int,
                       alarm: float | None) -> str | None:
        """Refuse, or say why not to size, a recording whose leak-free windows read a leak
        significantly below zero.

        Where the backend states a limit (``negative_leak_limit``: the EHA's high-side
        balance, ``NEGATIVE_LEAK_Z``; audit F2, docs/detect.md 8.5), the leak coefficient on
        the leak-free windows ``0 .. stop - 1`` (``alarm``: the first alarm's time, None
        without one), in standard errors: below the limit, the healthy model does not describe
        this recording's operation (a lower drive or load than the fit's reads a negative leak
        there). Without an alarm, or with scores within :data:`CHANCE_SCORE_FACTOR` of the
        level ``h`` (at 0.5 V such runs of a healthy unit crossed), the recording is refused
        (:class:`~leakdiag.io.recording.RecordingError`); a stronger alarm stands, as the bias
        works against it, but its size would be low: the words why it is not given are
        returned. None when the windows read no such leak.
        """
        zlim = self._backend().negative_leak_limit(self.model_)
        if zlim is None or stop < self._MIN_HISTORY:
            return None
        n = len(t["phi"])
        part = {key: (v[:stop] if isinstance(v, np.ndarray) and v.shape[:1] == (n,) else v)
                for key, v in t.items()}
        k, se = self._estimate(part, 0)
        if not (se > 0.0 and k / se < zlim):
            return None
        lpm = k * float(part["phi_abs"].sum()) / float(part["duration"].sum()) * LPM_PER_M3S
        before = ("of the whole recording (no alarm)" if alarm is None else
                  f"before the onset of the test's alarm at {seconds(alarm)} s")
        read = (f"the flow balance reads a leak of {lpm:.3g} L/min on the {stop} windows "
                f"{before} ({k / se:.3g} standard errors, below {zlim:g}): no leak is negative, "
                "so the healthy model does not describe this recording's operation; its drain "
                "terms were identified at the healthy recordings' operation and do not carry "
                "over to a lower drive or load (docs/detect.md 8.5)")
        if alarm is None or smax <= CHANCE_SCORE_FACTOR * h:
            what = ("NO LEAK would not mean what it says" if alarm is None else
                    f"the alarm (score {smax:.3g}, level {h:.3g}) is within "
                    f"{CHANCE_SCORE_FACTOR:g}x the level, as such runs crossed")
            raise RecordingError(
                f"predict: {rec.meta.get('source', '<recording>')}: {read}. {what}; fit on "
                "healthy recordings made at this operation. No verdict on a leak")
        return (f"no size: {read}; the alarm stands (score {smax:.3g}, over "
                f"{CHANCE_SCORE_FACTOR:g}x the level {h:.3g}: the bias works against it), but "
                "a size would be low; fit on healthy recordings made at this operation")

    def _detectable(self, t: dict, rec) -> tuple[float | None, float | None, str]:
        """The smallest step leak over the last span that the test would have seen (NO LEAK).

        The step starts at the last ``max_span_s`` judged (the GLR's longest span ending at the
        last window; no earlier than its first testable window); its coefficient is
        ``(h + z) / sqrt(I)`` (:func:`step_information`, ``z`` the
        :data:`DETECTABLE_POWER` quantile), its mean flow that coefficient times the mean
        ``|phi|`` over the span, times :data:`DETECTABLE_FACTOR` (measured on virtual
        machines).
        """
        n = len(t["phi"])
        first = max(self._MIN_HISTORY, n - self._max_span())
        start = float(t["start"][first]) if first < n else None
        load = self._load_of(rec)
        keys = [(self.system, load)] if (self.system, load) in DETECTABLE_FACTOR else \
            [k for k in DETECTABLE_FACTOR if k[0] == self.system]  # unknown load: the larger
        factor = max(DETECTABLE_FACTOR[k] for k in keys)
        hit = min(DETECTABLE_RUNS[k][0] for k in keys)
        runs = min(DETECTABLE_RUNS[k][1] for k in keys)
        info = step_information(t["phi"], 1.0 / self._sigma(t) ** 2, t["nuisance"], first) \
            if first < n else 0.0
        dur = float(t["duration"][first:].sum()) if first < n else 0.0
        if not info > 0.0 or not dur > 0.0:
            return None, start, ("the smallest leak this test would have seen is not stated: "
                                 "the windows judged do not determine a leak's step")
        k = (float(self.threshold_) + float(norm.ppf(DETECTABLE_POWER))) / math.sqrt(info)
        lpm = factor * k * float(t["phi_abs"][first:].sum()) / dur * LPM_PER_M3S
        span = float(t["end"][-1]) - start
        own = min(keys, key=lambda key: DETECTABLE_MODEL_RUNS[key][0]
                  / DETECTABLE_MODEL_RUNS[key][1])  # the worst measured
        basis = ("its error model's size" if factor == 1.0 else
                 f"{factor:g} times its error model's size (on the {self.system.upper()} "
                 f"{_load_words(load)} the model's own size alarmed in as few as "
                 f"{DETECTABLE_MODEL_RUNS[own][0]} of {DETECTABLE_MODEL_RUNS[own][1]} runs)")
        return lpm, start, (
            f"a step leak of {lpm:.3g} L/min or more from {seconds(start)} s (the last "
            f"{span:.3g} s "
            f"judged) would have alarmed with probability about {DETECTABLE_POWER:g}: "
            f"{basis}; on 8 virtual machines {hit} of {runs} such leaks alarmed (5 runs "
            "each, so nearer 8 independent trials; docs/detect.md 8.5). The test looks at spans of up to "
            f"{self.max_span_s:g} s anywhere in the run, so a leak that began earlier needs "
            "about the same size; a leak present from the start is not covered by this figure")

    def _load_of(self, rec) -> str | None:
        """The recording's load (its metadata, else the healthy recordings'), or None."""
        load = load_name(rec.meta.get("load"))
        if load is None:
            load = (getattr(self, "operation_", None) or {}).get("load")
        return None if load is None else str(load)

    def _lasting_alarm(self, t: dict, g: np.ndarray, h: float, arg: np.ndarray, i: int,
                       j: int, load) -> tuple[int, int, str]:
        """The alarm episode that starts the leak: ``(alarm window, onset window, words on the
        first alarm when it was passed over)``.

        A healthy stretch can cross the level and fall back (a false alarm) before a leak
        begins later in the same recording; the leak estimated from the false alarm's onset to
        the end is then significant because of the later leak, and the verdict took the false
        alarm's time and onset and a size diluted over the leak-free time (run-level study,
        2026-11-28: 11 of 80 leaks from 900 s in 30-min runs placed at 2-710 s, sized
        0.012-0.018 L/min for 0.02). The candidates are the first alarm's onset ``j`` and the
        onset of each later episode (a run of windows at or above ``h`` after one below it;
        :meth:`_onset`) that lies at least :data:`TRANSIENT_MIN_WINDOWS` after the previous
        candidate (nearer ones are the same change, placed twice); the one where a single
        step of the leak coefficient explains the whole recording best (the largest
        :math:`Z_j` of :func:`~leakdiag.detect._flow_balance_search.change_point` over all
        windows, nuisance as for the first alarm), if better than the first alarm's onset, is
        the leak's start when it is a step up: the leak coefficient from it on at least
        :data:`TRANSIENT_RATIO` times that on the windows between the two onsets and above it
        by :data:`GROWTH_Z` standard errors (nuisance profiled over the recording); else the
        first alarm stays. A leak that dips below the level and crosses again has about one
        coefficient on both sides and keeps its first alarm (its profile can be flat enough
        that a later onset edges out its own: Z 21.6 against 20.9 on a 30-min no-load run);
        a single episode (no dip) is never moved. Both rigs (the EHA since session 19: its
        window terms with the healthy weights; its size is then profiled from the new onset).
        """
        starts = np.flatnonzero(np.diff((g >= h).astype(np.int8)) == 1) + 1
        later = []  # onsets nearer than TRANSIENT_MIN_WINDOWS to the last kept: one change
        for i2 in starts[starts > i]:
            j2 = self._onset(t, int(i2), int(arg[i2]))
            if j2 - (later[-1][1] if later else j) >= TRANSIENT_MIN_WINDOWS:
                later.append((int(i2), int(j2)))
        if not later:
            return i, j, ""
        z = self._onset_profile(t, i, int(arg[i]), last=len(g) - 1)[1]
        best = max(later, key=lambda c: z[c[1]] if np.isfinite(z[c[1]]) else -np.inf)
        if not (np.isfinite(z[best[1]]) and (not np.isfinite(z[j]) or z[best[1]] > z[j])):
            return i, j, ""
        i2, j2 = best
        # and no leak between the two onsets: the coefficient from j2 on is a step up from
        # that between them, not the same leak (on long no-load runs a true leak's profile is
        # flat enough that a later onset can edge out its own: Z 21.6 against 20.9)
        w = np.arange(len(g))
        c, var = self._two_part_fit(t, (w > j) & (w < j2), w > j2,
                                    self._size_sigma(t, j + 1, load))
        if not (var > 0.0 and c[1] >= TRANSIENT_RATIO * max(c[0], 0.0)
                and c[1] - c[0] >= GROWTH_Z * math.sqrt(var)):
            return i, j, ""
        between = (f"{c[1] / c[0]:.3g}x that between the two onsets" if c[0] > 0.0 else
                   "not above zero between the two onsets")
        return i2, j2, (
            f"at {seconds(t['end'][i])} s (onset {seconds(t['start'][j])} s, score "
            f"{float(g[i:i2].max()):.3g}) it was not this leak's start: a step of the leak "
            f"coefficient at {seconds(t['start'][j2])} s explains the recording better (Z "
            f"{z[j2]:.3g} against {z[j]:.3g} at the earlier onset), and the coefficient from "
            f"there on is {between}")

    def _onset(self, t: dict, i: int, j_span: int) -> int:
        """Onset window of the first alarm at window ``i`` (``j_span``: the GLR's best span).

        The nuisance (null offset, its drift, flow gain) is fitted on the windows before the
        GLR's best span, which the test itself found leak-free; the onset is then the
        maximum-likelihood step of ``k`` in the residuals without it, over all windows (also
        those after the alarm), among the windows up to the alarm
        (:func:`~leakdiag.detect._flow_balance_search.change_point`). The span alone ended at
        its ``max_span_s`` limit without load (onset 33 s for a leak from 60 s); a step with
        the nuisance profiled over the whole recording let the nuisance absorb the leak and
        put the onset at the first windows (docs/detect.md 8.4, "Onset").
        """
        return self._onset_profile(t, i, j_span)[0]

    def _onset_profile(self, t: dict, i: int, j_span: int,
                       last: int | None = None) -> tuple[int, np.ndarray]:
        """``_onset``'s window and the change-point profile :math:`Z_j`, ``j = 0..i`` (to
        ``last`` when given; the nuisance as for the alarm at ``i``)."""
        r, nu, w = t["residual"], t["nuisance"], 1.0 / self._sigma(t) ** 2
        p = nu.shape[1]
        # the nuisance is fitted on the windows before the span (at least p + 1 of them),
        # except when the test alarmed within the first 2p + 2 windows with its span from the
        # first p: then those windows are the alarm's own evidence (a leak there from the
        # start), and the step is searched without the per-recording correction
        if p and (j_span > p or i > 2 * p + 1):
            pre = slice(0, min(len(r), max(j_span, p + 1)))
            sw = np.sqrt(w[pre])
            beta = np.linalg.lstsq(nu[pre] * sw[:, None], r[pre] * sw, rcond=None)[0]
            r = r - nu @ beta
        j, z = change_point(t["phi"], r, w, nu[:, :0], last=i if last is None else last)
        if last is None and not np.any(z > 0) and i + 1 < len(r):
            # no positive step fits the whole recording: the windows after the alarm pull every
            # candidate's coefficient below zero, and the argmax of negative Z_j is the first
            # window (an API audit, 2026-11-29: no-load runs cut a few seconds after the alarm
            # read "at or before 2.2 s", present from the start, for a leak from 30 s): the
            # step is searched on the test's own evidence, the windows up to the alarm
            # and, when none fits them either, the first window of the GLR's best span, the
            # test's own onset (_step_undetermined tells predict, which gives no size then)
            j2, z2 = change_point(t["phi"][:i + 1], r[:i + 1], w[:i + 1], nu[:i + 1, :0],
                                  last=i)
            j = j2 if np.any(z2 > 0) else min(max(j_span, 0), i)
        return int(j), z

    def _step_undetermined(self, t: dict, i: int, j_span: int) -> bool:
        """Whether no positive step of the leak coefficient fits the whole recording for the
        alarm at window ``i`` (every :math:`Z_j` of :meth:`_onset_profile` at or below zero):
        its onset then rests on the windows up to the alarm only."""
        return not np.any(self._onset_profile(t, i, j_span)[1] > 0)

    def _measured_size(self, t: dict, first: int, j: int, dur: float, sigma: np.ndarray):
        """Leak coefficient, its standard error, mean ``|phi|`` since window ``j`` and the
        ``interval_level`` size interval (L/min) on the measured pressures (no offset profiled;
        the coefficient from window ``first`` on, weights ``1 / sigma^2``)."""
        k, se = self._estimate(t, first, sigma=sigma)
        mean_phi = float(t["phi_abs"][j:].sum()) / dur
        zq = float(norm.ppf(0.5 + self.interval_level / 2))
        return k, se, mean_phi, ((k - zq * se) * mean_phi * LPM_PER_M3S,
                                 (k + zq * se) * mean_phi * LPM_PER_M3S)

    def _offset_profile(self, rec, t: dict, first: int, j: int, dur: float):
        """Leak coefficient and mean ``|phi|`` since window ``j`` with the differential
        pressure offset profiled (:func:`~leakdiag.detect._flow_balance_offset.profile_offset`;
        the coefficient from window ``first`` on), on the balance terms ``t`` of ``rec`` that
        the scan judged (on the VCA with the null drift it refitted after an alarm, if any:
        ``_causal_drift``; until session 29 the terms were recomputed here with the
        whole-recording drift fit). The offset moves the leak-law terms only
        (:func:`~leakdiag.detect._flow_balance_offset.leak_law_at`): the leak's regressor and
        the healthy baseline leak subtracted from the residual; the valve or pump flows, the
        nuisance and the error model stay as the healthy identification calibrated them on
        the measured pressures. On the EHA, whose other terms do not depend on the pressures'
        zero, this is the balance of a recording with ``p1`` lowered by the offset."""
        be = self._backend()
        law = leak_law_at(rec, t["start"], t["end"], be.DP_SMOOTHING_S,
                          be.leak_transition_pa(self._nominal()), self.leak_law == "laminar")
        kb = float(self.model_.baseline_leak_coefficient)

        def evaluate(delta: float) -> tuple[float, float, float]:
            phi, phi_abs = law(delta)
            shifted = {**t, "phi": phi, "residual": t["residual"] - kb * (phi - t["phi"])}
            k, se = self._estimate(shifted, first)
            return k, se, float(phi_abs[j:].sum()) / dur

        return profile_offset(evaluate, self.interval_level)

    def segments_spanned(self, n_samples: int, sample_rate_hz: float) -> float | None:
        """Healthy segments a recording of ``n_samples`` covers, as :meth:`predict` counts them.

        With a fixed ``segment_s``, the monitored time ``n_samples / sample_rate_hz -
        burn_in_s`` over it; otherwise the monitored windows (whole windows after the burn-in,
        as the balance cuts them) over ``segment_windows_``, the shortest healthy recording's.
        A recording as long as the shortest healthy one covers exactly 1 (its last partial
        window is not monitored, so its time after the burn-in is a window longer than the
        segment). Fractional; :func:`leakdiag.detect.decision.judge_run` compares it with 1.

        Parameters
        ----------
        n_samples : int
            Samples of the recording.
        sample_rate_hz : float
            Its sample rate, Hz.

        Returns
        -------
        float or None
            None for a detector saved before segments were recorded.
        """
        self._check_fitted()
        seg = self._fixed_segment()
        if seg is not None:
            return max(n_samples / float(sample_rate_hz) - float(self.burn_in_s), 0.0) / seg
        per = getattr(self, "segment_windows_", None)
        if per is None:
            return None
        w = int(round(self.window_s * float(sample_rate_hz)))
        n_win = max(0, (int(n_samples) - 1) // max(w, 1))
        skip = int(math.ceil(self.burn_in_s / self.window_s - 1e-9))
        return max(0, n_win - min(skip, n_win)) / float(per)

    def _n_segments(self, t: dict, rec) -> int | None:
        """Healthy segments the judged span covers (at least 1): whole windows per
        ``segment_windows_``, or the monitored time per ``segment_s`` (None for a detector
        saved before segments were recorded)."""
        seg = self._fixed_segment()
        per = getattr(self, "segment_windows_", None)
        if seg is None and per is None:
            return None
        # one count for the p-value, the run level and the decision (count_segments)
        return count_segments(len(t["end"]) / per if seg is None else
                              (rec.duration - float(self.burn_in_s)) / seg)

    def _p_value(self, smax: float, t: dict, rec, run: bool = False) -> tuple[float, bool]:
        """Probability that healthy operation of this span scores at least ``smax``.

        Conformal basis: ``m (1 + #{maxima >= smax}) / (n + 1)`` over the ``m`` segments the
        span covers. Model-based level: ``1 - exp(-rate(smax) * hours)``, the chance of at
        least one healthy alarm episode at level ``smax`` (Poisson episodes, rate from the
        bootstrap null, at least one episode in its ``simulated_hours``: the null's
        resolution). Small = evidence of a leak, as ``Verdict.confidence`` everywhere.
        ``run``: judged at a :meth:`run_level`, whose basis is the conformal one only when
        the healthy maxima hold the run (:meth:`_run_rank`). Returns ``(p, at its floor)``,
        the second True when the p-value is the reference's resolution: the conformal one's
        (``ThresholdBasis.at_floor``), or on the model level the null's one episode in its
        simulated hours (an API audit, 2026-11-30: every leak from 0.002 to 0.5 L/min read
        p = 8.12e-05, that floor, with the floor flag False).
        """
        basis = getattr(self, "threshold_basis_", None)  # None: a file saved before bases
        n_win = len(t["end"])
        m = self._n_segments(t, rec)
        if basis is not None and basis.supported and (not run or self._run_rank(m) >= 1):
            return basis.p_value(smax, m), basis.at_floor(smax)
        hours = n_win * float(self.window_s) / 3600.0
        th = self.alarm_threshold_
        # no smaller than the Monte-Carlo null resolves (one episode in its simulated hours):
        # beyond it the log-linear tail is a model, which gave p-values of 1e-286 and 0; at a
        # run level, the fitted tail the level rests on, to the same limit (run_level)
        model, floor = ((self._model_run_tail()[1] * th.tail_rate(smax),
                         1.0 / (RUN_LEVEL_MAX_EXTRAPOLATION * th.simulated_hours))
                        if run else (th.rate_at(smax), 1.0 / th.simulated_hours))
        return float(-np.expm1(-max(model, floor) * hours)), bool(model <= floor)

    def segment_maxima(self, recordings) -> np.ndarray:
        """GLR maxima of every complete segment of recordings (``segment_s`` of monitored
        time, or ``segment_windows_`` windows when ``segment_s`` is None).

        Use it on healthy runs **not** given to :meth:`fit` to build a
        :class:`~leakdiag.detect.threshold.ReferenceMaxima` for other units (``drift=0``,
        ``direction=self.reference_direction()``, ``burn_in_s=self.burn_in_s``). The
        recordings pass the same checks as in :meth:`predict` except the sum-equation gate
        (a refused healthy run would stop the benchmark's reference maxima of every unit).

        Parameters
        ----------
        recordings : sequence of Recording
            Healthy recordings of the unit this detector was fitted on.

        Returns
        -------
        numpy.ndarray
            One maximum per complete segment, recordings in order.
        """
        self._check_fitted()
        recs = [recordings] if hasattr(recordings, "channels") else list(recordings)
        out = []
        for r in recs:
            t, _, _, g, _ = self._scan(r, "segment_maxima", consistency=False)
            out.append(self._maxima(g, t, r))
        return np.concatenate(out) if out else np.zeros(0)

    def _estimate(self, t: dict, j: int, sigma=None) -> tuple[float, float]:
        """Leak coefficient (and its standard error) from window ``j`` on, nuisance profiled
        over the whole recording (weighted least squares, weights ``1 / sigma^2``; default
        the healthy error model's ``_sigma``)."""
        coef, cov = self._wls(t, j, self._sigma(t) if sigma is None else sigma)
        return float(coef[0]), float(math.sqrt(max(cov[0, 0], 0.0)))

    @staticmethod
    def _wls(t: dict, j: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``[k, nuisance...]`` and their covariance: residuals on ``phi 1(w >= j)`` and the
        nuisance, weights ``1 / s^2``."""
        ind = np.zeros(len(s))
        ind[j:] = 1.0
        x = np.column_stack([t["phi"] * ind, t["nuisance"]]) / s[:, None]
        y = t["residual"] / s
        cov = np.linalg.pinv(x.T @ x)
        return cov @ (x.T @ y), cov

    @staticmethod
    def _two_part_fit(t: dict, first: np.ndarray, second: np.ndarray,
                      s: np.ndarray) -> tuple[np.ndarray, float]:
        """Leak coefficients on two sets of windows (masks ``first``, ``second``) with the
        nuisance profiled over the recording, weights ``1 / s^2``: ``(coefficients, variance
        of their difference)`` (``coefficients[:2]`` the two parts, then the nuisance)."""
        x = np.column_stack([np.where(first, t["phi"], 0.0), np.where(second, t["phi"], 0.0),
                             t["nuisance"]]) / s[:, None]
        cov = np.linalg.pinv(x.T @ x)
        c = cov @ (x.T @ (t["residual"] / s))
        return c, float(cov[0, 0] + cov[1, 1] - 2.0 * cov[0, 1])

    def _growth(self, t: dict, j: int, s: np.ndarray) -> tuple[float, float, float] | None:
        """Is the leak since window ``j`` constant? ``(ratio, z, recent k)``: the coefficient
        on the second half of the windows since ``j`` over that on the first, the z of their
        difference, and the coefficient on the last ``RECENT_WINDOWS`` windows (all with the
        nuisance profiled over the recording, weights ``1 / s^2``). None with fewer than
        ``2 RECENT_WINDOWS`` windows since ``j`` or a first half without a positive
        coefficient."""
        n = len(s)
        if n - j < 2 * RECENT_WINDOWS:
            return None
        w = np.arange(n)
        mid = j + (n - j) // 2
        c, var = self._two_part_fit(t, (w >= j) & (w < mid), w >= mid, s)
        if not (c[0] > 0.0 and var > 0.0):
            return None
        r, _ = self._two_part_fit(t, w >= j, w >= n - RECENT_WINDOWS, s)
        return float(c[1] / c[0]), float((c[1] - c[0]) / math.sqrt(var)), float(r[0] + r[1])

    def _size_sigma(self, t: dict, j: int, load: str | None = "spring") -> np.ndarray:
        """Window standard deviations for the size from window ``j`` on: the error model
        evaluated at the valve's *leak-free* end-point flows (the VCA under a load of
        :data:`LEAK_FREE_WEIGHTS`), else ``_sigma``.

        The error model's end-point term ``c2 (Q_a^2 + Q_b^2)`` (timing errors of the valve
        model) reads the valve flow at a window's first and last sample, which with a leak
        includes what the servo delivers to feed it. Left in, it weighted the windows of a
        growing leak by its own size: on a 0.2 L/min ramp (unit 17, spring) sigma_w rose from
        1.5e-8 to 3.8e-8 m^3 and the size came out 0.59-0.71x the mean leak after the onset.
        Here the weighted fit is made once with the healthy weights, each window's leak flow
        since ``j`` (its profiled residual over its duration) is taken off both end-point
        flows, and the error model is evaluated there; ``predict`` refits the coefficient
        with these weights (one pass: a second moved the ramp's size by about 1 %). Only the
        VCA carries the end-point flows; the EHA's pump flow is measured, and its size keeps
        the healthy weights. Without load (or under an unknown one) the VCA keeps them too:
        there the leak-free weights moved delayed step leaks of 0.2 L/min from a median of
        0.82-1.03x the truth to 0.62x, and the size band was measured with the healthy
        weights (docs/detect.md 8.5, "What the verdict says beyond LEAK / NO LEAK")."""
        edges = t.get("edge_flows")
        if edges is None or load not in LEAK_FREE_WEIGHTS.get(self.system, ()):
            return self._sigma(t)
        coef, _ = self._wls(t, j, self._sigma(t))
        q = np.zeros(len(edges))
        profiled = t["residual"] - t["nuisance"] @ coef[1:]
        q[j:] = profiled[j:] / t["duration"][j:]  # the window's mean leak flow (m^3/s)
        x = self._error_regressors(t).copy()
        x[:, 2] = ((edges - q[:, None]) ** 2).sum(axis=1)
        return np.sqrt(x @ self.error_model_) * self.dispersion_

    def shift(self, recording, onset_s: float) -> float:
        """Standardised leak-coefficient estimate on the windows starting at or after ``onset_s``.

        Parameters
        ----------
        recording : Recording
            Recording of the fitted machine.
        onset_s : float
            Onset time in s.

        Returns
        -------
        float
            ``k / se(k)`` with the nuisance profiled; NaN if no window starts after ``onset_s``.
        """
        t, _, _, _, _ = self._scan(recording, "shift")
        after = np.flatnonzero(t["start"] >= onset_s)
        if len(after) == 0:
            return float("nan")
        k, se = self._estimate(t, int(after[0]))
        return k / se if se > 0 else float("nan")

    def calibrate(self, recordings, level: float = 0.9, validity=None) -> "FlowBalanceDetector":
        """No-op: the flow balance sizes a leak from physics, not from leaking examples.

        Parameters
        ----------
        recordings : list of Recording
            Ignored.
        level : float, default 0.9
            Ignored.
        validity : dict, optional
            Ignored.

        Returns
        -------
        FlowBalanceDetector
            ``self`` unchanged (present so that the benchmark can call it on every method).
        """
        return self
