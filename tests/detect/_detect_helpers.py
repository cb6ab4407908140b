"""Test-only detector and synthetic recordings with a planted change."""

import numpy as np

from leakdiag.detect.base import Detector
from leakdiag.features.series import FeatureSeries
from leakdiag.io.recording import Recording

RATE = 100.0  # Hz
WINDOW = 50  # samples, no overlap


class WindowMeanDetector(Detector):
    """Feature = mean of p1 over non-overlapping windows (a plain, hand-checkable feature)."""

    def __init__(self, window=WINDOW, alarm=None):
        self.window = window
        self.alarm = alarm

    def _feature_series(self, recording):
        x = recording["p1"]
        m = len(x) // self.window
        v = x[: m * self.window].reshape(m, self.window).mean(axis=1)
        t = recording.start_time + (np.arange(m) * self.window + self.window - 1) / recording.sample_rate
        return FeatureSeries(t, v, "window-mean", window=self.window,
                             sample_rate=recording.sample_rate)


def synthetic(duration_s, seed, onset=None, step=0.0):
    """White noise p1 (std 1) with a mean step of ``step`` at ``onset`` seconds."""
    rng = np.random.default_rng(seed)
    n = int(duration_s * RATE)
    p1 = rng.standard_normal(n)
    t = np.arange(n) / RATE
    if onset is not None:
        p1 = p1 + step * (t >= onset)
    return Recording({"p1": p1}, RATE, meta={"onset": onset, "leak_lpm": step, "source": f"syn{seed}"})


def healthy_vca(n=6, duration_s=20.0, machine=31):
    """``n`` healthy spring-load VCA runs of virtual machine ``machine`` (seeds 0..n-1), the
    flow-balance threshold and run-level tests' healthy recordings."""
    import leakdiag as ld

    return [ld.sim.simulate_vca(duration=duration_s, leak_lpm=0.0, load="spring",
                                machine=machine, seed=s) for s in range(n)]
