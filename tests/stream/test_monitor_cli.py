"""``leakdiag monitor``: events equal ``leakdiag analyze`` on the same file; stdin; detector; errors."""

import json
import pickle

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from scipy.signal import lfilter

from _stream_ref import ac_ref, cc_ref
from leakdiag.cli.main import cli
from leakdiag.cli.monitor import parse_replay
from leakdiag.io.recording import Recording


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    from leakdiag.io.parquet import write_parquet

    rng = np.random.default_rng(0)
    p1 = np.r_[lfilter([1], [1, -0.9], rng.normal(size=6000)),
               lfilter([1], [1, -0.3], rng.normal(size=6000))]
    rec = Recording({"p1": 1e7 + 1e5 * p1, "p2": rng.normal(size=12000)}, 1000.0,
                    start_time=0.5, meta={"onset": 6.5})
    path = tmp_path_factory.mktemp("mon") / "run.parquet"
    write_parquet(rec, path)
    return path, rec


def _events(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_monitor_equals_analyze(run_file, tmp_path):
    path, rec = run_file
    args = ["--method", "autocorrelation", "--channels", "p1", "--lag", "1", "--window", "200",
            "--overlap", "5"]
    ev_path = tmp_path / "events.jsonl"
    r = CliRunner().invoke(cli, ["monitor", "--input", str(path), "--replay", "fast", *args,
                                 "--events", str(ev_path), "--chunk", "999"])
    assert r.exit_code == 0, r.output
    events = _events(ev_path)
    expected = ac_ref(rec["p1"], 1, 200, 5)
    np.testing.assert_allclose([e["value"] for e in events], expected, rtol=1e-9)
    assert events[0]["time"] == pytest.approx(0.5 + 0.199)
    assert "12000 samples at 1000 Hz, 63 windows" in r.output
    out = tmp_path / "an"
    r2 = CliRunner().invoke(cli, ["analyze", str(path), *args, "--out", str(out)])
    if r2.exit_code != 0:
        pytest.skip(f"leakdiag analyze not usable yet: {r2.output[-300:]}")
    feats = pd.read_parquet(out / "features.parquet")
    np.testing.assert_allclose([e["value"] for e in events], feats["value"], rtol=1e-9)
    np.testing.assert_allclose([e["time"] for e in events], feats["time"], atol=1e-12)


def test_monitor_takes_the_recording_as_file_like_analyze_and_detect(run_file, tmp_path):
    """`leakdiag monitor FILE` (as analyze/detect/sweep take FILE) equals `--input FILE`;
    both at once, or neither, is a usage error that says what to give."""
    path, rec = run_file
    out = {}
    for how, args in (("file", [str(path)]), ("input", ["--input", str(path)])):
        ev = tmp_path / f"{how}.jsonl"
        r = CliRunner().invoke(cli, ["monitor", *args, "--window", "200", "--events", str(ev)])
        assert r.exit_code == 0, r.output
        out[how] = _events(ev)
    assert out["file"] == out["input"] and len(out["file"]) == 63
    r = CliRunner().invoke(cli, ["monitor", str(path), "--input", str(path)])
    assert r.exit_code == 2 and "give the recording once: FILE" in r.output
    r = CliRunner().invoke(cli, ["monitor", "--window", "200"])
    assert r.exit_code == 2 and "give the recording: leakdiag monitor FILE" in r.output


def test_monitor_stdin_cross_correlation():
    rng = np.random.default_rng(2)
    y, x = rng.normal(size=250), rng.normal(size=250)
    lines = "time,p1,p2\n" + "".join(f"{i / 100},{a!r},{b!r}\n" for i, (a, b) in
                                     enumerate(zip(y.tolist(), x.tolist())))
    r = CliRunner().invoke(cli, ["monitor", "-i", "-", "-m", "cross-correlation", "-c", "p1,p2",
                                 "--batch-lines", "7",
                                 "--lag", "2", "-w", "50", "--overlap", "10", "--events", "-", "-q"],
                           input=lines)
    assert r.exit_code == 0, r.output
    events = [json.loads(line) for line in r.stdout.splitlines()]
    np.testing.assert_allclose([e["value"] for e in events], cc_ref(y, x, 2, 50, 10), rtol=1e-9)
    assert events[-1]["time"] == pytest.approx((4 * 45 + 49) / 100)


class Threshold:
    """Picklable WindowScorer: score = 1 - value, alarm when the correlation falls below 0.5."""

    threshold_ = 0.5

    def score_windows(self, values, time):
        return 1.0 - values


def test_monitor_with_pickled_scorer_prints_alarm(run_file, tmp_path):
    path, rec = run_file
    det = tmp_path / "det.pkl"
    det.write_bytes(pickle.dumps(Threshold()))
    ev_path = tmp_path / "ev.jsonl"
    with pytest.warns(UserWarning, match="bare pickled detector without a metadata record"):
        r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1", "--detector",
                                     str(det), "--events", str(ev_path)])
    assert r.exit_code == 0, r.output
    events = _events(ev_path)
    expected = (1 - ac_ref(rec["p1"], 1, 200, 5)) >= 0.5
    assert [e["alarm"] for e in events] == expected.tolist()
    first = next(e["time"] for e in events if e["alarm"])
    assert f"ALARM   t={first:.6g} s" in r.output and first > 6.5


def test_parse_replay_and_errors(run_file, tmp_path):
    assert parse_replay("realtime") == 1.0 and parse_replay("2.5") == 2.5
    r = CliRunner().invoke(cli, ["monitor", "-i", str(run_file[0]), "--replay", "slow"])
    assert r.exit_code != 0 and "use fast, realtime or a factor" in r.output
    bad = tmp_path / "bad.pkl"
    bad.write_bytes(b"not a pickle")
    r = CliRunner().invoke(cli, ["monitor", "-i", str(run_file[0]), "--detector", str(bad)])
    assert r.exit_code != 0 and "cannot load" in r.output


def test_monitor_follow_and_text_fallback(run_file, tmp_path):
    _, rec = run_file
    part = rec.slice_time(None, 1.5)  # 1000 samples -> 5 windows of 200 at 5 % overlap
    csv = tmp_path / "live.csv"
    part.to_pandas()[["time", "p1"]].to_csv(csv, index=False)
    ev = tmp_path / "f.jsonl"
    r = CliRunner().invoke(cli, ["monitor", "-i", str(csv), "--follow", "--idle-timeout", "0.2",
                                 "-c", "p1", "--events", str(ev)])
    assert r.exit_code == 0, r.output
    np.testing.assert_allclose([e["value"] for e in _events(ev)], ac_ref(part["p1"], 1, 200, 5),
                               rtol=1e-9)
    tsv = tmp_path / "run.tsv"  # not a chunked format: loaded whole through read_recording
    part.to_pandas()[["time", "p1"]].to_csv(tsv, index=False, sep="\t")
    ev2 = tmp_path / "t.jsonl"
    r = CliRunner().invoke(cli, ["monitor", "-i", str(tsv), "-c", "p1", "--events", str(ev2)])
    assert r.exit_code == 0, r.output
    assert [e["value"] for e in _events(ev2)] == pytest.approx([e["value"] for e in _events(ev)],
                                                               rel=1e-9)


# ------------------------------------------------------------------ issue 15
def test_monitor_without_detector_says_no_alarm_was_possible(run_file):
    path, _ = run_file
    r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1"])
    assert r.exit_code == 0, r.output
    assert "no alarm possible (features only: give --detector FILE from leakdiag fit)" in r.output
    assert "alarm raising(s)" not in r.output


def test_monitor_sample_rate_conflicting_with_the_file_is_refused(run_file, tmp_path):
    path, rec = run_file
    r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1", "--sample-rate", "500"])
    assert r.exit_code != 0
    assert "500 Hz was given (--sample-rate, or sample_rate_hz in a column map), but the " \
           "file's header says 1000 Hz" in str(r.exception)
    csv = tmp_path / "run.csv"
    rec.to_pandas().to_csv(csv, index=False)
    r = CliRunner().invoke(cli, ["monitor", "-i", str(csv), "-c", "p1", "--sample-rate", "500"])
    assert "500 Hz was given (--sample-rate, or sample_rate_hz in a column map), but the " \
           "file's time column 'time' says 1000 Hz" in str(r.exception)


def test_monitor_stdin_time_going_backwards_is_an_error():
    lines = ["time,p1"] + [f"{k / 1000:.3f},{np.sin(k)}" for k in range(300)]
    lines[200] = f"{0.150:.3f},{0.0}"  # line 201 of the stream (1: header) goes back in time
    r = CliRunner().invoke(cli, ["monitor", "-i", "-", "-c", "p1", "-w", "50", "-q"],
                           input="\n".join(lines) + "\n")
    assert r.exit_code != 0
    assert ("<stdin>: column 'time' is not strictly increasing at line 201 (time 0.15 s after "
            "0.198 s)") in str(r.exception)


def test_monitor_empty_and_text_csv_name_file_channel_row(tmp_path):
    from leakdiag.cli.main import main

    empty = tmp_path / "empty.csv"
    empty.write_text("")
    text = tmp_path / "text.csv"
    rows = [f"{k / 1000},{np.sin(k)}" for k in range(5000)]
    rows[4500] = "4.5,abc"
    text.write_text("time,p1\n" + "\n".join(rows) + "\n")
    import contextlib
    import io

    for f, needle in [(empty, "empty.csv: empty file"),
                      (text, "text.csv: channel 'p1' holds text, not numbers: row 4500 is 'abc'")]:
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            code = main(["monitor", "-i", str(f), "-c", "p1", "-q", "--chunk", "1000"])
        assert code == 2 and needle in err.getvalue(), err.getvalue()


def test_monitor_with_a_fitted_detector_file(tmp_path):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    h = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s, reference_seed=40 + s),
                             tmp_path / f"h{s}.parquet")) for s in (1, 2)]
    leak = str(write_recording(simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=3,
                                            reference_seed=43), tmp_path / "leak.parquet"))
    det = tmp_path / "det.joblib"
    r = CliRunner().invoke(cli, ["fit", "--healthy", h[0], "--healthy", h[1], "-m", "ccf-p1p2",
                                 "--false-alarm-rate", "100",
                                 "-o", str(det)])
    assert r.exit_code == 0, r.output
    # the CUSUM restarts at each healthy segment: no caveat on the rate (the flow balance has)
    assert "the rate holds for a recording's first" not in r.output
    r = CliRunner().invoke(cli, ["monitor", "-i", leak, "--detector", str(det)])
    assert r.exit_code == 0, r.output
    alarm = [ln for ln in r.output.splitlines() if ln.startswith("ALARM")]
    assert alarm and float(alarm[0].split("t=")[1].split()[0]) >= 15.0
    assert "1 alarm raising(s) in 1 episode(s)" in r.output

    # a whole-recording detector is not streamed: it judges consecutive segments (until
    # 2026-11-28 refused: "cannot run window by window"; tests/stream/test_monitor_segments.py)
    comb = tmp_path / "comb.joblib"
    assert CliRunner().invoke(cli, ["fit", "--healthy", h[0], "-m", "combined",
                                    "--false-alarm-rate", "150", "-o",
                                    str(comb)]).exit_code == 0
    r = CliRunner().invoke(cli, ["monitor", "-i", leak, "--detector", str(comb),
                                 "--segment", "10"])
    assert r.exit_code == 0, r.output
    assert "segment(s) of up to 10 s judged by combined" in r.output


def test_monitor_follow_checks_the_time_axis_like_file_mode(tmp_path):
    path = tmp_path / "live.csv"
    times = [k / 1000 for k in range(100)] + [0.2]  # a 101 ms gap after 64+ good lines
    path.write_text("time,p1\n" + "".join(f"{t},{np.sin(i)}\n" for i, t in enumerate(times)))
    r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "--follow", "--idle-timeout", "0.2",
                                 "-c", "p1", "-w", "20", "-q"])
    assert r.exit_code != 0
    assert f"{path}: line 102: time 0.2 s after 0.099 s is a gap" in str(r.exception)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_monitor_file_checks_the_whole_time_column_not_only_its_head(tmp_path, suffix):
    """A gap or jitter after the rows the rate is taken from (4096) is refused, naming the row,
    as leakdiag analyze refuses it; before, the file was judged as if uniformly sampled."""
    rng = np.random.default_rng(2)
    t = np.arange(12_000) / 1000.0
    df = pd.DataFrame({"time": t, "p1": rng.normal(size=t.size)})
    gap, jit = df.copy(), df.copy()
    gap.loc[7000:, "time"] += 0.5
    jit.loc[9000, "time"] += 0.0004
    for frame, row, what in [(gap, 7000, "is a gap"), (jit, 9000, "is jitter")]:
        path = tmp_path / f"rec{suffix}"
        frame.to_csv(path, index=False) if suffix == ".csv" else frame.to_parquet(path)
        for chunk in ("65536", "1000"):  # the bad row inside and at the edge of a chunk
            r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1", "-q",
                                         "--chunk", chunk])
            assert r.exit_code != 0, (what, chunk)
            assert f"{path}: row {row}: time" in str(r.exception) and what in str(r.exception)
        assert "not uniformly sampled" in str(CliRunner().invoke(
            cli, ["analyze", str(path), "-c", "p1", "--onset", "6"]).exception)


def test_monitor_refuses_options_it_would_ignore(run_file, tmp_path):
    """Options that do nothing in the run asked for are refused, never silently ignored."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    path, _ = run_file
    cases = [
        (["-c", "p1", "--lag-ratio", "83:3"], "--lag-ratio applies to --method metric-length only"),
        (["-m", "metric-length", "-c", "p1", "--lag", "3"], "--lag applies to autocorrelation"),
        (["-c", "p1", "--idle-timeout", "2"], "--idle-timeout applies to --follow only"),
        (["-c", "p1", "--batch-lines", "10"], "--batch-lines applies to stdin (--input -) and "
                                              "--follow only"),
        (["-c", "p1", "--chunk", "0"], "Invalid value for '--chunk': 0 is not in the range x>=1"),
        (["-c", "p1", "--follow", "--idle-timeout", "0.1", "--replay", "10x"],
         "--replay paces a file; stdin and --follow run as the data arrives"),
        (["-c", "p1", "--batch-lines", "0"], "'--batch-lines': 0 is not in the range x>=1"),
    ]
    for args, needle in cases:
        r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-q", *args])
        assert r.exit_code == 2 and needle in r.output, (args, r.output)
    h = [str(write_recording(simulate_vca(duration=12.0, leak_lpm=None, seed=s,
                                          reference_seed=50 + s), tmp_path / f"h{s}.parquet"))
         for s in (1, 2, 3)]
    det = tmp_path / "det.joblib"
    assert CliRunner().invoke(cli, ["fit", "--healthy", h[0], "--healthy", h[1], "-m", "acf-p1",
                                    "--false-alarm-rate", "200", "-o", str(det)]).exit_code == 0
    r = CliRunner().invoke(cli, ["monitor", "-i", h[0], "--detector", str(det), "-w", "500"])
    assert r.exit_code == 2
    assert "--window: the detector file fixes its feature (autocorrelation p1 1 N=200 5%)" \
        in r.output
    # the detector's own values are harmless
    r = CliRunner().invoke(cli, ["monitor", "-i", h[2], "--detector", str(det), "-c", "p1",
                                 "-w", "200", "-q"])
    assert r.exit_code == 0, r.output


def test_monitor_warns_when_a_time_column_reads_as_a_low_rate(tmp_path):
    """A time column in milliseconds read as seconds (1 Hz) is warned about, as in analyze."""
    path = tmp_path / "ms.csv"
    rows = "".join(f"{k},{np.sin(k)}\n" for k in range(3000))  # time in ms
    path.write_text("time,p1\n" + rows)
    with pytest.warns(UserWarning, match=r"ms.csv: sample rate 1 Hz from the time column is low"
                                         r".*give --time-unit ms"):
        r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1", "-q"])
    assert r.exit_code == 0
    r = CliRunner().invoke(cli, ["monitor", "-i", str(path), "-c", "p1", "--time-unit", "ms"])
    assert r.exit_code == 0 and "3000 samples at 1000 Hz" in r.output


def test_monitor_accepts_the_detectors_own_method(tmp_path):
    """--method naming the detector's own feature (or an alias of it) is harmless, like its
    other settings given again; before, a ccf detector (N=100) was refused against a spec
    built from the option defaults ("... N=200 5%", a window the user did not give). Another
    method is refused as before."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    h = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s,
                                          reference_seed=40 + s), tmp_path / f"h{s}.parquet"))
         for s in (1, 2)]
    run = str(write_recording(simulate_vca(duration=10.0, leak_lpm=None, seed=3,
                                           reference_seed=43), tmp_path / "run.parquet"))
    det = tmp_path / "ccf.joblib"
    r = CliRunner().invoke(cli, ["fit", "--healthy", h[0], "--healthy", h[1], "-m", "ccf-p1p2",
                                 "--false-alarm-rate", "100", "-o", str(det)])
    assert r.exit_code == 0, r.output
    ref = tmp_path / "ref.jsonl"
    r = CliRunner().invoke(cli, ["monitor", run, "--detector", str(det), "-q", "--events",
                                 str(ref)])
    assert r.exit_code == 0, r.output
    label = "cross-correlation p1,p2 1 N=100 5%"
    for method in ("cross-correlation", "ccf"):
        ev = tmp_path / f"{method}.jsonl"
        r = CliRunner().invoke(cli, ["monitor", run, "--detector", str(det), "--method", method,
                                     "--events", str(ev)])
        assert r.exit_code == 0, r.output
        assert f"windows ({label})" in r.output
        assert ev.read_text() == ref.read_text()
    r = CliRunner().invoke(cli, ["monitor", run, "--detector", str(det), "--method",
                                 "metric-length", "-c", "p1,p2", "-q"])
    assert r.exit_code != 0
    assert f"detector feature '{label}' differs from the monitored 'metric-length p1,p2 83:3 " \
           "N=200 5%'" in str(r.exception)


@pytest.mark.parametrize("where,value,needle", [
    (1, 1 / 1101, "not uniformly sampled: interval before row 1"),  # the rate was 1101 Hz
    # a time far ahead with the next one after it: not increasing at the next, as detect
    # names it (until 2026-11-28 "line 152: time 0.4 s after 0.149 s is a gap")
    (150, 0.4, "<stdin>: column 'time' is not strictly increasing at line 153 (time 0.151 s "
               "after 0.4 s)"),
    (150, 0.1503, "<stdin>: line 152: time 0.1503 s after 0.149 s is jitter"),
])
def test_monitor_stdin_checks_the_time_axis_like_file_mode(where, value, needle):
    t = [k / 1000 for k in range(300)]
    t[where] = value
    lines = ["time,p1"] + [f"{a!r},{np.sin(k)}" for k, a in enumerate(t)]
    r = CliRunner().invoke(cli, ["monitor", "-i", "-", "-c", "p1", "-w", "50", "-q"],
                           input="\n".join(lines) + "\n")
    assert r.exit_code != 0 and needle in str(r.exception), str(r.exception)


def test_monitor_says_when_a_stuck_sensor_blinds_the_detector(tmp_path):
    """A stuck p1 makes acf windows undefined; the CUSUM holds across them, so '0 alarm(s)'
    said nothing there (an audit: 325 degenerate windows, state OK). The monitor says BLIND
    when the run passes the detector's healthy limit, and warns at the end."""
    import leakdiag as ld

    d = tmp_path
    healthy = []
    for s in range(3):
        healthy += ["--healthy", str(ld.io.write_recording(
            ld.sim.simulate_vca(duration=30, leak_lpm=0.0, seed=s), d / f"h{s}.parquet"))]
    r = CliRunner().invoke(cli, ["fit", *healthy, "-m", "acf-p1", "--false-alarm-rate", "60",
                                 "--no-progress", "-o", str(d / "acf.joblib")])
    assert r.exit_code == 0, r.output
    rec = ld.sim.simulate_vca(duration=30, leak_lpm=0.0, seed=9)
    p1 = rec["p1"].copy()
    p1[15000:] = p1[15000]  # stuck from 15 s
    stuck = Recording({**rec.channels, "p1": p1}, rec.sample_rate, meta=dict(rec.meta))
    path = ld.io.write_recording(stuck, d / "stuck.parquet")
    r = CliRunner().invoke(cli, ["monitor", str(path), "--detector", str(d / "acf.joblib"),
                                 "--replay", "fast"])
    assert r.exit_code == 0, r.output
    blind = [x for x in r.output.splitlines() if x.startswith("BLIND")]
    assert len(blind) == 1 and "undefined for 10.1 s, more than the 10 s allowed" in blind[0]
    t = float(blind[0].split("t=")[1].split(" s")[0])
    assert 25.0 < t < 26.5  # 10 s of undefined windows after the freeze at 15 s
    assert "leakdiag: warning: " in r.output
    text = " ".join(r.output.split())
    assert "was undefined in 78 consecutive windows ending 15.209 to 29.839 s (14.8 s;" in text
    assert "the detector's healthy recordings had undefined spans of at most 0 s (limit 10 s), " \
           "so no alarm there rules nothing out" in text
    # stuck from 0 to 12 s, 7 s of it after the 5-s burn-in: under the 10-s limit (the
    # burn-in's windows are not judged, so they were counted by mistake before a review)
    p1 = rec["p1"].copy()
    p1[:12000] = p1[0]
    early = ld.io.write_recording(Recording({**rec.channels, "p1": p1}, rec.sample_rate,
                                            meta=dict(rec.meta)), d / "early.parquet")
    r = CliRunner().invoke(cli, ["monitor", str(early), "--detector", str(d / "acf.joblib"),
                                 "--replay", "fast"])
    assert r.exit_code == 0 and "BLIND" not in r.output and "warning" not in r.output
    # the same run with its sensor working: no BLIND, no warning
    ok = ld.io.write_recording(rec, d / "ok.parquet")
    r = CliRunner().invoke(cli, ["monitor", str(ok), "--detector", str(d / "acf.joblib"),
                                 "--replay", "fast"])
    assert r.exit_code == 0 and "BLIND" not in r.output and "warning" not in r.output


@pytest.mark.parametrize("frozen_before", [False, True])
def test_monitor_keeps_what_it_loaded_out_of_the_collector_while_it_runs(run_file, monkeypatch,
                                                                          frozen_before):
    """The loop runs with the objects loaded before it frozen (gc.freeze) and gives them back
    when it ends, with or without --store/--dashboard; someone else's freeze is left alone."""
    import gc

    from leakdiag.stream import monitor as stream_monitor

    path, _ = run_file
    seen = []
    push = stream_monitor.Monitor.push

    def spy(self, chunk):
        seen.append(gc.get_freeze_count())
        return push(self, chunk)

    monkeypatch.setattr(stream_monitor.Monitor, "push", spy)
    if frozen_before:
        gc.freeze()
    try:
        r = CliRunner().invoke(cli, ["monitor", str(path), "--chunk", "4000"])
        assert r.exit_code == 0, r.output
        assert len(seen) == 3 and min(seen) > 0
        if frozen_before:  # the caller's freeze is the caller's: still there afterwards
            assert gc.get_freeze_count() > 0
        else:  # unfrozen by the monitor, which froze
            assert gc.get_freeze_count() == 0
    finally:
        if frozen_before:
            gc.unfreeze()


def test_an_existing_events_file_is_replaced_with_a_note_or_appended_to(tmp_path):
    # a workflow audit (2026-11-30): a monitor restarted with the same --events file wiped the
    # earlier run's alarm lines without a word
    import subprocess
    import sys

    import leakdiag as ld
    from leakdiag.io import write_recording

    rec = ld.sim.simulate_vca(duration=8, leak_lpm=0.0, seed=3)
    path = write_recording(rec, tmp_path / "r.parquet")
    events = tmp_path / "ev.jsonl"

    def run(*extra):
        return subprocess.run([sys.executable, "-m", "leakdiag.cli.main", "monitor", str(path),
                               "-c", "p1", "--events", str(events), "-q", *extra],
                              capture_output=True, text=True, check=True)

    assert "note" not in run().stderr  # a new file: nothing to say
    n = len(events.read_text().splitlines())
    assert n > 10
    assert run("--append-events").stderr == ""
    assert len(events.read_text().splitlines()) == 2 * n
    size = events.stat().st_size
    assert run().stderr == (f"leakdiag: note: {events} held {size} bytes of events: "
                            "replaced (--append-events keeps them)\n")
    assert len(events.read_text().splitlines()) == n
