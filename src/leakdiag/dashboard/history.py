"""The points of the history page: chunk summaries merged run by run, within a point budget.

Vectorised: the summaries are sorted once by feature, run and time, the blocks of a layout are
planned from the run sizes and the blocks' last times alone, and all blocks are merged in one
pass (:func:`leakdiag.store.merge_blocks`), whatever the number of runs. A per-run loop took
4.8 s for 1,500 one-chunk runs (user audit, 2026-11-29).
"""

from __future__ import annotations

import numpy as np

__all__ = ["history_points", "GAP_INTERVALS", "GAP_MIN_S"]

#: A gap inside a run longer than this many of its median intervals between points (and
#: than :data:`GAP_MIN_S`) breaks the history line: no data were recorded there.
GAP_INTERVALS = 5.0
#: Smallest gap (s) that breaks the line (chunks handed over within this are drawn joined).
GAP_MIN_S = 2.0
#: Most tries of a coarser layout before the one that fits by construction (a few suffice:
#: each removes the overflow of the one before).
_MAX_TRIES = 30


def _gaps(at, group):
    """Whether each point follows a gap of its group (its line is broken before it).

    ``at``: the points' wall times (datetime64), ``group``: each point's group (runs, or the
    whole feature), non-decreasing. A point is after a gap when its interval from the point
    before in its group exceeds :data:`GAP_INTERVALS` times the group's median interval and
    :data:`GAP_MIN_S`.
    """
    import pandas as pd

    d = pd.to_datetime(pd.Series(at), utc=True).diff().dt.total_seconds().to_numpy(copy=True)
    first = np.r_[True, group[1:] != group[:-1]]
    d[first] = np.nan
    med = pd.Series(d).groupby(group).median().to_numpy()
    _, g = np.unique(group, return_inverse=True)
    with np.errstate(invalid="ignore"):
        return d > np.maximum(GAP_INTERVALS * med[g], GAP_MIN_S)


def _plan_by_run(k, gstart, gsize, at):
    """Blocks of at most ``k`` chunks within each run (sized as ``merge_summaries`` sizes a
    run's blocks); a break before each run but the first and at each gap."""
    p = -(-gsize // k)
    kr = -(-gsize // p)  # merge_summaries(run, p): blocks of ceil(n / p) chunks
    p = -(-gsize // kr)
    run = np.repeat(np.arange(len(gsize)), p)
    within = np.arange(int(p.sum())) - np.repeat(np.cumsum(p) - p, p)
    starts = gstart[run] + within * kr[run]
    ends = np.append(starts[1:], gstart[-1] + gsize[-1]) - 1
    brk = _gaps(at[ends], run) | (within == 0)
    brk[0] = False
    return starts, (kr == 1)[run], brk, np.ones(len(starts), np.int64)


def _plan_runs_joined(g, gstart, gsize, at):
    """Points of ``g`` whole consecutive runs each, one line broken only at gaps."""
    first = np.arange(0, len(gsize), g)
    starts = gstart[first]
    ends = np.append(starts[1:], gstart[-1] + gsize[-1]) - 1
    brk = _gaps(at[ends], np.zeros(len(starts), np.int64))
    n_runs = np.diff(np.append(first, len(gsize)))
    return starts, ends == starts, brk, n_runs


def _plan(budget, gstart, gsize, at):
    """The layout of one feature's runs within ``budget`` points and breaks.

    1. Blocks of ``ceil(n / budget)`` chunks within each run (the layout before 2026-11-29),
       if that fits;
    2. else larger blocks within each run, if one point per run and a break between runs fit
       (``2 * runs - 1 <= budget``);
    3. else whole consecutive runs per point, one line broken only at gaps.
    """
    n, n_r = int(gsize.sum()), len(gsize)
    k = max(1, -(-n // budget))
    plan = _plan_by_run(k, gstart, gsize, at)
    rows = len(plan[0]) + int(plan[2].sum())
    if rows <= budget:
        return plan
    if 2 * n_r - 1 <= budget:  # larger blocks: one point per run (k = max size) fits
        target, k_max = budget, int(gsize.max())
        for _ in range(_MAX_TRIES):
            room = target - (n_r - 1)  # points that the breaks between runs leave
            if room < n_r or k >= k_max:
                break
            lo, hi = k + 1, k_max  # smallest k with sum(ceil(size / k)) <= room
            while lo < hi:
                mid = (lo + hi) // 2
                if int((-(-gsize // mid)).sum()) <= room:
                    hi = mid
                else:
                    lo = mid + 1
            k = lo
            plan = _plan_by_run(k, gstart, gsize, at)
            rows = len(plan[0]) + int(plan[2].sum())
            if rows <= budget:
                return plan
            target -= rows - budget  # the gaps' breaks: leave room for them
        return _plan_by_run(k_max, gstart, gsize, at)  # 2 * runs - 1 rows
    safe = -(-n_r // ((budget + 1) // 2))  # so many runs per point: points + breaks fit
    g = -(-n_r // budget)
    for _ in range(_MAX_TRIES):
        if g >= safe:
            break
        plan = _plan_runs_joined(g, gstart, gsize, at)
        rows = len(plan[0]) + int(plan[2].sum())
        if rows <= budget:
            return plan
        room = budget - int(plan[2].sum())  # points that these gaps' breaks leave
        g = safe if room < 1 else max(g + 1, -(-n_r // room))
    return _plan_runs_joined(safe, gstart, gsize, at)


def history_points(summ, max_points: int):
    """The points of a history plot: each feature's chunk summaries merged run by run.

    Each run's summaries are merged on their own (:func:`leakdiag.store.merge_summaries`,
    blocks of the same number of chunks across the feature's runs, so that all together make
    about ``max_points / number of features`` points), so no point mixes two runs. The runs
    follow one another (by their first chunk), a row of nulls between two (Plotly breaks a
    line there), and a run is broken likewise where its points are further apart than
    :data:`GAP_INTERVALS` median intervals and :data:`GAP_MIN_S`. So two monitors of one
    actuator at once are two lines, not one zig-zagging between them, and no line bridges
    days without data.

    Points and null rows together are at most ``max_points``: if the layout above makes more
    (many runs: each has at least a point and a null row), each feature gets at most
    ``max_points // number of features`` (at least 1), its blocks made larger, the same size
    for every run, where the layout above overflows that share; when even one point
    per run and a null row between runs overflow it, whole consecutive runs are merged into
    each point (as few as fit) and drawn as one line, broken only at gaps (``n_runs`` > 1 or
    runs without a null row between them: the page says so).

    Parameters
    ----------
    summ : pandas.DataFrame
        :meth:`leakdiag.store.EventStore.history` summaries (with ``run_id`` and ``feature``).
    max_points : int
        Largest number of rows (points and null rows); at least one point per feature.

    Returns
    -------
    points : pandas.DataFrame
        :func:`~leakdiag.store.merge_summaries` columns plus ``feature``, ``run_id`` (of the
        point's last chunk) and ``n_runs`` (runs merged into the point); the break rows have
        only ``recorded_at``, ``feature`` and ``run_id`` (``n_chunks`` null).
    features : list of str
        The features, in order of their first chunk.

    Raises
    ------
    ValueError
        If ``max_points`` < 1.

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"recorded_at": pd.to_datetime([0, 1, 2, 3, 5, 7, 3600], unit="s"),
    ...     "t_start_s": 0.0, "t_end_s": 1.0, "n_windows": 2, "n_degenerate": 0,
    ...     "value_mean": [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0], "value_min": 0.0,
    ...     "value_max": 9.0, "score_max": None, "alarm": None, "source": "a",
    ...     "feature": "f", "run_id": [1, 2, 1, 2, 2, 2, 2]})
    >>> p, _ = history_points(s, 100)
    >>> p["value_mean"].tolist()  # run 1; break; run 2, broken across the hour's gap
    [1.0, 3.0, nan, 2.0, 4.0, 5.0, 6.0, nan, 7.0]
    >>> cols = ["run_id", "n_runs", "n_chunks", "value_mean"]
    >>> p, _ = history_points(s, 2)  # 2 runs apart need 3 rows: one point a run, joined
    >>> p[cols].values.tolist()
    [[1.0, 1.0, 2.0, 2.0], [2.0, 1.0, 5.0, 4.8]]
    >>> history_points(s, 1)[0][cols].values.tolist()  # both runs in one point
    [[2.0, 2.0, 7.0, 4.0]]
    """
    import pandas as pd

    from leakdiag.store import merge_blocks, merge_summaries

    if max_points < 1:
        raise ValueError(f"max_points={max_points!r} must be >= 1")
    feats = list(dict.fromkeys(summ["feature"].tolist()))
    n = len(summ)
    if not n:
        return merge_summaries(summ, max_points).assign(feature=None, run_id=None,
                                                        n_runs=None), feats
    fcode = pd.factorize(summ["feature"], use_na_sentinel=False)[0]
    run = summ["run_id"].to_numpy()
    # runs numbered in order of their first chunk, then sorted: feature, run, time
    gcode = pd.DataFrame({"f": fcode, "r": run}).groupby(["f", "r"], sort=False).ngroup()
    order = np.lexsort((np.arange(n), gcode.to_numpy(), fcode))
    ss = summ.take(order).reset_index(drop=True)
    g_sorted, f_sorted = gcode.to_numpy()[order], fcode[order]
    gstart = np.flatnonzero(np.r_[True, g_sorted[1:] != g_sorted[:-1]])
    gsize = np.diff(np.append(gstart, n))
    at = ss["recorded_at"].to_numpy()
    budget = max(1, max_points // max(len(feats), 1))
    plans = []
    for f in range(len(feats)):  # a few features; each planned in a few vectorised passes
        mine = f_sorted[gstart] == f
        r0 = int(gstart[mine][0])
        gs, gn = gstart[mine] - r0, gsize[mine]
        plans.append((r0, gs, gn, _plan_by_run(max(1, -(-int(gn.sum()) // budget)), gs, gn,
                                               at[r0:])))
    if sum(len(p[3][0]) + int(p[3][2].sum()) for p in plans) > max_points:
        # over the budget: each feature within its share (the layout above where it fits)
        plans = [(r0, gs, gn, _plan(budget, gs, gn, at[r0:])) for r0, gs, gn, _ in plans]
    starts = np.concatenate([p[0] + r0 for r0, _, _, p in plans])
    brk = np.concatenate([p[2] for *_, p in plans])
    raw = [p[1] for *_, p in plans]
    n_runs = [p[3] for *_, p in plans]
    m = merge_blocks(ss, starts, np.concatenate(raw))
    ends = np.append(starts[1:], n) - 1
    m = m.assign(feature=ss["feature"].to_numpy()[ends], run_id=run[order][ends],
                 n_runs=np.concatenate(n_runs))
    if not brk.any():
        return m, feats
    b = np.flatnonzero(brk)  # a null row before each of these points
    nulls = pd.DataFrame({"recorded_at": m["recorded_at"].iloc[b].tolist(),
                          "feature": m["feature"].iloc[b].tolist(),
                          "run_id": m["run_id"].iloc[b].tolist()})
    out = pd.concat([m, nulls], ignore_index=True)
    key = np.argsort(np.concatenate([2 * np.arange(len(m)) + 1, 2 * b]), kind="stable")
    return out.iloc[key].reset_index(drop=True), feats
