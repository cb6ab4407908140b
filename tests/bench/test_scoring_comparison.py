"""Scoring and the literature comparison: hand-computed rates, all-error runs, the target
guard."""

import math

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
    # Poisson: -ln(1 - 0.5) / (1/60 h) = 60 ln 2 = 41.5888 per hour (the full 65 s gave 38.39)
    r = summarise(_runs(65.0, [True, False])).iloc[0]
    assert r.false_alarm_rate == 0.5
    assert r.false_alarms_per_hour == pytest.approx(60 * math.log(2), rel=1e-12)
    assert r.false_alarms_per_hour == pytest.approx(41.58883083359672, rel=1e-12)
    # the inverse of the conversion that set the thresholds' targets
    assert per_run_target_per_hour(0.5, 65.0, 5.0) == pytest.approx(r.false_alarms_per_hour)
    # another burn-in: 65 - 15 = 50 s
    r = summarise(_runs(65.0, [True, False]), burn_in_s=15.0).iloc[0]
    assert r.false_alarms_per_hour == pytest.approx(72 * math.log(2), rel=1e-12)
    # none alarmed: 0 per hour
    assert summarise(_runs(65.0, [False, False])).iloc[0].false_alarms_per_hour == 0.0
