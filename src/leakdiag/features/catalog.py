"""The thesis's four windowed features as registry records (Ch. 4, Eq. 4.1-4.4, 4.11-4.14).

Each record joins a feature module's three entry points (batch function, ``*_at`` function,
Numba kernel) to its name, aliases, channels, setting and expected leak direction. Importing
:mod:`leakdiag.features` registers them; a new feature registers its own record the same way
(see ``docs/features.md``, "Adding a feature").
"""

from __future__ import annotations

import numpy as np

from leakdiag.features._kernels.blocksums import autocorrelation_sorted, cross_correlation_sorted
from leakdiag.features.correlation import (
    autocorrelation_at,
    autocorrelation_planned,
    cross_correlation_at,
    cross_correlation_planned,
)
from leakdiag.features.metric_length import (
    _DEGENERATE,
    _metric_sorted,
    metric_length_planned,
    metric_length_ratio_at,
)
from leakdiag.features.moments import MOMENT_NAMES, _moments_sorted, moments_at, moments_planned
from leakdiag.features.registry import FeatureRecord, register_feature

__all__ = ["AUTOCORRELATION", "CROSS_CORRELATION", "METRIC_LENGTH", "MOMENTS"]


def _columns(signals) -> np.ndarray:
    """Channels as one C-contiguous ``(samples, channels)`` array (Eq. 4.4's norm over them)."""
    if len(signals) == 1:
        return np.ascontiguousarray(signals[0]).reshape(-1, 1)
    return np.column_stack(signals)


def _one(signals):
    return signals[0] if len(signals) == 1 else _columns(signals)


#: Eq. 4.1: the windowed autocorrelation coefficient; decreases under a leak (Ch. 5-6).
AUTOCORRELATION = register_feature(FeatureRecord(
    "autocorrelation",
    kernel=lambda s, lag, window, starts: autocorrelation_sorted(s[0], lag, window, starts),
    channels=("p1",), n_channels=1, setting="lag", default_setting=1, min_lag=1,
    aliases=("acf",), direction="down", equation="Eq. 4.1", thesis_name="autocorrelation",
    batch=lambda s, lag, plan, chans: autocorrelation_planned(s[0], lag, plan, chans),
    at=lambda s, lag, starts, window: autocorrelation_at(s[0], lag, starts, window),
))

#: Eq. 4.2: the windowed cross-correlation coefficient of ``(y, x)``; decreases under a leak.
CROSS_CORRELATION = register_feature(FeatureRecord(
    "cross-correlation",
    kernel=lambda s, lag, window, starts: cross_correlation_sorted(s[0], s[1], lag, window,
                                                                   starts),
    channels=("p1", "p2"), n_channels=2, setting="lag", default_setting=1, min_lag=1,
    aliases=("crosscorrelation", "ccf"), direction="down", equation="Eq. 4.2",
    thesis_name="cross_correlation",
    batch=lambda s, lag, plan, chans: cross_correlation_planned(s[0], s[1], lag, plan, chans),
    at=lambda s, lag, starts, window: cross_correlation_at(s[0], s[1], lag, starts, window),
))

#: Eq. 4.3-4.4: the ratio of metric lengths at steps l and k (one or more channels); increases.
METRIC_LENGTH = register_feature(FeatureRecord(
    "metric-length",
    kernel=lambda s, lr, window, starts: _metric_sorted(_columns(s), lr[0], lr[1], window,
                                                        starts),
    channels=("p1",), n_channels=None, setting="lag_ratio", default_setting=(83, 3),
    aliases=("metric-length-ratio", "ratio-of-metric-lengths"), direction="up",
    equation="Eq. 4.3-4.4", degenerate=_DEGENERATE, thesis_name="ratio_of_metric_lengths",
    sum_power=1,
    batch=lambda s, lr, plan, chans: metric_length_planned(_columns(s), lr, plan, chans),
    at=lambda s, lr, starts, window: metric_length_ratio_at(_one(s), lr, starts, window),
))

#: Eq. 4.11-4.14: mean, variance, skewness, kurtosis (the stationarity check, Sec. 4.7).
MOMENTS = register_feature(FeatureRecord(
    "moments",
    kernel=lambda s, _, window, starts: _moments_sorted(s[0], window, starts),
    channels=("p1",), n_channels=1, setting=None, outputs=MOMENT_NAMES, direction=None,
    equation="Eq. 4.11-4.14", degenerate="zero variance (skewness and kurtosis)",
    thesis_name="moments", sum_power=4,
    batch=lambda s, _, plan, chans: moments_planned(s[0], plan, chans),
    at=lambda s, _, starts, window: moments_at(s[0], starts, window).T,
    streamable=False,
))
