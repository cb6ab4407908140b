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
                         "window, or a window longer than the recording")
    end = rec.start_time + rec.duration
    code = main(["sweep", str(path), "-c", "p1", "--onset", str(end + 10)])
    assert code == 2
    assert f"onset {end + 10:g} s is outside the recording" in capsys.readouterr().err
