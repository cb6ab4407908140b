"""``leakdiag batch`` warns of a time column whose rate is implausibly high for actuator
pressures (above 200 kHz: seconds read as ms or us), as analyze, detect, fit and monitor do
(audit of users' recordings, 2026-11-27, finding 9)."""

import numpy as np
import pandas as pd

from leakdiag.cli.main import main

JOB = '[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\nwindow = 100\n'


def _csv(path, rate):
    rng = np.random.default_rng(3)
    n = 2000
    pd.DataFrame({"time": np.arange(n) / rate, "p1": 5e6 + 1e4 * rng.standard_normal(n)}) \
        .to_csv(path, index=False, float_format="%.9g")
    return str(path)


def test_batch_warns_of_a_rate_above_200_khz_and_not_of_1_khz(tmp_path, capsys):
    job = tmp_path / "job.toml"
    job.write_text(JOB)
    fast = _csv(tmp_path / "fast.csv", 1e6)  # the time column in us, read as s
    ok = _csv(tmp_path / "ok.csv", 1e3)
    code = main(["batch", fast, ok, "--config", str(job), "--out", str(tmp_path / "r"),
                 "--scheduler", "serial", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 0, err
    warn = [ln for ln in err.splitlines() if "is high for actuator pressures" in ln]
    assert len(warn) == 1 and "fast.csv: sample rate 1e+06 Hz from the time column" in warn[0] \
        and "above 200000 Hz" in warn[0], err
    assert "ok.csv: sample rate" not in err
