"""Sweep grid: hand-computed small cases, and the fast path equals the plain loop."""

import numpy as np
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.studies.grid import grid, grid_loop, parse_lag

ALT = [1.0, -1.0, 1.0, -1.0]  # Eq. 4.1, lag 1: num = -3, den = 4 -> -0.75
PAIRS = [1.0, 1.0, -1.0, -1.0]  # num = 1 - 1 + 1 = 1, den = 4 -> 0.25


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
    np.testing.assert_array_equal(fast.n_windows, slow.n_windows)
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
