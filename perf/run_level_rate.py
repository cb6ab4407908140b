"""Does a long run judged at the flow balance's run level keep its false-alarm promise?

``python -m perf.run_level_rate [--machines 3,5,17,23] [--per-machine 10]
[--groups vca:spring,vca:none,eha:spring] [--own N] [--out DIR]``

For each rig and load, each virtual machine (``--machines``) gets a flow-balance detector fitted
on :data:`N_OWN` (``--own``) of its own healthy runs of :data:`FIT_S` s (seeds 100..) for
:data:`FALSE_ALARMS_PER_HOUR` (about 0.1 per 115-s segment). Per suspect seed (300..) a healthy
run of :data:`RUN_S` s (about 1.5 false alarms expected at the fitted level with 4 fit runs, 0.94
with 16; longer than one healthy segment, so judged at the run level: docs/detect.md section 2,
"Long runs" and "Which runs are long") and the same seed with a step leak of
:data:`LEAK_LPM` from half-way are judged by :func:`leakdiag.detect.decision.judge_run`. The
healthy runs' alarms, against the run level's promise (``expected`` per run, at most the
``alpha`` requested of one segment), are printed with a 95 % Clopper-Pearson interval; so is the
share of leaks found, with the onset error.

Resumable: rows are written whole after each suspect (temporary file, atomic rename), keyed by
a hash of the settings, the source of the functions here, the code of :data:`CODE_PARTS` and the
library versions; a rerun reuses rows of its own key only.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
from pathlib import Path

import pandas as pd

#: Healthy runs per machine the detector is fitted on and their length (s); the false-alarm
#: target (per hour); the judged runs' length (s).
N_OWN, FIT_S, FALSE_ALARMS_PER_HOUR, RUN_S = 4, 120.0, 3.0, 1800.0
#: Leak of the leaking runs (L/min) per rig, from RUN_S / 2.
LEAK_LPM = {"vca": 0.02, "eha": 0.1}
#: Code a row depends on.
CODE_PARTS = ("_holds.py", "_validation.py", "detect", "features", "io", "sim")
GROUPS = (("vca", "spring"), ("vca", "none"), ("eha", "spring"))
COLUMNS = ["system", "load", "machine", "seed", "leak_lpm", "truth_lpm", "decision", "alarm",
           "error", "threshold", "run_level", "expected_at_threshold", "expected", "p_value",
           "score_max", "onset_s", "alarm_time_s", "size_lpm"]


def _sim(system, duration, **kw):
    import leakdiag as ld

    fn = ld.sim.simulate_vca if system == "vca" else ld.sim.simulate_eha
    return fn(duration=duration, **kw)


def _fit(system, load, machine, n_own=N_OWN):
    from leakdiag.detect import FlowBalanceDetector

    own = [_sim(system, FIT_S, leak_lpm=0.0, load=load, machine=machine, seed=s)
           for s in range(100, 100 + n_own)]
    return FlowBalanceDetector(system=system,
                               false_alarms_per_hour=FALSE_ALARMS_PER_HOUR).fit(own)


def _row(det, system, load, machine, seed, leak) -> dict:
    """Judge one run of ``RUN_S`` s (healthy when ``leak`` is 0, else from ``RUN_S / 2``)."""
    from leakdiag.detect.decision import judge_run
    from leakdiag.io.errors import RecordingError

    row = dict.fromkeys(COLUMNS)
    row.update(system=system, load=load, machine=machine, seed=seed, leak_lpm=leak,
               threshold=float(det.threshold_))
    rec = _sim(system, RUN_S, leak_lpm=leak, onset=RUN_S / 2, load=load, machine=machine,
               seed=seed)
    row["truth_lpm"] = float(rec.meta.get("leak_lpm_achieved") or 0.0)
    try:
        j = judge_run(det, rec)
    except RecordingError as exc:
        row["error"] = str(exc)[:200]
        return row
    v = j.verdict
    row.update(decision=j.decision, alarm=bool(v.leak), run_level=j.run_level,
               expected_at_threshold=j.expected_at_threshold, expected=j.expected,
               p_value=v.confidence, score_max=v.score_max, onset_s=v.onset_s,
               alarm_time_s=v.alarm_time_s, size_lpm=v.leak_lpm)
    return row


def rows_key(n_own: int = N_OWN) -> str:
    """Hash of everything a row depends on (not ``--machines``/``--per-machine``)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [n_own, FIT_S, FALSE_ALARMS_PER_HOUR, RUN_S, LEAK_LPM, inspect.getsource(_row),
           inspect.getsource(_sim), inspect.getsource(_fit), parts_fingerprint(CODE_PARTS),
           library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def summary(df: pd.DataFrame) -> list[str]:
    """Per group: healthy runs that crossed the level (LEAK, or an alarm then refused as no
    lasting leak: both are the level's false alarms) against the promise, leaks found and their
    onset errors; then the machines with any healthy crossing.

    Parameters
    ----------
    df : pandas.DataFrame
        Rows of :data:`COLUMNS`.

    Returns
    -------
    list of str
    """
    from leakdiag.detect.rates import clopper_pearson

    crossed = df["alarm"].eq(True) | df["error"].fillna("").str.contains("the test alarmed at")
    df = df.assign(crossed=crossed)
    lines = []
    for (s, ld), g in df.groupby(["system", "load"], sort=False):
        h = g[g["leak_lpm"].eq(0.0)]
        k, n = int(h["crossed"].sum()), len(h)
        lo, hi = clopper_pearson(k, n)
        lk = g[g["leak_lpm"].gt(0.0)]
        found = lk[lk["decision"].eq("leak")]
        err = (found["onset_s"] - RUN_S / 2).abs()
        lines.append(
            f"{s} {ld}: healthy {k} of {n} crossed the level (95 % CI {lo:.3g}-{hi:.3g}; "
            f"{int(h['alarm'].eq(True).sum())} LEAK, {int((h['crossed'] & h['error'].notna()).sum())}"
            f" alarmed then refused, {int((~h['crossed'] & h['error'].notna()).sum())} refused "
            f"otherwise; promised at most {h['expected'].max():.3g} per run, "
            f"{h['expected_at_threshold'].median():.3g} expected at the fitted level); leaks "
            f"{LEAK_LPM[s]:g} L/min: {len(found)} of {len(lk)} LEAK, onset within 10 s in "
            f"{int((err <= 10.0).sum())}, median error {err.median():.3g} s")
        per = h.groupby("machine")["crossed"].agg(["sum", "size"])
        bad = per[per["sum"] > 0]
        if len(bad):
            lines.append("  machines with healthy crossings: " + ", ".join(
                f"{m} ({int(r['sum'])} of {int(r['size'])})" for m, r in bad.iterrows()))
    return lines


def main(argv=None) -> None:
    from perf._rows import resume, save

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machines", default="3,5,17,23")
    ap.add_argument("--per-machine", type=int, default=10)
    ap.add_argument("--groups", default=",".join(f"{a}:{b}" for a, b in GROUPS))
    ap.add_argument("--own", type=int, default=N_OWN,
                    help="healthy runs each machine's detector is fitted on")
    ap.add_argument("--out", default="run_level")
    ap.add_argument("--report", action="store_true",
                    help="print the summary of OUT/run_level.csv only (no runs)")
    args = ap.parse_args(argv)
    if args.report:
        for line in summary(pd.read_csv(Path(args.out) / "run_level.csv")):
            print(line)
        return
    machines = [int(m) for m in args.machines.split(",")]
    groups = [tuple(g.split(":")) for g in args.groups.split(",")]
    state, rows = resume(args.out, rows_key(args.own), COLUMNS, "run-level rows")
    seen = {(r["system"], r["load"], int(r["machine"]), int(r["seed"]), float(r["leak_lpm"]))
            for r in rows}
    for system, load in groups:
        for m in machines:
            todo = [(s, lk) for s in range(300, 300 + args.per_machine)
                    for lk in (0.0, LEAK_LPM[system]) if (system, load, m, s, lk) not in seen]
            if not todo:
                continue
            det = _fit(system, load, m, args.own)
            for s, lk in todo:
                r = _row(det, system, load, m, s, lk)
                rows.append(r)
                save(state, rows, COLUMNS)
                print(system, load, m, s, lk, r["decision"], r["score_max"], r["run_level"],
                      r["onset_s"], r["error"], flush=True)
    df = save(Path(args.out) / "run_level.csv", rows, COLUMNS)
    for line in summary(df):
        print(line)


if __name__ == "__main__":
    main()
