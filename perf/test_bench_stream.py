"""Streaming goals of issue 7, measured by ``make bench``:

* throughput: at least 5 million samples per second per channel for chunks of 1,000 samples or
  more (autocorrelation, window 200, overlap 5 %, the thesis's VCA setting);
* latency: under 1 ms from a window's last sample to its value (monitor push of the chunk that
  completes the window, event included).

Each benchmark prints its figure and the goal; they do not fail on a slow or busy machine.
"""

import numpy as np
import pytest

from leakdiag.features.spec import MethodSpec
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


def _report(capsys, name, figure, goal, unit, better):
    """Print a figure next to its goal, through pytest's output capture (shown by make bench)."""
    ok = figure >= goal if better == "higher" else figure <= goal
    with capsys.disabled():
        sign = ">=" if better == "higher" else "<="
        print(f"\n[stream bench] {name}: {figure:.4g} {unit} (goal {sign} {goal:.4g} {unit}: "
              f"{'met' if ok else 'NOT met'})")


@pytest.mark.parametrize("method", list(SPECS))
@pytest.mark.parametrize("chunk", [1_000, 10_000, 100_000])
def test_bench_throughput(benchmark, capsys, method, chunk):
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
    _report(capsys, f"throughput {method} chunk={chunk}", rate, THROUGHPUT_GOAL_SAMPLES_PER_S,
            "samples/s/channel", "higher")


@pytest.mark.parametrize("chunk", [1, 1_000])
def test_bench_latency(benchmark, capsys, chunk):
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
    _report(capsys, f"latency chunk={chunk} (median)", worst_typical * 1e3,
            LATENCY_GOAL_S * 1e3, "ms", "lower")


FILE_ROWS = 1 << 25  # 32 Mi samples x 2 channels: a 0.5 GB Parquet file
CHILD = r"""
import json, resource, sys

def peak_rss_bytes():
    # VmHWM is the peak RSS of this process's own address space. ru_maxrss is not usable here:
    # Linux carries the parent's RSS high-water mark over fork + exec into the child's ru_maxrss.
    try:
        with open("/proc/self/status") as f:
            return next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmHWM"))
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

import time
from leakdiag.features.spec import MethodSpec
from leakdiag.stream import open_chunks, stream_feature
spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
t0 = time.perf_counter()
fs = stream_feature(open_chunks(sys.argv[1], ["p1"]), spec)
print(json.dumps({"s": time.perf_counter() - t0, "n": fs.params["n_samples"],
                  "rss": peak_rss_bytes()}))
"""


@pytest.mark.parametrize("fmt", ["parquet", "hdf5"])
def test_bench_file_streaming(benchmark, capsys, tmp_path, fmt):
    """Larger than memory: read a file in chunks and stream it; figure = samples/s and peak RSS."""
    import json
    import subprocess
    import sys

    from leakdiag.io.recording import Recording

    x = np.random.default_rng(2).normal(size=FILE_ROWS)
    rec = Recording({"p1": x, "p2": x[::-1].copy()}, sample_rate=10_000.0)
    path = tmp_path / f"big.{'parquet' if fmt == 'parquet' else 'h5'}"
    if fmt == "parquet":
        from leakdiag.io.parquet import write_parquet

        write_parquet(rec, path)
    else:
        from leakdiag.io.hdf5 import write_hdf5

        write_hdf5(rec, path)
    del rec, x
    size = path.stat().st_size

    def run():
        out = subprocess.run([sys.executable, "-c", CHILD, str(path)], capture_output=True,
                             text=True, check=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    info = benchmark.pedantic(run, rounds=1, iterations=1)
    path.unlink()
    assert info["n"] == FILE_ROWS
    benchmark.extra_info.update(samples_per_s=info["n"] / info["s"], peak_rss_bytes=info["rss"])
    _report(capsys, f"{fmt} file {size / 1e9:.2f} GB streamed (read + autocorrelation)",
            info["n"] / info["s"], THROUGHPUT_GOAL_SAMPLES_PER_S, "samples/s", "higher")
    _report(capsys, f"{fmt} file {size / 1e9:.2f} GB peak RSS", info["rss"] / 2**20, 1024, "MiB",
            "lower")
