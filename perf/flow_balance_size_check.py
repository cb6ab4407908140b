"""Held-out check of the flow balance's size interval: how often it holds the truth.

``python -m perf.flow_balance_size_check [--first 3000] [--per-size 30] [--workers 2]
[--systems vca,eha] [--out DIR]``

The size band (``perf/flow_balance_size_band.py``, docs/detect.md 8.5, "Size interval") is
measured on indexes 10-49 of the v5 suite's leaking runs; this judges ``--per-size`` runs per
leak size from index ``--first`` on (a block of seeds neither the band nor the benchmark uses,
each its own virtual machine fitted on 2 own healthy runs as there) with the code as it is, and
writes to ``DIR/size_check.csv`` the reported interval (statistical part and band), the
statistical part alone and whether each held the run's true mean leak after the onset. A run
the detector refused (:class:`~leakdiag.io.recording.RecordingError`: a refused alarm, or the
EHA's negative leak on the leak-free windows) or that was not detected at or after its onset
has no size and is not counted. Printed per rig
and load: intervals held / sized runs with their 95 % Clopper-Pearson interval, per leak size
the count and the median width relative to the size.

Resumable as the band study is (``perf._rows``; the key covers the code and settings).
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from perf import flow_balance_size_band as band

#: Columns of a row.
COLUMNS = ["system", "load", "leak_lpm", "seed", "machine", "index", "sized", "refused",
           "truth_lpm", "leak_lpm_est", "low_lpm", "high_lpm", "stat_low_lpm", "stat_high_lpm",
           "held", "stat_held"]


def _check_row(system, suite, c) -> dict:
    """Judge one leaking run (:func:`perf.flow_balance_size_band._judge`) and say whether its
    intervals hold the truth."""
    v, truth, ok, refused = band._judge(system, suite, c)
    row = {"system": system, "load": c.load, "leak_lpm": c.leak_lpm, "seed": c.seed,
           "machine": c.nuisance["machine"], "index": c.nuisance["index"], "sized": False,
           "refused": refused, "truth_lpm": truth}
    if not ok:
        return row
    lo, hi = v.leak_lpm_interval
    slo, shi = v.leak_lpm_interval_statistical
    return {**row, "sized": True, "leak_lpm_est": v.leak_lpm, "low_lpm": lo, "high_lpm": hi,
            "stat_low_lpm": slo, "stat_high_lpm": shi, "held": bool(lo <= truth <= hi),
            "stat_held": bool(slo <= truth <= shi)}


def _check_star(args) -> dict:
    return _check_row(*args)


def rows_key() -> str:
    """Hash of everything a row depends on (settings, row functions, code, libraries)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [band.FALSE_ALARM_PER_RUN, band.CONFIDENCE, band.N_OWN,
           inspect.getsource(_check_row), inspect.getsource(band._judge),
           parts_fingerprint(band.CODE_PARTS), library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def summary(df) -> list[str]:
    """Lines of the printed summary: per rig and load, then per leak size."""
    from leakdiag.detect.rates import clopper_pearson

    lines = []
    sized = df[df.sized.astype(bool)]
    for (system, load), g in sized.groupby(["system", "load"]):
        k, n = int(g.held.astype(bool).sum()), len(g)
        lo, hi = clopper_pearson(k, n)
        ks = int(g.stat_held.astype(bool).sum())
        lines.append(f"{system} {load}: intervals held {k}/{n} [{100 * lo:.1f}, {100 * hi:.1f} %]"
                     f" (statistical part alone {ks}/{n})")
        for size, s in g.groupby("leak_lpm"):
            width = float(np.median((s.high_lpm - s.low_lpm) / s.leak_lpm_est))
            lines.append(f"  {size:g} L/min: {int(s.held.astype(bool).sum())}/{len(s)}, "
                         f"median width {width:.3f} of the size")
    return lines


def main(argv=None) -> None:
    from perf._rows import leak_study_args, resume, run_rows, save
    from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args, systems = leak_study_args(ap, argv, V5_SUITES, "size-check", 30, 3000, "check")
    if args.first < 50:
        ap.error("--first: indexes 0-49 are the benchmark's and the size band's runs; "
                 "a held-out check takes 50 or more")
    state, rows = resume(args.out, rows_key(), COLUMNS, "size-check rows", filled=("seed",))
    seen = {int(r["seed"]) for r in rows}
    for system in systems:
        suite = replace(V5_SUITES[system], first_test_index=args.first,
                        n_test_leak=args.per_size, n_test_healthy=0, n_cal=0)
        todo = [(system, suite, c) for c in build_v5_suite({system: suite})
                if c.role == "test_leak" and c.seed not in seen]
        run_rows(todo, _check_star, args.workers, state, rows, COLUMNS, "held")
    df = save(Path(args.out) / "size_check.csv", rows, COLUMNS)
    print("\n".join(summary(df)))


if __name__ == "__main__":
    main()
