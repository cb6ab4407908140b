"""Windowed features of thesis Chapter 4 (Eq. 4.1-4.4, 4.11-4.14)."""

from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import n_windows, window_starts, window_step, window_times

__all__ = ["FeatureSeries", "window_step", "window_starts", "window_times", "n_windows"]
