"""`leakdiag analyze` end to end on files: table numbers, outputs, errors with exit code 2."""

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
    fs.params.update(window=200, sample_rate=1000.0)
    direct = ld.detect.rms_change(fs, onset=6.0)
    assert verdict.loc[0, "mean_rms_before"] == pytest.approx(direct.mean_rms_before, rel=1e-9)
    assert f"{direct.pct_change:.2f}" in text
    feats = pd.read_parquet(out / "features.parquet")
    np.testing.assert_allclose(feats["value"], fs.values, rtol=1e-12)
    assert (out / "features.png").stat().st_size > 10_000


def test_analyze_all_uses_thesis_settings(run_file, capsys):
    path, _ = run_file
    rec = ld.io.read_recording(path)
    rec.channels["x"] = np.cumsum(rec["p1"] - rec["p1"].mean()) * 1e-9
    rec.channels["u"] = rec["p2"] * 1e-6
    both = path.parent / "full.parquet"
    ld.io.write_recording(rec, both)
    assert main(["analyze", str(both), "--method", "all", "--onset", "6", "--chunk", "4"]) == 0
    rows = [ln.split() for ln in capsys.readouterr().out.splitlines()[2:]]
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
