"""What ``leakdiag monitor`` does with ``--store`` and ``--dashboard``, off the detector's path.

:class:`MonitorHooks` starts the monitor's sidecar process
(:class:`~leakdiag.dashboard.sidecar.Sidecar`), which keeps the live state of the monitored
actuator (:class:`~leakdiag.dashboard.live.ActuatorLive`), serves it with ``--dashboard`` and
writes the chunks to the event store with ``--store``. The monitor's only cost per chunk is
:meth:`MonitorHooks.push`: it reads the wall clock (the chunk's time of hand-off, shown on the
page, and once a second a check that the sidecar still runs) and copies the chunk's window
arrays into the sidecar's shared-memory ring (:mod:`leakdiag.dashboard.ring`); about 0.7 us for
a 1,000-sample chunk (docs/operations.md). The run itself is registered in the store (and
ended) by the monitor's process, so that a store that cannot be used stops the monitor before
it starts.
"""

from __future__ import annotations

import sys
import time
from typing import Any, Callable

import numpy as np

from leakdiag.dashboard.live import _num
from leakdiag.dashboard.sidecar import ALIVE_CHECK_S, Sidecar
from leakdiag.store import StoreError

__all__ = ["MonitorHooks"]

_wall = time.time


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
    """Live page and store writer of one monitor run, in a sidecar process.

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
    system : str, optional
        The rig (``vca``/``eha``: the recording's metadata or the detector file's); default:
        the detector's ``system`` attribute, if any.

    Raises
    ------
    leakdiag.store.StoreError
        If the store cannot be opened, or the sidecar cannot start.
    OSError
        If the page cannot listen on ``bind`` (a port in use: refused before the store is
        opened, so no run is stored; :func:`~leakdiag.dashboard.server.check_can_listen`).
    """

    def __init__(self, actuator: str, spec: Any, monitor: Any, source: str, sample_rate: float,
                 store: str | None = None, bind: Any = None, refresh_hz: float = 5.0,
                 say: Callable[[str], None] = print, system: str | None = None):

        self.actuator = actuator
        self.scorer = monitor.scorers[0]
        self.monitor = monitor
        self.store = self.run_id = None
        self._closed = False
        if bind is not None:  # a taken port refused before the run is stored (failed)
            from leakdiag.dashboard.server import check_can_listen

            check_can_listen(bind)
        if store is not None:
            from leakdiag.store import EventStore

            self.store = EventStore(store)
            if system is None:
                system = getattr(getattr(self.scorer, "detector", None), "system", None)
            self.run_id = self.store.start_run(
                actuator, command="monitor", source=source, feature=spec.label,
                sample_rate_hz=float(sample_rate),
                threshold=_num(getattr(self.scorer, "threshold_", None)),
                system=system if isinstance(system, str) else None,
                config={"method": spec.method, "channels": list(spec.channels),
                        "window": spec.window, "overlap": spec.overlap,
                        "detector": self.scorer is not None})
        try:
            self.sidecar = Sidecar(actuator, spec.label, self.scorer,
                                   (spec.window - 1) / sample_rate,
                                   None if self.store is None else self.store.url, self.run_id,
                                   bind, refresh_hz)
        except BaseException:
            if self.store is not None:
                exc = sys.exc_info()[1]
                if isinstance(exc, KeyboardInterrupt):  # Ctrl-C or kill PID while it started
                    self.store.end_run(self.run_id, "stopped", f"stopped by "
                                       f"{getattr(exc, 'name', 'SIGINT')} before the first chunk")
                else:
                    self.store.end_run(self.run_id, "failed",
                                       f"the page or store sidecar did not start: {exc}")
                self.store.close()
            raise
        self._write = self.sidecar.ring.write  # Sidecar.push without its layers
        # the CUSUM branches that a DetectorScorer keeps per push (``branches_``), read from the
        # scorer's __dict__: a getattr that misses raises and catches inside (0.05 us a chunk)
        sd, scorer = getattr(self.scorer, "__dict__", None), self.scorer
        self._attr = sd.get if sd is not None and not hasattr(type(scorer), "branches_") else \
            (lambda name: getattr(scorer, name, None))
        self._one_feature = len(monitor.features) == 1
        # push checks that the sidecar runs when the wall clock leaves [_alive_from, _alive_to)
        self._alive_from = time.time()
        self._alive_to = self._alive_from + ALIVE_CHECK_S
        if bind is not None:  # (leakdiag monitor stops on SIGINT and SIGTERM alike, page or not)
            from leakdiag.dashboard.server import page_path

            say(f"dashboard: {self.page_url(page_path('live', actuator))}")

    def page_url(self, path: str) -> str:
        """Address of a page of the live server (with the token, if any).

        Parameters
        ----------
        path : str
            Path below the server's root, e.g. ``live/rig1``.

        Returns
        -------
        str

        Raises
        ------
        ValueError
            Without ``--dashboard``.
        """
        return self.sidecar.page_url(path)

    def push(self, events: list) -> None:
        """Hand the events of one chunk (from ``Monitor.push``) to the sidecar.

        Waits only while the sidecar's ring is full. Once every :data:`ALIVE_CHECK_S` of wall
        time (and when the clock was set back) it checks that the sidecar process still runs.

        Parameters
        ----------
        events : list of WindowEvent
            Events of one feature, in time order.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the sidecar met (e.g. the database became unwritable), or
            the sidecar process ended.
        """
        if not events:
            return
        now = _wall()
        if not self._alive_from <= now < self._alive_to:
            self._alive_from, self._alive_to = now, now + ALIVE_CHECK_S
            self.sidecar.check_alive()
        mon = self.monitor
        if events is mon.last_events and self._one_feature:  # the monitor's last push
            t, v, s, a = mon.last_arrays[0]  # of one length (RingWriter.write)
            self._write(t, v, s, a, self._attr("branches_"), now)
        else:  # take them from the events
            self._write(*_arrays(events), self._attr("branches_"), now)

    def flush(self) -> None:
        """Wait until every chunk pushed is on the board and committed to the store.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the sidecar met.
        """
        self.sidecar.flush()

    def close(self, ok: bool, linger_s: float = 0.0, say: Callable[[str], None] = print,
              reason: str | None = None, stopped: bool = False,
              unjudged: str | None = None) -> None:
        """Take what is queued, end the run in the store; keep serving, then stop the sidecar.

        Parameters
        ----------
        ok : bool
            Whether the monitor ended without error (at the end of its input, or stopped).
        linger_s : float, default 0.0
            Seconds to keep the page up after the input ended (``inf``: until Ctrl-C or
            SIGTERM); not after a stop.
        say : callable, optional
            Prints a message for the user.
        reason : str, optional
            Why the monitor did not finish: its error (stored with the failed run), or with
            ``stopped`` what stopped it (e.g. "stopped by SIGTERM after 1263 windows").
        stopped : bool, default False
            The user stopped the monitor before the end of its input (a signal): the run ends
            as ``stopped`` with ``reason``, every chunk pushed stored.
        unjudged : str, optional
            Why the run, though it ended without error, judged nothing: no window was scored
            (all in the detector's burn-in), or the feature was undefined longer than the
            detector's healthy recordings allow (``BLIND``). The run then ends ``unjudged``
            with this reason (and a stop's ``reason`` after it), so that the fleet page does
            not show ``OK`` for it.

        Raises
        ------
        leakdiag.store.StoreError
            Or any other error the sidecar met, when ``ok`` (otherwise the monitor's own error
            is the one to report).

        Notes
        -----
        A ``KeyboardInterrupt`` (Ctrl-C, or the monitor's SIGTERM) while the last chunks are
        handed over ends the wait for them, not the run: the sidecar takes every chunk pushed
        when its pipe ends, so the run ends as it would have (``finished`` at the end of the
        input), and the page is not kept up.
        """
        if self._closed:
            return
        self._closed = True
        error = interrupted = None
        try:
            self.sidecar.finish()
            self.sidecar.flush()
        except (StoreError, OSError) as exc:
            error = exc
        except KeyboardInterrupt as exc:  # the ring is taken when the pipe ends all the same
            interrupted = exc
        try:
            if self.store is not None:
                if not ok or error is not None:
                    status, why = "failed", reason if not ok else \
                        f"{type(error).__name__}: {error}"
                elif unjudged is not None:
                    status, why = "unjudged", unjudged if not stopped else \
                        f"{unjudged}; {reason}"
                else:
                    status, why = ("stopped", reason) if stopped else ("finished", None)
                self.store.end_run(self.run_id, status, why)
                self.store.close()
            if ok and error is None and interrupted is None and not stopped and linger_s > 0 \
                    and self.sidecar.page_base is not None:
                say(f"dashboard: input ended; serving for {linger_s:g} s more (Ctrl-C stops)")
                t_end = time.monotonic() + linger_s
                try:
                    while time.monotonic() < t_end:
                        time.sleep(min(0.5, max(0.0, t_end - time.monotonic())))
                except KeyboardInterrupt:
                    pass
        finally:
            try:
                self.sidecar.close()
            except (StoreError, OSError) as exc:
                error = error or exc
        if ok and error is not None:
            raise error
