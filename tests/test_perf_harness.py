"""The speed-benchmark harness (``perf/harness.py``): timing with a fake clock, table verdicts."""

import itertools

import pytest

from perf import harness
from perf.harness import RatioRecord, best_time, format_table, time_calls


def fake_clock(durations):
    """A timer whose consecutive (start, stop) readings differ by the given durations."""
    ticks = itertools.accumulate(d for pair in ((0.0, dur) for dur in durations) for d in pair)
    return lambda: next(ticks)


def test_time_calls_counts_warmup_and_returns_each_repeat():
    calls = []
    times = time_calls(lambda: calls.append(1), repeats=3, warmup=2,
                       timer=fake_clock([0.5, 0.25, 0.75]))
    assert len(calls) == 5
    assert times == [0.5, 0.25, 0.75]
    assert best_time(lambda: None, repeats=3, warmup=0, timer=fake_clock([0.5, 0.25, 0.75])) == 0.25


def test_time_calls_spreads_repeats_with_sleeps(monkeypatch):
    slept = []
    monkeypatch.setattr(harness.time, "sleep", slept.append)
    time_calls(lambda: None, repeats=4, warmup=0, timer=fake_clock([1.0] * 4), spread_s=2.0)
    assert slept == [0.5] * 4
    slept.clear()
    time_calls(lambda: None, repeats=4, warmup=0, timer=fake_clock([1.0] * 4))
    assert slept == []


@pytest.mark.parametrize("kw, match", [(dict(repeats=0), "repeats"),
                                       (dict(spread_s=-1.0), "spread_s")])
def test_time_calls_rejects_bad_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        time_calls(lambda: None, **kw)


def test_verdicts_report_best_and_median_against_the_rate_goal():
    # 400,000 samples: 2 ms -> 200 Ms/s (best), 5 ms -> 80 Ms/s (median)
    rec = RatioRecord("case", 0.002, 2.0, n_samples=400_000, goal_ratio=50.0,
                      goal_samples_per_s=100e6, fast_median_seconds=0.005)
    assert rec.ratio == pytest.approx(1000.0)
    assert rec.samples_per_s == pytest.approx(2e8)
    assert rec.median_samples_per_s == pytest.approx(8e7)
    assert rec.verdicts() == ">=50x met; >=100 Ms/s met (best), NOT met (median)"
    plain = RatioRecord("case", 0.005, 0.1, n_samples=400_000, goal_samples_per_s=100e6)
    assert plain.median_samples_per_s is None
    assert plain.verdicts() == ">=100 Ms/s NOT met"
    fields = format_table([rec])[-1].split()
    assert fields[0] == "case" and fields[1:6] == ["2.000", "2000.0", "1000.0", "200.0", "80.0"]
