"""Detection at the 10-s deadline on the VCA without load, per unit (a session-26 audit study).

Usage: ``python perf/flow_balance_cut_deadline.py [LEAK_LPM] [N_UNITS] [FIRST_UNIT] [MODE]``
(defaults 0.02, 40, 5001; run it alone, e.g. under the heavy-job lock; about 6 s per unit).
``MODE`` (an experiment, not leakdiag's behaviour): ``no-transducer-offsets`` draws each unit
without its pressure transducers' zero errors; ``no-profile`` switches off the profile of the
transducers' differential zero error in the size since the onset, as before 2026-11-29
(``_flow_balance_vca.OFFSET_PROFILED_LOADS`` emptied; ``profile-offset``, the name of the
experiment that led to it, is now what leakdiag does).

Each virtual machine ``u`` is fitted on 4 of its own healthy 120-s runs (no load,
``false_alarms_per_hour=0.3``); one held-out leaking run (onset uniform in 35-65 % of the run,
0-10 K warming, 0-0.3 MPa supply ripple) is judged whole and cut at onset + 10, 20 and 30 s.
A leak counts as found by a deadline when the cut run reads LEAK with its alarm at or after
the onset (benchmark v5's rule); a refusal (``RefusedAlarm`` and its subclasses, INCONCLUSIVE
in ``detect``) counts as missed and is counted apart. Prints the counts with exact 95 %
intervals. docs/benchmark/v5/README.md quotes one run.
"""
import sys

import numpy as np
from scipy.stats import binomtest

import dataclasses

import leakdiag as ld
import leakdiag.detect._flow_balance_vca as vca_backend
from leakdiag.detect.flow_balance import RefusedAlarm
from leakdiag.sim.machine import draw_machine

LEAK = float(sys.argv[1]) if len(sys.argv) > 1 else 0.02
N_UNITS = int(sys.argv[2]) if len(sys.argv) > 2 else 40
FIRST = int(sys.argv[3]) if len(sys.argv) > 3 else 5001
MODE = sys.argv[4] if len(sys.argv) > 4 else ""
if MODE == "no-profile":
    vca_backend.OFFSET_PROFILED_LOADS = ()




def unit(u):
    if MODE == "no-transducer-offsets":
        return dataclasses.replace(draw_machine("vca", u), p1_offset_pa=0.0, p2_offset_pa=0.0)
    return u


DUR, N_FIT, DEADLINES = 120.0, 4, (10.0, 20.0, 30.0)


def conditions(rng):
    return ld.sim.OperatingConditions(temperature_rise_k=float(rng.uniform(0, 10)),
                                      supply_ripple_pa=float(rng.uniform(0, 0.3e6)))


found = {d: 0 for d in DEADLINES}
refused = {d: 0 for d in DEADLINES}
for u in range(FIRST, FIRST + N_UNITS):
    rng = np.random.default_rng(u * 7 + 3)
    fit = [ld.sim.simulate_vca(duration=DUR, leak_lpm=0.0, load="none", machine=unit(u),
                               seed=70000 + 10 * u + i) for i in range(N_FIT)]
    det = ld.detect.FlowBalanceDetector(system="vca", false_alarms_per_hour=0.3).fit(fit)
    onset = float(rng.uniform(0.35, 0.65) * DUR)
    rec = ld.sim.simulate_vca(duration=DUR, leak_lpm=LEAK, onset=onset, load="none",
                              machine=unit(u), seed=95000 + u, conditions=conditions(rng))
    for d in DEADLINES:
        try:
            v = det.predict(rec.slice_time(None, onset + d))
            found[d] += bool(v.leak) and v.alarm_time_s >= onset
        except RefusedAlarm:
            refused[d] += 1
for d in DEADLINES:
    ci = binomtest(found[d], N_UNITS).proportion_ci(method="exact")
    print(f"{MODE or 'as is'}: {LEAK:g} L/min, onset + {d:g} s: LEAK {found[d]}/{N_UNITS} = "
          f"{found[d] / N_UNITS:.1%} [{ci.low:.1%}, {ci.high:.1%}], refused {refused[d]}",
          flush=True)
