"""Windowed features of thesis Chapter 4 (Eq. 4.1-4.4, 4.11-4.14) and their registry.

Public functions return a :class:`FeatureSeries` (one value per window, timestamped at the
window's last sample, with its window geometry); :func:`moments` returns one series per moment.
The ``*_at`` functions evaluate arbitrary window starts in O(n + m) and are the building blocks
for sweeps and streaming checks. Every feature has one record in the registry
(:func:`feature_record`), which the specs, sweeps, streaming monitor and command line read; a new
feature is one kernel module plus one :func:`register_feature` call. See ``docs/features.md``.
"""

from leakdiag._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any kernel is defined (leakdiag._numba_cache)

from leakdiag.features._degenerate import DegenerateWindowWarning
from leakdiag.features.correlation import (
    autocorrelation,
    autocorrelation_at,
    cross_correlation,
    cross_correlation_at,
)
from leakdiag.features.metric_length import metric_length_ratio, metric_length_ratio_at
from leakdiag.features.moments import MOMENT_COLUMNS, MOMENT_NAMES, moments, moments_at, to_frame
from leakdiag.features.registry import (
    FeatureRecord,
    feature_names,
    feature_record,
    register_feature,
    unregister_feature,
)
from leakdiag.features import catalog as _catalog  # noqa: F401  (registers the four of Ch. 4)
from leakdiag.features.series import FeatureSeries
from leakdiag.features.spec import MethodSpec, compute_feature, thesis_defaults
from leakdiag.features.windowing import n_windows, window_starts, window_step, window_times

__all__ = [
    "FeatureSeries",
    "DegenerateWindowWarning",
    "autocorrelation",
    "cross_correlation",
    "metric_length_ratio",
    "moments",
    "autocorrelation_at",
    "cross_correlation_at",
    "metric_length_ratio_at",
    "moments_at",
    "MOMENT_COLUMNS",
    "MOMENT_NAMES",
    "to_frame",
    "FeatureRecord",
    "register_feature",
    "unregister_feature",
    "feature_record",
    "feature_names",
    "MethodSpec",
    "compute_feature",
    "thesis_defaults",
    "window_step",
    "window_starts",
    "window_times",
    "n_windows",
]
