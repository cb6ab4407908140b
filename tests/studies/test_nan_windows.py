"""Undefined (NaN) windows per side of the onset and the NaN-as-0 sensitivity (thesis audit
2026-11-28, F1: the reproduction skipped them silently; after the leak the VCA's quantised
position stood still in ~4 times as many U-X windows as before)."""

import numpy as np
import pytest

from leakdiag.detect.measure import rms_change
from leakdiag.features.series import FeatureSeries
from leakdiag.studies.nan_windows import nan_windows_by_side, pct_change_nan_as_zero


def _fs(values, window=None, sample_rate=1.0):
    t = np.arange(len(values), dtype=float) / sample_rate
    if window is None:
        return FeatureSeries(t, np.asarray(values, dtype=float), "demo", {})
    # windows of `window` samples, one per second, the timestamp at the last sample
    t = t + (window - 1) / sample_rate
    return FeatureSeries(t, np.asarray(values, dtype=float), "demo", {}, window=window,
                         step=1, sample_rate=sample_rate)


def test_counts_by_the_measures_side_rule_hand_case():
    # windows of 3 samples: window i covers [i, i+2], timestamp i+2; onset 10:
    # before = last sample < 10 -> i <= 7 (8 windows); after = first >= 10 -> i >= 10;
    # windows 8 and 9 span the onset (neither side)
    v = np.ones(20)
    v[[0, 5, 8, 9, 12, 13, 14, 19]] = np.nan
    fs = _fs(v, window=3)
    got = nan_windows_by_side(fs, onset=10.0, chunk=5)
    # whole chunks: 20 // 5 = 4 -> all 20 windows; after = i in 10..19 (10 windows)
    assert got == {"n_windows_before": 8, "n_windows_after": 10, "n_nan_windows_before": 2,
                   "n_nan_windows_after": 4}
    res = rms_change(fs, 10.0, chunk=5)
    # the measure counts every NaN in whole chunks, incl. the two windows astride the onset
    assert res.n_nan_windows == 8 == 2 + 4 + 2


def test_trailing_values_outside_whole_chunks_are_not_counted():
    v = np.r_[np.ones(10), np.ones(10), np.nan, np.nan, np.nan]  # 23 values, chunk 10
    got = nan_windows_by_side(_fs(v), onset=10.0, chunk=10)
    assert got == {"n_windows_before": 10, "n_windows_after": 10, "n_nan_windows_before": 0,
                   "n_nan_windows_after": 0}
    with pytest.raises(ValueError, match="chunk"):
        nan_windows_by_side(_fs(v), onset=10.0, chunk=0)


def test_nan_as_zero_hand_values():
    # before: 10 values of 2 (RMS 2); after: 10 values of 2, 4 of them NaN
    v = np.full(20, 2.0)
    v[[10, 11, 12, 13]] = np.nan
    fs = _fs(v)
    assert rms_change(fs, 10.0, chunk=10).pct_change_signed == pytest.approx(0.0)  # skipped
    # as 0: RMS after = sqrt(6 * 4 / 10) = 1.5492; (1.5492 - 2) / 2 = -22.54 %
    assert pct_change_nan_as_zero(fs, 10.0, chunk=10) == pytest.approx(
        (np.sqrt(2.4) - 2) / 2 * 100)
    assert pct_change_nan_as_zero(fs, 10.0, chunk=10) == pytest.approx(-22.54, abs=0.01)
    # no NaN: the measure itself
    w = np.r_[np.ones(10), 0.5 * np.ones(10)]
    assert pct_change_nan_as_zero(_fs(w), 10.0, chunk=5) == pytest.approx(-50.0)
    # no whole chunk after the onset: NaN, not an error
    assert np.isnan(pct_change_nan_as_zero(_fs(w), 19.5, chunk=5))


def test_the_series_is_not_changed():
    v = np.r_[np.ones(10), np.nan, np.ones(9)]
    fs = _fs(v)
    pct_change_nan_as_zero(fs, 10.0, chunk=10)
    assert np.isnan(fs.values[10])
