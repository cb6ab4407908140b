"""Sec. 5.2 measure: hand-computed chunk RMS, onset handling, and Eq. 5-3 against the thesis's tables."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.detect import chunk_rms, pct_change, rms_change
from leakdiag.features import FeatureSeries, autocorrelation
from leakdiag.features.windowing import window_first_times, window_times


def _fs(values, window=None, rate=1.0):
    t = np.arange(len(values), dtype=float)
    geometry = {} if window is None else {"window": window, "sample_rate": rate}
    return FeatureSeries(t, np.asarray(values, float), "f", **geometry)


def test_chunk_rms_hand_values():
    rms, n = chunk_rms([3.0, 4.0, 1.0, -1.0, 2.0, 2.0, 7.0], 2)
    np.testing.assert_allclose(rms, [np.sqrt(12.5), 1.0, 2.0])
    assert n.tolist() == [2, 2, 2]


def test_chunk_rms_skips_nan_and_all_nan_chunk():
    rms, n = chunk_rms([np.nan, 2.0, np.nan, np.nan], 2)
    assert rms[0] == 2.0 and np.isnan(rms[1])
    assert n.tolist() == [1, 0]


def test_rms_change_hand_computed():
    # before: chunks [1,1,1] [1,1,1]; after [2,2,2] [4,4,4] -> RMS 1,1 | 2,4
    v = [1, 1, 1, 1, 1, 1, 2, 2, 2, 4, 4, 4]
    res = rms_change(_fs(v), onset=6.0, chunk=3)
    assert res.mean_rms_before == 1.0
    assert res.mean_rms_after == 3.0
    assert res.pct_change_signed == pytest.approx(200.0)
    assert res.pct_change == pytest.approx(200.0)
    assert (res.n_chunks_before, res.n_chunks_after, res.n_chunks_straddling) == (2, 2, 0)


def test_rms_change_negative_change_reported_absolute():
    res = rms_change(_fs([2.0] * 10 + [1.0] * 10), onset=10.0, chunk=5)
    assert res.pct_change_signed == pytest.approx(-50.0)
    assert res.pct_change == pytest.approx(50.0)


def test_straddling_chunks_left_out_and_counted():
    # windows of 4 samples at rate 1: timestamps are last samples; a window with t_last >= onset
    # but t_first < onset straddles.
    v = np.r_[np.ones(8), 3 * np.ones(8)]
    res = rms_change(_fs(v, window=4), onset=8.0, chunk=4)
    # chunk 0: t 0..3 -> before; chunk 1: t 4..7 (all t_last < 8) before; chunk 2: t 8..11 with
    # t_first 5..8 -> straddles; chunk 3: t 12..15, t_first 9..12 -> after
    assert res.chunk_side.tolist() == [-1, -1, 0, 1]
    assert res.n_chunks_straddling == 1
    assert res.mean_rms_after == 3.0


def test_trailing_partial_chunk_dropped():
    res = rms_change(_fs(np.r_[np.ones(10), 2 * np.ones(13)]), onset=10.0, chunk=5)
    assert res.n_windows_dropped == 3 and res.n_chunks_after == 2


def test_no_chunk_after_onset_is_an_error():
    with pytest.raises(ValueError, match="at least one whole chunk on each side"):
        rms_change(_fs(np.ones(10)), onset=100.0, chunk=5)


def test_bad_chunk():
    with pytest.raises(ValueError, match="chunk=0"):
        rms_change(_fs(np.ones(10)), onset=5.0, chunk=0)


def test_pct_change_zero_before_is_nan():
    assert np.isnan(pct_change(0.0, 1.0))


def test_thesis_tables_inconsistent_rows_are_exactly_the_flagged_ones(shared_dir):
    """Recompute Eq. 5-3 from each printed table row's own RMS columns (Sec. 5.2)."""
    t = pd.read_csv(shared_dir / "thesis" / "tables.csv")
    recomputed = np.abs(pct_change(t["mean_rms_before"], t["mean_rms_after"]))
    np.testing.assert_allclose(recomputed, t["pct_change_recomputed"], atol=6e-4)
    disagrees = np.abs(recomputed - t["pct_change_reported"]) > 0.5
    flagged = ~t["consistent"].astype(bool)
    assert flagged.sum() > 0
    assert (disagrees.to_numpy() == flagged.to_numpy()).all(), t.loc[disagrees != flagged, "table"]


def test_all_nan_chunk_counted_as_empty_not_straddling():
    v = np.r_[np.ones(5), np.full(5, np.nan), 2 * np.ones(10)]
    res = rms_change(_fs(v), onset=10.0, chunk=5)
    assert res.chunk_side.tolist() == [-1, 2, 1, 1]
    assert (res.n_chunks_empty, res.n_chunks_straddling, res.n_nan_windows) == (1, 0, 5)
    assert res.pct_change_signed == pytest.approx(100.0)


# ---------------------------------------------------------------- decisions (issue 15, sec. 1)
from leakdiag.detect.measure import decide_change  # noqa: E402


def test_decision_exact_mann_whitney_hand_values():
    # every tested chunk below every reference chunk: U = 0, exact one-sided p = 1 / C(6, 3)
    ref, low = [1.0, 2.0, 3.0], [0.1, 0.2, 0.3]
    d = decide_change(ref, low, false_alarm_rate=0.1, direction="down")
    assert d.decision == "leak" and d.p_value == pytest.approx(1 / 20)
    assert (d.n_reference, d.n_test, d.basis) == (3, 3, "before-after")
    # the same data cannot reach 1 %: the smallest p-value 0.05 is above alpha
    d = decide_change(ref, low, false_alarm_rate=0.01, direction="down")
    assert d.decision == "inconclusive" and "smallest p-value the test can give, 0.05" in d.reason
    # two-sided doubles the smallest p-value: 0.1 is not below 0.1
    assert decide_change(ref, low, false_alarm_rate=0.1).decision == "inconclusive"


def test_decision_opposite_direction_is_inconclusive_and_noise_is_no_leak():
    rng = np.random.default_rng(0)
    ref = rng.normal(1.0, 0.05, 40)
    assert decide_change(ref, rng.normal(1.5, 0.05, 40), direction="down").decision == "inconclusive"
    assert decide_change(ref, rng.normal(1.5, 0.05, 40), direction="up").decision == "leak"
    d = decide_change(ref, rng.normal(1.0, 0.05, 40), direction="down")
    assert d.decision == "no-leak" and d.p_value > 0.01


def test_decision_false_alarm_rate_holds_on_exchangeable_noise():
    # 2000 healthy "runs" of iid chunks: the share reading "leak" is at most alpha (one-sided 5 %)
    rng = np.random.default_rng(1)
    hits = sum(decide_change(rng.standard_normal(30), rng.standard_normal(30),
                             false_alarm_rate=0.05, direction="down").decision == "leak"
               for _ in range(2000))
    # binomial(2000, 0.05): mean 100, sd 9.7; 135 is 3.6 sd above
    assert 60 < hits < 135


def test_decision_rejects_bad_alpha_and_direction():
    with pytest.raises(ValueError, match=r"false_alarm_rate=0.0 must be in \(0, 0.5\]"):
        decide_change([1.0], [2.0], false_alarm_rate=0.0)
    with pytest.raises(ValueError, match="direction='sideways'"):
        decide_change([1.0], [2.0], direction="sideways")


# ------------------------------------------- too few chunks: counts kept, said in words
def test_too_few_chunks_error_keeps_the_counts_and_says_them():
    """rms_change's counts also when it has no measure (sweep rows and analyze reasons use
    them); windows of 4 samples, step 1: window i spans i .. i + 3."""
    from leakdiag.detect.measure import TooFewChunksError

    v = np.r_[np.ones(5), np.full(5, np.nan), 2.0 * np.ones(5)]
    fs = FeatureSeries(np.arange(15.0) + 3, v, "f", window=4, sample_rate=1.0)
    # onset 12: chunk 0 (windows 0-4, last samples 3-7) before; chunk 1 all NaN (empty);
    # chunk 2 (first samples 10-14) straddles 12: nothing after
    with pytest.raises(TooFewChunksError) as info:
        rms_change(fs, onset=12.0, chunk=5)
    assert str(info.value) == (
        "the Sec. 5.2 measure needs at least one whole chunk on each side of the onset (12 s): "
        "got 1 before and 0 after (15 windows, 3 whole chunks of 5: 1 straddling the "
        "onset, 1 of NaN values only (zero-variance windows)); use a smaller chunk (--chunk), "
        "more windows (a smaller window or a larger overlap), or check the onset (--onset)")
    p = info.value.partial
    assert (p.n_chunks_before, p.n_chunks_after, p.n_chunks_straddling, p.n_chunks_empty,
            p.n_windows, p.n_windows_dropped, p.n_nan_windows) == (1, 0, 1, 1, 15, 0, 5)
    assert p.chunk_side.tolist() == [-1, 2, 0] and np.isnan(p.mean_rms_before)
    assert isinstance(info.value, ValueError)  # callers catching ValueError keep working


def test_too_few_chunks_message_for_fewer_windows_than_a_chunk():
    with pytest.raises(ValueError, match=r"got 0 before and 0 after \(6 windows, fewer than "
                                         r"one chunk of 10\)"):
        rms_change(_fs(np.ones(6)), onset=3.0, chunk=10)


def test_decision_with_an_empty_side_says_so_without_numpy_warnings():
    """An empty reference used to print 'Mean of empty slice' and 'invalid value encountered
    in scalar divide' (the lag-1 autocorrelation of no values) and to give 'the smallest
    p-value the test can give, 1' as the reason (warnings are errors in this test suite)."""
    for ref, tst in (([], []), ([], [1.0, 2.0]), ([np.nan, np.nan], [1.0]), ([1.0, 2.0], [])):
        d = decide_change(ref, tst, direction="down")
        n1, n2 = int(np.isfinite(ref).sum()), len(tst)
        assert (d.decision, d.n_reference, d.n_test) == ("inconclusive", n1, n2)
        assert np.isnan(d.p_value) and np.isnan(d.chunk_autocorr)
        assert d.reason == (f"nothing to test ({n1} reference, {n2} tested chunk RMS values): "
                            "the test needs at least one on each side (a chunk of NaN values "
                            "only has none)")


@settings(max_examples=200, deadline=None)
@given(rate=st.sampled_from([100.0, 500.0, 1000.0, 1024.0, 2048.0]),
       window=st.integers(2, 600), first=st.integers(0, 400_000),
       t0=st.sampled_from([0.0, 0.5, 1234.5, -3.0]))
def test_a_window_first_sample_is_placed_where_the_recording_places_that_sample(rate, window,
                                                                                 first, t0):
    """window_first_times with the start time gives start_time + i / fs exactly (the sample's
    own time): subtracting (N-1)/fs from the timestamp could land one rounding below it."""
    t_last = window_times(np.array([first]), window, rate, t0)
    assert window_first_times(t_last, window, rate, t0)[0] == t0 + first / rate


def test_a_window_starting_at_the_onset_sample_counts_after_it():
    """An audit: 1 kHz, N = 100, onset 12.3 s: the window whose first sample is sample 12300
    (t = 12.3 s) had window_start 12.299999999999999 and was dropped as straddling."""
    x = np.random.default_rng(0).normal(size=20000)
    f = autocorrelation(x, lag=1, window=100, overlap=0, sample_rate=1000.0)
    assert f.window_start[123] == 12.3
    r = rms_change(f, 12.3, chunk=1)
    assert (r.n_chunks_before, r.n_chunks_after, r.n_chunks_straddling) == (123, 77, 0)


def test_tied_chunk_values_get_the_exact_permutation_p_value():
    """A statistics audit: with ties SciPy's Mann-Whitney falls back to the normal
    approximation, whose p (0.058 for one tested value below ten tied ones) lies below anything
    a permutation can give (1/11 = 0.091), so the guard's smallest-p rule did not describe the
    test that ran. Tied samples small enough are now enumerated exactly."""
    from scipy.stats import PermutationMethod, mannwhitneyu

    from leakdiag.detect.measure import decide_change

    ref = np.array([1.0] * 5 + [2.0] * 5)
    d = decide_change(ref, np.array([0.5]), false_alarm_rate=0.1, direction="down")
    assert d.p_value == pytest.approx(1 / 11) and d.decision == "leak"  # 0.0909 < 0.1
    d = decide_change(ref, np.array([0.5]), false_alarm_rate=0.09, direction="down")
    assert d.decision == "inconclusive"  # the guard: 1/11 cannot go below 0.09
    rng = np.random.default_rng(4)
    for _ in range(20):  # the same as SciPy's exact permutation test where it applies (n >= 2)
        a = rng.integers(0, 4, 4).astype(float)
        b = rng.integers(0, 4, 7).astype(float)
        for alt, direction in (("less", "down"), ("greater", "up"), ("two-sided", "both")):
            want = mannwhitneyu(a, b, alternative=alt,
                                method=PermutationMethod(n_resamples=np.inf)).pvalue
            got = decide_change(b, a, false_alarm_rate=0.5, direction=direction).p_value
            if got == got:  # a decision with a p-value (not refused by the smallest-p guard)
                assert got == pytest.approx(want)
