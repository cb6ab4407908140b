"""Reading delimited text: separators, standard headers, column maps, junk columns, time axes."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from leakdiag.io import RecordingError, read_recording
from leakdiag.io.text import detect_separator


def _write(tmp_path, text, name="run.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("sep", [",", "\t", ";", "|", " "])
def test_standard_header_any_separator(tmp_path, sep):
    rows = ["time p1 p2 x u", "0.00 1e5 2e5 0.001 0.5", "0.01 1.5e5 2e5 0.002 -0.5",
            "0.02 2e5 2e5 0.003 0"]
    path = _write(tmp_path, "\n".join(r.replace(" ", sep) for r in rows) + "\n")
    rec = read_recording(path)
    assert rec.sample_rate == 100.0
    assert rec.channel_names == ["p1", "p2", "x", "u"]
    assert rec["p1"].tolist() == [1e5, 1.5e5, 2e5]
    assert rec["u"].tolist() == [0.5, -0.5, 0.0]
    assert rec.units == {"p1": "Pa", "p2": "Pa", "x": "m", "u": "V"}
    assert rec.meta == {"source": str(path)}


def test_detect_separator_prefers_consistent_candidate():
    # the header has commas in a quoted name, but the data rows only have tabs
    assert detect_separator(["a\tb,c\td", "1\t2\t3"]) == "\t"
    assert detect_separator(["a;b;c", "1,5;2,5;3"]) == ";"  # decimal commas


def test_no_time_column_needs_sample_rate(tmp_path):
    path = _write(tmp_path, "p1,p2\n1,2\n3,4\n")
    with pytest.raises(RecordingError, match=r"run.csv: no time column .* and no sample rate; "
                                             r"name the file's time column .*, or, if it has "
                                             r"none, give the sample rate \(--sample-rate, or "
                                             r"sample_rate_hz in the map\)"):
        read_recording(path)
    rec = read_recording(path, sample_rate=50)
    assert (rec.sample_rate, rec.start_time, rec.n_samples) == (50.0, 0.0, 2)


def test_units_argument_converts(tmp_path):
    path = _write(tmp_path, "time,p1,x\n0,100,5\n0.5,200,6\n")
    rec = read_recording(path, units={"p1": "bar", "x": "mm"})
    assert rec["p1"].tolist() == [1e7, 2e7]
    np.testing.assert_allclose(rec["x"], [0.005, 0.006], rtol=1e-15)
    with pytest.raises(RecordingError, match=r"units given for channel 'p2', which is not read"):
        read_recording(path, units={"p2": "bar"})
    with pytest.raises(RecordingError, match=r"channel 'p1': .*unknown unit 'atm'"):
        read_recording(path, units={"p1": "atm"})


def test_extra_numeric_columns_are_read_without_a_map(tmp_path):
    path = _write(tmp_path, "time,p1,temp_c\n0,1,20\n1,2,21\n")
    rec = read_recording(path)
    assert rec.channel_names == ["p1", "temp_c"]
    assert "temp_c" not in rec.units


def test_text_column_without_map_is_an_error(tmp_path):
    path = _write(tmp_path, "time,p1,note\n0,1,start\n1,2,\n")
    with pytest.raises(RecordingError, match=r"channel 'note' \(column 'note'\) holds text, not "
                                             r"numbers: row 0 is 'start'.*give a map"):
        read_recording(path)


def test_junk_columns_ignored_with_a_map(tmp_path):
    text = ("Cnt\tPA\tPB\tLabel\tScore\t\n"
            "1\t100\t200\thello\t3.5\t\n"
            "2\t110\t190\t\t\t\n"
            "3\t120\t180\t\t\t\n")
    path = _write(tmp_path, text, "odd name (1).txt")
    cmap = {"file": {"sample_rate_hz": 10, "time_column": "Cnt", "time_unit": "samples"},
            "channels": {"p1": {"column": "PA", "unit": "counts", "gain": 1000.0},
                         "p2": {"column": "PB", "unit": "counts"}}}
    rec = read_recording(path, cmap)
    assert rec["p1"].tolist() == [1e5, 1.1e5, 1.2e5]
    assert rec["p2"].tolist() == [200.0, 190.0, 180.0]
    assert rec.units == {"p1": "Pa", "p2": "counts"}
    assert rec.sample_rate == 10.0
    assert rec.start_time == pytest.approx(0.1)  # time = counter / sample_rate
    assert rec.meta["column_map"]["channels"]["p1"]["gain"] == 1000.0


def test_mapped_text_column_is_an_error(tmp_path):
    path = _write(tmp_path, "t,PA,Label\n0,1,a\n1,2,b\n")
    with pytest.raises(RecordingError, match=r"run.csv: channel 'p1' \(column 'Label'\) holds "
                                             r"text, not numbers: row 0 is 'a' \(2 non-numeric"):
        read_recording(path, {"p1": "Label"}, sample_rate=1)


def test_text_in_the_middle_names_the_row(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n1,2\n2,oops\n3,4\n")
    with pytest.raises(RecordingError, match=r"channel 'p1' \(column 'p1'\) holds text, not "
                                             r"numbers: row 2 is 'oops'"):
        read_recording(path, {"p1": "p1"})


@pytest.mark.parametrize("unit, scale", [("s", 1.0), ("ms", 1e-3), ("us", 1e-6)])
def test_time_units(tmp_path, unit, scale):
    path = _write(tmp_path, "T,P\n0,1\n2,2\n4,3\n6,4\n")
    rec = read_recording(path, {"file": {"time_column": "T", "time_unit": unit},
                                "channels": {"p1": {"column": "P"}}})
    assert rec.sample_rate == pytest.approx(1 / (2 * scale), rel=1e-9)


def test_sample_rate_must_agree_with_time_column(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n0.001,2\n0.002,3\n")
    assert read_recording(path, sample_rate=1000).sample_rate == 1000.0
    with pytest.raises(RecordingError, match=r"a sample rate of 2000 Hz was given .*, but the "
                                             r"file's time column 'time' says 1000 Hz"):
        read_recording(path, sample_rate=2000)


def test_channel_order_follows_the_map(tmp_path):
    path = _write(tmp_path, "time,a,b\n0,1,2\n1,3,4\n")
    rec = read_recording(path, {"p2": "a", "p1": "b"})
    assert rec.channel_names == ["p2", "p1"]
    assert rec["p1"].tolist() == [2.0, 4.0]


def test_utf8_bom_and_blank_padded_header(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufefftime , p1\n0, 1\n1, 2\n".encode("utf-8"))
    rec = read_recording(path)
    assert rec["p1"].tolist() == [1.0, 2.0]


def test_explicit_separator(tmp_path):
    path = _write(tmp_path, "time:p1\n0:1\n1:2\n")
    rec = read_recording(path, {"file": {"separator": ":"}, "channels": {"p1": "p1"}})
    assert rec["p1"].tolist() == [1.0, 2.0]


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(sep=st.sampled_from([",", "\t", ";", "|"]),
       trailing=st.booleans(),
       crlf=st.booleans(),
       data=st.lists(st.tuples(st.floats(-1e9, 1e9, allow_nan=False),
                               st.integers(-2**31, 2**31)), min_size=2, max_size=12))
def test_any_separator_and_line_ending_reads_back(tmp_path, sep, trailing, crlf, data):
    end = (sep if trailing else "") + ("\r\n" if crlf else "\n")
    lines = [sep.join(["time", "p1", "raw"]) + end]
    lines += [sep.join([repr(i / 100), repr(a), str(b)]) + end for i, (a, b) in enumerate(data)]
    path = tmp_path / "h.txt"
    path.write_bytes("".join(lines).encode())
    rec = read_recording(path, {"p1": "p1", "counts": "raw:counts"})
    assert rec["p1"].tolist() == [a for a, _ in data]
    assert rec["counts"].tolist() == [float(b) for _, b in data]
    assert rec.sample_rate == 100.0
