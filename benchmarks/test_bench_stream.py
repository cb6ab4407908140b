"""Streaming goals of issue 7, measured by ``make bench``:

* throughput: at least 5 million samples per second per channel for chunks of 1,000 samples or
  more (autocorrelation, window 200, overlap 5 %, the thesis's VCA setting);
* latency: under 1 ms from a window's last sample to its value (monitor push of the chunk that
  completes the window, event included).

Each benchmark prints its figure and the goal; they do not fail on a slow or busy machine.
"""

import numpy as np
import pytest

from leakdiag.features.methods import MethodSpec
from leakdiag.features.windowing import n_windows
from leakdiag.stream import Monitor, StreamingFeature

THROUGHPUT_GOAL_SAMPLES_PER_S = 5e6
LATENCY_GOAL_S = 1e-3
TOTAL_SAMPLES = 2_000_000
SPECS = {
    "autocorrelation": MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5),
    "cross-correlation": MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=100,
                                    overlap=5),
    "metric-length": MethodSpec("metric-length", ("p1",), lag_ratio="83:3", window=500, overlap=5),
}


def _report(name, figure, goal, unit, better):
    ok = figure >= goal if better == "higher" else figure <= goal
    print(f"\n[stream bench] {name}: {figure:.4g} {unit} (goal {'>=' if better == 'higher' else '<='}"
          f" {goal:.4g} {unit}: {'met' if ok else 'NOT met'})")


@pytest.mark.parametrize("method", list(SPECS))
@pytest.mark.parametrize("chunk", [1_000, 10_000, 100_000])
def test_bench_throughput(benchmark, method, chunk):
    spec = SPECS[method]
    rng = np.random.default_rng(0)
    data = {c: rng.normal(size=TOTAL_SAMPLES) for c in spec.channels}
    chunks = [{c: v[i:i + chunk] for c, v in data.items()} for i in range(0, TOTAL_SAMPLES, chunk)]
    StreamingFeature(spec).push({c: v[:1000] for c, v in data.items()})  # compile / load cache

    def run():
        sf = StreamingFeature(spec, sample_rate=1000.0)
        for c in chunks:
            sf.push(c)
        return sf.n_windows

    n_win = benchmark.pedantic(run, rounds=5, iterations=1)
    assert n_win == n_windows(TOTAL_SAMPLES, spec.window, spec.overlap)
    rate = TOTAL_SAMPLES / benchmark.stats.stats.min
    benchmark.extra_info["samples_per_s_per_channel"] = rate
    _report(f"throughput {method} chunk={chunk}", rate, THROUGHPUT_GOAL_SAMPLES_PER_S,
            "samples/s/channel", "higher")


@pytest.mark.parametrize("chunk", [1, 1_000])
def test_bench_latency(benchmark, chunk):
    spec = SPECS["autocorrelation"]
    rng = np.random.default_rng(1)
    x = rng.normal(size=400)
    last = {"p1": x[200 - chunk:200]}  # this chunk's last sample completes window 0

    def setup():
        mon = Monitor(spec, sample_rate=1000.0)
        mon.push({"p1": x[:200 - chunk]})
        return (mon,), {}

    def push(mon):
        events = mon.push(last)
        assert len(events) == 1
        return events

    benchmark.pedantic(push, setup=setup, rounds=2000, iterations=1, warmup_rounds=10)
    worst_typical = benchmark.stats.stats.median
    benchmark.extra_info["median_latency_s"] = worst_typical
    _report(f"latency chunk={chunk} (median)", worst_typical * 1e3, LATENCY_GOAL_S * 1e3, "ms",
            "lower")
