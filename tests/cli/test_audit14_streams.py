"""One recording, one answer from ``detect`` (whole-file reader, :mod:`leakdiag.io`) and
``monitor`` / ``batch`` (chunked readers, :mod:`leakdiag.stream`): findings of the streams
audit of 2026-11-27 (audit 14)."""

import re

import h5py
import pytest

from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca
from leakdiag.stream.files import open_recording


@pytest.fixture(scope="module")
def case(tmp_path_factory, run_cli):
    """A detector fitted with ``leakdiag fit`` on two healthy 20-s VCA runs (acf-p1, 1 kHz)
    and a 30-s VCA recording leaking from 15 s."""
    d = tmp_path_factory.mktemp("audit14")
    h = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s),
                             d / f"h{s}.parquet")) for s in (1, 2)]
    code, out, err = run_cli(["fit", "--healthy", h[0], "--healthy", h[1], "-m", "acf-p1",
                              "--false-alarm-rate", "100", "--no-progress", "-o",
                              str(d / "det.joblib")])
    assert code == 0, err
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=3)
    return {"dir": d, "det": str(d / "det.joblib"), "leak": leak,
            "parquet": str(write_recording(leak, d / "leak.parquet"))}


def _detect_alarm(run_cli, path, det, *extra):
    """detect's first alarm time (s) of its table, or None."""
    code, out, err = run_cli(["detect", str(path), "--detector", det, *extra])
    assert code == 0, err
    row = next(ln for ln in out.splitlines() if ln.startswith("acf-p1 "))
    alarm = row.split()[3]
    return None if alarm == "-" else float(alarm)


def _monitor(run_cli, path, det, *extra, stdin=None):
    code, out, err = run_cli(["monitor", str(path), "--detector", det, *extra], stdin=stdin)
    return code, out, err


def _monitor_alarm(run_cli, path, det, *extra, stdin=None):
    """monitor's first ALARM time (s), or None; and its summary line."""
    code, out, err = _monitor(run_cli, path, det, *extra, stdin=stdin)
    assert code == 0, err
    m = re.search(r"^ALARM\s+t=(\S+) s", out, re.M)
    summary = next(ln for ln in out.splitlines() if " samples at " in ln)
    return (None if m is None else float(m.group(1))), summary


# --- finding 2: another program's HDF5 attributes are not a header --------------------------

def _foreign_h5(path, rec, t0=0.0, attrs=None, group=False, with_time=True):
    """An HDF5 file another program wrote: no ``format`` attribute."""
    with h5py.File(path, "w") as f:
        if with_time:
            f["time"] = rec.time + t0
        for c in ("p1", "p2"):
            f[f"channels/{c}" if group else c] = rec[c]
        for k, v in (attrs or {}).items():
            f.attrs[k] = v
    return str(path)


def test_foreign_hdf5_start_and_rate_come_from_its_time_dataset(case, run_cli, tmp_path):
    """Finding 2: root attributes ``start_time`` / ``sample_rate`` of a file leakdiag did not
    write were used by monitor and batch (alarm 100 s early), ignored by detect."""
    rec, det = case["leak"], case["det"]
    ref = _detect_alarm(run_cli, case["parquet"], det)
    assert ref is not None and 15.0 < ref < 30.0
    # time from 100 s, a start_time attribute 0
    f = _foreign_h5(tmp_path / "daq.h5", rec, t0=100.0, attrs={"start_time": 0.0})
    assert _detect_alarm(run_cli, f, det) == pytest.approx(ref + 100.0, abs=1e-9)
    alarm, summary = _monitor_alarm(run_cli, f, det)
    assert alarm == pytest.approx(ref + 100.0, abs=1e-9)
    # and a sample_rate attribute in kHz (1): monitor refused the file, batch called it jitter
    f = _foreign_h5(tmp_path / "daq.h5", rec, t0=100.0,
                    attrs={"start_time": 0.0, "sample_rate": 1.0})
    alarm, summary = _monitor_alarm(run_cli, f, det)
    assert alarm == pytest.approx(ref + 100.0, abs=1e-9) and " at 1000 Hz," in summary
    src, _ = open_recording(f, ["p1"])  # batch's reader
    assert (src.sample_rate, src.start_time, src.meta) == (1000.0, 100.0, {})


def test_foreign_hdf5_without_time_needs_a_given_rate_in_both(case, run_cli, tmp_path):
    """Finding 2: no ``time`` dataset, a ``sample_rate`` attribute: detect refused, monitor
    and batch judged at the attribute's rate."""
    f = _foreign_h5(tmp_path / "notime.h5", case["leak"], attrs={"sample_rate": 1000.0},
                    with_time=False)
    for cmd in ("detect", "monitor"):
        code, out, err = run_cli([cmd, f, "--detector", case["det"]])
        assert code == 2 and "no sample rate" in err, (cmd, err)
    ref = _detect_alarm(run_cli, case["parquet"], case["det"])
    assert _detect_alarm(run_cli, f, case["det"], "--sample-rate", "1000") == ref
    assert _monitor_alarm(run_cli, f, case["det"], "--sample-rate", "1000")[0] == ref


def test_foreign_hdf5_channels_group_is_refused_by_both(case, run_cli, tmp_path):
    """Finding 2: a ``/channels`` group without the ``format`` attribute was read by monitor
    and batch, refused by detect (io/hdf5.py's rule: the group is leakdiag's layout only)."""
    f = _foreign_h5(tmp_path / "group.h5", case["leak"], group=True)
    code, out, err = run_cli(["detect", f, "--detector", case["det"]])
    assert code == 2 and "available columns: ['channels/p1', 'channels/p2', 'time']" in err
    code, out, err = _monitor(run_cli, f, case["det"])
    assert code == 2, err
    assert (f"{f}: missing channel(s) ['p1']; available: ['channels/p1', 'channels/p2']; the "
            "datasets of /channels are the channels only in a file leakdiag wrote") in err
    with pytest.raises(Exception, match=r"missing channel\(s\) \['p1'\]"):
        open_recording(f, ["p1"])



def test_foreign_hdf5_default_channels_stay_the_root_datasets(tmp_path):
    """Finding 2's rule names datasets in groups (``cal/v``) for the messages; without a
    channel list the chunked reader still reads the root's 1-D datasets only."""
    from leakdiag.stream.files import open_chunks

    path = tmp_path / "a.h5"
    with h5py.File(path, "w") as f:
        f["time"], f["p1"] = [k / 100 for k in range(10)], [float(k) for k in range(10)]
        f["cal/v"] = [1.0, 2.0, 3.0]
    src = open_chunks(path)
    assert (src.channels, src.sample_rate, [c["p1"].tolist() for c in src]) == (
        ["p1"], 100.0, [[float(k) for k in range(10)]])
    with pytest.raises(Exception, match=r"missing channel\(s\) \['x'\]; available: "
                                        r"\['cal/v', 'p1'\]$"):
        open_chunks(path, ["x"])

# --- finding 3: a given sample rate is a cross-check of the file's, in every reader ---------

def test_a_given_rate_within_tolerance_is_checked_not_used(case, run_cli, tmp_path):
    """Finding 3: ``--sample-rate 1000.9`` (0.09 % off) on a 1-kHz file: monitor stamped its
    windows at 1000.9 Hz (file and stdin), detect ignored it (time column) or refused it
    (header, compared exactly). Now the file's rate is used by all and the alarm is one."""
    det = case["det"]
    csv = str(write_recording(case["leak"], tmp_path / "leak.csv"))
    ref = _detect_alarm(run_cli, case["parquet"], det)
    assert ref is not None
    for path in (csv, case["parquet"]):
        assert _detect_alarm(run_cli, path, det, "--sample-rate", "1000.9") == ref, path
        alarm, summary = _monitor_alarm(run_cli, path, det, "--sample-rate", "1000.9")
        assert alarm == ref and " at 1000 Hz," in summary, (path, summary)
    with open(csv) as fh:
        alarm, summary = _monitor_alarm(run_cli, "-", det, "--sample-rate", "1000.9",
                                        stdin=fh.read())
    assert alarm == ref and " at 1000 Hz," in summary
    src, _ = open_recording(csv, ["p1"], sample_rate=1000.9)  # batch's reader
    assert src.sample_rate == 1000.0


@pytest.mark.parametrize("suffix, what", [(".csv", "time column 'time'"),
                                          (".parquet", "header")])
def test_a_given_rate_off_by_more_is_refused_in_one_wording(case, run_cli, tmp_path, suffix,
                                                             what):
    """Finding 3: 1002 Hz (0.2 %) given for a 1-kHz file is refused by detect and monitor with
    the same words."""
    path = str(write_recording(case["leak"], tmp_path / f"leak{suffix}"))
    words = (f"{path}: a sample rate of 1002 Hz was given (--sample-rate, or sample_rate_hz in "
             f"a column map), but the file's {what} says 1000 Hz (more than 0.1 % apart); leave "
             "the sample rate out (the file's own is used) or fix the file")
    for cmd in ("detect", "monitor"):
        code, out, err = run_cli([cmd, path, "--detector", case["det"], "--sample-rate",
                                  "1002"])
        assert code == 2 and words in " ".join(err.split()), (cmd, err)


# --- finding 4: a monitor run too short to judge says so and exits 2 -----------------------

def test_monitor_refuses_a_run_too_short_to_judge_in_the_store_s_words(case, run_cli, tmp_path):
    """Finding 4: 5.3 s against a 5-s burn-in: detect refused ("too short to judge", exit 2),
    the store recorded the monitor run 'unjudged', and the monitor's console said only
    "27 windows ..., 0 alarm raising(s)" with exit 0."""
    from leakdiag.io import Recording
    from leakdiag.store import EventStore

    rec = case["leak"]
    short = str(write_recording(Recording({c: v[:5300] for c, v in rec.channels.items()},
                                          rec.sample_rate, 0.0, rec.units, rec.meta),
                                tmp_path / "short.parquet"))
    code, out, err = run_cli(["detect", short, "--detector", case["det"]])
    assert code == 2 and "too short to judge: 5.3 s leaves no complete window" in err
    db = str(tmp_path / "ev.db")
    code, out, err = run_cli(["monitor", short, "--detector", case["det"], "--store", db,
                              "--actuator", "rigS"])
    reason = (f"{short}: no window was scored: all 27 windows lie in the detector's burn-in "
              "(the stream is shorter than the burn-in plus one window), nothing was judged")
    assert code == 2, (out, err)
    assert f"{short}: 5300 samples at 1000 Hz, 27 windows" in out  # the summary, then why
    assert f"leakdiag: error: {reason}" in err
    st = EventStore(db, create=False)
    try:
        row, runs = st.fleet().set_index("name").loc["rigS"].to_dict(), st.runs_of("rigS")
    finally:
        st.close()
    assert runs["status"].tolist() == ["unjudged"] and row["error"].endswith(reason)


# --- finding 6: a Parquet timestamp column is refused by every reader, in one wording --------

def test_a_parquet_timestamp_time_column_is_refused_alike(case, run_cli, tmp_path):
    """Finding 6: monitor and batch read a ``timestamp[ns]`` time column as nanoseconds taken
    as seconds (1e-06 Hz; batch wrote an "ok" row), detect said it "holds text"."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    from leakdiag.io import read_recording
    from leakdiag.io.recording import RecordingError

    rec = case["leak"]
    ts = pd.Timestamp("2026-11-27 10:00") + pd.to_timedelta(rec.time, unit="s")
    path = str(tmp_path / "ts.parquet")
    pq.write_table(pa.table({"time": ts, "p1": rec["p1"], "p2": rec["p2"]}), path)
    assert pq.read_schema(path).field("time").type == pa.timestamp("ns")
    words = (f"{path}: column 'time' holds timestamps (dates, times or durations), not "
             "numbers: leakdiag reads time as seconds (float64); convert the column, e.g. with "
             "pandas df['time'] = (df['time'] - df['time'].iloc[0]).dt.total_seconds() for "
             "seconds from the first row")
    for args in (["detect", path, "--detector", case["det"]],
                 ["monitor", path, "--detector", case["det"]],
                 ["monitor", path, "-c", "p1"],
                 ["analyze", path, "--method", "autocorrelation", "--channels", "p1"]):
        code, out, err = run_cli(args)
        assert code == 2 and f"error: {words}\n" in err, (args, err)
    for read in (lambda: open_recording(path, ["p1"]), lambda: read_recording(path)):
        with pytest.raises(RecordingError) as exc:  # batch's reader and detect's
            read()
        assert str(exc.value) == words


# --- finding 9: a time not increasing is named as detect names it ---------------------------

@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
@pytest.mark.parametrize("fault", ["swap", "back"])
def test_time_not_increasing_is_named_as_detect_names_it(case, run_cli, tmp_path, suffix,
                                                         fault):
    """Finding 9: two swapped rows were "a gap" at the row before in monitor and batch
    (detect: not strictly increasing at the second row), and a step back was "is time goes
    backwards"."""
    import pandas as pd

    rec = case["leak"]
    t = rec.time.copy()
    if fault == "swap":
        t[[10000, 10001]] = t[[10001, 10000]]
        row = 10001
    else:
        t[20000:] -= 0.0015  # row 20000 half an interval before row 19999
        row = 20000
    frame = pd.DataFrame({"time": t, "p1": rec["p1"], "p2": rec["p2"]})
    path = str(tmp_path / f"{fault}{suffix}")
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    want = (f"{path}: column 'time' is not strictly increasing at row {row} "
            f"(t[{row - 1}]={float(t[row - 1])!r}, t[{row}]={float(t[row])!r})")
    for args in (["detect", path, "--detector", case["det"]],
                 ["monitor", path, "--detector", case["det"], "--chunk", "4000"]):
        code, out, err = run_cli(args)
        assert code == 2 and f"error: {want}\n" in err, (args, err)
    src, _ = open_recording(path, ["p1"], chunk_samples=4000)  # batch's reader
    with pytest.raises(Exception) as exc:
        list(src)
    assert str(exc.value) == want
