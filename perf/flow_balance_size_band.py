"""How far the flow balance's leak size is from the truth on virtual machines (size band).

``python -m perf.flow_balance_size_band [--per-size 9] [--systems vca,eha] [--out DIR]``

For each rig and load, the benchmark v5 suite's leaking runs of index ``--first`` (default 10)
on, ``--per-size`` of them per leak size: the runs the benchmark does not use (it judges
indexes 0-9), each its own virtual machine, fitted per unit on 2 own healthy runs as in the
benchmark's per-unit mode. For every run detected at or after its onset the ratio
``leak_lpm / leak_lpm_achieved`` (the verdict's size over the run's true mean leak after the
onset) is written to ``DIR/size_ratios.csv``; per group the smallest and largest ratio of the
detected runs are printed: the
constants of ``detect/_flow_balance_size.py`` (docs/detect.md 8.5, "Size interval").

Resumable: after every run the rows so far are written whole (a temporary file and an atomic
rename) to ``DIR/rows-<key>.csv``, the key a hash of what a row depends on (the alarm and fit
settings below, the source of :func:`_run_row`, the code of :data:`CODE_PARTS`, the library
versions; not ``--per-size``/``--first``, which choose runs, not how a run is judged). A rerun
reads back only rows of its own key and says how many; ``size_ratios.csv`` holds the rows of
this key alone. Until 2026-11-27 the whole CSV was rewritten in place after every row and a
row counted as done by its seed alone, under any code or setting, a half-written row included
(cache audit 2026-11-27, finding 4).
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
from pathlib import Path

import numpy as np

#: The benchmark's per-unit settings: false alarms per run, the alarm's threshold confidence
#: and the unit's own healthy runs the detector is fitted on.
FALSE_ALARM_PER_RUN, CONFIDENCE, N_OWN = 0.01, 0.95, 2
#: The parts of leakdiag whose code a row depends on: the simulators and what they call,
#: the flow balance and its features, the benchmark's suite and helpers (``bench``).
CODE_PARTS = ("_holds.py", "_validation.py", "bench", "detect", "features", "io", "sim")
#: Columns of a row.
COLUMNS = ["system", "load", "leak_lpm", "seed", "machine", "detected", "truth_lpm",
           "leak_lpm_est", "ratio"]


def _run_row(system, suite, c) -> dict:
    """Fit the flow balance on the unit's own healthy runs and judge one leaking run."""
    from leakdiag.bench.registry import make_detector
    from leakdiag.bench.v5_common import _simulate, v5_alarm
    from leakdiag.bench.v5_unit import own_cases

    own = [_simulate(o) for o in own_cases(c, N_OWN, suite.nuisance)]
    det = make_detector("flow-balance", system,
                        v5_alarm(FALSE_ALARM_PER_RUN, c.duration_s, confidence=CONFIDENCE))
    det.fit(own)
    rec = _simulate(c)
    v = det.predict(rec)
    truth = float(rec.meta["leak_lpm_achieved"])
    ok = bool(v.leak and v.alarm_time_s >= c.onset_s and v.leak_lpm is not None)
    return {"system": system, "load": c.load, "leak_lpm": c.leak_lpm, "seed": c.seed,
            "machine": c.nuisance["machine"], "detected": ok, "truth_lpm": truth,
            "leak_lpm_est": v.leak_lpm, "ratio": v.leak_lpm / truth if ok else np.nan}


def rows_key() -> str:
    """Hash of everything a row depends on (see the module's docstring)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [FALSE_ALARM_PER_RUN, CONFIDENCE, N_OWN, inspect.getsource(_run_row),
           parts_fingerprint(CODE_PARTS), library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def main(argv=None) -> None:
    from perf._rows import resume, save
    from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-size", type=int, default=9)
    ap.add_argument("--first", type=int, default=10)
    ap.add_argument("--out", default="size-band")
    ap.add_argument("--systems", default=",".join(V5_SUITES),
                    help="rigs to measure, comma-separated (default: all)")
    args = ap.parse_args(argv)
    systems = args.systems.split(",")
    unknown = sorted(set(systems) - set(V5_SUITES))
    if unknown:
        ap.error(f"--systems: unknown rig(s) {unknown}; choose from {sorted(V5_SUITES)}")
    state, rows = resume(args.out, rows_key(), COLUMNS, "size-band rows", filled=("seed",))
    seen = {int(r["seed"]) for r in rows}
    for system, suite in V5_SUITES.items():
        if system not in systems:
            continue
        cases = [c for c in build_v5_suite({system: suite}) if c.role == "test_leak"
                 and args.first <= c.nuisance["index"] < args.first + args.per_size]
        for c in cases:
            if c.seed in seen:
                continue
            rows.append(_run_row(system, suite, c))
            save(state, rows, COLUMNS)
            print(system, c.load, c.leak_lpm, c.seed, rows[-1]["ratio"], flush=True)
    df = save(Path(args.out) / "size_ratios.csv", rows, COLUMNS)
    print("group, detected runs, smallest and largest ratio:")
    for (s, ld), g in df[df.detected.astype(bool)].groupby(["system", "load"]):
        r = np.sort(g.ratio.to_numpy())
        print(f"{s} {ld}: n={len(r)} min={r[0]:.4f} max={r[-1]:.4f} "
              f"p2.5={np.quantile(r, 0.025):.4f} p97.5={np.quantile(r, 0.975):.4f}")


if __name__ == "__main__":
    main()
