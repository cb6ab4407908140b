"""Shared pieces of the windowed-feature kernels: chunk size, the empty start array, window times."""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["CHUNK", "NO_STARTS", "fill_times"]

CHUNK = 4096  # windows per chunk: the per-window columns stay in L2 (16 x 32 KiB at most)

NO_STARTS = np.empty(0, dtype=np.int64)  # the `starts` argument of a regular-window call


@numba.njit(cache=True)
def fill_times(times, step, window, sample_rate, start_time):  # pragma: no cover - compiled
    """Write the window times ``(k * step + window - 1) / sample_rate + start_time`` in place.

    Same operations in the same order as :func:`leakdiag.features.window_times`, so the values
    are bit-identical.
    """
    last = float(window - 1)
    for k in range(times.shape[0]):
        times[k] = (float(k * step) + last) / sample_rate + start_time
