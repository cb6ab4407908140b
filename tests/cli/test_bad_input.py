"""Bad input at the command line: exit code 2 (1 for batch) and ONE clear line on stderr, no traceback.

Each case writes a small CSV that is wrong in exactly one way and checks that the message names the
file and the problem (channel, row, window, unit).
"""

import numpy as np
import pytest

from leakdiag.cli.main import main

N = 2000
RATE_HZ = 1000.0


def _write(path, time_s, cols):
    names = ["time", *cols]
    data = np.column_stack([time_s, *cols.values()])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    return path


def _cols(n=N, seed=0):
    rng = np.random.default_rng(seed)
    return {"p1": 1e6 + rng.normal(0, 1e3, n), "p2": 1e6 + rng.normal(0, 1e3, n),
            "x": rng.normal(0, 1e-3, n), "u": rng.normal(0, 1, n)}


@pytest.fixture
def files(tmp_path):
    t = np.arange(N) / RATE_HZ
    good = _write(tmp_path / "good.csv", t, _cols())
    c = _cols()
    c["p1"][500] = np.nan
    nan = _write(tmp_path / "nan.csv", t, c)
    t_bad = t.copy()
    t_bad[1000:] += 0.5e-3
    nonuni = _write(tmp_path / "nonuni.csv", t_bad, _cols())
    c = _cols()
    del c["p1"]
    missing = _write(tmp_path / "missing.csv", t, c)
    short = _write(tmp_path / "short.csv", t[:50], _cols(50))
    const = _write(tmp_path / "const.csv", t, {"p1": np.full(N, 1e6), "p2": np.full(N, 1e6),
                                                "x": np.zeros(N), "u": np.zeros(N)})
    (tmp_path / "adir").mkdir()
    return {"good": good, "nan": nan, "nonuni": nonuni, "missing": missing, "short": short,
            "const": const, "nope": tmp_path / "nope.csv", "adir": tmp_path / "adir"}


def _one_error_line(capsys, code, *needles, expect_code=2):
    out = capsys.readouterr()
    assert code == expect_code, out
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert "Traceback" not in out.err
    errors = [ln for ln in lines if "error" in ln.lower()]
    assert len(errors) == 1, out.err
    for needle in needles:
        assert needle in errors[0], errors[0]
    return errors[0]


# ---- analyze ---------------------------------------------------------------------------------

@pytest.mark.parametrize("case,needles", [
    ("nan", ["nan.csv", "channel 'p1'", "1 non-finite", "row 500"]),
    ("nonuni", ["nonuni.csv", "not uniformly sampled", "row 1000", "--resample"]),
    ("missing", ["missing.csv", "missing channel(s) ['p1']", "available"]),
    ("short", ["short.csv", "50 samples", "shorter than one window", "(--window 200)"]),
    ("const", ["const.csv", "every window is NaN", "autocorrelation p1", "zero variance"]),
    ("nope", ["nope.csv", "file not found"]),
])
def test_analyze_bad_file(files, capsys, case, needles):
    code = main(["analyze", str(files[case]), "-c", "p1"])
    _one_error_line(capsys, code, *needles)


def test_analyze_directory(files, capsys):
    code = main(["analyze", str(files["adir"])])
    _one_error_line(capsys, code, "adir", "is a directory")


def test_analyze_unknown_unit(files, capsys):
    code = main(["analyze", str(files["good"]), "--col", "p1=p1:furlong"])
    _one_error_line(capsys, code, "p1=p1:furlong", "unknown unit 'furlong'", "psi")


def test_analyze_zero_variance_in_one_method_only_warns(files, capsys):
    """Constant u,x but live p1: the analysis runs, the dead method is counted, exit 0."""
    t = np.arange(N) / RATE_HZ
    c = _cols()
    c["u"][:] = 0.0
    path = _write(files["good"].parent / "dead_u.csv", t, c)
    # 'all' runs four methods; only cross-correlation u,x sees the constant u
    with pytest.warns(match=r"dead_u.csv: cross-correlation u,x .* have zero variance"):
        code = main(["analyze", str(path), "-m", "all"])
    out = capsys.readouterr()
    assert code == 0, out.err
    row = [ln for ln in out.out.splitlines() if "u,x" in ln][0]
    assert row.split()[-4:-2] == ["21", "21"]  # 21 windows, all 21 NaN (N=100, 5%: step 95)


# ---- sweep -----------------------------------------------------------------------------------

@pytest.mark.parametrize("case,needles", [
    ("nan", ["nan.csv", "row 500"]),
    ("nonuni", ["nonuni.csv", "not uniformly sampled"]),
    ("missing", ["missing.csv", "no channel 'p1'", "available"]),
    ("short", ["short.csv", "windows 100, 200, 300, 400, 500, 600, 700 and 800 of --windows "
                            "'100:800:100' are longer than the recording (50 samples)"]),
    ("const", ["const.csv", "channel 'p1' is constant", "zero variance"]),
    ("nope", ["nope.csv", "file not found"]),
])
def test_sweep_bad_file(files, capsys, case, needles):
    code = main(["sweep", str(files[case]), "-c", "p1", "--onset", "1", "--no-figures"])
    _one_error_line(capsys, code, *needles)


def test_sweep_without_onset_names_file(files, capsys):
    code = main(["sweep", str(files["good"]), "-c", "p1", "--no-figures"])
    _one_error_line(capsys, code, "good.csv", "no leak onset")


# ---- monitor ---------------------------------------------------------------------------------

@pytest.mark.parametrize("case,needles", [
    ("nan", ["nan.csv", "channel 'p1'", "1 non-finite", "row 500"]),  # detect's words
    ("nonuni", ["nonuni.csv", "not uniformly sampled"]),
    ("missing", ["missing.csv", "['p1']"]),
    ("short", ["short.csv", "50 samples", "shorter than one window", "window=200"]),
    ("const", ["const.csv", "all 10 windows", "degenerate"]),
    ("nope", ["nope.csv", "no such file"]),
    ("adir", ["adir", "is a directory"]),
])
def test_monitor_bad_file(files, capsys, case, needles):
    code = main(["monitor", "-i", str(files[case]), "-c", "p1", "-q"])
    _one_error_line(capsys, code, *needles)


def test_monitor_nan_in_later_chunk_names_file_and_sample(files, capsys):
    code = main(["monitor", "-i", str(files["nan"]), "-c", "p1", "-q", "--chunk", "128"])
    _one_error_line(capsys, code, "nan.csv", "first NaN at row 500")


# ---- detect ----------------------------------------------------------------------------------

@pytest.mark.parametrize("case,needles", [
    ("nan", ["nan.csv", "row 500"]),
    ("missing", ["missing.csv", "['p1']"]),
    ("short", ["short.csv", "shorter than one window"]),
])
def test_detect_bad_file(files, capsys, case, needles):
    # one 2-s healthy file supports a false-alarm probability of 1/2 per 2 s at best (conformal
    # threshold): ask for that (1000/h), so that the healthy fit succeeds and the bad file is judged
    code = main(["detect", str(files[case]), "--healthy", str(files["good"]), "--burn-in", "0",
                 "--system", "vca", "--methods", "acf-p1", "--false-alarm-rate", "0.5"])
    _one_error_line(capsys, code, *needles)


def test_detect_constant_healthy_file(files, capsys):
    code = main(["detect", str(files["good"]), "--healthy", str(files["const"]), "--burn-in", "0",
                 "--system", "vca",
                 "--methods", "acf-p1"])
    _one_error_line(capsys, code, "good.csv", "no method could judge it (1 tried)",
                    "const.csv: no finite feature value in its 10 window(s)", "healthy")


def test_detect_constant_file_is_not_called_healthy(files, capsys):
    """A dead (constant) sensor must not read 'no leak': each method says why, exit 2."""
    code = main(["detect", str(files["const"]), "--healthy", str(files["good"]), "--burn-in", "0",
                 "--system", "vca",
                 "--methods", "acf-p1,ccf-p1p2", "--no-progress"])
    out = capsys.readouterr()
    assert code == 2
    assert "Traceback" not in out.err and "False" not in out.out
    assert out.out.count("channel 'p1' is constant (1e+06)") == 2
    assert out.err.strip().splitlines() == [
        f"leakdiag: error: {files['const']}: no method could judge it (2 tried); first reason: "
        f"{files['const']}: channel 'p1' is constant (1e+06): zero variance, acf-p1 cannot "
        "judge it"]


def test_detect_nonexistent_file(files, capsys):
    code = main(["detect", str(files["nope"]), "--healthy", str(files["good"])])
    _one_error_line(capsys, code, "nope.csv", "does not exist")


# ---- batch -----------------------------------------------------------------------------------

JOB = ('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\nlag = 1\nwindow = 200\n'
       'overlap = 5\n')


@pytest.mark.parametrize("case,needles", [
    ("nan", ["error: nan.csv", "nan.csv: channel 'p1' has 1 non-finite value(s); first NaN at "
             "row 500"]),  # detect's words (no class name: "ValueError: ... at sample 500")
    ("missing", ["error: missing.csv", "['p1']"]),
    ("short", ["unusable: short.csv", "50 samples is shorter than one window (window=200)"]),
    ("const", ["unusable: const.csv", "all 10 windows degenerate"]),
])
def test_batch_bad_file_exits_1_with_its_row(files, tmp_path, capsys, case, needles):
    job = tmp_path / "job.toml"
    job.write_text(JOB)
    code = main(["batch", str(files[case]), str(files["good"]), "--config", str(job), "--out",
                 str(tmp_path / "res"), "--scheduler", "serial", "--no-progress"])
    out = capsys.readouterr()
    assert code == 1, out
    assert "Traceback" not in out.err
    bad = [ln for ln in out.err.splitlines() if ln.strip()]
    assert len(bad) == 1 and all(n in bad[0] for n in needles), out.err
    assert "2 recording(s): 2 run" in out.out


def test_batch_good_file_exits_0(files, tmp_path, capsys):
    job = tmp_path / "job.toml"
    job.write_text(JOB)
    code = main(["batch", str(files["good"]), "--config", str(job), "--out", str(tmp_path / "r"),
                 "--scheduler", "serial", "--no-progress"])
    assert code == 0, capsys.readouterr()


def test_batch_invalid_toml(files, tmp_path, capsys):
    job = tmp_path / "bad.toml"
    job.write_text("x = [\n")
    code = main(["batch", str(files["good"]), "--config", str(job), "--out", str(tmp_path / "r"),
                 "--scheduler", "serial"])
    _one_error_line(capsys, code, "bad.toml", "invalid TOML")


# ---- simulate --------------------------------------------------------------------------------

def test_simulate_uncalibratable_leak_is_one_line(tmp_path, capsys):
    """0.1 L/min over a 1 s leak phase needs a coefficient the integrator refuses: no traceback."""
    code = main(["simulate", "vca", "--duration", "2", "--onset", "1", "--out",
                 str(tmp_path / "s.parquet")])
    line = _one_error_line(capsys, code, "leak coefficient", "RK4 steps per sample")
    assert line.startswith("leakdiag: error:")


def test_simulate_invalid_params_toml_names_file(tmp_path, capsys):
    bad = tmp_path / "p.toml"
    bad.write_text("x = [\n")
    code = main(["simulate", "vca", "--duration", "2", "--onset", "1", "--params", str(bad),
                 "--out", str(tmp_path / "s.parquet")])
    _one_error_line(capsys, code, "p.toml", "invalid TOML")


def test_simulate_unknown_params_field(tmp_path, capsys):
    bad = tmp_path / "p.toml"
    bad.write_text("bogus_field = 3\n")
    code = main(["simulate", "vca", "--duration", "2", "--onset", "1", "--params", str(bad),
                 "--out", str(tmp_path / "s.parquet")])
    _one_error_line(capsys, code, "p.toml", "unknown VCA parameter(s) ['bogus_field']")


@pytest.mark.parametrize("args,message", [
    (["--duration", "-5"], "Error: Invalid value for '--duration': -5.0 is not in the range x>0."),
    (["--duration", "10", "--onset", "20"],
     "leakdiag: error: --onset 20 s must lie in [0, 9.999) s: before the run's last sample "
     "(10000 samples at 1000 Hz, --duration 10 s)"),
    (["--leak", "50"], "leakdiag: error: --leak 50.0 must be below the rated flow 43.3 L/min"),
    # a 10-Hz run was refused as "leak coefficient 0 ... short-circuits the actuator", and a
    # 20-Hz one was written: the controller's loop at that rate is unstable
    (["--sample-rate", "45", "--leak", "0"],
     "leakdiag: error: --sample-rate 45 Hz is too low for the fixed-gain controller, which "
     "runs at the sample rate: its position loop (gain K_p k_v K_q / A = 91.2 1/s) is a sampled "
     "integrator, unstable at gain x period >= 2; give a rate above 45.6 Hz (the thesis's rig: "
     "1000 Hz), or, in Python, a lower position_gain_v_per_m or a controller of your own"),
    (["--sample-rate", "0"],
     "Error: Invalid value for '--sample-rate': 0.0 is not in the range x>0."),
    # audit 2026-11-27: inf was a bare OverflowError traceback, nan "cannot convert float NaN
    # to integer"; --leak -1 said "must be > 0" while --leak 0 (no leak) is accepted
    (["--duration", "inf", "--onset", "30"],
     "Error: Invalid value for '--duration': inf is not a finite number."),
    (["--duration", "nan"], "Error: Invalid value for '--duration': nan is not a finite number."),
    (["--onset", "nan"], "Error: Invalid value for '--onset': nan is not a finite number."),
    (["--onset", "-1"], "Error: Invalid value for '--onset': -1.0 is not in the range x>=0."),
    (["--leak", "-1"], "Error: Invalid value for '--leak': -1.0 is not in the range x>=0."),
    (["--leak", "inf"], "Error: Invalid value for '--leak': inf is not a finite number."),
    (["--sample-rate", "inf"],
     "Error: Invalid value for '--sample-rate': inf is not a finite number."),
    (["--leak-kind", "ramp", "--ramp-duration", "nan"],
     "Error: Invalid value for '--ramp-duration': nan is not a finite number."),
    (["--seed", "-1"], "Error: Invalid value for '--seed': -1 is not in the range x>=0."),
    (["--duration", "1e308", "--sample-rate", "1e10"],
     "Error: --duration 1e+308 s at --sample-rate 1e+10 Hz: too many samples to count"),
])
def test_simulate_bad_numbers(tmp_path, capsys, args, message):
    code = main(["simulate", "vca", *args, "--out", str(tmp_path / "s.parquet")])
    assert _one_error_line(capsys, code) == message
    assert not (tmp_path / "s.parquet").exists()


@pytest.mark.parametrize("system", ["vca", "eha"])
def test_simulate_default_onset_is_half_the_duration(tmp_path, capsys, system):
    """`simulate vca --duration 60` failed: the default onset stayed at 200 s."""
    import leakdiag as ld

    out = tmp_path / "s.parquet"
    assert main(["simulate", system, "--duration", "16", "--no-progress", "--out",
                 str(out)]) == 0
    assert ld.io.read_recording(out).meta["onset"] == 8.0
    assert ", onset 8 s" in capsys.readouterr().out
    # no leak: the default onset is not "ignored" (it was not given); a given one is said
    assert main(["simulate", system, "--duration", "4", "--leak", "0", "--no-progress",
                 "--out", str(out)]) == 0
    assert capsys.readouterr().out.rstrip().endswith("load none); no leak")
    assert main(["simulate", system, "--duration", "4", "--leak", "0", "--onset", "2",
                 "--no-progress", "--out", str(out)]) == 0
    assert capsys.readouterr().out.rstrip().endswith("no leak (--onset 2 ignored: no leak to "
                                                     "start)")


def test_simulate_help_shows_the_default_onset(capsys):
    assert main(["simulate", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--onset FLOAT Leak onset in s [default: half of --duration, as in Secs. 4.5, 4.6: " \
           "200 for vca, 90 for eha]. [x>=0]" in text
    assert "(0 = none) [default: 0.1 for vca, 1.2 for eha]. [x>=0]" in text


# ---- benchmark: --workers --------------------------------------------------------------------

@pytest.mark.parametrize("workers", ["0", "-1"])
def test_benchmark_workers_below_one_is_refused_not_a_hang(tmp_path, capsys, monkeypatch,
                                                           workers):
    """Audit 2026-11-27: a local cluster of 0 workers waited at 0 % until killed."""
    import leakdiag.runtime.executor as ex

    monkeypatch.setattr(ex, "_run_dask", lambda *a: pytest.fail("a cluster was started"))
    code = main(["benchmark", "--quick", "--workers", workers, "--scheduler", "local", "-o",
                 str(tmp_path / "b"), "--cache-dir", str(tmp_path / "c"), "--work-dir",
                 str(tmp_path / "w"), "--no-progress"])
    assert _one_error_line(capsys, code) == (
        f"Error: Invalid value for '--workers': {workers} is not in the range x>=1.")
    assert not (tmp_path / "b").exists()  # refused before any folder is made


@pytest.mark.parametrize("cmd", ["benchmark", "batch"])
def test_workers_with_the_serial_scheduler_is_refused_not_ignored(tmp_path, capsys, cmd):
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    args = (["benchmark", "--quick", "-o", str(tmp_path / "b")] if cmd == "benchmark" else
            ["batch", str(tmp_path / "*.parquet"), "--config", str(job), "-o",
             str(tmp_path / "res")])
    code = main(args + ["--scheduler", "serial", "--workers", "4"])
    assert _one_error_line(capsys, code) == (
        "Error: --workers 4 is for --scheduler local (serial runs every case in this process): "
        "drop --workers or give --scheduler local")
    assert not (tmp_path / "b").exists() and not (tmp_path / "res").exists()


# ---- options ---------------------------------------------------------------------------------

def test_monitor_garbage_detector_file(files, tmp_path, capsys):
    det = tmp_path / "det.pkl"
    det.write_bytes(b"garbage\n")
    code = main(["monitor", "-i", str(files["good"]), "--detector", str(det), "-q"])
    _one_error_line(capsys, code, "--detector", "det.pkl", "cannot load as a detector file")


@pytest.mark.parametrize("args,needle", [
    (["-w", "0"], "--window 0 must be >= 2"),
    (["--overlap", "100"], "--overlap 100.0 must be in [0, 100) percent"),
    (["--lag", "500"], "--lag 500 must be in [1, --window 200)"),
    (["-m", "metric-length", "--lag-ratio", "83-3"], "--lag-ratio '83-3' must look like 'l:k'"),
    (["--sample-rate", "-5"], "--sample-rate -5.0 must be a finite number > 0"),
])
def test_analyze_bad_option_values(files, capsys, args, needle):
    code = main(["analyze", str(files["good"]), *args])
    _one_error_line(capsys, code, needle)


def test_sweep_chunk_zero(files, capsys):
    code = main(["sweep", str(files["good"]), "-c", "p1", "--onset", "1", "--chunk", "0",
                 "--no-figures"])
    assert _one_error_line(capsys, code) == \
        "Error: Invalid value for '--chunk': 0 is not in the range x>=1."


def test_reproduce_chunk_zero_is_a_usage_error(tmp_path, capsys):
    """It used to run every case and write a report of empty measures with exit code 0."""
    code = main(["reproduce", "vca", "--quick", "--chunk", "0", "--scheduler", "serial",
                 "--out", str(tmp_path / "rep")])
    _one_error_line(capsys, code, "'--chunk'", "0 is not in the range x>=1")
    assert not (tmp_path / "rep").exists()


def test_sweep_no_setting_meets_the_rule_speaks_options(files, capsys):
    code = main(["sweep", str(files["good"]), "-c", "p1", "--onset", "1", "--windows", "100",
                 "--lags", "1", "--overlaps", "5", "--min-chunks", "50", "--no-figures"])
    err = capsys.readouterr().err
    assert code == 2 and "SelectionRule(" not in err
    assert "no setting meets the rule (at least --min-chunks 50 whole RMS chunks of --chunk 10 " \
           "feature values on each side of the onset 1 s)" in err
    assert "lower --min-chunks or --chunk, or check --onset" in err


@pytest.mark.parametrize("command", ["analyze", "sweep"])
def test_reader_options_are_named_as_options(tmp_path, capsys, command):
    """The reader's own message said 'resample=-5.0 must be ...' (a Python argument); the
    commands name the option (found after an audit, 2026-11-27)."""
    import leakdiag as ld

    f = tmp_path / "r.csv"
    ld.io.write_recording(ld.io.Recording({"p1": np.arange(200.0) % 7}, 100.0), f)
    code = main([command, str(f), "--resample", "-5"])
    assert _one_error_line(capsys, code) == \
        f"leakdiag: error: {f}: --resample -5.0 must be a finite number > 0"


def test_simulate_refuses_a_run_that_cannot_fit_in_memory(tmp_path, capsys, monkeypatch):
    """A 10-s EHA run at 10 MHz worked for minutes towards 40 GiB; it is refused up front,
    against this machine's memory (here set to 1 GiB), with the longest run that fits."""
    import leakdiag.runtime.memory as memory

    monkeypatch.setattr(memory, "memory_bytes", lambda: 2**30)
    code = main(["simulate", "eha", "--duration", "10", "--sample-rate", "1e6", "--out",
                 str(tmp_path / "s.parquet")])
    assert _one_error_line(capsys, code) == (
        "Error: --duration 10 s at --sample-rate 1e+06 Hz is 1e+07 samples, which need about "
        "3.86 GiB of memory (414 bytes per sample); this machine has 1 GiB: give at most 2 s at "
        "this rate")
    assert not (tmp_path / "s.parquet").exists()
    code = main(["simulate", "vca", "--duration", "10", "--sample-rate", "1e6", "--out",
                 str(tmp_path / "s.parquet")])
    assert "(248 bytes per sample)" in _one_error_line(capsys, code)


def test_a_nan_in_a_column_no_method_reads(files, tmp_path, capsys):
    """Streams audit (2026-11-27, finding 5): a NaN in a temperature column refused the file
    for methods that never read it, with no word of how to go on; the refusal then said how to
    read only the channels needed. Since a CLI audit of 2026-11-29 (detect refused a file with
    a text note column that monitor and batch judged), the commands read only the channels
    their methods read, so the file is judged; a reader asked for every column (Python's
    read_recording) still refuses it with the advice."""
    from leakdiag.io import RecordingError, read_recording

    t = np.arange(N) / RATE_HZ
    c = _cols()
    c["temp"] = np.full(N, 40.0)
    c["temp"][700] = np.nan
    path = _write(tmp_path / "temp.csv", t, c)
    with pytest.raises(RecordingError, match="first NaN at row 700") as err:
        read_recording(path)
    assert "'temp' is not a channel leakdiag reads" in str(err.value)
    assert "--col p1=p1" in str(err.value)
    assert read_recording(path, channels=["p1"]).channels.keys() == {"p1"}
    other = {k: v[::-1].copy() for k, v in _cols().items()}  # not temp.csv's samples
    ref = _write(tmp_path / "ref.csv", t, other)
    for args in (["analyze", str(path), "--onset", "1.0", "-m", "acf", "-c", "p1"],
                 ["detect", str(path), "--healthy", str(ref), "--burn-in", "0",
                  "--system", "vca", "--methods", "acf-p1", "--false-alarm-rate", "0.5"]):
        code = main(args)
        assert code == 0, capsys.readouterr().err
    c["p1"][700] = np.nan  # a NaN in a channel leakdiag reads: no such advice
    code = main(["analyze", str(_write(tmp_path / "p1.csv", t, c)), "--onset", "1.0", "-m",
                 "acf", "-c", "p1"])
    line = _one_error_line(capsys, code, "channel 'p1'")
    assert "not a channel leakdiag reads" not in line


def test_a_text_column_no_method_reads_is_left_alone_by_every_command(tmp_path, capsys):
    """A CLI audit, 2026-11-29: a text note column beside the signals made detect (and fit,
    analyze) refuse the file ("holds text, not numbers") while monitor and batch, which read
    only their detectors' channels, judged it LEAK. Now each command reads only the channels
    its methods read."""
    import pandas as pd

    t = np.arange(N) / RATE_HZ
    paths = []
    for seed in range(4):
        df = pd.DataFrame({"time": t, **_cols(seed=seed)})
        df["note"] = "ok"
        paths.append(tmp_path / f"n{seed}.csv")
        df.to_csv(paths[-1], index=False)
    det = tmp_path / "d.joblib"
    assert main(["fit", *[a for p in paths[:3] for a in ("--healthy", str(p))], "--system",
                 "vca", "-m", "acf-p1", "--burn-in", "0", "--false-alarm-rate", "1000", "-o",
                 str(det), "--no-progress"]) == 0, capsys.readouterr().err
    for args in (["detect", str(paths[3]), "--detector", str(det), "--no-progress"],
                 ["detect", str(paths[3]), *[a for p in paths[:3] for a in ("--healthy", str(p))],
                  "--system", "vca", "--methods", "acf-p1", "--burn-in", "0",
                  "--false-alarm-rate", "0.5", "--no-progress"],
                 ["analyze", str(paths[3]), "-m", "acf", "-c", "p1", "--onset", "1.0"],
                 ["monitor", str(paths[3]), "--detector", str(det), "-q"]):
        code = main(args)
        out = capsys.readouterr()
        assert code == 0 and "holds text" not in out.err, (args[0], out)
    # a text column a method reads is still refused, naming it
    df = pd.read_csv(paths[3])
    df["p1"] = "x"
    df.to_csv(tmp_path / "bad.csv", index=False)
    code = main(["detect", str(tmp_path / "bad.csv"), "--detector", str(det)])
    _one_error_line(capsys, code, "bad.csv", "channel 'p1'", "holds text")


def test_monitor_advises_a_resampling_it_can_be_given(tmp_path, run_cli):
    """A user-data audit (2026-11-29): monitor on a jittery time axis advised "leakdiag analyze
    --resample RATE_HZ reads it", which writes no resampled file to monitor."""
    import numpy as np

    t = np.arange(2000) / 1000.0
    t[1000:] += 0.0004  # one interval of 1.4 ms among 1-ms ones
    path = tmp_path / "jitter.csv"
    path.write_text("time,p1\n" + "\n".join(f"{a:.4f},{np.sin(a * 50):.6f}" for a in t) + "\n")
    code, out, err = run_cli(["monitor", str(path), "-q"])
    assert code == 2 and "is not uniformly sampled" in err, err
    assert "leakdiag.io.write_recording(leakdiag.io.read_recording(FILE, resample=RATE_HZ), " \
        "OUT)" in err and "analyze --resample RATE_HZ reads it" not in err


def test_batch_refuses_a_results_folder_named_like_a_csv_file(tmp_path, run_cli):
    """A flow-balance audit (2026-11-29): batch -o res.csv made a Parquet dataset folder named
    res.csv without a word."""
    (tmp_path / "d.joblib").write_bytes(b"not read")  # refused before it is loaded
    code, out, err = run_cli(["batch", str(tmp_path / "x.parquet"), "--detector",
                              str(tmp_path / "d.joblib"), "-o", str(tmp_path / "res.csv")])
    assert code == 2 and "batch writes a results folder (a Parquet dataset" in err, err
    assert not (tmp_path / "res.csv").exists()
