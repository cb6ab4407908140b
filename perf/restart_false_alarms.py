"""False alarms of a long healthy recording under the conformal threshold (docs/detect.md
section 2, "A recording longer than one healthy segment").

The threshold's promise: at most ``k / (n + 1)`` false alarms per healthy segment, so at most
``m k / (n + 1)`` in a recording of ``m`` segments (union bound). It holds for later segments
only if each starts like the healthy segments the maxima came from, i.e. with the CUSUM
restarted (``detect.cusum.segmented_cusum``). This Monte Carlo checks it on a synthetic
detector whose feature is a recording's channel ``f`` at 1 Hz (one window per sample): an
AR(1) sequence with unit variance and window autocorrelation ``phi`` (0, 0.5 and 0.8; the
simulated VCA's acf-p1 and ccf-p1p2 features have 0.5-0.6).

Per calibration: 200 healthy runs of 60 s (5-s burn-in, one 55-s segment each) set the
threshold for 1 % per segment (``n = 200``, ``k = 2``, bound 0.995 %); then ``M`` healthy
recordings of 10 segments (555 s) are judged. Printed per ``phi``: the share of first segments
and of segments 2-10 in which an alarm is *raised* (the score goes above the threshold), and of
later segments in which an alarm *episode* begins (a raising after the score has been back at 0
since the previous one: an alarm carried over a boundary that dips below the threshold and
rises again is the same episode, as the monitor's summary and the store count them; here on the
score, ``max(S+, S-)``, rather than per branch), and the share of recordings with an alarm against the union
bound, each with a 95 % interval over the calibrations (every recording's chance is its
calibration's, so the calibrations, not the recordings, are the independent sample: mean +-
1.96 standard errors of the per-calibration rates).

Not collected by pytest (no ``test_`` prefix). ``python perf/restart_false_alarms.py [R [M]]``
(default 200 calibrations x 100 recordings, 10-15 s per ``phi`` on one core; the seeds
are fixed, so a rerun prints the same numbers).
"""

import math
import sys
import time
import warnings

import numpy as np

from leakdiag.detect.base import Alarm, Detector
from leakdiag.detect.threshold import binned_maxima
from leakdiag.features.series import FeatureSeries
from leakdiag.io import Recording

BURN_S, SEGMENT_S, N_SEGMENTS, N_FIT, FIT_S = 5.0, 55.0, 10, 200, 60
PER_SEGMENT = 0.01
PHIS = (0.0, 0.5, 0.8)


class ChannelDetector(Detector):
    """A detector whose feature is the recording's channel ``f`` (1 Hz: one window a sample)."""

    def __init__(self, alarm=None):
        self.alarm = alarm

    def _feature_series(self, recording):
        return FeatureSeries(recording.time, recording["f"], "f", {},
                             sample_rate=recording.sample_rate,
                             start_time=recording.start_time)


def ar1(rng: np.random.Generator, n: int, phi: float) -> Recording:
    """A recording whose channel ``f`` is AR(1) with coefficient ``phi``, unit variance."""
    e = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = e[0]
    s = math.sqrt(1.0 - phi * phi)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + s * e[i]
    return Recording({"f": x}, 1.0)


def new_in_segments(flags: np.ndarray, time: np.ndarray) -> np.ndarray:
    """Per segment, whether any window flagged in ``flags`` ends in it."""
    return binned_maxima(flags.astype(float), time, SEGMENT_S, BURN_S,
                         SEGMENT_S * N_SEGMENTS) > 0


def mean_ci(x: np.ndarray) -> str:
    """``mean (lo-hi)`` in per cent, 95 % normal interval of the mean."""
    m, se = float(np.mean(x)), float(np.std(x, ddof=1) / math.sqrt(len(x)))
    return f"{100 * m:.2f} % ({100 * max(m - 1.96 * se, 0.0):.2f}-{100 * (m + 1.96 * se):.2f})"


def main(n_cal: int, n_rec: int) -> None:
    warnings.simplefilter("ignore")
    alarm = Alarm(false_alarms_per_hour=PER_SEGMENT * 3600 / SEGMENT_S, onset_method="cusum",
                  burn_in_s=BURN_S)
    for phi in PHIS:
        rng = np.random.default_rng(2)
        t0 = time.time()
        first, later, later_new, runs = (np.zeros(n_cal) for _ in range(4))
        for c in range(n_cal):
            det = ChannelDetector(alarm).fit([ar1(rng, FIT_S, phi) for _ in range(N_FIT)])
            h, basis = det.threshold_, det.threshold_basis_
            hits = np.zeros((2, N_SEGMENTS))  # segments with a raising; with a new episode
            n_run = 0
            for _ in range(n_rec):
                sc = det.score(ar1(rng, int(BURN_S + SEGMENT_S * N_SEGMENTS), phi))
                s = np.nan_to_num(sc.values, nan=-np.inf)
                above = s > h
                raised = np.flatnonzero(above & ~np.concatenate([[False], above[:-1]]))
                new = np.zeros(len(s))  # raisings that begin an episode
                for j, i in enumerate(raised):
                    new[i] = j == 0 or (s[raised[j - 1]:i] <= 0.0).any()
                hits[0] += new_in_segments(np.isin(np.arange(len(s)), raised), sc.time)
                hits[1] += new_in_segments(new > 0, sc.time)
                n_run += bool(above.any())
            first[c], later[c] = hits[0, 0] / n_rec, hits[0, 1:].mean() / n_rec
            later_new[c] = hits[1, 1:].mean() / n_rec
            runs[c] = n_run / n_rec
        union = min(1.0, N_SEGMENTS * basis.bound_per_segment)
        print(f"phi={phi}: n={basis.n} k={basis.k}, bound {100 * basis.bound_per_segment:.3f} % "
              f"per segment, {100 * union:.2f} % per {N_SEGMENTS}-segment recording; over "
              f"{n_cal} calibrations x {n_rec} recordings: first segments {mean_ci(first)}, "
              f"segments 2-{N_SEGMENTS} {mean_ci(later)} (an episode begun: {mean_ci(later_new)}), "
              f"recordings with an alarm "
              f"{mean_ci(runs)}; {time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200,
         int(sys.argv[2]) if len(sys.argv) > 2 else 100)
