"""Undefined (NaN) feature windows per side of the onset, and what skipping them does.

A zero-variance window has no correlation (Eq. 4.1/4.2 divide by its variance): its feature
value is NaN, and the Sec. 5.2 measure (:func:`leakdiag.detect.rms_change`) skips it inside its
chunk. When the share of such windows differs before and after the onset, the measure compares
two differently thinned samples; the reproduction therefore reports the counts per side
(:func:`nan_windows_by_side`) and, as a labelled sensitivity, the % change with the NaN values
counted as 0 (:func:`pct_change_nan_as_zero`). The measure itself is not changed
(docs/studies.md, "Degenerate windows in the reproduction"; thesis audit 2026-11-28, F1).
"""

from __future__ import annotations

import numpy as np

from leakdiag._validation import check_int
from leakdiag.detect.measure import TooFewChunksError, rms_change
from leakdiag.features.series import FeatureSeries

__all__ = ["NAN_SIDE_COLUMNS", "nan_windows_by_side", "pct_change_nan_as_zero"]

#: Columns :func:`nan_windows_by_side` returns (in this order).
NAN_SIDE_COLUMNS = ["n_windows_before", "n_windows_after", "n_nan_windows_before",
                    "n_nan_windows_after"]


def nan_windows_by_side(fs: FeatureSeries, onset: float, chunk: int) -> dict:
    """Windows and NaN windows before and after the onset, among the windows in whole chunks.

    A window is *before* the onset when its last sample is earlier than ``onset`` and *after*
    when its first sample is at or later than ``onset``: the rule of
    :func:`leakdiag.detect.rms_change`. Only the windows that fill whole chunks count (the
    ``n_windows - n_windows_dropped`` values the measure cuts into chunks); windows spanning
    the onset count on neither side, so ``n_nan_windows_before + n_nan_windows_after`` is at
    most the measure's ``n_nan_windows``.

    Parameters
    ----------
    fs : FeatureSeries
        Feature series (NaN values are undefined windows).
    onset : float
        Leak onset, s.
    chunk : int
        Chunk length in feature values (Sec. 5.2), >= 1.

    Returns
    -------
    dict
        :data:`NAN_SIDE_COLUMNS` -> int.

    Raises
    ------
    ValueError
        If ``chunk < 1``.

    Examples
    --------
    >>> t = np.arange(12, dtype=float)
    >>> v = np.array([1, np.nan, 1, 1, 1, 1, np.nan, np.nan, 1, np.nan, 1, np.nan])
    >>> nan_windows_by_side(FeatureSeries(t, v, "demo", {}), onset=6.0, chunk=5)
    {'n_windows_before': 6, 'n_windows_after': 4, 'n_nan_windows_before': 1, 'n_nan_windows_after': 3}
    """
    chunk = check_int(chunk, "chunk", 1)
    onset = float(onset)
    n = (len(fs.values) // chunk) * chunk
    t_last = np.asarray(fs.time, dtype=np.float64)[:n]
    t_first = np.asarray(fs.window_start, dtype=np.float64)[:n]
    nan = ~np.isfinite(np.asarray(fs.values, dtype=np.float64)[:n])
    before, after = t_last < onset, t_first >= onset
    return {"n_windows_before": int(before.sum()), "n_windows_after": int(after.sum()),
            "n_nan_windows_before": int((nan & before).sum()),
            "n_nan_windows_after": int((nan & after).sum())}


def pct_change_nan_as_zero(fs: FeatureSeries, onset: float, chunk: int) -> float:
    """Signed % change of the Sec. 5.2 measure with every NaN window counted as 0 (a sensitivity).

    Not the thesis's measure and not leakdiag's: Eq. 4.2 is undefined on a zero-variance
    window, so neither skipping it (the measure) nor reading it as "no correlation" (this) is
    right. The reproduction prints this value beside the measure to show how much the choice
    moves a row whose NaN share differs between the sides (docs/studies.md).

    Parameters
    ----------
    fs : FeatureSeries
        Feature series.
    onset : float
        Leak onset, s.
    chunk : int
        Chunk length in feature values, >= 1.

    Returns
    -------
    float
        Signed % change (Eq. 5-3 without the absolute value); NaN when the measure has no
        whole chunk on a side.

    Raises
    ------
    ValueError
        If ``chunk < 1``.

    Examples
    --------
    >>> t = np.arange(20, dtype=float)
    >>> v = np.where(t < 10, 1.0, 1.0)
    >>> v[[12, 13, 14, 15, 16]] = np.nan  # half the after-onset windows undefined
    >>> fs = FeatureSeries(t, v, "demo", {})
    >>> float(rms_change(fs, 10.0, chunk=10).pct_change_signed)  # skipped: no change
    0.0
    >>> round(pct_change_nan_as_zero(fs, 10.0, chunk=10), 2)  # as 0: RMS sqrt(0.5)
    -29.29
    """
    chunk = check_int(chunk, "chunk", 1)
    values = np.asarray(fs.values, dtype=np.float64)
    zeroed = fs.with_values(np.where(np.isfinite(values), values, 0.0))
    try:
        return float(rms_change(zeroed, onset, chunk=chunk).pct_change_signed)
    except TooFewChunksError:
        return float("nan")
