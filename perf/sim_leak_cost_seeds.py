"""CPU cost of a leaking 400-s run against a healthy one, per rig and load, over seeds 0-2.

Usage: ``python perf/sim_leak_cost_seeds.py`` (run it alone, e.g. under the heavy-job lock).
Prints, per rig and load, the median healthy CPU time with its real-time factor, and per leak
size the median leaking/healthy ratio with the calibration's post-onset runs of each seed
(``meta["calibration_runs"]``). docs/models.md ("Checked again") quotes one run.
"""
import time

import numpy as np

import leakdiag as ld


def t(fn):
    a = time.process_time()
    r = fn()
    return time.process_time() - a, r


for sysname in ("vca", "eha"):
    sim = getattr(ld.sim, f"simulate_{sysname}")
    sim(duration=20, leak_lpm=0.1, onset=10, seed=0)  # warm-up
    for load in ("none", "spring"):
        res = {}
        for rep in range(3):
            for lk in (0.0, 0.02, 0.2):
                dt, r = t(lambda: sim(duration=400, leak_lpm=lk or None, onset=200, load=load,
                                      seed=rep))
                res.setdefault(lk, []).append((dt, r.meta.get("calibration_runs")))
        h = np.median([d for d, _ in res[0.0]])
        print(sysname, load, "healthy %.3f s (%.0fx real time)" % (h, 400 / h),
              " ".join("%g: %.2fx runs %s" % (lk, np.median([d for d, _ in v]) / h,
                                              [c for _, c in v])
                       for lk, v in res.items() if lk), flush=True)
