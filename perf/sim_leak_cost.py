"""Cost of a leaking simulation against a healthy one (a timing script, not a test).

Run: ``PYTHONPATH=src python perf/sim_leak_cost.py [--repeat 3]``. Prints, per case, the
best wall time of a healthy and a leaking run of the same experiment, their ratio, the real-time
factors of the leaking and the healthy run, and the calibration's post-onset and pilot runs.
To compare two trees, run it alternately on each (``PYTHONPATH=<tree>/src``) under one
``flock /tmp/leakdiag-heavy.lock`` and compare within that run. Compile time is excluded (one
warm-up run first). Numbers depend on the host; quote them with the date and host load.
"""

from __future__ import annotations

import argparse
import time

import leakdiag as ld

CASES = [
    ("vca", dict(duration=400.0, onset=200.0, leak_lpm=0.1), "VCA 400 s, no load, 0.1 L/min"),
    ("vca", dict(duration=400.0, onset=200.0, leak_lpm=0.047, load="spring"),
     "VCA 400 s, spring, 0.047 L/min"),
    ("vca", dict(duration=400.0, onset=200.0, leak_lpm=0.5), "VCA 400 s, no load, 0.5 L/min"),
    ("vca", dict(duration=120.0, onset=60.0, leak_lpm=0.02, load="spring", machine=17,
                 conditions=ld.sim.OperatingConditions(temperature_rise_k=8.0)),
     "VCA 120 s, spring, 0.02 L/min, unit 17, +8 K"),
    ("eha", dict(duration=180.0, onset=90.0, leak_lpm=1.2), "EHA 180 s, open loop, 1.2 L/min"),
    ("eha", dict(duration=180.0, onset=90.0, leak_lpm=0.1, machine=17),
     "EHA 180 s, open loop, 0.1 L/min, unit 17"),
]


def _best(fn, repeat: int):
    best, rec = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        rec = fn()
        best = min(best, time.perf_counter() - t0)
    return best, rec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    ld.sim.simulate_vca(duration=2.0, leak_lpm=0.1, onset=1.0, leak_coefficient=1e-8)
    ld.sim.simulate_eha(duration=2.0, leak_lpm=None)
    print(f"{'case':48s} {'healthy s':>9s} {'leak s':>8s} {'ratio':>6s} {'x real':>7s} "
          f"{'healthy x':>9s} {'runs':>4s} {'pilots':>6s} {'achieved/target':>15s}")
    for system, kw, label in CASES:
        fn = ld.sim.simulate_vca if system == "vca" else ld.sim.simulate_eha
        healthy = {k: v for k, v in kw.items() if k != "leak_lpm"}
        t_h, _ = _best(lambda: fn(leak_lpm=None, **healthy), args.repeat)
        t_l, rec = _best(lambda: fn(**kw), args.repeat)
        m = rec.meta
        print(f"{label:48s} {t_h:9.3f} {t_l:8.3f} {t_l / t_h:6.2f} "
              f"{kw['duration'] / t_l:7.0f} {kw['duration'] / t_h:9.0f} "
              f"{m['calibration_runs']:4d} {m['calibration_pilot_runs']:6d} "
              f"{m['leak_lpm_achieved'] / m['leak_lpm']:15.4f}")


if __name__ == "__main__":
    main()
