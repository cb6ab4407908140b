"""Decision false-alarm check: 30 healthy VCA runs split at 60 s, per-method and overall
decisions of :func:`leakdiag.detect.analysis.analyze_recording` (docs/measure.md, "Decisions").

About 75 s on one core; writes ``decision_false_alarms.csv`` in the current folder. Not collected
by pytest (no ``test_`` prefix): run it with ``python perf/decision_false_alarms.py``.
"""

import sys
import warnings

import pandas as pd

import leakdiag as ld
from leakdiag.detect.analysis import analyze_recording, overall_decision
from leakdiag.features.spec import thesis_defaults

SEEDS = range(100, 130)  # 30 healthy runs
DURATION_S, SPLIT_S, ALPHA = 120.0, 60.0, 0.01


def main() -> None:
    warnings.simplefilter("ignore")  # zero-variance u,x windows while the piston rests
    rows = []
    for s in SEEDS:
        rec = ld.sim.simulate_vca(duration=DURATION_S, leak_lpm=None, seed=s,
                                  reference_seed=1000 + s)
        t = analyze_recording(rec, thesis_defaults("vca"), onset=SPLIT_S,
                              false_alarm_rate=ALPHA).table
        for r in t.to_dict("records"):
            rows.append({"seed": s, "method": f"{r['method']} {r['channels']}",
                         "decision": r["decision"], "p": r["p_value"],
                         "rho": r["chunk_autocorr"]})
        rows.append({"seed": s, "method": "overall", "decision": overall_decision(t, ALPHA)[0]})
        print(s, flush=True, file=sys.stderr)
    df = pd.DataFrame(rows)
    df.to_csv("decision_false_alarms.csv", index=False)
    print(df.groupby("method")["decision"].value_counts().unstack(fill_value=0))
    print(df.groupby("method")["rho"].median())


if __name__ == "__main__":
    main()
