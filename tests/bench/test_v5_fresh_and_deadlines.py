"""A final measurement on fresh seeds (``--first-index``), and detection by a deadline as the
user knows it then (benchmark audit 2026-11-28, findings 3, 4 and 6).

The audit found the per-unit benchmark's held-out indexes used in development (refusal
constants set on healthy indexes 10-24, a fix diagnosed on a judged leaking run), and "detected
within 10 s" read from a whole-recording verdict that used data after the deadline (3 of 64
runs got no verdict when cut at onset + 10 s).
"""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.bench.v5_common import deadline_alarms
from leakdiag.bench.v5_scoring import detection_table
from leakdiag.bench.v5_suite import V5_QUICK_SUITES, V5_SUITES, build_v5_suite


def test_first_index_takes_a_fresh_block_of_held_out_seeds():
    base = V5_QUICK_SUITES["vca"]
    old = build_v5_suite({"vca": base})
    new = build_v5_suite({"vca": replace(base, first_test_index=1000)})
    cal_old = [c.seed for c in old if c.role == "cal"]
    assert cal_old == [c.seed for c in new if c.role == "cal"]  # the same training units
    for role in ("test_healthy", "test_leak"):
        o = [c for c in old if c.role == role]
        n = [c for c in new if c.role == role]
        assert len(o) == len(n)
        assert [c.seed for c in n] == [c.seed + 1000 for c in o]  # seed = ... + index
        assert [c.nuisance["index"] for c in n] == [c.nuisance["index"] + 1000 for c in o]
        assert [c.nuisance["position"] for c in n] == [c.nuisance["index"] for c in o]
        assert not {c.seed for c in n} & {c.seed for c in old}
    with pytest.raises(ValueError, match="overlap the seeds of the next size"):
        build_v5_suite({"vca": replace(V5_SUITES["vca"], first_test_index=9990)})


def test_detection_by_a_deadline_is_the_verdict_on_the_run_cut_there():
    runs = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
                         "excitation": "operating", "role": "test_leak", "leak_lpm": 0.01,
                         "onset_true_s": 20.0, "alarm": [True, True, True],
                         "alarm_time_s": [24.0, 25.0, 26.0], "onset_est_s": [20.0, 21.0, 22.0],
                         "alarm_by_10s": [True, False, None],  # None: not judged cut (whole)
                         "alarm_by_5s": [True, False, None]})
    r = detection_table(runs, deadlines=(5.0, 10.0)).iloc[0]
    # whole verdicts: 3 of 3 within 10 s; cut at 30 s the second had no LEAK
    assert int(r["detected_10s"]) == 2 and int(r["detected_5s"]) == 1 + 0 + 0
    assert float(r["onset_error_median_s"]) == 1.0  # runs 1 and 3: errors 0 and 2


@pytest.fixture(scope="module")
def fitted():
    from leakdiag.detect import FlowBalanceDetector

    own = [ld.sim.simulate_vca(duration=20.0, leak_lpm=0.0, load="spring", machine=31, seed=s)
           for s in range(4)]
    det = FlowBalanceDetector(system="vca").fit(own)
    rec = ld.sim.simulate_vca(duration=40.0, leak_lpm=0.05, onset=20.0, load="spring",
                              machine=31, seed=9)
    return det, rec


def test_deadline_alarms_judge_the_cut_recording(fitted):
    det, rec = fitted
    case = SimpleNamespace(role="test_leak", onset_s=20.0)
    got = deadline_alarms(det, rec, case, deadlines=(0.0, 5.0, 30.0))
    for d in (0.0, 5.0):
        v = det.predict(rec.slice_time(None, 20.0 + d))
        assert got[f"alarm_by_{d:g}s"] == (bool(v.leak) and v.alarm_time_s >= 20.0)
    assert got["alarm_by_5s"] is True and got["alarm_by_0s"] is False  # nothing after onset
    assert got["alarm_by_30s"] == bool(det.predict(rec).leak)  # beyond the end: the whole run
    # healthy runs and window detectors (causal alarm times) are not cut
    assert deadline_alarms(det, rec, SimpleNamespace(role="test_healthy", onset_s=None)) == {}
    window = SimpleNamespace(spec=lambda: None, predict=det.predict, threshold_=1.0)
    assert deadline_alarms(window, rec, case) == {}
    assert np.isfinite(det.threshold_)


def test_refused_healthy_runs_are_counted_among_those_without_a_no_leak():
    """Finding 5: a refused healthy run is neither a false alarm nor a NO LEAK; the table now
    also gives the runs without a NO LEAK over all healthy runs (1 alarm + 1 refused of 5)."""
    from leakdiag.bench.v5_scoring import false_alarm_table
    from leakdiag.detect.rates import clopper_pearson

    g = {"method": "m", "system": "vca", "load": "none", "excitation": "operating"}
    runs = pd.DataFrame([{**g, "role": "test_healthy", "alarm": a}
                         for a in (True, False, False, False)] +
                        [{**g, "role": "error", "refused_role": "test_healthy", "alarm": None}])
    r = false_alarm_table(runs).iloc[0]
    assert (r.n_healthy, r.false_alarms, r.n_refused, r.not_clear) == (4, 1, 1, 2)
    assert r.not_clear_rate == 0.4
    assert (r.nc_low, r.nc_high) == pytest.approx(clopper_pearson(2, 5))
