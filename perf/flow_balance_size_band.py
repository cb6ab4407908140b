"""How far the flow balance's leak size is from the truth on virtual machines (size band).

``python -m perf.flow_balance_size_band [--per-size 9] [--out DIR]``

For each rig and load, the benchmark v5 suite's leaking runs of index ``--first`` (default 10)
on, ``--per-size`` of them per leak size: the runs the benchmark does not use (it judges
indexes 0-9), each its own virtual machine, fitted per unit on 2 own healthy runs as in the
benchmark's per-unit mode. For every run detected at or after its onset the ratio
``leak_lpm / leak_lpm_achieved`` (the verdict's size over the run's true mean leak after the
onset) is written to ``DIR/size_ratios.csv``; per group the smallest and largest ratio of the
detected runs are printed: the
constants of ``detect/_flow_balance_size.py`` (docs/detect.md 8.5, "Size interval").
Resumable: rows already in the CSV are not run again.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd


def main(argv=None) -> None:
    from leakdiag.bench.registry import make_detector
    from leakdiag.bench.v5_common import _simulate, v5_alarm
    from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite
    from leakdiag.bench.v5_unit import own_cases

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-size", type=int, default=9)
    ap.add_argument("--first", type=int, default=10)
    ap.add_argument("--out", default="size-band")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "size_ratios.csv"
    done = pd.read_csv(path) if path.exists() else pd.DataFrame(columns=["seed"])
    rows = done.to_dict("records")
    seen = set(done["seed"].astype(int))
    for system, suite in V5_SUITES.items():
        cases = [c for c in build_v5_suite({system: suite}) if c.role == "test_leak"
                 and args.first <= c.nuisance["index"] < args.first + args.per_size]
        for c in cases:
            if c.seed in seen:
                continue
            own = [_simulate(o) for o in own_cases(c, 2, suite.nuisance)]
            det = make_detector("flow-balance", system,
                                v5_alarm(0.01, c.duration_s, confidence=0.95))
            det.fit(own)
            rec = _simulate(c)
            v = det.predict(rec)
            truth = float(rec.meta["leak_lpm_achieved"])
            ok = bool(v.leak and v.alarm_time_s >= c.onset_s and v.leak_lpm is not None)
            rows.append({"system": system, "load": c.load, "leak_lpm": c.leak_lpm,
                         "seed": c.seed, "machine": c.nuisance["machine"], "detected": ok,
                         "truth_lpm": truth, "leak_lpm_est": v.leak_lpm,
                         "ratio": v.leak_lpm / truth if ok else np.nan})
            pd.DataFrame(rows).to_csv(path, index=False)
            print(system, c.load, c.leak_lpm, c.seed, rows[-1]["ratio"], flush=True)
    df = pd.DataFrame(rows)
    print("group, detected runs, smallest and largest ratio:")
    for (s, ld), g in df[df.detected.astype(bool)].groupby(["system", "load"]):
        r = np.sort(g.ratio.to_numpy())
        print(f"{s} {ld}: n={len(r)} min={r[0]:.4f} max={r[-1]:.4f} "
              f"p2.5={np.quantile(r, 0.025):.4f} p97.5={np.quantile(r, 0.975):.4f}")


if __name__ == "__main__":
    main()
