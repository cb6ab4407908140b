"""Live state of monitored actuators, updated off the monitor's path and read by the web page.

:class:`~leakdiag.dashboard.hooks.MonitorHooks` calls :meth:`LiveBoard.update` from its worker
thread with the windows of every chunk queued since its last take (any split of the windows
into calls gives the same state); the update appends to bounded buffers under a lock (no JSON,
no I/O). The web server reads :meth:`LiveBoard.snapshot` at a few Hz and sends it on.

State of an actuator (decisions, see ``docs/operations.md``):

* ``WAITING`` before the first window, then ``OK`` or ``ALARM`` as the detector says; without a
  detector ``NO DETECTOR``. ``BLIND`` instead of ``OK`` while the latest scored windows are a
  run of undefined feature values longer than the detector's healthy limit
  (:class:`~leakdiag.stream.blind.BlindSpans`: a stuck sensor; the CUSUM cannot move, so OK
  would say nothing).
* **Alarm time**: time of the first window in alarm (as :class:`leakdiag.detect.base.Verdict`).
  A CUSUM near its threshold may dip below it and cross again; while its excursion has not
  returned to 0 this is the same alarm *episode*: the state goes OK and ALARM again (and the
  events list it), but the alarm time, onset and the stored alarm row stay those of the episode.
* **Onset estimate**: the start of the CUSUM excursion that raised the alarm (the ``cusum``
  onset of :func:`leakdiag.detect.onset.cusum_onset`, taken online: the first window after the
  branch was last 0), at the middle of that window as in ``Detector.predict``. The offline
  ``leakdiag detect`` may refine it with change points; the live page does not. When that
  excursion began at the first window scored (the leak was there when monitoring started, or
  within the burn-in), the onset is only an upper bound: ``onset_censored`` (the page shows
  "at or before"), as ``Verdict.onset_censored``.
* **Leak size**: with a calibrated detector (``calibration_``), ``calibration_.estimate(shift)``
  with ``shift`` the mean standardised feature of the windows that start at or after the onset
  minus that of the windows that end before it (as ``Detector.shift``); it is updated with every
  chunk after the alarm.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from typing import Any

import numpy as np

from leakdiag.stream.blind import BlindSpans

__all__ = ["ActuatorLive", "LiveBoard"]

#: Points of each trace kept for the page.
MAX_POINTS = 3000
#: Recent events kept for the page.
MAX_EVENTS = 50
#: Standardised feature values kept for the leak-size "before" mean (about 2 days at 5 windows/s;
#: older blocks are dropped, so on longer streams "before" covers the last MAX_HISTORY windows).
MAX_HISTORY = 1_000_000


def _num(v) -> float | None:
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


#: What :class:`ActuatorLive` reads of a scorer, and of its ``detector``: a picklable copy
#: (:class:`leakdiag.dashboard.recorder.ScorerFacts`, the monitor's sidecar) carries these.
SCORER_FACTS = ("threshold_", "mean_", "std_", "segment_s_", "segment_origin_s_")
DETECTOR_FACTS = ("calibration_", "nan_span_healthy_s_")


class ActuatorLive:
    """Bounded live state of one actuator (see the module docstring).

    Parameters
    ----------
    name : str
        Actuator name.
    feature : str
        Feature label.
    scorer : object, optional
        The monitor's scorer (``threshold_``; a
        :class:`~leakdiag.stream.detector.DetectorScorer` also gives ``branches_``, ``mean_``,
        ``std_`` and the detector's ``calibration_``).
    window_s : float, default 0.0
        Window span ``(N - 1) / sample_rate`` in s (window start = time - window_s).
    """

    def __init__(self, name: str, feature: str, scorer: Any = None, window_s: float = 0.0):
        self.name, self.feature, self.scorer = name, feature, scorer
        self.window_s = float(window_s)
        self.threshold = _num(getattr(scorer, "threshold_", None))
        det = getattr(scorer, "detector", None)
        self.calibration = getattr(det, "calibration_", None)
        self.mean, self.std = getattr(scorer, "mean_", None), getattr(scorer, "std_", None)
        # what is read above and below: the facts a sidecar's copy must carry (ScorerFacts)
        self.time: deque = deque(maxlen=MAX_POINTS)
        self.value: deque = deque(maxlen=MAX_POINTS)
        self.score: deque = deque(maxlen=MAX_POINTS)
        self.events: deque = deque(maxlen=MAX_EVENTS)
        self.n_events_total = 0
        self.n_windows = 0
        self.alarm_on = False
        self.alarm_time_s = self.onset_s = None
        self.onset_censored = False
        self._first_scored = None  # time of the first window judged (scored and defined)
        # None: fitted before the healthy span was recorded (no BLIND state)
        self._healthy_span_s = getattr(det, "nan_span_healthy_s_", None)
        # the scorer's CUSUM restarts at healthy-segment boundaries unless in alarm: where it
        # dropped an excursion, a later one starts (as Detector.predict dates its onset)
        self._seg_s = getattr(scorer, "segment_s_", None)
        self._seg0 = getattr(scorer, "segment_origin_s_", None)
        self._prev_seg, self._prev_stat = None, 0.0
        self._restarts: deque = deque(maxlen=MAX_EVENTS)
        self._blind = None  # BlindSpans, made when the window step is known
        self._blind_wait: list = []  # scored windows taken before that (a 1-window chunk)
        self.leak: tuple | None = None
        self._exc_start = [None, None]  # (time, start) of the first window of each excursion
        self._episode_key = None  # (branch, excursion start) of the current alarm episode
        self.episode = 0
        self._before = float("nan")
        self._hist_t: deque = deque()  # blocks of (time, z) of scored windows, bounded
        self._hist_z: deque = deque()
        self._n_hist = 0
        self._after = [0.0, 0]
        self.received_wall = None
        self.done = False

    @property
    def leak_interval(self) -> str | None:
        """What the leak size's bracket is, in words (``"90 % prediction interval"``, the
        calibration's level), None without a calibration."""
        level = getattr(self.calibration, "level", None)
        if self.calibration is None:
            return None
        return "prediction interval" if level is None else \
            f"{float(level) * 100:g} % prediction interval"

    @property
    def episode_branch(self) -> int | None:
        """The CUSUM branch (0: S+, 1: S-) that raised the latest alarm episode, or None."""
        return None if self._episode_key is None else int(self._episode_key[0])

    def _z(self, v: np.ndarray, s: np.ndarray) -> np.ndarray:
        if self.mean is None or not self.std:
            return np.full(len(v), np.nan)
        z = (v - float(self.mean)) / float(self.std)
        return np.where(np.isfinite(s), z, np.nan)

    def update(self, t: np.ndarray, v: np.ndarray, s: np.ndarray | None,
               a: np.ndarray | None, received_wall: float, branches: tuple | None = None) -> None:
        """Take the windows of one or more consecutive chunks.

        Parameters
        ----------
        t, v : numpy.ndarray
            Window times (s) and feature values.
        s, a : numpy.ndarray or None
            Detector scores and alarms (None without a detector).
        received_wall : float
            Wall-clock time (``time.time()``) at which the last of these chunks arrived.
        branches : tuple of numpy.ndarray, optional
            CUSUM branches (S+, S-) of these windows; default: the scorer's ``branches_``
            (those of its last block), else the score itself.
        """
        self.received_wall = received_wall
        if not len(t):
            return
        self.n_windows += len(t)
        self.time.extend(t[-MAX_POINTS:].tolist())  # the deques keep the last MAX_POINTS
        self.value.extend(v[-MAX_POINTS:].tolist())
        if s is None:
            return
        self.score.extend(s[-MAX_POINTS:].tolist())
        if branches is None:
            branches = getattr(self.scorer, "branches_", None)
        if branches is None or len(branches[0]) != len(s):
            branches = (s, s)
        if self._first_scored is None:  # the first window judged: scored, feature defined
            scored = np.flatnonzero((np.isfinite(branches[0]) | np.isfinite(branches[1]))
                                    & np.isfinite(v))
            if len(scored):
                self._first_scored = float(t[scored[0]])
        if self._healthy_span_s is not None:  # undefined scored windows (no burn-in)
            scored = np.isfinite(s)
            if self._blind is None:  # the step is known from the second window on
                self._blind_wait.append((t[scored], v[scored]))
                if len(self.time) > 1:
                    self._blind = BlindSpans(self._healthy_span_s, self.time[1] - self.time[0])
                    for bt, bv in self._blind_wait:
                        self._blind.add_block(bt, bv)
                    self._blind_wait = []
            else:
                self._blind.add_block(t[scored], v[scored])
        if self._seg_s is not None and self._seg0 is not None:
            self._note_restarts(t, s, branches)
        z = self._z(v, s)
        fin = np.isfinite(z)
        self._hist_t.append(t[fin])
        self._hist_z.append(z[fin])
        self._n_hist += int(fin.sum())
        while self._n_hist - len(self._hist_t[0]) >= MAX_HISTORY:  # bounded memory
            self._n_hist -= len(self._hist_t.popleft())
            self._hist_z.popleft()
        onset_before = self.onset_s
        new_episode = False
        prev = self.alarm_on
        score_fin = np.isfinite(s)
        # only the windows where the alarm changes need a look of their own
        for i in np.flatnonzero(a != np.concatenate(([prev], a[:-1]))):
            ti = float(t[i])
            if a[i]:
                new_episode |= self._raise(i, ti, t, s, branches)
            elif score_fin[i]:
                self.alarm_on = False
                self.events.append({"time_s": ti, "kind": "cleared", "score": _num(s[i]),
                                    "episode": self.episode})
                self.n_events_total += 1
        for b in (0, 1):
            self._exc_start[b] = self._start_at(b, len(t) - 1, t, branches)
        if new_episode:
            self._recount()
        elif onset_before is not None:
            after = fin & (t - self.window_s >= self.onset_s)
            self._after[0] += float(z[after].sum())
            self._after[1] += int(after.sum())
        if self.onset_s is not None and self.calibration is not None:
            self._estimate()

    def _note_restarts(self, t: np.ndarray, s: np.ndarray, branches) -> None:
        """Times of the scored windows where the scorer restarted an excursion below the
        threshold (a new segment; :class:`~leakdiag.stream.detector.DetectorScorer`)."""
        scored = np.flatnonzero(np.isfinite(s))
        if not len(scored):
            return
        seg = np.maximum(np.floor((t[scored] - self._seg0) / self._seg_s), 0.0)
        stat = np.maximum(np.asarray(branches[0], float)[scored],
                          np.asarray(branches[1], float)[scored])
        prev_seg = np.concatenate(([np.nan if self._prev_seg is None else self._prev_seg],
                                   seg[:-1]))
        prev_stat = np.concatenate(([self._prev_stat], stat[:-1]))
        thr = self.threshold if self.threshold is not None else np.inf
        hit = (seg != prev_seg) & ~np.isnan(prev_seg) & (prev_stat > 0.0) & (prev_stat <= thr)
        self._restarts.extend(t[scored][hit].tolist())
        self._prev_seg, self._prev_stat = float(seg[-1]), float(stat[-1])

    def _start_at(self, b: int, i: int, t: np.ndarray, branches) -> tuple | None:
        """(time, start) of the first window of branch ``b``'s excursion at window ``i``."""
        bb = np.asarray(branches[b][:i + 1], dtype=np.float64)
        fin = np.isfinite(bb)
        zeros = np.flatnonzero(fin & (bb <= 0.0))
        if len(zeros):
            nxt = np.flatnonzero(fin[zeros[-1] + 1:])
            if not len(nxt):
                return None
            k = int(zeros[-1] + 1 + nxt[0])
        elif self._exc_start[b] is not None:
            return self._exc_start[b]
        else:
            first = np.flatnonzero(fin)
            if not len(first):
                return None
            k = int(first[0])
        return (float(t[k]), float(t[k]) - self.window_s)

    def _raise(self, i: int, ti: float, t: np.ndarray, s: np.ndarray, branches) -> bool:
        """Alarm: a new episode, or the same one again if its CUSUM excursion never ended."""
        self.alarm_on = True
        thr = self.threshold if self.threshold is not None else float(s[i])
        b = 0 if branches[0][i] >= thr else 1
        start = self._start_at(b, i, t, branches) or (ti, ti - self.window_s)
        same = self._episode_key == (b, start)
        if not same:
            self.episode += 1
            self._episode_key = (b, start)
            self.alarm_time_s = ti
            self.onset_censored = start[0] == self._first_scored  # there from the start
            # an undefined span beyond the limit inside the excursion (the CUSUM held across
            # it): the onset is at or before the first window after it, as Detector.predict
            ended = [e for _, e in (self._blind.ended if self._blind is not None else ())
                     if start[0] < e <= ti]
            if ended:
                start, self.onset_censored = (ended[-1], ended[-1] - self.window_s), True
            # an excursion the scorer restarted at a segment boundary starts again there
            dropped = [r for r in self._restarts if start[0] < r <= ti]
            if dropped:
                start = (dropped[-1], dropped[-1] - self.window_s)
            self.onset_s = (start[0] + start[1]) / 2.0
            self.leak = None
        self.events.append({"time_s": ti, "kind": "alarm", "score": _num(s[i]),
                            "onset_s": self.onset_s, "onset_censored": self.onset_censored,
                            "episode": self.episode, "again": same})
        self.n_events_total += 1
        return not same

    def _recount(self) -> None:
        """Before/after sums of the standardised feature around a new onset, from the history."""
        ht = np.concatenate(self._hist_t) if self._hist_t else np.empty(0)
        hz = np.concatenate(self._hist_z) if self._hist_z else np.empty(0)
        after = ht - self.window_s >= self.onset_s
        self._after = [float(hz[after].sum()), int(after.sum())]
        before = hz[ht < self.onset_s]
        self._before = float(before.mean()) if len(before) else float("nan")

    def _estimate(self) -> None:
        if not self._after[1]:
            return
        shift = self._after[0] / self._after[1] - self._before
        if np.isfinite(shift):
            lpm, (lo, hi), inside = self.calibration.estimate(shift)
            self.leak = (float(lpm), float(lo), float(hi), bool(inside), float(shift))

    def snapshot(self) -> dict:
        """The state as a JSON-ready dict (lists of numbers, None for NaN).

        Returns
        -------
        dict
        """
        if self.threshold is None and self.scorer is None:
            state = "NO DETECTOR" if self.n_windows else "WAITING"
        elif not self.n_windows:
            state = "WAITING"
        else:
            state = "ALARM" if self.alarm_on else "OK"
            if state == "OK" and self._blind is not None and self._blind.current_blind:
                state = "BLIND"  # undefined feature: the detector cannot see
        leak = self.leak
        return {
            "actuator": self.name, "feature": self.feature, "threshold": self.threshold,
            "state": state, "blind_windows": self._blind.windows if self._blind is not None else 0,
            "alarm_time_s": self.alarm_time_s, "onset_s": self.onset_s,
            "onset_censored": self.onset_censored if self.onset_s is not None else None,
            "leak_lpm": leak[0] if leak else None, "leak_lpm_low": leak[1] if leak else None,
            "leak_lpm_high": leak[2] if leak else None,
            "leak_in_range": leak[3] if leak else None, "leak_interval": self.leak_interval,
            "calibrated": self.calibration is not None,
            "n_windows": self.n_windows, "last_time_s": self.time[-1] if self.time else None,
            "received_wall": self.received_wall, "done": self.done,
            "time": list(self.time), "value": [_num(x) for x in self.value],
            "score": [_num(x) for x in self.score],
            "events": list(self.events)[::-1],
        }


class LiveBoard:
    """Thread-safe live states of several actuators with a change counter.

    Examples
    --------
    >>> board = LiveBoard()
    >>> board.add("rig1", "autocorrelation p1 1 N=4 0%")
    >>> board.update("rig1", np.array([0.3]), np.array([0.5]), None, None)
    >>> snap = board.snapshot("rig1")
    >>> snap["state"], snap["time"], snap["value"]
    ('NO DETECTOR', [0.3], [0.5])
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._live: dict[str, ActuatorLive] = {}
        self.version = 0

    def add(self, name: str, feature: str, scorer: Any = None, window_s: float = 0.0) -> None:
        """Register an actuator (replacing an earlier one of that name).

        Parameters
        ----------
        name : str
            Actuator name.
        feature : str
            Feature label.
        scorer : object, optional
            The monitor's scorer for this feature.
        window_s : float, default 0.0
            Window span in s.
        """
        with self._lock:
            self._live[name] = ActuatorLive(name, feature, scorer, window_s)
            self.version += 1

    def names(self) -> list[str]:
        """Registered actuators, sorted.

        Returns
        -------
        list of str
        """
        with self._lock:
            return sorted(self._live)

    def last_time(self, name: str) -> float | None:
        """Stream time (s) of an actuator's last window.

        Parameters
        ----------
        name : str
            Any name (an unknown one has no last window).

        Returns
        -------
        float or None
            None before the first window.
        """
        with self._lock:
            times = getattr(self._live.get(name), "time", None)
            return times[-1] if times else None

    def update(self, name: str, t, v, s=None, a=None, received_wall: float | None = None,
               branches: tuple | None = None) -> None:
        """Append the windows of one or more consecutive chunks to an actuator.

        Parameters
        ----------
        name : str
            Registered actuator.
        t, v : array_like
            Window times (s) and feature values.
        s, a : array_like, optional
            Scores and alarms.
        received_wall : float, optional
            Wall-clock arrival time of the (last) chunk (default: now).
        branches : tuple of array_like, optional
            CUSUM branches (S+, S-) of these windows (default: the scorer's last ones).
        """
        t = np.asarray(t, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        s = None if s is None else np.asarray(s, dtype=np.float64)
        a = None if a is None else np.asarray(a, dtype=bool)
        with self._lock:
            self._live[name].update(t, v, s, a, time.time() if received_wall is None
                                    else received_wall, branches)
            self.version += 1

    def finish(self, name: str) -> None:
        """Mark an actuator's stream as ended.

        Parameters
        ----------
        name : str
            Registered actuator.
        """
        with self._lock:
            self._live[name].done = True
            self.version += 1

    def snapshot(self, name: str) -> dict | None:
        """JSON-ready state of one actuator, None if unknown.

        Parameters
        ----------
        name : str
            Actuator name.

        Returns
        -------
        dict or None
        """
        with self._lock:
            live = self._live.get(name)
            if live is None:
                return None
            snap = live.snapshot()
            snap["version"] = self.version
            return snap
