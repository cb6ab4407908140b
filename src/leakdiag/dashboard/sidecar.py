"""The sidecar of ``leakdiag monitor --store/--dashboard``: a process of its own, fed through a pipe.

The monitor's thread hands each chunk's windows to :meth:`Sidecar.push`, which writes them to a
pipe (a few hundred bytes, about 1-2 us) and returns. The sidecar process (:func:`main`) reads
the pipe and hands what it read to a :class:`~leakdiag.dashboard.recorder.ChunkRecorder`: one
update of the live board and, with ``--store``, one transaction with the chunks' summaries and
alarm rows. With ``--dashboard`` it also runs the web server that serves the board. After each
take it lets the next chunks gather in the pipe for :data:`GATHER_S` seconds (less when the
pipe is half full, or when the monitor waits for it), so a fast replay costs one board update
and one transaction per 0.1 s, not one per chunk (a transaction has a fixed cost of about 2 ms
of CPU and an fsync), while a real-time stream whose chunks come further apart gets one per
chunk. So:

* the monitor's process runs no SQL, no summaries, no board update and no web server: nothing
  that would take Python's GIL from the detector;
* a chunk is out of the monitor's process as soon as ``push`` returns, before the monitor prints
  its events. If the monitor is killed (``kill -9``, a crash), the sidecar still reads what is in
  the pipe, commits it and ends: every chunk pushed is stored; only a chunk being written to the
  pipe at that instant can be lost (its bytes are then incomplete; the sidecar says so on
  stderr);
* the sidecar ignores Ctrl-C's SIGINT and runs in a session of its own, so a signal to the
  monitor's process group does not stop it half-way: it ends when the pipe does.

A sidecar that falls behind makes :meth:`Sidecar.push` wait once the pipe is full (1 MiB where
Linux allows it), which bounds memory. An error of the sidecar (e.g. the database became
unwritable) is reported on its stdout and raised by the next ``push``, ``flush`` or ``close``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
import pickle
import signal
import struct
import subprocess
import sys
import time
from typing import Any

from leakdiag.dashboard.recorder import (FINISH, FLUSH, HEADER, ChunkRecorder, ScorerFacts,
                                         decode_frames, encode_chunk)
from leakdiag.store import EventStore, StoreError

__all__ = ["Sidecar", "main"]

#: Pipe capacity asked for (Linux ``F_SETPIPE_SZ``; the default 64 KiB holds about 300 chunks).
PIPE_BYTES = 1 << 20
#: Seconds the sidecar lets chunks gather after each take (ended early when the pipe is half
#: full, so that the monitor does not wait for a pausing sidecar, or when the monitor waits).
GATHER_S = 0.1
_CHILD = "import sys; from leakdiag.dashboard.sidecar import main; sys.exit(main())"
_HURRY = [False]  # set by SIGUSR1: the monitor waits for a flush or the end


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

    Raises
    ------
    leakdiag.store.StoreError
        If the sidecar cannot start or open the store.
    OSError
        If the page cannot listen on ``bind``.
    """

    def __init__(self, actuator: str, feature: str, scorer: Any = None, window_s: float = 0.0,
                 url: str | None = None, run_id: int | None = None, bind: Any = None,
                 refresh_hz: float = 5.0):
        root = str(Path(__file__).resolve().parents[2])  # the folder holding the package
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [root, *filter(None, [os.environ.get("PYTHONPATH")])])}
        self.proc = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, env=env, start_new_session=True)
        self._fd = self.proc.stdin.fileno()
        self._error: BaseException | None = None
        self.page_base: str | None = None
        try:
            import fcntl

            fcntl.fcntl(self._fd, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
        except (ImportError, AttributeError, OSError):  # not Linux, or above pipe-max-size
            pass
        cfg = pickle.dumps({"url": url, "run_id": run_id, "actuator": actuator,
                            "feature": feature, "window_s": window_s, "bind": bind,
                            "refresh_hz": refresh_hz,
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
            while n < len(data):  # a frame larger than the pipe's free space
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

    def _hurry(self) -> None:
        try:
            self.proc.send_signal(signal.SIGUSR1)  # end its pause: someone waits
        except ProcessLookupError:  # pragma: no cover - it has ended; _expect says why
            pass

    def push(self, t, v, s=None, a=None, branches=None, received: float = 0.0) -> None:
        """Write one chunk's windows to the pipe (waits only while the pipe is full).

        Parameters
        ----------
        t, v, s, a, branches, received
            As :func:`~leakdiag.dashboard.recorder.encode_chunk`.

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error.
        """
        if self._error is not None:
            raise self._error
        if len(t):
            self._write(encode_chunk(t, v, s, a, branches, received))

    def flush(self) -> None:
        """Wait until the sidecar has taken every chunk pushed so far (board and store).

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error.
        """
        self._write(HEADER.pack(FLUSH, 0, 0.0))
        self._hurry()
        self._expect(b"flushed")

    def finish(self) -> None:
        """Tell the page that the input has ended (the server keeps serving until close).

        Raises
        ------
        leakdiag.store.StoreError
            If the sidecar has met an error.
        """
        self._write(HEADER.pack(FINISH, 0, 0.0))

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
        if self.proc.poll() is None:
            self._hurry()
        lines = [ln.rstrip(b"\n") for ln in self.proc.stdout.read().splitlines()]
        code = self.proc.wait()
        self.proc.stdout.close()
        if self._error is not None:
            raise self._error
        if not lines or lines[-1] != b"done":
            bad = [ln for ln in lines if ln.startswith(b"error ")]
            try:
                _raise_reported(bad[-1] if bad else b"", code)
            except BaseException as exc:
                self._error = exc
                raise


def _report(exc: BaseException) -> None:
    msg = json.dumps({"type": type(exc).__name__, "message": str(exc)})
    os.write(1, f"error {msg}\n".encode())


def _read_exact(fd: int, n: int) -> bytes:
    out = b""
    while len(out) < n:
        b = os.read(fd, n - len(out))
        if not b:
            raise EOFError("the monitor ended before its sidecar was configured")
        out += b
    return out


def _gather(fd: int, seconds: float = GATHER_S, step: float = 0.01) -> None:
    """Sleep up to ``seconds`` while chunks gather in the pipe; stop once it is half full or
    the monitor waits (SIGUSR1)."""
    try:
        import fcntl
        import termios

        half = fcntl.fcntl(fd, fcntl.F_GETPIPE_SZ) // 2
        buf = bytearray(4)

        def pending() -> int:
            fcntl.ioctl(fd, termios.FIONREAD, buf)
            return struct.unpack("<i", buf)[0]
    except (ImportError, AttributeError, OSError):  # not Linux: a plain pause
        half, pending = 1, (lambda: 0)
    t_end = time.monotonic() + seconds
    while not _HURRY[0] and (left := t_end - time.monotonic()) > 0 and pending() < half:
        time.sleep(min(step, left))
    _HURRY[0] = False


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
    """The sidecar process: configuration, then frames from stdin until it ends.

    Returns
    -------
    int
        Exit code: 0 when every complete chunk was taken, 1 after an error (reported on
        stdout as ``error {json}``).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the monitor; this ends with it
    signal.signal(signal.SIGUSR1, lambda *_: _HURRY.__setitem__(0, True))
    signal.siginterrupt(signal.SIGUSR1, False)  # system calls (SQLite's) restart, no EINTR
    store = server = None
    try:
        cfg = pickle.loads(_read_exact(0, struct.unpack("<I", _read_exact(0, 4))[0]))
        if cfg["url"] is not None:
            store = EventStore(cfg["url"], create=False)
        rec = ChunkRecorder(store, cfg["run_id"], cfg["actuator"], cfg["feature"],
                            cfg["scorer"], cfg["window_s"])
        server = _serve(cfg, rec, store)
    except BaseException as exc:  # noqa: BLE001 - everything is reported to the monitor
        _report(exc)
        if store is not None:
            store.close()
        return 1
    import gc

    gc.freeze()  # the modules loaded by now stay out of the collector's way
    page = "" if server is None else " " + server.page_url("")
    os.write(1, f"ready{page}\n".encode())
    buf = b""
    try:
        while True:
            data = os.read(0, PIPE_BYTES)
            buf += data
            chunks, control, used = decode_frames(buf)
            if chunks:
                rec.apply(chunks)
            for c in control:
                if c == FINISH:
                    rec.board.finish(cfg["actuator"])
                else:
                    os.write(1, b"flushed\n")
            buf = buf[used:]
            if not data:
                break
            _gather(0)
    except BaseException as exc:  # noqa: BLE001
        _report(exc)
        return 1
    finally:
        if server is not None:
            server.stop()
        if store is not None:
            store.close()
    if buf:  # the monitor ended in the middle of writing a chunk that it had not emitted yet
        print(f"leakdiag monitor sidecar: the monitor ended while writing a chunk; its "
              f"{len(buf)} bytes are incomplete and not stored", file=sys.stderr)
    os.write(1, b"done\n")
    return 0
