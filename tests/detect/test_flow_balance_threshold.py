"""FlowBalanceDetector thresholds: conformal from out-of-fold maxima when supported, else model.

The conformal level must be exactly the k-th largest of the out-of-fold GLR segment maxima
(recomputed here by hand from two half-fits), pool reference maxima only when they were made
with the same statistic, and the p-value reported as ``confidence`` must be small for a leak and
large for a healthy run (the ``Verdict.confidence`` convention of every detector).
"""

import math

import numpy as np
import pytest
from sklearn.base import clone

import leakdiag as ld
from _detect_helpers import healthy_vca
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect.flow_balance import glr_segment_maxima
from leakdiag.detect.threshold import ReferenceMaxima

DURATION_S = 20.0


@pytest.fixture(scope="module")
def healthy():
    return healthy_vca(6, DURATION_S)


@pytest.fixture(scope="module")
def seg(healthy):
    """Segment (s) of these runs: their monitored windows after the burn-in, times window_s."""
    det = FlowBalanceDetector(system="vca").fit(healthy)
    n_win = {len(det.score(r).values) for r in healthy}
    assert len(n_win) == 1  # equal runs: one segment each
    assert det.threshold_basis_.segment_s == n_win.pop() * det.window_s
    return det.threshold_basis_.segment_s


def _out_of_fold_maxima(det, recs):
    """Two-fold maxima by hand: fit on the even/odd runs, GLR maxima of the other half."""
    out = {}
    for fit_idx, judge_idx in (((0, 2, 4), (1, 3, 5)), ((1, 3, 5), (0, 2, 4))):
        half = clone(det).fit([recs[i] for i in fit_idx])
        for i in judge_idx:
            out[i] = half.segment_maxima([recs[i]])
    return np.concatenate([out[i] for i in range(len(recs))])


def test_segment_maxima_by_hand():
    g = [0.5, 2.0, 1.0, 4.0, 3.0, 7.0, 9.0]
    assert glr_segment_maxima(g, 3).tolist() == [2.0, 7.0]  # the 7th window is left out
    assert glr_segment_maxima(g, 8).tolist() == []  # no complete segment
    with pytest.raises(ValueError, match="per_segment"):
        glr_segment_maxima(g, 0)


def test_conformal_level_is_the_kth_largest_out_of_fold_maximum(healthy, seg):
    # one segment per run (equal runs); 6 out-of-fold maxima support alpha >= 1/7 per segment;
    # alpha = 0.3 per segment gives k = floor(0.3 * 7) = 2
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=0.3 * 3600.0 / seg)
    det.fit(healthy)
    b = det.threshold_basis_
    assert b.method == "conformal" and b.supported
    assert (b.n, b.n_own, b.n_reference, b.k) == (6, 6, 0, 2)
    by_hand = np.sort(_out_of_fold_maxima(FlowBalanceDetector(system="vca"), healthy))[::-1]
    assert det.threshold_ == pytest.approx(by_hand[1], rel=1e-12)
    assert b.bound_per_segment == pytest.approx(2 / 7)
    assert "= the 2nd largest of 6 healthy GLR maxima (6 own; 17-s segments)" in str(b)
    # the model-based level is kept beside it, and is what a too-small target falls back to
    assert det.alarm_threshold_.threshold > 0


def test_too_few_maxima_fall_back_to_the_model_level_and_say_so(healthy, seg):
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=1.0).fit(healthy)
    b = det.threshold_basis_
    assert b.method == "glr-model" and not b.supported and b.k == 0
    assert det.threshold_ == det.alarm_threshold_.threshold
    assert b.min_n_for_target == math.ceil(3600.0 / seg) - 1  # 1/h over 17 s segments: 211
    assert "NOT distribution-free: 6 healthy GLR maxima" in str(b)
    assert "the requested 1 false alarm(s) per hour needs at least 211 maxima" in str(b)


def test_reference_maxima_are_pooled_and_checked(healthy, seg):
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=0.05 * 3600.0 / seg)
    ref_values = np.linspace(1.0, 5.0, 60)
    ref = ReferenceMaxima(ref_values, seg, 0.0, det.reference_direction(), det.burn_in_s,
                          "test units", 60)
    det.fit(healthy[:2], reference_maxima=ref)  # 2 own runs: no out-of-fold maxima
    b = det.threshold_basis_
    assert b.method == "conformal" and (b.n_own, b.n_reference) == (0, 60)
    k = math.floor(0.05 * 61)
    assert b.k == k and det.threshold_ == pytest.approx(np.sort(ref_values)[::-1][k - 1])
    other = ReferenceMaxima(ref_values, seg, 0.0, "glr(window_s=2, max_span_s=30, "
                            "leak_law=turbulent)", det.burn_in_s)
    with pytest.raises(ValueError, match="direction"):
        clone(det).fit(healthy[:2], reference_maxima=other)
    with pytest.raises(ValueError, match="segment_s"):
        clone(det).fit(healthy[:2], reference_maxima=ReferenceMaxima(
            ref_values, 2 * seg, 0.0, det.reference_direction(), det.burn_in_s))
    with pytest.raises(TypeError, match="ReferenceMaxima"):
        clone(det).fit(healthy[:2], reference_maxima=list(ref_values))


def test_confidence_picks_the_calibration_conditional_rank_or_says_what_it_needs(healthy, seg):
    # 5 % per segment over 60 reference maxima: marginal k = floor(0.05 * 61) = 3; at 80 %
    # confidence the largest k with P(Bin(60, 0.05) <= k - 1) <= 0.2 is 2 (0.046, 0.19, 0.42)
    ref_values = np.linspace(1.0, 5.0, 60)
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=0.05 * 3600.0 / seg,
                              confidence=0.8)
    ref = ReferenceMaxima(ref_values, seg, 0.0, det.reference_direction(), det.burn_in_s,
                          "test units", 60)
    det.fit(healthy[:2], reference_maxima=ref)
    b = det.threshold_basis_
    assert b.method == "conformal" and b.k == 2 and b.confidence == 0.8
    assert det.threshold_ == pytest.approx(np.sort(ref_values)[::-1][1])
    assert "with probability 80 % over the healthy data" in str(b)
    # at 99 % confidence 60 maxima are too few (0.95^60 = 0.046 > 0.01): the model level, and
    # the number of maxima the request needs, ceil(log 0.01 / log 0.95) = 90
    hi = clone(det).set_params(confidence=0.99).fit(healthy[:2], reference_maxima=ref)
    assert hi.threshold_basis_.method == "glr-model"
    assert hi.threshold_basis_.min_n_for_target == 90
    with pytest.raises(ValueError, match="confidence"):
        clone(det).set_params(confidence=1.5).fit(healthy[:2], reference_maxima=ref)


@pytest.mark.parametrize("rate_per_segment", [0.3, None])
def test_confidence_is_a_p_value_small_for_a_leak(healthy, seg, rate_per_segment):
    per_hour = 1.0 if rate_per_segment is None else rate_per_segment * 3600.0 / seg
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=per_hour).fit(healthy)
    ok = det.predict(ld.sim.simulate_vca(duration=DURATION_S, leak_lpm=0.0, load="spring",
                                         machine=31, seed=50))
    leak = det.predict(ld.sim.simulate_vca(duration=DURATION_S, leak_lpm=0.1, onset=8.0,
                                           load="spring", machine=31, seed=51))
    assert leak.leak and not ok.leak
    assert 0.0 <= leak.confidence < ok.confidence <= 1.0
    if det.threshold_basis_.supported:
        # conformal p-value: never below the resolution 1/(n+1) of the healthy maxima
        assert leak.confidence == pytest.approx(1 / 7)
    else:
        assert leak.confidence < 1e-3 and ok.confidence > 0.05


def test_detector_saved_before_threshold_bases_still_judges(healthy):
    """A detector file written before ``threshold_basis_`` existed keeps its model level and
    reports the model-based p-value."""
    import pickle

    det = FlowBalanceDetector(system="vca").fit(healthy[:4])
    old = pickle.loads(pickle.dumps(det))
    for name in ("threshold_basis_", "segment_windows_"):
        del old.__dict__[name]
    old.threshold_ = old.alarm_threshold_.threshold
    rec = ld.sim.simulate_vca(duration=DURATION_S, leak_lpm=0.1, onset=8.0, load="spring",
                              machine=31, seed=51)
    v_old, v_new = old.predict(rec), det.predict(rec)
    assert v_old.leak and v_old.threshold == det.alarm_threshold_.threshold
    assert v_old.confidence == pytest.approx(v_new.confidence)  # both model-based here


def test_a_per_run_target_needs_the_runs_segment_not_its_complete_windows(healthy, seg):
    """Benchmark v5 states 1 % per run and converts it to per hour with the run's monitored
    span (duration - burn-in); the windows cover a window less (the last, incomplete one). With
    the window segment the per-run target shrinks below what the maxima support and the level
    falls back to the model; with ``segment_s`` = the monitored span it is conformal."""
    span = DURATION_S - 2.0  # default burn-in 2 s: 18 s monitored, 17 complete windows
    assert seg == span - 1.0
    per_hour = (1 / 7) * 3600.0 / span  # 1/7 per run: k = 1 of the 6 out-of-fold maxima
    windows = FlowBalanceDetector(system="vca", false_alarms_per_hour=per_hour).fit(healthy)
    assert windows.threshold_basis_.method == "glr-model"  # alpha = (1/7) 17/18: k = 0
    runs = FlowBalanceDetector(system="vca", false_alarms_per_hour=per_hour,
                               segment_s=span).fit(healthy)
    b = runs.threshold_basis_
    assert b.method == "conformal" and (b.n, b.k, b.segment_s) == (6, 1, span)
    by_hand = _out_of_fold_maxima(FlowBalanceDetector(system="vca", segment_s=span), healthy)
    assert runs.threshold_ == pytest.approx(by_hand.max(), rel=1e-12)
    # one segment per run holds every monitored window: the same maxima as the window segment
    assert by_hand == pytest.approx(_out_of_fold_maxima(FlowBalanceDetector(system="vca"),
                                                        healthy), rel=1e-12)


def test_segment_s_bins_windows_by_their_end_time(healthy):
    det = FlowBalanceDetector(system="vca", segment_s=9.0).fit(healthy[:2])
    rec = healthy[3]
    g = det.score(rec)
    rel = g.time - (rec.start_time + det.burn_in_s)
    by_hand = [g.values[rel < 9.0].max(), g.values[(rel >= 9.0) & (rel < 18.0)].max()]
    assert det.segment_maxima([rec]).tolist() == by_hand  # 18 s monitored: 2 segments of 9 s
    assert det.threshold_basis_.segment_s == 9.0
    with pytest.raises(ValueError, match="segment_s"):
        FlowBalanceDetector(system="vca", segment_s=0.0).fit(healthy[:2])


def test_a_model_level_is_never_below_the_largest_out_of_fold_healthy_maximum():
    # a statistics audit (2026-11-30): the one-segment model level had no floor at M_(1), the
    # largest out-of-fold healthy GLR maximum, though the run level had one; unit 321 (no
    # load, 3 per hour, 4 runs) sat at 3.41 below its maxima's 3.66, and 20 of 100 held-out
    # healthy runs crossed it against 9.8 % promised (15 of 100 at the floor: the model is
    # off for this unit, and 4 runs cannot show a 9.8 % rate; docs/detect.md 8.4)
    runs = [ld.sim.simulate_vca(duration=120, leak_lpm=0.0, load="none", machine=321,
                                seed=321000 + i) for i in range(4)]
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=3.0).fit(runs)
    b = det.threshold_basis_
    assert b.method == "glr-model" and len(b.maxima) == 4
    assert det.alarm_threshold_.threshold < float(np.max(b.maxima)) == det.threshold_
    assert det.threshold_ == pytest.approx(3.66, abs=0.01)
