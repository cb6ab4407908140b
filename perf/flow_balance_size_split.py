"""Split the VCA's no-load size bias into its coefficient and mean |g| parts (session 28).

Usage: ``python perf/flow_balance_size_split.py SIZES FIRST STOP`` (e.g. ``0.05,0.1,0.2 10 13``:
the size band's runs of those sizes with index FIRST to STOP - 1; about 2 min). For each run:
the verdict's size over the truth, the coefficient and mean |g| over theirs, the effective
differential offset (the median of the measured minus the true P1 - P2, the true one from the
simulator's ``leak_flow`` channel through the inverted leak law) against the profiled one, and
both parts evaluated at the effective offset. docs/detect.md 8.5 ("Where the no-load bias comes
from") quotes one run.
"""
import sys

import numpy as np

import leakdiag.detect.flow_balance as fb
from leakdiag.bench.registry import make_detector
from leakdiag.bench.v5_common import _simulate, v5_alarm
from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite
from leakdiag.bench.v5_unit import own_cases
from leakdiag.sim.leak import LPM_PER_M3S, leak_flow
from leakdiag.sim.vca.params import LEAK_TRANSITION_PRESSURE_PA


def _g(dp):
    """The simulator's leak law per unit coefficient (turbulent, its laminar core)."""
    return leak_flow(1.0, dp, LEAK_TRANSITION_PRESSURE_PA, False)


def main(sizes, first: int, stop: int) -> None:
    captured = {}
    profile = fb.profile_offset

    def keep(evaluate, level, **kw):  # the verdict's profile and its evaluation of an offset
        captured["evaluate"], captured["profile"] = evaluate, profile(evaluate, level, **kw)
        return captured["profile"]

    fb.profile_offset = keep
    suite = V5_SUITES["vca"]
    cases = [c for c in build_v5_suite({"vca": suite}) if c.role == "test_leak"
             and c.load == "none" and first <= c.nuisance["index"] < stop
             and c.leak_lpm in sizes]
    grid = np.linspace(-3e6, 3e6, 600001)
    print("L/min seed noise | size k g (over the truth) | offset effective, profiled kPa | "
          "k g at the effective offset | size there")
    for c in cases:
        own = [_simulate(o) for o in own_cases(c, 2, suite.nuisance)]
        det = make_detector("flow-balance", "vca",
                            v5_alarm(0.01, c.duration_s, confidence=0.95)).fit(own)
        rec = _simulate(c)
        captured.clear()
        v = det.predict(rec)
        if not (v.leak and "profile" in captured):
            print(c.leak_lpm, c.seed, "not sized")
            continue
        kt, truth = rec.meta["leak_coefficient"], rec.meta["leak_lpm_achieved"]
        gt = truth / LPM_PER_M3S / kt
        p = captured["profile"]
        after = np.arange(rec.n_samples) / rec.sample_rate >= c.onset_s + 1.0
        true_dp = np.interp(np.asarray(rec.channels["leak_flow"])[after] / kt, _g(grid), grid)
        dp = np.asarray(rec.channels["p1"] - rec.channels["p2"])[after]
        eff = float(np.median(dp - true_dp))
        k2, _, g2 = captured["evaluate"](eff)
        print(f"{c.leak_lpm:g} {c.seed} {c.noise_std_pa / 1e3:.0f}k | {v.leak_lpm / truth:.3f} "
              f"{p.coefficient / kt:.3f} {p.mean_abs_law / gt:.3f} | {eff / 1e3:+.1f} "
              f"{p.offset_pa / 1e3:+.1f} | {k2 / kt:.3f} {g2 / gt:.3f} | "
              f"{k2 * g2 / kt / gt:.3f}", flush=True)


if __name__ == "__main__":
    main([float(s) for s in sys.argv[1].split(",")], int(sys.argv[2]), int(sys.argv[3]))
