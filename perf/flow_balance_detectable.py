"""Does a flow-balance NO LEAK's "smallest leak it would have seen" hold? (virtual machines)

``python -m perf.flow_balance_detectable [--machines 3,5,17,23] [--per-machine 5]
[--groups vca:spring,vca:none,eha:spring,eha:none] [--factors 1] [--out DIR]``

For each rig and load, each virtual machine (``--machines``) gets a flow-balance detector
fitted on :data:`N_OWN` of its own healthy runs of :data:`DURATION_S` s (seeds 100..,
:data:`FALSE_ALARMS_PER_HOUR`). Then, per suspect seed (200..), the healthy run of that seed is
judged; where it reads NO LEAK, the verdict's ``detectable_lpm`` (the smallest step leak it
states it would have seen, from ``detectable_from_s`` to the end; ``FlowBalanceDetector.
_detectable``: the error model's size times ``DETECTABLE_FACTOR``) is simulated on the same
seed (same reference and noise; the step at ``detectable_from_s``) and judged, at each of
``--factors`` times that size. A row per suspect and factor goes to ``DIR/rows-<key>.csv`` (and
all rows to ``DIR/detectable.csv``); the printed share of alarms per group is what
``DETECTABLE_RUNS`` in ``detect/flow_balance.py`` rests on (docs/detect.md 8.5).

``DETECTABLE_FACTOR`` was chosen from a run of this script before the factor existed (the
stated size was then the model's own, factors 1-4;
docs/flow_balance_study/detectable/model_size_factors.csv).

Resumable: rows are written whole after each suspect (temporary file, atomic rename), keyed by
a hash of the settings, :func:`_row`'s source, the code of :data:`CODE_PARTS` and the library
versions; a rerun reuses rows of its own key only.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
from pathlib import Path

import pandas as pd

#: Healthy runs per machine the detector is fitted on, their length (s), the false-alarm target.
N_OWN, DURATION_S, FALSE_ALARMS_PER_HOUR = 4, 120.0, 1.0
#: Code a row depends on.
CODE_PARTS = ("_holds.py", "_validation.py", "detect", "features", "io", "sim")
#: Rigs and loads measured.
GROUPS = (("vca", "spring"), ("vca", "none"), ("eha", "spring"), ("eha", "none"))
COLUMNS = ["system", "load", "machine", "seed", "factor", "healthy_leak", "healthy_error",
           "detectable_lpm", "detectable_from_s", "truth_lpm", "leak", "score_max",
           "threshold", "leak_error"]


def _sim(system, **kw):
    import leakdiag as ld

    fn = ld.sim.simulate_vca if system == "vca" else ld.sim.simulate_eha
    return fn(duration=DURATION_S, **kw)


def _fit(system, load, machine):
    from leakdiag.detect import FlowBalanceDetector

    own = [_sim(system, leak_lpm=0.0, load=load, machine=machine, seed=s)
           for s in range(100, 100 + N_OWN)]
    return FlowBalanceDetector(system=system,
                               false_alarms_per_hour=FALSE_ALARMS_PER_HOUR).fit(own)


def _row(det, system, load, machine, seed, factors) -> list[dict]:
    """Judge the healthy run of ``seed``; on NO LEAK, the stated detectable leak on that seed
    times each of ``factors`` (a row per factor; one row when the healthy run did not read NO
    LEAK)."""
    from leakdiag.io.errors import RecordingError

    row = dict.fromkeys(COLUMNS)
    row.update(system=system, load=load, machine=machine, seed=seed)
    try:
        v = det.predict(_sim(system, leak_lpm=0.0, load=load, machine=machine, seed=seed))
    except RecordingError as exc:
        row["healthy_error"] = str(exc)[:200]
        return [row]
    row["healthy_leak"] = bool(v.leak)
    if v.leak or v.detectable_lpm is None:
        return [row]
    row.update(detectable_lpm=v.detectable_lpm, detectable_from_s=v.detectable_from_s)
    rows = []
    for f in factors:
        r = {**row, "factor": f}
        rec = _sim(system, leak_lpm=f * v.detectable_lpm, onset=v.detectable_from_s, load=load,
                   machine=machine, seed=seed)
        r["truth_lpm"] = float(rec.meta["leak_lpm_achieved"])
        try:
            w = det.predict(rec)
        except RecordingError as exc:
            r["leak_error"] = str(exc)[:200]
        else:
            r.update(leak=bool(w.leak), score_max=w.score_max, threshold=w.threshold)
        rows.append(r)
    return rows


def rows_key() -> str:
    """Hash of everything a row depends on (not ``--machines``/``--per-machine``, which choose
    runs, not how a run is judged)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [N_OWN, DURATION_S, FALSE_ALARMS_PER_HOUR, inspect.getsource(_row),
           inspect.getsource(_sim), inspect.getsource(_fit), parts_fingerprint(CODE_PARTS),
           library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def main(argv=None) -> None:
    from perf._rows import resume, save

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machines", default="3,5,17,23")
    ap.add_argument("--per-machine", type=int, default=5)
    ap.add_argument("--groups", default=",".join(f"{a}:{b}" for a, b in GROUPS))
    ap.add_argument("--factors", default="1")
    ap.add_argument("--out", default="detectable")
    args = ap.parse_args(argv)
    machines = [int(m) for m in args.machines.split(",")]
    groups = [tuple(g.split(":")) for g in args.groups.split(",")]
    factors = [float(f) for f in args.factors.split(",")]
    state, rows = resume(args.out, rows_key(), COLUMNS, "detectable rows")
    seen = {(r["system"], r["load"], int(r["machine"]), int(r["seed"]), r["factor"])
            for r in rows}
    for system, load in groups:
        for m in machines:
            todo = [s for s in range(200, 200 + args.per_machine)
                    if any((system, load, m, s, f) not in seen for f in factors)]
            if not todo:
                continue
            det = _fit(system, load, m)
            for s in todo:
                todo_f = [f for f in factors if (system, load, m, s, f) not in seen]
                new = _row(det, system, load, m, s, todo_f)
                # a healthy run that did not read NO LEAK is one row, whatever the factors
                rows = [r for r in rows if not (r["system"] == system and r["load"] == load and
                        int(r["machine"]) == m and int(r["seed"]) == s and
                        pd.isna(r["factor"]))] + new
                save(state, rows, COLUMNS)
                for r in new:
                    print(system, load, m, s, r["factor"], r["detectable_lpm"], r["leak"],
                          r["score_max"], flush=True)
    df = save(Path(args.out) / "detectable.csv", rows, COLUMNS)
    print("group: healthy runs judged, false alarms, refused; per factor, leaks of that "
          "multiple of the stated size judged, alarmed")
    for (s, ld), g in df.groupby(["system", "load"], sort=False):
        healthy = g.drop_duplicates(["machine", "seed"])
        line = (f"{s} {ld}: {int(healthy['healthy_leak'].notna().sum())} healthy, "
                f"{int(healthy['healthy_leak'].eq(True).sum())} false alarm(s), "
                f"{int(healthy['healthy_error'].notna().sum())} refused; detectable "
                f"{g['detectable_lpm'].min():.3g}-{g['detectable_lpm'].max():.3g} L/min")
        for f, gf in g[g["factor"].notna()].groupby("factor"):
            judged = gf[gf["leak"].notna()]
            line += (f"; x{f:g}: {len(judged)} leaks, {int(judged['leak'].astype(bool).sum())} "
                     f"alarmed, {int(gf['leak_error'].notna().sum())} refused")
        print(line)


if __name__ == "__main__":
    main()
