"""What the flow balance's verdict says beyond LEAK / NO LEAK, on virtual machines: the size
interval's coverage, censored onsets, withheld sizes and coefficients, growing leaks
(docs/detect.md 8.5, "what the verdict says"; the audit and its fixes of 2026-11-27 ran these
designs from scripts outside the repository, gathered here).

Per VCA unit (17, 23, 101, 102) and load (spring, none): a ``FlowBalanceDetector`` fitted on 20
healthy 120-s runs (false alarms 0.3 per hour), then two designs of 120-s judged runs:

* ``coverage``: step leaks of 0.01, 0.02, 0.05, 0.2 L/min, ``N_PER`` runs each, onset U(40, 80)
  s, temperature rise U(0, 10) K;
* ``start``: leaks of 0.02, 0.05, 0.2 L/min, 2 seeds, as steps from 0, 5, 10 and 20 s and as
  ramps (from 30 s over 60 s, from 20 s over 100 s).

Truth: ``meta["leak_lpm_achieved"]`` (the mean leak after the true onset). Printed: per load and
design, runs, detections, censored onsets, sized verdicts, intervals holding the truth with
95 % Clopper-Pearson intervals, size ratios, leaks said to grow, coefficients given.

Resumable: every fitted detector (``det_<unit>_<load>_<key>.pkl``) and every unit's rows
(``rows_<unit>_<load>_<key>.csv``) are kept in the output folder, written whole (a temporary
file and an atomic rename), and read back only under the same key: a hash of the settings they
depend on, the source of the functions that compute them, the code of the parts of leakdiag
they run (:data:`CODE_PARTS`) and the library versions (:func:`fit_key`, :func:`rows_key`).
Every file reused or computed is printed; a file that cannot be read is removed and computed
again with a warning. Until 2026-11-27 the files were keyed by unit and load alone and written
in place: a rerun with other sizes or run counts read the former rows back, and a cut CSV or
pickle was read as valid or stopped every rerun (cache audit 2026-11-27, finding 4).
About 40 CPU-minutes in all.
Not collected by pytest (no ``test_`` prefix): ``python perf/flow_balance_verdict_study.py OUT``.
"""

import hashlib
import inspect
import json
import os
import pickle
import sys

import numpy as np
import pandas as pd
from scipy.stats import beta

import leakdiag as ld
from leakdiag._fingerprint import library_versions, parts_fingerprint
from leakdiag.bench._workfiles import read_or_discard, write_atomic
from leakdiag.io.recording import RecordingError

UNITS = (17, 23, 101, 102)
LOADS = ("spring", "none")
N_FIT, FIT_S, RUN_S, N_PER = 20, 120.0, 120.0, 6
FALSE_ALARMS_PER_HOUR = 0.3
COVERAGE_SIZES = (0.01, 0.02, 0.05, 0.2)
START_SIZES = (0.02, 0.05, 0.2)
START_KINDS = (("step@0", 0.0, None), ("step@5", 5.0, None), ("step@10", 10.0, None),
               ("step@20", 20.0, None), ("ramp30+60", 30.0, 60.0), ("ramp20+100", 20.0, 100.0))


def clopper_pearson(k: int, n: int) -> str:
    lo = 0.0 if k == 0 else beta.ppf(0.025, k, n - k + 1)
    hi = 1.0 if k == n else beta.ppf(0.975, k + 1, n - k)
    return f"{k}/{n} [{lo:.3f}, {hi:.3f}]"


#: The parts of leakdiag whose code the study's files depend on: the simulator and what it
#: calls (``sim``, ``io``, ``_validation.py``), the flow balance and its features (``detect``,
#: ``features``, ``_holds.py``).
CODE_PARTS = ("_holds.py", "_validation.py", "detect", "features", "io", "sim")


def _hash(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


def fit_key(unit: int, load: str) -> str:
    """Key of a fitted detector: its settings, the fitting code, leakdiag's and the libraries'."""
    return _hash([unit, load, N_FIT, FIT_S, FALSE_ALARMS_PER_HOUR, inspect.getsource(detector),
                  parts_fingerprint(CODE_PARTS), library_versions()])


def rows_key(unit: int, load: str) -> str:
    """Key of a unit's rows: its detector's key, both designs and the code that runs them."""
    return _hash([fit_key(unit, load), RUN_S, N_PER, COVERAGE_SIZES, START_SIZES, START_KINDS,
                  inspect.getsource(judge), inspect.getsource(unit_rows)])


def _read_pickle(path):
    with open(path, "rb") as f:
        return pickle.load(f)


def detector(out: str, unit: int, load: str):
    path = os.path.join(out, f"det_{unit}_{load}_{fit_key(unit, load)}.pkl")
    det = read_or_discard(path, _read_pickle, "fitted detector")
    if det is not None:
        print(f"reused {path}", flush=True)
        return det
    healthy = [ld.sim.simulate_vca(duration=FIT_S, leak_lpm=0.0, load=load, machine=unit, seed=s)
               for s in range(N_FIT)]
    det = ld.detect.FlowBalanceDetector(system="vca",
                                        false_alarms_per_hour=FALSE_ALARMS_PER_HOUR).fit(healthy)
    write_atomic(path, lambda tmp: tmp.write_bytes(pickle.dumps(det)))
    print(f"computed {path}", flush=True)
    return det


def judge(det, rec, row: dict) -> dict:
    row["achieved"] = rec.meta["leak_lpm_achieved"]
    try:
        v = det.predict(rec)
    except RecordingError as exc:
        return {**row, "refused": str(exc)[:200]}
    row.update(leak=v.leak, onset_s=v.onset_s, censored=v.onset_censored, lpm=v.leak_lpm,
               coefficient_given=v.leak_coefficient is not None,
               growing=getattr(v, "recent_leak_lpm", None) is not None)
    if v.leak_lpm_interval is not None:
        lo, hi = v.leak_lpm_interval
        row.update(lo=lo, hi=hi, covered=bool(lo <= row["achieved"] <= hi))
    return row


def _n_rows() -> int:
    return len(COVERAGE_SIZES) * N_PER + len(START_SIZES) * 2 * len(START_KINDS)


def _read_rows(path) -> pd.DataFrame:
    df = pd.read_csv(path)
    if len(df) != _n_rows():  # written whole, so this is a damaged file
        raise ValueError(f"{len(df)} rows, not {_n_rows()}")
    return df


def unit_rows(out: str, unit: int, load: str) -> pd.DataFrame:
    path = os.path.join(out, f"rows_{unit}_{load}_{rows_key(unit, load)}.csv")
    df = read_or_discard(path, _read_rows, "rows")
    if df is not None:
        print(f"reused {path} ({len(df)} rows)", flush=True)
        return df
    det = detector(out, unit, load)
    rows = []
    for size in COVERAGE_SIZES:
        for k in range(N_PER):
            seed = 1000 + 97 * unit + 13 * k + int(size * 1000)
            rng = np.random.default_rng(seed)
            onset, temp = float(rng.uniform(40, 80)), float(rng.uniform(0, 10))
            rec = ld.sim.simulate_vca(duration=RUN_S, leak_lpm=size, onset=onset, load=load,
                                      machine=unit, seed=seed,
                                      conditions=ld.sim.OperatingConditions(
                                          temperature_rise_k=temp))
            rows.append(judge(det, rec, dict(design="coverage", kind="step", unit=unit,
                                             load=load, size=size, seed=seed,
                                             true_onset=onset)))
    for size in START_SIZES:
        for s in range(2):
            seed = 7000 + 31 * unit + 7 * s + int(1000 * size)
            for kind, onset, ramp in START_KINDS:
                kw = dict(leak_kind="ramp", ramp_duration=ramp) if ramp else {}
                rec = ld.sim.simulate_vca(duration=RUN_S, leak_lpm=size, onset=onset, load=load,
                                          machine=unit, seed=seed, **kw)
                rows.append(judge(det, rec, dict(design="start", kind=kind, unit=unit,
                                                 load=load, size=size, seed=seed,
                                                 true_onset=onset)))
    df = pd.DataFrame(rows)
    write_atomic(path, lambda tmp: df.to_csv(tmp, index=False))
    print(f"computed {path} ({len(df)} rows)", flush=True)
    return df


def main(out: str) -> None:
    os.makedirs(out, exist_ok=True)
    d = pd.concat([unit_rows(out, u, load) for u in UNITS for load in LOADS], ignore_index=True)
    d["ratio"] = d["lpm"] / d["achieved"]
    for (load, design, kind), g in d.groupby(["load", "design", "kind"]):
        sized = g[g["lpm"].notna()]
        cov = int(sized["covered"].fillna(False).astype(bool).sum())
        print(f"{load:6s} {design:8s} {kind:10s} runs {len(g):3d}, detected "
              f"{int(g['leak'].fillna(False).astype(bool).sum())}, censored "
              f"{int(g['censored'].fillna(False).astype(bool).sum())}, sized {len(sized)}, "
              f"interval holds {clopper_pearson(cov, len(sized)) if len(sized) else '-'}, "
              f"size ratio {sized['ratio'].min():.3g}-{sized['ratio'].max():.3g} (median "
              f"{sized['ratio'].median():.3g}), growing "
              f"{int(g['growing'].fillna(False).astype(bool).sum())}, coefficient given "
              f"{int(g['coefficient_given'].fillna(False).astype(bool).sum())}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "flow_balance_verdict_study")
