"""What ``leakdiag monitor`` does with ``--store`` and ``--dashboard``: one object, one call per chunk.

:class:`MonitorHooks` keeps the live state of the monitored actuator
(:class:`~leakdiag.dashboard.live.ActuatorLive`), serves it with ``--dashboard`` and writes each
chunk to the event store with ``--store`` (one transaction per chunk: its summary, an alarm when
raised, its clearing, the updated onset and leak estimates).
"""

from __future__ import annotations

import threading
import time
from urllib.parse import quote
from typing import Any, Callable, Iterable, Iterator

import numpy as np

from leakdiag.dashboard.live import LiveBoard

__all__ = ["MonitorHooks"]


class MonitorHooks:
    """Live board, web server and store writer of one monitor run.

    Parameters
    ----------
    actuator : str
        Actuator name.
    spec : MethodSpec
        The monitored feature.
    monitor : leakdiag.stream.Monitor
        The monitor (its first scorer gives threshold and detector).
    source : str
        Input name.
    sample_rate : float
        Sample rate in Hz.
    store : str, optional
        ``--store`` target (file or URL).
    bind : leakdiag.dashboard.server.Bind, optional
        ``--dashboard`` address.
    refresh_hz : float, default 5.0
        Largest page update rate.
    say : callable, optional
        Prints a message for the user.

    Raises
    ------
    leakdiag.store.StoreError
        If the store cannot be opened.
    """

    def __init__(self, actuator: str, spec: Any, monitor: Any, source: str, sample_rate: float,
                 store: str | None = None, bind: Any = None, refresh_hz: float = 5.0,
                 say: Callable[[str], None] = print):
        self.actuator = actuator
        self.scorer = monitor.scorers[0]
        self.board = LiveBoard()
        self.board.add(actuator, spec.label, self.scorer, (spec.window - 1) / sample_rate)
        self.live = self.board._live[actuator]
        self.store = self.run_id = self.server = None
        self._alarm_id: int | None = None
        self._sent_leak = None
        self._sent_onset = None
        self._n_events = 0
        self._recv = time.time()
        if store is not None:
            from leakdiag.store import EventStore

            self.store = EventStore(store)
            det = getattr(self.scorer, "detector", None)
            system = getattr(det, "system", None)
            self.run_id = self.store.start_run(
                actuator, command="monitor", source=source, feature=spec.label,
                sample_rate_hz=float(sample_rate), threshold=self.live.threshold,
                system=system if isinstance(system, str) else None,
                config={"method": spec.method, "channels": list(spec.channels),
                        "window": spec.window, "overlap": spec.overlap})
        if bind is not None:
            from leakdiag.dashboard.app import make_app
            from leakdiag.dashboard.server import DashboardServer, stop_on_sigterm

            stop = threading.Event()
            app = make_app(self.board, self.store, bind.token, refresh_hz, stop)
            self.server = DashboardServer(app, bind, stop).start()
            stop_on_sigterm()  # `kill PID` stops a served monitor like Ctrl-C
            say(f"dashboard: {self.server.page_url('live/' + quote(actuator))}")

    def wrap(self, chunks: Iterable) -> Iterator:
        """Yield the chunks, noting the wall-clock time each one arrives.

        Parameters
        ----------
        chunks : iterable of dict
            The (paced) chunk source.

        Yields
        ------
        dict
        """
        for c in chunks:
            self._recv = time.time()
            yield c

    def push(self, events: list) -> None:
        """Take the events of one chunk (from ``Monitor.push``).

        Parameters
        ----------
        events : list of WindowEvent
            Events of one feature, in time order.
        """
        if not events:
            return
        t = np.fromiter((e.time for e in events), np.float64, len(events))
        v = np.fromiter((e.value for e in events), np.float64, len(events))
        s = a = None
        if events[0].score is not None:
            s = np.fromiter((e.score for e in events), np.float64, len(events))
            a = np.fromiter((e.alarm for e in events), bool, len(events))
        self.board.update(self.actuator, t, v, s, a, self._recv)
        if self.store is not None:
            self._write(t, v, s, a)

    def _write(self, t, v, s, a) -> None:
        from leakdiag.store import AlarmRecord, summarize_windows

        live = self.live
        new, updates = [], {}
        evs = list(live.events)  # oldest first; the deque is bounded, so count from the end
        fresh = evs[len(evs) - min(len(evs), live.n_events_total - self._n_events):]
        self._n_events = live.n_events_total
        for e in fresh:
            if e["kind"] == "alarm" and not e["again"]:
                new.append(AlarmRecord(e["time_s"], e["score"], live.threshold, e["onset_s"],
                                       detector=live.feature))
                continue
            if new:  # the episode's alarm row is written with this chunk
                new[-1] = AlarmRecord(**{**new[-1].__dict__, "cleared_time_s":
                                         e["time_s"] if e["kind"] == "cleared" else None})
            elif self._alarm_id is not None:
                updates.setdefault(self._alarm_id, {})["cleared_time_s"] = \
                    e["time_s"] if e["kind"] == "cleared" else None
        leak = (live.leak[0], live.leak[1], live.leak[2]) if live.leak else None
        if new and leak:
            new[-1] = AlarmRecord(**{**new[-1].__dict__, "leak_lpm": leak[0],
                                     "leak_lpm_low": leak[1], "leak_lpm_high": leak[2]})
        elif self._alarm_id is not None and leak and leak != self._sent_leak:
            updates.setdefault(self._alarm_id, {}).update(
                leak_lpm=leak[0], leak_lpm_low=leak[1], leak_lpm_high=leak[2])
        _, ids = self.store.add_chunk(self.run_id, summarize_windows(t, v, s, a), new, updates)
        if ids:
            self._alarm_id = ids[-1]
        self._sent_leak = leak

    def close(self, ok: bool, linger_s: float = 0.0, say: Callable[[str], None] = print) -> None:
        """End the run in the store; keep serving ``linger_s`` seconds, then stop the server.

        Parameters
        ----------
        ok : bool
            Whether the monitor finished without error.
        linger_s : float, default 0.0
            Seconds to keep the page up after the input ended (``inf``: until Ctrl-C or
            SIGTERM).
        say : callable, optional
            Prints a message for the user.
        """
        self.board.finish(self.actuator)
        if self.store is not None:
            self.store.end_run(self.run_id, "finished" if ok else "failed")
            self.store.close()
        if self.server is not None:
            try:
                if ok and linger_s > 0:
                    say(f"dashboard: input ended; serving for {linger_s:g} s more (Ctrl-C stops)")
                    t_end = time.monotonic() + linger_s
                    while time.monotonic() < t_end:
                        time.sleep(min(0.5, max(0.0, t_end - time.monotonic())))
            except KeyboardInterrupt:
                pass
            finally:
                self.server.stop()
