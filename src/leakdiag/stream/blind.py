"""Blind spans of a monitored stream: undefined feature windows a detector cannot see through.

A window whose feature is undefined (zero variance: a channel it reads is constant, e.g. a stuck
sensor) is NaN, and the CUSUM holds its value across it, so "no alarm" during such a span says
nothing. :class:`~leakdiag.detect.base.Detector` refuses a NO LEAK over an undefined span longer
than :func:`~leakdiag.detect.blind_rules.blind_limit_s` of its healthy recordings' longest
(``nan_span_healthy_s_``, docs/detect.md section 2, "Blind spans"), and one with more than half
of its judged windows undefined (:func:`~leakdiag.detect.blind_rules.blind_rule`). :class:`BlindSpans`
applies the same rule window by window to a stream, for ``leakdiag monitor``: the span limit
always, the fraction when it is given every judged window (``every_window=True``).
"""

from __future__ import annotations

import math
from collections import deque

from leakdiag._format import seconds
from leakdiag.detect.blind_rules import blind_limit_s, blind_rule, undefined_limit

__all__ = ["BlindSpans", "MAX_ENDED"]

#: Ended spans longer than the limit that :attr:`BlindSpans.ended` keeps (the latest).
MAX_ENDED = 64


class BlindSpans:
    """The current span of undefined (NaN) scored windows, against a detector's healthy limit.

    Parameters
    ----------
    healthy_span_s : float
        Longest undefined span of the detector's healthy recordings
        (``Detector.nan_span_healthy_s_``).
    step_s : float
        Time between consecutive windows (s): a span of n windows is ``n * step_s``.
    every_window : bool, default False
        Whether the caller gives every judged (scored) window to :meth:`add` /
        :meth:`add_block`, defined or not: only then are :attr:`judged` and :attr:`undefined`
        the run's counts, and :attr:`blind` applies the fraction rule
        (:data:`~leakdiag.detect.blind_rules.MAX_UNDEFINED_FRACTION`) as ``Detector.predict`` does.
        A caller that gives only the undefined windows and the first defined one after each
        span gets the span limit only.
    healthy_fraction : float, default 0.0
        Largest share of undefined windows in a healthy recording.
    window_span_s : float, default 0.0
        Time from a window's first sample to its last, ``(N - 1) / rate``: :meth:`words`
        names a span from its first window's first sample, as ``Detector.predict`` does.

    Attributes
    ----------
    limit_s : float
        :func:`~leakdiag.detect.blind_rules.blind_limit_s` of ``healthy_span_s``.
    windows : int
        Undefined windows in a row up to the latest one (0 after a defined window).
    since : float
        Time of the first of them (NaN when ``windows`` is 0).
    longest : tuple of (int, float, float)
        ``(windows, first time, last time)`` of the longest span so far.
    ended : collections.deque of (float, float)
        ``(first window time, time of the first defined window after it)`` of the latest spans
        longer than the limit that have ended (at most :data:`MAX_ENDED`): an alarm whose CUSUM
        excursion began before one of them dates its onset after it
        (:class:`~leakdiag.dashboard.live.ActuatorLive`, as ``Detector.predict``).
    judged, undefined : int
        Windows taken, and of them undefined ones.

    Examples
    --------
    >>> b = BlindSpans(0.0, step_s=4.0)  # limit 10 s: 3 windows of 4 s
    >>> nan = float("nan")
    >>> [b.add(t, v) for t, v in [(4.0, 0.5), (8.0, nan), (12.0, nan), (16.0, nan), (20.0, nan)]]
    [False, False, False, True, False]
    >>> b.blind, b.windows, b.since, b.longest
    (True, 4, 8.0, (4, 8.0, 20.0))
    >>> c = BlindSpans(0.0, step_s=4.0)  # the same windows in two blocks
    >>> c.add_block([4.0, 8.0, 12.0], [0.5, nan, nan]); c.add_block([16.0, 20.0], [nan, nan])
    >>> c.current_blind, c.windows, c.since, c.longest
    (True, 4, 8.0, (4, 8.0, 20.0))
    >>> c.add_block([24.0, 28.0], [0.3, 0.4]); list(c.ended)   # the span ends at 24 s
    [(8.0, 24.0)]
    >>> d = BlindSpans(0.0, step_s=0.2, every_window=True)  # a 3-s run: no span can reach 10 s
    >>> d.add_block([0.2, 0.4], [0.5, 0.6]); d.add_block([0.6 + 0.2 * k for k in range(13)],
    ...                                                    [nan] * 13)
    >>> d.current_blind, d.blind, d.judged, d.undefined
    (False, True, 15, 13)
    """

    def __init__(self, healthy_span_s: float, step_s: float, every_window: bool = False,
                 healthy_fraction: float = 0.0, window_span_s: float = 0.0):
        self.healthy_span_s = float(healthy_span_s)
        self.window_span_s = float(window_span_s)
        self.step_s = float(step_s)
        self.limit_s = blind_limit_s(self.healthy_span_s)
        self.every_window = bool(every_window)
        #: Largest share of undefined windows in a healthy recording (the fraction rule's
        #: reference, :func:`~leakdiag.detect.blind_rules.undefined_limit`).
        self.healthy_fraction = float(healthy_fraction)
        self.windows, self.since = 0, math.nan
        self.longest = (0, math.nan, math.nan)
        self.ended: deque = deque(maxlen=MAX_ENDED)
        self.judged = self.undefined = 0

    def add(self, time: float, value: float) -> bool:
        """Take one scored window.

        Parameters
        ----------
        time : float
            Time of the window's last sample (s).
        value : float
            Its feature value (NaN: undefined).

        Returns
        -------
        bool
            True when this window makes the current span longer than the limit (once per
            span: at the window that first exceeds it).
        """
        self.judged += 1
        if math.isfinite(value):
            if self.windows * self.step_s > self.limit_s:
                self.ended.append((self.since, float(time)))
            self.windows, self.since = 0, math.nan
            return False
        self.undefined += 1
        if self.windows == 0:
            self.since = time
        self.windows += 1
        if self.windows > self.longest[0]:
            self.longest = (self.windows, self.since, time)
        return self.windows * self.step_s > self.limit_s >= (self.windows - 1) * self.step_s

    def add_block(self, times, values) -> None:
        """Take consecutive scored windows at once (:meth:`add` for each, vectorised: the
        live board's per-chunk update).

        Parameters
        ----------
        times, values : numpy.ndarray
            Window times (s) and feature values (NaN: undefined), in order.
        """
        import numpy as np

        bad = ~np.isfinite(np.asarray(values, dtype=np.float64))
        self.judged += len(bad)
        self.undefined += int(bad.sum())
        if not bad.any():
            if len(bad):
                if self.windows * self.step_s > self.limit_s:
                    self.ended.append((self.since, float(times[0])))
                self.windows, self.since = 0, math.nan
            return
        edges = np.diff(np.concatenate(([0], bad.view(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        lengths = ends - starts
        if starts[0] > 0 and self.windows * self.step_s > self.limit_s:  # ended at times[0]
            self.ended.append((self.since, float(times[0])))
        if starts[0] == 0 and self.windows:  # the span before this block goes on
            lengths[0] += self.windows
        else:
            self.since = math.nan
        since = [self.since if (k == 0 and starts[0] == 0 and self.windows) else
                 float(times[st]) for k, st in enumerate(starts)]
        for r in np.flatnonzero((lengths * self.step_s > self.limit_s) & (ends < len(bad))):
            self.ended.append((since[r], float(times[ends[r]])))
        k = int(np.argmax(lengths))
        if lengths[k] > self.longest[0]:
            self.longest = (int(lengths[k]), since[k], float(times[ends[k] - 1]))
        trailing = ends[-1] == len(bad)
        self.windows = int(lengths[-1]) if trailing else 0
        self.since = since[-1] if trailing else math.nan

    @property
    def current_blind(self) -> bool:
        """Whether the windows taken last are an undefined span longer than the limit."""
        return self.windows * self.step_s > self.limit_s

    @property
    def rule(self) -> str | None:
        """The rule that refuses a NO LEAK over the windows so far
        (:func:`~leakdiag.detect.blind_rules.blind_rule`: ``"span"``, ``"fraction"``; None: none).
        The fraction only with ``every_window``."""
        if self.longest[0] * self.step_s > self.limit_s:
            return "span"
        if not self.every_window:
            return None
        return blind_rule(self.healthy_span_s, self.judged, self.undefined,
                          self.longest[0] * self.step_s, self.healthy_fraction)

    @property
    def blind(self) -> bool:
        """Whether NO LEAK is refused over the windows so far: the longest span is longer than
        the limit, or (``every_window``) more than half of the windows are undefined."""
        return self.rule is not None

    def words(self, source: str, label: str) -> str:
        """The longest span as a sentence for the monitor's summary.

        Parameters
        ----------
        source, label : str
            The stream's name and the feature's label.

        Returns
        -------
        str
        """
        n, t0, t1 = self.longest
        if self.rule == "fraction":
            limit = undefined_limit(self.healthy_fraction)
            more = ("more than half" if limit == 0.5 else f"more than {limit:.0%}, the healthy "
                    f"recordings had at most {self.healthy_fraction:.0%}")
            return (f"{source}: the feature {label!r} was undefined in {self.undefined} of the "
                    f"{self.judged} windows judged ({more}; the longest span {n} windows "
                    f"from {seconds(t0 - self.window_span_s, 6)} to {seconds(t1, 6)} s: a "
                    "channel it reads is "
                    "constant there, a "
                    f"stuck sensor?), so the absence of an alarm rules nothing out: it rests on "
                    f"{self.judged - self.undefined} defined window(s)")
        return (f"{source}: the feature {label!r} was undefined in {n} consecutive windows "
                f"ending {t0:.6g} to {t1:.6g} s ({n * self.step_s:.3g} s; zero variance: a "
                f"channel it reads is constant there, a stuck sensor?); the detector's healthy "
                f"recordings had undefined spans of at most {self.healthy_span_s:.3g} s (limit "
                f"{self.limit_s:.3g} s), so no alarm there rules nothing out")
