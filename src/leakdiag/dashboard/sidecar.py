"""The sidecar of ``leakdiag monitor --store/--dashboard``: a process of its own, fed by a ring.

The monitor's thread hands each chunk's windows to :meth:`Sidecar.push`, which copies them into
a ring in shared memory (:mod:`leakdiag.dashboard.ring`; under 1 us, no system call) and
returns (:class:`~leakdiag.dashboard.hooks.MonitorHooks` writes to the ring itself, with the
same check that the sidecar still runs). The sidecar process (:func:`main`) polls the ring
and hands what it took to a :class:`~leakdiag.dashboard.recorder.ChunkRecorder`: one update
of the live board and, with ``--store``, one transaction with the chunks' summaries and alarm
rows. With ``--dashboard`` it also runs the web server that serves the board. After each take it lets the next chunks gather
for :data:`GATHER_S` seconds (less when the ring is half full, or when the monitor asks through
the pipe), so a fast replay costs one board update and one transaction per 0.1 s, not one per
chunk (a transaction has a fixed cost of about 2 ms of CPU and an fsync); once that time is up
it looks every :data:`POLL_S` seconds, so a chunk of a real-time stream is taken within 0.1 s.
The pipe to the sidecar's stdin carries the configuration, then the control requests (flush,
end of input), and its end of file says that the monitor has ended. So:

* the monitor's process runs no SQL, no summaries, no board update and no web server: nothing
  that would take Python's GIL from the detector;
* a chunk is out of the monitor's process as soon as ``push`` returns, before the monitor prints
  its events: the ring is a memory file that the sidecar has mapped too. If the monitor is
  killed (``kill -9``, a crash), the sidecar sees the pipe end, takes what is in the ring,
  commits it and ends: every chunk pushed is stored; a chunk being written at that instant is
  not, and the sidecar says so on stderr (its events were not printed);
* the sidecar ignores Ctrl-C's SIGINT and runs in a session of its own, so a signal to the
  monitor's process group does not stop it half-way: it ends when the pipe does;
* the sidecar runs at a lower priority (:data:`NICE`): where cores are short, the detector
  gets them first.

A sidecar that falls behind makes :meth:`Sidecar.push` wait once the ring is full (4 MiB),
which bounds memory. An error of the sidecar (e.g. the database became unwritable) is flagged in
the ring and reported on its stdout, and raised by the next ``push``, ``flush`` or ``close``; a
sidecar that ended without a word is raised by ``push`` within :data:`ALIVE_CHECK_S`.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
import pickle
import select
import signal
import struct
import subprocess
import sys
import time
from typing import Any

from leakdiag.dashboard.recorder import ChunkRecorder, ScorerFacts
from leakdiag.dashboard.ring import RING_BYTES, RingReader, RingWriter, ring_file
from leakdiag.store import EventStore, StoreError

__all__ = ["Sidecar", "main"]

#: Seconds the sidecar lets chunks gather after each take (ended early when the ring is half
#: full, so that the monitor does not wait for a pausing sidecar, or by a request on the pipe).
GATHER_S = 0.1
#: Seconds between two looks at the ring while it gathers or waits.
POLL_S = 0.01
#: Seconds between two checks by ``push`` that the sidecar process still runs (a sidecar killed
#: from outside would otherwise be noticed only when the ring fills, hours later in real time;
#: a clock read per push costs about 0.05 us, the check itself one waitpid per second).
ALIVE_CHECK_S = 1.0
#: Control requests on the pipe (one byte each): flush (the sidecar answers ``flushed`` once
#: every chunk pushed before it is taken) and end of input (the page shows "input ended").
FLUSH, FINISH = b"F", b"E"
#: Niceness added to the sidecar process: on a machine with fewer free cores than busy
#: processes, the scheduler gives the monitor's thread about three times the sidecar's share
#: (Linux CFS weights 1024 against 335), so the page and the store fall behind, not the
#: detector. The sidecar needs a few % of a core in real time, so its chunks still reach the
#: page in time (docs/operations.md has the latency measured under load).
NICE = 5
_CHILD = "import sys; from leakdiag.dashboard.sidecar import main; sys.exit(main())"


def _raise_reported(line: bytes, code: int | None) -> None:
    """Raise the error the sidecar reported (``error {json}``), or one for its silent end."""
    if line.startswith(b"error "):
        err = json.loads(line[6:])
        if err["type"] == "OSError":  # e.g. the page's port is taken
            raise OSError(err["message"])
        msg = err["message"] if err["type"] == "StoreError" else \
            f"monitor sidecar: {err['type']}: {err['message']}"
        raise StoreError(msg)
    raise StoreError(f"the monitor's sidecar process ended unexpectedly (exit code {code})")


class Sidecar:
    """The monitor's end of the sidecar process: push chunks, flush, finish, close.

    Parameters
    ----------
    actuator, feature : str
        Actuator name and feature label.
    scorer : object, optional
        The monitor's scorer (its threshold, standardisation and calibration are sent).
    window_s : float, default 0.0
        Window span in s.
    url : str, optional
        Store URL (the run exists already); None: no store.
    run_id : int, optional
        The run in the store.
    bind : leakdiag.dashboard.server.Bind, optional
        Serve the live page there.
    refresh_hz : float, default 5.0
        Largest page update rate.
    ring_bytes : int, default RING_BYTES
        Size of the shared-memory ring.

    Raises
    ------
    leakdiag.store.StoreError
        If the sidecar cannot start or open the store.
    OSError
        If the page cannot listen on ``bind``.
    """

    def __init__(self, actuator: str, feature: str, scorer: Any = None, window_s: float = 0.0,
                 url: str | None = None, run_id: int | None = None, bind: Any = None,
                 refresh_hz: float = 5.0, ring_bytes: int = RING_BYTES):
        root = str(Path(__file__).resolve().parents[2])  # the folder holding the package
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [root, *filter(None, [os.environ.get("PYTHONPATH")])])}
        fd = ring_file(ring_bytes)
        try:
            self.ring = RingWriter(fd, ring_bytes, self._on_full)
            self.proc = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, env=env, pass_fds=(fd,),
                                         start_new_session=True)
        finally:
            os.close(fd)  # both ends hold their mapping
        self._fd = self.proc.stdin.fileno()
        self._error: BaseException | None = None
        self._alive_until = time.monotonic() + ALIVE_CHECK_S
        self.page_base: str | None = None
        cfg = pickle.dumps({"url": url, "run_id": run_id, "actuator": actuator,
                            "feature": feature, "window_s": window_s, "bind": bind,
                            "refresh_hz": refresh_hz, "ring": (fd, ring_bytes),
                            "scorer": None if scorer is None else ScorerFacts(scorer)})
        try:
            self._write(struct.pack("<I", len(cfg)) + cfg)
            line = self._expect(b"ready")
            self.page_base = line[6:].decode() or None
        except BaseException:
            self.close()
            raise

    def page_url(self, path: str) -> str:
        """Address of a page of the sidecar's server (with the token, if any).

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
            If the sidecar serves no page.
        """
        if self.page_base is None:
            raise ValueError("this monitor serves no page (no --dashboard)")
        base, _, query = self.page_base.partition("?")
        return base + path + (f"?{query}" if query else "")

    def _write(self, data: bytes) -> None:
        try:
            n = os.write(self._fd, data)
            while n < len(data):  # a configuration larger than the pipe's free space
                data = data[n:]
                n = os.write(self._fd, data)
        except BrokenPipeError:  # the sidecar ended: say why
            self._expect(b"")
            raise AssertionError("unreachable") from None  # pragma: no cover

    def _expect(self, answer: bytes) -> bytes:
        """Read the sidecar's next line: return it if it starts with ``answer``, else raise."""
        if self._error is not None:
            raise self._error
        line = self.proc.stdout.readline().rstrip(b"\n")
        if answer and line.split(b" ", 1)[0] == answer:
            return line
        code = None if line else self.proc.wait()
        try:
            _raise_reported(line, code)
        except BaseException as exc:
            self._error = exc
            raise
        raise AssertionError("unreachable")  # pragma: no cover

    def _on_full(self) -> None:
        """The ring is full: raise if the sidecar has stopped, else wait a little for it."""
        if self.ring.failed or self.proc.poll() is not None:
            self._expect(b"")
        time.sleep(POLL_S / 10)

    def push(self, t, v, s=None, a=None, branches=None, received: float = 0.0) -> None:
        """Copy one chunk's windows into the ring (waits only while the ring is full).

        Parameters
        ----------
        t, v, s, a, branches, received
            As :meth:`~leakdiag.dashboard.ring.RingWriter.push`.

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error, or has ended (checked at most once every
            :data:`ALIVE_CHECK_S`).
        ValueError
            If the arrays are not float64 (alarms: bool) of one length.
        """
        if self._error is not None:
            raise self._error
        now = time.monotonic()
        if now >= self._alive_until:  # a sidecar that died silently (killed, OOM): say so
            self._alive_until = now + ALIVE_CHECK_S
            self.check_alive()
        if len(t):  # (the ring raises the error that the sidecar flagged)
            self.ring.push(t, v, s, a, branches, received)

    def check_alive(self) -> None:
        """Raise if the sidecar process has ended (one ``waitpid``, no wait).

        Raises
        ------
        leakdiag.store.StoreError
            Saying why it ended (the error it reported, or its exit code).
        """
        if self.proc.poll() is not None:
            self._expect(b"")

    def flush(self) -> None:
        """Wait until the sidecar has taken every chunk pushed so far (board and store).

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error.
        """
        self._write(FLUSH)
        self._expect(b"flushed")

    def finish(self) -> None:
        """Tell the page that the input has ended (the server keeps serving until close).

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error.
        """
        self._write(FINISH)

    def close(self) -> None:
        """End the pipe and wait for the sidecar to take what it holds, stop serving and exit.

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar met an error (also one reported before).
        """
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
        lines = [ln.rstrip(b"\n") for ln in self.proc.stdout.read().splitlines()]
        code = self.proc.wait()
        self.proc.stdout.close()
        self.ring.close()
        if self._error is not None:
            raise self._error
        if not lines or lines[-1] != b"done":
            bad = [ln for ln in lines if ln.startswith(b"error ")]
            try:
                _raise_reported(bad[-1] if bad else b"", code)
            except BaseException as exc:
                self._error = exc
                raise


def _tell(line: bytes) -> None:
    """Write a line to the monitor; nothing once it has ended (it reads no more answers)."""
    try:
        os.write(1, line)
    except BrokenPipeError:  # the monitor has ended (stopped, killed): its pipe is closed
        pass


def _report(exc: BaseException) -> None:
    msg = json.dumps({"type": type(exc).__name__, "message": str(exc)})
    _tell(f"error {msg}\n".encode())


def _read_exact(fd: int, n: int) -> bytes:
    out = b""
    while len(out) < n:
        b = os.read(fd, n - len(out))
        if not b:
            raise EOFError("the monitor ended before its sidecar was configured")
        out += b
    return out


def _wait(ring: RingReader, since: float) -> bool:
    """Wait until the pipe has something (True) or chunks are due (False): the ring is half full,
    or holds chunks and :data:`GATHER_S` has passed since the take at ``since``."""
    half = ring.capacity // 2
    while True:
        held = ring.held()
        if held >= half or (held and time.monotonic() - since >= GATHER_S):
            return False
        if select.select([0], [], [], POLL_S)[0]:
            return True


def _serve(cfg: dict, rec: ChunkRecorder, store: EventStore | None):
    """Start the page's server in this process; returns it (None without ``bind``)."""
    if cfg["bind"] is None:
        return None
    import threading

    from leakdiag.dashboard.app import make_app
    from leakdiag.dashboard.server import DashboardServer

    stop = threading.Event()
    app = make_app(rec.board, store, cfg["bind"].token, cfg["refresh_hz"], stop)
    return DashboardServer(app, cfg["bind"], stop).start()


def main() -> int:
    """The sidecar process: configuration, then chunks from the ring until the pipe ends.

    Returns
    -------
    int
        Exit code: 0 when every complete chunk was taken, 1 after an error (reported on
        stdout as ``error {json}``).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the monitor; this ends with it
    try:
        os.nice(NICE)  # where cores are short, the monitor's thread runs first
    except OSError:  # pragma: no cover - not allowed here
        pass
    store = server = ring = None
    try:
        cfg = pickle.loads(_read_exact(0, struct.unpack("<I", _read_exact(0, 4))[0]))
        ring = RingReader(*cfg["ring"])
        os.close(cfg["ring"][0])
        if cfg["url"] is not None:
            store = EventStore(cfg["url"], create=False)
        rec = ChunkRecorder(store, cfg["run_id"], cfg["actuator"], cfg["feature"],
                            cfg["scorer"], cfg["window_s"])
        server = _serve(cfg, rec, store)
    except BaseException as exc:  # noqa: BLE001 - everything is reported to the monitor
        if ring is not None:
            ring.fail()
        _report(exc)
        if store is not None:
            store.close()
        return 1
    import gc

    gc.freeze()  # the modules loaded by now stay out of the collector's way
    page = "" if server is None else " " + server.page_url("")
    _tell(f"ready{page}\n".encode())
    lost = None
    try:
        taken = time.monotonic()
        while True:
            control = os.read(0, 4096) if _wait(ring, taken) else None
            chunks, lost = ring.take(final=control == b"")  # after the read: all pushed before
            if chunks:
                rec.apply(chunks)
            for c in control or b"":
                if c == FINISH[0]:
                    rec.board.finish(cfg["actuator"])
                else:
                    _tell(b"flushed\n")
            taken = time.monotonic()
            if control == b"":  # the monitor has closed the pipe or ended
                break
    except BaseException as exc:  # noqa: BLE001
        ring.fail()
        _report(exc)
        return 1
    finally:
        if server is not None:
            server.stop()
        if store is not None:
            store.close()
    if lost:  # the monitor ended while writing a chunk that it had not printed yet
        print(f"leakdiag monitor sidecar: the monitor ended while writing a chunk: {lost}; "
              "incomplete, not stored", file=sys.stderr)
    _tell(b"done\n")
    return 0
