"""Eq. 4.1 (autocorrelation) and Eq. 4.2 (cross-correlation): fast path vs plain reference."""

from __future__ import annotations

import warnings
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import leakdiag as ld
from leakdiag.features import (
    DegenerateWindowWarning,
    autocorrelation,
    autocorrelation_at,
    cross_correlation,
    cross_correlation_at,
)
from leakdiag.features._kernels.blocksums import _auto_core, _cross_core
from leakdiag.features._kernels.chunks import NO_STARTS
from leakdiag.features._kernels.smalllag import LAG_DIRECT, auto_small_core, cross_small_core
from leakdiag.features._kernels.stepsums import STEP_MAX

from . import reference as ref
from .signals import SETTINGS, make_signals

SIGNALS = make_signals()
RTOL = 1e-9
ATOL = 1e-11  # coefficients are O(1); absolute slack for values that cross zero


@pytest.mark.parametrize("name", sorted(SIGNALS))
@pytest.mark.parametrize("window,overlap,lag", SETTINGS)
def test_autocorrelation_matches_reference(name, window, overlap, lag):
    x = SIGNALS[name]
    fs = autocorrelation(x, lag=lag, window=window, overlap=overlap)
    expected = ref.autocorrelation_ref(x, lag, window, overlap)
    assert fs.values.shape == expected.shape
    np.testing.assert_allclose(fs.values, expected, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("name", sorted(SIGNALS))
@pytest.mark.parametrize("window,overlap,lag", SETTINGS)
def test_cross_correlation_matches_reference(name, window, overlap, lag):
    x = SIGNALS[name]
    y = 0.3 * np.roll(x, 5) - 2.0 * x + np.cos(np.arange(len(x)) / 7.0)
    fs = cross_correlation(y, x, lag=lag, window=window, overlap=overlap)
    expected = ref.cross_correlation_ref(y, x, lag, window, overlap)
    np.testing.assert_allclose(fs.values, expected, rtol=RTOL, atol=ATOL)


def _exact_ac(w, lag):
    w = [Fraction(float(v)) for v in w]
    m = sum(w) / len(w)
    d = [v - m for v in w]
    return float(sum(d[j] * d[j + lag] for j in range(len(d) - lag)) / sum(v * v for v in d))


@pytest.mark.parametrize("offset,step,noise", [(8.6e6, 1e5, 1.0), (0.0, 1e3, 1e-4)])
def test_autocorrelation_exact_on_extreme_level_steps(offset, step, noise):
    # level/noise ratios of 1e7: beyond a float64 two-pass reference (its rounded mean alone
    # moves the result by ~1e-10); the anchored sums stay within 1e-14 of exact arithmetic.
    rng = np.random.default_rng(3)
    n = 900
    x = offset + step * np.repeat(rng.integers(0, 5, n // 60), 60) + noise * rng.normal(size=n)
    starts = np.arange(0, n - 120 + 1, 37)
    for lag in (3, 20):  # the short-lag kernel and the general one
        got = autocorrelation_at(x, lag, starts, 120)
        exact = [_exact_ac(x[s : s + 120], lag) for s in starts]
        np.testing.assert_allclose(got, exact, rtol=0, atol=1e-14)
    # and the step-increment kernel (regular windows, step 3 at 97.5 % overlap)
    got = autocorrelation(x, 3, 120, 97.5).values
    exact = [_exact_ac(x[s : s + 120], 3) for s in range(0, n - 120 + 1, 3)]
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-14)


def test_reference_vs_exact():
    # the reference itself is accurate on the test signals (two-pass corrected mean)
    x = SIGNALS["level_steps"]
    for s in (0, 140, 1234):
        w = x[s : s + 200]
        assert ref.autocorrelation_window(w, 7) == pytest.approx(_exact_ac(w, 7), abs=1e-13)


# ------------------------------------------------------------------ hand-computed values
def test_autocorrelation_by_hand():
    # x = 1,2,3,4: mean 2.5, deviations -1.5 -0.5 0.5 1.5
    # lag 1: (0.75 - 0.25 + 0.75) / 5 = 0.25 ; lag 2: (-0.75 - 0.75) / 5 = -0.3
    assert autocorrelation([1, 2, 3, 4], lag=1, window=4).values.tolist() == [0.25]
    assert autocorrelation([1, 2, 3, 4], lag=2, window=4).values[0] == pytest.approx(-0.3)
    assert autocorrelation([1, 2, 3, 4], lag=3, window=4).values[0] == pytest.approx(-0.45)


def test_autocorrelation_windows_and_times_by_hand():
    # N=4, overlap 50 -> step 2: windows [0,4) [2,6); timestamps at the last sample
    x = [1.0, 2.0, 3.0, 4.0, 0.0, 4.0]
    fs = autocorrelation(x, lag=1, window=4, overlap=50, sample_rate=10.0, start_time=1.0)
    assert fs.time.tolist() == pytest.approx([1.3, 1.5])
    # second window 3,4,0,4: mean 2.75, dev .25 1.25 -2.75 1.25
    num = 0.25 * 1.25 + 1.25 * -2.75 + -2.75 * 1.25
    den = 0.25**2 + 1.25**2 + 2.75**2 + 1.25**2
    assert fs.values.tolist() == pytest.approx([0.25, num / den], rel=1e-15)
    assert fs.params == {"lag": 1, "window": 4, "overlap": 50.0, "step": 2,
                         "channels": ("x",), "sample_rate": 10.0, "start_time": 1.0}
    assert fs.name == "autocorrelation"


def test_cross_correlation_by_hand():
    # y = 1,2,3,4 ; x = 2,0,2,0: means 2.5, 1; dy -1.5 -.5 .5 1.5 ; dx 1 -1 1 -1
    # lag 1 pairs (y0,x1)(y1,x2)(y2,x3): 1.5 - 0.5 - 0.5 = 0.5
    # var_y = 5/4, var_x = 1 -> cc = (1/4) * 0.5 / sqrt(1.25)
    fs = cross_correlation([1, 2, 3, 4], [2, 0, 2, 0], lag=1, window=4)
    assert fs.values[0] == pytest.approx(0.125 / np.sqrt(1.25), rel=1e-15)
    assert fs.params["channels"] == ("y", "x")


def test_cross_correlation_order_is_y_then_lagged_x():
    rng = np.random.default_rng(0)
    x = rng.normal(size=600)
    delayed = np.roll(x, 4)  # delayed_i = x_{i-4}
    # pairs (y_j, x_{j+lag}) = (x_j, delayed_{j+4}) = (x_j, x_j): (N - lag)/N-ish
    high = cross_correlation(x, delayed, lag=4, window=200, overlap=0).values
    assert np.all(high > 0.9)
    # swapped: pairs (delayed_j, x_{j+4}) = (x_{j-4}, x_{j+4}): white noise 8 apart
    low = cross_correlation(delayed, x, lag=4, window=200, overlap=0).values
    assert np.all(np.abs(low) < 0.3)


@pytest.mark.parametrize("lag", [1, 20])  # short-lag and general kernels
@pytest.mark.parametrize("scale", [1e100, 1e-100, 1e150, 1e-150])
def test_cross_correlation_is_scale_invariant_where_the_variance_product_leaves_float_range(
        lag, scale):
    # ss_x * ss_y over- or underflows at these scales (e.g. 1e100: ss ~ 1e202 each), so the
    # one-square-root denominator sqrt(ss_x ss_y) would give 0 or inf; the kernels must notice
    # and redo those windows with sqrt(ss_x) sqrt(ss_y).
    rng = np.random.default_rng(3)
    y = rng.normal(size=3000)
    x = np.roll(y, 2) + 0.3 * rng.normal(size=3000)
    base = cross_correlation(y, x, lag=lag, window=100, overlap=50).values
    np.testing.assert_allclose(base, ref.cross_correlation_ref(y, x, lag, 100, 50),
                               rtol=1e-12, atol=1e-14)
    got = cross_correlation(y * scale, x * scale, lag=lag, window=100, overlap=50).values
    np.testing.assert_allclose(got, base, rtol=1e-12, atol=1e-14)
    starts = np.arange(0, 2901, 37)
    at = cross_correlation_at(y * scale, x * scale, lag, starts, 100)
    np.testing.assert_allclose(at, cross_correlation_at(y, x, lag, starts, 100),
                               rtol=1e-12, atol=1e-14)


# ------------------------------------------------------------------ properties
# millesimal values: no subnormals (their squares underflow to 0, a different degenerate case)
finite = st.integers(-10**6, 10**6).map(lambda i: i / 1000.0)


@settings(max_examples=40, deadline=None)
@given(hnp.arrays(np.float64, st.integers(8, 60), elements=finite),
       st.integers(2, 8), st.integers(1, 7),
       st.floats(-1e6, 1e6), st.floats(1e-3, 1e3))
def test_autocorrelation_properties(x, window, lag, offset, scale):
    lag = min(lag, window - 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        a = autocorrelation(x, lag=lag, window=window, overlap=50).values
        b = autocorrelation(scale * x + offset, lag=lag, window=window, overlap=50).values
        c = cross_correlation(x, x, lag=lag, window=window, overlap=50).values
        r = ref.autocorrelation_ref(x, lag, window, 50)
    ok = ~np.isnan(a)
    # |numerator| <= sum over N-lag pairs <= denominator (Cauchy-Schwarz): |ac| <= 1
    assert np.all(np.abs(a[ok]) <= 1 + 1e-12)
    np.testing.assert_allclose(a, r, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(np.isnan(a), np.isnan(r))
    # Eq. 4.2 with y = x: the 1/N cancels against the population variances -> Eq. 4.1
    np.testing.assert_allclose(c, a, rtol=1e-12, atol=1e-12)
    # invariance to offset and positive scale where the scaled window is still non-constant
    both = ok & ~np.isnan(b)
    np.testing.assert_allclose(b[both], a[both], rtol=1e-6, atol=1e-6)


@settings(max_examples=30, deadline=None)
@given(hnp.arrays(np.float64, st.integers(10, 50), elements=finite), st.data())
def test_at_equals_regular_windows(x, data):
    window = data.draw(st.integers(2, len(x)))
    lag = data.draw(st.integers(1, window - 1))
    starts = data.draw(st.lists(st.integers(0, len(x) - window), min_size=1, max_size=12))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        got = autocorrelation_at(x, lag, starts, window)
        want = np.array([ref.autocorrelation_window(x[s : s + window], lag) for s in starts])
        got_cc = cross_correlation_at(x[::-1], x, lag, starts, window)
        want_cc = np.array([ref.cross_correlation_window(x[::-1][s : s + window],
                                                         x[s : s + window], lag) for s in starts])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(got_cc, want_cc, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("kind", ["large_offset", "level_steps", "constant_plus_noise"])
@pytest.mark.parametrize("lag", [1, 2, 5, LAG_DIRECT])
@pytest.mark.parametrize("window,step", [(200, 2), (37, 1), (120, 7), (50, 50)])
def test_short_lag_kernels_agree_with_general_kernels(kind, lag, window, step):
    # lag <= LAG_DIRECT runs the one-structure kernels of _smalllag; the two-structure kernels of
    # _blocksums compute the same windows another way (different anchors and sums)
    x = SIGNALS[kind]
    y = x[::-1].copy()
    n_win = (len(x) - window) // step + 1
    auto_small, auto_general = np.empty(n_win), np.empty(n_win)
    cross_small, cross_general = np.empty(n_win), np.empty(n_win)
    bad = [auto_small_core(x, lag, window, NO_STARTS, step, auto_small),
           _auto_core(x, lag, window, NO_STARTS, step, auto_general),
           cross_small_core(y, x, lag, window, NO_STARTS, step, cross_small),
           _cross_core(y, x, lag, window, NO_STARTS, step, cross_general)]
    assert bad[0] == bad[1] and bad[2] == bad[3]
    np.testing.assert_allclose(auto_small, auto_general, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(cross_small, cross_general, rtol=1e-11, atol=1e-13)
    overlap = 100.0 * (1 - step / window)  # maps back to this step for every case here
    used = (n_win - 1) * step + window
    want = ref.autocorrelation_ref(x[:used], lag, window, overlap)
    want_cc = ref.cross_correlation_ref(y[:used], x[:used], lag, window, overlap)
    assert len(want) == len(want_cc) == n_win
    np.testing.assert_allclose(auto_small, want, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(cross_small, want_cc, rtol=1e-9, atol=1e-11)


def assert_slice_matches(every, values, step):
    """Bit for bit where the per-term kernels run (their order of additions does not depend on
    the step); to rounding where the step-increment kernels add ``step`` terms first."""
    if 2 <= step <= STEP_MAX:
        np.testing.assert_allclose(values, every[::step], rtol=1e-12, atol=1e-14)
    else:
        np.testing.assert_array_equal(every[::step], values)


def test_all_starts_then_slice_equals_overlap_call():
    x = SIGNALS["large_offset"]
    y = SIGNALS["level_steps"]
    for lag in (5, 40):  # the short-lag kernels and the general ones
        every = autocorrelation_at(x, lag, np.arange(len(x) - 200 + 1), 200)
        every_cc = cross_correlation_at(y, x, lag, np.arange(len(x) - 200 + 1), 200)
        for overlap in (5, 50, 97, 99, 99.5):  # steps 190, 100, 6, 2, 1
            fs = autocorrelation(x, lag=lag, window=200, overlap=overlap)
            assert_slice_matches(every, fs.values, fs.params["step"])
            fs = cross_correlation(y, x, lag=lag, window=200, overlap=overlap)
            assert_slice_matches(every_cc, fs.values, fs.params["step"])


# ------------------------------------------------------------------ robustness
@pytest.mark.parametrize("kind", ["readonly", "strided", "series", "int", "list", "float32"])
def test_input_kinds(kind):
    base = np.array([3, 1, 4, 1, 5, 9, 2, 6, 5, 3, 5, 8, 9, 7, 9, 3], dtype=np.int64)
    expected = ref.autocorrelation_ref(base, 2, 6, 50)
    if kind == "readonly":
        x = base.astype(float)
        x.flags.writeable = False
    elif kind == "strided":
        x = np.repeat(base.astype(float), 3)[::3]
        assert not x.flags.c_contiguous
    elif kind == "series":
        x = pd.Series(base.astype(float), name="p1")
    elif kind == "int":
        x = base
    elif kind == "list":
        x = base.tolist()
    else:
        x = base.astype(np.float32)
    fs = autocorrelation(x, lag=2, window=6, overlap=50)
    np.testing.assert_allclose(fs.values, expected, rtol=1e-12)
    if kind == "series":
        assert fs.params["channels"] == ("p1",)
    cc = cross_correlation(x, x, lag=2, window=6, overlap=50)
    np.testing.assert_allclose(cc.values, expected, rtol=1e-12)


def test_top_level_access():
    fs = ld.features.autocorrelation(np.arange(10.0) ** 2, lag=1, window=5, overlap=5,
                                     sample_rate=1000.0, start_time=0.0)
    assert isinstance(fs, ld.FeatureSeries)
    assert fs.time.tolist() == pytest.approx([0.004, 0.009])


# ------------------------------------------------------------------ degenerate windows
def test_zero_variance_gives_nan_and_one_counted_warning():
    x = np.r_[np.full(40, 8.6e6), np.arange(40.0)]  # windows of 10, step 10: 4 constant
    with pytest.warns(DegenerateWindowWarning, match=r"^4 of 8 windows have zero variance; "
                      r"their values are NaN$") as rec:
        fs = autocorrelation(x, lag=1, window=10, overlap=0)
    assert len(rec) == 1
    assert rec[0].filename == __file__  # points at the caller, not at leakdiag internals
    assert np.isnan(fs.values[:4]).all() and np.isfinite(fs.values[4:]).all()


def test_constant_with_large_offset_is_exactly_degenerate():
    # 0.1 is not representable: a naive mean gives a non-zero variance; anchored sums do not
    x = np.full(30, 0.1)
    with pytest.warns(DegenerateWindowWarning, match="3 of 3 windows"):
        fs = autocorrelation(x, lag=1, window=10, overlap=0)
    assert np.isnan(fs.values).all()


def test_cross_correlation_zero_variance_in_either_signal():
    y = np.r_[np.zeros(10), np.arange(20.0)]
    x = np.r_[np.arange(20.0), np.ones(10)]
    with pytest.warns(DegenerateWindowWarning, match="^2 of 3 windows have zero variance") as rec:
        fs = cross_correlation(y, x, lag=1, window=10, overlap=0)
    assert len(rec) == 1
    assert np.isnan(fs.values[[0, 2]]).all() and np.isfinite(fs.values[1])


def test_no_numpy_warning_when_all_windows_degenerate():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DegenerateWindowWarning, match="2 of 2"):
            autocorrelation(np.ones(8), lag=1, window=4, overlap=0)


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("kwargs,match", [
    ({"lag": 0}, r"lag=0 must be in \[1, window=10\)"),
    ({"lag": 10}, r"lag=10 must be in \[1, window=10\)"),
    ({"window": 1, "lag": 1}, r"window=1 must be >= 2"),
    ({"overlap": 100}, r"overlap=100 must be in \[0, 100\)"),
    ({"overlap": -1}, r"overlap=-1 must be in \[0, 100\)"),
    ({"window": 50}, r"signal has 30 samples, shorter than one window \(window=50"),
    ({"sample_rate": 0}, r"sample_rate=0 must be a finite number > 0"),
])
def test_errors(kwargs, match):
    args = {"lag": 1, "window": 10, "overlap": 5} | kwargs
    with pytest.raises(ValueError, match=match):
        autocorrelation(np.arange(30.0), **args)
    with pytest.raises(ValueError, match=match):
        cross_correlation(np.arange(30.0), np.arange(30.0) ** 2, **args)


def test_type_errors():
    with pytest.raises(TypeError, match=r"lag=1.5 must be an integer"):
        autocorrelation(np.arange(30.0), lag=1.5, window=10)
    with pytest.raises(TypeError, match=r"window='10' must be an integer"):
        autocorrelation(np.arange(30.0), lag=1, window="10")
    with pytest.raises(TypeError, match="x must be numeric"):
        autocorrelation(["a", "b"], lag=1, window=2)


@pytest.mark.parametrize("bad,kind", [(np.nan, "NaN"), (np.inf, "inf")])
def test_non_finite_input_names_first_bad_sample(bad, kind):
    x = np.arange(30.0)
    x[17] = bad
    x[23] = bad
    with pytest.raises(ValueError, match=rf"x holds 2 non-finite value\(s\) \({kind}\); first at sample 17"):
        autocorrelation(x, lag=1, window=10)
    with pytest.raises(ValueError, match="y holds 2 non-finite.*first at sample 17"):
        cross_correlation(x, np.arange(30.0), lag=1, window=10)


def test_length_mismatch():
    with pytest.raises(ValueError, match=r"same length, got len\(y\)=30 and len\(x\)=29"):
        cross_correlation(np.arange(30.0), np.arange(29.0), lag=1, window=10)


def test_at_errors():
    with pytest.raises(ValueError, match=r"starts\[1\]=21 must be in \[0, 20\]"):
        autocorrelation_at(np.arange(30.0), 1, [0, 21], 10)
    with pytest.raises(ValueError, match=r"starts\[0\]=-1 must be in \[0, 20\]"):
        cross_correlation_at(np.arange(30.0), np.arange(30.0), 1, [-1], 10)
    with pytest.raises(TypeError, match="starts must hold integers"):
        autocorrelation_at(np.arange(30.0), 1, [0.5], 10)
    assert autocorrelation_at(np.arange(30.0), 1, [], 10).shape == (0,)


def test_times_equal_windowing_module_exactly():
    from leakdiag.features.windowing import window_starts, window_times

    x = SIGNALS["random"]
    for overlap, rate, t0 in [(5, 1000.0, 0.0), (99, 333.0, 12.5), (50, 1.0, -3.0)]:
        fs = autocorrelation(x, lag=2, window=123, overlap=overlap, sample_rate=rate,
                             start_time=t0)
        expected = window_times(window_starts(len(x), 123, overlap), 123, rate, t0)
        np.testing.assert_array_equal(fs.time, expected)


def test_overflowing_sum_is_not_mistaken_for_non_finite():
    x = np.full(20, 1e308)  # the sum overflows to inf, yet every sample is finite
    with pytest.raises(ValueError, match=r"^x: its largest magnitude, 1e\+308, is beyond what "
                                         r"float64 sums of squares over 10 samples hold"):
        autocorrelation(x, lag=1, window=10, overlap=0)  # not "x holds ... non-finite"


def test_start_time_must_be_a_number():
    with pytest.raises(TypeError, match=r"start_time='0' must be a number"):
        autocorrelation(np.arange(30.0), lag=1, window=10, start_time="0")
