"""Delimited text whose rows or header cannot be trusted: truncated lines, repeated names.

A row with fewer fields than the header is refused when it ends at or before the last column
read (its last field may be cut: ``53`` written as ``5``); a name the header holds twice is
refused when that column is read. Rows are 0-based data rows (the header is not counted).
"""

import re

import pytest

from leakdiag.io import RecordingError, read_recording
from leakdiag.io.errors import CutLastRowWarning
from leakdiag.io.text import read_text

P1_P2 = {"p1": "p1", "p2": "p2"}


def _write(tmp_path, lines, sep=",", newline=True, name="run.csv"):
    path = tmp_path / name
    text = "\n".join(line.replace(",", sep) for line in lines)
    path.write_text(text + "\n" if newline else text)
    return path


def _raises(path, message, *args, **kwargs):
    with pytest.raises(RecordingError, match=re.escape(f"{path}: {message}") + "$"):
        read_recording(path, *args, **kwargs)


# --- truncated lines --------------------------------------------------------------------------


@pytest.mark.parametrize("sep", [",", "\t"])
@pytest.mark.parametrize("newline", [True, False])
def test_last_line_cut_inside_a_mapped_field_is_refused(tmp_path, sep, newline):
    # "0.3,4,53,ok" cut after the "5" of 53: 3 of 4 fields, p2 would read 5 instead of 53
    path = _write(tmp_path, ["time,p1,p2,note", "0.0,1,50,ok", "0.1,2,51,ok", "0.2,3,52,ok",
                             "0.3,4,5"], sep, newline)
    _raises(path, "row 3 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", P1_P2)


@pytest.mark.parametrize("sep", [",", "\t"])
@pytest.mark.parametrize("newline", [True, False])
def test_last_line_cut_before_mapped_fields_names_them_not_a_nan(tmp_path, sep, newline):
    # (four complete rows first: the separator is detected from the first five lines)
    path = _write(tmp_path, ["time,p1,p2,note", "0.0,1,50,", "0.1,2,51,", "0.2,3,52,",
                             "0.3,4,53,", "0.4"], sep, newline)
    _raises(path, "row 4 has 1 of 4 fields (truncated line?); columns 'time' (time column), "
                  "'p1' (channel 'p1'), 'p2' (channel 'p2') are missing or cut", P1_P2)


def test_short_row_in_the_middle_and_the_count_of_short_rows(tmp_path):
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2", "0.2,3,52", "0.3,4"])
    _raises(path, "row 1 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut; 2 rows are short like this")


def test_standard_names_without_a_map_every_column_is_read(tmp_path):
    # without a map the last column is read too, so any short row is refused
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3"], newline=False)
    _raises(path, "row 2 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut")


def test_empty_last_field_is_not_a_short_row(tmp_path):
    # "0.2,3," has 3 of 3 fields: p2 is an empty cell (NaN), not a missing field
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3,"], newline=False)
    _raises(path, "channel 'p2' has 1 non-finite value(s); first NaN at row 2")


def test_a_non_finite_value_names_the_mapped_column(tmp_path):
    # a CLI audit (2026-11-29): "channel 'p2' ... row 1999" of a file whose column is PG_2
    path = _write(tmp_path, ["time,PG_1,PG_2", "0.0,1,50", "0.1,2,51", "0.2,3,"], newline=False)
    _raises(path, "channel 'p2' (column 'PG_2') has 1 non-finite value(s); first NaN at row 2",
            {"p1": "PG_1", "p2": "PG_2"})


@pytest.mark.parametrize("newline", [True, False])
def test_row_lacking_only_unread_trailing_columns_is_read(tmp_path, newline):
    # p2 is followed by a field ("x") in the short row, so p2 is complete: decided to read it
    path = _write(tmp_path, ["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,53,x"],
                  newline=newline)
    # read, and said (session 28: a CLI audit)
    with pytest.warns(CutLastRowWarning, match="ends in a cut line"):
        rec = read_recording(path, P1_P2)
    assert rec["p2"].tolist() == [50.0, 53.0]
    assert rec["p1"].tolist() == [1.0, 2.0]


def test_row_ending_at_the_last_mapped_column_is_refused(tmp_path):
    # the row ends with p2: "53" may be the start of a longer number, so it is not read
    path = _write(tmp_path, ["time,p1,p2,note,extra", "0.0,1,50,a,b", "0.1,2,53"])
    _raises(path, "row 1 has 3 of 5 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", P1_P2)


def test_one_column_read_as_two_channels_is_named_once(tmp_path):
    path = _write(tmp_path, ["time,P,junk", "0.0,1,a", "0.1,2"])
    # (with another gain: the same offset and gain is refused, a signal read twice)
    _raises(path, "row 1 has 2 of 3 fields (truncated line?); column 'P' (channel 'p1', "
                  "channel 'p2') is missing or cut", {"p1": "P", "p2": "P:Pa*2"})


def test_rows_ending_in_tabs_with_empty_junk_fields_are_complete(tmp_path):
    # like the real rotary-actuator files: text columns filled in the first rows only, every
    # row has all its fields (trailing empty ones), the last line has no newline
    text = ("Time\tPG_1\tPG_2\tF_Names\tF_Values\n1\t10\t53\tVar_A\t1.5\n2\t11\t54\t\t\n"
            "3\t12\t55\t\t")
    path = tmp_path / "log.txt"
    path.write_text(text)
    cmap = {"file": {"separator": "\t", "sample_rate_hz": 10, "time_column": "Time",
                     "time_unit": "samples"},
            "channels": {"p1": "PG_1:counts", "p2": "PG_2:counts"}}
    rec = read_recording(path, cmap)
    assert rec["p2"].tolist() == [53.0, 54.0, 55.0]
    path.write_text(text[:-4])  # cut inside PG_2 ("55" -> "5"): 3 of 5 fields
    _raises(path, "row 2 has 3 of 5 fields (truncated line?); column 'PG_2' (channel 'p2') is "
                  "missing or cut", cmap)


def test_quoted_separators_and_blank_lines_keep_the_row_numbers(tmp_path):
    # a quoted "a,b" is one field; blank lines are skipped by the parser and by the count
    lines = ["time,p1,note,p2", '0.0,1,"a,b",50', "", '0.1,2,"c,d"', '0.2,3,"e,f",52']
    path = _write(tmp_path, lines)
    _raises(path, "row 1 has 3 of 4 fields (truncated line?); column 'p2' (channel 'p2') is "
                  "missing or cut", P1_P2)
    lines[3] = '0.1,2,"c,d",51'
    assert read_recording(_write(tmp_path, lines), P1_P2)["p2"].tolist() == [50.0, 51.0, 52.0]


def test_whitespace_separated_short_row(tmp_path):
    path = _write(tmp_path, ["time p1 p2", "0.0 1 50", "0.1  2", "0.2 3 52"], sep=" ")
    assert read_text(path).separator == r"\s+"
    _raises(path, "row 1 has 2 of 3 fields (truncated line?); columns 'p1' (channel 'p1'), "
                  "'p2' (channel 'p2') are missing or cut")


def test_short_row_is_reported_before_the_time_axis_is_checked(tmp_path):
    # the time value "0.4" cut to "0." would otherwise be reported as time going backwards
    path = _write(tmp_path, ["time,p1", "0.0,1", "0.1,2", "0.2,3", "0.3,4", "0."],
                  newline=False)
    _raises(path, "row 4 has 1 of 2 fields (truncated line?); columns 'time' (time column), "
                  "'p1' (channel 'p1') are missing or cut")


def test_row_counts_that_disagree_are_refused_not_guessed(tmp_path):
    # a line of only quotes is a row of empty fields to pandas but blank to the field count
    path = _write(tmp_path, ["time,p1,p2,n", "0,1,2,x", "1,2,3,y", "2,3,4,z", "3,4,5,w", '""',
                             "4,5,6,v"])
    _raises(path, "cannot check the rows for missing fields: pandas reads 6 data rows, counting "
                  "fields line by line finds 5; look for odd lines (only quotes or blanks)",
            {"p1": "p1"})


def test_known_limit_cut_inside_the_last_field_of_a_full_row(tmp_path):
    # docs/io.md, Known limits: "0.3,4,53" cut to "0.3,4,5" still has all its fields
    path = _write(tmp_path, ["time,p1,p2", "0.0,1,50", "0.1,2,51", "0.2,3,52", "0.3,4,5"],
                  newline=False)
    assert read_recording(path)["p2"].tolist() == [50.0, 51.0, 52.0, 5.0]


# --- repeated header names --------------------------------------------------------------------


@pytest.mark.parametrize("sep", [",", "\t"])
def test_mapped_column_named_twice_is_refused(tmp_path, sep):
    path = _write(tmp_path, ["time,PG_1,PG_2,PG_1", "0.0,1,50,900", "0.1,2,51,901"], sep)
    _raises(path, "column 'PG_1' (channel 'p1') appears 2 times in the header, at fields 2 and "
                  "4 (counting from 1); which one is meant cannot be told: rename the others",
            {"p1": "PG_1", "p2": "PG_2"})


def test_three_times_and_the_time_column(tmp_path):
    path = _write(tmp_path, ["T,P,P,P", "0,1,2,3", "1,4,5,6"])
    _raises(path, "column 'P' (channel 'p1') appears 3 times in the header, at fields 2, 3 and "
                  "4 (counting from 1); which one is meant cannot be told: rename the others",
            {"file": {"time_column": "T"}, "channels": {"p1": "P"}})
    path = _write(tmp_path, ["T,P,T", "0,1,2", "1,4,5"])
    _raises(path, "column 'T' (time column) appears 2 times in the header, at fields 1 and 3 "
                  "(counting from 1); which one is meant cannot be told: rename the others",
            {"file": {"time_column": "T"}, "channels": {"p1": "P"}})
    # the default time column is read whenever the file has one
    path = _write(tmp_path, ["time,p1,time", "0,1,2", "1,4,5"])
    _raises(path, "column 'time' (time column) appears 2 times in the header, at fields 1 and "
                  "3 (counting from 1); which one is meant cannot be told: rename the others",
            {"p1": "p1"})


def test_without_a_map_any_repeated_name_is_refused(tmp_path):
    # names equal after stripping blanks are the same name
    path = _write(tmp_path, ["time,p1,temp ,temp", "0,1,20,21", "1,2,20,21"])
    _raises(path, "column 'temp' (channel 'temp') appears 2 times in the header, at fields 3 "
                  "and 4 (counting from 1); which one is meant cannot be told: rename the "
                  "others; without a column map every column is read - give a map that selects "
                  "the columns to read")


def test_unread_repeated_names_do_no_harm(tmp_path):
    path = _write(tmp_path, ["time,junk,p1,junk,p2", "0.0,a,1,b,50", "0.1,c,2,d,51"])
    rec = read_recording(path, P1_P2)
    assert rec["p1"].tolist() == [1.0, 2.0]
    assert rec["p2"].tolist() == [50.0, 51.0]
    assert read_text(path).duplicates == {"junk": [1, 3]}


def test_a_column_really_named_with_a_dot_suffix_is_read(tmp_path):
    # pandas would call the second PG_1 "PG_1.1"; the real PG_1.1 is the third column
    path = _write(tmp_path, ["time,PG_1.1,PG_1", "0.0,7,50", "0.1,8,51"])
    rec = read_recording(path, {"p1": "PG_1.1", "p2": "PG_1"})
    assert rec["p1"].tolist() == [7.0, 8.0]
    assert rec["p2"].tolist() == [50.0, 51.0]
    path = _write(tmp_path, ["time,PG_1,PG_1,PG_1.1", "0.0,1,2,7", "0.1,3,4,8"])
    assert read_recording(path, {"p1": "PG_1.1"})["p1"].tolist() == [7.0, 8.0]


def test_missing_column_message_names_the_repeated_ones(tmp_path):
    # mapping pandas' made-up name does not reach the second PG_1
    path = _write(tmp_path, ["time,PG_1,PG_1", "0.0,1,2", "0.1,3,4"])
    _raises(path, "missing column 'PG_1.1' for channel 'p1'; available columns: ['time']; in the "
                  "header more than once (not readable): ['PG_1']", {"p1": "PG_1.1"})


def test_a_non_empty_field_beyond_the_header_is_refused_not_dropped(tmp_path):
    """Found when the streaming reader was fixed (2026-11-27): pandas dropped a value after the
    header's last column with only a warning (its index_col=False 'loss of data')."""
    p = _write(tmp_path, ["time,p1,p2", "0.0,1,50,7", "0.1,2,51,8"])
    tail = ("which column each value belongs to cannot be told (a name missing in the header, "
            "or two lines run together?)")
    _raises(p, f"row 0 has more fields than the header (3 names): field 4 is '7'; {tail}")
    p = _write(tmp_path, ["time\tp1\tp2", "0.0\t1\t50\t\t", "0.1\t2\t51\t\t9"], sep="\t",
               name="late.txt")
    _raises(p, f"row 1 has more fields than the header (3 names): field 5 is '9'; {tail}")
    p = _write(tmp_path, ["time\tp1\tp2", "0.0\t1\t50\t\t", "0.1\t2\t51\t\t"], sep="\t",
               name="tabs.txt")  # trailing separators only: ignored, as documented
    assert read_recording(p).channels["p2"].tolist() == [50.0, 51.0]


def test_a_cut_file_read_by_a_command_is_said_once(tmp_path):
    """A CLI audit (2026-11-29, session 28): a CSV cut in the middle of a line, its last line
    ending after the channels a command reads, was judged by ``analyze -c p1`` (and detect,
    monitor) without a word; read_recording refused it. Now each command reads it and says so
    once."""
    path = _write(tmp_path, ["time,p1,p2,x"] + [f"{i / 100},{i % 5},{i % 3},0.1"
                                                 for i in range(400)] + ["4.0,1,2,0.0"],
                  newline=False)
    path.write_text(path.read_text()[:-4])  # "4.0,1,2,0.0" cut to "4.0,1,2"
    import subprocess
    import sys

    for args in (["analyze", str(path), "-c", "p1"], ["monitor", str(path), "-c", "p1", "-q"]):
        # a process of its own: the warning shown as a user sees it (pytest raises warnings)
        run = subprocess.run([sys.executable, "-m", "leakdiag.cli.main", *args],
                             capture_output=True, text=True, timeout=120)
        code, err = run.returncode, run.stderr
        assert code == 0, err
        assert err.count("ends in a cut line") == 1, args[0]
        assert (f"{path}: its last line, row 400, has 3 of 4 fields (the columns read are "
                "complete, so it is read)") in err
