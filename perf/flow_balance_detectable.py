"""Does a flow-balance NO LEAK's "smallest leak it would have seen" hold? (virtual machines)

``python -m perf.flow_balance_detectable [--machines 3,5,17,23] [--per-machine 5] [--out DIR]``

For each rig and load, each virtual machine (``--machines``) gets a flow-balance detector
fitted on :data:`N_OWN` of its own healthy runs of :data:`DURATION_S` s (seeds 100..,
:data:`FALSE_ALARMS_PER_HOUR`). Then, per suspect seed (200..), the healthy run of that seed is
judged; where it reads NO LEAK, the verdict's ``detectable_lpm`` (the step leak that reaches the
threshold with probability ``DETECTABLE_POWER`` under the test's error model, from
``detectable_from_s`` to the end; ``FlowBalanceDetector._detectable``) is simulated on the same
seed (same reference and noise; the step at ``detectable_from_s``) and judged. A row per
suspect goes to ``DIR/rows-<key>.csv``; the printed share of alarms per group is what
``DETECTABLE_MEASURED`` in ``detect/flow_balance.py`` rests on (docs/detect.md 8.5).

The size is computed for every rig and load here, also where the detector withholds it
(``DETECTABLE_MEASURED`` is widened in this process only), so that the withheld groups are
measured too.

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
COLUMNS = ["system", "load", "machine", "seed", "healthy_leak", "healthy_error",
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


def _row(det, system, load, machine, seed) -> dict:
    """Judge the healthy run of ``seed``; on NO LEAK, the stated detectable leak on that seed."""
    from leakdiag.io.errors import RecordingError

    row = dict.fromkeys(COLUMNS)
    row.update(system=system, load=load, machine=machine, seed=seed)
    try:
        v = det.predict(_sim(system, leak_lpm=0.0, load=load, machine=machine, seed=seed))
    except RecordingError as exc:
        row["healthy_error"] = str(exc)[:200]
        return row
    row["healthy_leak"] = bool(v.leak)
    if v.leak or v.detectable_lpm is None:
        return row
    row.update(detectable_lpm=v.detectable_lpm, detectable_from_s=v.detectable_from_s)
    rec = _sim(system, leak_lpm=v.detectable_lpm, onset=v.detectable_from_s, load=load,
               machine=machine, seed=seed)
    row["truth_lpm"] = float(rec.meta["leak_lpm_achieved"])
    try:
        w = det.predict(rec)
    except RecordingError as exc:
        row["leak_error"] = str(exc)[:200]
        return row
    row.update(leak=bool(w.leak), score_max=w.score_max, threshold=w.threshold)
    return row


def rows_key() -> str:
    """Hash of everything a row depends on (not ``--machines``/``--per-machine``, which choose
    runs, not how a run is judged)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [N_OWN, DURATION_S, FALSE_ALARMS_PER_HOUR, inspect.getsource(_row),
           inspect.getsource(_sim), inspect.getsource(_fit), parts_fingerprint(CODE_PARTS),
           library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def _read_rows(path) -> pd.DataFrame:
    df = pd.read_csv(path)
    if list(df.columns) != COLUMNS:
        raise ValueError(f"columns {list(df.columns)}, not {COLUMNS}")
    return df


def main(argv=None) -> None:
    from leakdiag.bench._workfiles import read_or_discard, write_atomic
    from leakdiag.detect import flow_balance as fb

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machines", default="3,5,17,23")
    ap.add_argument("--per-machine", type=int, default=5)
    ap.add_argument("--out", default="detectable")
    args = ap.parse_args(argv)
    machines = [int(m) for m in args.machines.split(",")]
    # measured everywhere, also where the verdict withholds it (this process only)
    fb.DETECTABLE_MEASURED = {"vca": ("spring", "none"), "eha": ("spring", "none")}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    state = out / f"rows-{rows_key()}.csv"
    done = read_or_discard(state, _read_rows, "detectable rows")
    rows = [] if done is None else done.to_dict("records")
    print(f"reused {len(rows)} rows from {state}" if rows else f"no rows to reuse in {state}",
          flush=True)
    seen = {(r["system"], r["load"], int(r["machine"]), int(r["seed"])) for r in rows}
    for system, load in GROUPS:
        for m in machines:
            todo = [s for s in range(200, 200 + args.per_machine)
                    if (system, load, m, s) not in seen]
            if not todo:
                continue
            det = _fit(system, load, m)
            for s in todo:
                rows.append(_row(det, system, load, m, s))
                so_far = pd.DataFrame(rows, columns=COLUMNS)
                write_atomic(state, lambda tmp: so_far.to_csv(tmp, index=False))
                r = rows[-1]
                print(system, load, m, s, r["detectable_lpm"], r["leak"], r["score_max"],
                      flush=True)
    df = pd.DataFrame(rows, columns=COLUMNS)
    write_atomic(out / "detectable.csv", lambda tmp: df.to_csv(tmp, index=False))
    print("group: healthy runs judged, false alarms, refused; leaks of the stated size "
          "judged, alarmed")
    for (s, ld), g in df.groupby(["system", "load"], sort=False):
        judged = g[g["leak"].notna()]
        print(f"{s} {ld}: {int(g['healthy_leak'].notna().sum())} healthy, "
              f"{int(g['healthy_leak'].eq(True).sum())} false alarm(s), "
              f"{int(g['healthy_error'].notna().sum())} refused; {len(judged)} leaks, "
              f"{int(judged['leak'].astype(bool).sum())} alarmed, "
              f"{int(g['leak_error'].notna().sum())} refused; detectable "
              f"{g['detectable_lpm'].min():.3g}-{g['detectable_lpm'].max():.3g} L/min")


if __name__ == "__main__":
    main()
