"""Shared pieces of the windowed-feature kernels: chunk size, the empty start array, window times."""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["CHUNK", "NO_STARTS", "PRODUCT_MAX", "PRODUCT_MIN", "UINT", "fill_times"]

CHUNK = 4096  # windows per chunk: the per-window columns stay in L2 (16 x 32 KiB at most)

NO_STARTS = np.empty(0, dtype=np.int64)  # the `starts` argument of a regular-window call

# Sample indices in the kernels' hot loops are cast to unsigned: Numba then adds no
# negative-index wraparound, which costs 4-14 % in the per-term loops and keeps LLVM from
# vectorising the step-increment loops (docs/features.md). Every such index is >= 0 by
# construction (window starts are validated).
UINT = np.uint64

# Eq. 4.2's denominator is evaluated as sqrt(ss_x * ss_y), one square root instead of two (7 %
# of the cross-correlation kernel at step 2). The product is exact to rounding while it stays
# inside [PRODUCT_MIN, PRODUCT_MAX]; the evaluation loops count the windows where it does not
# (over- or underflow, e.g. pressures in units of 1e-100) and then redo their chunk with
# sqrt(ss_x) * sqrt(ss_y).
PRODUCT_MIN = 1e-300
PRODUCT_MAX = 1e300


@numba.njit(cache=True)
def fill_times(times, step, window, sample_rate, start_time):  # pragma: no cover - compiled
    """Write the window times ``(k * step + window - 1) / sample_rate + start_time`` in place.

    Same operations in the same order as :func:`leakdiag.features.window_times`, so the values
    are bit-identical.
    """
    last = float(window - 1)
    for k in range(times.shape[0]):
        times[k] = (float(k * step) + last) / sample_rate + start_time
