"""Sweep grid: hand-computed small cases, and the fast path equals the plain loop."""

import numpy as np
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.studies.grid import grid, grid_loop, parse_lag

ALT = [1.0, -1.0, 1.0, -1.0]  # Eq. 4.1, lag 1: num = -3, den = 4 -> -0.75
PAIRS = [1.0, 1.0, -1.0, -1.0]  # num = 1 - 1 + 1 = 1, den = 4 -> 0.25
COUNT_COLUMNS = ["n_windows", "n_windows_dropped", "n_chunks_before", "n_chunks_after",
                 "n_chunks_straddling", "n_chunks_empty", "n_nan_windows", "chunk"]


def toy():
    x = np.array(ALT * 2 + PAIRS * 2)
    return Recording({"p1": x}, sample_rate=1.0, meta={"onset": 8.0})


def test_hand_computed_no_overlap():
    t = grid(toy(), "autocorrelation", "p1", [1], [4], [0], chunk=1)
    row = t.iloc[0]
    assert row.n_windows == 4 and row.n_chunks_before == 2 and row.n_chunks_after == 2
    assert row.mean_rms_before == pytest.approx(0.75)
    assert row.mean_rms_after == pytest.approx(0.25)
    assert row.pct_change_signed == pytest.approx((0.25 - 0.75) / 0.75 * 100)
    assert row["pct_change"] == pytest.approx(200 / 3)


def test_hand_computed_half_overlap_straddling_chunk_left_out():
    # step 2: starts 0..12; the window at 6 (samples 6-9) spans the onset at 8 s.
    t = grid(toy(), "autocorrelation", "p1", [1], [4], [50], chunk=1)
    row = t.iloc[0]
    assert (row.n_windows, row.n_chunks_before, row.n_chunks_straddling, row.n_chunks_after) == (
        7, 3, 1, 3)
    assert row.mean_rms_before == pytest.approx(0.75)
    assert row.mean_rms_after == pytest.approx(0.25)


def test_lag_not_below_window_is_skipped_and_order_is_lag_window_overlap():
    rec = toy()
    t = grid(rec, "autocorrelation", "p1", [1, 2, 4], [4, 8], [0, 50], chunk=1)
    got = list(zip(t.lag, t.window, t.overlap))
    want = [(1, 4, 0.0), (1, 4, 50.0), (1, 8, 0.0), (1, 8, 50.0), (2, 4, 0.0), (2, 4, 50.0),
            (2, 8, 0.0), (2, 8, 50.0), (4, 8, 0.0), (4, 8, 50.0)]
    assert got == want


def test_too_few_chunks_gives_nan_not_error():
    t = grid(toy(), "autocorrelation", "p1", [1], [4], [0], chunk=4)
    assert np.isnan(t["pct_change"].iloc[0]) and t.n_chunks_before.iloc[0] == 0


def ar_recording(n=6000, seed=0, rate=100.0):
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n, 2))
    x = np.zeros((n, 2))
    half = n // 2
    for i in range(1, n):
        a = 0.9 if i < half else 0.5
        x[i, 0] = a * x[i - 1, 0] + e[i, 0]
        x[i, 1] = 0.7 * x[i - 1, 1] + 0.5 * x[i - 1, 0] + e[i, 1]
    return Recording({"p1": x[:, 0], "p2": x[:, 1]}, sample_rate=rate,
                     meta={"onset": half / rate})


@pytest.mark.parametrize("method, channels, lags", [
    ("autocorrelation", "p1", [1, 3, 10]),
    ("cross_correlation", "p1,p2", [1, 4]),
    ("ratio_of_metric_lengths", "p1", ["16:3", "43:3"]),
])
def test_fast_grid_equals_plain_loop(method, channels, lags):
    rec = ar_recording()
    kw = dict(lags=lags, windows=[60, 100, 250], overlaps=[0, 5, 25, 50, 90], chunk=5)
    fast = grid(rec, method, channels, **kw)
    slow = grid_loop(rec, method, channels, **kw)
    assert len(fast) == len(slow) == len(lags) * 15
    for col in COUNT_COLUMNS:  # every count, as rms_change (the plain loop) gives it
        np.testing.assert_array_equal(fast[col], slow[col], err_msg=col)
    for col in ("mean_rms_before", "mean_rms_after", "pct_change_signed"):
        np.testing.assert_allclose(fast[col], slow[col], rtol=1e-9, atol=1e-12)


def test_autocorrelation_falls_when_process_whitens():
    t = grid(ar_recording(), "autocorrelation", "p1", [1], [100], [5], chunk=5)
    # AR(1) lag-1 autocorrelation 0.9 -> 0.5 (minus small-window bias): a fall of about 40 %.
    assert -55 < t.pct_change_signed.iloc[0] < -30


def test_errors():
    with pytest.raises(ValueError, match="no leak onset"):
        grid(Recording({"p1": np.ones(10)}, 1.0), "autocorrelation", "p1", [1], [4], [0])
    with pytest.raises(ValueError, match="lag ratio"):
        parse_lag("autocorrelation", "83:3")
    with pytest.raises(RecordingError, match=r"missing channel\(s\) \['u'\]"):
        grid(toy(), "autocorrelation", "u", [1], [4], [0])


def test_bad_chunk_is_an_error_not_a_nan_row():
    """chunk=0 used to divide by zero in grid and give silent NaN rows in measure_row."""
    from leakdiag.features.series import FeatureSeries
    from leakdiag.studies.grid import grid, measure_row

    rng = np.random.default_rng(0)
    rec = Recording({"p1": rng.normal(size=2000)}, 100.0, meta={"onset": 10.0})
    with pytest.raises(ValueError, match="chunk=0 must be >= 1"):
        grid(rec, "autocorrelation", "p1", [1], [100], [0], chunk=0)
    fs = FeatureSeries(np.arange(20.0), np.ones(20), "ac", {})
    with pytest.raises(ValueError, match="chunk=0 must be >= 1"):
        measure_row(fs, 10.0, 0, "autocorrelation", ("p1",), 1, 100, 0.0)


# ------------------------------------------------- the fast path's counts equal rms_change's
# Found by an audit (2026-11-27): the fast path filed all-NaN chunks as straddling, so sweep.csv
# said n_chunks_straddling=6 where rms_change says 0 straddling and 6 empty.
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from leakdiag.detect.measure import TooFewChunksError, rms_change  # noqa: E402
from leakdiag.features.series import FeatureSeries  # noqa: E402
from leakdiag.studies.grid import MEASURE_COLUMNS, _chunk_sides, _fast_measure  # noqa: E402

COUNTS = ["n_windows", "n_windows_dropped", "n_chunks_before", "n_chunks_after",
          "n_chunks_straddling", "n_chunks_empty", "n_nan_windows", "chunk"]


def reference(fs, onset, chunk) -> dict:
    """rms_change's row: its measure, or (no whole chunk on a side) the counts it found."""
    try:
        return rms_change(fs, onset, chunk=chunk).as_dict()
    except TooFewChunksError as exc:
        return exc.partial.as_dict()


def fast(fs, onset, chunk) -> dict:
    sides = _chunk_sides(np.asarray(fs.time), fs.window_start, onset, chunk)
    return _fast_measure(np.asarray(fs.values), sides, chunk)


def assert_same(got, want):
    assert set(MEASURE_COLUMNS) <= set(got)
    for c in MEASURE_COLUMNS:  # exact: the same arithmetic on the same values
        g, w = got[c], want[c]
        assert (np.isnan(g) and np.isnan(w)) if isinstance(w, float) and np.isnan(w) else g == w, \
            (c, g, w)


def series(values, window=4, step=2, rate=1.0):
    v = np.asarray(values, dtype=float)
    t = (np.arange(len(v)) * step + window - 1) / rate  # each window's last sample
    return FeatureSeries(t, v, "f", window=window, sample_rate=rate)


@pytest.mark.parametrize("values, window, onset, chunk, counts", [
    # Window i (step 2, rate 1 Hz) spans samples 2i .. 2i + window - 1; it is before the onset
    # if its last sample is earlier, after it if its first sample is not earlier.
    # counts: (before, after, straddling, empty, NaN in whole chunks, dropped)
    # an all-NaN chunk astride the onset is empty, not straddling (the audit's case)
    ([1, 1, np.nan, np.nan, 2, 2], 4, 6.0, 2, (1, 1, 0, 1, 2, 0)),
    # chunk (w2, w3): last samples 7, 9 and first 4, 6 straddle 7; NaN in a used chunk skipped
    ([1, np.nan, 1, 1, 2, 2, 2, 2], 4, 7.0, 2, (1, 2, 1, 0, 1, 0)),
    # empty chunks on both sides, one straddling (first samples 8, 10 vs onset 10), and a
    # trailing NaN window that fills no chunk (dropped, not counted as NaN)
    ([np.nan, np.nan, 1, 1, 5, 5, np.nan, np.nan, 2, np.nan, np.nan], 4, 10.0, 2,
     (1, 1, 1, 2, 5, 1)),
    # windows of two samples: (0, 1), (2, 3), (4, 5) before 6, (6, 7) ... after
    ([1, 1, 1, 2, 2, 2, np.nan], 2, 6.0, 3, (1, 1, 0, 0, 0, 1)),
    # no measure: onset after the end, only straddling, fewer windows than a chunk
    ([1, 1, np.nan, np.nan], 4, 100.0, 2, (1, 0, 0, 1, 2, 0)),
    ([1, 2, 3, 4], 4, 4.0, 4, (0, 0, 1, 0, 0, 0)),
    ([1, np.nan, 3], 4, 4.0, 5, (0, 0, 0, 0, 0, 3)),
])
def test_fast_measure_equals_rms_change_by_hand(values, window, onset, chunk, counts):
    fs = series(values, window=window)
    got, want = fast(fs, onset, chunk), reference(fs, onset, chunk)
    assert_same(got, want)
    assert (got["n_chunks_before"], got["n_chunks_after"], got["n_chunks_straddling"],
            got["n_chunks_empty"], got["n_nan_windows"], got["n_windows_dropped"]) == counts


@st.composite
def feature_series(draw):
    m = draw(st.integers(0, 40))
    chunk = draw(st.integers(1, 6))
    window = draw(st.integers(2, 6))
    step = draw(st.integers(1, 6))
    rate = draw(st.sampled_from([1.0, 1000.0]))
    finite = st.floats(-1e3, 1e3, allow_nan=False)
    vals = np.array(draw(st.lists(finite, min_size=m, max_size=m)), dtype=float)
    nan = np.array(draw(st.lists(st.booleans(), min_size=m, max_size=m)), dtype=bool)
    vals[nan] = np.nan
    k = m // chunk  # whole chunks of NaN values only, so that empty chunks are common
    for c in draw(st.lists(st.integers(0, max(k - 1, 0)), max_size=3)) if k else []:
        vals[c * chunk:(c + 1) * chunk] = np.nan
    fs = series(vals, window, step, rate)
    t = np.asarray(fs.time)
    lo, hi = (float(t[0]) - 2.0 / rate, float(t[-1]) + 2.0 / rate) if m else (0.0, 1.0)
    onset = draw(st.one_of(st.floats(lo, hi), st.sampled_from(list(t) or [0.0]),
                           st.sampled_from(list(fs.window_start) or [0.0])))
    return fs, float(onset), chunk


@settings(max_examples=300, deadline=None)
@given(feature_series())
def test_fast_measure_equals_rms_change_property(case):
    """Any values (NaN windows, empty chunks, chunks astride the onset), onset and chunk."""
    fs, onset, chunk = case
    assert_same(fast(fs, onset, chunk), reference(fs, onset, chunk))


def degenerate_recording():
    """AR noise with exactly constant stretches: zero-variance windows, some astride the onset."""
    rng = np.random.default_rng(7)
    x = rng.normal(size=3000)
    for a, b in ((300, 700), (1380, 1700), (2500, 2800)):
        x[a:b] = 2.5
    return Recording({"p1": x}, sample_rate=1000.0, meta={"onset": 1.5})


@pytest.mark.parametrize("chunk", [1, 2, 3, 10])
def test_grid_counts_equal_rms_change_on_nan_windows(chunk):
    from leakdiag.features.spec import MethodSpec, compute_feature
    from leakdiag.studies.grid import quiet_degenerate

    rec = degenerate_recording()
    t = grid(rec, "autocorrelation", "p1", [1, 5], [50, 100, 300], [0, 5, 50], chunk=chunk)
    assert len(t) == 18 and (t.n_nan_windows > 0).any() and (t.n_chunks_empty > 0).any() \
        and (t.n_chunks_straddling > 0).any()
    for r in t.itertuples(index=False):
        with quiet_degenerate():
            fs = compute_feature(rec, MethodSpec("autocorrelation", ("p1",), lag=r.lag,
                                                 window=r.window, overlap=r.overlap))
        want = reference(fs, 1.5, chunk)
        got = r._asdict()
        assert [got[c] for c in COUNTS] == [want[c] for c in COUNTS], (r, want)
        for c in ("mean_rms_before", "mean_rms_after", "pct_change_signed"):
            np.testing.assert_allclose(got[c], want[c], rtol=1e-9, atol=1e-12)
