"""Explicit resampling: linear interpolation onto a uniform grid, recorded in meta."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.io import RecordingError, read_recording, resample_linear
from leakdiag.io.resample import uniform_grid


def _plain_interp(t, y, tq):
    """Reference: straight-line interpolation by searching the bracketing pair."""
    out = []
    for q in tq:
        j = max(i for i in range(len(t)) if t[i] <= q)
        if j == len(t) - 1:
            out.append(y[-1])
        else:
            w = (q - t[j]) / (t[j + 1] - t[j])
            out.append(y[j] + w * (y[j + 1] - y[j]))
    return np.array(out)


def test_ramp_is_reproduced_exactly():
    # a linear signal is unchanged by linear interpolation, whatever the jitter
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 400))
    start, out = resample_linear(t, {"x": 3.0 * t - 1.0}, 1000.0)
    grid = start + np.arange(len(out["x"])) / 1000.0
    np.testing.assert_allclose(out["x"], 3.0 * grid - 1.0, rtol=0, atol=1e-12)
    assert start == t[0]
    assert grid[-1] <= t[-1] + 1e-12 and grid[-1] + 1e-3 > t[-1]


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(0.01, 1.0), min_size=2, max_size=20),
       st.floats(1.0, 50.0))
def test_matches_plain_reference(dts, rate):
    t = np.concatenate([[0.0], np.cumsum(dts)])
    y = np.sin(3 * t) + t**2
    start, out = resample_linear(t, {"y": y}, rate, max_gap_intervals=None)  # any intervals
    grid = uniform_grid(start, t[-1], rate)
    np.testing.assert_allclose(out["y"], _plain_interp(t, y, grid), rtol=1e-12, atol=1e-12)


def test_grid_length():
    assert len(uniform_grid(0.0, 0.999, 1000.0)) == 1000
    assert len(uniform_grid(0.0, 1.0, 1000.0)) == 1001
    assert len(uniform_grid(1.0, 1.0 + 0.3, 10.0)) == 4  # 1.3 - 1.0 is 0.30000000000000004


def test_read_with_resample_records_meta(tmp_path):
    path = tmp_path / "jitter.csv"
    path.write_text("time,p1\n0,0\n0.9,9\n2.2,22\n3.0,30\n")
    with pytest.raises(RecordingError, match="--resample"):
        read_recording(path)
    rec = read_recording(path, resample=2.0)
    assert rec.sample_rate == 2.0
    np.testing.assert_allclose(rec["p1"], [0, 5, 10, 15, 20, 25, 30], atol=1e-12)
    assert rec.meta["resampled"] == {"sample_rate_hz": 2.0, "method": "linear",
                                     "source_samples": 4, "time_column": "time"}


def test_resample_without_time_column_changes_rate(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("p1\n0\n10\n20\n")
    rec = read_recording(path, sample_rate=1.0, resample=2.0)
    assert rec["p1"].tolist() == [0.0, 5.0, 10.0, 15.0, 20.0]
    assert rec.meta["resampled"]["time_column"] is None


def test_resample_errors():
    with pytest.raises(RecordingError, match=r"resample=0 must be a finite number > 0"):
        resample_linear(np.arange(3.0), {}, 0)
    with pytest.raises(RecordingError, match=r"cannot resample 1 sample\(s\)"):
        resample_linear(np.zeros(1), {}, 1.0)


def test_resample_fills_dropped_counter_samples(tmp_path):
    path = tmp_path / "gaps.txt"
    path.write_text("n\tP\n1\t10\n2\t20\n4\t40\n5\t50\n")
    cmap = {"file": {"time_column": "n", "time_unit": "samples", "sample_rate_hz": 1000},
            "channels": {"p1": "P:counts"}}
    with pytest.raises(RecordingError, match="not uniformly sampled"):
        read_recording(path, cmap)
    rec = read_recording(path, cmap, resample=1000)
    np.testing.assert_allclose(rec["p1"], [10, 20, 30, 40, 50], atol=1e-9)
    assert rec.start_time == pytest.approx(0.001)
    assert rec.units == {"p1": "counts"}


def test_a_gap_is_refused_not_filled(tmp_path, run_cli):
    """A flow-balance audit (2026-11-28) resampled healthy runs across a 0.2-s gap, as the
    non-uniform message advised, and read LEAK in 5 of 6 (the interpolated piston motion and
    pressures are no measurement). Up to 3 median intervals (two missing samples) is filled."""
    t = np.arange(2000) / 1000.0
    t[1000:] += 0.2  # 200 samples missing before row 1000
    with pytest.raises(RecordingError, match=r"^<input>: cannot resample across a gap of 0.201 "
                                             r"s before row 1000 \(about 200 missing samples at "
                                             r"the median interval 0.001 s\) \(more than 3 "
                                             r"median intervals\): resampling would invent the "
                                             r"missing samples, which a detector reads as "
                                             r"measured: cut the recording at the gap"):
        resample_linear(t, {"x": t}, 1000.0)
    two = np.delete(np.arange(20) / 1000.0, [5, 6])  # two missing samples: filled
    start, out = resample_linear(two, {"x": two}, 1000.0)
    np.testing.assert_allclose(out["x"], np.arange(20) / 1000.0, atol=1e-15)
    # the reader's message advises cutting, not resampling, and the CLI refuses --resample
    path = tmp_path / "gap.csv"
    path.write_text("time,p1\n" + "".join(f"{float(a)!r},{np.sin(k)}\n"
                                           for k, a in enumerate(t)))
    with pytest.raises(RecordingError) as err:
        read_recording(path)
    assert "it has a gap of 0.201 s before row 1000" in str(err.value)
    assert "cut the recording at the gap" in str(err.value) and "--resample" not in str(err.value)
    code, _, stderr = run_cli(["analyze", str(path), "--channels", "p1", "--resample", "1000"])
    assert code == 2 and "cannot resample across a gap of 0.201 s before row 1000" in stderr
