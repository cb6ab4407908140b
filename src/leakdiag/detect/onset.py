"""Onset search on a standardised feature series: offline change points and the CUSUM estimate.

* :func:`best_split_gain` -- the largest L2 cost reduction of one split (used to derive the
  change-point penalty from healthy data).
* :func:`change_points` -- PELT or binary segmentation (``ruptures``, L2 cost) with a penalty.
* :func:`cusum_onset` -- the index after the last zero of the CUSUM branch that raised the alarm
  (Page's estimate of the change time).
"""

from __future__ import annotations

import numpy as np

from leakdiag._validation import as_1d_float, check_int

__all__ = ["best_split_gain", "change_points", "cusum_onset", "ONSET_METHODS"]

#: Offline and online onset estimators.
ONSET_METHODS = ("pelt", "binseg", "cusum")


def best_split_gain(z, min_size: int = 5) -> float:
    """Largest decrease of the L2 cost obtained by splitting ``z`` once.

    Parameters
    ----------
    z : array_like
        Series (NaN removed by the caller), shape ``(m,)``.
    min_size : int, default 5
        Minimum segment length.

    Returns
    -------
    float
        ``max_t t (m - t) / m * (mean(z[:t]) - mean(z[t:]))**2``; 0 if ``m < 2 * min_size``.

    Notes
    -----
    A penalised search (PELT, binary segmentation) with penalty ``pen`` accepts a single change
    only if its gain exceeds ``pen``; the maximum gain over healthy runs is therefore the smallest
    penalty that finds no change on them.

    Examples
    --------
    >>> best_split_gain([0.0] * 5 + [2.0] * 5)
    10.0
    """
    z = as_1d_float(z, "z")
    min_size = check_int(min_size, "min_size", 1)
    m = len(z)
    if m < 2 * min_size:
        return 0.0
    c = np.cumsum(z)
    t = np.arange(min_size, m - min_size + 1)
    left = c[t - 1] / t
    right = (c[-1] - c[t - 1]) / (m - t)
    return float(np.max(t * (m - t) / m * (left - right) ** 2))


def change_points(z, penalty: float, method: str = "binseg", min_size: int = 5,
                  jump: int = 1) -> list[int]:
    """Change points of ``z`` (indices where a new segment starts), L2 cost.

    Parameters
    ----------
    z : array_like
        Series without NaN, shape ``(m,)``.
    penalty : float
        Penalty per change point (> 0).
    method : {"binseg", "pelt"}, default "binseg"
        ``ruptures.Binseg`` or ``ruptures.Pelt``.
    min_size : int, default 5
        Minimum segment length.
    jump : int, default 1
        Subsampling of candidate indices.

    Returns
    -------
    list of int
        Sorted start indices of the segments after the first (the final ``m`` is dropped).

    Raises
    ------
    ValueError
        Unknown method or non-positive penalty.

    Examples
    --------
    >>> change_points([0.0] * 20 + [3.0] * 20, penalty=5.0, method="pelt")
    [20]
    """
    import ruptures as rpt

    z = as_1d_float(z, "z")
    if not np.isfinite(penalty) or penalty <= 0:
        raise ValueError(f"penalty={penalty!r} must be a finite number > 0")
    if len(z) < 2 * min_size:
        return []
    if method == "pelt":
        algo = rpt.Pelt(model="l2", min_size=min_size, jump=jump)
    elif method == "binseg":
        algo = rpt.Binseg(model="l2", min_size=min_size, jump=jump)
    else:
        raise ValueError(f"method={method!r} must be 'pelt' or 'binseg'")
    bkps = algo.fit(z.reshape(-1, 1)).predict(pen=float(penalty))
    return [int(b) for b in bkps[:-1]]


def cusum_onset(s_branch, alarm_index: int) -> int:
    """Index of the first value of the CUSUM excursion that reached the alarm.

    Parameters
    ----------
    s_branch : array_like
        The CUSUM statistic (``S+`` or ``S-``) that raised the alarm.
    alarm_index : int
        Index of the alarm.

    Returns
    -------
    int
        ``j + 1`` with ``j`` the last index before the alarm where the statistic was 0 (0 if it
        never was).

    Examples
    --------
    >>> cusum_onset([0.0, 0.0, 1.0, 2.5, 4.0], 4)
    2
    """
    s = as_1d_float(s_branch, "s_branch")
    zeros = np.flatnonzero(s[:alarm_index] <= 0.0)
    return int(zeros[-1] + 1) if len(zeros) else 0
