"""How far the flow balance's leak size is from the truth on virtual machines (size band).

``python -m perf.flow_balance_size_band [--per-size 40] [--systems vca,eha] [--out DIR]``

For each rig and load, the benchmark v5 suite's leaking runs of index ``--first`` (default 10)
on, ``--per-size`` of them per leak size: the runs the benchmark does not use (it judges
indexes 0-9), each its own virtual machine, fitted per unit on 2 own healthy runs as in the
benchmark's per-unit mode. For every run detected at or after its onset the verdict's size, its
statistical interval and the run's true mean leak after the onset are written to
``DIR/size_ratios.csv`` (with the ratio ``size / truth``). Each size's first half of the runs
(by index) fits the scale of :class:`~leakdiag.detect._flow_balance_size.SizeErrorModel`
(:func:`fit_scale`), the second half gives the scores (:func:`calibrate`); the models are
printed: the constants of ``detect/_flow_balance_size.py`` (docs/detect.md 8.5, "Size
interval").

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
import math
from pathlib import Path

import numpy as np

#: The benchmark's per-unit settings: false alarms per run, the alarm's threshold confidence
#: and the unit's own healthy runs the detector is fitted on.
FALSE_ALARM_PER_RUN, CONFIDENCE, N_OWN = 0.01, 0.95, 2
#: The parts of leakdiag whose code a row depends on: the simulators and what they call,
#: the flow balance and its features, the benchmark's suite and helpers (``bench``).
CODE_PARTS = ("_holds.py", "_validation.py", "bench", "detect", "features", "io", "sim")
#: Columns of a row.
COLUMNS = ["system", "load", "leak_lpm", "seed", "machine", "index", "detected", "truth_lpm",
           "leak_lpm_est", "stat_low_lpm", "stat_high_lpm", "ratio"]


def _judge(system, suite, c):
    """Fit the flow balance on the unit's own healthy runs and judge one leaking run:
    ``(verdict, true mean leak after the onset, detected at or after the onset with a size,
    refusal)``; a run the detector refuses (a refused alarm, the EHA's negative leak: a
    :class:`~leakdiag.io.recording.RecordingError`) has verdict None and its class name as
    the refusal, else the refusal is ``""``."""
    from leakdiag.bench.registry import make_detector
    from leakdiag.bench.v5_common import _simulate, v5_alarm
    from leakdiag.bench.v5_unit import own_cases
    from leakdiag.io.recording import RecordingError

    own = [_simulate(o) for o in own_cases(c, N_OWN, suite.nuisance)]
    det = make_detector("flow-balance", system,
                        v5_alarm(FALSE_ALARM_PER_RUN, c.duration_s, confidence=CONFIDENCE))
    det.fit(own)
    rec = _simulate(c)
    truth = float(rec.meta["leak_lpm_achieved"])
    try:
        v = det.predict(rec)
    except RecordingError as e:
        return None, truth, False, type(e).__name__
    return v, truth, bool(v.leak and v.alarm_time_s >= c.onset_s and v.leak_lpm is not None), ""


def _run_row(system, suite, c) -> dict:
    """One row: the size, its statistical interval and the truth (:func:`_judge`); a run the
    detector refuses (a refused alarm, the EHA's negative leak) counts as not detected."""
    v, truth, ok, _ = _judge(system, suite, c)
    stat = v.leak_lpm_interval_statistical if ok else (np.nan, np.nan)
    return {"system": system, "load": c.load, "leak_lpm": c.leak_lpm, "seed": c.seed,
            "machine": c.nuisance["machine"], "index": c.nuisance["index"], "detected": ok,
            "truth_lpm": truth, "leak_lpm_est": v.leak_lpm if ok else np.nan,
            "stat_low_lpm": stat[0], "stat_high_lpm": stat[1],
            "ratio": v.leak_lpm / truth if ok else np.nan}


def halves(df):
    """``(fit, calibration)``: each leak size's runs of a group split at the median index.

    The first half of the indexes per size (``index < first + per_size // 2`` for a study of
    ``--first``, ``--per-size``) fits the scale, the second gives the scores; split on all
    runs, detected or not, so that a missed run moves no other run to the other half.
    """
    idx = df["index"].astype(int)
    lo = idx.groupby([df.system, df.load, df.leak_lpm]).transform("min")
    hi = idx.groupby([df.system, df.load, df.leak_lpm]).transform("max")
    fit = idx < lo + (hi - lo + 1) // 2
    return df[fit], df[~fit]


def fit_scale(det) -> tuple[float, float]:
    """``(a, c)`` of the scale ``sqrt(a w^2 + (c s)^2)`` on one group's detected fit runs.

    Non-negative least squares of the squared relative error ``((s - truth) / s)^2`` on
    ``(w / s)^2`` and 1, on their means per leak size (each size weighted alike), ``w`` the
    statistical interval's half-width.
    """
    from scipy.optimize import nnls

    s = det.leak_lpm_est.to_numpy(float)
    e2 = ((s - det.truth_lpm.to_numpy(float)) / s) ** 2
    x = (((det.stat_high_lpm - det.stat_low_lpm) / 2).to_numpy(float) / s) ** 2
    m = np.c_[e2, x]
    g = np.asarray([m[(det.leak_lpm == size).to_numpy()].mean(axis=0)
                    for size in sorted(set(det.leak_lpm))])
    coef, _ = nnls(np.c_[g[:, 1], np.ones(len(g))], g[:, 0])
    if not (coef > 0).any():
        raise ValueError("size band: the fit runs give a zero scale")
    return float(coef[0]), float(np.sqrt(coef[1]))


def calibrate(fit_det, cal_det):
    """The :class:`~leakdiag.detect._flow_balance_size.SizeErrorModel` of one group: the scale
    from ``fit_det`` (:func:`fit_scale`), the extreme scores ``(s - truth) / rho`` of
    ``cal_det``."""
    from leakdiag.detect._flow_balance_size import SizeErrorModel

    a, c = (float(f"{v:.4g}") for v in fit_scale(fit_det))  # the constants as printed
    w = ((cal_det.stat_high_lpm - cal_det.stat_low_lpm) / 2).to_numpy(float)
    s = cal_det.leak_lpm_est.to_numpy(float)
    score = (s - cal_det.truth_lpm.to_numpy(float)) / np.sqrt(a * w ** 2 + (c * s) ** 2)
    # rounded outwards, so the printed band holds every calibration run
    return SizeErrorModel(a, c, math.floor(score.min() * 1e4) / 1e4,
                          math.ceil(score.max() * 1e4) / 1e4, len(score), len(fit_det))


def models(df) -> dict:
    """``{(system, load): SizeErrorModel}`` of a study's rows (detected runs only)."""
    fit, cal = (h[h.detected.astype(bool)] for h in halves(df))  # halves of all runs
    out = {}
    for key, g in cal.groupby(["system", "load"]):
        f = fit[(fit.system == key[0]) & (fit.load == key[1])]
        if len(f):  # (a study of one run per size has no fit half)
            out[key] = calibrate(f, g)
    return out


def _run_star(args) -> dict:
    return _run_row(*args)


def rows_key() -> str:
    """Hash of everything a row depends on (see the module's docstring)."""
    from leakdiag._fingerprint import library_versions, parts_fingerprint

    obj = [FALSE_ALARM_PER_RUN, CONFIDENCE, N_OWN, inspect.getsource(_run_row),
           inspect.getsource(_judge),
           parts_fingerprint(CODE_PARTS), library_versions()]
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def main(argv=None) -> None:
    from perf._rows import leak_study_args, resume, run_rows, save
    from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args, systems = leak_study_args(ap, argv, V5_SUITES, "size-band", 40, 10, "measure")
    state, rows = resume(args.out, rows_key(), COLUMNS, "size-band rows", filled=("seed",))
    seen = {int(r["seed"]) for r in rows}
    for system, suite in V5_SUITES.items():
        if system not in systems:
            continue
        cases = [c for c in build_v5_suite({system: suite}) if c.role == "test_leak"
                 and args.first <= c.nuisance["index"] < args.first + args.per_size]
        todo = [(system, suite, c) for c in cases if c.seed not in seen]
        run_rows(todo, _run_star, args.workers, state, rows, COLUMNS, "ratio")
    df = save(Path(args.out) / "size_ratios.csv", rows, COLUMNS)
    print("group: noise weight a, relative error c, scores low/high, calibration runs, fit runs")
    for (sys_, ld), m in models(df).items():
        print(f"{sys_} {ld}: SizeErrorModel({m.noise_weight:.4g}, {m.relative_error:.4g}, "
              f"{m.score_low:.4f}, {m.score_high:.4f}, {m.n}, {m.n_fit})")


if __name__ == "__main__":
    main()
