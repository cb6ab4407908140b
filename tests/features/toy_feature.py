"""A toy windowed feature as a user would add one: one kernel, one registry record.

The mean absolute increment at lag tau over a window of N samples,

    mad_tau = (1 / (N - tau)) * sum_{j=1}^{N-tau} |x_{j+tau} - x_j|,

computed for any sorted window starts in O(n + m) from one prefix sum of the increments.
It is the worked example of docs/features.md ("Adding a feature").
"""

from __future__ import annotations

import numpy as np

from leakdiag.features import FeatureRecord


def mean_abs_increment_kernel(signals, lag, window, starts):
    """Kernel contract of the registry: ``(signals, setting, window, starts) -> (values, n_bad)``."""
    x = signals[0]
    c = np.concatenate([[0.0], np.cumsum(np.abs(x[lag:] - x[:-lag]))])
    values = (c[starts + window - lag] - c[starts]) / (window - lag)
    return values, 0


RECORD = FeatureRecord(
    "mean-abs-increment", mean_abs_increment_kernel, channels=("p1",), n_channels=1,
    setting="lag", default_setting=1, aliases=("mai",), direction="up",
    equation="toy example, docs/features.md")
