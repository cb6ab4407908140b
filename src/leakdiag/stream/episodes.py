"""Alarm episodes of a monitored stream, counted as the live page and the event store count them.

A CUSUM near its threshold can dip below it and cross again; while its excursion has not
returned to 0 that is one alarm **episode** (docs/operations.md, "Alarm time"). The monitor's
summary counts raisings and episodes with :class:`AlarmEpisodes`; the live page
(:class:`leakdiag.dashboard.live.ActuatorLive`) keeps one alarm row per episode in the store.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["AlarmEpisodes"]


class AlarmEpisodes:
    """Count the alarm episodes of a stream as the live page and the event store do.

    An alarm raised by the CUSUM branch (S+, else S-: the branch at the threshold) that raised
    the previous one continues that episode while the branch has not been back at 0 since; any
    other raising starts a new episode (docs/operations.md, "Alarm time";
    :class:`leakdiag.dashboard.live.ActuatorLive`, whose episodes are the store's alarm rows).
    The count does not depend on how the windows are split into chunks.

    Parameters
    ----------
    threshold : float, optional
        The scorer's ``threshold_``; None (or not finite): the raising window's score.

    Attributes
    ----------
    n : int
        Episodes so far.
    open : bool
        Whether the branch of the last episode has not been back at 0 since it was raised
        (only then does a chunk without a raising need :meth:`add`).

    Examples
    --------
    >>> import numpy as np
    >>> ep = AlarmEpisodes(2.0)
    >>> s = np.array([1.0, 2.0, 1.5, 2.5, 0.0, 3.0])  # raised at 1, 3 (same excursion) and 5
    >>> ep.add([1, 3, 5], s, (s, np.zeros(6)))
    >>> ep.n
    2
    """

    def __init__(self, threshold: float | None = None):
        ok = threshold is not None and math.isfinite(float(threshold))
        self.threshold = float(threshold) if ok else None
        self.n = 0
        self.open = False
        self._branch: int | None = None

    def add(self, raised, scores, branches=None) -> None:
        """Take one chunk's windows.

        Parameters
        ----------
        raised : sequence of int
            Indices of the windows where the alarm was raised (it was off before), ascending.
        scores : numpy.ndarray
            The windows' scores.
        branches : tuple of numpy.ndarray, optional
            CUSUM branches (S+, S-) of the windows (a ``DetectorScorer``'s ``branches_``);
            default, or of another length: the score for both.
        """
        if branches is None or len(branches[0]) != len(scores):
            branches = (scores, scores)
        start = 0
        for i in raised:
            thr = self.threshold if self.threshold is not None else scores[i]
            b = 0 if branches[0][i] >= thr else 1
            if not (self.open and b == self._branch and
                    not (np.asarray(branches[b][start:i]) <= 0.0).any()):
                self.n += 1
            self._branch, self.open, start = b, True, i + 1
        if self.open:
            self.open = not (np.asarray(branches[self._branch][start:]) <= 0.0).any()
