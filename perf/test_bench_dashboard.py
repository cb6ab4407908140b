"""Dashboard goals of issue 17, measured by ``make bench`` (printed, never asserted):

* latency from a sample to the page: the wall time from a chunk's hand-off by the monitor (its
  arrival plus the detector's work on it, microseconds; before 36e6f3d its arrival) to the end
  of the page's render of the snapshot that contains it, measured in the page (``Date.now()``
  against the chunk's ``received_wall``); goal <= 1 s. Real-time replay at
  1 kHz in 50-sample chunks, a headless Chromium on the live page.
* the monitor's throughput (replay as fast as possible, 3.6 M samples replayed ``LOOPS`` = 8
  times in 1,000- and 65,536-sample chunks, with a fixed-threshold scorer and with a fitted
  detector's CUSUM, whose frames carry S+/S- too: ``SCORERS``): the monitor alone against ``--dashboard`` with
  a client process reading the event stream, ``--store`` (SQLite), both, and ``--dashboard``
  with the page open in Chromium. The cases run interleaved in one process (ABBA order),
  ``REPEATS`` times each, and their medians are compared: the loop's wall time (the monitor's
  throughput), the CPU time of the monitor's thread, and the wall time until the hooks have
  written everything (flush). The CPU time outside the monitor's thread (its other threads and
  the sidecar process) is printed beside.

The latency and page-open cases are skipped when Debian's chromium/chromedriver are missing.

``LEAKDIAG_BENCH_BEFORE_SRC=DIR`` (the ``src`` folder of an earlier commit, e.g. from ``git
archive REV src | tar -x -C /tmp/before``, then ``DIR=/tmp/before/src``) adds a "before" run of
every case with hooks to the same interleaved run: that tree's hooks, sidecar and recorder
(its sidecar process runs that tree), with the current monitor, so that a change of the hooks
is measured against its predecessor under the same load.

The results, with the load they were measured at, are in docs/operations.md ("Tests and
measurements").
"""

import gc
import importlib.util
import itertools
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

from leakdiag.dashboard.hooks import MonitorHooks
from leakdiag.dashboard.server import Bind
from leakdiag.features.spec import MethodSpec
from leakdiag.io.recording import Recording
from leakdiag.stream import Monitor, paced, recording_chunks

LATENCY_GOAL_S = 1.0
SPEC = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
#: Repeats of each throughput case (interleaved; the medians are compared).
REPEATS = int(os.environ.get("LEAKDIAG_BENCH_REPEATS", "6"))
#: Passes over the one-hour recording per throughput run: the monitor alone replays one hour
#: in about 0.07 s (1,000-sample chunks), too short a run to measure the hooks against.
LOOPS = 8
#: The ``src`` folder of an earlier commit to measure against in the same run (module docstring).
BEFORE_SRC = os.environ.get("LEAKDIAG_BENCH_BEFORE_SRC")


def _before_hooks():
    """MonitorHooks of the ``src`` tree at BEFORE_SRC, with that tree's ring, sidecar and
    recorder (loaded under the current modules' names while its hooks are imported, so that
    its monitor side writes the ring layout that its sidecar process reads: that process runs
    with that tree first on its path). A tree without ``dashboard/ring.py`` (before 25b6c62)
    is loaded without it."""
    names = ("ring", "recorder", "sidecar", "hooks")
    saved = {n: sys.modules.get(f"leakdiag.dashboard.{n}") for n in names}
    mods = {}
    try:
        for n in names:
            path = os.path.join(BEFORE_SRC, "leakdiag", "dashboard", f"{n}.py")
            if not os.path.exists(path):
                continue
            spec = importlib.util.spec_from_file_location(f"leakdiag.dashboard.{n}", path)
            mods[n] = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = mods[n]
            spec.loader.exec_module(mods[n])
    finally:
        for n, cur in saved.items():
            if cur is None:
                sys.modules.pop(f"leakdiag.dashboard.{n}", None)
            else:
                sys.modules[f"leakdiag.dashboard.{n}"] = cur
    # the scorer's facts are pickled by class name for that tree's sidecar process: send the
    # current class (both trees' ScorerFacts have the same attributes)
    mods["sidecar"].ScorerFacts = saved["recorder"].ScorerFacts
    return mods["hooks"].MonitorHooks


def _page_url(hooks, path: str) -> str:
    """A page's address from the hooks (``server.page_url`` in the hooks before the sidecar)."""
    page_url = getattr(hooks, "page_url", None)
    return page_url(path) if page_url else hooks.server.page_url(path)


def _child_cpu(hooks) -> float:
    """CPU seconds of the hooks' sidecar (or store writer) process so far (0 without one)."""
    proc = getattr(getattr(hooks, "sidecar", None) or getattr(hooks, "writer", None), "proc",
                   None)
    if proc is None:
        return 0.0
    with open(f"/proc/{proc.pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class _Scorer:
    """A fixed-threshold scorer (the score is the feature), enough to exercise the page."""

    threshold_ = 0.95

    def score_windows(self, values, time):
        return np.abs(values)


def _cusum_scorer(rate: float):
    """What a detector file from ``leakdiag fit`` runs in the monitor: a DetectorScorer (Page's
    CUSUM on the standardised feature, with its S+/S- branches handed to the page), here with
    a threshold that the synthetic recording never reaches."""
    from types import SimpleNamespace

    from leakdiag.stream.detector import DetectorScorer

    det = SimpleNamespace(mean_=0.9, std_=0.05, threshold_=1e12,
                          alarm=SimpleNamespace(drift=0.5, direction="both", burn_in_s=0.0))
    return DetectorScorer(det, SPEC.window, rate)


#: The scorers of the throughput runs: the fixed threshold (the cheapest detector work, where
#: the hand-off weighs most) and a fitted detector's CUSUM (frames with S+/S-, as `leakdiag
#: monitor --detector FILE` hands them over).
SCORERS = {"fixed threshold": lambda rate: _Scorer(), "CUSUM detector": _cusum_scorer}


def _recording(seconds: float, seed: int = 0) -> Recording:
    rng = np.random.default_rng(seed)
    n = int(seconds * 1000)
    p1 = np.cumsum(rng.normal(size=n)) * 0.01 + rng.normal(size=n)
    return Recording({"p1": p1}, 1000.0)


def _browser():
    if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        pytest.skip("no chromium/chromedriver (apt-get install chromium chromium-driver)")
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    os.environ.setdefault("SE_OFFLINE", "true")
    prof = tempfile.mkdtemp(prefix="leakdiag-bench-")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
              "--disable-background-networking", "--disable-component-update", "--disable-sync",
              f"--user-data-dir={prof}", "--window-size=1200,1000"]:
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts), prof


def _say(capsys, msg):
    with capsys.disabled():
        print(f"\n[dashboard bench] {msg}")


def _sse_client(url):
    """A page stand-in in another process: reads the server-sent events and drops them."""
    code = ("import sys, urllib.request\n"
            "r = urllib.request.urlopen(sys.argv[1])\n"
            "while r.read(65536):\n    pass\n")
    return subprocess.Popen([sys.executable, "-c", code, url], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def _run(rec, hooks_kw=None, page=None, chunk=1000, speed=None, loops=1, hooks_cls=None,
         scorer="fixed threshold"):
    """Replay ``rec`` (``loops`` times, back to back, when ``speed`` is None); ``page``: None,
    "sse" (a client process) or "chromium" (the live page); ``hooks_cls``: default
    :class:`MonitorHooks`.

    Returns (loop wall s, monitor-thread CPU s, wall s including the hooks' flush, latencies,
    CPU s outside the monitor's thread: other threads and the store writer's process).
    """
    src = recording_chunks(rec, chunk, ["p1"])
    if loops > 1 and speed is None:
        src = itertools.chain.from_iterable(recording_chunks(rec, chunk, ["p1"])
                                            for _ in range(loops))
    mon = Monitor(SPEC, rec.sample_rate, 0.0, scorers=SCORERS[scorer](rec.sample_rate))
    hooks = None if hooks_kw is None else (hooks_cls or MonitorHooks)(
        "bench", SPEC, mon, "synthetic", rec.sample_rate, say=lambda m: None, **hooks_kw)
    drv = prof = client = None
    if page == "chromium":
        drv, prof = _browser()
        drv.get(_page_url(hooks, "live/bench"))
        time.sleep(1.0)  # page loaded and streaming
    elif page == "sse":
        client = _sse_client(_page_url(hooks, "stream/bench"))
        time.sleep(1.0)
    it = src if speed is None else paced(src, speed)
    t0, c0, p0 = time.perf_counter(), time.thread_time(), time.process_time()
    k0 = _child_cpu(hooks)
    # hooks before c7f219d noted each chunk's arrival in a wrap() generator
    for c in (hooks.wrap(it) if hasattr(hooks, "wrap") else it):
        evs = mon.push(c)
        if hooks:
            hooks.push(evs)
    dt, cpu = time.perf_counter() - t0, time.thread_time() - c0
    lat = None
    if hooks and hasattr(hooks, "flush"):  # (the hooks before 49d6169 wrote in push)
        hooks.flush()
    dt_all = time.perf_counter() - t0
    other = time.process_time() - p0 - cpu + _child_cpu(hooks) - k0
    if drv is not None:
        time.sleep(1.0)
        lat = drv.execute_script("return window.leakdiagLatencies")
        drv.quit()
        shutil.rmtree(prof, ignore_errors=True)
    if client is not None:
        client.kill()
        client.wait()
    if hooks:
        hooks.close(True)
    return dt, cpu, dt_all, lat, other


@pytest.mark.parametrize("store", [False, True], ids=["page", "page+store"])
def test_bench_latency_sample_to_page(capsys, tmp_path, store):
    rec = _recording(30.0)
    kw = {"bind": Bind("127.0.0.1", 0)}
    if store:
        kw["store"] = str(tmp_path / "lat.db")
    load0 = os.getloadavg()[0]
    _, _, _, lat, _ = _run(rec, kw, page="chromium", chunk=50, speed=1.0)
    load1 = os.getloadavg()[0]
    lat = np.array(lat[3:])  # the first renders include the page's start-up
    _say(capsys, f"latency sample -> page render, real-time replay 1 kHz, 50-sample chunks, "
         f"{'--dashboard and --store' if store else '--dashboard'}, {len(lat)} renders, load "
         f"{load0:.1f} -> {load1:.1f}: median {np.median(lat) * 1e3:.0f} ms, 95th percentile "
         f"{np.percentile(lat, 95) * 1e3:.0f} ms, 99th percentile "
         f"{np.percentile(lat, 99) * 1e3:.0f} ms, max {lat.max() * 1e3:.0f} ms "
         f"(goal <= {LATENCY_GOAL_S * 1e3:.0f} ms: "
         f"{'met' if lat.max() <= LATENCY_GOAL_S else 'NOT met'} at the max)")


@pytest.mark.parametrize("scorer", list(SCORERS))
@pytest.mark.parametrize("chunk", [1000, 65536])
def test_bench_throughput_with_and_without_page(capsys, tmp_path, chunk, scorer):
    """Each case against the monitor alone, in the same process, interleaved (ABBA order)."""
    rec = _recording(3600.0, seed=1)  # 3.6 M samples: one hour at 1 kHz, replayed LOOPS times
    n = len(rec["p1"]) * LOOPS
    _run(_recording(5.0), scorer=scorer)  # compile / warm caches
    gc.collect()
    gc.freeze()  # as `leakdiag monitor` does before its loop (runtime.collector)
    have_browser = os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)
    srv = {"bind": Bind("127.0.0.1", 0)}
    cases = [("monitor alone", None, None),
             ("--dashboard, a client reading the event stream", srv, "sse"),
             ("--store (SQLite)", "store", None),
             ("--store and --dashboard with a client", "both", "sse")]
    if have_browser:
        cases.append(("--dashboard, the page open in Chromium", srv, "chromium"))
    before = _before_hooks() if BEFORE_SRC else None
    if before is not None:
        cases += [(name + ", before", kw, page) for name, kw, page in cases[1:]]
    reps = REPEATS
    res: dict = {name: [] for name, _, _ in cases}
    load0 = os.getloadavg()[0]
    for r in range(reps):
        for k, (name, kw, page) in enumerate(cases if r % 2 == 0 else cases[::-1]):
            if kw == "store":
                kw = {"store": str(tmp_path / f"s{r}-{k}.db")}
            elif kw == "both":
                kw = {"store": str(tmp_path / f"b{r}-{k}.db"), **srv}
            cls = before if name.endswith(", before") else None
            out = _run(rec, kw, page, chunk=chunk, loops=LOOPS, hooks_cls=cls, scorer=scorer)
            res[name].append(out[:3] + out[4:])
    base = np.median(np.array(res["monitor alone"]), axis=0)
    _say(capsys, f"throughput, {chunk}-sample chunks, {scorer}: load {load0:.1f} -> "
         f"{os.getloadavg()[0]:.1f} (1-min average)")
    for name, _, _ in cases:
        m = np.median(np.array(res[name]), axis=0)
        _say(capsys, f"throughput, {chunk}-sample chunks, {scorer}, {name}: {n / m[0]:.3g} "
             f"samples/s "
             f"(median of {reps}: loop {m[0]:.3f} s, {base[0] / m[0]:.0%} of the monitor alone; "
             f"monitor-thread CPU {m[1]:.3f} s, {base[1] / m[1]:.0%}; with the hooks' final "
             f"flush {m[2]:.3f} s, {base[2] / m[2]:.0%}; CPU outside the monitor's thread "
             f"{m[3]:.3f} s)")
    gc.unfreeze()
    if not have_browser:
        _say(capsys, "page-open case skipped: no chromium")
