"""Chunked sources: Parquet/HDF5/CSV readers give back the samples, rate and start time; stdin
lines; a growing file; real-time pacing with an injected clock."""

import io
import os
import re
import threading
import time

import numpy as np
import pandas as pd
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.stream import csv_lines, open_chunks, paced, recording_chunks, tail_csv


def _rec(n=1000):
    rng = np.random.default_rng(0)
    return Recording({"p1": rng.normal(size=n), "p2": rng.normal(size=n)}, sample_rate=500.0,
                     start_time=1.5, meta={"onset": 2.0, "leak_lpm": 0.2, "source": "sim"})


def _gather(src, chans=("p1", "p2")):
    chunks = list(src)
    return {c: np.concatenate([ch[c] for ch in chunks]) for c in chans}, [len(ch[chans[0]]) for ch in chunks]


def test_parquet_chunks_with_leakdiag_header(tmp_path):
    from leakdiag.io.parquet import write_parquet

    rec, path = _rec(), tmp_path / "r.parquet"
    write_parquet(rec, path)
    src = open_chunks(path, chunk_samples=300)
    assert (src.sample_rate, src.start_time, src.n_samples) == (500.0, 1.5, 1000)
    assert src.meta["onset"] == 2.0 and src.channels == ["p1", "p2"]
    data, sizes = _gather(src)
    assert sizes == [300, 300, 300, 100]
    np.testing.assert_array_equal(data["p1"], rec["p1"])


def test_hdf5_chunks_with_leakdiag_layout(tmp_path):
    from leakdiag.io.hdf5 import write_hdf5

    rec, path = _rec(), tmp_path / "r.h5"
    write_hdf5(rec, path)
    src = open_chunks(path, channels=["p2"], chunk_samples=400)
    assert (src.sample_rate, src.start_time, src.meta["leak_lpm"]) == (500.0, 1.5, 0.2)
    data, sizes = _gather(src, ("p2",))
    assert sizes == [400, 400, 200]
    np.testing.assert_array_equal(data["p2"], rec["p2"])


def test_plain_parquet_infers_rate_from_time(tmp_path):
    path = tmp_path / "plain.parquet"
    pd.DataFrame({"time": 10.0 + np.arange(50) / 200.0, "p1": np.arange(50.0)}).to_parquet(path)
    src = open_chunks(path, chunk_samples=64)
    assert (src.sample_rate, src.start_time) == (200.0, 10.0)
    np.testing.assert_array_equal(_gather(src, ("p1",))[0]["p1"], np.arange(50.0))


def test_csv_chunks(tmp_path):
    path = tmp_path / "r.csv"
    rec = _rec(100)
    rec.to_pandas().to_csv(path, index=False)
    src = open_chunks(path, chunk_samples=30)
    assert src.sample_rate == pytest.approx(500.0) and src.start_time == pytest.approx(1.5)
    data, sizes = _gather(src)
    assert sizes == [30, 30, 30, 10]
    np.testing.assert_allclose(data["p2"], rec["p2"], rtol=1e-15)


def test_open_chunks_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.parquet: no such file"):
        open_chunks(tmp_path / "nope.parquet")
    bad = tmp_path / "bad.parquet"
    bad.write_text("not parquet")
    with pytest.raises(RecordingError, match="bad.parquet: unreadable as Parquet"):
        open_chunks(bad)
    txt = tmp_path / "x.txt"
    txt.write_text("")
    with pytest.raises(RecordingError, match="unknown file type '.txt'"):
        open_chunks(txt)
    path = tmp_path / "r.csv"
    pd.DataFrame({"p1": [1.0, 2.0]}).to_csv(path, index=False)
    with pytest.raises(RecordingError, match="no 'time' column and no sample rate"):
        open_chunks(path)
    with pytest.raises(RecordingError, match=r"missing channel\(s\) \['p9'\]"):
        open_chunks(path, channels=["p9"], sample_rate=10.0)


def test_recording_chunks_are_views():
    rec = _rec(10)
    chunks = list(recording_chunks(rec, 4))
    assert [len(c["p1"]) for c in chunks] == [4, 4, 2]
    assert np.shares_memory(chunks[0]["p1"], rec["p1"])


def test_csv_lines_one_chunk_per_line():
    s = io.StringIO("time,p1,p2\n0.0,1,5\n\n0.1,2,6\n\n0.2,3,7\n")
    src = csv_lines(s, channels=["p2"])
    assert src.sample_rate == pytest.approx(10.0)
    assert [c["p2"].tolist() for c in src] == [[5.0], [6.0], [7.0]]


def test_csv_lines_reads_no_comment_lines():
    # '#' is data in every reader (docs/io.md, decision 2026-11-27, audit 13 finding 11): a
    # line '# note' is a short line, refused, saying why
    s = io.StringIO("time,p1,p2\n0.0,1,5\n# note\n0.1,2,6\n")
    with pytest.raises(RecordingError, match=re.escape(
            "<stdin>: line 3 has 1 of 3 fields (truncated line?); columns 'time' (time column), "
            "'p2' (channel 'p2') are missing or cut; it starts with '#', and leakdiag reads no "
            "comment lines")):
        list(csv_lines(s, channels=["p2"]))


def test_csv_lines_errors():
    with pytest.raises(RecordingError, match="empty input"):
        csv_lines(io.StringIO(""))
    src = csv_lines(io.StringIO("p1,p2\n1,2\n3\n"), sample_rate=5.0)
    with pytest.raises(RecordingError, match=re.escape(
            "<stdin>: line 3 has 1 of 2 fields (truncated line?); columns 'p1' (channel 'p1'), "
            "'p2' (channel 'p2') are missing or cut") + "$"):
        list(src)


@pytest.mark.parametrize("last,needle", [
    (0.068, re.escape("column 'time' is not strictly increasing at line 72 (time 0.068 s "
                      "after 0.069 s)")),
    (0.069, re.escape("column 'time' is not strictly increasing at line 72 (time 0.069 s "
                      "after 0.069 s)")),
    (0.075, "line 72: time 0.075 s after 0.069 s is a gap"),
    (0.0701, "line 72: time 0.0701 s after 0.069 s is jitter"),
])
def test_csv_lines_checks_the_time_axis_like_file_mode(last, needle):
    # issue 15: stdin used to accept time going backwards, gaps and jitter (here after the
    # 64 head lines that set the rate; line 1 is the header)
    times = [round(0.001 * k, 6) for k in range(70)] + [last]
    text = "time,p1\n" + "".join(f"{t},{i}\n" for i, t in enumerate(times))
    src = csv_lines(io.StringIO(text))
    assert src.sample_rate == 1000.0  # from the first uniform lines
    with pytest.raises(RecordingError, match=needle):
        list(src)


def test_csv_lines_rate_from_many_lines_not_the_first_interval():
    # a jittered first interval (1101 Hz) used to set the rate; now the head is checked
    times = [0.0, 0.000908] + [0.001 * k for k in range(2, 10)]
    text = "time,p1\n" + "".join(f"{t},{i}\n" for i, t in enumerate(times))
    with pytest.raises(RecordingError, match="not uniformly sampled"):
        csv_lines(io.StringIO(text))


def test_csv_lines_names_line_and_channel_of_text():
    src = csv_lines(io.StringIO("time,p1\n0,1\n0.001,abc\n"))
    with pytest.raises(RecordingError, match=r"<stdin>: line 3, channel 'p1': 'abc' is not a number"):
        list(src)


def test_csv_lines_sample_rate_conflicting_with_time_column_is_refused():
    with pytest.raises(RecordingError, match=r"500 Hz was given .*, but the file's time column "
                                             r"'time' says 1000 Hz"):
        csv_lines(io.StringIO("time,p1\n0,1\n0.001,2\n0.002,3\n"), sample_rate=500.0)


def test_tail_follows_a_growing_file(tmp_path):
    path = tmp_path / "live.csv"
    path.write_text("time,p1\n0.00,0\n0.01,1\n")

    def writer():
        with open(path, "a") as f:
            for i in range(2, 6):
                time.sleep(0.02)
                f.write(f"{i / 100:.2f},")  # partial line first: must wait for the newline
                f.flush()
                time.sleep(0.02)
                f.write(f"{i}\n")
                f.flush()

    th = threading.Thread(target=writer)
    th.start()
    src = tail_csv(path, poll_s=0.01, idle_timeout_s=1.5)  # generous: the CI machine may be busy
    got = [v for c in src for v in c["p1"].tolist()]
    th.join()
    assert src.sample_rate == pytest.approx(100.0)
    assert got == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]


def test_paced_releases_chunks_at_stream_time():
    rec = Recording({"p1": np.zeros(1000)}, sample_rate=100.0)  # 10 s of data
    now = [0.0]
    sleeps = []

    def sleep(dt):
        sleeps.append(dt)
        now[0] += dt

    out = list(paced(recording_chunks(rec, 250), speed=2.0, clock=lambda: now[0], sleep=sleep,
                     piece_s=1.25))   # pieces of up to 250 samples: the chunks as they are
    assert len(out) == 4
    # chunk i ends at (i+1)*2.5 s of stream time -> released at (i+1)*1.25 s of wall time
    assert sleeps == pytest.approx([1.25, 1.25, 1.25, 1.25])
    assert now[0] == pytest.approx(5.0)
    with pytest.raises(ValueError, match="speed=0"):
        list(paced(recording_chunks(rec, 250), speed=0))


def test_paced_cuts_long_chunks_into_pieces_of_at_most_piece_s():
    # one 65,536-sample chunk replayed in real time had reached the monitor (and its page)
    # only after 65.5 s; cut into 0.1-s pieces it arrives ten times a second
    rec = Recording({"p1": np.arange(1000.0), "p2": -np.arange(1000.0)}, sample_rate=100.0)
    now = [0.0]
    released = []

    def sleep(dt):
        now[0] += dt

    pieces = []
    for piece in paced(recording_chunks(rec, 1000), speed=2.0, clock=lambda: now[0],
                       sleep=sleep, piece_s=0.35):
        released.append(now[0])
        pieces.append(piece)
    assert [len(p["p1"]) for p in pieces] == [70] * 14 + [20]     # 100 Hz * 2 * 0.35 s = 70
    assert np.array_equal(np.concatenate([p["p1"] for p in pieces]), rec.channels["p1"])
    assert np.array_equal(np.concatenate([p["p2"] for p in pieces]), rec.channels["p2"])
    # piece i ends at 0.7 (i + 1) s of stream time -> released at 0.35 (i + 1) s of wall time
    assert released == pytest.approx([0.35 * (i + 1) for i in range(14)] + [5.0])
    with pytest.raises(ValueError, match="piece_s"):
        list(paced(recording_chunks(rec, 1000), speed=1.0, piece_s=0.0))


def test_paced_default_pieces_are_a_tenth_of_a_second():
    rec = Recording({"p1": np.zeros(5000)}, sample_rate=1000.0)
    sizes = [len(p["p1"]) for p in paced(recording_chunks(rec, 5000), speed=1.0,
                                          clock=lambda: 1e9, sleep=lambda dt: None)]
    assert sizes == [100] * 50


@pytest.mark.parametrize("fmt", ["parquet", "hdf5"])
def test_following_a_binary_recording_is_refused_by_name(tmp_path, fmt):
    """An audit (2026-11-29, session 28): ``monitor FILE.parquet --follow`` said only
    "'utf-8' codec can't decode byte 0x80 in position 7"."""
    from leakdiag.io import write_recording

    rec = Recording({"p1": np.arange(5.0), "p2": np.arange(5.0)}, sample_rate=10.0)
    path = tmp_path / f"rec.{'parquet' if fmt == 'parquet' else 'h5'}"
    write_recording(rec, path)
    kind = {"parquet": "a Parquet file", "hdf5": "an HDF5 file"}[fmt]
    with pytest.raises(RecordingError, match=re.escape(
            f"{path}: {kind} (a recording?), not delimited text: following (monitor --follow) "
            "reads a CSV file that is still being written, line by line; judge a finished "
            "recording without --follow")):
        tail_csv(path, idle_timeout_s=0.1)


def test_a_followed_line_that_is_not_utf8_is_named_with_its_line(tmp_path, run_cli):
    path = tmp_path / "bad.csv"
    path.write_bytes(b"time,p1,p2\n0.0,1,2\n0.001,\xff\xfe,3\n0.002,1,2\n")
    with pytest.raises(RecordingError, match=re.escape(
            f"{path}: line 3 is not UTF-8 text (invalid start byte: byte 0xff, byte 7 of the "
            "line): following reads CSV text")):
        list(tail_csv(path, idle_timeout_s=0.1).chunks)  # (the first lines read at the start)
    code, _, err = run_cli(["monitor", str(path), "-c", "p1", "--follow", "--idle-timeout",
                            "0.2"])
    assert code == 2 and f"leakdiag: error: {path}: line 3 is not UTF-8 text" in err


def _follow_until_error(path, change, delay=0.15):
    """Follow ``path`` while ``change()`` runs in a thread after ``delay`` s; the error."""
    th = threading.Timer(delay, change)
    th.start()
    try:
        with pytest.raises(RecordingError) as err:
            list(tail_csv(path, poll_s=0.01, idle_timeout_s=3.0))
    finally:
        th.join()
    return str(err.value)


def test_a_followed_file_truncated_replaced_or_written_anew_is_an_error(tmp_path):
    # a workflow audit (2026-11-30): after a logrotate copytruncate the monitor ended normally
    # without reading the new file's lines, or read from the middle of one
    path = tmp_path / "live.csv"
    lines = "time,p1\n" + "".join(f"{i / 100:.2f},{i}\n" for i in range(5))
    path.write_text(lines)
    size = path.stat().st_size

    def shorter():
        path.write_text("time,p1\n0.00,7\n")  # opened "w": truncated, then written

    msg = _follow_until_error(path, shorter)
    assert msg == (f"{path}: the file was truncated to 15 bytes (read up to byte {size}) after "
                   "line 6: following reads one file as it grows, so the lines written to it "
                   "since were not read (a log rotation, or a writer that started the file "
                   "again?); start the monitor again to read the new file from its start")
    path.write_text(lines)

    def same_size():  # truncated and written again as long as before: only its bytes tell
        path.write_text(lines.replace(",0\n", ",9\n"))

    assert "was written anew from its start (its first bytes changed) after line 6" in \
        _follow_until_error(path, same_size)
    path.write_text(lines)
    other = tmp_path / "new.csv"

    def rotated():  # renamed away and created anew
        other.write_text(lines)
        os.replace(other, path)

    assert "was replaced by another file of that name after line 6" in \
        _follow_until_error(path, rotated)


def test_following_waits_for_a_file_to_be_created(tmp_path):
    path = tmp_path / "later.csv"
    th = threading.Timer(0.15, lambda: path.write_text("time,p1\n0.00,1\n0.01,2\n"))
    th.start()
    got = [v for c in tail_csv(path, poll_s=0.01, idle_timeout_s=2.0) for v in c["p1"]]
    th.join()
    assert got == [1.0, 2.0]
    with pytest.raises(RecordingError, match=re.escape(
            f"{tmp_path / 'never.csv'}: no such file after 0.1 s of waiting for it to be "
            "created (--follow waits for a file's creation and growth, up to --idle-timeout)")):
        tail_csv(tmp_path / "never.csv", poll_s=0.01, idle_timeout_s=0.1)
