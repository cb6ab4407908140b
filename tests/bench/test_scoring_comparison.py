"""Scoring and the literature comparison: hand-computed rates, all-error runs, the target
guard."""


import numpy as np
import pandas as pd
import pytest

from leakdiag.bench.run import per_run_target_per_hour
from leakdiag.bench.scoring import summarise


def _runs(duration_s, alarms):
    n = len(alarms)
    return pd.DataFrame({
        "method": "m", "system": "vca", "role": ["test_healthy"] * n + ["test_leak"],
        "leak_lpm": [0.0] * n + [0.5], "score_max": list(range(n)) + [99.0],
        "alarm": list(alarms) + [True], "alarm_time_s": [None] * n + [40.0],
        "onset_true_s": [None] * n + [30.0], "onset_est_s": [None] * n + [30.5],
        "duration_s": duration_s})


def test_false_alarms_per_hour_over_the_monitored_span():
    # 1 of 2 healthy 65-s runs alarmed; the 5-s burn-in is not monitored: 60 s = 1/60 h,
    # one segment per run: 0.5 / (1/60 h) = 30 per hour (Poisson, 60 ln 2 = 41.59, until a
    # statistics audit of 2026-11-29: the fit turns a rate per hour back linearly)
    r = summarise(_runs(65.0, [True, False])).iloc[0]
    assert r.false_alarm_rate == 0.5
    assert r.false_alarms_per_hour == pytest.approx(30.0, rel=1e-12)
    # the inverse of the conversion that set the thresholds' targets
    assert per_run_target_per_hour(0.5, 65.0, 5.0) == pytest.approx(r.false_alarms_per_hour)
    # another burn-in: 65 - 15 = 50 s
    r = summarise(_runs(65.0, [True, False]), burn_in_s=15.0).iloc[0]
    assert r.false_alarms_per_hour == pytest.approx(36.0, rel=1e-12)
    # none alarmed: 0 per hour
    assert summarise(_runs(65.0, [False, False])).iloc[0].false_alarms_per_hour == 0.0


def _error_rows():
    # what run_suite returns when no fit succeeds: one error row per method and group
    msg = ("InsufficientHealthyDataError: 5 healthy maxima of 15 s segments (5 own, 0 "
           "reference) support false-alarm probabilities down to 1/(n+1) = 0.167 per segment")
    return pd.DataFrame([{"method": "fft-p1", "system": "vca", "load": "none",
                          "noise_level": "low", "excitation": exc, "role": "error",
                          "error": msg} for exc in ("operating", "structured")])


def test_summarise_all_error_rows_says_why_instead_of_crashing():
    # before: AttributeError: 'DataFrame' object has no attribute 'alarm'
    with pytest.raises(ValueError, match=r"summarise: no run was judged: all 2 row\(s\) are "
                                         r"errors \(a method that could not be fitted on its "
                                         r"group\); first: fft-p1 on vca none low operating: "
                                         r"InsufficientHealthyDataError: 5 healthy maxima"):
        summarise(_error_rows())


def test_summarise_leaves_error_rows_out_of_the_scores():
    judged = _runs(65.0, [True, False]).assign(excitation="operating")
    mixed = pd.concat([judged, _error_rows()], ignore_index=True)
    r = summarise(mixed)
    assert r.method.tolist() == ["m"] and r.false_alarm_rate.tolist() == [0.5]
    pd.testing.assert_frame_equal(r, summarise(judged))


def test_comparison_target_guard_hand_computed():
    from leakdiag.bench.comparison import (COMPARISON_FAR, COMPARISON_METHODS,
                                           check_comparison_target, comparison_suite)

    # the defaults support their own target: 19 runs, 1 / (19 + 1) = 0.05 per segment
    check_comparison_target(comparison_suite(), COMPARISON_METHODS, COMPARISON_FAR)
    # 1 % per run (one segment) needs 1 / 0.01 - 1 = 99 maxima; 5 runs support 1/6 = 0.167
    with pytest.raises(ValueError, match=r"fits acf-p1's threshold on n_fit=5 healthy runs per "
                                         r"excitation \(vca\), one CUSUM maximum each: they "
                                         r"support a false-alarm target of at least 0\.167 per "
                                         r"run, and false_alarm_per_run=0\.01 needs n_fit=99; "
                                         r"give n_fit=99 or false_alarm_per_run >= 0\.17"):
        check_comparison_target(comparison_suite(n_fit=5), COMPARISON_METHODS, 0.01)
    # the EKF has fit-time learning of its own (_fit_features) but the common threshold: checked
    with pytest.raises(ValueError, match="fits ekf's threshold on n_fit=5"):
        check_comparison_target(comparison_suite(n_fit=5), ["ekf"], 0.05)
    with pytest.raises(ValueError, match=r"false_alarm_per_run=1\.0 must be in \(0, 1\)"):
        check_comparison_target(comparison_suite(), ["ekf"], 1.0)


def test_run_comparison_refuses_an_unsupported_target_before_simulating(monkeypatch):
    import leakdiag.bench.run as run
    from leakdiag.bench.comparison import run_comparison

    def no_work(*a, **k):
        raise AssertionError("simulated before checking the target")

    monkeypatch.setattr(run, "run_suite", no_work)
    with pytest.raises(ValueError, match="needs n_fit=99"):
        run_comparison(["fft-p1"], false_alarm_per_run=0.01, n_fit=5)


def test_comparison_table_rows_from_results_and_summary():
    from leakdiag.bench.comparison import comparison_table, table_markdown

    res = pd.DataFrame({"method": ["a"] * 3 + ["b"] * 3, "excitation": "operating",
                        "leak_lpm": [0.05, 0.2, 1.0] * 2, "auc": [0.6, 0.8, 1.0, 0.5, 0.5, 0.7],
                        "detection_rate": [0.0, 0.4, 1.0, 0.0, 0.0, 0.2],
                        "onset_error_median_s": [np.nan, 2.0, 0.5, np.nan, np.nan, 4.0],
                        "detection_delay_median_s": [np.nan, 8.0, 1.5, np.nan, np.nan, 30.0],
                        "n_runs": 5, "detections": [0, 2, 5, 0, 0, 1]})
    summ = pd.DataFrame({"method": ["a", "b"], "excitation": "operating",
                         "min_detectable_lpm": [1.0, np.nan], "false_alarms": [0, 2],
                         "n_test_healthy": [10, 10], "cpu_s_per_hour": [0.03, 38.5]})
    t = comparison_table(res, summ)
    # every rate with its count and 95 % Clopper-Pearson interval (a statistics audit,
    # 2026-11-30): 5/5 -> [(0.025)^(1/5), 1], 0/10 -> [0, 1 - 0.025^(1/10)]
    assert t["AUC 0.05"].tolist() == [0.6, 0.5]
    assert t["det 1.0 [95 % CI]"].tolist() == ["5/5 = 1 [0.478, 1]",
                                               "1/5 = 0.2 [0.00505, 0.716]"]
    assert t["false alarms [95 % CI]"].tolist() == ["0/10 = 0 [0, 0.308]",
                                                    "2/10 = 0.2 [0.0252, 0.556]"]
    assert f"{0.025 ** (1 / 5):.3g}" == "0.478" and f"{1 - 0.025 ** (1 / 10):.3g}" == "0.308"
    lines = table_markdown(t).splitlines()
    assert lines[2] == ("| a | operating | 1 | 0.6 | 0.8 | 1 | 2/5 = 0.4 [0.0527, 0.853] | "
                        "5/5 = 1 [0.478, 1] | 0.5 | 1.5 | 0/10 = 0 [0, 0.308] | 0.03 |")
    # results written before the detections' count: the count from the rate and the runs
    old = comparison_table(res.drop(columns=["detections"]), summ)
    assert old["det 1.0 [95 % CI]"].tolist() == t["det 1.0 [95 % CI]"].tolist()
    assert lines[3] == ("| b | operating |  | 0.5 | 0.5 | 0.7 | 0/5 = 0 [0, 0.522] | "
                        "1/5 = 0.2 [0.00505, 0.716] | 4 | 30 | 2/10 = 0.2 [0.0252, 0.556] | 38.5 |")
