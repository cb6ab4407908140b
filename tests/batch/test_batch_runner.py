"""Batch: config parsing and sweeps, run_case rows against references, error rows, resumability,
a killed run keeps finished results, the CLI."""

import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from leakdiag.stream.detector_file import DetectorFileWarning
from click.testing import CliRunner

from _batch_helpers import BurnInScorer, SlowScorer, make_recording
from leakdiag.batch import config_from_dict, load_config, read_results, run_batch, run_case
from leakdiag.batch.store import content_hash, result_key
from leakdiag.cli.main import cli
from leakdiag.detect.measure import rms_change
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import window_starts, window_times
from leakdiag.io.parquet import write_parquet

JOB = {"job": {"rms_chunk": 10},
       "analysis": [{"method": "autocorrelation", "channels": ["p1"], "lag": [1, 3],
                     "window": 200, "overlap": 5},
                    {"method": "metric-length", "channels": "p1", "lag_ratio": "83:3",
                     "window": 500, "overlap": 5}]}


def ac(x, lag, window, overlap):
    out = []
    for s in window_starts(len(x), window, overlap):
        d = x[s:s + window] - x[s:s + window].mean()
        out.append(np.sum(d[:-lag] * d[lag:]) / np.sum(d * d))
    return np.array(out)


@pytest.fixture()
def recordings(tmp_path):
    paths = []
    for i in range(3):
        sub = tmp_path / "recordings" / f"rig{i % 2}"
        sub.mkdir(parents=True, exist_ok=True)
        p = sub / f"run{i}.parquet"
        write_parquet(make_recording(i), p)
        paths.append(p)
    (tmp_path / "recordings" / "rig0" / "broken.parquet").write_bytes(b"PAR1 garbage")
    return tmp_path, paths


def test_config_sweep_and_digest(tmp_path):
    cfg = config_from_dict(JOB)
    assert [s.label for s in cfg.analyses] == [
        "autocorrelation p1 1 N=200 5%", "autocorrelation p1 3 N=200 5%",
        "metric-length p1 83:3 N=500 5%"]
    assert cfg.digest == config_from_dict(JOB).digest
    assert cfg.digest != config_from_dict({**JOB, "job": {"rms_chunk": 5}}).digest
    toml = tmp_path / "job.toml"
    toml.write_text('[[analysis]]\nmethod = "cross-correlation"\nchannels = ["u", "x"]\n'
                    'lag = 1\nwindow = [100, 200]\noverlap = [5, 10]\n')
    assert len(load_config(toml).analyses) == 4


@pytest.mark.parametrize("d, msg", [
    ({}, "has no \\[\\[analysis\\]\\] and no \\[\\[detector\\]\\]"),
    ({"analysis": [{"method": "moments"}]}, "method='moments' is not one of"),
    ({"analysis": [{"method": "autocorrelation", "lags": 2}]}, "unknown key\\(s\\) \\['lags'\\]"),
    ({"analysis": [{"method": "autocorrelation", "lag": [1, 300]}]},
     "#1 \\(lag = 300\\): lag=300 must be in \\[1, 200\\)"),
    ({"analysis": [{"method": "autocorr"}]},
     "^\\[\\[analysis\\]\\] #1: unknown method 'autocorr'; known: .* \\(aliases: acf, ccf"),
    ({"detector": [{"path": "/no/such.pkl"}]}, "\\[\\[detector\\]\\] #1: cannot read"),
    ({"jobs": {}}, "unknown table\\(s\\) \\['jobs'\\]"),
    # a CLI audit, 2026-11-29: these were taken without a word
    ({"detector": [{"path": "/no/such.pkl", "nmae": "x", "false_alarm_rate": 0.001}]},
     "^\\[\\[detector\\]\\] #1: unknown key\\(s\\) \\['false_alarm_rate', 'nmae'\\]; "
     "allowed: \\['name', 'path'\\]"),
    *[({"job": {"onset_s": v}, "analysis": [{"method": "autocorrelation"}]},
       f"^\\[job\\] onset_s = {w}: must be a finite number of seconds >= 0")
      for v, w in ((float("nan"), "nan"), (float("inf"), "inf"), (-1.0, "-1.0"),
                   (True, "True"), ("30", "'30'"))],
])
def test_config_errors(d, msg):
    with pytest.raises(ValueError, match=msg):
        config_from_dict(d)


def test_config_onset_is_a_float():
    cfg = config_from_dict({"job": {"onset_s": 30}, "analysis": [{"method": "autocorrelation"}]})
    assert cfg.onset_s == 30.0 and isinstance(cfg.onset_s, float)


def test_load_config_names_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[analysis]\n")
    with pytest.raises(ValueError, match="bad.toml: invalid TOML"):
        load_config(bad)


def test_run_case_rows_equal_references(recordings):
    _, paths = recordings
    cfg = config_from_dict(JOB)
    rows = run_case(str(paths[1]), cfg)
    assert [r["status"] for r in rows] == ["ok"] * 3
    rec = make_recording(1)
    for r, lag in zip(rows[:2], (1, 3)):
        ref = ac(rec["p1"], lag, 200, 5)
        assert r["lag"] == lag and r["n_windows"] == len(ref) == 63
        assert r["value_mean"] == pytest.approx(ref.mean(), rel=1e-9)
        assert r["value_min"] == pytest.approx(ref.min(), rel=1e-9)
        t = window_times(window_starts(12000, 200, 5), 200, 1000.0)
        m = rms_change(FeatureSeries(t, ref, "ac", window=200, sample_rate=1000.0), 6.0, 10)
        assert r["pct_change_signed"] == pytest.approx(m.pct_change_signed, rel=1e-9)
        assert r["onset_s"] == 6.0
    # planted truth: the correlation falls after the onset
    assert rows[0]["pct_change_signed"] < -20
    assert rows[2]["lag_ratio"] == "83:3" and rows[2]["n_samples"] == 12000


def test_bad_file_becomes_error_row(recordings):
    tmp, _ = recordings
    rows = run_case(str(tmp / "recordings" / "rig0" / "broken.parquet"), config_from_dict(JOB))
    assert len(rows) == 1 and rows[0]["status"] == "error"
    assert "unreadable as Parquet" in rows[0]["error"]
    rows = run_case(str(tmp / "missing.parquet"), config_from_dict(JOB))
    assert "FileNotFoundError" in rows[0]["error"]


def test_a_case_that_raises_outside_run_case_becomes_its_error_row(recordings, monkeypatch):
    """The executor's on_error (a worker that dies on Dask): that recording's error row, the
    others finish, and the run reports one error."""
    import leakdiag.batch.runner as runner

    tmp, paths = recordings
    real = runner.run_case

    def dies_on_run1(path, config):
        if path.endswith("run1.parquet"):
            raise RuntimeError("worker lost")
        return real(path, config)

    monkeypatch.setattr(runner, "run_case", dies_on_run1)
    cfg = config_from_dict(JOB)
    s = run_batch([str(p) for p in paths], cfg, tmp / "out", progress=False)
    assert (s.n_run, s.n_errors) == (3, 1)
    res = read_results(tmp / "out")
    err = res[res.status == "error"]
    assert list(err.recording) == ["run1.parquet"]
    assert err.error.iloc[0] == "RuntimeError: worker lost"
    assert err.job_digest.iloc[0] == cfg.digest
    ok = res[res.status == "ok"]  # three analyses each: lags 1 and 3, the metric length
    assert ok.recording.value_counts().to_dict() == {"run0.parquet": 3, "run2.parquet": 3}


def test_detector_rows(recordings, tmp_path):
    _, paths = recordings
    det = tmp_path / "det.pkl"
    det.write_bytes(pickle.dumps(SlowScorer()))
    cfg = config_from_dict({"detector": [{"name": "slow", "path": str(det)}]})
    (row,) = run_case(str(paths[0]), cfg)
    ref = ac(make_recording(0)["p1"], 1, 200, 5)
    assert row["kind"] == "detector" and row["name"] == "slow"
    assert row["score_max"] == pytest.approx((1 - ref).max(), rel=1e-9)
    first = int(np.argmax(1 - ref >= 0.5))
    assert row["alarm"] and row["alarm_time_s"] == pytest.approx((first * 190 + 199) / 1000.0)


def test_a_detector_that_scored_no_window_is_not_judged(tmp_path):
    """A recording shorter than the detector's burn-in: alarm None (not False) and a note."""
    from leakdiag.io.recording import Recording

    det = tmp_path / "det.pkl"
    det.write_bytes(pickle.dumps(BurnInScorer()))
    rec = make_recording(0, n=4500, onset_s=1.0)
    path = tmp_path / "short.parquet"
    write_parquet(Recording(rec.channels, rec.sample_rate, meta={}), path)
    cfg = config_from_dict({"detector": [{"name": "b", "path": str(det)}]})
    (row,) = run_case(str(path), cfg)
    assert row["status"] == "ok" and row["alarm"] is None and row["score_max"] is None
    assert row["error"].startswith("detector not judged: no window of 23 was scored (the "
                                   "recording, 4.5 s, is too short for the 5-s burn-in")


def test_resume_skips_finished_and_recomputes_changed(recordings):
    tmp, paths = recordings
    cfg, out = config_from_dict(JOB), tmp / "results.parquet"
    pattern = str(tmp / "recordings" / "**" / "*.parquet")
    s1 = run_batch([pattern], cfg, out, progress=False)
    assert (s1.n_inputs, s1.n_run, s1.n_errors) == (4, 4, 1)
    broken = tmp / "recordings" / "rig0" / "broken.parquet"
    assert s1.paths == tuple(sorted(os.path.abspath(p) for p in [*paths, broken]))
    df = read_results(out)
    assert len(df) == 3 * 3 + 1 and set(df["status"]) == {"ok", "error"}
    assert pd.read_parquet(out).shape == df.shape  # a plain Parquet dataset
    s2 = run_batch([pattern], cfg, out, progress=False)
    assert (s2.n_skipped, s2.n_run) == (4, 0)
    # a leftover temporary file of a killed write is ignored; an edited recording is re-run
    (out / ".deadbeef.123.tmp").write_bytes(b"partial")
    write_parquet(make_recording(7), paths[0])
    os.utime(paths[0], ns=(time.time_ns(), time.time_ns() + 10**9))
    s3 = run_batch([pattern], cfg, out, progress=False, retry_errors=True)
    assert (s3.n_skipped, s3.n_run) == (2, 2)
    # issue 15: one current row set per recording: the edited file's rows replace its old ones
    new = read_results(out)
    assert len(new) == len(df)
    mine = new[new["path"] == os.path.abspath(paths[0])]
    assert len(mine) == 3 and mine["recording_sha256"].nunique() == 1
    assert mine["recording_sha256"].iloc[0] == content_hash(paths[0])
    assert (out / f"{result_key(paths[0], cfg.digest)}.parquet").exists()
    # touching a file without changing its content does not re-run it (content hash, not mtime)
    os.utime(paths[1], ns=(time.time_ns(), time.time_ns() + 2 * 10**9))
    s4 = run_batch([pattern], cfg, out, progress=False)
    assert (s4.n_skipped, s4.n_run) == (4, 0)



def test_killed_run_loses_no_finished_result(recordings, tmp_path):
    tmp, paths = recordings
    for i in range(3, 8):
        write_parquet(make_recording(i), tmp / "recordings" / f"extra{i}.parquet")
    det = tmp_path / "slow.pkl"
    det.write_bytes(pickle.dumps(SlowScorer(delay_s=0.25)))
    job = tmp_path / "job.toml"
    job.write_text(f'[[detector]]\nname = "slow"\npath = "{det}"\n')
    out = tmp_path / "res.parquet"
    args = [sys.executable, "-m", "leakdiag.cli.main", "batch",
            str(tmp / "recordings" / "**" / "*.parquet"), "--config", str(job), "--out", str(out),
            "--scheduler", "serial", "--no-progress"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).parent), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    while time.time() < deadline and len(list(out.glob("*.parquet"))) < 2:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    kept = sorted(out.glob("*.parquet"))
    assert 2 <= len(kept) < 9, "the run was not interrupted mid-way"
    assert len(read_results(out)) == len(kept)  # every kept file is complete and readable
    cfg = load_config(job)
    with pytest.warns(DetectorFileWarning, match="a bare pickled detector"):
        s = run_batch([str(tmp / "recordings" / "**" / "*.parquet")], cfg, out, progress=False)
    assert s.n_skipped == len(kept) and s.n_run == 9 - len(kept)
    df = read_results(out)
    assert len(df) == 9 and df["path"].is_unique


def test_cli_serial(recordings):
    tmp, _ = recordings
    job = tmp / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\nlag = 1\n'
                   'window = 200\noverlap = 5\n')
    out = tmp / "results.parquet"
    r = CliRunner().invoke(cli, ["batch", str(tmp / "recordings" / "**" / "*.parquet"),
                                 "--config", str(job), "--out", str(out), "--scheduler", "serial",
                                 "--no-progress"])
    assert r.exit_code == 1, r.output  # a bad recording: rows are written, the exit code says so
    assert ("4 recording(s): 4 run, 0 already done, 1 error(s) in this run; 4 current row(s)"
            in r.output)
    assert "broken.parquet: unreadable as Parquet" in r.output
    r = CliRunner().invoke(cli, ["batch", str(tmp / "nothing" / "*.parquet"), "--config", str(job),
                                 "--out", str(out), "--scheduler", "serial"])
    assert r.exit_code != 0 and "no recording matches" in r.output


def test_measure_note_when_no_chunk_before_onset(recordings):
    _, paths = recordings
    job = {"job": {"onset_s": 0.1}, "analysis": [{"method": "autocorrelation", "channels": ["p1"]}]}
    (row,) = run_case(str(paths[0]), config_from_dict(job))
    assert row["status"] == "ok" and row["onset_s"] == 0.1
    assert row["error"].startswith("Sec. 5.2 measure:") and "pct_change" not in row


# ------------------------------------------------------------------ issue 15
def _cli_batch(tmp, job, out, *extra):
    return CliRunner().invoke(cli, ["batch", str(tmp / "recordings" / "**" / "*.parquet"),
                                    "--config", str(job), "-o", str(out), "--scheduler", "serial",
                                    "--no-progress", *extra])


def test_repaired_file_with_retry_errors_replaces_its_error_row_and_exit_code_is_0(recordings):
    tmp, _ = recordings
    job = tmp / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    out = tmp / "res.parquet"
    assert _cli_batch(tmp, job, out).exit_code == 1  # broken.parquet is an error row
    write_parquet(make_recording(5), tmp / "recordings" / "rig0" / "broken.parquet")  # repaired
    r = _cli_batch(tmp, job, out, "--retry-errors")
    assert r.exit_code == 0, r.output
    df = read_results(out)
    assert len(df) == 4 and set(df["status"]) == {"ok"} and df["path"].is_unique
    assert "4 current row(s)" in r.output


def test_job_with_fitted_detector_file_and_column_map(tmp_path):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    h = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s,
                                          reference_seed=40 + s), tmp_path / f"h{s}.parquet"))
         for s in (1, 2)]
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=3, reference_seed=43)
    df = leak.to_pandas()[["time", "p1", "p2"]]
    df["P_A"], df["P_B"] = df.pop("p1") / 6894.757293168, df.pop("p2") / 6894.757293168  # psi
    df.to_csv(rec_dir / "leak.csv", index=False)
    (tmp_path / "map.toml").write_text('[channels]\np1 = {column = "P_A", unit = "psi"}\n'
                                       'p2 = {column = "P_B", unit = "psi"}\n')
    r = CliRunner().invoke(cli, ["fit", "--healthy", h[0], "--healthy", h[1], "-m", "ccf-p1p2",
                                 "--false-alarm-rate", "100",
                                 "-o", str(tmp_path / "det.joblib")])
    assert r.exit_code == 0, r.output
    job = tmp_path / "job.toml"
    job.write_text('[job]\ncolumn_map = "map.toml"\n[[detector]]\nname = "ccf"\n'
                   'path = "det.joblib"\n')
    r = CliRunner().invoke(cli, ["batch", str(rec_dir / "*.csv"), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert r.exit_code == 0, r.output
    (row,) = read_results(tmp_path / "res").to_dict("records")
    assert row["status"] == "ok" and row["alarm"] and row["alarm_time_s"] >= 15.0


def test_a_detector_that_disagrees_with_a_recording_gets_its_own_error_row(tmp_path):
    """An EHA recording in a fleet job with a VCA detector: the detector's row is an error that
    names both files and the systems; the analyses of that recording are still computed (the
    whole recording used to become one error row)."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_eha, simulate_vca

    h = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s),
                             tmp_path / f"h{s}.parquet")) for s in (1, 2)]
    r = CliRunner().invoke(cli, ["fit", "--healthy", h[0], "--healthy", h[1], "-m", "acf-p1",
                                 "--false-alarm-rate", "100", "--no-progress",
                                 "-o", str(tmp_path / "det.joblib")])
    assert r.exit_code == 0, r.output
    eha = str(write_recording(simulate_eha(duration=20.0, leak_lpm=None, seed=3),
                              tmp_path / "eha.parquet"))
    cfg = config_from_dict({"analysis": [{"method": "autocorrelation", "channels": ["p1"]}],
                            "detector": [{"name": "acf", "path": str(tmp_path / "det.joblib")}]})
    rows = {r["kind"]: r for r in run_case(eha, cfg)}
    assert rows["analysis"]["status"] == "ok" and rows["analysis"]["n_windows"] > 0
    det = rows["detector"]
    assert det["status"] == "error" and det["name"] == "acf"
    assert eha in det["error"] and "det.joblib" in det["error"]
    assert "'eha'" in det["error"] and "'vca'" in det["error"]
    ok = {r["kind"]: r for r in run_case(h[0], cfg)}  # a VCA run: both computed
    assert ok["detector"]["status"] == "ok" and ok["analysis"]["status"] == "ok"


def test_empty_and_text_csv_rows_name_file_channel_row(tmp_path):
    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    (rec_dir / "empty.csv").write_text("")
    rows = [f"{k / 1000},{np.sin(k)}" for k in range(3000)]
    rows[2500] = "2.5,abc"
    (rec_dir / "text.csv").write_text("time,p1\n" + "\n".join(rows) + "\n")
    cfg = config_from_dict({"job": {"chunk_samples": 1000},
                            "analysis": [{"method": "autocorrelation", "channels": ["p1"]}]})
    (e,) = run_case(str(rec_dir / "empty.csv"), cfg)
    assert e["error"] == f"{rec_dir / 'empty.csv'}: empty file: no header line and no data"
    (t,) = run_case(str(rec_dir / "text.csv"), cfg)
    assert t["error"] == (f"{rec_dir / 'text.csv'}: channel 'p1' holds text, not numbers: "
                          "row 2500 is 'abc'")


def test_cli_rerun_after_a_recording_changed_keeps_one_current_row_set(recordings):
    """Through the command: an edited recording's rows replace its old ones (one row set per
    path and job), and the exit code follows the current rows."""
    tmp, paths = recordings
    job = tmp / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    out = tmp / "res.parquet"
    assert _cli_batch(tmp, job, out).exit_code == 1  # broken.parquet
    old = read_results(out)
    write_parquet(make_recording(11), paths[0])  # the recording changed
    (tmp / "recordings" / "rig0" / "broken.parquet").unlink()  # and the bad one is gone
    r = _cli_batch(tmp, job, out)
    assert r.exit_code == 0, r.output
    assert "3 recording(s): 1 run, 2 already done, 0 error(s) in this run; 3 current row(s)" \
        in r.output
    df = read_results(out)
    mine = df[df["path"] == os.path.abspath(paths[0])]
    assert len(mine) == 1 and mine["recording_sha256"].iloc[0] == content_hash(paths[0])
    assert mine["value_mean"].iloc[0] != old[old["path"] == os.path.abspath(paths[0])][
        "value_mean"].iloc[0]


def test_cli_rows_for_empty_text_and_gapped_csv_name_file_channel_row(tmp_path):
    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    (rec_dir / "empty.csv").write_text("")
    rows = [f"{k / 1000},{np.sin(k)}" for k in range(6000)]
    text = list(rows)
    text[2500] = "2.5,abc"
    (rec_dir / "text.csv").write_text("time,p1\n" + "\n".join(text) + "\n")
    gap = [f"{k / 1000 + (0.5 if k >= 5000 else 0)},{np.sin(k)}" for k in range(6000)]
    (rec_dir / "gap.csv").write_text("time,p1\n" + "\n".join(gap) + "\n")
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    r = CliRunner().invoke(cli, ["batch", str(rec_dir / "*.csv"), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert r.exit_code == 1
    assert f"{rec_dir / 'empty.csv'}: empty file: no header line and no data" in r.output
    assert f"{rec_dir / 'text.csv'}: channel 'p1' holds text, not numbers: row 2500 is 'abc'" \
        in r.output
    assert f"{rec_dir / 'gap.csv'}: row 5000: time 5.5 s after 4.999 s is a gap" in r.output


def test_cli_job_of_detector_files_alone_and_unfitted_whole_recording_detectors_refused(
        recordings, tmp_path):
    """A job file with only [job] runs the --detector files given; a whole-recording detector
    that is not fitted is refused before any recording is read (fitted ones are judged on the
    file read whole: tests/batch/test_batch_whole.py)."""
    tmp, _ = recordings
    (tmp / "recordings" / "rig0" / "broken.parquet").unlink()
    det = tmp_path / "slow.pkl"
    det.write_bytes(pickle.dumps(SlowScorer()))
    job = tmp_path / "job.toml"
    job.write_text("[job]\nrms_chunk = 10\n")
    r = _cli_batch(tmp, job, tmp_path / "res", "--detector", str(det))
    assert r.exit_code == 0, r.output
    assert "3 recording(s): 3 run" in r.output
    whole = tmp_path / "whole.pkl"
    # a real detector that judges whole recordings only, not fitted: fit/predict, no spec()
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm

    whole.write_bytes(pickle.dumps(make_detector("fft-p1", "vca", Alarm())))
    r = _cli_batch(tmp, job, tmp_path / "res2", "--detector", str(whole))
    assert r.exit_code == 2
    assert f"{whole}: FFTBandDetector is not fitted (no threshold): fit it with leakdiag fit" \
        in " ".join(r.output.split())
    assert not (tmp_path / "res2").exists()


def test_cli_error_rows_advise_what_a_batch_job_can_do(tmp_path):
    """batch has no --sample-rate or --resample: its rows advise the job's column_map and
    resampling beforehand instead."""
    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    (rec_dir / "notime.csv").write_text("p1\n" + "".join(f"{np.sin(k)}\n" for k in range(3000)))
    t = np.arange(3000) / 1000.0
    t[1500:] += 0.0004
    (rec_dir / "jitter.txt").write_text("time\tp1\n" + "".join(
        f"{a}\t{np.sin(k)}\n" for k, a in enumerate(t)))
    for name in ("raw.csv", "raw.txt"):  # a real rig's names: they need a column map
        (rec_dir / name).write_text("time,PG_1\n" + "".join(
            f"{k / 1000},{k}\n" for k in range(3000)))
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    r = CliRunner().invoke(cli, ["batch", str(rec_dir / "*"), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert r.exit_code == 1
    assert "notime.csv: no 'time' column and no sample rate in the file: give the sample rate " \
           "(sample_rate_hz in the job's column_map)" in r.output
    assert "jitter.txt: column 'time' is not uniformly sampled" in r.output
    assert "batch needs a uniform time axis: resample the file first" in r.output
    # advice batch can follow: no "analyze --resample", which writes no file (a CLI audit,
    # 2026-11-29)
    assert "leakdiag.io.read_recording(FILE, resample=RATE_HZ), OUT); batch has no " \
           "--resample)" in r.output and "analyze --resample" not in r.output
    assert "raw.txt: no column is named like a channel" in r.output
    assert "raw.csv: missing channel(s) ['p1']; available: ['PG_1']; give the job a column " \
           'map (column_map = "map.toml" under [job])' in r.output
    assert r.output.count('give the job a column map (column_map = "map.toml" under [job])') \
        == 2
    assert "--sample-rate" not in r.output and "(--resample" not in r.output
    assert "--map" not in r.output and "--col" not in r.output


def test_cli_warns_of_a_time_column_read_as_a_low_rate(tmp_path):
    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    (rec_dir / "ms.csv").write_text("time,p1\n" + "".join(f"{k},{np.sin(k)}\n"
                                                          for k in range(3000)))
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    r = CliRunner().invoke(cli, ["batch", str(rec_dir / "*.csv"), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert r.exit_code == 0
    assert "warning: ms.csv: sample rate 1 Hz from the time column is low" in r.output
    assert '[file] time_unit = "ms"' in r.output


def test_a_leakdiag_detector_row_is_its_verdict(tmp_path):
    """A fitted and calibrated leakdiag detector in a job: the row says what
    ``Detector.predict`` says of the whole recording (alarm, times, onset by its own method,
    p-value, threshold, leak size with interval); a healthy run gets no alarm and no size."""
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm
    from leakdiag.io import read_recording, write_recording
    from leakdiag.sim import simulate_vca

    det = make_detector("ccf-p1p2", "vca", Alarm(false_alarms_per_hour=100.0, burn_in_s=2.0))
    det.fit([simulate_vca(duration=30.0, leak_lpm=None, seed=s) for s in (1, 2, 3)])
    # a calibration given by hand: ccf-p1p2's shift does not follow these simulated leaks
    # (calibrate refuses them since 2026-11-27), and the row only has to repeat the verdict
    from leakdiag.detect.leaksize import fit_leak_calibration

    det.calibration_ = fit_leak_calibration([-1.0, 0.5, 2.0, 3.5, 5.0], [0.1, 0.4, 0.8, 1.3, 1.5])
    (tmp_path / "det.pkl").write_bytes(pickle.dumps(det))
    cfg = config_from_dict({"detector": [{"name": "ccf", "path": str(tmp_path / "det.pkl")}]})
    leak = str(write_recording(simulate_vca(duration=30.0, leak_lpm=1.0, onset=15.0, seed=30),
                               tmp_path / "leak.parquet"))
    ok = str(write_recording(simulate_vca(duration=30.0, leak_lpm=None, seed=31),
                             tmp_path / "ok.parquet"))
    (row,) = run_case(leak, cfg)
    v = det.predict(read_recording(leak))
    assert v.leak and v.leak_lpm is not None  # the case this test is about
    assert row["alarm"] is True and row["system"] == "vca"
    assert row["alarm_time_s"] == v.alarm_time_s and row["alarm_onset_s"] == v.onset_s
    assert row["onset_method"] == v.onset_method and row["p_value"] == v.confidence
    assert row["alarm_onset_censored"] is v.onset_censored is False  # a leak from 15 s
    assert row["score_max"] == pytest.approx(v.score_max, rel=1e-12)
    assert row["threshold"] == det.threshold_
    assert (row["leak_lpm"], row["leak_lpm_low"], row["leak_lpm_high"]) == pytest.approx(
        (v.leak_lpm, *v.leak_lpm_interval), rel=1e-12)
    assert row["leak_lpm_in_range"] == v.leak_lpm_in_range
    # the decision leakdiag detect makes with this detector alone (expected false alarms in
    # this 30-s run at its rate, 2-s burn-in; an alarm expected by chance is inconclusive)
    from leakdiag.detect.decision import detector_rate, expected_false_alarms

    per_hour, burn = detector_rate(det)
    exp = expected_false_alarms(det.threshold_basis_, per_hour, 30.0 - burn, v.n_segments)
    assert row["false_alarms_expected"] == pytest.approx(exp)
    assert row["decision"] == ("leak" if exp < 1.0 else "inconclusive")
    (row,) = run_case(ok, cfg)
    v = det.predict(read_recording(ok))
    assert row["alarm"] is v.leak and row["score_max"] == pytest.approx(v.score_max, rel=1e-12)
    if not v.leak:
        assert row["alarm_time_s"] is None and row["leak_lpm"] is None


def test_predict_series_refuses_another_feature(tmp_path):
    from leakdiag.bench.registry import make_detector
    from leakdiag.detect.base import Alarm
    from leakdiag.sim import simulate_vca

    det = make_detector("ccf-p1p2", "vca", Alarm(false_alarms_per_hour=100.0, burn_in_s=2.0))
    det.fit([simulate_vca(duration=30.0, leak_lpm=None, seed=s) for s in (1, 2, 3)])
    fs = FeatureSeries(np.array([0.5, 1.0]), np.array([0.1, 0.2]), "autocorrelation",
                       window=200, step=190, sample_rate=1000.0)
    with pytest.raises(ValueError, match=r"predict_series: x.csv: the series is "
                                         r"'autocorrelation' over N=200, the detector's"):
        det.predict_series(fs, 30.0, source="x.csv")


def test_a_recording_shorter_than_a_window_says_so_in_its_rows(tmp_path):
    """Found by a real-data audit (2026-11-27): a 5-row file gave rows with status ok and no
    note (the reason was only printed), the detector's note blamed a 0-s burn-in, and the
    printed window was '200.0'."""
    from leakdiag.io.recording import Recording

    det = tmp_path / "det.pkl"
    det.write_bytes(pickle.dumps(SlowScorer()))
    path = tmp_path / "five.parquet"
    write_parquet(Recording({"p1": np.arange(5.0)}, 1000.0, meta={}), path)
    cfg = config_from_dict({"analysis": [{"method": "autocorrelation", "channels": ["p1"],
                                          "window": 200}],
                            "detector": [{"name": "slow", "path": str(det)}]})
    rows = {r["kind"]: r for r in run_case(str(path), cfg)}
    why = "no window: 5 samples is shorter than one window (window=200)"
    assert rows["analysis"]["status"] == "ok" and rows["analysis"]["error"] == why
    assert rows["detector"]["alarm"] is None
    assert rows["detector"]["error"] == f"detector not judged: {why}"
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n'
                   'window = 200\n')
    r = CliRunner().invoke(cli, ["batch", str(path), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    assert r.exit_code == 1
    assert "unusable: five.parquet: autocorrelation p1 1 N=200 5%: 5 samples is shorter than " \
           "one window (window=200)" in r.output


def test_a_detector_does_not_judge_its_own_healthy_files(tmp_path):
    """A CLI audit (2026-11-29): batch judged one of acf-p1's 8 healthy files with it, LEAK
    against a threshold that file set itself; ``detect`` refuses it. ``fit`` now records the
    healthy files' SHA-256 and batch leaves such a row not judged, saying why."""
    import leakdiag as ld
    from leakdiag.cli.main import main
    from leakdiag.io import write_recording
    from leakdiag.stream.detector_file import load_detector_file

    hs = [write_recording(ld.sim.simulate_vca(duration=20.0, leak_lpm=0.0, load="none",
                                              machine=31, seed=s), tmp_path / f"h{s}.parquet")
          for s in range(3)]
    other = write_recording(ld.sim.simulate_vca(duration=20.0, leak_lpm=0.0, load="none",
                                                machine=31, seed=9), tmp_path / "ok.parquet")
    det_path = tmp_path / "acf.joblib"
    assert main(["fit", *[a for h in hs for a in ("--healthy", str(h))], "-m", "acf-p1",
                 "--false-alarm-rate", "60", "--no-progress", "-o", str(det_path)]) == 0
    _, meta = load_detector_file(det_path)
    assert meta.healthy_sha256 == tuple(content_hash(h) for h in hs)
    job = config_from_dict({"detector": [{"path": str(det_path), "name": "acf"}],
                            "analysis": []})
    (own,) = run_case(str(hs[1]), job)
    assert own["status"] == "ok" and own["alarm"] is None and own["decision"] is None
    assert own["error"] == (f"detector not judged: {hs[1]}: one of the 3 healthy recordings "
                            f"{det_path} was fitted on (the same bytes): judged against a "
                            "threshold it set itself, a leak reads NO LEAK; judge recordings "
                            "other than the healthy ones (or fit without this one)")
    (judged,) = run_case(str(other), job)
    assert judged["alarm"] is not None
