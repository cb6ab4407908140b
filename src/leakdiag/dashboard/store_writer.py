"""The event-store writer of ``leakdiag monitor --store``: a process of its own, fed through a pipe.

The monitor's thread hands each chunk's windows to :meth:`StoreWriter.push`, which writes them
to a pipe (a few hundred bytes, about 1-2 us) and returns. A child process
(:func:`main`) reads the pipe, keeps the live state that the alarm rows need
(:class:`~leakdiag.dashboard.live.ActuatorLive`: alarm episodes, onset, leak estimate), summarises
the chunks (:func:`~leakdiag.store.summarize_chunks`) and commits everything it has read in one
transaction (:class:`ChunkRecorder`). After each transaction it lets the next chunks gather in
the pipe for :data:`GATHER_S` seconds (less when the pipe is half full), so a fast replay costs
one transaction per 0.1 s, not one per chunk (each has a fixed cost of about 2 ms of CPU and
an fsync), while a real-time stream whose chunks come further apart gets one per chunk. So:

* the monitor's process does no SQL, no summaries and no board update for the store: nothing
  that would take Python's GIL from the detector;
* a chunk is out of the monitor's process as soon as ``push`` returns, before the monitor prints
  its events. If the monitor is killed (``kill -9``, a crash), the writer still reads what is in
  the pipe, commits it and ends: every chunk pushed is stored; only a chunk being written to the
  pipe at that instant can be lost (its bytes are then incomplete; the writer says so on stderr).
* the writer ignores Ctrl-C's SIGINT and runs in a session of its own, so a signal to the
  monitor's process group does not stop it half-way: it ends when the pipe does.

A writer that falls behind makes :meth:`StoreWriter.push` wait once the pipe is full (1 MiB where
Linux allows it), which bounds memory. An error of the writer (e.g. the database became
unwritable) is reported on its stdout and raised by the next ``push``, ``flush`` or ``close`` as
:class:`~leakdiag.store.StoreError`.
"""

from __future__ import annotations

import json
import os
import pickle
import signal
import struct
import subprocess
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np

from leakdiag.dashboard.live import ActuatorLive
from leakdiag.store import AlarmRecord, EventStore, StoreError, summarize_chunks

__all__ = ["StoreWriter", "ChunkRecorder", "encode_chunk", "decode_frames", "main"]

#: Frame header: windows in the chunk, flags (1: scores and alarms follow, 2: CUSUM branches).
HEADER = struct.Struct("<IB")
#: Window count of a flush request (no body): the writer answers after committing what precedes.
FLUSH = 0xFFFFFFFF
#: Pipe capacity asked for (Linux ``F_SETPIPE_SZ``; the default 64 KiB holds about 300 chunks).
PIPE_BYTES = 1 << 20
#: Seconds the writer lets chunks gather after each transaction (ended early when the pipe is
#: half full, so that the monitor does not wait for a pausing writer).
GATHER_S = 0.1
_F8 = np.dtype(np.float64)
_CHILD = "import sys; from leakdiag.dashboard.store_writer import main; sys.exit(main())"


def encode_chunk(t, v, s=None, a=None, branches=None) -> bytes:
    """One chunk's windows as a frame of the pipe.

    Parameters
    ----------
    t, v : numpy.ndarray
        Window times (s) and feature values.
    s, a : numpy.ndarray, optional
        Scores and alarms (both or neither).
    branches : tuple of numpy.ndarray, optional
        CUSUM branches (S+, S-) of these windows.

    Returns
    -------
    bytes

    Examples
    --------
    >>> fr = encode_chunk(np.array([0.2]), np.array([0.5]))  # 5-byte header, 2 x 8 bytes
    >>> chunks, flushes, used = decode_frames(fr + fr[:7])  # one frame and part of the next
    >>> [c[:2] for c in chunks], flushes, used
    ([(array([0.2]), array([0.5]))], 0, 21)
    """
    n = len(t)
    if s is None:
        return b"".join((HEADER.pack(n, 0), np.asarray(t, _F8).tobytes(),
                         np.asarray(v, _F8).tobytes()))
    parts = [b"", np.asarray(t, _F8).tobytes(), np.asarray(v, _F8).tobytes(),
             np.asarray(s, _F8).tobytes(), np.asarray(a, bool).tobytes()]
    flags = 1
    if branches is not None and len(branches[0]) == n:
        flags = 3
        parts += [np.asarray(branches[0], _F8).tobytes(), np.asarray(branches[1], _F8).tobytes()]
    parts[0] = HEADER.pack(n, flags)
    return b"".join(parts)


def decode_frames(buf: bytes) -> tuple[list, int, int]:
    """The complete frames at the start of ``buf``.

    Parameters
    ----------
    buf : bytes
        Bytes read from the pipe (may end inside a frame).

    Returns
    -------
    chunks : list of tuple
        ``(t, v, s, a, branches)`` per chunk; ``s``, ``a``, ``branches`` may be None.
    flushes : int
        Flush requests among the frames.
    used : int
        Bytes of the complete frames.
    """
    chunks: list = []
    flushes = pos = 0
    end = len(buf)
    h = HEADER.size
    while pos + h <= end:
        n, flags = HEADER.unpack_from(buf, pos)
        if n == FLUSH:
            flushes += 1
            pos += h
            continue
        size = 16 * n + (9 * n if flags & 1 else 0) + (16 * n if flags & 2 else 0)
        if pos + h + size > end:
            break
        p = pos + h
        t = np.frombuffer(buf, _F8, n, p)
        v = np.frombuffer(buf, _F8, n, p + 8 * n)
        s = a = br = None
        if flags & 1:
            s = np.frombuffer(buf, _F8, n, p + 16 * n)
            a = np.frombuffer(buf, bool, n, p + 24 * n)
        if flags & 2:
            br = (np.frombuffer(buf, _F8, n, p + 25 * n), np.frombuffer(buf, _F8, n, p + 33 * n))
        chunks.append((t, v, s, a, br))
        pos = p + size
    return chunks, flushes, pos


class _ScorerFacts:
    """What the alarm rows need of the monitor's scorer, picklable (no detector code runs)."""

    def __init__(self, scorer: Any):
        self.threshold_ = getattr(scorer, "threshold_", None)
        self.mean_ = getattr(scorer, "mean_", None)
        self.std_ = getattr(scorer, "std_", None)
        self.calibration_ = getattr(getattr(scorer, "detector", None), "calibration_", None)
        self.detector = self  # ActuatorLive reads detector.calibration_


class ChunkRecorder:
    """Alarm rows and chunk summaries of a monitor run, written to the store take by take.

    Parameters
    ----------
    store : EventStore
        Open store.
    run_id : int
        The run (from :meth:`EventStore.start_run`).
    actuator, feature : str
        Actuator name and feature label.
    scorer : object, optional
        The monitor's scorer or its :class:`_ScorerFacts` (threshold, standardisation,
        calibration); None without a detector.
    window_s : float, default 0.0
        Window span in s.
    """

    def __init__(self, store: EventStore, run_id: int, actuator: str, feature: str,
                 scorer: Any = None, window_s: float = 0.0):
        self.store, self.run_id = store, run_id
        self.live = ActuatorLive(actuator, feature, scorer, window_s)
        self._alarm_id: int | None = None
        self._sent_leak = None
        self._n_events = 0

    def apply(self, chunks: list) -> None:
        """Write consecutive chunks in one transaction (summaries, new and changed alarms).

        Parameters
        ----------
        chunks : list of tuple
            ``(t, v, s, a, branches)`` per chunk, as :func:`decode_frames` gives them.

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
        for i0, i1 in zip(cuts[:-1], cuts[1:]):
            seg = slice(i0, i1)
            self.live.update(t[seg], v[seg], None if s is None else s[seg],
                             None if a is None else a[seg], 0.0,
                             None if br is None else (br[0][seg], br[1][seg]))
            self._collect(new, updates)
        summaries = summarize_chunks(t, v, s, a, [len(c[0]) for c in chunks])
        _, ids = self.store.add_chunks(self.run_id, summaries, new, updates)
        if ids:
            self._alarm_id = ids[-1]

    def _collect(self, new: list, updates: dict) -> None:
        """Alarm rows to write for the events since the last call (``new``/``updates`` grow)."""
        live = self.live
        evs = list(live.events)  # oldest first; the deque is bounded, so count from the end
        fresh = evs[len(evs) - min(len(evs), live.n_events_total - self._n_events):]
        self._n_events = live.n_events_total
        for e in fresh:
            if e["kind"] == "alarm" and not e["again"]:
                new.append(AlarmRecord(e["time_s"], e["score"], live.threshold, e["onset_s"],
                                       detector=live.feature))
                continue
            cleared = e["time_s"] if e["kind"] == "cleared" else None
            if new:  # the episode's alarm row is written with these chunks
                new[-1] = replace(new[-1], cleared_time_s=cleared)
            elif self._alarm_id is not None:
                updates.setdefault(self._alarm_id, {})["cleared_time_s"] = cleared
        leak = (live.leak[0], live.leak[1], live.leak[2]) if live.leak else None
        if new and leak:
            new[-1] = replace(new[-1], leak_lpm=leak[0], leak_lpm_low=leak[1],
                              leak_lpm_high=leak[2])
        elif self._alarm_id is not None and leak and leak != self._sent_leak:
            updates.setdefault(self._alarm_id, {}).update(
                leak_lpm=leak[0], leak_lpm_low=leak[1], leak_lpm_high=leak[2])
        self._sent_leak = leak


def _raise_reported(line: bytes, code: int | None) -> None:
    """Raise the error a writer reported (``error {json}``), or one for its silent end."""
    if line.startswith(b"error "):
        err = json.loads(line[6:])
        msg = err["message"] if err["type"] == "StoreError" else \
            f"store writer: {err['type']}: {err['message']}"
        raise StoreError(msg)
    raise StoreError(f"the store writer process ended unexpectedly (exit code {code})")


class StoreWriter:
    """The monitor's end of the writer process: push chunks, flush, close.

    Parameters
    ----------
    url : str
        Store URL (the run exists already).
    run_id : int
        The run.
    actuator, feature : str
        Actuator name and feature label.
    scorer : object, optional
        The monitor's scorer (its threshold, standardisation and calibration are sent).
    window_s : float, default 0.0
        Window span in s.

    Raises
    ------
    leakdiag.store.StoreError
        If the writer cannot start or open the store.
    """

    def __init__(self, url: str, run_id: int, actuator: str, feature: str, scorer: Any = None,
                 window_s: float = 0.0):
        import leakdiag

        root = os.path.dirname(os.path.dirname(os.path.abspath(leakdiag.__file__)))
        env = {**os.environ,
               "PYTHONPATH": os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])])}
        self.proc = subprocess.Popen([sys.executable, "-c", _CHILD], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, env=env, start_new_session=True)
        self._fd = self.proc.stdin.fileno()
        try:
            import fcntl

            fcntl.fcntl(self._fd, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
        except (ImportError, AttributeError, OSError):  # not Linux, or above pipe-max-size
            pass
        cfg = pickle.dumps({"url": url, "run_id": run_id, "actuator": actuator,
                            "feature": feature, "window_s": window_s,
                            "scorer": None if scorer is None else _ScorerFacts(scorer)})
        self._error: StoreError | None = None
        try:
            self._write(struct.pack("<I", len(cfg)) + cfg)
            self._expect(b"ready")
        except BaseException:
            self.close()
            raise

    def _write(self, data: bytes) -> None:
        try:
            n = os.write(self._fd, data)
            while n < len(data):  # a frame larger than the pipe's free space
                data = data[n:]
                n = os.write(self._fd, data)
        except BrokenPipeError:  # the writer ended: say why
            self._expect(b"")
            raise AssertionError("unreachable") from None  # pragma: no cover

    def _expect(self, answer: bytes) -> None:
        """Read the writer's next line: return if it is ``answer``, else raise its error."""
        if self._error is not None:
            raise self._error
        line = self.proc.stdout.readline().rstrip(b"\n")
        if answer and line == answer:
            return
        code = None if line else self.proc.wait()
        try:
            _raise_reported(line, code)
        except StoreError as exc:
            self._error = exc
            raise

    def push(self, t, v, s=None, a=None, branches=None) -> None:
        """Write one chunk's windows to the pipe (waits only while the pipe is full).

        Parameters
        ----------
        t, v, s, a, branches
            As :func:`encode_chunk`.

        Raises
        ------
        leakdiag.store.StoreError
            If the writer has met an error.
        """
        if self._error is not None:
            raise self._error
        if len(t):
            self._write(encode_chunk(t, v, s, a, branches))

    def flush(self) -> None:
        """Wait until the writer has committed every chunk pushed so far.

        Raises
        ------
        leakdiag.store.StoreError
            If the writer has met an error.
        """
        self._write(HEADER.pack(FLUSH, 0))
        self._expect(b"flushed")

    def close(self) -> None:
        """End the pipe and wait for the writer to commit what it holds and exit.

        Raises
        ------
        leakdiag.store.StoreError
            If the writer met an error (also one reported before).
        """
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:
                pass
        lines = [ln.rstrip(b"\n") for ln in self.proc.stdout.read().splitlines()]
        code = self.proc.wait()
        self.proc.stdout.close()
        if self._error is not None:
            raise self._error
        if not lines or lines[-1] != b"done":
            bad = [ln for ln in lines if ln.startswith(b"error ")]
            try:
                _raise_reported(bad[-1] if bad else b"", code)
            except StoreError as exc:
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
            raise EOFError("the monitor ended before the writer was configured")
        out += b
    return out


def _gather(fd: int, seconds: float = GATHER_S, step: float = 0.01) -> None:
    """Sleep up to ``seconds`` while chunks gather in the pipe; stop once it is half full."""
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
    while (left := t_end - time.monotonic()) > 0 and pending() < half:
        time.sleep(min(step, left))


def main() -> int:
    """The writer process: configuration, then frames from stdin until it ends.

    Returns
    -------
    int
        Exit code: 0 when every complete chunk was committed, 1 after an error (reported on
        stdout as ``error {json}``).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the monitor; this ends with it
    try:
        cfg = pickle.loads(_read_exact(0, struct.unpack("<I", _read_exact(0, 4))[0]))
        store = EventStore(cfg["url"], create=False)
        rec = ChunkRecorder(store, cfg["run_id"], cfg["actuator"], cfg["feature"],
                            cfg["scorer"], cfg["window_s"])
    except BaseException as exc:  # noqa: BLE001 - everything is reported to the monitor
        _report(exc)
        return 1
    os.write(1, b"ready\n")
    buf = b""
    try:
        while True:
            data = os.read(0, PIPE_BYTES)
            buf += data
            chunks, flushes, used = decode_frames(buf)
            if chunks:
                rec.apply(chunks)
            if flushes:
                os.write(1, b"flushed\n" * flushes)
            buf = buf[used:]
            if not data:
                break
            _gather(0)
    except BaseException as exc:  # noqa: BLE001
        _report(exc)
        store.close()
        return 1
    if buf:  # the monitor ended in the middle of writing a chunk that it had not emitted yet
        print(f"leakdiag store writer: the monitor ended while writing a chunk; its {len(buf)} "
              "bytes are incomplete and not stored", file=sys.stderr)
    store.close()
    os.write(1, b"done\n")
    return 0
