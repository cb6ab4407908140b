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
# step 3 (98.5 %): the step-increment kernels; 267 windows cover samples 0..997
OVERLAPS = [OVERLAP, 98.5]


def covered(overlap):
    """Samples ``0 .. covered - 1`` are read by some window."""
    return (n_windows(N, WINDOW, overlap) - 1) * window_step(WINDOW, overlap) + WINDOW


def positions(overlap):
    return [0, 437, covered(overlap) - 1, covered(overlap), N - 1]


FEATURES = {
    "autocorrelation lag 1": lambda x, y, ov: autocorrelation(x, 1, WINDOW, ov),
    "autocorrelation lag 40": lambda x, y, ov: autocorrelation(x, 40, WINDOW, ov),
    "cross-correlation lag 1 (bad x)": lambda x, y, ov: cross_correlation(y, x, 1, WINDOW, ov),
    "cross-correlation lag 40 (bad x)": lambda x, y, ov: cross_correlation(y, x, 40, WINDOW, ov),
    "metric length": lambda x, y, ov: metric_length_ratio(x, "83:3", WINDOW, ov),
    "metric length, 2 channels": lambda x, y, ov: metric_length_ratio(np.column_stack([y, x]),
                                                                       "83:3", WINDOW, ov),
    "moments": lambda x, y, ov: moments(x, WINDOW, ov),
}


def test_the_split_is_where_the_tests_assume():
    assert covered(OVERLAP) == 960
    assert window_step(WINDOW, 98.5) == 3 and covered(98.5) == 998


@pytest.mark.parametrize("bad,kind", [(np.nan, "NaN"), (np.inf, "inf"), (-np.inf, "inf")])
@pytest.mark.parametrize("overlap,pos", [(ov, p) for ov in OVERLAPS for p in positions(ov)])
@pytest.mark.parametrize("feature", list(FEATURES))
def test_non_finite_sample_is_named(feature, overlap, pos, bad, kind):
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
            FEATURES[feature](x, y, overlap)


@pytest.mark.parametrize("feature", ["cross-correlation lag 1", "cross-correlation lag 40"])
def test_cross_correlation_names_the_bad_signal(feature):
    lag = 1 if feature.endswith("1") else 40
    x = np.sin(np.arange(N) / 7.0)
    y = np.cos(np.arange(N) / 5.0)
    y[covered(OVERLAP)] = np.nan
    with pytest.raises(ValueError, match=r"^y holds 1 non-finite value\(s\) \(NaN\); first at sample 960"):
        cross_correlation(y, x, lag, WINDOW, OVERLAP)
    y[covered(OVERLAP)] = 0.0
    x[12] = np.inf
    with pytest.raises(ValueError, match=r"^x holds 1 non-finite value\(s\) \(inf\); first at sample 12"):
        cross_correlation(y, x, lag, WINDOW, OVERLAP)


@pytest.mark.parametrize("overlap", OVERLAPS)
def test_huge_finite_values_are_not_called_non_finite(overlap):
    # sums that overflow to inf make a window "non-finite" for the kernel, but the full scan then
    # finds every sample finite, so no sample is called NaN or inf; the squares overflow
    # (float64 would give -inf / inf = NaN in every window), which is refused by its magnitude
    # (until 2026-11-27 the NaN values were returned without a word: a features audit)
    x = np.full(N, 1e200)
    x[::2] = -1e200
    with np.errstate(all="ignore"), pytest.raises(ValueError, match=r"^x: its largest "
                                                  r"magnitude, 1e\+200, is beyond what float64 "
                                                  r"sums of squares"):
        autocorrelation(x, 1, WINDOW, overlap)


def test_compute_feature_names_the_file_channel_and_row():
    """Found by an API audit (2026-11-27): a NaN in p2 of a recording reached a detector as
    "x holds 1 non-finite value(s)": the kernel's argument, not the channel (x is also the
    position channel), and no file."""
    from leakdiag.features.spec import MethodSpec, compute_feature
    from leakdiag.io import RecordingError
    from leakdiag.io.recording import Recording

    p1, p2 = np.sin(np.arange(N) / 7.0), np.cos(np.arange(N) / 5.0)
    p2[70] = np.nan
    p2[90] = np.inf
    rec = Recording({"p1": p1, "p2": p2}, 1000.0, meta={"source": "run7.parquet"})
    spec = MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=WINDOW, overlap=0)
    with pytest.raises(RecordingError, match=r"^run7.parquet: channel 'p2' has 2 non-finite "
                                             r"value\(s\); first NaN at row 70$"):
        compute_feature(rec, spec)


@pytest.mark.parametrize("scale, power_words", [(1e80, "fourth powers"), (1e160, "squares"),
                                                (1e-170, "squares")])
def test_a_signal_beyond_float64s_range_for_the_sums_is_refused(scale, power_words):
    """A features audit: finite samples too large or too small for the window sums gave NaN
    or inf without a word (kurtosis NaN at 1e80, an autocorrelation of inf at 1e152) or a
    false 'zero variance' warning (1e160, 1e-170). Refused now, naming the magnitude; the
    values at ordinary scales are unchanged."""
    import leakdiag as ld
    from leakdiag.features.spec import MethodSpec
    from leakdiag.stream.feature import StreamingFeature

    x = np.array([1.0, 2.0, 3.0, 10.0])
    calls = [lambda: ld.features.moments(x * scale, window=4),
             lambda: ld.features.moments_at(x * scale, [0], 4)]
    if power_words == "squares":
        calls += [lambda: ld.features.autocorrelation(x * scale, lag=1, window=4),
                  lambda: ld.features.cross_correlation(x * scale, x[::-1] * scale, 1, 4),
                  lambda: ld.features.autocorrelation_at(x * scale, 1, [0], 4),
                  lambda: StreamingFeature(MethodSpec("autocorrelation", ("p1",), lag=1,
                                                      window=4, overlap=0)).push({"p1": x * scale})]
    for call in calls:
        with pytest.raises(ValueError, match=r"its largest magnitude, \d(\.\d+)?e[+-]\d+, is "
                                             r"beyond what float64 sums of (fourth powers|"
                                             r"squares) over 4 samples hold"):
            call()
    assert ld.features.autocorrelation(x * 1e60, lag=1, window=4).values[0] == \
        pytest.approx(0.04)
    assert ld.features.moments(x * 1e60, window=4)[3].values[0] == pytest.approx(1.6728, 1e-4)
