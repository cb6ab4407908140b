"""How many windows after a censored onset does the flow balance's VCA size need?

``python -m perf.censored_size [--machines 3,17,42] [--leaks 0.01,0.02,0.05] [--seeds 1,2,3,4]
[--lengths 9,11,...,45] [--variants start,mid15,mid35] [--out DIR] [--report]``

A leak present from a recording's first sample (or a ``monitor --segment`` segment of a leak
that was already running) has its onset in the first windows judged: the onset is *censored*
("at or before"), and the per-recording null offset and gain are fitted on leaking windows. Such
a leak is sized only with :data:`leakdiag.detect.flow_balance.CENSORED_SIZE_MIN_WINDOWS`
windows after its onset window; this study measured that limit (session 23, docs/detect.md
8.5). Each machine's ``FlowBalanceDetector(system="vca", false_alarms_per_hour=3)`` is fitted
on :data:`N_OWN` of its own healthy spring runs of :data:`FIT_S` s (seeds 100..); per (machine,
leak, seed) one spring run of :data:`SIM_S` s with the leak from the first sample is cut into
parts of ``--lengths`` s starting at 0 s (``start``) or at 15 and 35 s (``mid15``, ``mid35``)
and judged with the limit switched off (in this process only), so that every censored alarm
gets a size. Truth: the mean |leak flow| of the simulator's true channel from the reported onset
to the cut's end. ``--report`` prints the coverage of the interval per number of windows after
the onset window, with 95 % Clopper-Pearson intervals (cases share seeds and nested cuts, so
the intervals are narrower than the evidence).

Resumable: rows are written whole after each simulated run (temporary file, atomic rename),
keyed by a hash of the settings, the source of the functions here, the code of
:data:`CODE_PARTS` and the library versions (``perf._rows``); a rerun reuses rows of its own key
only and skips the (machine, leak, seed, variant, length) already there. The table of all rows
goes to ``OUT/censored_size.parquet``; the rows made in session 23 are in
``docs/flow_balance_study/censored_size/``.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import pickle
from pathlib import Path

import numpy as np
import pandas as pd

#: False alarms per hour of the fitted detectors; own healthy runs and their length (s); length
#: of the leaking runs that are cut (s).
FAPH, N_OWN, FIT_S, SIM_S = 3.0, 8, 120.0, 80.0
#: Where each variant cuts the leaking run (s).
T0 = {"start": 0.0, "mid15": 15.0, "mid35": 35.0}
#: Bins of windows after the onset window (upper edges) and their labels.
BINS = [0, 6, 9, 12, 14, 15, 18, 22, 27, 35, 45]
LABELS = ["<=6", "7-9", "10-12", "13-14", "15", "16-18", "19-22", "23-27", "28-35", "36-45"]
LPM_PER_M3S = 6e4
#: Code a row depends on.
CODE_PARTS = ("_holds.py", "_validation.py", "detect", "features", "io", "sim")
COLUMNS = ["machine", "leak", "seed", "variant", "length_s", "t0", "error", "alarm",
           "score_max", "threshold", "onset_s", "j", "n_after", "censored", "size_lpm",
           "truth_lpm", "lo", "hi"]


def rows_key() -> str:
    """Hash of everything a row depends on (not which machines, leaks, seeds or cuts)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [FAPH, N_OWN, FIT_S, SIM_S, T0, inspect.getsource(case), inspect.getsource(_fit),
           parts_fingerprint(CODE_PARTS), library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def _fit(machine: int, out: Path, key: str):
    import leakdiag as ld
    from leakdiag.detect import FlowBalanceDetector

    path = out / f"det_m{machine}-{key}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    own = [ld.sim.simulate_vca(duration=FIT_S, leak_lpm=0.0, load="spring", machine=machine,
                               seed=s) for s in range(100, 100 + N_OWN)]
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=FAPH).fit(own)
    path.write_bytes(pickle.dumps(det))
    return det


def case(det, full, variant: str, length_s: float) -> dict:
    """One cut of a leaking run judged: its alarm, onset, windows after it, size and truth."""
    from leakdiag.io import RecordingError

    t0 = T0[variant]
    rec = full.slice_time(t0, t0 + length_s)
    row = {"variant": variant, "length_s": length_s, "t0": t0}
    flow = np.abs(rec["leak_flow"]) * LPM_PER_M3S
    try:
        v = det.predict(rec)
    except RecordingError as exc:
        row["error"] = type(exc).__name__
        return row
    row.update(alarm=bool(v.leak), score_max=v.score_max, threshold=v.threshold)
    if not v.leak:
        return row
    j = int(round((v.onset_s - t0 - det.burn_in_s) / det.window_s))  # the onset window
    first = j + 1 if j + 1 < v.n_windows else j
    i0 = int(round((v.onset_s - t0) * rec.sample_rate))
    row.update(onset_s=v.onset_s, j=j, n_after=v.n_windows - first,
               censored=bool(v.onset_censored), size_lpm=v.leak_lpm,
               truth_lpm=float(flow[i0:].mean()))
    if v.leak_lpm_interval is not None:
        row.update(lo=v.leak_lpm_interval[0], hi=v.leak_lpm_interval[1])
    return row


def report(rows: pd.DataFrame) -> list[str]:
    """The coverage table of the censored sizes, one line per bin of windows after the onset."""
    from leakdiag.detect.rates import clopper_pearson

    a = rows[rows["censored"].eq(True) & rows["lo"].notna()].copy()
    a["held"] = (a["lo"] <= a["truth_lpm"]) & (a["truth_lpm"] <= a["hi"])
    a["ratio"] = a["size_lpm"] / a["truth_lpm"]
    a["bin"] = pd.cut(a["n_after"], bins=BINS, labels=LABELS, include_lowest=True)
    out = [f"{len(a)} censored sizes of {a.groupby(['machine', 'leak', 'seed']).ngroups} runs"]
    for b, x in a.groupby("bin", observed=True):
        k, n = int(x["held"].sum()), len(x)
        lo, hi = clopper_pearson(k, n)
        out.append(f"{b:>6} windows: {n:5d} cases, interval held {100 * k / n:5.1f} % "
                   f"({100 * lo:.1f}-{100 * hi:.1f}), median size/truth "
                   f"{x['ratio'].median():.2f} ({x['ratio'].min():.3g}-{x['ratio'].max():.3g})")
    for limit in (15, 20, 25, 28):
        x = a[a["n_after"] >= limit]
        gross = int(((x["ratio"] < 0.5) | (x["ratio"] > 2.0)).sum())
        out.append(f"at {limit} windows or more: {100 * x['held'].mean():.1f} % of {len(x)} "
                   f"held, {gross} gross errors (size < 0.5x or > 2x the truth)")
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="censored_size")
    ap.add_argument("--machines", default="3,17,42")
    ap.add_argument("--leaks", default="0.01,0.02,0.05")
    ap.add_argument("--seeds", default="1,2,3,4")
    ap.add_argument("--lengths", default="9,11,13,15,17,19,21,23,25,28,31,35,40,45")
    ap.add_argument("--variants", default="start,mid15,mid35")
    ap.add_argument("--report", action="store_true", help="print the table of OUT only")
    a = ap.parse_args(argv)
    out = Path(a.out)
    table = out / "censored_size.parquet"
    if a.report:
        print("\n".join(report(pd.read_parquet(table))))
        return
    import leakdiag as ld
    import leakdiag.detect.flow_balance as fb
    from perf._rows import resume, save

    fb.CENSORED_SIZE_MIN_WINDOWS = 0  # this process only: every censored alarm sized
    key = rows_key()
    state, rows = resume(out, key, COLUMNS, "censored-size rows")
    done = {(r["machine"], r["leak"], r["seed"], r["variant"], float(r["length_s"]))
            for r in rows}
    lengths = [float(x) for x in a.lengths.split(",")]
    for m in map(int, a.machines.split(",")):
        det = _fit(m, out, key)
        for leak in map(float, a.leaks.split(",")):
            for seed in map(int, a.seeds.split(",")):
                todo = [(v, L) for v in a.variants.split(",") for L in lengths
                        if (m, leak, seed, v, L) not in done]
                if not todo:
                    continue
                full = ld.sim.simulate_vca(duration=SIM_S, leak_lpm=leak, onset=0.0,
                                           load="spring", machine=m, seed=seed)
                rows += [{**case(det, full, v, L), "machine": m, "leak": leak, "seed": seed}
                         for v, L in todo]
                save(state, rows, COLUMNS)
                print(f"machine {m}, {leak} L/min, seed {seed}: {len(todo)} cuts", flush=True)
    df = pd.DataFrame(rows, columns=COLUMNS)
    df.to_parquet(table, index=False)
    print("\n".join(report(df)))


if __name__ == "__main__":
    main()
