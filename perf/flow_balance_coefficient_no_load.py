"""The VCA's leak coefficient without load, with and without the offset profile (session 27).

Usage: ``python perf/flow_balance_coefficient_no_load.py`` (about 1 min; run it alone, e.g.
under the heavy-job lock). docs/detect.md 8.5 quotes one run.

The verdict withholds the coefficient (and the flow at the reference pressure difference) on
the VCA without load (``flow_balance.COEFFICIENT_MEASURED``); this study lifts that for itself
and compares the coefficient with the simulator's (``meta["leak_coefficient"]``) on the size
band's runs (benchmark v5 suite, VCA without load, indexes 10-18 of every size, each unit fitted
on 2 own healthy runs as in the benchmark's per-unit mode), with the transducers' differential
zero error profiled (leakdiag's behaviour since 2026-11-29) and without.
"""
import numpy as np

import leakdiag.detect._flow_balance_vca as vca_backend
import leakdiag.detect.flow_balance as fb
from leakdiag.bench.registry import make_detector
from leakdiag.bench.v5_common import _simulate, v5_alarm
from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite
from leakdiag.bench.v5_unit import own_cases


def main() -> None:
    fb.COEFFICIENT_MEASURED = {"vca": ("spring", "none"), "eha": ("none", "spring")}
    suite = V5_SUITES["vca"]
    cases = [c for c in build_v5_suite({"vca": suite}) if c.role == "test_leak"
             and c.load == "none" and 10 <= c.nuisance["index"] < 19]
    res = {"profiled": [], "not profiled": []}
    for c in cases:
        own = [_simulate(o) for o in own_cases(c, 2, suite.nuisance)]
        det = make_detector("flow-balance", "vca",
                            v5_alarm(0.01, c.duration_s, confidence=0.95)).fit(own)
        rec = _simulate(c)
        truth = rec.meta["leak_coefficient"]
        for mode, key in ((("none", None), "profiled"), ((), "not profiled")):
            vca_backend.OFFSET_PROFILED_LOADS = mode
            try:
                v = det.predict(rec)
            except fb.RefusedAlarm:
                continue
            if v.leak and v.alarm_time_s >= c.onset_s and v.leak_coefficient is not None:
                res[key].append((c.leak_lpm, v.leak_coefficient / truth))
        vca_backend.OFFSET_PROFILED_LOADS = ("none", None)
    for key, rows in res.items():
        a = np.array(rows)
        print(f"{key}: {len(a)} runs, coefficient / truth {a[:, 1].min():.3f}-"
              f"{a[:, 1].max():.3f} (median {np.median(a[:, 1]):.3f})")
        for lk in np.unique(a[:, 0]):
            r = a[a[:, 0] == lk, 1]
            print(f"  {lk:g} L/min: {len(r)} runs, {r.min():.2f}-{r.max():.2f} "
                  f"(median {np.median(r):.2f})")


if __name__ == "__main__":
    main()
