"""Runs of one exact value in a recorded channel: where a sensor held (or froze) its reading.

One primitive, :func:`holds`, under every check that looks for a held value: the EKF's
measurement mask (:mod:`leakdiag.literature.ekf`), the windowed literature methods' frozen
windows (:func:`leakdiag.literature._windowed.frozen_windows`), the EMD's split at holds
(:func:`leakdiag.literature.emd_hilbert.emd_hilbert_amplitude`) and the flow balance's longest
hold (:func:`leakdiag.detect._flow_balance_checks.longest_hold`). What counts as frozen differs
by method (a window long, a multiple of the healthy runs' longest hold, rails exempt) and
stays with each method; what a hold *is* is decided here once: consecutive samples that are
exactly equal. A NaN never equals anything, so each NaN sample is a run of its own (NaN
samples are refused or masked by the callers before this matters).
"""

from __future__ import annotations

import numpy as np

__all__ = ["holds"]


def holds(v) -> tuple[np.ndarray, np.ndarray]:
    """Runs of one exact value in ``v``: their first samples and lengths (samples).

    Parameters
    ----------
    v : array_like
        One channel, shape ``(n,)``.

    Returns
    -------
    starts, lengths : numpy.ndarray of int
        One entry per run, in order; the lengths add up to ``n`` (both empty for ``n = 0``).

    Examples
    --------
    >>> [a.tolist() for a in holds([1.0, 2.0, 2.0, 2.0, 3.0, 3.0])]
    [[0, 1, 4], [1, 3, 2]]
    >>> [a.tolist() for a in holds([np.nan, np.nan, 1.0])]   # NaN != NaN: runs of one
    [[0, 1, 2], [1, 1, 1]]
    """
    v = np.asarray(v, dtype=np.float64)
    if len(v) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.concatenate(([True], v[1:] != v[:-1])))
    return starts, np.diff(np.append(starts, len(v)))
