import numpy as np
import pytest

from leakdiag.features.windowing import window_starts
from leakdiag.io.recording import Recording
from leakdiag.literature.fft_band import FFTBandParams, fft_band_feature, fft_band_rms

FS = 1000.0


def _plain_band_rms(x, window, overlap, band):
    """Reference: band-limit each window by zeroing FFT bins outside the band, take the RMS."""
    out = []
    f = np.fft.fftfreq(window, 1 / FS)
    for s in window_starts(len(x), window, overlap):
        spec = np.fft.fft(x[s:s + window])
        spec[~((np.abs(f) >= band[0]) & (np.abs(f) <= band[1]))] = 0
        out.append(np.sqrt(np.mean(np.abs(np.fft.ifft(spec)) ** 2)))
    return np.array(out)


def test_parseval_sine_in_band_is_amplitude_over_sqrt2():
    t = np.arange(3000) / FS
    x = 3.0 * np.sin(2 * np.pi * 70 * t) + 5.0 * np.sin(2 * np.pi * 200 * t) + 7.0
    np.testing.assert_allclose(fft_band_rms(x, FS, 1000, 50, (35.0, 105.0)), 3 / np.sqrt(2),
                               rtol=1e-12)


def test_dc_and_nyquist_bins_counted_once():
    x = np.tile([1.0, -1.0], 50) + 2.0  # Nyquist tone of amplitude 1 plus DC 2
    assert fft_band_rms(x, FS, 100, 0, (0.0, 500.0)).tolist() == pytest.approx([np.sqrt(5.0)])
    assert fft_band_rms(x, FS, 100, 0, (499.0, 500.0)).tolist() == pytest.approx([1.0])


@pytest.mark.parametrize("window,overlap", [(256, 0), (1000, 50), (333, 90)])
def test_equals_plain_reference_on_noise(window, overlap):
    x = np.random.default_rng(1).standard_normal(5000) * 1e5
    band = (35.0, 105.0)
    np.testing.assert_allclose(fft_band_rms(x, FS, window, overlap, band),
                               _plain_band_rms(x, window, overlap, band), rtol=1e-9)


def test_blocks_do_not_change_result(monkeypatch):
    import leakdiag.literature.fft_band as fb

    x = np.random.default_rng(2).standard_normal(20000)
    full = fb.fft_band_rms(x, FS, 500, 50, (30.0, 120.0))
    monkeypatch.setattr(fb, "_BLOCK_VALUES", 1500)  # three windows per block
    np.testing.assert_allclose(fb.fft_band_rms(x, FS, 500, 50, (30.0, 120.0)), full, rtol=1e-12)


def test_short_signal_gives_no_window():
    assert fft_band_rms(np.zeros(10), FS, 100, 0, (10.0, 100.0)).shape == (0,)


def test_errors():
    with pytest.raises(ValueError, match="holds no FFT bin"):
        fft_band_rms(np.zeros(1000), FS, 100, 0, (41.0, 49.0))
    with pytest.raises(ValueError, match="0 <= low < high"):
        fft_band_rms(np.zeros(1000), FS, 100, 0, (80.0, 40.0))
    with pytest.raises(ValueError, match=r"band_hz=\(-1.0, 5.0\) must satisfy 0 <= low < high"):
        FFTBandParams(band_hz=(-1.0, 5.0))


def test_default_band_brackets_natural_frequency_and_feature_params():
    p = FFTBandParams()
    lo, hi = p.resolved_band_hz
    assert lo == pytest.approx(0.5 * 69.74, rel=1e-3) and hi == pytest.approx(1.5 * 69.74, rel=1e-3)
    t = np.arange(2000) / FS
    rec = Recording({"p1": np.sin(2 * np.pi * 70 * t), "p2": np.sin(2 * np.pi * 300 * t)}, FS)
    fs = fft_band_feature(rec, FFTBandParams(("p1", "p2"), overlap=0))
    np.testing.assert_allclose(fs.values, 1 / np.sqrt(2), rtol=1e-12)  # p2 is out of band
    assert fs.params["band_hz"] == (lo, hi)


def test_band_above_nyquist_is_refused_not_cut():
    # at 100 Hz the default band 34.85-104.56 Hz (0.5-1.5 x 69.7 Hz) would be computed only up
    # to the 50-Hz Nyquist bin; it is refused instead, as wavelet-p1 refuses its level
    x = np.random.default_rng(3).standard_normal(1000)
    band = FFTBandParams().resolved_band_hz
    with pytest.raises(ValueError, match=r"band_hz=\(34\.8544, 104\.563\) must lie below the "
                                         r"Nyquist frequency 50 Hz \(sample_rate=100 Hz\).*"
                                         r"50-104\.563 Hz of the band would not be computed"):
        fft_band_rms(x, 100.0, 100, 0, band)
    rec = Recording({"p1": x}, 100.0)
    with pytest.raises(ValueError, match="must lie below the Nyquist frequency 50 Hz"):
        fft_band_feature(rec, FFTBandParams(window=100))
    # a band ending exactly at Nyquist keeps every bin (the Nyquist bin counted once)
    assert fft_band_rms(np.tile([1.0, -1.0], 50), 100.0, 100, 0, (40.0, 50.0)).tolist() == \
        pytest.approx([1.0])
