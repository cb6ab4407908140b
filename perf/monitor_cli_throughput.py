"""The `leakdiag monitor` command's throughput with and without its hooks (issue 17).

``perf/test_bench_dashboard.py`` measures the monitor's inner loop (``Monitor.push`` and the
hand-off, nothing else); this script measures the command a user runs, end to end inside its
loop: ``leakdiag monitor FILE --detector DET`` over a four-hour VCA recording (one simulated
healthy hour of the nominal unit four times, 14.4 M samples at 1 kHz), replayed as fast as it goes, alone and with ``--dashboard``
(no page open), ``--store`` (SQLite) and both, at the command's default ``--chunk`` (65,536
samples) and at ``--chunk 1000``. The throughput is the command's own: samples over the loop's
time that the summary line prints ("... in X s"; reading the file's chunks, the feature, the
detector's CUSUM, the events' alarm / blind bookkeeping and the hooks' hand-off; not Python's
start-up, the file's opening or the sidecar's start and stop).

The cases run interleaved (ABBA order), ``--repeats`` times each (default 6), as separate
processes under the same load; the medians are compared with the command alone, and the
spread (smallest and largest ratio of a repeat to the median alone) is printed beside. The
loop is timed by a wrapper around the loop's chunk source (``WRAPPER``): its wall time (the
throughput; the summary's "in X s" is the same span) and its main thread's CPU time (the
detector's and the hand-off's work, without the scheduling noise of two cores shared with the
sidecar).

Usage (under the heavy-job lock; about 2-4 minutes)::

    flock /tmp/leakdiag-heavy.lock .venv/bin/python perf/monitor_cli_throughput.py

The inputs (the recording, the healthy runs and the fitted acf-p1 detector) are made once in
``--work`` (default ``/tmp/leakdiag-monitor-cli``) and reused.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile

LEAKDIAG = os.path.join(os.path.dirname(sys.executable), "leakdiag")
HOURS = 4
SUMMARY = re.compile(r": (\d+) samples at [0-9.e+]+ Hz, .* in ([0-9.e+-]+) s")
CASES = {
    "alone": [],
    "--dashboard": ["--dashboard", "127.0.0.1:0"],
    "--store": ["--store", "{work}/events-{i}.db"],
    "--store --dashboard": ["--store", "{work}/events-{i}.db", "--dashboard", "127.0.0.1:0"],
}


def _run(cmd: list[str]) -> str:
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({res.returncode}):\n{res.stderr}")
    return res.stdout + res.stderr


def prepare(work: str) -> tuple[str, str]:
    """The one-hour recording and the fitted detector file (made once)."""
    os.makedirs(work, exist_ok=True)
    rec, det = os.path.join(work, f"{HOURS}-hours.parquet"), os.path.join(work, "acf-p1.joblib")
    if not os.path.exists(det):
        healthy = []
        for s in range(8):
            path = os.path.join(work, f"healthy-{s}.parquet")
            _run([LEAKDIAG, "simulate", "vca", "--duration", "120", "--leak", "0",
                  "--seed", str(100 + s), "-o", path])
            healthy.append(path)
        _run([LEAKDIAG, "fit", "-m", "acf-p1", *sum((["--healthy", h] for h in healthy), []),
              "--false-alarm-rate", "10", "-o", det + ".tmp.joblib"])
        os.replace(det + ".tmp.joblib", det)
    if not os.path.exists(rec):
        hour = os.path.join(work, "one-hour.parquet")
        if not os.path.exists(hour):
            _run([LEAKDIAG, "simulate", "vca", "--duration", "3600", "--leak", "0", "--seed",
                  "7", "-o", hour + ".tmp.parquet"])
            os.replace(hour + ".tmp.parquet", hour)
        # HOURS of that hour's samples back to back (a run long enough to time: the command
        # alone takes about 0.2-0.7 s an hour), with its sample rate and metadata
        import numpy as np

        from leakdiag.io import read_recording, write_recording
        from leakdiag.io.recording import Recording

        one = read_recording(hour)
        long = Recording({c: np.tile(one[c], HOURS) for c in one.channel_names},
                         one.sample_rate, meta=one.meta, units=one.units)
        write_recording(long, rec + ".tmp.parquet")
        os.replace(rec + ".tmp.parquet", rec)
    return rec, det


#: Runs the command as its entry point does, with ``leakdiag.stream.paced`` (the loop's source
#: of chunks) wrapped to time the loop: wall and the main thread's CPU from the first chunk's
#: request to the input's end, printed as "LOOP wall cpu" on stderr.
WRAPPER = """
import sys, time
import leakdiag.stream as S
_paced = S.paced
def paced(source, speed):
    w0, c0 = time.perf_counter(), time.thread_time()
    yield from _paced(source, speed)
    print(f"LOOP {time.perf_counter() - w0!r} {time.thread_time() - c0!r}", file=sys.stderr)
S.paced = paced
from leakdiag.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def once(rec: str, det: str, case: str, chunk: int, work: str, i: int) -> tuple[float, float]:
    """Samples per second of one run of the command's loop: by its wall time (the throughput)
    and by its main thread's CPU time."""
    extra = [a.format(work=work, i=i) for a in CASES[case]]
    for a in extra:
        if a.endswith(".db") and os.path.exists(a):
            os.remove(a)  # a fresh store each run
    out = _run([sys.executable, "-c", WRAPPER, "monitor", rec, "--detector", det, "--chunk",
                str(chunk), "--actuator", "bench", *extra])
    m, loop = SUMMARY.search(out), re.search(r"^LOOP (\S+) (\S+)$", out, re.M)
    if m is None or loop is None:
        raise SystemExit(f"no summary line or loop time in:\n{out}")
    n = int(m.group(1))
    return n / float(loop.group(1)), n / float(loop.group(2))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=6)
    ap.add_argument("--chunks", default="65536,1000")
    ap.add_argument("--work", default=os.path.join(tempfile.gettempdir(),
                                                   "leakdiag-monitor-cli"))
    args = ap.parse_args(argv)
    rec, det = prepare(args.work)
    with open("/proc/loadavg") as f:
        load0 = f.read().split()[0]
    for chunk in (int(c) for c in args.chunks.split(",")):
        names = list(CASES)
        rates: dict[str, list[tuple[float, float]]] = {c: [] for c in names}
        for r in range(args.repeats):
            order = names if r % 2 == 0 else names[::-1]  # ABBA
            for case in order:
                rates[case].append(once(rec, det, case, chunk, args.work, r))
        for k, what in ((0, "wall time (throughput)"), (1, "main thread's CPU time")):
            alone = statistics.median(x[k] for x in rates["alone"])
            print(f"--chunk {chunk}, by the loop's {what}: the command alone {alone:.3g} "
                  f"samples/s (median of {args.repeats})")
            for case in names[1:]:
                vals = [x[k] for x in rates[case]]
                med = statistics.median(vals)
                print(f"  {case:22s} {med:.3g} samples/s: {100 * med / alone:.1f} % of alone "
                      f"(repeats {100 * min(vals) / alone:.0f}-{100 * max(vals) / alone:.0f} %)")
            vals = [x[k] for x in rates["alone"]]
            print(f"  {'alone, its repeats':22s} {100 * min(vals) / alone:.0f}-"
                  f"{100 * max(vals) / alone:.0f} % of its median")
    with open("/proc/loadavg") as f:
        print(f"load {load0} -> {f.read().split()[0]} (1-min average)")


if __name__ == "__main__":
    main()
