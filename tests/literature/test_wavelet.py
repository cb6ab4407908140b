import numpy as np
import pytest

from leakdiag.io.recording import Recording
from leakdiag.literature.wavelet import (WaveletParams, wavelet_detail, wavelet_detail_rms,
                                      wavelet_feature, wavelet_level_for_frequency)

FS = 1000.0


def _sine(f, n=8192, a=1.0):
    return a * np.sin(2 * np.pi * f * np.arange(n) / FS)


@pytest.mark.parametrize("f,fs,level", [(69.7, 1000.0, 3), (130.0, 1000.0, 2), (300.0, 1000.0, 1),
                                        (69.7, 5000.0, 6)])
def test_level_band_contains_frequency(f, fs, level):
    j = wavelet_level_for_frequency(f, fs)
    assert j == level
    assert fs / 2 ** (j + 1) <= f <= fs / 2**j


def test_level_rejects_nyquist():
    with pytest.raises(ValueError, match="below the Nyquist"):
        wavelet_level_for_frequency(600.0, 1000.0)


def test_levels_partition_the_energy():
    """Tight frame: mean squares of all details plus the approximation equal the signal's."""
    import pywt

    x = np.random.default_rng(0).standard_normal(4096)
    coeffs = pywt.swt(x, "db4", level=4, trim_approx=True, norm=True)
    assert sum(np.mean(c**2) for c in coeffs) == pytest.approx(np.mean(x**2), rel=1e-10)
    # and our level-j detail (reflection-padded, trimmed) carries the same band energy
    d2 = wavelet_detail(x, "db4", 2)
    assert np.mean(d2**2) == pytest.approx(np.mean(coeffs[-2] ** 2), rel=0.05)


def test_in_band_sine_keeps_most_energy_out_of_band_little():
    # 100 Hz is in the level-3 band (62.5-125 Hz) at 1 kHz; 400 Hz is in level 1
    in_band = wavelet_detail_rms(_sine(100.0), 1000, 0, "db4", 3)
    out_band = wavelet_detail_rms(_sine(400.0), 1000, 0, "db4", 3)
    assert np.all(in_band > 0.6 / np.sqrt(2)) and np.all(in_band <= 1 / np.sqrt(2) + 1e-9)
    assert np.all(out_band < 0.05)


def test_linearity_and_alignment():
    x = _sine(90.0, 3000) + 0.3 * _sine(20.0, 3000)
    np.testing.assert_allclose(wavelet_detail(2.5 * x), 2.5 * wavelet_detail(x), rtol=1e-12)
    assert wavelet_detail(x).shape == x.shape


def test_strided_readonly_and_odd_length():
    x = _sine(40.0, 2001 * 2)[::2]  # every other sample of 40 Hz: an 80 Hz tone at 1 kHz
    x.flags.writeable = False
    d = wavelet_detail(x, "db4", 3)
    assert d.shape == (2001,)
    # the strided, read-only view gives exactly what its contiguous copy gives
    np.testing.assert_array_equal(d, wavelet_detail(np.array(x), "db4", 3))
    # and the 80 Hz tone at 1 kHz lies in level 3 (62.5-125 Hz): most of its power survives
    assert np.mean(d[200:-200] ** 2) > 0.5 * np.mean(x**2)


def test_rejects_non_orthogonal_and_unknown():
    with pytest.raises(ValueError, match="must be orthogonal"):
        wavelet_detail(np.zeros(64), "bior2.2", 2)
    with pytest.raises(ValueError, match="not a discrete PyWavelets wavelet"):
        wavelet_detail(np.zeros(64), "nope", 2)
    with pytest.raises(ValueError, match="level=0 must be"):
        wavelet_detail(np.zeros(64), "db4", 0)


def test_feature_combines_channels_in_mean_square_and_timestamps():
    x = 1e5 * _sine(100.0, 4000)
    rec = Recording({"p1": x, "p2": x}, FS)
    one = wavelet_feature(rec, WaveletParams(("p1",), window=1000, overlap=0))
    two = wavelet_feature(rec, WaveletParams(("p1", "p2"), window=1000, overlap=0))
    np.testing.assert_allclose(two.values, np.sqrt(2) * one.values)
    assert one.time.tolist() == [0.999, 1.999, 2.999, 3.999]
    assert one.params["level"] == 3 and one.params["sample_rate"] == FS


def test_params_validation():
    with pytest.raises(ValueError, match="channels='p1' must be"):
        WaveletParams(channels="p1")
    with pytest.raises(ValueError, match="overlap=100"):
        WaveletParams(overlap=100)
