"""Non-finite input is refused up front, naming the recording, the channel and the first bad
sample (one NaN used to spread through a prefix sum or an EMD block into every later window,
which then read as undefined and was blamed on a stuck sensor)."""

import numpy as np
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.literature.ekf import EKFParams, ekf_feature, run_vca_ekf
from leakdiag.literature.emd_hilbert import EMDHilbertParams, emd_hilbert_feature
from leakdiag.literature.fft_band import FFTBandParams, fft_band_feature
from leakdiag.literature.wavelet import WaveletParams, wavelet_feature


def _rec(channel, bad_index, value=np.nan, start_time=0.0):
    n = 4000
    rng = np.random.default_rng(0)
    ch = {"u": 0.01 * rng.standard_normal(n), "x": np.zeros(n),
          "p1": 8.6e6 + 1e4 * rng.standard_normal(n), "p2": 8.6e6 + 1e4 * rng.standard_normal(n)}
    ch[channel][bad_index] = value
    ch[channel][bad_index + 100] = value  # a second bad sample: counted, the first one named
    return Recording(ch, sample_rate=1000.0, start_time=start_time,
                     meta={"system": "vca", "source": "rig7/run3.csv"})


@pytest.mark.parametrize("feature,params,name", [
    (wavelet_feature, WaveletParams(), "wavelet"),
    (fft_band_feature, FFTBandParams(), "fft_band"),
    (emd_hilbert_feature, EMDHilbertParams(block=2000, margin=200), "emd_hilbert"),
])
def test_signal_features_refuse_nan_naming_recording_channel_sample(feature, params, name):
    rec = _rec("p1", 2345)
    msg = (r"^rig7/run3\.csv: channel 'p1' has 2 non-finite value\(s\); first NaN at row 2345; "
           rf"the {name} feature needs finite samples: fill or cut the gap$")
    with pytest.raises(RecordingError, match=msg):
        feature(rec, params)


def test_two_channel_feature_names_the_bad_channel_and_inf():
    rec = _rec("p2", 10, value=np.inf, start_time=100.0)
    with pytest.raises(RecordingError, match=r"channel 'p2' has 2 non-finite value\(s\); "
                                             r"first inf at row 10; "):
        wavelet_feature(rec, WaveletParams(channels=("p1", "p2")))


@pytest.mark.parametrize("channel", ["u", "x", "p1", "p2"])
def test_ekf_refuses_nan_naming_recording(channel):
    rec = _rec(channel, 1500)
    msg = (rf"^rig7/run3\.csv: channel '{channel}' has 2 non-finite value\(s\); first NaN at "
           r"row 1500; the EKF needs finite samples: fill or cut the gap$")
    with pytest.raises(RecordingError, match=msg):
        run_vca_ekf(rec)
    with pytest.raises(RecordingError, match=msg):
        ekf_feature(rec, EKFParams())


def test_ekf_too_short_names_recording():
    rec = Recording({c: np.zeros(1) for c in ("u", "x", "p1", "p2")}, 1000.0,
                    meta={"source": "one.csv"})
    with pytest.raises(ValueError, match=r"one\.csv: 1 sample\(s\); the EKF needs at least 2"):
        run_vca_ekf(rec)
