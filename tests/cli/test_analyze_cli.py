"""`leakdiag analyze` end to end on files: table numbers, outputs, errors with exit code 2."""

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.cli.main import main


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    rng = np.random.default_rng(3)
    n = 12_000
    p1 = np.convolve(rng.standard_normal(n), np.ones(5) / 5, mode="same")
    p1[6000:] = rng.standard_normal(n - 6000)  # white after the "leak": autocorrelation drops
    rec = ld.Recording({"p1": 1e6 + 1e3 * p1, "p2": 1e6 - 1e3 * p1}, 1000.0)
    path = tmp_path_factory.mktemp("a") / "run.csv"
    rec.to_pandas().to_csv(path, index=False)
    return path, rec


def test_analyze_prints_measure_and_writes_outputs(run_file, tmp_path, capsys):
    path, rec = run_file
    out = tmp_path / "out"
    code = main(["analyze", str(path), "--method", "autocorrelation", "--channels", "p1",
                 "--lag", "1", "--window", "200", "--overlap", "5", "--onset", "6",
                 "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    verdict = pd.read_csv(out / "verdict.csv")
    fs = ld.features.autocorrelation(rec["p1"], lag=1, window=200, overlap=5, sample_rate=1000.0)
    direct = ld.detect.rms_change(fs, onset=6.0)
    assert verdict.loc[0, "mean_rms_before"] == pytest.approx(direct.mean_rms_before, rel=1e-9)
    assert f"{direct.pct_change:.2f}" in text
    feats = pd.read_parquet(out / "features.parquet")
    np.testing.assert_allclose(feats["value"], fs.values, rtol=1e-12)
    assert (out / "features.png").stat().st_size > 10_000


def test_analyze_refuses_a_system_the_file_contradicts(run_file, tmp_path, capsys):
    """--system eha on a file whose metadata say VCA ran silently at the EHA's settings."""
    path, _ = run_file
    rec = ld.io.read_recording(path)
    rec.meta["system"] = "vca"
    f = tmp_path / "vca.parquet"
    ld.io.write_recording(rec, f)
    assert main(["analyze", str(f), "--method", "all", "--system", "eha"]) == 2
    err = capsys.readouterr().err
    assert f"--system eha, but {f}'s metadata says 'vca'" in err
    assert main(["analyze", str(f), "--method", "autocorrelation", "--system", "vca"]) == 0


def test_analyze_all_uses_thesis_settings(run_file, capsys):
    path, _ = run_file
    rec = ld.io.read_recording(path)
    rec.channels["x"] = np.cumsum(rec["p1"] - rec["p1"].mean()) * 1e-9
    rec.channels["u"] = rec["p2"] * 1e-6
    both = path.parent / "full.parquet"
    ld.io.write_recording(rec, both)
    assert main(["analyze", str(both), "--method", "all", "--onset", "6", "--chunk", "4"]) == 0
    rows = [ln.split() for ln in capsys.readouterr().out.splitlines()[2:6]]
    # the thesis's preferred VCA settings (case study 2), and window counts from
    # n_windows = (n - N) // (N - round(N * overlap / 100)) + 1 with n = 12000
    got = [(r[0], r[1], r[2], int(r[3]), r[4], int(r[5])) for r in rows]
    assert got == [("autocorrelation", "p1", "1", 200, "5%", 63),
                   ("cross-correlation", "p1,p2", "1", 100, "5%", 126),
                   ("cross-correlation", "u,x", "1", 100, "5%", 126),
                   ("metric-length", "p1", "83:3", 500, "5%", 25)]


def test_analyze_missing_channel_is_one_clear_error(run_file, capsys):
    path, _ = run_file
    code = main(["analyze", str(path), "--method", "cross-correlation", "--channels", "u,x"])
    assert code == 2
    err = capsys.readouterr().err
    assert "missing channel(s) ['u', 'x']" in err and "Traceback" not in err


def test_analyze_missing_file(tmp_path, capsys):
    assert main(["analyze", str(tmp_path / "nope.csv")]) == 2
    assert "nope.csv" in capsys.readouterr().err


def test_analyze_column_flags(tmp_path, capsys):
    n = 3000
    rng = np.random.default_rng(1)
    df = pd.DataFrame({"t_s": np.arange(n) / 1000.0, "PA_psi": 1000 + rng.standard_normal(n)})
    path = tmp_path / "rig.csv"
    df.to_csv(path, index=False)
    out = tmp_path / "out"
    code = main(["analyze", str(path), "--col", "p1=PA_psi:psi", "--col", "time=t_s:s",
                 "--window", "100", "-m", "moments", "-c", "p1", "--out", str(out)])
    err = capsys.readouterr()
    assert code == 0, err.err
    assert "3000 samples at 1000 Hz" in err.out
    feats = pd.read_parquet(out / "features.parquet")
    means = feats[feats["method"] == "moments:mean"]
    # window 100, overlap 5%: step 95, windows start at 0, 95, ..., 2850 -> 31 windows,
    # timestamped at the last sample (t_s column) of each
    starts = np.arange(31) * 95
    np.testing.assert_allclose(means["time"], (starts + 99) / 1000.0, rtol=0, atol=1e-12)
    # the psi column was converted to Pa: 1 psi = 6894.757293168 Pa (exact, NIST)
    want = [df["PA_psi"].to_numpy()[s:s + 100].mean() * 6894.757293168 for s in starts]
    np.testing.assert_allclose(means["value"], want, rtol=1e-12)


# ---------------------------------------------------------------- decisions (issue 15)
@pytest.fixture(scope="module")
def healthy_files(tmp_path_factory):
    """Two healthy copies of run_file's process (smoothed noise all along, no change)."""
    d = tmp_path_factory.mktemp("h")
    paths = []
    for seed in (11, 12):
        rng = np.random.default_rng(seed)
        p1 = np.convolve(rng.standard_normal(12_000), np.ones(5) / 5, mode="same")
        rec = ld.Recording({"p1": 1e6 + 1e3 * p1, "p2": 1e6 - 1e3 * p1}, 1000.0)
        paths.append(d / f"healthy{seed}.csv")
        rec.to_pandas().to_csv(paths[-1], index=False)
    return paths


def test_analyze_decides_leak_and_writes_decision_columns(run_file, tmp_path, capsys):
    path, _ = run_file
    assert main(["analyze", str(path), "--onset", "6", "--chunk", "2", "-o",
                 str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "Decision: LEAK" in out and "autocorrelation p1: LEAK" in out
    v = pd.read_csv(tmp_path / "o" / "verdict.csv")
    assert v.loc[0, "decision"] == "leak" and v.loc[0, "basis"] == "before-after"
    assert v.loc[0, "p_value"] < 1e-4 and v.loc[0, "false_alarm_rate"] == 0.01
    assert v.loc[0, "test"] == "Mann-Whitney U, one-sided (feature falls)"


def test_analyze_healthy_run_reads_no_leak(healthy_files, capsys):
    assert main(["analyze", str(healthy_files[0]), "--onset", "6", "--chunk", "2"]) == 0
    out = capsys.readouterr().out
    assert "Decision: NO LEAK" in out
    # the same change with 3 and 2 chunks cannot reach 1 %: inconclusive, said so
    run_file_too_few = main(["analyze", str(healthy_files[0]), "--onset", "6"])
    out = capsys.readouterr().out
    assert run_file_too_few == 0 and "too few chunks (3 reference, 2 tested)" in out
    assert "Decision: INCONCLUSIVE" in out


def test_analyze_with_healthy_references(run_file, healthy_files, capsys):
    path, _ = run_file
    args = ["analyze", str(path), "--healthy", str(healthy_files[0]),
            "--healthy", str(healthy_files[1]), "--onset", "6", "--chunk", "2"]
    assert main(args) == 0  # the chunks after the onset against every healthy chunk
    out = capsys.readouterr().out
    assert "against healthy references" in out and "Decision: LEAK" in out
    # the percentage is the file's own change across the onset (Sec. 5.2), said so; not the
    # change against the references (a CLI audit, 2026-11-29)
    line = next(ln for ln in out.splitlines() if "against healthy references" in ln)
    assert re.search(r"\([+-]\d+\.\d % after vs before the onset; decided against healthy "
                     r"references; ", line), line
    # no onset: the whole file is judged against the references
    assert main(["analyze", str(healthy_files[0]), "--healthy", str(healthy_files[1])]) == 0
    assert "Decision: NO LEAK" in capsys.readouterr().out


def test_analyze_healthy_reference_with_other_sample_rate_is_refused(run_file, healthy_files,
                                                                     tmp_path, capsys):
    path, _ = run_file
    df = pd.read_csv(healthy_files[0])
    df["time"] = df["time"] * 2.0  # 500 Hz
    slow = tmp_path / "slow.csv"
    df.to_csv(slow, index=False)
    assert main(["analyze", str(path), "--healthy", str(slow)]) == 2
    err = capsys.readouterr().err
    assert "--healthy" in err and "sample rate 500 Hz differs" in err and "1000 Hz" in err


def test_analyze_all_skips_methods_without_their_channels(run_file, capsys):
    path, _ = run_file  # p1 and p2 only: no u, x
    assert main(["analyze", str(path), "--method", "all", "--onset", "6", "--chunk", "2"]) == 0
    out = capsys.readouterr().out
    assert "cross-correlation u,x: skipped (no channel u, x in the recording)" in out
    assert "autocorrelation p1: LEAK" in out


@pytest.mark.parametrize("opt", [["--lag", "2"], ["--window", "300"], ["--overlap", "10"],
                                 ["--lag-ratio", "40:2"], ["-c", "p2"]])
def test_analyze_all_refuses_settings_it_does_not_use(run_file, capsys, opt):
    path, _ = run_file
    assert main(["analyze", str(path), "--method", "all", *opt]) == 2
    assert f"does not use {opt[0] if opt[0] != '-c' else '--channels'}" in capsys.readouterr().err


def test_analyze_refuses_lag_for_metric_length_only(run_file, capsys):
    path, _ = run_file
    assert main(["analyze", str(path), "-m", "metric-length", "--lag", "3"]) == 2
    assert "metric-length takes --lag-ratio" in capsys.readouterr().err
    assert main(["analyze", str(path), "-m", "autocorrelation", "--lag-ratio", "3:1"]) == 2
    assert "--lag-ratio applies to --method metric-length only" in capsys.readouterr().err


@pytest.mark.filterwarnings("ignore:.*have zero variance")  # u,x windows while the piston rests
def test_demo_ends_with_the_decision_in_words(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path / "demo")]) == 0
    out = capsys.readouterr().out.rstrip().splitlines()
    assert out[-1].startswith("Decision: LEAK -- ")  # thesis case study 1: 0.1 L/min leak
    assert any(ln.startswith("Does it leak?") for ln in out)
    v = pd.read_csv(tmp_path / "demo" / "verdict.csv")
    # the pressure features see the 0.1 L/min leak (docs/measure.md, "Decisions")
    assert set(v.loc[v["channels"] != "u,x", "decision"]) == {"leak"}


def test_nan_window_count_in_table_equals_the_warning(tmp_path, capsys):
    # the last 600 samples are constant: the last windows are NaN and fall in the trailing
    # partial chunk; the table used to count only NaN values inside whole chunks
    rng = np.random.default_rng(5)
    p1 = rng.standard_normal(12_000)
    p1[-600:] = 0.0
    path = tmp_path / "tail.csv"
    ld.Recording({"p1": p1}, 1000.0).to_pandas().to_csv(path, index=False)
    with pytest.warns(match=r"tail.csv: autocorrelation p1 .*: (\d+) of 63 windows") as rec:
        assert main(["analyze", str(path), "--onset", "6", "--chunk", "2"]) == 0
    n_warned = int(re.search(r": (\d+) of 63 windows", str(rec[0].message)).group(1))
    row = [ln for ln in capsys.readouterr().out.splitlines() if ln.lstrip().startswith("auto")][0]
    assert n_warned == 3 and row.split()[-3] == "3"  # NaN windows column, before decision and p


def test_analyze_sample_rate_contradicting_a_header_speaks_cli(tmp_path, capsys):
    """The file's header says 1000 Hz: --sample-rate 500 is refused in the command's words."""
    path = ld.io.write_recording(ld.Recording({"p1": np.sin(np.arange(3000.0))}, 1000.0),
                                 tmp_path / "r.parquet")
    assert main(["analyze", str(path), "-c", "p1", "--sample-rate", "500", "--onset", "1.5"]) == 2
    err = capsys.readouterr().err
    assert "a sample rate of 500 Hz was given (--sample-rate, or sample_rate_hz in a column " \
           "map), but the file's header says 1000 Hz" in err and "sample_rate=" not in err


def test_no_time_column_and_no_rate_advises_the_option(tmp_path, capsys):
    path = tmp_path / "notime.csv"
    pd.DataFrame({"p1": np.sin(np.arange(3000.0))}).to_csv(path, index=False)
    assert main(["analyze", str(path), "-c", "p1", "--onset", "1.5"]) == 2
    err = capsys.readouterr().err
    assert ("no sample rate; name the file's time column (--col time=NAME, or time_column in "
            "the map), or, if it has none, give the sample rate (--sample-rate, or "
            "sample_rate_hz in the map)") in err and "give sample_rate" not in err


@pytest.mark.parametrize("name", ["Time", "t", "time_s", "Time [s]"])
def test_a_time_column_not_named_time_is_not_ignored_for_a_sample_rate(tmp_path, capsys, name):
    """Audit of users' recordings (2026-11-27, finding 3): a 500-Hz file with a 'Time' column
    and --sample-rate 1000 read as '3000 samples at 1000 Hz' and its time column as a channel;
    the error without a rate suggested --sample-rate only."""
    path = tmp_path / "T500.csv"
    pd.DataFrame({name: np.arange(3000) * 0.002, "p1": np.sin(np.arange(3000.0))}).to_csv(
        path, index=False)
    said = (f"{path}: column {name!r} looks like a time column, but only a column named exactly "
            "'time' is the time axis of a file read without a map (it would be read as a "
            "channel, and a sample rate would place the samples instead of it): say it is the "
            f"time column with --col time={name} (")
    for rate in ([], ["--sample-rate", "1000"]):
        assert main(["analyze", str(path), "-c", "p1", *rate]) == 2
        assert said in capsys.readouterr().err
    assert main(["monitor", str(path), "-c", "p1", "--sample-rate", "1000", "-w", "200"]) == 2
    assert said in capsys.readouterr().err
    assert main(["analyze", str(path), "-c", "p1", "--col", f"time={name}"]) == 0
    assert "3000 samples at 500 Hz (6 s)" in capsys.readouterr().out


def test_time_unit_contradicting_a_leakdiag_header_is_refused(tmp_path, capsys):
    """--time-unit ms on a file whose header says 1000 Hz read it silently at 1 MHz."""
    path = ld.io.write_recording(ld.Recording({"p1": np.sin(np.arange(3000.0))}, 1000.0),
                                 tmp_path / "r.parquet")
    assert main(["analyze", str(path), "-c", "p1", "--time-unit", "ms", "--onset", "1.5e-3",
                 "--chunk", "1"]) == 2
    err = capsys.readouterr().err
    assert "r.parquet: the file's header says 1000 Hz, but its time column read with the column " \
           "map (--map/--col/--time-unit) gives 1e+06 Hz" in err
    assert main(["analyze", str(path), "-c", "p1", "--time-unit", "s", "--onset", "1.5",
                 "--chunk", "2"]) == 0


def test_a_method_without_a_measure_prints_dashes_not_nan(tmp_path, capsys):
    rng = np.random.default_rng(5)
    path = tmp_path / "short.csv"
    ld.Recording({"p1": 1e6 + 1e3 * rng.standard_normal(3000),
                  "p2": 1e6 + 1e3 * rng.standard_normal(3000)}, 1000.0).to_pandas().to_csv(
        path, index=False)
    # 15 autocorrelation windows in 3 s: no whole chunk of 10 on either side of the onset;
    # 31 cross-correlation windows: one on each side, so the table has the measure's columns
    assert main(["analyze", str(path), "--method", "all", "--onset", "1.5"]) == 0
    out = capsys.readouterr().out
    table = out.split("\n  autocorrelation p1:")[0]
    assert "autocorrelation" in table and "inconclusive" in table
    assert "nan" not in table.lower().replace("nan windows", "")


@pytest.mark.parametrize("args,needle", [
    (["--chunk", "0"], "Invalid value for '--chunk': 0 is not in the range x>=1"),
    (["--false-alarm-rate", "1.5"], "'--false-alarm-rate': 1.5 is not in the range 0<x<=0.5"),
    (["--false-alarm-rate", "0"], "'--false-alarm-rate': 0.0 is not in the range 0<x<=0.5"),
])
def test_analyze_refuses_nonsense_settings_even_without_an_onset(run_file, capsys, args, needle):
    """Without an onset the decision is INCONCLUSIVE; it used to state 'each at 1.5 so that the
    overall false-alarm rate per run is 1.5' (or run with 0 chunks) instead of refusing."""
    path, _ = run_file
    assert main(["analyze", str(path), "-c", "p1", *args]) == 2
    assert needle in capsys.readouterr().err


def test_method_all_states_whose_settings_it_uses(run_file, capsys):
    """A file that does not say its system is analysed at the VCA's settings: said, not silent."""
    path, _ = run_file
    assert main(["analyze", str(path), "--method", "all", "--onset", "6"]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert head.endswith("; --method all at the thesis's VCA settings (the file does not say its "
                         "system; --system eha for the EHA's)")
    assert main(["analyze", str(path), "--method", "all", "--onset", "6", "--system", "eha"]) == 0
    assert capsys.readouterr().out.splitlines()[0].endswith("at the thesis's EHA settings")


# --------------------- found by an audit on real recordings (2026-11-27): too few chunks
@pytest.fixture(scope="module")
def three_seconds(tmp_path_factory):
    """3000 samples at 1 kHz (as the rotary-actuator files): 6 metric-length windows of 500."""
    d = tmp_path_factory.mktemp("short")
    paths = []
    for seed in (5, 6):
        rng = np.random.default_rng(seed)
        rec = ld.Recording({"p1": 1e6 + 1e3 * rng.standard_normal(3000),
                            "p2": 1e6 + 1e3 * rng.standard_normal(3000)}, 1000.0)
        paths.append(d / f"short{seed}.csv")
        rec.to_pandas().to_csv(paths[-1], index=False)
    return paths


def test_one_method_without_a_whole_chunk_is_inconclusive_like_one_of_many(three_seconds,
                                                                           capsys):
    """A single method used to exit 2 ('the Sec. 5.2 measure needs ...', no file name) where
    the same method among --method all was INCONCLUSIVE with exit 0."""
    path = three_seconds[0]
    why = ("metric-length p1: INCONCLUSIVE (before vs after the onset; the Sec. 5.2 measure "
           "needs at least one whole chunk on each side of the onset (1.5 s): got 0 before and "
           "0 after (6 windows, fewer than one chunk of 10); use a smaller chunk (--chunk), "
           "more windows (a smaller window or a larger overlap), or check the onset (--onset))")
    assert main(["analyze", str(path), "-m", "metric-length", "-c", "p1", "-w", "500",
                 "--onset", "1.5"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{path}: 3000 samples at 1000 Hz (3 s), leak onset 1.5 s\n")
    assert f"\n  {why}\n" in out and "Decision: INCONCLUSIVE" in out
    assert main(["analyze", str(path), "-m", "all", "--onset", "1.5"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{path}: ") and f"\n  {why}\n" in out
    # the row's chunk counts: none before, none after, none straddling (no whole chunk)
    row = [ln for ln in out.splitlines() if ln.lstrip().startswith("metric-length")][0]
    assert "0/0/0" in row.split()


def test_an_onset_outside_the_recording_is_refused_naming_the_file(three_seconds, capsys):
    path = three_seconds[0]
    for method in (["-m", "autocorrelation"], ["-m", "all"]):
        assert main(["analyze", str(path), *method, "--onset", "7"]) == 2
        # the last sample's time (3 s of samples at 1 kHz end at 2.999 s; an audit,
        # 2026-11-29: "0.001 to 3.001 s" for samples up to 3.000 s)
        assert (f"{path}: onset 7 s is outside the recording (samples from 0 to 2.999 s): "
                "nothing to compare before and after it") in capsys.readouterr().err


def test_healthy_reference_too_short_says_why_without_numpy_warnings(three_seconds, capsys):
    """It printed 'leakdiag: warning: Mean of empty slice' and 'invalid value encountered in
    scalar divide' (warnings are errors in this suite) and a reason of 'too few chunks (0
    reference, 0 tested): the smallest p-value the test can give, 1'."""
    path, ref = three_seconds
    assert main(["analyze", str(path), "-m", "metric-length", "-c", "p1", "-w", "500",
                 "--healthy", str(ref)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert ("metric-length p1: INCONCLUSIVE (against healthy references; too few chunks to "
            "test (0 reference, 0 tested): the file has 6 windows, fewer than one chunk of 10; "
            "the healthy reference short6.csv has 6 windows, fewer than one chunk of 10; use a "
            "smaller chunk (--chunk), or more windows (a smaller --window or a larger "
            "--overlap))") in out


def test_audit_commands_on_the_rotary_actuator_files(shared_dir, capsys):
    """The audit's own commands (shared/realdata; 3000 samples, '1 kHz' assumed)."""
    data = shared_dir / "realdata" / "rotary-actuators" / "Data"
    cmap = str(Path(__file__).resolve().parents[2] / "docs" / "examples"
               / "rotary_actuator_map.toml")
    leak = next((data / "Act_4 (Seal Defect)").glob("Leak_000_10_313_*PM.txt"))
    base = next((data / "Act_1").glob("Base_000_10_418_*AM.txt"))
    assert main(["analyze", str(leak), "--map", cmap, "-m", "metric-length", "-c", "p1",
                 "-w", "500", "--healthy", str(base)]) == 0
    out, err = capsys.readouterr()
    assert err == "" and (f"the file has 6 windows, fewer than one chunk of 10; the healthy "
                          f"reference {base.name} has 6 windows, fewer than one chunk of 10"
                          ) in out
    assert main(["analyze", str(leak), "--map", cmap, "-m", "metric-length", "-c", "p1",
                 "-w", "500", "--onset", "1.5"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(str(leak)) and "metric-length p1: INCONCLUSIVE (before vs after the " \
        "onset; the Sec. 5.2 measure needs at least one whole chunk" in out


# --------------------- audit of the commands' options (2026-11-27): messages name the options
@pytest.mark.parametrize("args, message", [
    (["--window", "1"], "--window 1 must be >= 2"),
    (["--overlap", "100"], "--overlap 100.0 must be in [0, 100) percent"),
    (["--lag", "0"], "--lag 0 must be in [1, --window 200)"),
    # the cross-correlation too (an audit: analyze alone took lag 0 as Pearson's correlation,
    # -46 %, LEAK, where the docs, sweep and monitor refuse it)
    (["-m", "cross-correlation", "-c", "p1,p2", "--lag", "0"],
     "--lag 0 must be in [1, --window 200)"),
    (["--lag", "300", "--window", "250"], "--lag 300 must be in [1, --window 250)"),
    (["-m", "metric-length", "--lag-ratio", "300:3"],
     "--lag-ratio '300:3': l=300 must be < --window 200"),
    (["--window", "20000"], "{path}: recording has 12000 samples (12 s), shorter than one "
                            "window (--window 20000); use a smaller window or a longer "
                            "recording"),
])
def test_analyze_messages_name_the_options(run_file, capsys, args, message):
    """`--window 1` said 'window=1 must be >= 2', the Python argument, not the option."""
    path, _ = run_file
    extra = [] if "-c" in args else ["-c", "p1"]
    assert main(["analyze", str(path), *extra, "--onset", "6", *args]) == 2
    assert capsys.readouterr().err == f"leakdiag: error: {message.format(path=path)}\n"


def test_analyze_method_all_keeps_the_thesis_settings_words(tmp_path, capsys):
    """--method all runs the thesis's settings, not options: its messages keep their names."""
    path = tmp_path / "short.csv"
    ld.Recording({"p1": np.sin(np.arange(150.0)), "p2": np.cos(np.arange(150.0))},
                 1000.0).to_pandas().to_csv(path, index=False)
    assert main(["analyze", str(path), "-m", "all", "--onset", "0.07"]) == 2
    assert capsys.readouterr().err == (
        f"leakdiag: error: {path}: recording has 150 samples (0.15 s), shorter than one window "
        "(window=200); use a smaller window or a longer recording\n")


def test_analyze_tests_an_ehas_change_two_sided(tmp_path, capsys):
    """--system eha (or the file's word) makes the decision two-sided: a rise of the
    cross-correlation, as in the thesis's EHA tables, reads LEAK there and INCONCLUSIVE on a
    rig that is not said (one-sided, the VCA's direction)."""
    from scipy.signal import lfilter

    from leakdiag.io import Recording, write_recording

    rng = np.random.default_rng(3)
    n = 20000
    z = lfilter([1.0], [1.0, -0.99], rng.normal(size=n))
    w = np.where(np.arange(n) < n // 2, 0.6, 1.2) / z.std()
    rec = Recording({"p1": w * z + rng.normal(size=n), "p2": w * z + rng.normal(size=n)}, 100.0)
    path = tmp_path / "rise.parquet"
    write_recording(rec, path)
    args = ["analyze", str(path), "-m", "cross-correlation", "-c", "p1,p2", "--onset", "100",
            "--overlap", "0"]
    assert main(args) == 0
    assert "cross-correlation p1,p2: INCONCLUSIVE" in capsys.readouterr().out
    assert main([*args, "--system", "eha"]) == 0
    assert "cross-correlation p1,p2: LEAK" in capsys.readouterr().out


@pytest.mark.filterwarnings("ignore::leakdiag.features._degenerate.DegenerateWindowWarning")
def test_moments_of_adc_counts_are_said_to_depend_on_the_converters_zero(shared_dir, capsys):
    """A user-data audit (2026-11-29): analyze -m moments on the rotary files' raw counts said
    nothing, while the mean's % change (a ratio) depends on the ADC's zero."""
    data = shared_dir / "realdata" / "rotary-actuators" / "Data"
    cmap = str(Path(__file__).resolve().parents[2] / "docs" / "examples"
               / "rotary_actuator_map.toml")
    base = next((data / "Act_1").glob("Base_000_10_418_*AM.txt"))
    assert main(["analyze", str(base), "--map", cmap, "-m", "moments", "-c", "p1", "-w", "200",
                 "--onset", "1.5", "--chunk", "2"]) == 0
    err = capsys.readouterr().err
    assert "the moments of p1 are in ADC counts, whose zero is the converter's" in err
    assert main(["analyze", str(base), "--map", cmap, "-m", "autocorrelation", "-c", "p1",
                 "--onset", "1.5", "--chunk", "2"]) == 0
    assert "ADC counts" not in capsys.readouterr().err


def test_verdict_csv_holds_the_runs_decision_beside_each_method(tmp_path):
    """A CLI audit (2026-11-29, session 28): with ``--method all`` a method's row read
    ``decision = leak`` (p = 0.0052 < 0.01 alone) while the run's decision, the rate split over
    4 methods (0.0025 each), was INCONCLUSIVE, and verdict.csv had no overall decision: a
    script reading it took the method's for the run's."""
    from leakdiag.cli.analyze import verdict_table

    t = pd.DataFrame({"method": ["a", "b", "c", "d"], "channels": ["p1"] * 4,
                      "decision": ["leak", "no-leak", "no-leak", "no-leak"],
                      "p_value": [0.0052, 0.4, 0.5, 0.6]})
    v = verdict_table(t, 0.01)
    assert v["decision"].tolist() == t["decision"].tolist()  # each method's own, unchanged
    assert set(v["overall_decision"]) == {"no-leak"} and set(v["method_level"]) == {0.0025}
    assert "a below 0.01 alone, not below the split level" in v["overall_reason"][0]
    out = tmp_path / "o"
    assert main(["analyze", "docs/examples/rig.csv", "--map", "docs/examples/map.toml",
                 "-m", "autocorrelation", "-m", "metric-length", "-c", "p1", "--onset", "10",
                 "-o", str(out)]) == 0
    f = pd.read_csv(out / "verdict.csv")
    assert f["overall_decision"].nunique() == 1 and f["method_level"].nunique() == 1
    assert f["method_level"][0] == pytest.approx(0.01 / f["decision"].notna().sum())


def test_a_no_leak_of_analyze_says_what_it_does_not_rule_out():
    """A CLI audit (2026-11-29, session 28): rig.csv, a 0.5 L/min leak, read "autocorrelation
    p1: NO LEAK (-48.2 %, ... p=0.0325 >= 0.01)" and "Decision: NO LEAK" without a word of
    what that NO LEAK covers (detect says it for its feature detectors)."""
    from leakdiag.cli.analyze import decision_words

    t = pd.DataFrame({"method": ["autocorrelation"], "channels": ["p1"],
                      "decision": ["no-leak"], "p_value": [0.0325], "basis": ["before-after"],
                      "reason": ["p=0.0325 >= 0.01"], "pct_change_signed": [-48.2]})
    text = decision_words(t, 0.01)
    assert text.splitlines()[-2].startswith("Decision: NO LEAK")
    assert text.splitlines()[-1] == (
        "  sensitivity: not stated: NO LEAK here means no change significant at this rate; a "
        "leak whose change the chunks do not resolve is not ruled out (the flow balance, "
        "leakdiag detect, states the smallest leak it would have seen; docs/detect.md section "
        "6)")
    leak = t.assign(decision=["leak"], p_value=[0.001])
    assert "sensitivity" not in decision_words(leak, 0.01)
