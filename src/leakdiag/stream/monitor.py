"""The streaming monitor: features, detector scores and alarms as soon as each window completes.

A detector plugs in through the small :class:`WindowScorer` protocol. Any object with

* ``score_windows(values, time) -> scores`` (one score per feature value; ``time`` holds the
  windows' timestamps in s; called with consecutive blocks of windows in time order; it may keep
  state, but the scores must not depend on how the windows are split into blocks), and
* either ``alarm_windows(scores) -> bool array`` or a numeric attribute ``threshold_``
  (alarm when ``score >= threshold_``)

can be given to :class:`Monitor`. A fitted :class:`leakdiag.detect.base.Detector` with a
``spec()`` (e.g. :class:`~leakdiag.detect.methods.FeatureDetector`) is wrapped automatically in
:class:`~leakdiag.stream.detector.DetectorScorer`, which runs its CUSUM incrementally.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Iterable, Protocol, Sequence, runtime_checkable

import numpy as np

from leakdiag.features.spec import MethodSpec
from leakdiag.stream.detector import as_scorer
from leakdiag.stream.feature import StreamingFeature

__all__ = ["Monitor", "WindowEvent", "WindowScorer", "check_scorer"]


@runtime_checkable
class WindowScorer(Protocol):
    """Protocol of a detector the monitor can call once per block of new feature values."""

    def score_windows(self, values: np.ndarray, time: np.ndarray) -> np.ndarray:  # pragma: no cover
        """Return one score per value (same shape), causal in time."""


def check_scorer(scorer: Any) -> Any:
    """Check that ``scorer`` follows the :class:`WindowScorer` protocol and return it.

    Parameters
    ----------
    scorer : object
        Needs ``score_windows`` and either ``alarm_windows`` or a numeric ``threshold_``.

    Returns
    -------
    object
        ``scorer`` itself.

    Raises
    ------
    TypeError
        Naming the missing hook.

    Examples
    --------
    >>> class Above:
    ...     threshold_ = 0.5
    ...     def score_windows(self, values, time):
    ...         return values
    >>> check_scorer(Above()).threshold_
    0.5
    """
    if not callable(getattr(scorer, "score_windows", None)):
        raise TypeError(f"{type(scorer).__name__} has no score_windows(values, time) method")
    if not callable(getattr(scorer, "alarm_windows", None)):
        thr = getattr(scorer, "threshold_", None)
        if not isinstance(thr, (int, float, np.floating, np.integer)) or isinstance(thr, bool):
            raise TypeError(
                f"{type(scorer).__name__} needs alarm_windows(scores) or a numeric threshold_"
            )
    return scorer


def _alarms(scorer: Any, scores: np.ndarray) -> np.ndarray:
    if callable(getattr(scorer, "alarm_windows", None)):
        alarms = np.asarray(scorer.alarm_windows(scores), dtype=bool)
        if alarms.shape != scores.shape:
            raise ValueError(f"alarm_windows returned shape {alarms.shape} for {scores.shape} "
                             "scores")
        return alarms
    return np.asarray(scores >= float(scorer.threshold_), dtype=bool)


def _json_number(v: float) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


@dataclass(frozen=True)
class WindowEvent:
    """One completed window: its feature value and, with a detector, score and alarm.

    Parameters
    ----------
    time : float
        Time of the window's last sample in seconds.
    window : int
        Window index (0-based) of this feature.
    method : str
        Feature method.
    channels : tuple of str
        Channels the feature uses.
    value : float
        Feature value (NaN for a degenerate window).
    score : float or None
        Detector score, None without a detector.
    alarm : bool or None
        Detector alarm, None without a detector.
    """

    time: float
    window: int
    method: str
    channels: tuple[str, ...]
    value: float
    score: float | None = None
    alarm: bool | None = None

    def to_json(self) -> str:
        """One JSON line (NaN and inf become ``null``).

        Returns
        -------
        str
        """
        d = {"time": self.time, "window": self.window, "method": self.method,
             "channels": list(self.channels), "value": _json_number(self.value)}
        if self.score is not None:
            d["score"] = _json_number(self.score)
            d["alarm"] = bool(self.alarm)
        return json.dumps(d)


class Monitor:
    """Push chunks of a multichannel stream; get one event per completed window.

    Parameters
    ----------
    specs : MethodSpec or sequence of MethodSpec
        Features to compute.
    sample_rate : float
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of the first sample in seconds.
    scorers : object or sequence of object, optional
        A :class:`WindowScorer` or a fitted leakdiag detector per spec (None entries allowed),
        or a single one when there is one spec.

    Raises
    ------
    TypeError
        If a scorer lacks the protocol hooks.
    ValueError
        If the number of scorers does not match the number of specs.

    Examples
    --------
    >>> spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=4, overlap=0)
    >>> mon = Monitor(spec, sample_rate=10.0)
    >>> [e.time for e in mon.push({"p1": [1.0, 2.0, 4.0, 3.0, 5.0]})]
    [0.3]
    """

    def __init__(self, specs: MethodSpec | Sequence[MethodSpec], sample_rate: float,
                 start_time: float = 0.0, scorers: Any = None):
        specs = [specs] if isinstance(specs, MethodSpec) else list(specs)
        if not specs:
            raise ValueError("Monitor needs at least one MethodSpec")
        if scorers is None:
            scorers = [None] * len(specs)
        elif not isinstance(scorers, (list, tuple)):
            scorers = [scorers]
        if len(scorers) != len(specs):
            raise ValueError(f"got {len(scorers)} scorer(s) for {len(specs)} feature spec(s)")

        self.scorers = [
            None if s is None else check_scorer(as_scorer(s, sp, sample_rate, start_time))
            for s, sp in zip(scorers, specs)]
        self.features = [StreamingFeature(s, sample_rate, start_time) for s in specs]
        self.channels = sorted({c for s in specs for c in s.channels})
        #: The arrays of the last push, per spec ``(time, values, scores, alarms)``: what a
        #: consumer of the events (the dashboard, the store) can keep without the event objects.
        self.last_arrays: list = []
        #: The events that the last :meth:`push` returned (the same list object): a consumer
        #: given them can tell that :attr:`last_arrays` holds them.
        self.last_events: list | None = None

    @property
    def n_samples_seen(self) -> int:
        """Samples per channel pushed so far."""
        return self.features[0].n_samples_seen

    def push_arrays(self, chunk) -> list[tuple[np.ndarray, np.ndarray, np.ndarray | None,
                                               np.ndarray | None]]:
        """Push a chunk and return arrays per feature (fast path, no event objects).

        Parameters
        ----------
        chunk : dict of str to array_like
            New samples per channel.

        Returns
        -------
        list of tuple
            Per spec ``(time, values, scores, alarms)``; ``scores``/``alarms`` are None
            without a scorer.

        Raises
        ------
        ValueError
            If a chunk is not finite or its channels differ in length (from the streaming
            feature), or a scorer's ``score_windows`` returns a shape other than the values'
            (``alarm_windows`` one other than the scores').
        """
        out = []
        for feat, scorer in zip(self.features, self.scorers):
            fs = feat.push(chunk)
            scores = alarms = None
            if scorer is not None and len(fs):
                scores = np.asarray(scorer.score_windows(fs.values, fs.time), dtype=np.float64)
                if scores.shape != fs.values.shape:
                    raise ValueError(
                        f"score_windows returned shape {scores.shape} for {fs.values.shape} values"
                    )
                alarms = _alarms(scorer, scores)
            out.append((fs.time, fs.values, scores, alarms))
        self.last_arrays = out
        return out

    def push(self, chunk) -> list[WindowEvent]:
        """Push a chunk and return the events of all windows it completed, in time order.

        Parameters
        ----------
        chunk : dict of str to array_like
            New samples per channel (any length).

        Returns
        -------
        list of WindowEvent
        """
        events = []
        for feat, (t, v, s, a) in zip(self.features, self.push_arrays(chunk)):
            first = feat.n_windows - len(v)
            for i in range(len(v)):
                events.append(WindowEvent(
                    float(t[i]), first + i, feat.spec.method, feat.spec.channels, float(v[i]),
                    None if s is None else float(s[i]), None if a is None else bool(a[i])))
        events.sort(key=lambda e: e.time)
        self.last_events = events
        return events

    def run(self, chunks: Iterable) -> Iterable[WindowEvent]:
        """Push every chunk of an iterable and yield the events as they complete.

        Parameters
        ----------
        chunks : iterable of dict
            Chunks of samples per channel.

        Yields
        ------
        WindowEvent
        """
        for chunk in chunks:
            yield from self.push(chunk)
