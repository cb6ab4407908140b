"""The step-increment kernels (regular windows, steps 2 .. STEP_MAX) against the per-term
kernels and the per-window reference (exact arithmetic: test_correlation.py)."""

from __future__ import annotations

import numpy as np
import pytest

from leakdiag.features import autocorrelation, cross_correlation, metric_length_ratio, moments, to_frame
from leakdiag.features._kernels.chunks import NO_STARTS
from leakdiag.features._kernels.smalllag import auto_small_core, cross_small_core
from leakdiag.features._kernels.stepsums import (
    STEP_MAX,
    auto_small_steps,
    cross_small_steps,
    metric_steps,
    moments_steps,
)
from leakdiag.features.metric_length import _metric_core
from leakdiag.features.moments import _moment_core
from leakdiag.features.windowing import window_step

from . import reference as ref
from .signals import make_signals

SIGNALS = make_signals(n=1500, seed=7)
STEPS = list(range(2, STEP_MAX + 2))  # STEP_MAX + 1: the kernels' generic (run-time step) loop
# window 200, overlap -> step 2 .. 8, as the features compute it
OVERLAP_FOR_STEP = {2: 99.0, 3: 98.5, 4: 98.0, 5: 97.5, 6: 97.0, 7: 96.5, 8: 96.0}


def test_overlaps_give_the_steps():
    assert {s: window_step(200, ov) for s, ov in OVERLAP_FOR_STEP.items()} == {
        s: s for s in OVERLAP_FOR_STEP}


def n_win(n, window, step):
    return (n - window) // step + 1


@pytest.mark.parametrize("name", list(SIGNALS))
@pytest.mark.parametrize("lag", [1, 2, 5, 8])
@pytest.mark.parametrize("window", [9, 37, 200])
def test_correlation_step_kernels_agree_with_per_term_kernels(name, lag, window):
    x = SIGNALS[name]
    y = SIGNALS["level_steps"] if name != "level_steps" else SIGNALS["large_offset"]
    for step in STEPS:
        m = n_win(len(x), window, step)
        a, b = np.empty(m), np.empty(m)
        assert auto_small_steps(x, lag, window, step, a) == auto_small_core(
            x, lag, window, NO_STARTS, step, b)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
        assert cross_small_steps(y, x, lag, window, step, a) == cross_small_core(
            y, x, lag, window, NO_STARTS, step, b)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", list(SIGNALS))
@pytest.mark.parametrize("window", [2, 3, 37, 400])
def test_moment_step_kernel_agrees_with_per_term_kernel(name, window):
    x = SIGNALS[name]
    for step in STEPS:
        m = n_win(len(x), window, step)
        a, b = np.empty((4, m)), np.empty((4, m))
        assert moments_steps(x, window, step, a) == _moment_core(x, window, NO_STARTS, step, b)
        scale = np.max(np.abs(x))  # the mean can cross zero: its error is relative to the data
        np.testing.assert_allclose(a[0], b[0], rtol=1e-12, atol=1e-13 * scale)
        np.testing.assert_allclose(a[1], b[1], rtol=1e-12)
        np.testing.assert_allclose(a[2:], b[2:], rtol=1e-9, atol=1e-11)  # skewness, kurtosis


@pytest.mark.parametrize("name", list(SIGNALS))
@pytest.mark.parametrize("lags,window", [((83, 3), 200), ((83, 3), 84), ((2, 1), 3), ((10, 4), 37)])
def test_metric_step_kernel_agrees_with_per_term_kernel(name, lags, window):
    x = SIGNALS[name]
    for step in STEPS:
        m = n_win(len(x), window, step)
        a, b = np.empty(m), np.empty(m)
        assert metric_steps(x, *lags, window, step, a) == _metric_core(
            x.reshape(-1, 1), *lags, window, NO_STARTS, step, b)
        np.testing.assert_allclose(a, b, rtol=1e-13)


@pytest.mark.parametrize("name", list(SIGNALS))
@pytest.mark.parametrize("step", list(OVERLAP_FOR_STEP))
def test_features_at_short_steps_match_the_reference(name, step):
    x = SIGNALS[name]
    y = SIGNALS["sine"]
    ov = OVERLAP_FOR_STEP[step]
    for lag in (1, 3):
        np.testing.assert_allclose(autocorrelation(x, lag, 200, ov).values,
                                   ref.autocorrelation_ref(x, lag, 200, ov), rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(cross_correlation(y, x, lag, 200, ov).values,
                                   ref.cross_correlation_ref(y, x, lag, 200, ov),
                                   rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(metric_length_ratio(x, "83:3", 200, ov).values,
                               ref.metric_length_ratio_ref(x, 83, 3, 200, ov), rtol=1e-12)
    got = to_frame(moments(x, 200, ov))[["mean", "variance", "skewness", "kurtosis"]].to_numpy()
    np.testing.assert_allclose(got, ref.moments_ref(x, 200, ov), rtol=1e-9, atol=1e-9)


def test_zero_variance_windows_are_counted_as_by_the_per_term_kernels():
    x = np.r_[np.full(300, 2.0), np.arange(300.0)]  # constant first half
    for step in (2, 5):
        m = n_win(len(x), 50, step)
        a, b = np.empty(m), np.empty(m)
        got = auto_small_steps(x, 1, 50, step, a)
        assert got == auto_small_core(x, 1, 50, NO_STARTS, step, b)
        assert got[0] == np.isnan(a).sum() > 0
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
