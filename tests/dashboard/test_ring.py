"""The shared-memory ring between the monitor and its sidecar: frames round trip, wrap around the
ring's end, wait when it is full, split huge chunks, and report (never return) a frame that was
being written, or one that fails its CRC check."""

import numpy as np
import pytest

from leakdiag.dashboard.ring import (CONTINUED, DATA_OFFSET, HEADER, WRAP, RingReader,
                                     RingWriter, frame_size, ring_file)


def _pair(capacity=4096, on_full=None, checked=None):
    fd = ring_file(capacity)
    w = RingWriter(fd, capacity, on_full or (lambda: pytest.fail("ring full")), checked)
    r = RingReader(fd, capacity)
    return w, r


def _chunk(i, n, kind):
    """Chunk i of n windows: t = i + k/10, v = -t, s = 2 t, a = k odd, S+ = 3 t, S- = 4 t."""
    t = i + np.arange(n) / 10.0
    if kind == "values":
        return t, -t, None, None, None, 100.0 + i
    br = (3 * t, 4 * t) if kind == "branches" else None
    return t, -t, 2 * t, np.arange(n) % 2 == 1, br, 100.0 + i


def _same(got, want):
    assert len(got) == len(want)
    for g, c in zip(got, want):
        for x, y in zip(g[:4], c[:4]):
            assert (x is None and y is None) or np.array_equal(x, y)
        assert (g[4] is None) == (c[4] is None)
        if c[4] is not None:
            assert np.array_equal(g[4][0], c[4][0]) and np.array_equal(g[4][1], c[4][1])
        assert g[5] == c[5]


@pytest.mark.parametrize("kind", ["values", "scores", "branches"])
def test_round_trip(kind):
    w, r = _pair()
    sent = [_chunk(i, n, kind) for i, n in enumerate((5, 1, 7))]
    for c in sent:
        w.push(*c)
    assert r.held() == sum(frame_size(len(c[0]), {"values": 0, "scores": 1,
                                                   "branches": 3}[kind]) for c in sent)
    got, lost = r.take(final=True)
    _same(got, sent)
    assert lost is None and r.held() == 0


@pytest.mark.parametrize("n, marker", [(7, False), (5, True)])
def test_wrap_around(n, marker):
    """Frames of 136 bytes (7 windows, values) leave 16 bytes at the end of a 4096-byte ring:
    fewer than a header, skipped by both ends without a marker; frames of 152 bytes (5 windows
    with scores) leave 144, where the writer puts a WRAP marker."""
    kind = "values" if n == 7 else "scores"
    size = frame_size(n, 0 if n == 7 else 1)
    assert 4096 % size == (16 if n == 7 else 144)
    w, r = _pair()
    sent, got = [], []
    for i in range(100):  # almost 4 laps, taken every 10 frames
        sent.append(_chunk(i, n, kind))
        w.push(*sent[-1])
        if i % 10 == 9:
            got += r.take()[0]
        if i == 4096 // size:  # the first frame that did not fit at the end: at the start
            end = i * size
            assert w.n_wraps == 1 and w._w == 4096 + size
            word = HEADER.unpack_from(w.mm, DATA_OFFSET + end)[0] if marker else None
            assert word == (WRAP if marker else None)
    got += r.take(final=True)[0]
    _same(got, sent)
    assert w.n_wraps == 100 * size // 4096 and w.n_waits == 0


def test_full_ring_waits_for_the_reader():
    """The writer never overwrites frames that were not taken: while the ring is full it calls
    on_full (here: the reader takes one lot), and nothing is lost or reordered."""
    got = []
    calls = []

    def on_full():
        calls.append(w._r)
        got.extend(r.take()[0])

    w, r = _pair(on_full=on_full)
    sent = [_chunk(i, 5, "branches") for i in range(60)]  # 232 bytes each: 17 per ring
    for c in sent:
        w.push(*c)
        assert 0 <= r.held() <= 4096
    got += r.take(final=True)[0]
    _same(got, sent)
    assert w.n_waits == len(calls) == 3  # 17 + 17 + 17 frames fit, then 9


def test_huge_chunk_is_split_and_joined():
    w, r = _pair()
    c = _chunk(3, 200, "branches")  # 8,232 bytes in one frame: more than a quarter of the ring
    got = []
    w.on_full = lambda: got.extend(r.take()[0])
    w.push(*c)
    got += r.take(final=True)[0]
    _same(got, [c])
    assert w.n_waits > 0


def test_torn_frame_is_reported_not_returned():
    """A writer killed inside push: the frame's room is announced (P) and partly written, W not
    moved. The reader returns the complete chunks only and says what it dropped."""
    w, r = _pair()
    sent = [_chunk(i, 5, "scores") for i in range(3)]
    for c in sent:
        w.push(*c)
    p = w._reserve(frame_size(5, 1))
    w.mm[p:p + 40] = b"\x07" * 40  # a header and part of the times
    got, lost = r.take()
    _same(got, sent)
    assert r.take(final=True) == ([], "152 bytes of a frame being written")


def test_split_chunk_cut_short_is_reported():
    w, r = _pair(on_full=lambda: None)
    c = _chunk(0, 50, "scores")
    w.push(c[0][:20], c[1][:20], c[2][:20], c[3][:20])
    w._cont = CONTINUED  # as _push_split does for all but the last part
    w.push(c[0][20:], c[1][20:], c[2][20:], c[3][20:])
    got, lost = r.take(final=True)
    assert [len(x[0]) for x in got] == [20] and lost == \
        "the first 30 windows of a chunk split in frames"


def test_bad_arrays_publish_nothing():
    w, r = _pair()
    good = _chunk(0, 5, "scores")
    with pytest.raises(ValueError, match="5 contiguous float64 values"):
        w.push(good[0], good[1].astype(np.float32), good[2], good[3])
    with pytest.raises(ValueError, match="contiguous"):
        w.push(good[0], np.repeat(good[1], 2)[::2], good[2], good[3])
    w.push(*good)
    got, lost = r.take(final=True)
    _same(got, [good])
    assert lost is None


def test_write_checks_the_frame_size_push_each_length():
    """write (the monitor's arrays, made together) refuses what changes the frame's size;
    push also refuses lengths whose errors cancel out in the size (v one short, s one long)."""
    w, r = _pair()
    t, v, s, a, _, rec = _chunk(0, 5, "scores")
    with pytest.raises(ValueError, match="5 contiguous float64 values"):
        w.write(t, v.astype(np.float32), s, a, None, rec)
    with pytest.raises(ValueError, match="5 contiguous float64 values.*different lengths"):
        w.push(t, v[:4], np.append(s, 9.0), a, None, rec)
    with pytest.raises(ValueError, match="5 contiguous float64 values"):
        w.push(t, v, s, None, None, rec)  # scores without alarms
    assert r.held() == 0 and w.idx[8] == w.idx[0] == 0  # nothing announced or published
    w.write(t, v, s, a, None, rec)
    _same(r.take(final=True)[0], [(t, v, s, a, None, rec)])


def test_crc_frames():
    """With CRC-32 (the default off x86): good frames pass; a frame whose bytes are not right is
    retried at the next take, an error if still wrong then, and reported at the end."""
    w, r = _pair(checked=True)
    sent = [_chunk(i, 5, "scores") for i in range(2)]
    for c in sent:
        w.push(*c)
    _same(r.take()[0], sent)
    w.push(*_chunk(2, 5, "scores"))
    p = DATA_OFFSET + 2 * frame_size(5, 1) + HEADER.size
    w.mm[p] ^= 1  # a bit of the first time flipped
    assert r.take() == ([], None)
    with pytest.raises(RuntimeError, match="failed its CRC check twice"):
        r.take()
    assert r.take(final=True) == ([], "a frame of 152 bytes at 304 failed its CRC check")


def test_reader_failure_reaches_the_writer():
    raised = []

    def on_full():
        raised.append(True)
        raise RuntimeError("the reader failed")

    w, r = _pair(on_full=on_full)
    w.push(*_chunk(0, 5, "scores"))
    r.fail()
    assert w.failed
    with pytest.raises(RuntimeError, match="the reader failed"):
        w.push(*_chunk(1, 5, "scores"))
    assert [len(c[0]) for c in r.take(final=True)[0]] == [5]


def test_ring_file_size_is_checked():
    with pytest.raises(ValueError, match="capacity=4100 must be a multiple of 8"):
        ring_file(4100)
