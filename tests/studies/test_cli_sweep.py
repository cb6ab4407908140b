"""`leakdiag sweep` on a file: table printed, CSV/Parquet and figures written."""

import numpy as np
import pandas as pd

from leakdiag.cli.main import main

from .test_grid import ar_recording


def test_sweep_cli_ofat_and_grid(tmp_path, capsys):
    rec = ar_recording()
    df = rec.to_pandas()
    path = tmp_path / "rec.csv"
    df.drop(columns=[]).to_csv(path, index=False)
    out = tmp_path / "o"
    code = main(["sweep", str(path), "--method", "autocorrelation", "-c", "p1", "--lags", "1,3",
                 "--windows", "60:120:60", "--overlaps", "0,50", "--onset", "30", "--chunk", "5",
                 "--out", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    assert "preferred (max |% change|" in text
    t = pd.read_csv(out / "sweep.csv")
    assert list(t.varied) == ["lag", "lag", "window", "window", "overlap", "overlap"]
    assert (t.pct_change_signed < 0).all()  # the AR coefficient falls from 0.9 to 0.5
    for f in ("panels_lag.png", "pct_vs_window.png", "sweep.parquet"):
        assert (out / f).stat().st_size > 500
    code = main(["sweep", str(path), "-m", "autocorrelation", "-c", "p1", "--lags", "1,3",
                 "--windows", "60,120", "--overlaps", "0,50", "--onset", "30", "--chunk", "5",
                 "--mode", "grid", "--out", str(out / "g")])
    assert code == 0
    g = pd.read_csv(out / "g" / "sweep.csv")
    assert len(g) == 8
    best = g.loc[g["pct_change"].idxmax()]
    assert f"lag {int(best.lag)}, window {int(best.window)}" in capsys.readouterr().out
    np.testing.assert_allclose(g["pct_change"], g.pct_change_signed.abs())
    assert (out / "g" / "grid_heatmap.png").stat().st_size > 500


def test_sweep_says_which_grid_settings_it_skipped_and_refuses_an_onset_outside(tmp_path,
                                                                                capsys):
    """Found by an audit session (2026-11-27): a grid quietly dropped lag >= window settings,
    and an onset after the end read as 'no setting meets the rule'."""
    rec = ar_recording()
    path = tmp_path / "rec.csv"
    rec.to_pandas().to_csv(path, index=False)
    code = main(["sweep", str(path), "-m", "autocorrelation", "-c", "p1", "--lags", "1,80",
                 "--windows", "60,120", "--overlaps", "0", "--onset", "30", "--chunk", "5",
                 "--mode", "grid", "--no-figures"])
    assert code == 0
    head = capsys.readouterr().out.splitlines()[0]
    assert head.endswith("3 settings (grid); 1 of 4 skipped: a lag not smaller than its "
                         "window")
    end = rec.start_time + rec.duration
    code = main(["sweep", str(path), "-c", "p1", "--onset", str(end + 10)])
    assert code == 2
    assert f"onset {end + 10:g} s is outside the recording" in capsys.readouterr().err


# ------------------------------------------ found by an audit on real recordings, 2026-11-27
import pytest  # noqa: E402

from leakdiag.detect.measure import TooFewChunksError, rms_change  # noqa: E402
from leakdiag.features import DegenerateWindowWarning  # noqa: E402
from leakdiag.features.spec import MethodSpec, compute_feature  # noqa: E402
from leakdiag.studies.grid import grid, quiet_degenerate  # noqa: E402

from .test_grid import degenerate_recording  # noqa: E402

COUNTS = ["n_windows", "n_windows_dropped", "n_chunks_before", "n_chunks_after",
          "n_chunks_straddling", "n_chunks_empty", "n_nan_windows", "chunk"]


def rms_change_counts(rec, method, channels, lag, window, overlap, onset, chunk):
    """The reference: rms_change's counts on the plain feature series of that setting."""
    with quiet_degenerate():
        fs = compute_feature(rec, MethodSpec(method, tuple(channels.split(",")), lag=lag,
                                             window=window, overlap=overlap))
    try:
        d = rms_change(fs, onset, chunk=chunk).as_dict()
    except TooFewChunksError as exc:
        d = exc.partial.as_dict()
    return [d[c] for c in COUNTS]


def test_sweep_counts_and_reports_nan_windows_as_analyze_does(tmp_path, capsys):
    rec = degenerate_recording()
    path = tmp_path / "flat.csv"
    rec.to_pandas().to_csv(path, index=False)
    args = ["sweep", str(path), "-m", "autocorrelation", "-c", "p1", "--lags", "1",
            "--windows", "100", "--overlaps", "0,5,50", "--mode", "grid", "--onset", "1.5",
            "--chunk", "2", "--min-chunks", "1", "--no-figures", "-o", str(tmp_path / "o")]
    with pytest.warns(DegenerateWindowWarning) as caught:
        assert main(args) == 0
    t = pd.read_csv(tmp_path / "o" / "sweep.csv")
    for r in t.itertuples(index=False):
        assert [getattr(r, c) for c in COUNTS] == rms_change_counts(
            rec, "autocorrelation", "p1", 1, 100, r.overlap, 1.5, 2)
    # overlap 0: 30 windows, 10 NaN in 15 chunks of 2, 3 of them NaN only; 5 %: 31 windows
    assert t[["n_nan_windows", "n_chunks_empty"]].values.tolist() == [[10, 3], [7, 1], [17, 7]]
    assert [str(w.message) for w in caught] == [
        f"{path}: autocorrelation p1: in 3 of 3 settings, windows have zero variance; their "
        "values are NaN (skipped inside their chunk's RMS, column n_nan_windows; a chunk of "
        "NaN values only is left out, column n_chunks_empty); the most at lag 1, window 100, "
        "overlap 0%: 10 of the 30 windows in whole chunks, 3 chunks of NaN values only"]
    head = capsys.readouterr().out.splitlines()[1].split()
    assert head[-2:] == ["n_nan_windows", "n_chunks_empty"]


@pytest.mark.parametrize("mode, stage", [("grid", ""), ("ofat", " at the lag stage")])
def test_sweep_without_an_eligible_setting_keeps_its_table(tmp_path, capsys, mode, stage):
    """No setting meeting the rule used to exit 2 with nothing printed and nothing written."""
    rec = ar_recording()
    path = tmp_path / "rec.csv"
    rec.to_pandas().to_csv(path, index=False)
    out = tmp_path / "o"
    code = main(["sweep", str(path), "-m", "autocorrelation", "-c", "p1", "--lags", "1,3",
                 "--windows", "60,120", "--overlaps", "0", "--mode", mode, "--onset", "30",
                 "--chunk", "5", "--min-chunks", "1000", "-o", str(out)])
    text = capsys.readouterr()
    assert code == 2
    t = pd.read_csv(out / "sweep.csv")
    want = grid(rec, "autocorrelation", "p1", [1, 3], [60], [0], onset=30, chunk=5) \
        if mode == "ofat" else grid(rec, "autocorrelation", "p1", [1, 3], [60, 120], [0],
                                    onset=30, chunk=5)
    np.testing.assert_array_equal(t["pct_change_signed"], want["pct_change_signed"])
    assert sorted(p.name for p in out.iterdir()) == ["sweep.csv", "sweep.parquet"]
    assert f"wrote {out}/: sweep.csv, sweep.parquet (no figures: no setting was chosen)" \
        in text.out and "preferred" not in text.out
    assert len(text.out.splitlines()) == 1 + 1 + len(t) + 1  # head, column names, rows, wrote
    later = " (the window and overlap stages could not run)" if mode == "ofat" else ""
    assert text.err == (
        f"leakdiag: error: {path}: no setting meets the rule (at least --min-chunks 1000 whole "
        f"RMS chunks of --chunk 5 feature values on each side of the onset 30 s){stage}: "
        f"{len(t)} row(s), {len(t)} with a finite % change{later}; lower --min-chunks or "
        f"--chunk, or check --onset; the table is printed above and in {out / 'sweep.csv'}\n")


def test_audit_sweep_on_a_rotary_actuator_file(shared_dir, tmp_path, capsys):
    """The audit's command: sweep.csv said n_chunks_straddling=6 where rms_change says 0
    straddling and 6 empty (all-NaN chunks), and hid that 13 windows were NaN."""
    from pathlib import Path

    from leakdiag.cli._options import column_map_from, read_with

    repo = Path(__file__).resolve().parents[2]
    cmap = str(repo / "docs" / "examples" / "rotary_actuator_map.toml")
    f = shared_dir / "realdata" / "rotary-actuators" / "Data" / "Act_2" / \
        "Base_000_30_754_9-11-2019-10-36-12 AM.txt"
    with pytest.warns(DegenerateWindowWarning, match=r"in 3 of 3 settings, windows have zero "
                                                     r"variance"):
        assert main(["sweep", str(f), "--map", cmap, "-m", "cross-correlation", "-c", "p1,p2",
                     "--lags", "1", "--windows", "100", "--mode", "grid", "--onset", "1",
                     "--chunk", "2", "--min-chunks", "1", "--no-figures",
                     "-o", str(tmp_path / "sw2")]) == 0
    t = pd.read_csv(tmp_path / "sw2" / "sweep.csv")
    rec = read_with(str(f), column_map_from(cmap, (), None), None, None)
    for r in t.itertuples(index=False):
        assert [getattr(r, c) for c in COUNTS] == rms_change_counts(
            rec, "cross-correlation", "p1,p2", 1, 100, r.overlap, 1.0, 2)
    assert t.loc[0, ["n_chunks_straddling", "n_chunks_empty", "n_nan_windows"]].tolist() == [
        0, 6, 13]


# ------------------------------------------ audit of the commands' options, 2026-11-27
@pytest.mark.parametrize("args, message", [
    (["--windows", "0"], "Error: Invalid value for '--windows': 0: a window must be >= 2 samples"),
    (["--windows", "-100"],
     "Error: Invalid value for '--windows': -100: a window must be >= 2 samples"),
    (["--windows", "100,1"],
     "Error: Invalid value for '--windows': 1 in '100,1': a window must be >= 2 samples"),
    (["--windows", ""],
     "Error: Invalid value for '--windows': '' is an empty list; give e.g. 100:800:100"),
    (["--windows", "400:100:100"],
     "Error: Invalid value for '--windows': range '400:100:100' is empty (start > stop)"),
    (["--lags", "0"], "Error: Invalid value for '--lags': 0: lag=0 must be >= 1"),
    (["--lags", "1,-2"], "Error: Invalid value for '--lags': -2 in '1,-2': lag=-2 must be >= 1"),
    (["--lags", ","], "Error: Invalid value for '--lags': ',' is an empty list; give e.g. "
                      "1,2,4,8"),
    (["-m", "metric-length", "--lags", "0:3"], "Error: Invalid value for '--lags': '0:3': "
                                               "lag_ratio='0:3' needs l > k >= 1, got l=0, k=3"),
    (["--overlaps", "100"],
     "Error: Invalid value for '--overlaps': 100.0: an overlap must be in [0, 100) percent"),
    (["--overlaps", "5,nan"],
     "Error: Invalid value for '--overlaps': nan in '5,nan': an overlap must be in [0, 100) "
     "percent"),
    (["--lags", "1,200", "--windows", "100,300"],
     "Error: Invalid value for '--lags': 200 does not fit window 100 (the smallest of "
     "--windows): in ofat mode every lag must be smaller than every window (the chosen lag is "
     "held while the window varies)"),
    (["--lags", "1000", "--windows", "100,300", "--mode", "grid"],
     "Error: Invalid value for '--lags': no value of '1000' is smaller than a window of "
     "'100,300': no setting to compute"),
    (["--chunk", "0"], "Error: Invalid value for '--chunk': 0 is not in the range x>=1."),
    (["--min-chunks", "0"], "Error: Invalid value for '--min-chunks': 0 is not in the range "
                            "x>=1."),
    (["--tolerance", "-1"], "Error: Invalid value for '--tolerance': -1.0 is not in the range "
                            "x>=0."),
    (["--tolerance", "nan"], "Error: Invalid value for '--tolerance': nan is not a finite "
                             "number."),
])
def test_sweep_refuses_bad_settings_before_reading_the_file(tmp_path, capsys, args, message):
    """`--windows 0` printed an empty table, then "no setting meets the rule ... 0 row(s)".
    The settings are checked before FILE is read: a missing file is not even looked at."""
    code = main(["sweep", str(tmp_path / "never-read.csv"), "-c", "p1", "--onset", "1",
                 *args])
    err = capsys.readouterr()
    assert code == 2 and err.out == "" and "Traceback" not in err.err
    assert err.err.splitlines()[-1] == message


# ------------------------------------------ audit of sweep, sensitivity, analyze, 2026-11-27
def test_sweep_figure_titles_name_the_default_channels(tmp_path, monkeypatch):
    """Without -c the % change figures were titled 'autocorrelation None: ...'."""
    import leakdiag.report.study_plots as study_plots

    titles = []
    plot = study_plots.plot_pct_vs_parameter

    def spy(*args, **kwargs):
        titles.append(kwargs["title"])
        return plot(*args, **kwargs)

    monkeypatch.setattr(study_plots, "plot_pct_vs_parameter", spy)
    path = tmp_path / "rec.csv"
    ar_recording().to_pandas().to_csv(path, index=False)
    assert main(["sweep", str(path), "--mode", "grid", "--lags", "1,3", "--windows", "60,120",
                 "--overlaps", "5", "--onset", "30", "--chunk", "5", "-o",
                 str(tmp_path / "o")]) == 0
    assert titles == [f"autocorrelation p1: % change against {v}"
                      for v in ("lag", "window", "overlap")]


def test_a_sweep_over_an_earlier_one_removes_its_figures_only(tmp_path, capsys):
    """A grid run's heatmap and panels stayed beside a later --no-figures run's table (an
    audit helper, 2026-11-27); files that are not sweep figures are kept."""
    path = tmp_path / "rec.csv"
    ar_recording().to_pandas().to_csv(path, index=False)
    o = tmp_path / "o"
    args = ["sweep", str(path), "--mode", "grid", "--lags", "1,3", "--windows", "60,120",
            "--overlaps", "5,25", "--onset", "30", "--chunk", "5", "-o", str(o)]
    assert main(args) == 0
    figs = {"grid_heatmap.png", "panels_lag.png", "panels_window.png", "panels_overlap.png",
            "pct_vs_lag.png", "pct_vs_window.png", "pct_vs_overlap.png"}
    assert figs <= {p.name for p in o.iterdir()}
    (o / "notes.png").write_bytes(b"mine")
    capsys.readouterr()
    assert main(args + ["--no-figures"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert {p.name for p in o.iterdir()} == {"sweep.csv", "sweep.parquet", "notes.png"}
    assert out[-1] == (f"removed {', '.join(sorted(figs))} from {o}/ (an earlier sweep's "
                       "figures, which this run did not draw)")


@pytest.mark.parametrize("windows, which", [("100,1000000", "window 1000000"),
                                            ("1000000,100", "window 1000000"),
                                            ("8000,100,7000", "windows 8000 and 7000")])
def test_ofat_sweep_refuses_a_window_longer_than_the_recording(tmp_path, capsys, windows, which):
    """ofat dropped window 1000000 without a word ('8 settings'); held first, it emptied the
    lag stage and the error blamed --min-chunks and --onset."""
    path = tmp_path / "rec.csv"
    ar_recording().to_pandas().to_csv(path, index=False)  # 6000 samples
    code = main(["sweep", str(path), "-c", "p1", "--windows", windows, "--no-figures"])
    err = capsys.readouterr()
    verb = "are" if "and" in which else "is"
    assert code == 2 and err.out == ""
    assert err.err == (f"leakdiag: error: {path}: {which} of --windows {windows!r} {verb} "
                       "longer than the recording (6000 samples): in ofat mode every window is "
                       "computed (the first is held while the lag varies) and none is skipped; "
                       "give windows of at most 6000 samples\n")


@pytest.mark.parametrize("lags, windows, said", [
    ("1", "60,1000000", "1 settings (grid); 1 of 2 skipped: window 1000000 is longer than the "
                        "recording (6000 samples)"),
    ("1,80", "60,7000,8000", "1 settings (grid); 5 of 6 skipped: 1 with a lag not smaller than "
                             "its window, 4 with windows 7000 and 8000 longer than the "
                             "recording (6000 samples)"),
    ("80", "60,7000", "error: {path}: no setting to compute: the lags of --lags '80' fit only "
                      "window 7000 of --windows '60,7000', longer than the recording (6000 "
                      "samples)"),
    ("1", "7000,8000", "error: {path}: every window of --windows '7000,8000' is longer than the "
                       "recording (6000 samples): no setting to compute; give windows of at "
                       "most 6000 samples"),
])
def test_grid_sweep_names_why_it_skipped_settings(tmp_path, capsys, lags, windows, said):
    path = tmp_path / "rec.csv"
    ar_recording().to_pandas().to_csv(path, index=False)
    code = main(["sweep", str(path), "-c", "p1", "--lags", lags, "--windows", windows,
                 "--overlaps", "0", "--mode", "grid", "--onset", "30", "--chunk", "5",
                 "--no-figures"])
    err = capsys.readouterr()
    if said.startswith("error"):
        assert code == 2 and err.err == f"leakdiag: {said.format(path=path)}\n"
    else:
        assert code == 0 and err.out.splitlines()[0].endswith(said)


def test_ofat_sweep_function_refuses_a_window_longer_than_the_recording():
    from leakdiag.studies.sweep import ofat_sweep

    rec = ar_recording()
    with pytest.raises(ValueError, match=r"^window 7000 is longer than the recording \(6000 "
                                         r"samples\): ofat_sweep computes every window \(the "
                                         r"first is held while the lag varies\) and skips none$"):
        ofat_sweep(rec, "autocorrelation", "p1", [1], [100, 7000], [0], onset=30)
    with pytest.raises(ValueError, match="^window 9000 is longer"):
        ofat_sweep(rec, "autocorrelation", "p1", [1], [100], [0], start_window=9000, onset=30)


def test_metric_length_sweep_defaults_to_the_thesis_lag_ratios(tmp_path, capsys):
    """`-m metric-length` without --lags said "'1' in '1,2,4,8': lag_ratio='1' must look like
    'l:k'": the correlations' default. Its own default: Table 5-13's lag ratios."""
    path = tmp_path / "rec.csv"
    ar_recording().to_pandas().to_csv(path, index=False)
    assert main(["sweep", str(path), "-m", "metric-length", "--windows", "100,200",
                 "--overlaps", "5", "--onset", "30", "--chunk", "5", "--no-figures",
                 "-o", str(tmp_path / "o")]) == 0
    t = pd.read_csv(tmp_path / "o" / "sweep.csv")
    assert t.loc[t.varied == "lag", "lag_ratio"].tolist() == [
        "83:3", "57:3", "43:3", "28:3", "23:3", "16:3"]
    assert main(["sweep", str(path), "-m", "metric-length", "--windows", "50"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "Error: Invalid value for '--lags': 83:3 (the default --lags of metric-length) does not "
        "fit window 50 (the smallest of --windows): in ofat mode every lag must be smaller than "
        "every window (the chosen lag is held while the window varies)")
