"""Eq. 4.3-4.4 ratio of metric lengths: fast path vs plain reference, hand values, errors."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from leakdiag.features import DegenerateWindowWarning, metric_length_ratio, metric_length_ratio_at
from leakdiag.features._kernels.stepsums import STEP_MAX
from . import reference as ref
from .signals import make_signals

SIGNALS = make_signals()
# (window, overlap, l, k)
SETTINGS = [(500, 5.0, 83, 3), (500, 99.0, 83, 3), (200, 99.5, 7, 2), (37, 99.0, 36, 35),
            (100, 50.0, 10, 1), (3, 0.0, 2, 1)]


@pytest.mark.parametrize("name", sorted(SIGNALS))
@pytest.mark.parametrize("window,overlap,l_step,k_step", SETTINGS)
def test_matches_reference(name, window, overlap, l_step, k_step):
    x = SIGNALS[name]
    fs = metric_length_ratio(x, lag_ratio=f"{l_step}:{k_step}", window=window, overlap=overlap)
    expected = ref.metric_length_ratio_ref(x, l_step, k_step, window, overlap)
    np.testing.assert_allclose(fs.values, expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("window,overlap,l_step,k_step", SETTINGS[:4])
def test_two_channels_match_reference(window, overlap, l_step, k_step):
    x = np.column_stack([SIGNALS["large_offset"], SIGNALS["level_steps"] - 1e6])
    fs = metric_length_ratio(x, lag_ratio=(l_step, k_step), window=window, overlap=overlap)
    expected = ref.metric_length_ratio_ref(x, l_step, k_step, window, overlap)
    np.testing.assert_allclose(fs.values, expected, rtol=1e-12, atol=0)
    assert fs.params["channels"] == ("x[0]", "x[1]")


def test_by_hand():
    # x = 0 1 3 6 10, N=5, l=2, k=1: pairs j=0..2
    # k-steps: 1, 2, 3 -> 6 ; l-steps: 3, 5, 7 -> 15 ; F = 0.4
    fs = metric_length_ratio([0, 1, 3, 6, 10], lag_ratio="2:1", window=5, overlap=0)
    assert fs.values.tolist() == [pytest.approx(0.4, rel=1e-15)]
    assert fs.params["lag_ratio"] == "2:1" and fs.params["l"] == 2 and fs.params["k"] == 1


def test_euclidean_norm_by_hand():
    # 2 channels: steps are 3-4-5 triangles: x = (0,0), (3,4), (6,8), (9,12)
    # N=4, l=2, k=1, 2 pairs: k-steps 5+5 = 10, l-steps 10+10 = 20 -> 0.5
    x = np.array([[0, 0], [3, 4], [6, 8], [9, 12]], dtype=float)
    assert metric_length_ratio(x, "2:1", window=4).values.tolist() == [0.5]
    df = pd.DataFrame(x, columns=["p1", "p2"])
    assert metric_length_ratio(df, "2:1", window=4).params["channels"] == ("p1", "p2")


@pytest.mark.parametrize("l_step,k_step", [(83, 3), (10, 7), (2, 1)])
def test_ramp_gives_k_over_l(l_step, k_step):
    fs = metric_length_ratio(8.6e6 + 0.5 * np.arange(3000.0), (l_step, k_step), window=500,
                             overlap=99)
    np.testing.assert_allclose(fs.values, k_step / l_step, rtol=1e-12)


@settings(max_examples=30, deadline=None)
@given(hnp.arrays(np.float64, st.integers(6, 40),
                  elements=st.integers(-10**6, 10**6).map(lambda i: i / 1000.0)),
       st.data())
def test_at_matches_reference_any_starts(x, data):
    window = data.draw(st.integers(3, len(x)))
    l_step = data.draw(st.integers(2, window - 1))
    k_step = data.draw(st.integers(1, l_step - 1))
    starts = data.draw(st.lists(st.integers(0, len(x) - window), min_size=1, max_size=10))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        got = metric_length_ratio_at(x, (l_step, k_step), starts, window)
    want = [ref.metric_length_ratio_window(x[s : s + window], l_step, k_step) for s in starts]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    # scale and offset invariance of a ratio of lengths
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        scaled = metric_length_ratio_at(4.0 * x - 7.0, (l_step, k_step), starts, window)
    np.testing.assert_allclose(scaled, got, rtol=1e-9)


def test_zero_denominator_nan_and_one_warning():
    # first 20 samples periodic with period l=2 -> denominator 0 though numerator is not
    x = np.r_[np.tile([0.0, 1.0], 10), np.arange(20.0) ** 2]
    with pytest.warns(DegenerateWindowWarning, match=r"^2 of 4 windows have zero metric length"
                      r".*their values are NaN$") as rec:
        fs = metric_length_ratio(x, "2:1", window=10, overlap=0)
    assert len(rec) == 1
    assert np.isnan(fs.values[:2]).all() and np.isfinite(fs.values[2:]).all()


@pytest.mark.parametrize("lag_ratio,match", [
    ("3:3", r"needs l > k >= 1, got l=3, k=3"),
    ("2:5", r"needs l > k >= 1, got l=2, k=5"),
    ("5:0", r"needs l > k >= 1, got l=5, k=0"),
    ("10:3", r"l=10 must be < window=10"),
    ("83-3", r"lag_ratio='83-3' must look like 'l:k'"),
    ("a:b", r"must look like 'l:k'"),
])
def test_lag_ratio_errors(lag_ratio, match):
    with pytest.raises(ValueError, match=match):
        metric_length_ratio(np.arange(40.0), lag_ratio, window=10)


def test_other_errors():
    with pytest.raises(ValueError, match=r"signal has 9 samples, shorter than one window \(window=10"):
        metric_length_ratio(np.arange(9.0), "3:1", window=10)
    with pytest.raises(ValueError, match=r"overlap=100 must be in \[0, 100\)"):
        metric_length_ratio(np.arange(40.0), "3:1", window=10, overlap=100)
    x = np.ones((40, 2))
    x[12, 1] = np.nan
    with pytest.raises(ValueError, match="first at sample 12"):
        metric_length_ratio(x, "3:1", window=10)
    with pytest.raises(TypeError, match="must be 'l:k' or a pair"):
        metric_length_ratio(np.arange(40.0), 3, window=10)
    with pytest.raises(ValueError, match=r"must be 1-D or 2-D"):
        metric_length_ratio(np.ones((4, 4, 4)), "3:1", window=2)


@pytest.mark.parametrize("kind", ["readonly", "strided", "series", "int", "fortran"])
def test_input_kinds(kind):
    base = np.array([3, 1, 4, 1, 5, 9, 2, 6, 5, 3, 5, 8, 9, 7, 9, 3], dtype=np.int64)
    expected = ref.metric_length_ratio_ref(base, 3, 1, 8, 50)
    if kind == "readonly":
        x = base.astype(float)
        x.flags.writeable = False
    elif kind == "strided":
        x = np.repeat(base.astype(float), 2)[::2]
    elif kind == "series":
        x = pd.Series(base, name="p2")
    elif kind == "int":
        x = base
    else:
        x = np.asfortranarray(np.column_stack([base, np.zeros_like(base)]).astype(float))
    np.testing.assert_allclose(metric_length_ratio(x, "3:1", 8, 50).values, expected, rtol=1e-14)


def test_all_starts_then_slice_equals_overlap_call():
    # bit for bit from the per-term kernel (steps 1 and > STEP_MAX); the step-increment kernel
    # (steps 2 .. STEP_MAX) adds step terms first: the same to rounding
    x = SIGNALS["level_steps"]
    every = metric_length_ratio_at(x, "83:3", np.arange(len(x) - 500 + 1), 500)
    for overlap in (5, 50, 99, 99.8):  # steps 475, 250, 5, 1
        fs = metric_length_ratio(x, "83:3", window=500, overlap=overlap)
        step = fs.params["step"]
        if 2 <= step <= STEP_MAX:
            np.testing.assert_allclose(fs.values, every[::step], rtol=1e-13)
        else:
            np.testing.assert_array_equal(every[::step], fs.values)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
@pytest.mark.parametrize("where", [5, 16])
def test_a_bad_sample_that_eq_4_3_never_reads_is_refused(bad, where):
    """With 2l - k > N, Eq. 4.3 reads [s, s+N-l+k) and [s+l, s+N) of a window only: samples
    3-7 of each 10-sample window (l=8, k=1) were never read, so the kernel's sums stayed finite
    and a NaN or inf there passed unseen (an audit); the docs promise an error wherever it is."""
    x = np.arange(40, dtype=float) ** 1.5
    x[where] = bad
    with pytest.raises(ValueError, match=f"x holds 1 non-finite value.*first at sample {where}"):
        metric_length_ratio(x, lag_ratio="8:1", window=10, overlap=0)
    x[where] = 1.0  # a finite value there is simply not read
    assert np.isfinite(metric_length_ratio(x, lag_ratio="8:1", window=10, overlap=0).values).all()
