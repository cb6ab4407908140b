"""NaN/inf anywhere in the input is an error naming the first bad sample, for every feature.

The regular-window features let the kernel find non-finite windows and scan the few samples
after the last window themselves (``_args.finish_finite_check``); these tests put the bad sample
at the edges of that split: first sample, inside a window, the last sample any window reads, the
first sample no window reads, and the last sample.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from leakdiag.features import autocorrelation, cross_correlation, metric_length_ratio, moments
from leakdiag.features.windowing import n_windows, window_step

N = 1000
WINDOW = 200
OVERLAP = 5  # step 190: 5 windows cover samples 0..959, samples 960..999 are read by none
COVERED = (n_windows(N, WINDOW, OVERLAP) - 1) * window_step(WINDOW, OVERLAP) + WINDOW
POSITIONS = [0, 437, COVERED - 1, COVERED, N - 1]

FEATURES = {
    "autocorrelation lag 1": lambda x, y: autocorrelation(x, 1, WINDOW, OVERLAP),
    "autocorrelation lag 40": lambda x, y: autocorrelation(x, 40, WINDOW, OVERLAP),
    "cross-correlation lag 1 (bad x)": lambda x, y: cross_correlation(y, x, 1, WINDOW, OVERLAP),
    "cross-correlation lag 40 (bad x)": lambda x, y: cross_correlation(y, x, 40, WINDOW, OVERLAP),
    "metric length": lambda x, y: metric_length_ratio(x, "83:3", WINDOW, OVERLAP),
    "metric length, 2 channels": lambda x, y: metric_length_ratio(np.column_stack([y, x]),
                                                                   "83:3", WINDOW, OVERLAP),
    "moments": lambda x, y: moments(x, WINDOW, OVERLAP),
}


def test_the_split_is_where_the_tests_assume():
    assert COVERED == 960


@pytest.mark.parametrize("bad,kind", [(np.nan, "NaN"), (np.inf, "inf"), (-np.inf, "inf")])
@pytest.mark.parametrize("pos", POSITIONS)
@pytest.mark.parametrize("feature", list(FEATURES))
def test_non_finite_sample_is_named(feature, pos, bad, kind):
    rng = np.random.default_rng(3)
    x = 8.6e6 + 1e3 * rng.normal(size=N)
    y = 8.6e6 + 1e3 * rng.normal(size=N)
    x[pos] = bad
    x[pos + 1 if pos + 1 < N else pos] = bad
    count = 2 if pos + 1 < N else 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no degenerate-window warning before the error
        with pytest.raises(ValueError, match=rf"holds {count} non-finite value\(s\) \({kind}\); "
                                             rf"first at sample {pos}"):
            FEATURES[feature](x, y)


@pytest.mark.parametrize("feature", ["cross-correlation lag 1", "cross-correlation lag 40"])
def test_cross_correlation_names_the_bad_signal(feature):
    lag = 1 if feature.endswith("1") else 40
    x = np.sin(np.arange(N) / 7.0)
    y = np.cos(np.arange(N) / 5.0)
    y[COVERED] = np.nan
    with pytest.raises(ValueError, match=r"^y holds 1 non-finite value\(s\) \(NaN\); first at sample 960"):
        cross_correlation(y, x, lag, WINDOW, OVERLAP)
    y[COVERED] = 0.0
    x[12] = np.inf
    with pytest.raises(ValueError, match=r"^x holds 1 non-finite value\(s\) \(inf\); first at sample 12"):
        cross_correlation(y, x, lag, WINDOW, OVERLAP)


def test_huge_finite_values_are_not_an_error():
    # sums that overflow to inf make a window "non-finite" for the kernel, but the full scan then
    # finds every sample finite, so nothing is raised; the squares overflow, so float64 gives
    # -inf / inf = NaN in every window, as a direct evaluation would
    x = np.full(N, 1e200)
    x[::2] = -1e200
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = autocorrelation(x, 1, WINDOW, OVERLAP)
    assert len(fs) == n_windows(N, WINDOW, OVERLAP)
    assert np.isnan(fs.values).all()
