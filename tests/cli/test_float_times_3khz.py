"""A time column on no decimal grid (3 kHz times written as binary floats, i / 3000): the
streamed readers' time check looked for the times' print resolution in every block, found none
(0.0) and divided by it, so `leakdiag monitor` of such a Parquet file, of the same CSV printed
at full precision, of those lines on stdin, and `leakdiag batch` of it stopped with a bare
ZeroDivisionError (found 2026-11-27 by a reference test of the block check; the whole-file
reader of detect and analyze had the guard). A jittered block is still refused, naming its
row."""

import numpy as np
import pandas as pd
import pytest


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("f3k")
    n = 30000
    t = np.arange(n) / 3000.0
    rng = np.random.default_rng(3)
    df = pd.DataFrame({"time": t, "p1": rng.normal(size=n).cumsum() * 0.01
                       + rng.normal(size=n)})
    df.to_parquet(d / "r3k.parquet")
    df.to_csv(d / "r3k.csv", index=False, float_format="%.17g")
    bad = df.copy()
    bad.loc[20000, "time"] += 0.3 / 3000.0  # 30 % of an interval at data row 20000
    bad.to_parquet(d / "bad.parquet")
    (d / "job.toml").write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n'
                                'lag = 1\nwindow = 200\noverlap = 5\n')
    return d


@pytest.mark.parametrize("name", ["r3k.parquet", "r3k.csv"])
def test_monitor_reads_a_3khz_file_with_float_times(run_cli, files, name):
    code, out, err = run_cli(["monitor", str(files / name), "--chunk", "1000"])
    assert code == 0, err
    assert f"{name}: 30000 samples at 3000 Hz, 157 windows" in out + err


def test_monitor_reads_float_times_on_stdin(run_cli, files):
    text = (files / "r3k.csv").read_text()
    code, out, err = run_cli(["monitor", "-", "--channels", "p1"], stdin=text)
    assert code == 0, err
    assert "30000 samples at 3000 Hz, 157 windows" in out + err


def test_batch_reads_a_3khz_file_with_float_times(run_cli, files, tmp_path):
    code, out, err = run_cli(["batch", str(files / "r3k.parquet"), "--config",
                              str(files / "job.toml"), "-o", str(tmp_path / "out")])
    assert code == 0, out + err
    assert "ZeroDivisionError" not in out + err


def test_a_jittered_row_is_still_refused_by_name(run_cli, files):
    code, out, err = run_cli(["monitor", str(files / "bad.parquet"), "--chunk", "1000"])
    assert code != 0
    assert "bad.parquet: row 20000: time" in err and "jitter" in err, err
