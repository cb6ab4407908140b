"""Sample rates estimated from time columns carry the timestamps' jitter: every command compares
rates within io's 0.1 % (``io.checks.same_rate``), as a time column and a given rate are
compared (audit of users' recordings, 2026-11-27, finding 6: sub-microsecond jitter gave
1000.000067 Hz, and fit, detect, analyze --healthy and monitor FILE refused it as "sample rate
1000 Hz differs from 1000 Hz", while monitor on stdin judged the same file)."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.io.checks import SAME_RATE_RTOL, infer_sample_rate, same_rate


def _csv(rec, path, jitter_s=0.0, seed=0, rate=1000.0):
    t = np.arange(rec.n_samples) / rate
    t = t + np.random.default_rng(seed).uniform(-jitter_s, jitter_s, len(t))
    pd.DataFrame({"time": t, "p1": rec["p1"], "p2": rec["p2"]}).to_csv(
        path, index=False, float_format="%.7f")
    return str(path)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from leakdiag.sim import simulate_vca

    d = tmp_path_factory.mktemp("jitter")
    runs = [simulate_vca(duration=20.0, leak_lpm=None, seed=40 + s) for s in range(4)]
    return {"exact": [_csv(r, d / f"h{i}.csv") for i, r in enumerate(runs[:3])],
            "jittered": [_csv(r, d / f"j{i}.csv", 4e-7, seed=i) for i, r in enumerate(runs[:3])],
            "judged": _csv(runs[3], d / "judged.csv", 4e-7, seed=9),
            "other_rate": _csv(runs[3], d / "r1002.csv", rate=1002.0), "dir": d}


def test_jittered_rates_are_one_rate_but_other_rates_are_not(files):
    t = pd.read_csv(files["judged"])["time"].to_numpy()
    rate = infer_sample_rate(t)
    assert rate != 1000.0 and abs(rate / 1000.0 - 1) < 1e-6  # the jitter moves the estimate
    assert same_rate(rate, 1000.0) and SAME_RATE_RTOL == 1e-3
    assert not same_rate(1002.0, 1000.0)


def test_fit_detect_and_monitor_take_jittered_timestamps(run_cli, files, tmp_path):
    h = [a for p in files["jittered"] for a in ("--healthy", p)]
    det = tmp_path / "j.joblib"
    code, out, err = run_cli(["fit", *h, "-m", "acf-p1", "--system", "vca", "--false-alarm-rate",
                              "100", "-o", str(det)])
    assert code == 0, err  # was: "sample rate 1000 Hz differs from ... 1000 Hz"
    code, out, err = run_cli(["fit", *[a for p in files["exact"] for a in ("--healthy", p)], "-m",
                              "acf-p1", "--system", "vca", "--false-alarm-rate", "100", "-o",
                              str(tmp_path / "e.joblib")])
    assert code == 0, err
    for d in (det, tmp_path / "e.joblib"):  # a detector of exact or jittered files, alike
        code, out, err = run_cli(["detect", files["judged"], "--detector", str(d),
                                  "--no-progress"])
        assert code == 0 and "Decision:" in out, err
        code, out, err = run_cli(["monitor", "--input", files["judged"], "--detector", str(d)])
        assert code == 0, err
    code, out, err = run_cli(["analyze", files["judged"], "--healthy", files["jittered"][0],
                              "-m", "autocorrelation", "-c", "p1"])
    assert code == 0, err
    # a rate 0.2 % off is another rate: refused by name
    code, out, err = run_cli(["detect", files["other_rate"], "--detector", str(det),
                              "--no-progress"])
    assert code == 2 and "sample rate 1002 Hz, but" in err and "fitted at 1000 Hz" in err, err
