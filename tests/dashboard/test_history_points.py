"""The history page's points are computed in a few vectorised passes and stay within
HISTORY_POINTS rows (points and line breaks) for any number of runs (user audit, 2026-11-29:
1,500 one-chunk runs took 4.8 s per request and gave 2,999 rows against 2,000). Where the
layout before then fitted, the points are the same: the old per-run implementation is kept here
as the reference (commit b7dd268, with the ``merge_summaries`` it called)."""

from datetime import datetime, timedelta, timezone

import numpy as np
import pandas as pd
import pytest

from leakdiag.dashboard import app
from leakdiag.dashboard.app import history_points
from leakdiag.store import ChunkSummary, EventStore

from .test_app import Client

GAP_INTERVALS, GAP_MIN_S = 5.0, 2.0


def _old_merge_summaries(summ, max_points: int):
    """merge_summaries as of b7dd268."""
    if max_points < 1:
        raise ValueError(f"max_points={max_points!r} must be >= 1")
    n = len(summ)
    k = max(1, -(-n // max_points))
    starts = np.arange(0, n, k)
    ends = np.minimum(starts + k, n) - 1
    if not n:
        starts = ends = np.empty(0, dtype=np.int64)

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
    if k == 1:  # nothing to merge: the values as stored (no rounding by the weights)
        wmean = mean
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            wmean = red(np.add, mean * w, 0.0) / red(np.add, w, 0.0)
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


def _old_history_points(summ, max_points: int):
    """history_points as of b7dd268."""
    merge_summaries = _old_merge_summaries

    feats = list(dict.fromkeys(summ["feature"].tolist()))
    budget = max(1, max_points // max(len(feats), 1))
    parts = []
    for f in feats:
        fs = summ[summ["feature"] == f]
        k = max(1, -(-len(fs) // budget))  # chunks per point, the same for every run
        first = True
        for rid, rs in fs.groupby("run_id", sort=False):
            m = merge_summaries(rs.reset_index(drop=True), max(1, -(-len(rs) // k)))
            at = pd.to_datetime(pd.Series(m["recorded_at"]), utc=True)
            d = at.diff().dt.total_seconds().to_numpy()[1:]
            med = float(np.median(d)) if len(d) else 0.0
            gap = np.flatnonzero(d > max(GAP_INTERVALS * med, GAP_MIN_S)) + 1
            edges = [0, *gap.tolist(), len(m)]
            for i0, i1 in zip(edges[:-1], edges[1:]):
                if not first:  # a null row between two stretches of line
                    parts.append(pd.DataFrame({"recorded_at": [m["recorded_at"].iloc[i0]],
                                               "feature": [f], "run_id": [rid]}))
                parts.append(m.iloc[i0:i1].assign(feature=f, run_id=rid))
                first = False
    if not parts:
        return merge_summaries(summ, max_points).assign(feature=None, run_id=None), feats
    return pd.concat(parts, ignore_index=True), feats


T0 = np.datetime64("2026-11-20T08:00:00", "us")


def _summaries(rng, n_runs, feats=("f",), max_len=40, gap_p=0.05, spread_s=600.0):
    """A history as EventStore.history gives it (naive datetime64[us] by time of recording):
    runs of random lengths, features and starts (some at once), random gaps, undefined values,
    chunks without finite windows, and no score or alarm for the feature 'nodet'."""
    lens = rng.integers(1, max_len + 1, n_runs)
    n, run = int(lens.sum()), np.repeat(np.arange(n_runs), lens)
    step = np.where(rng.random(n) < gap_p, rng.uniform(60.0, 3600.0, n),
                    rng.uniform(0.5, 1.5, n))
    cs = np.cumsum(step)
    t = (rng.uniform(0.0, spread_s, n_runs) - (cs - step)[np.cumsum(lens) - lens])[run] + cs
    f = np.asarray(feats, dtype=object)[rng.integers(len(feats), size=n_runs)][run]
    det = f != "nodet"
    nw = rng.integers(1, 6, n)
    mean = np.where(rng.random(n) < 0.05, np.nan, rng.normal(0.0, 1.0, n))
    on = rng.random(n) < 0.1
    s = pd.DataFrame({
        "run_id": run + 1, "recorded_at": T0 + (t * 1e6).astype("timedelta64[us]"),
        "t_start_s": t - 1.0, "t_end_s": t, "n_windows": nw,
        "n_degenerate": np.where(rng.random(n) < 0.05, nw, rng.integers(0, 2, n)),
        "value_mean": mean, "value_min": mean - 1.0, "value_max": mean + 1.0,
        "score_max": np.where(det, rng.uniform(0.0, 9.0, n), np.nan),
        "alarm": pd.array([bool(a) if d else None for a, d in zip(on, det)], dtype=object),
        "feature": f, "source": [f"/x/run{r}.csv" for r in run]})
    return s.sort_values("recorded_at", kind="stable").reset_index(drop=True)


def _rows_per_feature(p):
    return p.groupby("feature", sort=False).size().to_dict()


@pytest.mark.parametrize("seed", range(12))
def test_same_points_as_the_per_run_loop_where_it_fitted(seed):
    rng = np.random.default_rng(seed)
    n_same = 0
    for n_runs in (1, 2, 5, 20):
        feats = ("f", "g", "nodet")[:1 + seed % 3]
        s = _summaries(rng, n_runs, feats, max_len=40 if seed % 2 else 5)
        for max_points in (3, 8, 20, 60, 200, 2000):
            old, old_feats = _old_history_points(s, max_points)
            new, new_feats = history_points(s, max_points)
            assert new_feats == old_feats
            if len(old) <= max_points:
                pd.testing.assert_frame_equal(new.drop(columns="n_runs", errors="ignore"), old)
                assert set(new["n_runs"].dropna()) <= {1}
                n_same += 1
            else:
                assert len(new) <= max_points
                _check_whole_runs(s, new)
    assert n_same >= 12  # most cases fitted before: these pin the old points exactly


def _check_whole_runs(s, p):
    """Every feature's chunks all counted once, and every point holds whole runs or part of
    one run (its n_chunks never straddles a run's end)."""
    for f, fs in s.groupby("feature", sort=False):
        sizes = fs.groupby("run_id", sort=False).size().to_numpy()  # by first chunk
        pts = p[(p["feature"] == f) & p["n_chunks"].notna()]
        assert pts["n_chunks"].sum() == len(fs) and pts["n_runs"].sum() >= len(sizes)
        run_ends = set(np.cumsum(sizes).tolist())
        ends = np.cumsum(pts["n_chunks"].to_numpy(np.int64))
        many = pts["n_runs"].to_numpy() > 1
        assert set(ends[many].tolist()) <= run_ends  # merged runs: whole ones
        if pts["n_runs"].max() == 1:  # runs apart: each run's points sum to its chunks
            per_run = pts.groupby("run_id")["n_chunks"].sum()
            assert per_run.to_dict() == fs.groupby("run_id").size().to_dict()


def _old_rows_at_least(s, max_points):
    """Rows of the per-run loop without its gap breaks (its points and a null row between two
    runs), without running it (5 s for 1,500 runs)."""
    budget, n = max(1, max_points // s["feature"].nunique()), 0
    for _, fs in s.groupby("feature"):
        sizes = fs.groupby("run_id").size().to_numpy()
        k = -(-len(fs) // budget)
        n += int((-(-sizes // k)).sum()) + len(sizes) - 1
    return n


@pytest.mark.parametrize("case", ["many2", "runs_of_100", "random_5000", "gappy_1800"])
def test_thousands_of_runs_stay_within_the_budget(case):
    rng = np.random.default_rng(7)
    if case == "many2":  # the audit's store: 1,500 one-chunk runs, 25 ms apart
        s = _summaries(rng, 1500, max_len=1, gap_p=0.0).sort_values("run_id")
        s = s.reset_index(drop=True)
        s["recorded_at"] = T0 + (np.arange(1500) * 25_000).astype("timedelta64[us]")
    elif case == "runs_of_100":  # 600 runs of 100 chunks: larger blocks, runs still apart
        s = _summaries(rng, 600, max_len=1, gap_p=0.0)
        s = s.loc[s.index.repeat(100)].reset_index(drop=True)
        s["recorded_at"] += (np.tile(np.arange(100), 600) * 10**6).astype("timedelta64[us]")
        s = s.sort_values("recorded_at", kind="stable").reset_index(drop=True)
    elif case == "random_5000":
        s = _summaries(rng, 5000, ("f", "nodet"), max_len=50, spread_s=86_400.0)
    else:  # one-chunk runs, 40 % of them an hour after the one before: many gap breaks
        s = _summaries(rng, 1800, max_len=1, gap_p=0.0, spread_s=0.0)
        step = np.where(rng.random(1800) < 0.4, 3600.0, 1.0)
        s["recorded_at"] = T0 + (np.cumsum(step) * 1e6).astype("timedelta64[us]")
    assert _old_rows_at_least(s, 2000) > 2000  # the per-run loop overshot
    p, feats = history_points(s, 2000)
    assert len(p) <= 2000 and sorted(feats) == sorted(s["feature"].unique())
    assert all(v <= 2000 // len(feats) for v in _rows_per_feature(p).values())
    _check_whole_runs(s, p)
    if case == "runs_of_100":  # 2 * 600 - 1 rows fit: runs kept apart, a null row between
        assert p["n_runs"].max() == 1 and p["n_chunks"].isna().sum() >= 599
    if case == "many2":  # one point per run, drawn as one line (no gap in 37.5 s)
        assert len(p) == 1500 and p["n_chunks"].notna().all() and p["n_runs"].max() == 1
        assert p["run_id"].tolist() == list(range(1, 1501))


def test_more_features_than_points_gives_one_point_each():
    s = _summaries(np.random.default_rng(3), 30, tuple("abcde"), max_len=10)
    p, feats = history_points(s, 3)
    assert len(feats) == 5 and _rows_per_feature(p) == dict.fromkeys(feats, 1)
    assert (p.groupby("feature")["n_chunks"].sum() == s.groupby("feature").size()).all()


def test_max_points_below_one_is_refused():
    with pytest.raises(ValueError, match="max_points=0 must be >= 1"):
        history_points(_summaries(np.random.default_rng(0), 1), 0)


@pytest.mark.parametrize("n_runs, joined, per_point", [(20, False, 1), (60, True, 2)])
def test_history_api_says_when_runs_are_joined(tmp_path, monkeypatch, n_runs, joined,
                                               per_point):
    """With fewer runs than the budget allows apart, the page gets the layout of before; with
    more, whole runs per point, and the payload (and the plot's title) says so."""
    monkeypatch.setattr(app, "HISTORY_POINTS", 50)
    st = EventStore(tmp_path / "e.db")
    t0 = datetime(2026, 11, 20, 8, tzinfo=timezone.utc)
    for r in range(n_runs):
        run = st.start_run("b", command="monitor", source=f"run{r}.csv", feature="f")
        st.add_chunks(run, [ChunkSummary(0.0, 100.0, 500, 0, float(r), 0.1, 0.9, 0.5, 1.0,
                                         1.0, False)],
                      recorded_at=[t0 + timedelta(seconds=0.025 * r)])
    c = Client(app.make_app(store=st))
    try:
        h = c.get("/api/history/b").json()
    finally:
        c.srv.stop()
        st.close()
    s = h["summaries"]
    n_null = sum(k is None for k in s["n_chunks"])
    assert len(s["n_chunks"]) <= 50 and sum(k or 0 for k in s["n_chunks"]) == n_runs
    assert (h["runs_joined"], h["runs_per_point"], h["n_runs"]) == (joined, per_point, n_runs)
    assert n_null == (0 if joined else n_runs - 1)
    if joined:  # runs 2r and 2r+1 in a point: values r merged, equal weights
        assert [v for v in s["value_mean"]] == [2 * r + 0.5 for r in range(30)]
