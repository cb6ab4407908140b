"""Blind spans of a monitored stream: runs of undefined feature windows a detector cannot see.

A window whose feature is undefined (zero variance: a channel it reads is constant, e.g. a stuck
sensor) is NaN, and the CUSUM holds its value across it, so "no alarm" over such a span says
nothing. :class:`~leakdiag.detect.base.Detector` refuses a NO LEAK over a run of undefined
windows longer than ``NAN_RUN_FACTOR`` times its healthy recordings' longest
(``nan_run_healthy_``, docs/detect.md section 2, "Blind spans"); :class:`BlindSpans` applies the
same limit window by window to a stream, for ``leakdiag monitor``.
"""

from __future__ import annotations

import math

__all__ = ["BlindSpans"]


class BlindSpans:
    """Runs of undefined (NaN) scored windows, against a detector's healthy limit.

    Parameters
    ----------
    healthy_run : int
        Longest run of undefined windows in the detector's healthy recordings
        (``Detector.nan_run_healthy_``).

    Attributes
    ----------
    limit : int
        ``NAN_RUN_FACTOR * max(healthy_run, NAN_RUN_FLOOR)``: longer runs are blind spans.
    longest : tuple of (int, float, float)
        ``(windows, first time, last time)`` of the longest run seen (times of the windows' last
        samples), ``(0, nan, nan)`` before any.

    Examples
    --------
    >>> b = BlindSpans(0)  # limit 3
    >>> [b.add(t, v) for t, v in [(1.0, 0.5), (2.0, float("nan")), (3.0, float("nan")),
    ...                           (4.0, float("nan")), (5.0, float("nan")), (6.0, 0.1)]]
    [False, False, False, False, True, False]
    >>> b.longest
    (4, 2.0, 5.0)
    """

    def __init__(self, healthy_run: int):
        from leakdiag.detect.base import NAN_RUN_FACTOR, NAN_RUN_FLOOR

        self.healthy_run = int(healthy_run)
        self.limit = NAN_RUN_FACTOR * max(self.healthy_run, NAN_RUN_FLOOR)
        self._n, self._t0 = 0, math.nan
        self.longest = (0, math.nan, math.nan)

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
            True when this window makes the current run a blind span (once per run: at the
            window that first exceeds the limit).
        """
        if math.isfinite(value):
            self._n = 0
            return False
        if self._n == 0:
            self._t0 = time
        self._n += 1
        if self._n > self.longest[0]:
            self.longest = (self._n, self._t0, time)
        return self._n == self.limit + 1

    @property
    def blind(self) -> bool:
        """Whether the longest run seen is a blind span."""
        return self.longest[0] > self.limit

    def words(self, source: str, label: str) -> str:
        """The longest run as a sentence for the monitor's summary.

        Parameters
        ----------
        source, label : str
            The stream's name and the feature's label.

        Returns
        -------
        str
        """
        n, t0, t1 = self.longest
        return (f"{source}: the feature {label!r} was undefined in {n} consecutive windows "
                f"ending {t0:.6g} to {t1:.6g} s (zero variance: a channel it reads is constant "
                f"there, a stuck sensor?); the detector's healthy recordings had at most "
                f"{self.healthy_run} in a row (limit {self.limit}), so no alarm there rules "
                "nothing out")
