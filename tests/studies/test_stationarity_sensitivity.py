"""Stationarity tests (Sec. 4.7 + ADF/KPSS) and the sensitivity summary (Table 5-17)."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.io.recording import Recording
from leakdiag.studies.reproduce import sensitivity_summary
from leakdiag.studies.stationarity import decimate_mean, stationarity, stationarity_tests


def test_decimate_mean_exact():
    y, f = decimate_mean(np.arange(12.0), 5)
    assert f == 3 and y.tolist() == [1.0, 4.0, 7.0, 10.0]
    y, f = decimate_mean(np.arange(4.0), 10)
    assert f == 1 and y.tolist() == [0.0, 1.0, 2.0, 3.0]


def test_verdicts_on_known_processes():
    rng = np.random.default_rng(1)
    assert stationarity_tests(rng.normal(size=3000))["verdict"] == "stationary"
    walk = stationarity_tests(np.cumsum(rng.normal(size=3000)))
    assert walk["verdict"] == "non-stationary" and walk["kpss_p"] <= 0.05
    const = stationarity_tests(np.ones(100))
    assert const["verdict"] == "constant or too short" and np.isnan(const["adf_p"])


def test_stationarity_on_recording_parts():
    rng = np.random.default_rng(2)
    n = 4000
    rec = Recording({"p1": rng.normal(size=n), "u": rng.normal(size=n)}, 100.0,
                    meta={"onset": 20.0})
    out = stationarity(rec, channels=("p1", "u", "x"), window=400, overlap=50)
    assert set(out["moments"]) == {"p1", "u"}
    assert len(out["moments"]["p1"]) == 19  # (4000 - 400) // 200 + 1
    parts = [(r["channel"], r["part"], r["n_points"]) for r in out["tests"]]
    assert parts == [("p1", "whole", 4000), ("p1", "before leak", 2000),
                     ("u", "whole", 4000), ("u", "before leak", 2000)]


def test_sensitivity_summary_ranges_and_thesis_match():
    sens = pd.DataFrame({
        "system": "vca", "method": ["autocorrelation"] * 3 + ["cross-correlation"] * 2,
        "channels": ["p2"] * 3 + ["u,x"] * 2, "leak_lpm": [0.047, 0.1, 0.5, 0.047, 0.5],
        "pct_change": [10.0, 20.0, 40.0, 30.0, np.nan],
        "pct_change_signed": [-10.0, -20.0, -40.0, 30.0, np.nan]})
    s = sensitivity_summary(sens).set_index("channels")
    assert (s.loc["p2", "min_pct"], s.loc["p2", "max_pct"], s.loc["p2", "n_runs"]) == (
        10.0, 40.0, 3)
    assert s.loc["p2", "rho_pct_vs_leak"] == pytest.approx(1.0)
    assert s.loc["p2", "share_falling"] == 1.0
    assert (s.loc["p2", "thesis_min_pct"], s.loc["p2", "thesis_max_pct"]) == (19, 50)
    assert (s.loc["u,x", "thesis_min_pct"], s.loc["u,x", "thesis_max_pct"]) == (20, 63)
    assert s.loc["u,x", "n_runs"] == 1


def test_sensitivity_trend_is_taken_within_each_load_not_pooled():
    """Two loads at different levels, each rising with the leak: pooled, the levels decide the
    ranks (rho 0.45 for every EHA method in the reproduction); within each load it is 1."""
    leaks = [0.77, 0.98, 1.2, 1.4, 1.63]
    sens = pd.DataFrame({
        "system": "eha", "method": "autocorrelation", "channels": "p1",
        "leak_lpm": leaks * 2, "load": ["none"] * 5 + ["spring"] * 5, "duration": 180.0,
        "pct_change": [20.0, 21, 22, 23, 24] + [1.0, 2, 3, 4, 5],
        "pct_change_signed": -1.0})
    from leakdiag.studies.thesis import spearman

    pooled = spearman(sens["leak_lpm"], sens["pct_change"])
    assert abs(pooled) < 0.5  # what the summary used to report
    s = sensitivity_summary(sens).iloc[0]
    assert s["rho_pct_vs_leak"] == pytest.approx(1.0)
    assert s["rho_pct_vs_leak_none"] == pytest.approx(1.0)
    assert s["rho_pct_vs_leak_spring"] == pytest.approx(1.0)
    falls = sens.assign(pct_change=[24.0, 23, 22, 21, 20] + [1.0, 2, 3, 4, 5])
    s = sensitivity_summary(falls).iloc[0]
    assert (s["rho_pct_vs_leak_none"], s["rho_pct_vs_leak_spring"]) == pytest.approx((-1, 1))
    assert s["rho_pct_vs_leak"] == pytest.approx(0.0)
