"""What ``leakdiag monitor`` does with ``--store`` and ``--dashboard``, off the detector's path.

:class:`MonitorHooks` keeps the live state of the monitored actuator
(:class:`~leakdiag.dashboard.live.ActuatorLive`) and serves it with ``--dashboard``, and hands
the chunks to the event store's writer process with ``--store``.

The monitor's only cost per chunk is :meth:`MonitorHooks.push`:

* with ``--store``, it writes the chunk's windows to the pipe of the writer process
  (:class:`~leakdiag.dashboard.store_writer.StoreWriter`, about 1-2 us): the summaries, alarm
  rows and transactions are computed in another process, and a chunk is out of the monitor's
  process before its events are printed, so a killed monitor loses no chunk it has emitted;
* with ``--dashboard``, it appends a reference to the chunk's window arrays to a bounded queue. A
  worker thread takes everything queued at once, at most every :data:`UPDATE_PERIOD_S` seconds,
  into one update of the live board that the page reads.
"""

from __future__ import annotations

import gc
import threading
import time
from collections import deque
from typing import Any, Callable, Iterable, Iterator
from urllib.parse import quote

import numpy as np

from leakdiag.dashboard.live import LiveBoard
from leakdiag.store import StoreError

__all__ = ["MonitorHooks"]

#: Seconds the worker pauses after each take, so that the chunks of a fast replay gather into one
#: board update and one store transaction. Small against the page's 1 s latency goal (issue 17).
UPDATE_PERIOD_S = 0.1
#: Windows the monitor may run ahead of the worker before :meth:`MonitorHooks.push` waits
#: (bounds the memory of the queue: about 200 bytes per window).
MAX_PENDING_WINDOWS = 100_000


def _arrays(events: list) -> tuple:
    """(time, values, scores, alarms) of a list of WindowEvent (scores, alarms None without)."""
    n = len(events)
    t = np.fromiter((e.time for e in events), np.float64, n)
    v = np.fromiter((e.value for e in events), np.float64, n)
    if events[0].score is None:
        return t, v, None, None
    return (t, v, np.fromiter((e.score for e in events), np.float64, n),
            np.fromiter((e.alarm for e in events), bool, n))


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
    board : bool, optional
        Keep the live board up to date (default: only with ``bind``, for the page).

    Raises
    ------
    leakdiag.store.StoreError
        If the store cannot be opened.
    """

    def __init__(self, actuator: str, spec: Any, monitor: Any, source: str, sample_rate: float,
                 store: str | None = None, bind: Any = None, refresh_hz: float = 5.0,
                 say: Callable[[str], None] = print, board: bool | None = None):
        self.actuator = actuator
        self.scorer = monitor.scorers[0]
        self.monitor = monitor
        self.board = LiveBoard()
        self.board.add(actuator, spec.label, self.scorer, (spec.window - 1) / sample_rate)
        self.live = self.board._live[actuator]
        self.store = self.run_id = self.server = self.writer = None
        self._board_on = bind is not None if board is None else bool(board)
        self._recv = time.time()
        self._cond = threading.Condition()
        self._pending: deque = deque()
        self._n_pending = self._n_pushed = self._n_done = 0
        self._closing = False
        self._error: BaseException | None = None
        self._wake = threading.Event()
        self._froze_gc = False
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
            from leakdiag.dashboard.store_writer import StoreWriter

            try:
                self.writer = StoreWriter(self.store.url, self.run_id, actuator, spec.label,
                                          self.scorer, (spec.window - 1) / sample_rate)
            except BaseException:
                self.store.end_run(self.run_id, "failed")
                self.store.close()
                raise
        if bind is not None:
            from leakdiag.dashboard.app import make_app
            from leakdiag.dashboard.server import DashboardServer, stop_on_sigterm

            stop = threading.Event()
            app = make_app(self.board, self.store, bind.token, refresh_hz, stop)
            self.server = DashboardServer(app, bind, stop).start()
            stop_on_sigterm()  # `kill PID` stops a served monitor like Ctrl-C
            say(f"dashboard: {self.server.page_url('live/' + quote(actuator))}")
        self._worker = threading.Thread(target=self._work, name="leakdiag-monitor-hooks",
                                        daemon=True)
        if self._board_on:
            self._worker.start()

    def freeze_gc(self) -> None:
        """Move every object loaded so far out of the cyclic garbage collector's way until close.

        The modules, the detector and the server are loaded by now; frozen (``gc.freeze``),
        the collections that the board's worker thread and the server trigger no longer
        traverse them in the monitor's thread (measured when the store was written by that
        thread: the monitor's own CPU time with ``--store`` in a fast replay rose by a quarter
        without this). :meth:`close` unfreezes them, so that a
        monitor run inside a longer-lived process (tests, a notebook) leaves the collector as
        it found it. Nothing is done when someone else has frozen objects already.
        """
        if gc.get_freeze_count() == 0:
            gc.freeze()
            self._froze_gc = True

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
        """Hand the events of one chunk (from ``Monitor.push``) to the store writer and the board.

        Waits only when the store writer's pipe is full or the board's worker is
        :data:`MAX_PENDING_WINDOWS` windows behind.

        Parameters
        ----------
        events : list of WindowEvent
            Events of one feature, in time order.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the worker met (e.g. the database became unwritable).
        """
        if self._error is not None:
            raise self._error
        if not events:
            return
        arrays = self.monitor.last_arrays[0] if self.monitor.last_arrays else None
        if arrays is None or len(arrays[0]) != len(events) or arrays[0][-1] != events[-1].time:
            arrays = _arrays(events)  # not the monitor's last push: take them from the events
        # a chunk is kept as four arrays (no event objects: they would burden the garbage
        # collector of the monitor's thread while they wait)
        br = getattr(self.scorer, "branches_", None)  # a new tuple per scored block
        if self.writer is not None:
            self.writer.push(*arrays, br)
        if not self._board_on:
            return
        with self._cond:
            while self._n_pending >= MAX_PENDING_WINDOWS and self._error is None:
                self._cond.wait()
            self._pending.append((arrays, br, self._recv))
            self._n_pending += len(events)
            self._n_pushed += 1
            self._cond.notify()

    def _work(self) -> None:
        """Worker thread: take every queued chunk into one board update, pause."""
        try:
            while True:
                with self._cond:
                    while not self._pending and not self._closing:
                        self._cond.wait()
                    if not self._pending:
                        return
                    batch = list(self._pending)
                    self._pending.clear()
                    self._n_pending = 0
                    self._cond.notify_all()
                self._apply(batch)
                with self._cond:
                    self._n_done += len(batch)
                    self._cond.notify_all()
                self._wake.wait(UPDATE_PERIOD_S)  # let a fast replay's chunks gather
        except BaseException as exc:  # handed to the monitor's thread by push() and close()
            with self._cond:
                self._error = exc
                self._pending.clear()
                self._n_pending = 0
                self._cond.notify_all()

    def _apply(self, batch: list) -> None:
        """One board update with every chunk of a take (any split gives the same state)."""
        t, v = (np.concatenate([c[k] for c, _, _ in batch]) for k in (0, 1))
        s = a = br = None
        if batch[0][0][2] is not None:
            s, a = (np.concatenate([c[k] for c, _, _ in batch]) for k in (2, 3))
            br = tuple(np.concatenate([c[2] if b is None or len(b[0]) != len(c[0]) else b[k]
                                       for c, b, _ in batch]) for k in (0, 1))
        self.board.update(self.actuator, t, v, s, a, batch[-1][2], br)

    def flush(self) -> None:
        """Wait until every chunk pushed is in the board and committed to the store.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the worker met.
        """
        with self._cond:
            self._wake.set()  # no pause between two takes while someone waits
            while self._n_done < self._n_pushed and self._error is None:
                self._cond.wait(0.05)
            if not self._closing:
                self._wake.clear()
        if self._error is not None:
            raise self._error
        if self.writer is not None:
            self.writer.flush()

    def close(self, ok: bool, linger_s: float = 0.0, say: Callable[[str], None] = print) -> None:
        """Write what is queued, end the run in the store; keep serving, then stop the server.

        Parameters
        ----------
        ok : bool
            Whether the monitor finished without error.
        linger_s : float, default 0.0
            Seconds to keep the page up after the input ended (``inf``: until Ctrl-C or
            SIGTERM).
        say : callable, optional
            Prints a message for the user.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the worker met, when ``ok`` (otherwise the monitor's own error
            is the one to report).
        """
        with self._cond:
            self._closing = True
            self._wake.set()
            self._cond.notify_all()
        if self._worker.is_alive():
            self._worker.join()
        if self._froze_gc:
            self._froze_gc = False
            gc.unfreeze()
        error = self._error
        if self.writer is not None:
            try:
                self.writer.close()  # the writer commits what the pipe holds, then ends
            except StoreError as exc:
                error = error or exc
            self.writer = None
        self.board.finish(self.actuator)
        try:
            if self.store is not None:
                self.store.end_run(self.run_id, "finished" if ok and error is None else "failed")
                self.store.close()
            if ok and error is not None:
                raise error
        finally:
            if self.server is not None:
                try:
                    if ok and error is None and linger_s > 0:
                        say(f"dashboard: input ended; serving for {linger_s:g} s more "
                            "(Ctrl-C stops)")
                        t_end = time.monotonic() + linger_s
                        while time.monotonic() < t_end:
                            time.sleep(min(0.5, max(0.0, t_end - time.monotonic())))
                except KeyboardInterrupt:
                    pass
                finally:
                    self.server.stop()
