"""What the store keeps of a chunk: :class:`ChunkSummary` and :class:`AlarmRecord`; of a whole
run judged at once (``batch``, ``detect``): :class:`FinishedRun`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ChunkSummary", "AlarmRecord", "FinishedRun", "summarize_windows", "summarize_chunks",
           "merge_summaries", "merge_blocks"]


def _f(v) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


@dataclass(frozen=True)
class ChunkSummary:
    """The windows one chunk of a stream completed, summarised.

    Attributes
    ----------
    t_start_s, t_end_s : float
        Time (s) of the first and last completed window (time of each window's last sample).
    n_windows : int
        Windows completed in the chunk.
    n_degenerate : int
        Of these, windows whose feature is NaN (zero variance).
    value_mean, value_min, value_max, value_last : float or None
        Feature over the finite windows (None if there is none).
    score_max, score_last : float or None
        Detector score (None without a detector or when every score is NaN, e.g. burn-in).
    alarm : bool or None
        Whether any window of the chunk is in alarm (None without a detector).
    """

    t_start_s: float
    t_end_s: float
    n_windows: int
    n_degenerate: int
    value_mean: float | None
    value_min: float | None
    value_max: float | None
    value_last: float | None
    score_max: float | None = None
    score_last: float | None = None
    alarm: bool | None = None


@dataclass(frozen=True)
class AlarmRecord:
    """An alarm as stored: when it was raised (stream time), its onset and leak estimates.

    Attributes
    ----------
    alarm_time_s : float
        Time (s) of the first window in alarm.
    score, threshold : float or None
        Detector score at the alarm and its threshold.
    onset_s : float or None
        Estimated leak onset (s).
    onset_censored : bool or None
        True when the onset is the first window judged: the leak was there from the start and
        ``onset_s`` is an upper bound (None: not known, e.g. a store before schema version 3).
    leak_lpm, leak_lpm_low, leak_lpm_high : float or None
        Leak flow estimate and its interval (L/min), when the detector sizes leaks.
    cleared_time_s : float or None
        Time (s) at which the alarm episode ended: the first window out of alarm with the
        CUSUM excursion back at 0 (a dip under the threshold does not end it).
    detector : str or None
        Feature or method name.
    leak_extrapolated : bool or None
        True when the feature shift lies outside the calibrated range, so the size is an
        extrapolation its interval does not cover (None: not known or no size).
    leak_interval : str or None
        What the bracket ``[leak_lpm_low, leak_lpm_high]`` is, in the detector's words
        (``"90 % prediction interval"`` of a calibrated feature, the flow balance's interval).
    """

    alarm_time_s: float
    score: float | None = None
    threshold: float | None = None
    onset_s: float | None = None
    leak_lpm: float | None = None
    leak_lpm_low: float | None = None
    leak_lpm_high: float | None = None
    cleared_time_s: float | None = None
    detector: str | None = None
    onset_censored: bool | None = None
    leak_extrapolated: bool | None = None
    leak_interval: str | None = None


@dataclass(frozen=True)
class FinishedRun:
    """A run judged as a whole (a ``batch`` result row, one method of ``detect``), written with
    its summary, alarms and end in one transaction (:meth:`EventStore.add_finished_runs`).

    Attributes
    ----------
    command : str
        ``batch`` or ``detect``.
    source : str
        The judged recording (named in messages, e.g. a rig that disagrees with the store's).
    feature : str
        Feature, method or detector name.
    status : str, default "finished"
        ``finished``, ``failed``, ``unjudged`` or ``inconclusive`` (it alarmed, but the alarm
        is no evidence of a leak).
    error : str or None
        Why it failed, was not judged or was inconclusive.
    sample_rate_hz, threshold : float or None
        Sample rate (Hz) and detector threshold.
    system : str or None
        The recording's rig (``vca``/``eha``), None when not known.
    config : dict or None
        Settings stored as JSON.
    summary : ChunkSummary or None
        The whole recording's windows as one summary.
    alarms : tuple of AlarmRecord
        Alarms raised.
    key : str or None
        Identity of a batch result row: a run whose key the actuator already has in the store is
        not written again (stored as ``config["row"]``).
    """

    command: str
    source: str
    feature: str
    status: str = "finished"
    error: str | None = None
    sample_rate_hz: float | None = None
    threshold: float | None = None
    system: str | None = None
    config: dict | None = None
    summary: ChunkSummary | None = None
    alarms: tuple = ()
    key: str | None = None


def summarize_windows(time, values, scores=None, alarms=None) -> ChunkSummary | None:
    """Summarise the windows of one chunk.

    Parameters
    ----------
    time : array_like
        Window times (s), in order.
    values : array_like
        Feature values (NaN for degenerate windows).
    scores : array_like, optional
        Detector scores (NaN within the burn-in).
    alarms : array_like of bool, optional
        Detector alarms.

    Returns
    -------
    ChunkSummary or None
        None when the chunk completed no window.

    Raises
    ------
    ValueError
        If the arrays differ in length.

    Examples
    --------
    >>> s = summarize_windows([1.0, 2.0, 3.0], [0.5, float("nan"), 0.1], [0.0, 1.0, 4.0],
    ...                       [False, False, True])
    >>> s.n_windows, s.n_degenerate, s.value_mean, s.value_last, s.score_max, s.alarm
    (3, 1, 0.3, 0.1, 4.0, True)
    """
    t = np.asarray(time, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if v.shape != t.shape:
        raise ValueError(f"values has shape {v.shape}, time has {t.shape}")
    if len(t) == 0:
        return None
    fin = v[np.isfinite(v)]
    s_max = s_last = a_any = None
    if scores is not None:
        s = np.asarray(scores, dtype=np.float64)
        if s.shape != t.shape:
            raise ValueError(f"scores has shape {s.shape}, time has {t.shape}")
        sf = s[np.isfinite(s)]
        s_max = _f(sf.max()) if len(sf) else None
        s_last = _f(s[-1])
    if alarms is not None:
        a = np.asarray(alarms, dtype=bool)
        if a.shape != t.shape:
            raise ValueError(f"alarms has shape {a.shape}, time has {t.shape}")
        a_any = bool(a.any())
    return ChunkSummary(
        float(t[0]), float(t[-1]), int(len(t)), int(len(v) - len(fin)),
        _f(fin.mean()) if len(fin) else None, _f(fin.min()) if len(fin) else None,
        _f(fin.max()) if len(fin) else None, _f(v[-1]), s_max, s_last, a_any)


def _nan_none(x: list) -> list:
    return [v if math.isfinite(v) else None for v in x]


def summarize_chunks(time, values, scores=None, alarms=None, counts=()) -> list[ChunkSummary]:
    """Summarise several consecutive chunks at once (as :func:`summarize_windows` on each).

    The windows of all chunks come concatenated; ``counts`` says how many belong to each chunk.
    The statistics are computed with ``numpy.ufunc.reduceat`` over the chunk boundaries, so the
    cost does not grow with the number of chunks as a Python loop over them would (the event
    store's writer takes every chunk a fast replay produced in one pass).

    Parameters
    ----------
    time : array_like
        Window times (s), in order.
    values : array_like
        Feature values (NaN for degenerate windows).
    scores : array_like, optional
        Detector scores (NaN within the burn-in).
    alarms : array_like of bool, optional
        Detector alarms.
    counts : sequence of int
        Windows per chunk, summing to ``len(time)``; chunks with 0 windows give no summary.

    Returns
    -------
    list of ChunkSummary
        One per chunk with at least one window, equal to :func:`summarize_windows` on its
        windows (the mean summed in another order: equal to about 1e-15 relative).

    Raises
    ------
    ValueError
        If the arrays differ in length, or ``counts`` is negative or does not sum to their length.

    Examples
    --------
    >>> out = summarize_chunks([1.0, 2.0, 3.0], [0.5, float("nan"), 0.1], [0.0, 1.0, 4.0],
    ...                        [False, False, True], counts=[2, 0, 1])
    >>> [(s.t_start_s, s.n_windows, s.n_degenerate, s.value_mean, s.alarm) for s in out]
    [(1.0, 2, 1, 0.5, False), (3.0, 1, 0, 0.1, True)]
    """
    t = np.asarray(time, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    c = np.asarray(counts, dtype=np.int64).reshape(-1)
    if v.shape != t.shape:
        raise ValueError(f"values has shape {v.shape}, time has {t.shape}")
    if (c < 0).any() or int(c.sum()) != len(t):
        raise ValueError(f"counts must be >= 0 and sum to {len(t)} windows, got sum {int(c.sum())}")
    c = c[c > 0]
    if not len(c):
        return []
    ends = np.cumsum(c)
    starts = ends - c
    fin = np.isfinite(v)
    n_fin = np.add.reduceat(fin.astype(np.int64), starts)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.add.reduceat(np.where(fin, v, 0.0), starts) / n_fin
    vmin = np.minimum.reduceat(np.where(fin, v, np.inf), starts)
    vmax = np.maximum.reduceat(np.where(fin, v, -np.inf), starts)
    none = [None] * len(c)
    s_max = s_last = a_any = none
    if scores is not None:
        s = np.asarray(scores, dtype=np.float64)
        if s.shape != t.shape:
            raise ValueError(f"scores has shape {s.shape}, time has {t.shape}")
        s_max = _nan_none(np.maximum.reduceat(np.where(np.isfinite(s), s, -np.inf),
                                              starts).tolist())
        s_last = _nan_none(s[ends - 1].tolist())
    if alarms is not None:
        a = np.asarray(alarms, dtype=bool)
        if a.shape != t.shape:
            raise ValueError(f"alarms has shape {a.shape}, time has {t.shape}")
        a_any = np.logical_or.reduceat(a, starts).tolist()
    return [ChunkSummary(*row) for row in zip(
        t[starts].tolist(), t[ends - 1].tolist(), c.tolist(), (c - n_fin).tolist(),
        _nan_none(mean.tolist()), _nan_none(vmin.tolist()), _nan_none(vmax.tolist()),
        _nan_none(v[ends - 1].tolist()), s_max, s_last, a_any)]


def merge_summaries(summ, max_points: int):
    """Merge consecutive rows of a history into at most ``max_points`` rows (for a plot).

    Blocks of ``k = ceil(n / max_points)`` consecutive chunk summaries become one row: the last
    ``recorded_at``, the first ``t_start_s`` and last ``t_end_s``, the mean of the feature
    weighted by each chunk's finite windows (``n_windows - n_degenerate``), the smallest
    minimum, the largest maximum and largest score, and ``alarm`` True if any chunk was in
    alarm (None if no chunk had a detector). A history of fewer rows is returned as it is, with
    ``n_chunks`` 1.

    Parameters
    ----------
    summ : pandas.DataFrame
        Summaries from :meth:`leakdiag.store.EventStore.history`, in order.
    max_points : int
        Largest number of rows returned (>= 1).

    Returns
    -------
    pandas.DataFrame
        Columns ``recorded_at``, ``t_start_s``, ``t_end_s``, ``n_chunks``, ``n_windows``,
        ``value_mean``, ``value_min``, ``value_max``, ``score_max``, ``alarm``, ``source``.

    Raises
    ------
    ValueError
        If ``max_points`` < 1.

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"recorded_at": [1, 2, 3], "t_start_s": [0.0, 1.0, 2.0],
    ...                   "t_end_s": [0.9, 1.9, 2.9], "n_windows": [4, 2, 3],
    ...                   "n_degenerate": [0, 1, 0], "value_mean": [1.0, 4.0, 0.0],
    ...                   "value_min": [0.0, 4.0, -1.0], "value_max": [2.0, 4.0, 1.0],
    ...                   "score_max": [1.0, None, 3.0], "alarm": [False, None, True],
    ...                   "source": ["a", "a", "b"]})
    >>> m = merge_summaries(s, 2)
    >>> cols = ["n_chunks", "n_windows", "value_mean", "value_min", "score_max", "alarm"]
    >>> m[cols].values.tolist()
    [[2, 6, 1.6, 0.0, 1.0, False], [1, 3, 0.0, -1.0, 3.0, True]]
    """
    if max_points < 1:
        raise ValueError(f"max_points={max_points!r} must be >= 1")
    n = len(summ)
    k = max(1, -(-n // max_points))
    return merge_blocks(summ, np.arange(0, n, k, dtype=np.int64), k == 1)


def merge_blocks(summ, starts, raw):
    """Merge the blocks of consecutive rows of a history that begin at ``starts``.

    The reductions of :func:`merge_summaries` over blocks of any sizes, all in one pass (the
    history page's blocks differ from run to run:
    :func:`leakdiag.dashboard.history.history_points`).

    Parameters
    ----------
    summ : pandas.DataFrame
        Summaries from :meth:`leakdiag.store.EventStore.history`, in the order of the blocks.
    starts : array of int, shape (n_blocks,)
        Row where each block begins, increasing from 0; a block ends where the next begins
        (the last at the end of ``summ``).
    raw : bool or array of bool, shape (n_blocks,)
        Blocks of one chunk whose ``value_mean`` is taken as stored (no weighting: no rounding
        by the weights, and a chunk without finite windows keeps its value); the others get
        the mean weighted by the finite windows.

    Returns
    -------
    pandas.DataFrame
        The columns of :func:`merge_summaries`, one row per block.

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"recorded_at": [1, 2, 3], "t_start_s": [0.0, 1.0, 2.0],
    ...                   "t_end_s": [0.9, 1.9, 2.9], "n_windows": [4, 2, 3],
    ...                   "n_degenerate": [0, 1, 0], "value_mean": [1.0, 4.0, 0.0],
    ...                   "value_min": [0.0, 4.0, -1.0], "value_max": [2.0, 4.0, 1.0],
    ...                   "score_max": [1.0, None, 3.0], "alarm": [False, None, True],
    ...                   "source": ["a", "a", "b"]})
    >>> m = merge_blocks(s, np.array([0, 2]), [False, True])  # chunks 0-1, then chunk 2
    >>> m[["n_chunks", "value_mean"]].values.tolist()  # (1*4 + 4*1) / 5, then as stored
    [[2.0, 1.6], [1.0, 0.0]]
    """
    import pandas as pd

    n = len(summ)
    starts = np.asarray(starts, dtype=np.int64)
    if not n:
        starts = np.empty(0, dtype=np.int64)
    ends = np.append(starts[1:], n)[:len(starts)] - 1

    def col(c):
        return pd.to_numeric(summ[c], errors="coerce").to_numpy(np.float64)

    def red(ufunc, x, fill):
        if not n:
            return np.empty(0)
        fin = np.isfinite(x)
        out = ufunc.reduceat(np.where(fin, x, fill), starts)
        return np.where(np.add.reduceat(fin.astype(np.int64), starts) > 0, out, np.nan)

    w = col("n_windows") - col("n_degenerate")
    mean = col("value_mean")
    w = np.where(np.isfinite(mean), w, 0.0)
    raw = np.broadcast_to(np.asarray(raw, dtype=bool), starts.shape)
    if raw.all():  # nothing to merge: the values as stored
        wmean = mean[starts]
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            wmean = red(np.add, mean * w, 0.0) / red(np.add, w, 0.0)
        wmean = np.where(raw, mean[starts], wmean)
    a = summ["alarm"]
    known = a.notna().to_numpy()
    on = (a.fillna(False).astype(bool).to_numpy() & known).astype(np.int64)
    n_known = np.add.reduceat(known.astype(np.int64), starts) if n else np.empty(0, np.int64)
    n_on = np.add.reduceat(on, starts) if n else np.empty(0, np.int64)
    alarm = [None if nk == 0 else bool(no) for nk, no in zip(n_known.tolist(), n_on.tolist())]
    return pd.DataFrame({
        "recorded_at": summ["recorded_at"].to_numpy()[ends],
        "t_start_s": col("t_start_s")[starts], "t_end_s": col("t_end_s")[ends],
        "n_chunks": (ends - starts + 1).astype(np.int64),
        "n_windows": red(np.add, col("n_windows"), 0.0).astype(np.int64),
        "value_mean": np.where(np.isfinite(wmean), wmean, np.nan),
        "value_min": red(np.minimum, col("value_min"), np.inf),
        "value_max": red(np.maximum, col("value_max"), -np.inf),
        "score_max": red(np.maximum, col("score_max"), -np.inf),
        "alarm": pd.array(alarm, dtype=object), "source": summ["source"].to_numpy()[ends]})
