"""Helpers for the batch tests: synthetic recordings and a picklable slow detector."""

import time

import numpy as np
from scipy.signal import lfilter

from leakdiag.features.spec import MethodSpec
from leakdiag.io.recording import Recording


def make_recording(seed, n=12000, onset_s=6.0, sample_rate=1000.0):
    """AR(1) pressure whose correlation drops at ``onset_s`` (a planted 'leak')."""
    rng = np.random.default_rng(seed)
    k = int(onset_s * sample_rate)
    p1 = np.r_[lfilter([1], [1, -0.9], rng.normal(size=k)),
               lfilter([1], [1, -0.3], rng.normal(size=n - k))]
    return Recording({"p1": 1e7 + 1e5 * p1, "p2": rng.normal(size=n)}, sample_rate,
                     meta={"onset": onset_s, "source": f"seed{seed}"})


class SlowScorer:
    """Detector-like object: a spec, a threshold and a score that takes ``delay_s`` per call."""

    threshold_ = 0.5

    def __init__(self, delay_s=0.0):
        self.delay_s = delay_s

    def spec(self):
        return MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)

    def score_windows(self, values, time_s):
        time.sleep(self.delay_s)
        return 1.0 - values
