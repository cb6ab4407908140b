"""The error catalogue of docs/io.md: each bad input gives one RecordingError naming the problem."""

import numpy as np
import re
import pytest

from leakdiag.io import Recording, RecordingError, check_length, read_recording


def _write(tmp_path, text, name="run.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_file_not_found(tmp_path):
    with pytest.raises(RecordingError, match=r"missing.csv: file not found"):
        read_recording(tmp_path / "missing.csv")


def test_directory(tmp_path):
    with pytest.raises(RecordingError, match="is a directory"):
        read_recording(tmp_path)


def test_unknown_format(tmp_path):
    path = _write(tmp_path, "x", "run.xlsx")
    with pytest.raises(RecordingError, match=r"run.xlsx: cannot read files with extension "
                                             r"'.xlsx'; known: .csv, .tsv, .txt, .dat, .parquet"):
        read_recording(path)


def test_empty_file(tmp_path):
    with pytest.raises(RecordingError, match=r"run.csv: file is empty"):
        read_recording(_write(tmp_path, ""))
    with pytest.raises(RecordingError, match=r"file is empty"):
        read_recording(_write(tmp_path, "\n\n  \n"))


def test_header_without_rows(tmp_path):
    with pytest.raises(RecordingError, match=r"has a header \(time, p1\) but no data rows"):
        read_recording(_write(tmp_path, "time,p1\n"))


def test_binary_file_with_text_extension(tmp_path):
    path = tmp_path / "run.csv"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(RecordingError, match=r"run.csv: unreadable as text \(binary data\)"):
        read_recording(path)


@pytest.mark.parametrize("ext, what", [(".parquet", "Parquet"), (".h5", "HDF5"),
                                       (".mat", "a MATLAB .mat file")])
def test_unreadable_binary_formats(tmp_path, ext, what):
    path = _write(tmp_path, "time,p1\n0,1\n", f"run{ext}")
    with pytest.raises(RecordingError, match=rf"run{ext}: unreadable as {what}"):
        read_recording(path)


def test_missing_column_lists_available(tmp_path):
    path = _write(tmp_path, "t,PA,PB\n0,1,2\n1,2,3\n")
    with pytest.raises(RecordingError, match=r"run.csv: missing column 'PG_1' for channel 'p1'; "
                                             r"available columns: \['t', 'PA', 'PB'\]"):
        read_recording(path, {"p1": "PG_1"}, sample_rate=1)
    with pytest.raises(RecordingError, match=r"missing time column 'Time'; available columns"):
        read_recording(path, {"file": {"time_column": "Time"}, "channels": {"p1": "PA"}})


def test_no_standard_column_without_map(tmp_path):
    path = _write(tmp_path, "t,PA,PB\n0,1,2\n1,2,3\n")
    with pytest.raises(RecordingError, match=r"no column is named like a channel \(p1, p2, x, u, "
                                             r"x_ref, leak_flow, speed\); available columns: "
                                             r"\['t', 'PA', 'PB'\]; give a column map"):
        read_recording(path)


@pytest.mark.parametrize("value, kind", [("nan", "NaN"), ("inf", "inf"), ("", "NaN")])
def test_non_finite_names_channel_and_first_row(tmp_path, value, kind):
    path = _write(tmp_path, f"time,p1,p2\n0,1,1\n1,2,2\n2,3,{value}\n3,4,{value}\n")
    with pytest.raises(RecordingError, match=rf"run.csv: channel 'p2' has 2 non-finite value\(s\); "
                                             rf"first {kind} at row 2"):
        read_recording(path)


def test_non_monotonic_time_names_row(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n1,2\n3,3\n2,4\n")
    with pytest.raises(RecordingError, match=r"column 'time' is not strictly increasing at row 3 "
                                             r"\(t\[2\]=3.0, t\[3\]=2.0\)"):
        read_recording(path)
    with pytest.raises(RecordingError, match=r"time is not strictly increasing at row 3"):
        read_recording(path, resample=1.0)


def test_non_uniform_time_suggests_resample(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n1,2\n2,3\n3.5,4\n4.5,5\n")
    with pytest.raises(RecordingError, match=r"column 'time' is not uniformly sampled: interval "
                                             r"before row 3 is 1.5 s.*--resample RATE_HZ"):
        read_recording(path)


def test_non_finite_time(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n,2\n2,3\n")
    with pytest.raises(RecordingError, match=r"time column 'time' is not a finite number at row 1"):
        read_recording(path)


def test_sample_counter_needs_a_rate(tmp_path):
    path = _write(tmp_path, "n,p\n1,1\n2,2\n")
    with pytest.raises(RecordingError, match=r"time column 'n' is a sample counter; give the "
                                             r"sample rate"):
        read_recording(path, {"file": {"time_column": "n", "time_unit": "samples"},
                              "channels": {"p1": "p"}})


def test_dropped_samples_in_counter(tmp_path):
    path = _write(tmp_path, "n,p\n1,1\n2,2\n3,3\n5,4\n6,5\n")
    cmap = {"file": {"time_column": "n", "time_unit": "samples", "sample_rate_hz": 1000},
            "channels": {"p1": "p"}}
    with pytest.raises(RecordingError, match=r"column 'n' is not uniformly sampled: interval "
                                             r"before row 3"):
        read_recording(path, cmap)


def test_invalid_sample_rate_argument(tmp_path):
    path = _write(tmp_path, "p1\n1\n2\n")
    with pytest.raises(RecordingError, match=r"run.csv: sample_rate=-1 must be a finite number > 0"):
        read_recording(path, sample_rate=-1)


def test_rows_longer_than_header(tmp_path):
    path = _write(tmp_path, "time,p1\n0,1\n1,2,3,4\n")
    with pytest.raises(RecordingError, match=r"run.csv: cannot parse as delimited text"):
        read_recording(path)


def test_check_length():
    rec = Recording({"p1": np.zeros(150), "p2": np.zeros(150)}, 1000.0,
                    meta={"source": "run.csv"})
    check_length(rec, 150, "p1")  # exactly one window is enough
    with pytest.raises(RecordingError, match=r"run.csv: channel 'p1' has 150 samples \(0.15 s\), "
                                             r"shorter than one window \(window=151\)"):
        check_length(rec, 151, "p1")
    with pytest.raises(RecordingError, match=r"run.csv: recording has 150 samples"):
        check_length(rec, 200)
    with pytest.raises(RecordingError, match=r"missing channel\(s\) \['x'\]"):
        check_length(rec, 10, "x")
    with pytest.raises(ValueError, match=r"window=0 must be"):
        check_length(rec, 0)
    with pytest.raises(TypeError, match=r"window=1.5 must be an integer"):
        check_length(rec, 1.5)


def test_latin1_text_is_read(tmp_path):
    path = tmp_path / "daq.csv"
    path.write_bytes("time;p1;T in \xb0C\n0;1;20\n1;2;21\n".encode("latin-1"))
    rec = read_recording(path, {"p1": "p1"})
    assert rec["p1"].tolist() == [1.0, 2.0]
    rec = read_recording(path, {"temp": "T in \xb0C"})
    assert rec["temp"].tolist() == [20.0, 21.0]


def test_bad_dict_map_names_the_data_file(tmp_path):
    path = _write(tmp_path, "time,P\n0,1\n1,2\n")
    with pytest.raises(RecordingError, match=r"run.csv: column map: column spec 'p1=P:atm': .*"
                                             r"unknown unit 'atm'"):
        read_recording(path, {"p1": "P:atm"})


def test_a_latin_1_byte_after_the_first_64_kb_reads_the_file_as_latin_1(tmp_path):
    """A user-data audit (2026-11-29): a cp1252 export whose only non-UTF-8 byte (a degree
    sign in a note) came after the 64 KB the encoding was sniffed on failed with "'utf-8'
    codec can't decode byte 0xb0 in position 131694" in every command; docs/io.md says text
    that is not UTF-8 is read as Latin-1."""
    import numpy as np

    from leakdiag.io import read_recording
    from leakdiag.stream import open_chunks

    rows = [f"{k / 1000:.3f},{k % 97},{k % 89}," for k in range(8000)]
    rows[7000] += "45\xb0C"
    path = tmp_path / "late.csv"
    path.write_bytes(("time,p1,p2,note\n" + "\n".join(rows) + "\n").encode("cp1252"))
    assert path.stat().st_size > 1 << 16 and path.read_bytes().index(b"\xb0") > 1 << 16
    rec = read_recording(path, channels=["p1", "p2"])
    assert rec["p1"][7000] == 7000 % 97 and rec.n_samples == 8000
    got = np.concatenate([c["p2"] for c in open_chunks(path, ["p1", "p2"], 1000)])
    assert got.tolist() == [k % 89 for k in range(8000)]


def test_decimal_commas_are_named_not_read_as_text_to_leave_out(tmp_path):
    """A user-data audit (2026-11-29): an Excel export with decimal commas was refused with
    advice to map only the numeric columns (p1, the channel needed, among the "text" ones)."""
    from leakdiag.io import RecordingError, read_recording
    from leakdiag.stream import open_chunks

    path = tmp_path / "excel.csv"
    path.write_text("time;p1;p2\n0,0;0,392;3,608\n0,001;0,596;2,994\n0,002;1,5;2,5\n")
    hint = ("'0,0' looks like a number with a decimal comma (an export in a European "
            "locale?): leakdiag reads '.' as the decimal mark and guesses no locale")
    with pytest.raises(RecordingError, match=re.escape(hint)) as exc:
        read_recording(path, column_map={"p1": "p1"}, sample_rate=1000.0)
    assert "give a map" not in str(exc.value)
    with pytest.raises(RecordingError, match=re.escape("row 0 is '0,0'; '0,0' looks like a "
                                                       "number with a decimal comma")):
        list(open_chunks(path, ["p1"]))
    path.write_text("time,p1\n0.0,abc\n0.001,1\n")  # other text: no such hint
    with pytest.raises(RecordingError) as exc:
        read_recording(path)
    assert "decimal comma" not in str(exc.value)


def test_utf16_text_and_a_separator_other_than_the_maps_are_named(tmp_path):
    """A user-data audit (2026-11-29): an Excel "Unicode text" export (UTF-16) was reported as
    "unreadable as text (binary data)", and a ';' file read with a map's tab separator said
    only "missing column 'PG_1'" with the whole header as one name."""
    from leakdiag.io import RecordingError, read_recording

    path = tmp_path / "u16.txt"
    path.write_bytes("time\tp1\n0\t1\n0.001\t2\n".encode("utf-16"))
    with pytest.raises(RecordingError, match=re.escape(
            "u16.txt: UTF-16 text (a byte-order mark; Excel's \"Unicode text\"): leakdiag "
            "reads UTF-8 or Latin-1 text")):
        read_recording(path)
    semi = tmp_path / "semi.txt"
    semi.write_text("Time;PG_1\n1;10\n2;11\n")
    cmap = {"file": {"separator": "\t", "time_column": "Time", "time_unit": "ms"},
            "channels": {"p1": "PG_1"}}
    with pytest.raises(RecordingError, match=re.escape(
            "the header is one field that holds ';': the file seems separated by ';', not by "
            "the separator given")):
        read_recording(semi, cmap)
