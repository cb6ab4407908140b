"""The words of ``monitor`` (file and stdin) and ``batch`` for bad input, the same as
``detect``'s (:mod:`leakdiag.io`): the streams audit of 2026-11-27, finding 9."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.io import read_recording
from leakdiag.io.recording import RecordingError

FS = 1000.0
N = 6000  # the rate is taken from the first 4096 rows: the faults lie after them


def _frame(swap=None):
    """6 s of white noise at 1 kHz, times printed to the ms; rows ``swap`` and ``swap + 1``
    swapped."""
    rng = np.random.default_rng(0)
    t = np.round(np.arange(N) / FS, 3)
    if swap is not None:
        t[[swap, swap + 1]] = t[[swap + 1, swap]]
    return pd.DataFrame({"time": t, "p1": rng.normal(size=N), "p2": rng.normal(size=N)})


# --- 9a: two swapped rows are named at the second, as detect names them --------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_swap_across_a_chunk_boundary_is_named_as_detect_names_it(run_cli, tmp_path, suffix):
    """Rows 5000 and 5001 swapped, the first chunk ending at row 5000: monitor said "row 5000:
    time 5.001 s after 4.999 s is a gap" (within a chunk it already said what detect says)."""
    path = str(tmp_path / f"swap{suffix}")
    frame = _frame(swap=5000)
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    want = (f"{path}: column 'time' is not strictly increasing at row 5001 "
            f"(t[5000]=5.001, t[5001]=5.0)")
    with pytest.raises(RecordingError) as exc:
        read_recording(path)
    assert str(exc.value) == want  # detect's words
    code, out, err = run_cli(["monitor", path, "-c", "p1", "--chunk", "5001"])
    assert code == 2 and err.endswith(f"error: {want}\n"), err


def test_swap_on_stdin_is_named_at_the_second_line(run_cli):
    """stdin (checked line by line) said "line 5002: time 5.001 s after 4.999 s is a gap";
    line 5003 is data row 5001 (the header is line 1)."""
    text = _frame(swap=5000).to_csv(index=False)
    code, out, err = run_cli(["monitor", "-", "-c", "p1"], stdin=text)
    assert code == 2, err
    assert err.endswith("error: <stdin>: column 'time' is not strictly increasing at line 5003 "
                        "(time 5.0 s after 5.001 s)\n"), err


def test_a_gap_is_still_a_gap(run_cli, tmp_path):
    """A real gap at a chunk's last row and on stdin keeps its words (the next time is after
    it), also when the gap is the last line of the input."""
    frame = _frame().drop(index=5001).reset_index(drop=True)
    path = str(tmp_path / "gap.parquet")
    frame.to_parquet(path)
    code, out, err = run_cli(["monitor", path, "-c", "p1", "--chunk", "5001"])
    assert code == 2 and err.endswith(
        f"error: {path}: row 5001: time 5.002 s after 5.0 s is a gap: interval 0.002 s, "
        "expected 0.001 s (1000 Hz from the time column, tolerance 0.001 relative); the "
        "stream must be uniformly sampled\n"), err
    code, out, err = run_cli(["monitor", "-", "-c", "p1"],
                             stdin=frame.iloc[:5002].to_csv(index=False))
    assert code == 2 and err.endswith(
        "error: <stdin>: line 5003: time 5.002 s after 5.0 s is a gap: interval 0.002 s, "
        "expected 0.001 s (1000 Hz from the first lines, tolerance 0.001 relative); the "
        "stream must be uniformly sampled\n"), err


# --- 9b: a non-finite sample is named with the file, in detect's words ----------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_a_nan_is_named_as_detect_names_it_by_monitor_and_batch(run_cli, tmp_path, suffix):
    """NaN at rows 5000 and 5500, read in chunks of 5200: monitor said "channel 'p1' is not
    finite at sample 5000" (no file), batch "...: ValueError: channel 'p1' is not finite at
    sample 5000"; both now say what detect says, counting over the whole file."""
    from leakdiag.batch import read_results

    frame = _frame()
    frame.loc[[5000, 5500], "p1"] = np.nan
    path = str(tmp_path / f"nan{suffix}")
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    want = f"{path}: channel 'p1' has 2 non-finite value(s); first NaN at row 5000"
    with pytest.raises(RecordingError) as exc:
        read_recording(path)
    assert str(exc.value) == want  # detect's words
    events = tmp_path / "ev.jsonl"
    code, out, err = run_cli(["monitor", path, "-c", "p1", "--chunk", "5200", "--events",
                              str(events)])
    assert code == 2 and err.endswith(f"error: {want}\n"), err
    # the windows before the first NaN are judged, as a followed file's lines are (a workflow
    # audit, 2026-11-30: none of the chunk's were): the last ends before row 5000
    import json

    ends = [json.loads(ln)["time"] for ln in events.read_text().splitlines()]
    assert len(ends) > 10 and ends[-1] < 5000 / 1000.0
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    code, out, err = run_cli(["batch", path, "--config", str(job), "-o", str(tmp_path / "res"),
                              "--scheduler", "serial", "--no-progress"])
    assert code == 1, err
    rows = read_results(tmp_path / "res")
    assert rows["status"].tolist() == ["error"] and rows["error"].tolist() == [want]


def test_a_nan_on_stdin_is_named_with_its_line(run_cli):
    """A literal 'nan' on stdin was "channel 'p1' is not finite at sample 5000" (no stream)."""
    frame = _frame()
    frame.loc[5000, "p1"] = np.nan
    code, out, err = run_cli(["monitor", "-", "-c", "p1"], stdin=frame.to_csv(index=False,
                                                                               na_rep="nan"))
    assert code == 2 and err.endswith(
        "error: <stdin>: line 5002, channel 'p1': 'nan' is not a finite number\n"), err


# --- 9c: the rate warning says where the rate came from --------------------------------------

def test_the_low_rate_warning_names_where_the_rate_came_from(run_cli, tmp_path):
    """A 1-Hz rate from a leakdiag header, or from a map's sample_rate_hz, was "from the time
    column" with time-column advice (--time-unit ms); a time column's keeps its words."""
    from leakdiag.io import Recording, write_recording

    rng = np.random.default_rng(1)
    p1 = rng.normal(size=400)
    hdr = str(write_recording(Recording({"p1": p1}, 1.0), tmp_path / "slow.parquet"))
    notime = tmp_path / "notime.csv"
    pd.DataFrame({"p1": p1}).to_csv(notime, index=False)
    cmap = tmp_path / "map.toml"
    cmap.write_text('[file]\nsample_rate_hz = 1\n[channels]\np1 = "p1"\n')
    timed = tmp_path / "timed.csv"
    pd.DataFrame({"time": np.arange(400.0), "p1": p1}).to_csv(timed, index=False)
    cases = [
        (["monitor", hdr, "-c", "p1", "-q"],
         f"{hdr}: sample rate 1 Hz from the file's leakdiag header is low for actuator "
         "pressures; the header of a file leakdiag wrote gives the rate its samples were "
         "written at: if that is wrong, write the recording again with its true rate"),
        (["analyze", hdr, "--method", "autocorrelation", "--channels", "p1"],
         f"{hdr}: sample rate 1 Hz from the file's leakdiag header is low for actuator "
         "pressures; the header"),
        (["monitor", str(notime), "-c", "p1", "-q", "--map", str(cmap)],
         f"{notime}: sample rate 1 Hz from sample_rate_hz in the column map is low for "
         "actuator pressures; check sample_rate_hz in the column map (in Hz)"),
        (["monitor", str(timed), "-c", "p1", "-q"],
         f"{timed}: sample rate 1 Hz from the time column is low for actuator pressures; if "
         "the time column is in milliseconds or a sample counter, give --time-unit ms"),
    ]
    for args, want in cases:
        with pytest.warns(UserWarning) as caught:
            run_cli(args)
        assert any(str(w.message).startswith(want) for w in caught), (args, caught[0].message)
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    code, out, err = run_cli(["batch", hdr, "--config", str(job), "-o", str(tmp_path / "res"),
                              "--scheduler", "serial", "--no-progress"])
    assert ("warning: slow.parquet: sample rate 1 Hz from the file's leakdiag header is low "
            "for actuator pressures; the header") in err, err


# --- 9d: a repeated Parquet column name is refused in one line ------------------------------

@pytest.mark.parametrize("header", [False, True])
def test_a_repeated_parquet_name_is_one_line_naming_file_and_name(run_cli, tmp_path, header):
    """detect printed arrow's multi-line schema dump ("unreadable as Parquet: Multiple matches
    for FieldRef.Name(p1) in p1: double | p1: double ... __filename: string"); now the words
    of a CSV header's repeated name, which monitor also says for this file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from leakdiag.io import Recording, write_recording

    frame = _frame()
    path = str(tmp_path / "dup.parquet")
    table = pa.Table.from_arrays([pa.array(frame["time"]), pa.array(frame["p1"]),
                                  pa.array(frame["p1"]), pa.array(frame["p2"])],
                                 names=["time", "p1", "p1", "p2"])
    if header:  # a leakdiag header (restored exactly, without the repeated-name check before)
        hdr = tmp_path / "h.parquet"
        write_recording(Recording({"p1": frame["p1"].to_numpy(), "p2": frame["p2"].to_numpy()},
                                  FS), hdr)
        table = table.replace_schema_metadata(pq.read_schema(hdr).metadata)
    pq.write_table(table, path)
    want = (f"{path}: column 'p1' (channel 'p1') appears 2 times in the header, at fields 2 "
            "and 3 (counting from 1); which one is meant cannot be told: rename the others")
    code, out, err = run_cli(["detect", path, "--healthy", path])
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"leakdiag: error: {want}"), err
    code, out, err = run_cli(["monitor", path, "-c", "p1"])
    assert code == 2 and err.endswith(f"error: {want}\n"), err


# --- 9e: a batch detector row holds the detector's verdict only ------------------------------

class HalfScorer:
    """A bare scorer of the acf of p1 (lag 1, N=200, 5 %): score 1 - value, alarm at 0.5."""

    threshold_ = 0.5

    def spec(self):
        from leakdiag.features.spec import MethodSpec

        return MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)

    def score_windows(self, values, time_s):
        return 1.0 - values


def test_a_batch_detector_row_has_no_measure_note(run_cli, tmp_path):
    """A file whose metadata onset (60 s) lies outside it (start 1234.567 s): the ok detector
    row with an alarm read "Sec. 5.2 measure: ... needs at least one whole chunk on each side
    of the onset" in its error; the measure is the analysis row's only."""
    import pickle

    from leakdiag.batch import read_results
    from leakdiag.io import Recording, write_recording

    frame = _frame()
    path = str(write_recording(Recording({"p1": frame["p1"].to_numpy()}, FS, 1234.567,
                                         meta={"onset": 60.0}), tmp_path / "late.parquet"))
    (tmp_path / "det.pkl").write_bytes(pickle.dumps(HalfScorer()))
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n\n'
                   '[[detector]]\nname = "half"\npath = "det.pkl"\n')
    code, out, err = run_cli(["batch", path, "--config", str(job), "-o", str(tmp_path / "res"),
                              "--scheduler", "serial", "--no-progress"])
    assert code == 0 and "bare pickle" in err, err
    rows = read_results(tmp_path / "res").set_index("kind")
    det, ana = rows.loc["detector"], rows.loc["analysis"]
    assert det["status"] == "ok" and bool(det["alarm"]) and pd.isna(det["error"]), det["error"]
    assert np.isnan(det["onset_s"]) and np.isnan(det["pct_change_signed"])
    assert ana["status"] == "ok" and ana["onset_s"] == 60.0
    assert ana["error"].startswith("Sec. 5.2 measure: "), ana["error"]


# --- 7: stdin reads the separators and quoting that the file readers read --------------------

@pytest.mark.parametrize("sep,quoting", [(";", 0), ("\t", 0), ("|", 0), (",", 2), (";", 2)])
def test_stdin_reads_what_the_file_reader_reads(run_cli, tmp_path, sep, quoting):
    """stdin split on ',' only: ';' gave "missing channel(s) ['p1']; available:
    ['time;p1;p2']", a quoted header "available: ['\\"p1\\"', ...]", tab "column
    'time\\tp1\\tp2' looks like a time column"; now the same windows as the file."""
    import csv
    import json

    frame = _frame().iloc[:1000]
    path = tmp_path / "run.csv"
    frame.to_csv(path, sep=sep, index=False, quoting=quoting)  # 2: every field quoted
    assert quoting != csv.QUOTE_NONNUMERIC or path.read_text().startswith('"time"')
    got = {}
    for name, args, stdin in (("file", [str(path)], None),
                              ("stdin", ["-"], path.read_text())):
        ev = tmp_path / f"{name}.jsonl"
        code, out, err = run_cli(["monitor", *args, "-c", "p1", "--events", str(ev)],
                                 stdin=stdin)
        assert code == 0, err
        assert "1000 samples at 1000 Hz, 5 windows (autocorrelation p1 1 N=200 5%)" in out, out
        got[name] = [json.loads(ln) for ln in ev.read_text().splitlines()]
    assert [e["time"] for e in got["stdin"]] == [e["time"] for e in got["file"]]
    np.testing.assert_allclose([e["value"] for e in got["stdin"]],
                               [e["value"] for e in got["file"]], rtol=1e-12)


def test_stdin_refuses_a_quoted_field_across_lines(run_cli):
    """A newline inside quotes cannot be read line by line: refused naming the line."""
    text = 'time,p1,note\n' + "".join(f"{k / 1000},{k % 7},x\n" for k in range(300))
    text = text.replace("0.25,5,x\n", '0.25,5,"two\nlines"\n')
    code, out, err = run_cli(["monitor", "-", "-c", "p1"], stdin=text)
    assert code == 2 and err.endswith(
        "error: <stdin>: line 252: a quoted field goes on past the end of the line (a newline "
        "inside quotes); a stream is read line by line: '0.25,5,\"two'\n"), err


# --- 8: a file's streamed sample rate is detect's, from the whole time column -----------------

def test_a_streamed_file_has_detect_s_sample_rate(run_cli, tmp_path):
    """3 kHz, 6000 rows, times printed to 5 decimals: the last is 1.99967 s, so io's rate is
    5999 / 1.99967 = 2999.994999175 Hz (9 decimals); the first 4096 rows end at 1.36500 s, and
    monitor and batch took 4095 / 1.365 = 3000 Hz. stdin keeps its first lines' rate (its
    end is not known; docs/operations.md)."""
    import json

    from leakdiag.batch import read_results
    from leakdiag.stream.files import open_recording

    n, rate = 6000, 2999.994999175
    path = tmp_path / "r3k.csv"
    pd.DataFrame({"time": np.arange(n) / 3000.0, "p1": _frame()["p1"]}).to_csv(
        path, index=False, float_format="%.5f")
    assert read_recording(path).sample_rate == rate  # detect's
    assert open_recording(str(path), ["p1"], 1000)[0].sample_rate == rate  # batch's reader
    for args, stdin, fs in (([str(path)], None, rate), (["-"], path.read_text(), 3000.0)):
        ev = tmp_path / "ev.jsonl"
        code, out, err = run_cli(["monitor", *args, "-c", "p1", "--events", str(ev)],
                                 stdin=stdin)
        assert code == 0, err
        first = json.loads(ev.read_text().splitlines()[0])
        assert first["time"] == 199 / fs, (args, first)
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    code, out, err = run_cli(["batch", str(path), "--config", str(job), "-o",
                              str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert code == 0, err
    assert read_results(tmp_path / "res")["sample_rate"].tolist() == [rate]
