"""Eq. 4.11-4.14 windowed moments: reference, hand values, the skewness decision, degenerate."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from leakdiag.features import DegenerateWindowWarning, FeatureSeries, moments, moments_at, to_frame
from leakdiag.features._kernels.stepsums import STEP_MAX
from . import reference as ref
from .signals import make_signals

SIGNALS = make_signals()


@pytest.mark.parametrize("name", sorted(SIGNALS))
@pytest.mark.parametrize("window,overlap", [(400, 50.0), (400, 99.0), (37, 99.0), (3, 0.0)])
def test_matches_reference(name, window, overlap):
    x = SIGNALS[name]
    df = to_frame(moments(x, window=window, overlap=overlap))
    expected = ref.moments_ref(x, window, overlap)
    got = df[["mean", "variance", "skewness", "kurtosis"]].to_numpy()
    np.testing.assert_allclose(got[:, 0], expected[:, 0], rtol=1e-13,
                               atol=1e-13 * np.max(np.abs(x)))
    np.testing.assert_allclose(got[:, 1:], expected[:, 1:], rtol=1e-9, atol=1e-12)


def test_by_hand_and_columns():
    # 1 2 3 10: mean 4, deviations -3 -2 -1 6: sums of powers 50, 180, 1394
    # variance 50/4; s^2 = 50/3; skew = 180 / (3 s^3); kurt = 1394 / (3 s^4)
    df = to_frame(moments([1, 2, 3, 10], window=4, overlap=0, sample_rate=2.0))
    assert list(df.columns) == ["time", "mean", "variance", "skewness", "kurtosis"]
    s2 = 50 / 3
    row = df.iloc[0]
    assert row["time"] == 1.5
    assert row["mean"] == 4.0
    assert row["variance"] == 12.5
    assert row["skewness"] == pytest.approx(180 / (3 * s2**1.5), rel=1e-14)
    assert row["kurtosis"] == pytest.approx(1394 / (3 * s2**2), rel=1e-14)
    assert df.attrs["window"] == 4 and df.attrs["step"] == 4


def test_skewness_sign_and_relation_to_scipy():
    # The cube (not the printed square): a right-skewed sample is positive, its mirror negative.
    rng = np.random.default_rng(4)
    x = rng.exponential(size=4000)
    right = to_frame(moments(x, window=4000, overlap=0))
    left = to_frame(moments(-x, window=4000, overlap=0))
    assert right["skewness"].iloc[0] > 1.5
    assert left["skewness"].iloc[0] == pytest.approx(-right["skewness"].iloc[0], rel=1e-12)
    # (N-1) s^3 denominator relates to the biased g1 by (N/(N-1))^(-1/2)... exactly:
    n = 4000
    g1 = stats.skew(x, bias=True)
    assert right["skewness"].iloc[0] == pytest.approx(g1 * n / (n - 1) * ((n - 1) / n) ** 1.5,
                                                      rel=1e-12)
    b2 = stats.kurtosis(x, fisher=False, bias=True)
    assert right["kurtosis"].iloc[0] == pytest.approx(b2 * n / (n - 1) * ((n - 1) / n) ** 2,
                                                      rel=1e-12)


def test_gaussian_kurtosis_not_excess():
    x = np.random.default_rng(5).normal(size=200_000)
    df = to_frame(moments(x, window=200_000, overlap=0))
    assert df["kurtosis"].iloc[0] == pytest.approx(3.0, abs=0.05)


def test_constant_window_zero_variance_nan_shape_and_one_warning():
    x = np.r_[np.full(8, 8.6e6), np.arange(8.0)]
    with pytest.warns(DegenerateWindowWarning, match=r"^2 of 4 windows have zero variance") as r:
        df = to_frame(moments(x, window=4, overlap=0))
    assert len(r) == 1
    assert df["mean"].tolist()[:2] == [8.6e6, 8.6e6]
    assert df["variance"].tolist()[:2] == [0.0, 0.0]
    assert df[["skewness", "kurtosis"]].iloc[:2].isna().all().all()
    assert df[["skewness", "kurtosis"]].iloc[2:].notna().all().all()


def test_at_any_order():
    x = SIGNALS["level_steps"]
    got = moments_at(x, [900, 3, 900, 0], 200)
    for row, s in zip(got, [900, 3, 900, 0]):
        np.testing.assert_allclose(row, ref.moments_window(x[s : s + 200]), rtol=1e-9)


def test_errors_and_inputs():
    with pytest.raises(ValueError, match=r"window=1 must be >= 2"):
        to_frame(moments(np.arange(10.0), window=1))
    with pytest.raises(ValueError, match=r"signal has 10 samples, shorter than one window"):
        to_frame(moments(np.arange(10.0), window=11))
    with pytest.raises(ValueError, match=r"x holds 1 non-finite value\(s\) \(inf\); first at sample 2"):
        to_frame(moments([1.0, 2.0, np.inf, 4.0], window=2))
    s = pd.Series(np.arange(10), name="p1")
    df = to_frame(moments(s, window=5, overlap=0))
    assert df.attrs["channels"] == ("p1",)
    assert df["mean"].tolist() == [2.0, 7.0]


def test_all_starts_then_slice_equals_overlap_call():
    # bit for bit from the per-term kernel (steps 1 and > STEP_MAX); the step-increment kernel
    # (steps 2 .. STEP_MAX) adds step terms first: the same to rounding
    x = SIGNALS["large_offset"]
    every = moments_at(x, np.arange(len(x) - 400 + 1), 400)
    for overlap in (5, 50, 99, 99.75):  # steps 380, 200, 4, 1
        df = to_frame(moments(x, window=400, overlap=overlap))
        got = df[["mean", "variance", "skewness", "kurtosis"]].to_numpy()
        step = df.attrs["step"]
        if 2 <= step <= STEP_MAX:
            want = every[::step]
            np.testing.assert_allclose(got[:, :2], want[:, :2], rtol=1e-12)  # mean, variance
            np.testing.assert_allclose(got[:, 2:], want[:, 2:], rtol=1e-9, atol=1e-11)
        else:
            np.testing.assert_array_equal(every[::step], got)


def test_one_series_per_moment_on_shared_windows():
    # moments returns the same kind of object as every feature: one FeatureSeries per moment,
    # all on the same windows (same time array, same typed geometry), named as MOMENT_NAMES.
    series = moments(pd.Series(np.arange(12.0), name="p2"), window=4, overlap=50,
                     sample_rate=10.0, start_time=1.0)
    assert [fs.name for fs in series] == ["mean", "variance", "skewness", "kurtosis"]
    assert all(isinstance(fs, FeatureSeries) for fs in series)
    assert [dict(fs.settings) for fs in series] == [{"moment": n} for n in
                                                   ("mean", "variance", "skewness", "kurtosis")]
    for fs in series:
        assert (fs.window, fs.step, fs.overlap, fs.sample_rate, fs.start_time, fs.channels) == \
            (4, 2, 50.0, 10.0, 1.0, ("p2",))
        np.testing.assert_array_equal(fs.time, [1.3, 1.5, 1.7, 1.9, 2.1])
        np.testing.assert_allclose(fs.window_start, [1.0, 1.2, 1.4, 1.6, 1.8])
    # windows [0..3], [2..5], ...: means 1.5, 3.5, ...; variance of 4 consecutive integers 1.25
    np.testing.assert_allclose(series[0].values, [1.5, 3.5, 5.5, 7.5, 9.5])
    np.testing.assert_allclose(series[1].values, 1.25)
    with pytest.raises(ValueError, match="not on the windows of 'mean'"):
        to_frame([series[0], series[1].with_values(series[1].values[:2],
                                                   time=series[1].time[:2])])
