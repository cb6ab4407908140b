import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.features.windowing import window_starts
from leakdiag.literature._windowed import windowed_mean, windowed_rms


def _plain(x, window, overlap, fn):
    return np.array([fn(x[s:s + window]) for s in window_starts(len(x), window, overlap)])


def test_hand_values():
    assert windowed_rms([3.0, 4.0, 0.0, 0.0], 2, 0).tolist() == pytest.approx([12.5**0.5, 0.0])
    # step = 3 - round(1.5) = 1 (half to even)
    assert windowed_mean([1.0, 3.0, 5.0, 7.0, 9.0], 3, 50).tolist() == [3.0, 5.0, 7.0]


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 400), window=st.integers(2, 50), overlap=st.floats(0, 99),
       scale=st.sampled_from([1e-6, 1.0, 1e7]), seed=st.integers(0, 1000))
def test_equals_plain_reference(n, window, overlap, scale, seed):
    x = np.random.default_rng(seed).standard_normal(n) * scale + 3 * scale
    if n < window:
        assert len(windowed_rms(x, window, overlap)) == 0
        return
    np.testing.assert_allclose(windowed_rms(x, window, overlap),
                               _plain(x, window, overlap, lambda w: np.sqrt(np.mean(w**2))),
                               rtol=1e-9)
    np.testing.assert_allclose(windowed_mean(x, window, overlap),
                               _plain(x, window, overlap, np.mean), rtol=1e-9, atol=1e-12 * scale)


def test_strided_and_readonly_input():
    x = np.arange(20.0)[::2]
    x.flags.writeable = False
    np.testing.assert_allclose(windowed_rms(x, 5, 0), [np.sqrt(np.mean(np.arange(0, 10, 2.0)**2)),
                                                       np.sqrt(np.mean(np.arange(10, 20, 2.0)**2))])


def test_zero_signal_is_zero_not_nan():
    assert windowed_rms(np.zeros(10), 5, 0).tolist() == [0.0, 0.0]


def test_bad_window():
    with pytest.raises(ValueError, match="window=1 must be"):
        windowed_rms(np.zeros(10), 1, 0)
