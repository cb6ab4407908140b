"""StreamingFeature: hand-computed values, equality with per-window references and the batch
features under random chunk boundaries, bounded state, degenerate windows, robustness, errors."""

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _stream_ref import ac_ref, cc_ref, mlr_ref, times_ref
from leakdiag.features import autocorrelation
from leakdiag.features.spec import MethodSpec
from leakdiag.stream import StreamingFeature


def _push_in_pieces(sf, channels, cuts):
    """Push ``channels`` (dict of arrays) split at ``cuts``; concatenate the outputs."""
    n = len(next(iter(channels.values())))
    bounds = [0, *sorted(c for c in cuts if 0 < c < n), n]
    times, values = [], []
    for a, b in zip(bounds[:-1], bounds[1:]):
        fs = sf.push({k: v[a:b] for k, v in channels.items()})
        times.append(fs.time)
        values.append(fs.values)
        assert sf.state_samples < sf.spec.window
    return np.concatenate(times), np.concatenate(values)


def test_autocorrelation_hand_computed():
    # [1,2,3,4]: mean 2.5, deviations -1.5,-.5,.5,1.5; sum d^2 = 5; lag-1 products .75-.25+.75
    sf = StreamingFeature(MethodSpec("autocorrelation", ("p1",), lag=1, window=4, overlap=0))
    fs = sf.push({"p1": [1.0, 2.0, 3.0, 4.0]})
    assert fs.values.tolist() == [pytest.approx(1.25 / 5)]
    assert fs.time.tolist() == [3.0]


def test_cross_correlation_hand_computed():
    # y=[1,2,3,4], x=[2,4,6,8], lag 1: (1/4)*sum_{j<3} dy_j dx_{j+1} / (sd_x sd_y)
    # dy=-1.5,-.5,.5,1.5; dx=-3,-1,1,3 -> (-1.5*-1)+(-.5*1)+(.5*3)=2.5; var_y=1.25, var_x=5
    sf = StreamingFeature(MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=4,
                                     overlap=0))
    fs = sf.push({"p1": np.array([1.0, 2, 3, 4]), "p2": np.array([2.0, 4, 6, 8])})
    assert fs.values[0] == pytest.approx(2.5 / 4 / np.sqrt(1.25 * 5.0))


def test_metric_length_ratio_hand_computed():
    # ramp 0..5, l=2, k=1, N=6: sum_{j<4}|x_{j+1}-x_j| = 4, sum_{j<4}|x_{j+2}-x_j| = 8
    sf = StreamingFeature(MethodSpec("metric-length", ("p1",), lag_ratio="2:1", window=6,
                                     overlap=0))
    assert sf.push({"p1": np.arange(6.0)}).values.tolist() == [0.5]


def test_metric_length_two_channels_uses_euclidean_norm():
    # (x, y) = (3t, 4t): every step has norm 5|dt| -> ratio k/l exactly
    t = np.arange(10.0)
    sf = StreamingFeature(MethodSpec("metric-length", ("p1", "p2"), lag_ratio="3:1", window=10,
                                     overlap=0))
    assert sf.push({"p1": 3 * t, "p2": 4 * t}).values[0] == pytest.approx(1 / 3)


@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_any_chunking_equals_reference(data):
    window = data.draw(st.integers(2, 40), label="window")
    overlap = data.draw(st.sampled_from([0, 5, 10, 50, 75, 99]), label="overlap")
    n = data.draw(st.integers(0, 300), label="n")
    cuts = data.draw(st.lists(st.integers(0, n), max_size=12), label="cuts")
    seed = data.draw(st.integers(0, 2**31 - 1), label="seed")
    rng = np.random.default_rng(seed)
    y, x = rng.normal(size=n).cumsum(), rng.normal(size=n)
    lag = data.draw(st.integers(1, window - 1), label="lag")
    fs = 250.0
    cases = [
        (MethodSpec("autocorrelation", ("p1",), lag=lag, window=window, overlap=overlap),
         ac_ref(y, lag, window, overlap)),
        (MethodSpec("cross-correlation", ("p1", "p2"), lag=lag, window=window,
                    overlap=overlap), cc_ref(y, x, lag, window, overlap)),
    ]
    if window >= 3:
        ell = data.draw(st.integers(2, window - 1), label="l")
        k = data.draw(st.integers(1, ell - 1), label="k")
        cases.append((MethodSpec("metric-length", ("p1",), lag_ratio=(ell, k), window=window,
                                 overlap=overlap), mlr_ref(y, ell, k, window, overlap)))
    for spec, expected in cases:
        sf = StreamingFeature(spec, sample_rate=fs, start_time=2.0)
        t, v = _push_in_pieces(sf, {"p1": y, "p2": x}, cuts)
        np.testing.assert_allclose(v, expected, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(t, times_ref(n, window, overlap, fs, 2.0))
        assert sf.n_windows == len(expected)


def test_one_sample_at_a_time_equals_one_big_chunk():
    rng = np.random.default_rng(1)
    x = rng.normal(size=2000)
    spec = MethodSpec("autocorrelation", ("p1",), lag=3, window=200, overlap=5)
    big = StreamingFeature(spec).push({"p1": x})
    batch = autocorrelation(x, lag=3, window=200, overlap=5)
    # one chunk: the batch kernel on the same buffer with the same window starts -> bit-equal
    np.testing.assert_array_equal(big.values, batch.values)
    small = StreamingFeature(spec)
    vals = np.concatenate([small.push({"p1": x[i:i + 1]}).values for i in range(len(x))])
    # one sample at a time: each window summed from its own first sample (other block anchors)
    np.testing.assert_allclose(vals, big.values, rtol=1e-12, atol=0)


@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_any_chunking_equals_batch_features_module(data):
    from leakdiag import features as F

    window = data.draw(st.integers(90, 300), label="window")
    overlap = data.draw(st.sampled_from([0, 5, 10, 50]), label="overlap")
    lag = data.draw(st.integers(1, 40), label="lag")
    n = 3000
    cuts = data.draw(st.lists(st.integers(1, n - 1), max_size=10), label="cuts")
    rng = np.random.default_rng(data.draw(st.integers(0, 2**31 - 1), label="seed"))
    p1, p2 = rng.normal(size=n).cumsum(), rng.normal(size=n)
    kw = dict(window=window, overlap=overlap, sample_rate=1000.0, start_time=0.5)
    pairs = [
        (MethodSpec("autocorrelation", ("p1",), lag=lag, window=window, overlap=overlap),
         F.autocorrelation(p1, lag=lag, **kw)),
        (MethodSpec("cross-correlation", ("p1", "p2"), lag=lag, window=window, overlap=overlap),
         F.cross_correlation(p1, p2, lag=lag, **kw)),
        (MethodSpec("metric-length", ("p1",), lag_ratio="83:3", window=window, overlap=overlap),
         F.metric_length_ratio(p1, lag_ratio="83:3", **kw)),
    ]
    for spec, batch in pairs:
        sf = StreamingFeature(spec, sample_rate=1000.0, start_time=0.5)
        t, v = _push_in_pieces(sf, {"p1": p1, "p2": p2}, cuts)
        np.testing.assert_allclose(v, batch.values, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(t, batch.time, rtol=0, atol=1e-12)


def test_constant_window_is_nan_and_counted():
    x = np.r_[np.full(10, 3.3), np.arange(10.0)]
    sf = StreamingFeature(MethodSpec("autocorrelation", ("p1",), lag=1, window=10, overlap=0))
    fs = sf.push({"p1": x})
    assert np.isnan(fs.values[0]) and np.isfinite(fs.values[1])
    assert sf.n_degenerate == 1


@pytest.mark.parametrize("make", [
    lambda x: x.astype(np.float32),
    lambda x: (x * 100).astype(np.int64),
    lambda x: np.repeat(x, 2)[::2],  # strided view
    lambda x: pd.Series(x),
    lambda x: np.frombuffer(x.tobytes()),  # read-only
])
def test_input_kinds(make):
    x = np.random.default_rng(3).normal(size=400)
    xin = make(x)
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=50, overlap=10)
    got = StreamingFeature(spec).push({"p1": xin}).values
    np.testing.assert_allclose(got, ac_ref(np.asarray(xin, dtype=float), 1, 50, 10), rtol=1e-12)


def test_dataframe_chunk_uses_named_columns():
    rng = np.random.default_rng(5)
    df = pd.DataFrame({"time": np.arange(300) / 10.0, "p2": rng.normal(size=300),
                       "p1": rng.normal(size=300)})
    spec = MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=100, overlap=5)
    got = StreamingFeature(spec).push(df).values
    np.testing.assert_allclose(got, cc_ref(df["p1"].to_numpy(), df["p2"].to_numpy(), 1, 100, 5),
                               rtol=1e-12)


def test_array_chunk_in_channel_order():
    rng = np.random.default_rng(4)
    y, x = rng.normal(size=300), rng.normal(size=300)
    spec = MethodSpec("cross-correlation", ("p1", "p2"), lag=2, window=100, overlap=5)
    got = StreamingFeature(spec).push(np.column_stack([y, x])).values
    np.testing.assert_allclose(got, cc_ref(y, x, 2, 100, 5), rtol=1e-12)


def test_errors_name_the_problem():
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=10, overlap=0)
    sf = StreamingFeature(spec)
    sf.push({"p1": np.ones(5)})
    with pytest.raises(ValueError, match="channel 'p1' is not finite at sample 7"):
        sf.push({"p1": [1.0, 2.0, np.nan]})
    with pytest.raises(KeyError, match=r"no channel\(s\) \['p1'\]"):
        sf.push({"p2": [1.0]})
    with pytest.raises(ValueError, match="does not fit channels"):
        sf.push(np.ones((3, 2)))
    with pytest.raises(ValueError, match="method='moments' cannot be streamed"):
        StreamingFeature(MethodSpec("moments", ("p1",), window=10, overlap=0))
    with pytest.raises(TypeError, match="spec must be a MethodSpec"):
        StreamingFeature({"method": "autocorrelation"})
    with pytest.raises(ValueError, match="sample_rate=0"):
        StreamingFeature(spec, sample_rate=0)
    two = StreamingFeature(MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=10,
                                      overlap=0))
    with pytest.raises(ValueError, match="differ in length: p1=3, p2=2"):
        two.push({"p1": np.ones(3), "p2": np.ones(2)})
