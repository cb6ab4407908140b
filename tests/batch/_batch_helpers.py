"""Helpers for the batch tests: synthetic recordings and a picklable slow detector."""

import time
from dataclasses import dataclass

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


@dataclass(frozen=True)
class _BurnIn:
    burn_in_s: float = 5.0


class BurnInScorer(SlowScorer):
    """:class:`SlowScorer` that scores no window starting within a 5-s burn-in (NaN)."""

    alarm = _BurnIn()

    def score_windows(self, values, time_s):
        return np.where(time_s - 0.199 < self.alarm.burn_in_s, np.nan, 1.0 - values)

    def alarm_windows(self, scores):
        return np.where(np.isnan(scores), False, scores >= self.threshold_)
