"""Signals that stop a long command cleanly: SIGINT (Ctrl-C) and SIGTERM (``kill PID``).

``leakdiag monitor`` runs until its input ends, or, following a file or stdin, until the user
stops it; :class:`StopSignals` turns both signals into :class:`Stopped` between two chunks, so
that every chunk is handled whole or not at all and the run ends as stopped, not failed
(docs/operations.md, "Stopping the monitor").
"""

from __future__ import annotations

import signal
import threading

__all__ = ["Stopped", "StopSignals", "signal_name"]


class Stopped(KeyboardInterrupt):
    """The user stopped the monitor with a signal: SIGINT (Ctrl-C) or SIGTERM (``kill PID``).

    Parameters
    ----------
    signum : int
        The signal's number.
    """

    def __init__(self, signum: int):
        super().__init__(int(signum))
        self.signum = int(signum)

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``SIGTERM``."""
        return signal.Signals(self.signum).name


def signal_name(exc: BaseException) -> str:
    """The signal of a :class:`Stopped` (a bare ``KeyboardInterrupt`` is Python's SIGINT)."""
    return exc.name if isinstance(exc, Stopped) else "SIGINT"


class StopSignals:
    """SIGINT and SIGTERM stop the monitor with :class:`Stopped`, between two chunks.

    A signal that arrives while a chunk is handled (``busy``: computed, handed to the sidecar,
    printed) is kept until :meth:`check` at the chunk's end, so that every chunk is handled
    whole or not at all; one that arrives while the monitor waits (for data, for a paced
    replay's next chunk, in the sidecar's hand-over or ``--linger``) stops it at once. A signal
    that this process was started with ignored (SIGINT of a background job) stays ignored.
    Outside the main thread nothing is installed. Used as a context manager, which gives the
    previous handlers back.
    """

    def __init__(self):
        self.busy = False
        self.pending: int | None = None
        self._old: dict = {}

    def __enter__(self) -> "StopSignals":
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                if signal.getsignal(sig) is not signal.SIG_IGN:
                    self._old[sig] = signal.signal(sig, self._on_signal)
        return self

    def __exit__(self, *exc) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, signal.SIG_DFL if old is None else old)
        self._old = {}

    def _on_signal(self, signum, frame) -> None:
        if self.busy:
            self.pending = signum
        else:
            raise Stopped(signum)

    def check(self) -> None:
        """End of a chunk: raise :class:`Stopped` for a signal that came while it was handled.

        Raises
        ------
        Stopped
            If a signal came.
        """
        self.busy = False
        if self.pending is not None:
            signum, self.pending = self.pending, None
            raise Stopped(signum)
