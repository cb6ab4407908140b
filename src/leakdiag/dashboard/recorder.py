"""What the monitor's sidecar process does with each chunk: the live board and the store rows.

The monitor copies each chunk's windows into the sidecar's shared-memory ring
(:mod:`leakdiag.dashboard.ring`); the sidecar (:mod:`leakdiag.dashboard.sidecar`) takes what the
ring holds and hands the chunks to :class:`ChunkRecorder` in one call: one update
of the live board that the page serves (split only where an alarm is raised, so that each alarm
episode keeps its own leak estimate) and, with a store, the chunk summaries
(:func:`~leakdiag.store.summarize_chunks`) and alarm rows in one transaction.
"""

from __future__ import annotations

from dataclasses import replace
from datetime import datetime, timezone
from typing import Any

import numpy as np

from leakdiag.dashboard.live import DETECTOR_FACTS, SCORER_FACTS, LiveBoard
from leakdiag.store import AlarmRecord, EventStore, summarize_chunks

__all__ = ["ChunkRecorder", "ScorerFacts"]


class ScorerFacts:
    """What the board needs of the monitor's scorer, picklable (no detector code runs).

    Parameters
    ----------
    scorer : object
        The monitor's scorer (``threshold_``; a
        :class:`~leakdiag.stream.detector.DetectorScorer` also has ``mean_``, ``std_`` and the
        detector's ``calibration_`` and ``nan_span_healthy_s_``): the names that
        :class:`~leakdiag.dashboard.live.ActuatorLive` reads (``SCORER_FACTS`` and
        ``DETECTOR_FACTS``), so that the sidecar's board is the monitor's (without the
        detector's healthy span it had no BLIND state).
    """

    def __init__(self, scorer: Any):
        det = getattr(scorer, "detector", None)
        for name in SCORER_FACTS:
            setattr(self, name, getattr(scorer, name, None))
        for name in DETECTOR_FACTS:
            setattr(self, name, getattr(det, name, None))
        self.detector = self  # ActuatorLive reads detector.calibration_, ...


class ChunkRecorder:
    """Live board, alarm rows and chunk summaries of a monitor run, updated take by take.

    Parameters
    ----------
    store : EventStore or None
        Open store (None: the board only).
    run_id : int or None
        The run (from :meth:`EventStore.start_run`).
    actuator, feature : str
        Actuator name and feature label.
    scorer : object, optional
        The monitor's scorer or its :class:`ScorerFacts` (threshold, standardisation,
        calibration); None without a detector.
    window_s : float, default 0.0
        Window span in s.
    """

    def __init__(self, store: EventStore | None, run_id: int | None, actuator: str, feature: str,
                 scorer: Any = None, window_s: float = 0.0):
        self.store, self.run_id, self.actuator = store, run_id, actuator
        self.board = LiveBoard()
        self.board.add(actuator, feature, scorer, window_s)
        self.live = self.board._live[actuator]
        self._alarm_id: int | None = None
        self._sent_leak = None
        self._n_events = 0
        self._open = False  # an alarm episode whose CUSUM excursion is not back at 0 yet

    def apply(self, chunks: list) -> None:
        """Take consecutive chunks: one board update, one transaction (summaries, alarms).

        Parameters
        ----------
        chunks : list of tuple
            ``(t, v, s, a, branches, received)`` per chunk, as
            :meth:`~leakdiag.dashboard.ring.RingReader.take` gives them.

        Raises
        ------
        leakdiag.store.StoreError
            Or the database's error.
        """
        t, v = (np.concatenate([c[k] for c in chunks]) for k in (0, 1))
        n = len(t)
        s = a = br = None
        if chunks[0][2] is not None:
            s, a = (np.concatenate([c[k] for c in chunks]) for k in (2, 3))
            br = tuple(np.concatenate([c[2] if c[4] is None else c[4][k] for c in chunks])
                       for k in (0, 1))
        # split where an alarm is raised: each episode's leak estimate is taken before the next
        cuts = [0, n]
        if a is not None:
            prev = np.concatenate(([self.live.alarm_on], a[:-1]))
            cuts = sorted({0, n, *np.flatnonzero(a & ~prev).tolist()})
        new: list = []
        updates: dict = {}
        if self.store is None:  # the page only: any split gives the same state
            cuts = [0, n]
        for i0, i1 in zip(cuts[:-1], cuts[1:]):
            seg = slice(i0, i1)
            self.board.update(self.actuator, t[seg], v[seg], None if s is None else s[seg],
                              None if a is None else a[seg], chunks[-1][5],
                              None if br is None else (br[0][seg], br[1][seg]))
            if self.store is not None:
                self._collect(new, updates)
                if br is not None:
                    self._episode_end(new, updates, t[seg], a[seg], (br[0][seg], br[1][seg]))
        if self.store is None:
            return
        summaries = summarize_chunks(t, v, s, a, [len(c[0]) for c in chunks])
        # each summary stamped with its chunk's hand-off time (a sidecar that lags behind a
        # fast replay would stamp a whole take with its commit time)
        handed = [c[5] for c in chunks if len(c[0])]
        at = [datetime.fromtimestamp(w, timezone.utc) for w in handed] \
            if len(handed) == len(summaries) and all(w > 0 for w in handed) else None
        _, ids = self.store.add_chunks(self.run_id, summaries, new, updates, recorded_at=at)
        if ids:
            self._alarm_id = ids[-1]

    def _collect(self, new: list, updates: dict) -> None:
        """Alarm rows to write for the events since the last call (``new``/``updates`` grow).

        A new episode's alarm is a new row; an alarm raised again in the same episode and a
        clearing (the score under the threshold) change nothing: the episode goes on until
        its CUSUM excursion is back at 0 (:meth:`_episode_end`).
        """
        live = self.live
        evs = list(live.events)  # oldest first; the deque is bounded, so count from the end
        fresh = evs[len(evs) - min(len(evs), live.n_events_total - self._n_events):]
        self._n_events = live.n_events_total
        for e in fresh:
            if e["kind"] == "alarm" and not e["again"]:
                new.append(AlarmRecord(e["time_s"], e["score"], live.threshold, e["onset_s"],
                                       detector=live.feature,
                                       onset_censored=e.get("onset_censored")))
                self._open = True
        leak = (live.leak[0], live.leak[1], live.leak[2], not live.leak[3]) \
            if live.leak else None
        if leak:
            cols = dict(leak_lpm=leak[0], leak_lpm_low=leak[1], leak_lpm_high=leak[2],
                        leak_extrapolated=leak[3], leak_interval=live.leak_interval)
        if new and leak:
            new[-1] = replace(new[-1], **cols)
        elif self._alarm_id is not None and leak and leak != self._sent_leak:
            updates.setdefault(self._alarm_id, {}).update(cols)
        self._sent_leak = leak

    def _episode_end(self, new: list, updates: dict, t: np.ndarray, a: np.ndarray,
                     branches: tuple) -> None:
        """Write ``cleared_time_s`` when the open alarm episode ends in these windows.

        The episode ends at the first window out of alarm whose CUSUM branch (the one that
        raised it) is back at 0, as the monitor's :class:`~leakdiag.stream.episodes.
        AlarmEpisodes` and the board count episodes: a score that dips under the threshold
        and crosses it again in one excursion is one alarm, and a run that ends (or is
        killed) in such a dip ends in alarm, as ``leakdiag detect`` judges the recording
        (session 26 audit: a dip at the end of a run was stored as a clearing, and the fleet
        page showed OK where ``detect`` said LEAK). The windows start with the raising, if
        any (:meth:`apply` splits there). An undefined branch (NaN, the CUSUM held) is not 0.
        """
        b = self.live.episode_branch
        if not self._open or b is None:
            return
        with np.errstate(invalid="ignore"):
            back = np.flatnonzero(~a & (np.asarray(branches[b], dtype=np.float64) <= 0.0))
        if not len(back):
            return
        cleared = float(t[back[0]])
        if new:  # the episode's alarm row is written with these chunks
            new[-1] = replace(new[-1], cleared_time_s=cleared)
        elif self._alarm_id is not None:
            updates.setdefault(self._alarm_id, {})["cleared_time_s"] = cleared
        self._open = False
