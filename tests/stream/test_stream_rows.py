"""Streamed CSV whose rows or header cannot be trusted: truncated lines, repeated names, extra
fields. The same rules and messages as ``leakdiag.io.read_recording`` (tests/io/test_text_rows.py):
a row with fewer fields than the header is refused when it ends at or before the last column
read (its last field may be cut: ``53`` written as ``5``); a column read whose name the header
holds twice is refused; empty fields after the header's (rows ending in a separator) are ignored,
other extra fields refused. File rows are 0-based data rows; stream lines count the header as 1.
"""

import contextlib
import io
import re

import numpy as np
import pytest

from leakdiag.io import RecordingError, read_recording
from leakdiag.io.errors import CutLastRowWarning
from leakdiag.stream import csv_lines, open_chunks, tail_csv
from leakdiag.stream.live import IncompleteLineWarning

CUT = ["time,p1,p2,note", "0.0,1,50,ok", "0.1,2,51,ok", "0.2,3,52,ok", "0.3,4,5"]
REPEATED = "column 'PG_1' (channel 'PG_1') appears 2 times in the header, at fields 2 and 4 " \
           "(counting from 1); which one is meant cannot be told: rename the others"
EXTRA = "has more fields than the header (3 names): field 4 is '7'; which column each value " \
        "belongs to cannot be told (a name missing in the header, or two lines run together?)"


def _write(tmp_path, lines, newline=True, name="run.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + ("\n" if newline else ""))
    return path


def _read(path, channels=None, chunk_samples=1 << 20):
    """Every channel of the file, opened and read to the end."""
    chunks = list(open_chunks(path, channels, chunk_samples))
    return {c: np.concatenate([ch[c] for ch in chunks]).tolist() for c in chunks[0]}


def _raises(path, message, *args, **kwargs):
    with pytest.raises(RecordingError, match=re.escape(f"{path}: {message}") + "$"):
        _read(path, *args, **kwargs)


def _uniform(n, short=(), extra=()):
    """``time,p1,p2`` at 1 kHz; rows in ``short`` lose p2, rows in ``extra`` get a 4th field."""
    rows = []
    for k in range(n):
        row = f"{k / 1000},{k},{k + 50}"
        rows.append(row.rsplit(",", 1)[0] if k in short else row + ",7" if k in extra else row)
    return ["time,p1,p2"] + rows


# --- truncated lines (short rows) -------------------------------------------------------------


@pytest.mark.parametrize("newline", [True, False])
def test_last_line_cut_inside_a_read_field_is_refused(tmp_path, newline):
    # "0.3,4,53,ok" cut after the "5" of 53: 3 of 4 fields; p2 used to read 5.0, no error
    path = _write(tmp_path, CUT, newline)
    _raises(path, "row 3 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", ["p1", "p2"])


@pytest.mark.parametrize("newline", [True, False])
@pytest.mark.parametrize("channels,named", [
    (None, "columns 'p1' (channel 'p1'), 'p2' (channel 'p2') are"),
    (["p1"], "column 'p1' (channel 'p1') is"),
    (["p2"], "column 'p2' (channel 'p2') is"),
], ids=["all", "p1", "p2"])
def test_line_cut_before_the_last_column_is_named_not_a_nan(tmp_path, newline, channels, named):
    # a NaN used to pass through for p2 (reported later as non-finite, hiding the cause)
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3"], newline)
    _raises(path, f"row 2 has 2 of 3 fields (truncated line?); {named} missing or cut", channels)


def test_time_and_channels_cut_and_the_count_of_short_rows(tmp_path):
    path = _write(tmp_path, ["time,p1,p2,note", "0.0,1,50,", "0.1,2,51,", "0.2,3,52,",
                             "0.3,4,53,", "0.4"], newline=False)
    _raises(path, "row 4 has 1 of 4 fields (truncated line?); columns 'time' (time column), "
                  "'p1' (channel 'p1'), 'p2' (channel 'p2') are missing or cut", ["p1", "p2"])
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2", "0.2,3,52", "0.3,4"])
    _raises(path, "row 1 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut; 2 rows are short like this")


@pytest.mark.parametrize("newline", [True, False])
def test_row_lacking_only_unread_trailing_columns_is_read(tmp_path, newline):
    # p1 is followed by a field in the cut row ("5"), so p1 is complete: read it
    # read, and said (session 28: a CLI audit)
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        assert _read(_write(tmp_path, CUT, newline), ["p1"]) == {"p1": [1.0, 2.0, 3.0, 4.0]}
    path = _write(tmp_path, ["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,53,x"], newline)
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        assert _read(path, ["p1", "p2"]) == {"p1": [1.0, 2.0], "p2": [50.0, 53.0]}


def test_row_ending_at_the_last_read_column_is_refused(tmp_path):
    path = _write(tmp_path, ["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,53"])
    _raises(path, "row 1 has 3 of 5 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", ["p1", "p2"])


def test_empty_last_field_is_not_a_short_row(tmp_path):
    # "0.2,3," has all 3 fields: p2 is an empty cell, a NaN (the monitor refuses it later)
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3,"], newline=False)
    assert np.isnan(_read(path)["p2"][2])


@pytest.mark.parametrize("row", [2, 4098, 4099])
def test_short_row_at_chunk_boundaries(tmp_path, row):
    # chunks of 2 rows: row 2 and 4098 start a chunk, 4099 ends one; the first 4096 rows are
    # checked when the file is opened (they give the sample rate), later rows chunk by chunk
    path = _write(tmp_path, _uniform(5000, short={row}))
    message = (f"{path}: row {row} has 2 of 3 fields (truncated line?); columns 'p1' (channel "
               "'p1'), 'p2' (channel 'p2') are missing or cut")
    if row < 4096:
        with pytest.raises(RecordingError, match=re.escape(message) + "$"):
            open_chunks(path, chunk_samples=2)
        return
    src = open_chunks(path, chunk_samples=2)
    assert src.sample_rate == pytest.approx(1000.0)
    with pytest.raises(RecordingError, match=re.escape(message) + "$"):
        list(src)


def test_short_rows_of_a_later_chunk_are_counted_in_that_chunk(tmp_path):
    # the rest of the file is not read: "at least", unless the chunk is the file's last
    path = _write(tmp_path, _uniform(8000, short={5001, 5003}))
    _raises(path, "row 5001 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut; at least 2 rows are short like this",
            chunk_samples=1000)
    _raises(path, "row 5001 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut; 2 rows are short like this",
            chunk_samples=5000)


def test_long_file_with_empty_cells_after_the_read_columns_is_read(tmp_path):
    # the fields are counted in every chunk (the note is empty), and agree with pandas
    lines = ["time,p1,p2,note"] + [f"{k / 1000},{k},{k + 50}," for k in range(5000)]
    lines[3000] = "2.999,2999,3049,a # b"  # a comment: pandas cuts it, so does the count
    data = _read(_write(tmp_path, lines), ["p1", "p2"], chunk_samples=700)
    assert data["p2"] == [k + 50.0 for k in range(5000)]


def test_quoted_separators_hashes_and_blank_lines_keep_the_row_numbers(tmp_path):
    lines = ["time,p1,note,p2", '0.0,1,"a,b",50', "", '0.1,2,"c#d"', '0.2,3,"e,f",52']
    path = _write(tmp_path, lines)
    _raises(path, "row 1 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", ["p1", "p2"])
    lines[3] = '0.1,2,"c#d",51'
    assert _read(_write(tmp_path, lines), ["p1", "p2"]) == {"p1": [1.0, 2.0, 3.0],
                                                            "p2": [50.0, 51.0, 52.0]}


def test_hash_is_data_as_in_io_not_a_comment(tmp_path):
    """Audit of users' recordings (2026-11-27, finding 11): monitor and batch skipped '# note'
    lines that analyze refused, and called a complete row with an Excel '#N/A' cell truncated.
    '#' is data in every reader (docs/io.md)."""
    lines = ["time,p1,p2"] + [f"0.{k},{k},{50 + k}" for k in range(8)]
    path = _write(tmp_path, lines[:7] + ["# operator note"] + lines[7:])
    msg = ("row 6 has 1 of 3 fields (truncated line?); columns 'time' (time column), 'p1' "
           "(channel 'p1'), 'p2' (channel 'p2') are missing or cut; it starts with '#', and "
           "leakdiag reads no comment lines ('#' is data, as in an Excel '#N/A' cell): remove "
           "the line")
    _raises(path, msg)
    with pytest.raises(RecordingError, match=re.escape(f"{path}: {msg}") + "$"):
        read_recording(path)
    path = _write(tmp_path, ["# exported by the rig"] + lines, name="top.csv")
    with pytest.raises(RecordingError, match=r"missing channel|fields|not a number"):
        _read(path, ["p1"])
    path = _write(tmp_path, lines[:7] + ["0.6,#N/A,56"] + lines[8:], name="na.csv")
    p1 = _read(path, ["p1"])["p1"]  # a complete row: its cell is NaN, as io reads it
    assert np.isnan(p1[6]) and p1[:6] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0] and p1[7] == 7.0
    with pytest.raises(RecordingError, match="channel 'p1' has 1 non-finite value"):
        read_recording(path)
    assert _read(_write(tmp_path, ["time,p1,note", "0.0,1,a#b", "0.1,2,#c"], name="h.csv"),
                 ["p1"]) == {"p1": [1.0, 2.0]}


def test_known_limit_cut_inside_the_last_field_of_a_full_row(tmp_path):
    # as in leakdiag.io (docs/io.md, Known limits): "0.3,4,53" cut to "0.3,4,5" has all fields
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3,52", "0.3,4,5"],
                  newline=False)
    assert _read(path)["p2"] == [50.0, 51.0, 52.0, 5.0]


# --- repeated header names --------------------------------------------------------------------


def test_repeated_name_of_a_read_column_is_refused(tmp_path):
    # the channels used to be ['PG_1', 'p2', 'PG_1.1'], and PG_1 silently the first of the two
    path = _write(tmp_path, ["time,PG_1,p2,PG_1", "0.0,1,50,900", "0.1,2,51,901"])
    _raises(path, f"{REPEATED}; without a channel list every column is read - give the channels "
                  "to read")
    _raises(path, REPEATED, ["PG_1"])
    _raises(path, "missing channel(s) ['PG_1.1']; available: ['p2']; in the header more than "
                  "once (not readable): ['PG_1']", ["PG_1.1"])
    src = open_chunks(path, ["p2"])  # an unread repeated name is harmless
    assert src.channels == ["p2"] and _read(path, ["p2"]) == {"p2": [50.0, 51.0]}


def test_repeated_time_and_names_equal_after_stripping_blanks(tmp_path):
    path = _write(tmp_path, ["time,p1,time", "0,1,2", "1,4,5"])
    _raises(path, "column 'time' (time column) appears 2 times in the header, at fields 1 and 3 "
                  "(counting from 1); which one is meant cannot be told: rename the others",
            ["p1"])
    path = _write(tmp_path, ["time,p1,temp ,temp", "0,1,20,21", "1,2,20,21"])
    _raises(path, "column 'temp' (channel 'temp') appears 2 times in the header, at fields 3 and "
                  "4 (counting from 1); which one is meant cannot be told: rename the others",
            ["temp"])


def test_a_column_really_named_with_a_dot_suffix_is_read(tmp_path):
    # pandas would call the second PG_1 "PG_1.1"; the real PG_1.1 is the fourth column
    path = _write(tmp_path, ["time,PG_1,PG_1,PG_1.1", "0.0,1,2,7", "0.1,3,4,8"])
    assert _read(path, ["PG_1.1"]) == {"PG_1.1": [7.0, 8.0]}


# --- extra fields -----------------------------------------------------------------------------


@pytest.mark.parametrize("channels", [None, ["p2"]])
def test_rows_ending_in_a_separator_are_read_in_their_columns(tmp_path, channels):
    # pandas used to take the time column as an index: the columns shifted (p2 read NaN, or
    # the time read p1 and the rate came out as 1 Hz)
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50,", "0.1,2,51,", "0.2,3,52,"])
    assert open_chunks(path, channels).sample_rate == pytest.approx(10.0)
    assert _read(path, channels)["p2"] == [50.0, 51.0, 52.0]


@pytest.mark.parametrize("channels", [None, ["p2"]])
def test_first_row_with_an_extra_field_is_refused(tmp_path, channels):
    # p2 used to read the 4th field (7, 8) without a word: the header lacks a name
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50,7", "0.1,2,51,8"])
    _raises(path, f"row 0 {EXTRA}", channels)


def test_extra_field_after_rows_ending_in_a_separator_is_refused(tmp_path):
    # the first row ends in a separator, so pandas takes rows of 4 fields without a word
    lines = ["time,p1,p2"] + [f"{k / 1000},{k},{k + 50}," for k in range(5000)]
    assert _read(_write(tmp_path, lines), chunk_samples=1000)["p2"][-1] == 5049.0
    lines[4501] += "7"  # data row 4500
    _raises(_write(tmp_path, lines), f"row 4500 {EXTRA}", chunk_samples=1000)


def test_later_row_with_an_extra_field_is_refused_like_read_recording(tmp_path):
    # every column read: pandas refuses, in the words leakdiag.io uses
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51,7", "0.2,3,52"])
    with pytest.raises(RecordingError) as io_error:
        read_recording(path)
    assert str(io_error.value) == (f"{path}: cannot parse as delimited text (separator ','): "
                                   "Error tokenizing data. C error: Expected 3 fields in line 3, "
                                   "saw 4")
    _raises(path, str(io_error.value).split(": ", 1)[1])


def test_known_limit_later_extra_field_when_only_some_columns_are_read(tmp_path):
    # docs/operations.md: pandas does not count the fields of rows (usecols) when a column is
    # left out; only the first row is checked then (and the time column shows run-together lines)
    path = _write(tmp_path, ["time,p1,p2,note", "0.0,1,50,a", "0.1,2,51,b,7", "0.2,3,52,c"])
    assert _read(path, ["p1"]) == {"p1": [1.0, 2.0, 3.0]}


# --- the same messages as leakdiag.io ---------------------------------------------------------


@pytest.mark.parametrize("lines,channels", [
    (CUT, ["p1", "p2"]),
    (["time,p1,p2,note", "0.0,1,50,", "0.1,2,51,", "0.2,3,52,", "0.3,4,53,", "0.4"], ["p1", "p2"]),
    (["time,p1,p2", "0.0,1,50", "0.1,2", "0.2,3,52", "0.3,4"], None),
    (["time,p1,note,p2", '0.0,1,"a,b",50', "", '0.1,2,"c,d"', '0.2,3,"e,f",52'], ["p1", "p2"]),
    (["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,53"], ["p1", "p2"]),
    (["time,PG_1,p2,PG_1", "0.0,1,50,900", "0.1,2,51,901"], ["PG_1", "p2"]),
    (["time,p1,time", "0,1,2", "1,4,5"], ["p1"]),
    (["time,p1,p2", "0.0,1,50", "0.1,2,51,7", "0.2,3,52"], None),
], ids=["cut", "cut-time", "short-rows", "quoted", "cut-at-last-read", "repeated",
        "repeated-time", "extra"])
def test_messages_equal_those_of_read_recording(tmp_path, lines, channels):
    path = _write(tmp_path, lines)
    with pytest.raises(RecordingError) as io_error:
        read_recording(path, {c: c for c in channels} if channels else None)
    _raises(path, str(io_error.value).split(": ", 1)[1], channels)


# --- the monitor command ----------------------------------------------------------------------


def _monitor(*args):
    from leakdiag.cli.main import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["monitor", *args, "-q"])
    return code, err.getvalue().strip()


@pytest.mark.parametrize("channels,named", [
    ("p2", "column 'p2' (channel 'p2') is"),
    ("p1,p2", "columns 'p1' (channel 'p1'), 'p2' (channel 'p2') are"),
], ids=["p2", "p1,p2"])
def test_monitor_names_the_cut_row_of_a_csv(tmp_path, channels, named):
    lines = ["time,p1,p2"] + [f"{k / 1000},{np.sin(k):.6f},{np.cos(k):.6f}" for k in range(6000)]
    lines[-1] = lines[-1][:lines[-1].rindex(",") - 2]  # the last line cut inside p1
    path = _write(tmp_path, lines, newline=False)
    method = "cross-correlation" if "," in channels else "autocorrelation"
    code, err = _monitor(str(path), "-c", channels, "-m", method, "--chunk", "1000")
    assert (code, err) == (2, f"leakdiag: error: {path}: row 5999 has 2 of 3 fields (truncated "
                              f"line?); {named} missing or cut")


def test_monitor_refuses_a_repeated_channel_name(tmp_path):
    path = _write(tmp_path, ["time,p1,p1"] + [f"{k / 1000},{k % 7},{k % 5}" for k in range(500)])
    code, err = _monitor(str(path), "-c", "p1")
    assert (code, err) == (2, f"leakdiag: error: {path}: column 'p1' (channel 'p1') appears 2 "
                              "times in the header, at fields 2 and 3 (counting from 1); which "
                              "one is meant cannot be told: rename the others")


# --- stdin and growing files ------------------------------------------------------------------


def _lines(text, channels=None, **kwargs):
    return [v for c in csv_lines(io.StringIO(text), channels, **kwargs)
            for v in c[(channels or ["p1"])[-1]].tolist()]


def test_stream_repeated_names_are_refused():
    # csv_lines used to report the channels ['p1', 'p1'] and read the first
    text = "time,p1,p1\n0.0,1,10\n0.1,2,20\n"
    message = ("<stdin>: column 'p1' (channel 'p1') appears 2 times in the header, at fields 2 "
               "and 3 (counting from 1); which one is meant cannot be told: rename the others")
    with pytest.raises(RecordingError, match=re.escape(message) + "$"):
        csv_lines(io.StringIO(text), ["p1"])
    with pytest.raises(RecordingError, match=re.escape(
            f"{message}; without a channel list every column is read - give the channels to "
            "read") + "$"):
        csv_lines(io.StringIO(text))
    assert _lines("time,p1,junk,junk\n0.0,1,a,b\n0.1,2,c,d\n", ["p1"]) == [1.0, 2.0]


@pytest.mark.parametrize("text,channels,message", [
    ("time,p1,p2\n0.0,1,50\n0.1,2\n", None, "line 3 has 2 of 3 fields (truncated line?); "
     "columns 'p1' (channel 'p1'), 'p2' (channel 'p2') are missing or cut"),
    ("time,p1,p2\n0.0,1,50\n0.1,2\n", ["p1"], "line 3 has 2 of 3 fields (truncated line?); "
     "column 'p1' (channel 'p1') is missing or cut"),
    # in the head lines that give the rate: named before the time is read ("0." would be 0.0)
    ("time,p1\n0.0,1\n0.\n", None, "line 3 has 1 of 2 fields (truncated line?); columns "
     "'time' (time column), 'p1' (channel 'p1') are missing or cut"),
    ("time,p1,p2\n0.0,1,50\n0.1,2,51,7\n", ["p1"], f"line 3 {EXTRA}"),
], ids=["short-all", "short-p1", "short-head", "extra"])
def test_stream_short_and_long_lines_are_refused(text, channels, message):
    with pytest.raises(RecordingError, match=re.escape(f"<stdin>: {message}") + "$"):
        _lines(text, channels)


def test_stream_lines_ending_in_a_separator_are_read_and_short_ones_refused():
    assert _lines("time,p1,p2\n0.0,1,50,\n0.1,2,51, \n", ["p2"]) == [50.0, 51.0]
    # a line of a live stream is complete with its newline: one with fewer fields lacks one
    # somewhere, which may shift the columns read (a user-data audit, 2026-11-29; such a line
    # lacking only unread columns was read until then)
    with pytest.raises(RecordingError, match=re.escape(
            "line 3 has 3 of 4 fields: a field is missing, and one missing before a column read "
            "shifts that column's value into another")):
        _lines("time,p1,p2,note\n0.0,1,50,a\n0.1,2,51\n", ["p1"])


def test_tail_refuses_a_short_line_and_leaves_out_a_line_without_newline(tmp_path):
    # a complete line (with its newline) lacking a field read is refused, as in a file
    path = tmp_path / "live.csv"
    path.write_text("time,p1,p2\n0.00,0,50\n0.01,1,51\n0.02,2\n")
    with pytest.raises(RecordingError, match=re.escape(
            f"{path}: line 4 has 2 of 3 fields (truncated line?); column 'p2' (channel 'p2') is "
            "missing or cut") + "$"):
        list(tail_csv(path, ["p2"], poll_s=0.01, idle_timeout_s=0.05))
    # the writer stopped inside the line: at the idle timeout it is incomplete, whatever its
    # fields, and left out with a warning (tests/stream/test_stream_input_ends.py, monitor)
    path.write_text("time,p1,p2\n0.00,0,50\n0.01,1,51\n0.02,2")
    with pytest.warns(IncompleteLineWarning, match=re.escape(
            f"{path}: line 4 is incomplete: no newline after 0.05 s without new data (a write "
            "cut short, or a writer that stopped mid-line?): '0.02,2' was left out, not read as "
            "a sample") + "$"):
        got = [v for c in tail_csv(path, ["p2"], poll_s=0.01, idle_timeout_s=0.05)
               for v in c["p2"].tolist()]
    assert got == [50.0, 51.0]


# --- the field count agrees with pandas -------------------------------------------------------


def test_field_counts_agree_with_pandas_on_random_files():
    # quoted separators, '#' in quotes, comments, quoted line breaks, blank and odd lines,
    # three kinds of line ends: the count of fields per row equals pandas' (every field is
    # non-empty, so pandas' NaNs show how many fields a row has)
    import random

    import pandas as pd

    from leakdiag.stream.files import _field_counts

    rng = random.Random(0)
    fields = ["7", "12", '"a,b"', '"x#y"', '"l1\nl2"', '"q""q"', " 5", '5"x', ' "a,b"', "ab"]
    odd = ["", "   ", "# a, hash", "  # indented", '""', '"  "', '"" # c']
    compared = 0
    for _ in range(400):
        width = rng.randint(1, 5)
        lines = [",".join(f"c{j}" for j in range(width))]
        for _ in range(rng.randint(1, 8)):
            if rng.random() < 0.2:
                lines.append(rng.choice(odd))
                continue
            k = rng.choice([width, width, width, width - 1, 1, 2, width + 1])
            line = ",".join(rng.choice(fields) for _ in range(max(1, k)))
            lines.append(line + (" # note" if rng.random() < 0.1 else ""))
        end = rng.choice(["\n", "\r\n", "\r"])
        text = end.join(lines) + (end if rng.random() < 0.7 else "")
        for n_names in range(2 * width + 4, 0, -1):  # as many names as the widest row has
            try:  # (usecols: pandas reads rows longer than the first ones, as open_chunks does)
                df = pd.read_csv(io.StringIO(text), header=0, index_col=False,
                                 names=[f"c{j}" for j in range(n_names)], dtype=str,
                                 na_filter=False, usecols=range(n_names))
                break
            except pd.errors.ParserError as exc:
                assert "out-of-bounds" in str(exc) or "Too many columns" in str(exc), exc
        theirs = [max((j + 1 for j, v in enumerate(row) if v != ""), default=0)
                  for row in df.to_numpy()]
        mine = [abs(k) for k in _field_counts(iter(io.StringIO(text, newline="")), width, {})]
        assert mine[0] == width and len(mine) - 1 == len(theirs), text
        assert all(a == b for a, b in zip(mine[1:], theirs) if b), text
        compared += 1
    assert compared == 400


def test_a_blank_extra_field_is_a_trailing_separator_not_a_value(tmp_path):
    """A review (2026-11-27) found open_chunks refusing ``1,2,3, `` (a blank after the last
    separator; pandas keeps it as text) that read_recording and csv_lines read."""
    from leakdiag.io import read_recording
    from leakdiag.stream.files import open_chunks

    p = tmp_path / "blank.csv"
    p.write_text("time,p1,p2\n0,1,2,\n1,2,3, \n2,3,4,\n")
    for chans in (None, ["p1"]):
        got = [c for c in open_chunks(p, chans)]
        assert [c["p1"].tolist() for c in got] == [[1.0, 2.0, 3.0]]
    assert read_recording(p).channels["p2"].tolist() == [2.0, 3.0, 4.0]


# --- the separator and encoding, found as leakdiag.io finds them (audit 13, finding 10) -------


@pytest.mark.parametrize("sep", [";", "\t", "|"])
def test_separator_found_as_io_finds_it_and_rows_checked_with_it(tmp_path, sep):
    lines = [line.replace(",", sep) for line in CUT]
    path = _write(tmp_path, lines, newline=False)
    _raises(path, "row 3 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", ["p1", "p2"])
    with pytest.raises(RecordingError, match="row 3 has 3 of 4 fields"):
        read_recording(path)
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        assert _read(path, ["p1"], chunk_samples=2) == {"p1": [1.0, 2.0, 3.0, 4.0]}


def test_latin1_semicolon_file_and_blank_separated_file(tmp_path):
    from leakdiag.stream.files import open_recording

    path = tmp_path / "eu.csv"
    path.write_bytes("time;p1;T [\xb5s]\n0,0;1;5\n0,1;2;6\n".replace(",", ".").encode("latin-1"))
    assert _read(path, ["p1"]) == {"p1": [1.0, 2.0]}
    blank = _write(tmp_path, ["time p1", "0.0 1", "0.1 2"], name="blank.csv")
    _raises(blank, "fields separated by blanks, not by one of ['\\t', ',', ';', '|']; the "
                   "chunked CSV reader needs one (leakdiag.io.read_recording reads it whole)")
    src, _ = open_recording(blank)
    assert np.concatenate([c["p1"] for c in src]).tolist() == [1.0, 2.0]


MIDDLE = ["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,51,b", "0.2,3,52,c,d", "0.3,4,53,e,f"]


@pytest.mark.parametrize("chunk_samples", [1, 2, 3, 1 << 20])
def test_a_middle_row_short_after_the_columns_read_is_refused(tmp_path, chunk_samples):
    """A user-data audit (2026-11-29): a real file's row without its ``Temp_3`` field (before
    the pressures) was read with PG_2 as p1 and PG_3 as p2, because a short row that ends after
    every column read was read as if its fields were missing at the end. Now only the file's
    last row may be read so (a file cut while written), whatever the chunks, also when a chunk
    ends on it."""
    path = _write(tmp_path, MIDDLE)
    message = ("row 1 has 4 of 5 fields: a field is missing, and one missing before a column "
               "read shifts that column's value into another (a field missing at the end of "
               "the row cannot be told from one missing in the middle); fix or remove the row")
    _raises(path, message, ["p1", "p2"], chunk_samples=chunk_samples)
    with pytest.raises(RecordingError, match=re.escape(f"{path}: {message}") + "$"):
        read_recording(path, channels=["p1", "p2"])
    # the last row cut after the columns read: read, whether its chunk is full or not
    last = _write(tmp_path, MIDDLE[:1] + MIDDLE[3:] + ["0.4,5,54,g"], name="cut.csv")
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        assert _read(last, ["p1", "p2"], chunk_samples=chunk_samples)["p2"] == [52, 53, 54]
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        assert read_recording(last, channels=["p1", "p2"])["p2"].tolist() == [52, 53, 54]
