"""The shared-memory ring through which the monitor hands each chunk's windows to its sidecar.

One producer (the monitor's thread, :class:`RingWriter`) and one consumer (the sidecar process,
:class:`RingReader`) share a memory file (``memfd_create``; elsewhere an unlinked temporary
file) that both map. A chunk costs the monitor one ``bytes.join`` of the frame's header and
arrays, one slice assignment into the mapping and two 8-byte stores, no system call: about
0.6 us for a 1,000-sample chunk in a tight loop, about 0.8 us in the monitor's loop, where
the caches hold the detector's data rather than this code's (docs/operations.md has the
measurements).

Layout (byte offsets; the positions are totals since the start, so ``W - R`` is what is held):

* 0: ``W``, end of the last published frame (written by the producer);
* 64: ``P``, end of the frame being written (``P > W`` while the producer is inside ``push``);
* 128: ``R``, how far the consumer has taken (written by the consumer);
* 192: status, set by the consumer when it stops on an error (the producer checks it per push);
* :data:`DATA_OFFSET`: the data area of ``capacity`` bytes. A frame never wraps: one that does
  not fit before the end starts the next lap, after a :data:`WRAP` marker (no marker when fewer
  than a header's bytes are left; the consumer skips them too).

Frame: header (:data:`HEADER`: windows ``n``, flags, arrival wall time, CRC-32 or 0), then the
float64 arrays time, value, [score, [S+, S-]] and, with scores, the alarms as ``n`` bytes; padded
to 8 bytes. Flag :data:`CONTINUED`: a chunk larger than a quarter of the ring is sent as several
frames, each but the last flagged; the consumer joins them before it hands the chunk on.

**Why the consumer never reads a half-written frame.** The producer writes ``P``, then the
frame, then ``W``; the consumer reads ``W``, then the frames before it, then publishes ``R``
after copying them out; the producer overwrites bytes only below ``R + capacity``. ``W``, ``P``
and ``R`` are aligned 8-byte words written and read through a ``memoryview`` cast to ``"Q"``,
which CPython compiles to one 8-byte ``memcpy``, a single move on x86-64 and ARM64: a word is
never seen half-written. On x86-64 (total store order) stores become visible in program order
and loads are not reordered with other loads or with later stores, so a ``W`` seen implies the
frame bytes before it are seen, and an ``R`` seen implies the consumer has finished reading
below it. ARM64 and other weakly ordered processors give no such order without a fence, which
Python cannot issue; there each frame carries its CRC-32 (flag :data:`CHECKED`, about 0.15 us
more per chunk), and the consumer takes a frame only when the CRC of its copy matches: a frame
whose bytes were not all visible yet is read again at the next take, one still wrong then is an
error (the sidecar stops and reports it), and one wrong when the producer has ended is
reported and not stored. The consumer's ``R`` store then depends on the check of the bytes it
copied, and ARM64 does not make a store visible before the loads that it depends on. After
the producer's death the consumer sees every store the producer made: its pipe's end-of-file
is delivered through the kernel, which orders them. Both ends map the file with
``MAP_POPULATE`` (Linux), so its pages are faulted in at start (about 7 ms for 4 MiB), not one
by one inside the monitor's loop during the first lap.

**A producer killed inside** ``push`` leaves ``P > W``: the consumer reports those bytes (and a
chunk of which only ``CONTINUED`` frames arrived) as incomplete, and stores none of it. Such a
chunk's events were not printed yet: the monitor prints them after ``push`` returns.
"""

from __future__ import annotations

import mmap
import os
import platform
import struct
import tempfile
import zlib
from typing import Callable

import numpy as np

__all__ = ["RingWriter", "RingReader", "ring_file", "RING_BYTES"]

#: Data area of the ring (bytes). A 1,000-sample chunk of the thesis's detector (5 windows) is
#: 240 bytes, so the ring holds about 17,000 such chunks, 0.3 s of a fast replay.
RING_BYTES = 1 << 22
#: Where the data area starts (the first page holds the positions).
DATA_OFFSET = 4096
_W, _P, _R, _STATUS = 0, 8, 16, 24  # word indices (x 8 bytes: offsets 0, 64, 128, 192)
#: Frame header: windows, flags, arrival wall time (``time.time()``), CRC-32 of the body (0).
HEADER = struct.Struct("<IIdI4x")
#: Window count of the marker that sends the consumer to the next lap.
WRAP = 0xFFFFFFFF
SCORES, BRANCHES, CONTINUED, CHECKED = 1, 2, 4, 8
_ORDERED = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686", "x86")
_H = HEADER.size
_F8 = np.dtype(np.float64)
_PAD = tuple(bytes(k) for k in range(8))  # zero bytes that pad a frame to 8
_cat = b"".join


def ring_file(capacity: int = RING_BYTES) -> int:
    """A new zeroed memory file for a ring of ``capacity`` bytes; returns its descriptor.

    Parameters
    ----------
    capacity : int, default RING_BYTES
        Data area in bytes (a multiple of 8, at least 4096).

    Returns
    -------
    int
        File descriptor (inheritable by a child through ``pass_fds``).

    Raises
    ------
    ValueError
        If ``capacity`` is not a multiple of 8 or below 4096.
    """
    if capacity % 8 or capacity < 4096:
        raise ValueError(f"{capacity=} must be a multiple of 8 and at least 4096")
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("leakdiag-ring")
    else:  # pragma: no cover - not Linux
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    os.ftruncate(fd, DATA_OFFSET + capacity)
    return fd


def frame_size(n: int, flags: int) -> int:
    """Bytes of a frame of ``n`` windows with ``flags`` (header and padding included).

    Parameters
    ----------
    n : int
        Windows in the frame.
    flags : int
        :data:`SCORES`, :data:`BRANCHES` (with scores) and others.

    Returns
    -------
    int

    Examples
    --------
    >>> frame_size(5, 0), frame_size(5, SCORES), frame_size(5, SCORES | BRANCHES)
    (104, 152, 232)
    """
    k = 2 + (flags & SCORES) + (flags & BRANCHES)
    return (_H + 8 * k * n + (n if flags & SCORES else 0) + 7) & -8


class _Ring:
    def __init__(self, fd: int, capacity: int):
        self.capacity = capacity
        # faulted in now (Linux MAP_POPULATE), not page by page inside the monitor's loop
        self.mm = mmap.mmap(fd, DATA_OFFSET + capacity,
                            flags=mmap.MAP_SHARED | getattr(mmap, "MAP_POPULATE", 0))
        self.idx = memoryview(self.mm).cast("Q")  # the positions, one aligned word each

    def close(self) -> None:
        self.idx.release()
        self.mm.close()


class RingWriter(_Ring):
    """The producer's end: :meth:`push` one chunk's windows per call.

    Parameters
    ----------
    fd : int
        From :func:`ring_file` (may be closed once this is made).
    capacity : int
        Its data area in bytes.
    on_full : callable
        Called repeatedly while the ring has no room (the reader falls behind), and once when
        the reader has flagged an error: it should raise if the reader has ended or failed,
        else wait a little.
    checked : bool, optional
        Add a CRC-32 to each frame; default: on processors other than x86 (see the module
        docstring).
    """

    def __init__(self, fd: int, capacity: int, on_full: Callable[[], None],
                 checked: bool | None = None):
        super().__init__(fd, capacity)
        self.on_full = on_full
        self.checked = (not _ORDERED) if checked is None else checked
        self._w = self._r = 0
        # a frame that ends at or below _limit needs no wrap and no wait: it goes at mmap
        # offset w + _base (the fast path of push; _reserve sets both)
        self._base, self._limit = DATA_OFFSET, capacity
        self._cont = 0  # CONTINUED while _push_split writes all but the last part
        #: Frames that started a new lap, and pushes that waited for room (for the tests).
        self.n_wraps = self.n_waits = 0

    @property
    def failed(self) -> bool:
        """Whether the reader has stopped on an error."""
        return bool(self.idx[_STATUS])

    def _reserve(self, size: int) -> int:
        """Room for a frame of ``size`` bytes: announce it (``P``), return its mmap offset."""
        w, cap = self._w, self.capacity
        pos = w % cap
        skip = cap - pos if cap - pos < size else 0
        end = w + skip + size
        if end - self._r > cap:
            self._r = self.idx[_R]
            if end - self._r > cap:
                self.n_waits += 1
                while end - self._r > cap:
                    self.on_full()
                    self._r = self.idx[_R]
        self.idx[_P] = end
        if skip:
            self.n_wraps += 1
            if skip >= _H:
                HEADER.pack_into(self.mm, DATA_OFFSET + pos, WRAP, 0, 0.0, 0)
        self._w = end
        lap = w + skip - (w + skip) % cap  # where this frame's lap starts
        self._base, self._limit = DATA_OFFSET - lap, min(lap + cap, self._r + cap)
        return DATA_OFFSET + (w + skip) % cap

    def push(self, t, v, s=None, a=None, branches=None, received: float = 0.0) -> None:
        """Write one chunk's windows and publish them.

        Parameters
        ----------
        t, v : numpy.ndarray
            Window times (s) and feature values (float64, contiguous).
        s, a : numpy.ndarray, optional
            Scores (float64) and alarms (bool), both or neither.
        branches : tuple of numpy.ndarray, optional
            CUSUM branches (S+, S-) of these windows (ignored unless they match ``t``).
        received : float, default 0.0
            Wall-clock time at which the chunk arrived.

        Raises
        ------
        ValueError
            If an array has another item size than float64 (alarms: bool), another length
            than ``t`` or is not contiguous (nothing is published then).
        """
        n = len(t)
        try:
            same = len(v) == n if s is None else len(v) == len(s) == len(a) == n
        except TypeError as exc:  # e.g. scores without alarms
            raise _bad(n, exc) from None
        if not same:
            raise _bad(n, "arrays of different lengths")
        self.write(t, v, s, a, branches, received)

    def write(self, t, v, s=None, a=None, branches=None, received: float = 0.0) -> None:
        """:meth:`push` without the check of the arrays' lengths: for arrays made together.

        The monitor's arrays of one push have one length by construction (the feature's times
        and values; scores and alarms checked by :class:`~leakdiag.stream.Monitor`); the frame
        is one ``bytes.join`` of the header and the arrays, written by one slice assignment,
        whose size check still refuses an array of another item size or length (unless two
        such errors cancel out). About 0.5 us per 1,000-sample chunk in the monitor's loop.

        Parameters
        ----------
        t, v, s, a, branches, received
            As :meth:`push`.

        Raises
        ------
        ValueError
            If the frame does not have the size of ``len(t)`` windows, or an array is not
            contiguous (nothing is published then).
        """
        idx = self.idx
        if idx[_STATUS]:
            self.on_full()  # raises: the reader has stopped on an error
        n = len(t)
        if s is None:
            flags, size = 0, _H + 16 * n
            frame = (HEADER.pack(n, self._cont, received, 0), t, v)
        elif branches is None or len(branches[0]) != n:
            flags, size = SCORES, (_H + 25 * n + 7) & -8
            frame = (HEADER.pack(n, SCORES | self._cont, received, 0), t, v, s, a, _PAD[-n & 7])
        else:
            flags, size = SCORES | BRANCHES, (_H + 41 * n + 7) & -8
            frame = (HEADER.pack(n, SCORES | BRANCHES | self._cont, received, 0), t, v, s,
                     branches[0], branches[1], a, _PAD[-n & 7])
        end = self._w + size
        if end <= self._limit:  # no wrap, room: the usual case
            p = end - size + self._base
            self._w = idx[_P] = end
        elif size > self.capacity // 4:  # a huge chunk: several frames
            self._push_split(t, v, s, a, branches if flags & BRANCHES else None, received)
            return
        else:
            p = self._reserve(size)
        mm = self.mm
        try:
            mm[p:p + size] = _cat(frame)
            if self.checked:
                HEADER.pack_into(mm, p, n, flags | CHECKED | self._cont, received,
                                 zlib.crc32(mm[p + _H:p + size]))
        except (IndexError, ValueError, TypeError, BufferError) as exc:
            self._w = idx[_P] = idx[_W]  # nothing was published: the next frame goes here
            self._limit = -1  # _reserve places the next frame (it may not be in this lap)
            raise _bad(n, exc) from None
        idx[_W] = self._w  # publish: after the frame's bytes (module docstring)

    def _push_split(self, t, v, s, a, branches, received: float) -> None:
        k = 2 + (s is not None) + 2 * (branches is not None)
        step = max(1, (self.capacity // 4 - _H - 8) // (8 * k + 1))
        for i in range(0, len(t), step):
            j = slice(i, i + step)
            self._cont = CONTINUED if i + step < len(t) else 0
            try:
                self.write(t[j], v[j], None if s is None else s[j], None if a is None else a[j],
                          None if branches is None else (branches[0][j], branches[1][j]),
                          received)
            finally:
                self._cont = 0


def _bad(n: int, exc: BaseException | str) -> ValueError:
    return ValueError(f"a chunk's window arrays must be {n} contiguous float64 values each "
                      f"(alarms: bool): {exc}")


class RingReader(_Ring):
    """The consumer's end: :meth:`take` what the producer has published.

    Parameters
    ----------
    fd : int
        The ring's memory file (from the producer).
    capacity : int
        Its data area in bytes.
    """

    def __init__(self, fd: int, capacity: int):
        super().__init__(fd, capacity)
        self._part: list = []  # frames of a chunk whose CONTINUED frames are not all here
        self._bad_at = -1  # where a frame failed its CRC check at the last take

    def held(self) -> int:
        """Bytes published and not taken yet.

        Returns
        -------
        int
        """
        return self.idx[_W] - self.idx[_R]

    def fail(self) -> None:
        """Tell the producer that the reader stopped on an error (its next push raises)."""
        self.idx[_STATUS] = 1

    def take(self, final: bool = False) -> tuple[list, str | None]:
        """Copy out every published frame and free its room.

        Parameters
        ----------
        final : bool, default False
            The producer has ended: what is still incomplete will stay so.

        Returns
        -------
        chunks : list of tuple
            ``(t, v, s, a, branches, received)`` per complete chunk (``s``, ``a``,
            ``branches`` may be None), in order.
        lost : str or None
            With ``final``: what was incomplete or corrupt and not returned, else None.

        Raises
        ------
        RuntimeError
            If a frame failed its CRC check at two takes in a row (not ``final``).
        """
        mm, cap, idx = self.mm, self.capacity, self.idx
        w, r = idx[_W], idx[_R]
        chunks: list = []
        bad = None
        while r < w:
            pos = r % cap
            p = DATA_OFFSET + pos
            if cap - pos < _H:
                r += cap - pos
                continue
            n, flags, received, crc = HEADER.unpack_from(mm, p)
            if n == WRAP:
                r += cap - pos
                continue
            size = frame_size(n, flags)
            body = mm[p + _H:p + size]
            if flags & CHECKED and zlib.crc32(body) != crc:
                bad = f"a frame of {size} bytes at {r} failed its CRC check"
                if r == self._bad_at and not final:  # still wrong a poll later: corrupt
                    raise RuntimeError(f"monitor ring: {bad} twice")
                self._bad_at = r
                break  # not all visible yet: the next take reads it again
            self._part.append(_decode(body, n, flags, received))
            r += size
            if not flags & CONTINUED:
                chunks.append(_join(self._part))
                self._part = []
        idx[_R] = r
        lost = None
        if final:
            torn = idx[_P] - w
            parts = sum(len(c[0]) for c in self._part)
            lost = "; ".join(x for x in (
                f"{torn} bytes of a frame being written" if torn > 0 else "",
                f"the first {parts} windows of a chunk split in frames" if self._part else "",
                bad or "") if x) or None
        return chunks, lost


def _decode(body: bytes, n: int, flags: int, received: float) -> tuple:
    f = np.frombuffer(body, _F8, (2 + (flags & SCORES) + (flags & BRANCHES)) * n)
    s = a = br = None
    if flags & SCORES:
        s = f[2 * n:3 * n]
        a = np.frombuffer(body, bool, n, 8 * len(f))
        if flags & BRANCHES:
            br = (f[3 * n:4 * n], f[4 * n:])
    return f[:n], f[n:2 * n], s, a, br, received


def _join(parts: list) -> tuple:
    if len(parts) == 1:
        return parts[0]
    t, v, s, a = (None if parts[0][k] is None else np.concatenate([p[k] for p in parts])
                  for k in range(4))
    br = None if parts[0][4] is None else tuple(np.concatenate([p[4][k] for p in parts])
                                                for k in (0, 1))
    return t, v, s, a, br, parts[0][5]
