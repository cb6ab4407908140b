import numpy as np
import pytest

from leakdiag.io.recording import Recording
from leakdiag.literature.emd_hilbert import EMDHilbertParams, emd_hilbert_feature, first_imf_amplitude

FS = 1000.0


def _two_tone(n, a_fast=1.0):
    t = np.arange(n) / FS
    return a_fast * np.sin(2 * np.pi * 50 * t) + 4 * np.sin(2 * np.pi * 2 * t)


@pytest.mark.parametrize("iters", [10, None])
def test_first_imf_is_the_fast_tone(iters):
    a = first_imf_amplitude(_two_tone(3000, 1.5), block=1500, margin=300, sifting_iterations=iters)
    np.testing.assert_allclose(a[300:-300], 1.5, atol=0.1)


def test_block_size_hardly_matters():
    x = _two_tone(6000)
    a1 = first_imf_amplitude(x, block=6000, margin=0)
    a2 = first_imf_amplitude(x, block=1000, margin=300)
    assert np.sqrt(np.mean((a1[500:-500] - a2[500:-500]) ** 2)) < 0.02


def test_scales_with_the_signal():
    x = _two_tone(3000)
    np.testing.assert_allclose(first_imf_amplitude(1e5 * x, 1000, 200),
                               1e5 * first_imf_amplitude(x, 1000, 200), rtol=1e-6, atol=1e-3)


def test_constant_signal_has_zero_amplitude():
    assert first_imf_amplitude(np.full(500, 3.0), 200, 50).tolist() == [0.0] * 500


def test_errors():
    with pytest.raises(ValueError, match="block=1 must be"):
        first_imf_amplitude(np.zeros(10), block=1)
    with pytest.raises(ValueError, match="margin=-1 must be"):
        first_imf_amplitude(np.zeros(10), margin=-1)
    with pytest.raises(ValueError, match="sifting_iterations=0 must be"):
        EMDHilbertParams(sifting_iterations=0)


def test_feature_rms_of_amplitude():
    rec = Recording({"p1": 2.0 * np.sin(2 * np.pi * 60 * np.arange(4000) / FS)}, FS)
    fs = emd_hilbert_feature(rec, EMDHilbertParams(overlap=0, block=2000, margin=200))
    np.testing.assert_allclose(fs.values, 2.0, rtol=0.02)
    assert fs.name == "emd_hilbert" and fs.params["window"] == 1000
