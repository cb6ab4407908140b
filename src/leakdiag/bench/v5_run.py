"""Run benchmark v5: calibrate on training machines, score held-out units, resumably.

Three stages of pure ``run_case(config)`` calls (serial or Dask,
:func:`leakdiag.runtime.executor.run_cases`):

1. :func:`simulate_case` -- each calibration run into the simulation cache;
2. :func:`fit_method` -- one method on one group's calibration runs (read lazily from the
   cache), saved with joblib under ``work/fits/<key>.joblib`` (:func:`save_fit`);
3. :func:`score_chunk` -- a chunk of held-out runs, each simulated **once** (not cached) and
   judged by every method of its group; one row per (method, run) in
   ``work/shards/<key>.parquet``. The per-run verdict (alarm time, onset estimate) gives every
   deadline (5, 10, 30 s) without recomputation.

Keys hash everything that shapes the result (suite version, cases, method, alarm, and the code
of every package that can change a result: simulators, recordings, cache, detectors, features,
literature methods, the benchmark; :data:`~leakdiag.bench.v5_common.FINGERPRINT_PARTS`), so a
cut run resumes where it stopped and a changed setting or edited code never reads a stale file.
A fit keeps the CPU time it took; a resumed run says what it reused (:func:`work_summary`).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from leakdiag._fingerprint import library_versions
from leakdiag._version import __version__
from leakdiag.bench._workfiles import read_or_discard, remove_stale_temps, write_atomic
from leakdiag.bench.registry import make_detector
from leakdiag.bench.run import SimConfig, simulate_case, simulator_has_machines
from leakdiag.bench.v5_common import (
    LazyRecordings,
    Plan,
    _fingerprint,
    _key,
    _simulate,
    deadline_alarms,
    error_row,
    run_row,
    shard_rows,
    v5_alarm,
    write_shard,
)
from leakdiag.bench.v5_suite import V5_VERSION, build_v5_suite
from leakdiag.bench.v5_unit import own_cases, plan_units
from leakdiag.detect.base import Detector
from leakdiag.runtime.executor import run_cases

__all__ = ["LazyRecordings", "FitConfig", "ChunkConfig", "Plan", "fit_method", "fit_shared",
           "score_chunk", "run_v5", "REDUCED_BUDGET", "v5_alarm", "shares_fit", "run_row",
           "error_row", "write_shard", "save_fit", "load_fit", "work_summary",
           "work_lines"]

#: Reduced budget of the slow literature methods (calibration runs, held-out healthy runs,
#: leaking runs per size, per group): EMD ~12 and the EKF ~50 CPU s per hour of signal would
#: alone take hours on the full suite. Stated in the report.
REDUCED_BUDGET: dict[str, tuple[int, int, int]] = {"emd-p1": (100, 100, 10),
                                                   "ekf": (100, 100, 10)}


@dataclass(frozen=True)
class FitConfig:
    """One method fitted on one group's calibration runs."""

    method: str
    cases: tuple
    alarm: Any
    cache_dir: str | None
    path: str


@dataclass(frozen=True)
class ChunkConfig:
    """A chunk of held-out runs of one group, judged by every fitted method."""

    cases: tuple
    fits: tuple  # (method, fit path, caps (n_test_healthy, n_test_leak) or None)
    path: str


def save_fit(path, det, error: str | None, cpu_s: float) -> None:
    """Save one fit atomically: the fitted detector (or None and its error) and its CPU time.

    Parameters
    ----------
    path : path-like
        Fit file (joblib).
    det : Detector or None
        Fitted detector; None when the fit failed.
    error : str or None
        ``"<ErrorType>: <message>"`` of a failed fit.
    cpu_s : float
        CPU seconds the fit took (kept, so that a resumed run reports the work it reuses).
    """
    import joblib

    write_atomic(path, lambda tmp: joblib.dump({"detector": det, "error": error,
                                                "cpu_s": float(cpu_s)}, tmp))


def load_fit(path) -> dict:
    """Read a fit saved by :func:`save_fit`.

    Parameters
    ----------
    path : path-like
        Fit file.

    Returns
    -------
    dict
        ``detector`` (None for a failed fit), ``error``, ``cpu_s``.

    Raises
    ------
    ValueError
        If the file holds something else than a saved fit (a cut file raises what joblib
        raises: ``EOFError``, ``UnpicklingError``, ...).
    """
    import joblib

    saved = joblib.load(path)
    if not isinstance(saved, dict) or not {"detector", "error", "cpu_s"} <= set(saved):
        raise ValueError(f"{path}: not a fit saved by save_fit")
    return saved


def fit_method(config: FitConfig) -> dict:
    """Fit one method on its calibration runs (or read the saved fit).

    Parameters
    ----------
    config : FitConfig
        Method, calibration runs, alarm, cache, output path.

    Returns
    -------
    dict
        ``method``, the group, ``error`` (or None), ``cpu_s`` (as recorded when the fit was
        computed), ``reused`` (read from the work folder) and the threshold basis
        (``threshold_basis_.as_dict()``) of the fitted detector.
    """
    c0 = config.cases[0]
    base = {"method": config.method, "system": c0.system, "load": c0.load,
            "excitation": c0.excitation}
    path = Path(config.path)
    saved = read_or_discard(path, load_fit, "fit")  # a damaged file: warned, removed, refitted
    if saved is not None:
        det = saved["detector"]
        return {**base, "error": saved["error"], "cpu_s": saved["cpu_s"], "reused": True,
                **(_basis(det) if det is not None else {})}
    det = make_detector(config.method, c0.system, config.alarm)
    cpu0 = time.process_time()
    try:
        det.fit(LazyRecordings(config.cases, config.cache_dir))
    except (ValueError, NotImplementedError) as exc:
        err, cpu = f"{type(exc).__name__}: {exc}", time.process_time() - cpu0
        save_fit(path, None, err, cpu)
        return {**base, "error": err, "cpu_s": cpu, "reused": False}
    cpu = time.process_time() - cpu0
    save_fit(path, det, None, cpu)
    return {**base, "error": None, "cpu_s": cpu, "reused": False, **_basis(det)}


def _fit_task(task) -> list[dict]:
    kind, cfg = task
    return fit_shared(cfg) if kind == "shared" else [fit_method(cfg)]


def _basis(det) -> dict:
    """The threshold basis of a fitted detector (a detector with its own fit: what it records)."""
    basis = getattr(det, "threshold_basis_", None)
    if basis is None:
        other = getattr(det, "alarm_threshold_", None)
        return {"threshold_method": getattr(other, "method", type(other).__name__),
                "threshold": float(getattr(det, "threshold_", float("nan")))}
    b = basis.as_dict()
    b["threshold_method"] = b.pop("method")
    return b


def shares_fit(det) -> bool:
    """Whether a detector uses the base class's fit unchanged (its fit can share reads).

    Parameters
    ----------
    det : Detector
        Unfitted detector.

    Returns
    -------
    bool
        False for detectors with their own ``fit`` or ``_fit_features`` (read the runs
        themselves).
    """
    cls = type(det)
    return (isinstance(det, Detector) and cls.fit is Detector.fit
            and cls._fit_features is Detector._fit_features)


def fit_shared(configs: tuple) -> list[dict]:
    """Fit several methods of one group, reading each calibration run once for all of them.

    Parameters
    ----------
    configs : tuple of FitConfig
        Methods of one group whose detectors :func:`shares_fit`; each with its own runs (a
        prefix of the group's calibration runs).

    Returns
    -------
    list of dict
        One :func:`fit_method`-like row per method.
    """
    todo, rows = [], []
    for cfg in configs:
        if Path(cfg.path).is_file():
            rows.append(fit_method(cfg))
        else:
            todo.append((cfg, make_detector(cfg.method, cfg.cases[0].system, cfg.alarm)))
    if not todo:
        return rows
    longest = max(todo, key=lambda x: len(x[0].cases))[0].cases
    parts = {cfg.method: [] for cfg, _ in todo}
    errors: dict[str, str] = {}
    cpu = {cfg.method: 0.0 for cfg, _ in todo}
    lazy = LazyRecordings(longest, todo[0][0].cache_dir)
    for i in range(len(longest)):
        rec = lazy[i]
        for cfg, det in todo:
            if i >= len(cfg.cases) or cfg.method in errors:
                continue
            c0 = time.process_time()
            try:
                parts[cfg.method].append(det._fit_part(rec))
            except (ValueError, NotImplementedError) as exc:
                errors[cfg.method] = f"{type(exc).__name__}: {exc}"
            cpu[cfg.method] += time.process_time() - c0
    for cfg, det in todo:
        c0 = cfg.cases[0]
        base = {"method": cfg.method, "system": c0.system, "load": c0.load,
                "excitation": c0.excitation}
        path = Path(cfg.path)
        err = errors.get(cfg.method)
        if err is None:
            t0 = time.process_time()
            try:
                det._fit_from_parts(parts[cfg.method])
            except ValueError as exc:
                err = f"{type(exc).__name__}: {exc}"
            cpu[cfg.method] += time.process_time() - t0
        if err is not None:
            save_fit(path, None, err, cpu[cfg.method])
            rows.append({**base, "error": err, "cpu_s": cpu[cfg.method], "reused": False})
            continue
        save_fit(path, det, None, cpu[cfg.method])
        rows.append({**base, "error": None, "cpu_s": cpu[cfg.method], "reused": False,
                     **_basis(det)})
    return rows


def score_chunk(config: ChunkConfig) -> dict:
    """Judge a chunk of held-out runs with every fitted method; write one Parquet shard.

    Parameters
    ----------
    config : ChunkConfig
        Runs, fitted methods, shard path.

    Returns
    -------
    dict
        ``rows`` in the shard and ``reused`` (the shard existed: read back, not recomputed).
    """
    path = Path(config.path)
    n = read_or_discard(path, shard_rows, "result shard")  # damaged: warned, removed, redone
    if n is not None:
        return {"rows": n, "reused": True}
    dets = []
    for method, fpath, caps in config.fits:
        det = load_fit(fpath)["detector"]
        if det is not None:
            dets.append((method, det, caps))
    rows = []
    for c in config.cases:
        idx = c.nuisance.get("position", c.nuisance["index"])  # budget caps
        todo = [(m, d) for m, d, caps in dets
                if caps is None or idx < (caps[0] if c.role == "test_healthy" else caps[1])]
        if not todo:
            continue
        cpu0 = time.process_time()
        rec = _simulate(c)
        sim_cpu = time.process_time() - cpu0
        for m, det in todo:
            cpu0 = time.process_time()
            try:
                v = det.predict(rec)
            except (ValueError, ArithmeticError) as exc:  # recorded, never dropped
                rows.append(error_row(c, m, exc))
                continue
            rows.append({**run_row(c, m, rec, v, time.process_time() - cpu0, sim_cpu),
                         **deadline_alarms(det, rec, c)})
    return {"rows": write_shard(rows, path), "reused": False}


def run_v5(suites, methods, work_dir, *, false_alarm_per_run: float, onset_method: str = "binseg",
           scheduler: str = "serial", n_workers: int | None = None, cache_dir: str | None = None,
           progress: bool = True, unit_fit: int = 0,
           full_budget: bool = False, confidence: float | None = None) -> tuple[Any, Any, dict]:
    """All three stages; returns ``(runs, fits, settings)``.

    Parameters
    ----------
    suites : dict
        Rig -> :class:`~leakdiag.bench.v5_suite.V5Suite`.
    methods : sequence of str
        Registry names.
    work_dir : path-like
        Folder of the fits and shards (resumable state).
    false_alarm_per_run : float
        Target false-alarm probability per healthy run.
    onset_method : str, default "binseg"
        Onset estimator.
    scheduler, n_workers, cache_dir, progress
        As :func:`leakdiag.bench.run.run_suite`.
    unit_fit : int, default 0
        0: fleet mode (each method fitted once on the group's training units). N > 0: per-unit
        mode (:mod:`leakdiag.bench.v5_unit`): each unit fitted on N own healthy runs, threshold
        from reference maxima of the training units.
    full_budget : bool, default False
        No :data:`REDUCED_BUDGET`: every method on the suite's run counts.
    confidence : float, optional
        Calibration-conditional thresholds at this confidence (``Alarm.confidence``); None:
        the marginal rank ``floor(alpha (n + 1))``.

    Returns
    -------
    runs : pandas.DataFrame
        One row per (method, held-out run).
    fits : pandas.DataFrame
        One row per (method, group): threshold basis or fitting error.
    settings : dict
        Everything that shaped the run.
    """
    import pandas as pd

    work = Path(work_dir)
    budget = {} if full_budget else REDUCED_BUDGET
    cases = build_v5_suite(suites)
    fp = _fingerprint()
    groups: dict[tuple, list] = {}
    for c in cases:
        groups.setdefault((c.system, c.load, c.excitation), []).append(c)
    cal_all = [c for c in cases if c.role == "cal"]
    if unit_fit:

        cal_all = cal_all + [o for c in cal_all
                             for o in own_cases(c, unit_fit, suites[c.system].nuisance)]
        plan = plan_units(suites, methods, work, groups, fp, unit_fit, false_alarm_per_run,
                          onset_method, cache_dir, budget, confidence)
    else:
        plan = _plan_fleet(suites, methods, work, groups, fp, false_alarm_per_run, onset_method,
                           cache_dir, budget, confidence)
    for sub in ("fits", "shards", "refs", "unit-shards"):  # leftovers of killed writers
        remove_stale_temps(work / sub)
    # the one skeleton of both modes: simulate, fit (or reference maxima), score, collect
    stages = [(simulate_case, [SimConfig(c, cache_dir) for c in cal_all],
               "simulate calibration runs"), (plan.fit, plan.fit_tasks, plan.fit_desc),
              (plan.score, plan.chunks, plan.score_desc)]
    walls, results = [], []
    for fn, cfgs, desc in stages:
        t0 = time.time()
        results.append(run_cases(fn, cfgs, scheduler=scheduler, n_workers=n_workers, desc=desc,
                                 progress=progress))
        walls.append(time.time() - t0)
    shards = [pd.read_parquet(c.path) for c in plan.chunks]
    rows = [x for x in shards if len(x)]  # none when every method failed to fit: said later
    runs = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    fits = pd.DataFrame([row for r in results[1] for row in r.result])
    settings = {"suite_version": V5_VERSION, "methods": list(methods),
                "false_alarm_per_run": false_alarm_per_run, "onset_method": onset_method,
                "threshold_confidence": confidence,
                "reduced_budget": {m: list(v) for m, v in budget.items() if m in methods},
                "virtual_machines": {s: simulator_has_machines(s) for s in suites},
                "code_fingerprint": fp, "leakdiag_version": __version__,
                "library_versions": library_versions(),  # a record: not part of the keys
                "wall_s": dict(zip(("simulate_calibration", "fit", "score"), walls)),
                "n_fit_tasks": plan.n_fit_tasks, "n_chunks": len(plan.chunks),
                "work": work_summary(work, results[0], fits, [r.result for r in results[2]],
                                     shards, "reference maxima" if unit_fit else "fits")}
    if unit_fit:
        settings["unit_fit"] = unit_fit
    return runs, fits, settings


def _scoring_cpu(df) -> float:
    """CPU seconds recorded in a shard: judging every row plus simulating every run once."""
    import pandas as pd

    if not len(df):
        return 0.0
    judge = pd.to_numeric(df["cpu_s"], errors="coerce").sum() if "cpu_s" in df else 0.0
    sim = (pd.to_numeric(df.drop_duplicates("seed")["sim_cpu_s"], errors="coerce").sum()
           if "sim_cpu_s" in df else 0.0)
    return float(judge + sim)


def work_summary(work, sims, fits, chunks, shards, fit_label: str = "fits") -> dict:
    """What a v5 run reused from its work folder and what it computed now.

    Parameters
    ----------
    work : pathlib.Path
        Work folder.
    sims : list of CaseResult
        Stage 1 (calibration simulations; ``cache_hit`` in each result).
    fits : pandas.DataFrame
        Stage 2 rows (``reused``, ``cpu_s``).
    chunks : list of dict
        Stage 3 results (``rows``, ``reused``).
    shards : list of pandas.DataFrame
        The shards, in the order of ``chunks``.
    fit_label : str, default "fits"
        Name of stage 2's results ("fits", or "reference maxima" in per-unit mode).

    Returns
    -------
    dict
        ``work_dir``; ``calibration_cached`` / ``calibration_simulated``;
        ``fit_label``, ``fits_reused`` / ``fits_computed`` and their recorded CPU seconds
        ``fit_cpu_s_reused`` / ``fit_cpu_s_computed``; ``shards_reused`` /
        ``shards_computed``, ``runs_reused`` / ``runs_computed`` (verdicts: rows of the
        shards), ``score_cpu_s_reused`` /
        ``score_cpu_s_computed``.
    """
    import pandas as pd

    hit = [bool(r.result.get("cache_hit")) for r in sims]
    reused = (fits["reused"].astype(bool) if "reused" in fits
              else pd.Series(False, index=fits.index))
    cpu = pd.to_numeric(fits["cpu_s"], errors="coerce") if "cpu_s" in fits else reused * 0.0
    out = {"work_dir": str(work), "calibration_cached": sum(hit),
           "calibration_simulated": len(hit) - sum(hit), "fit_label": fit_label,
           "fits_reused": int(reused.sum()), "fits_computed": int((~reused).sum()),
           "fit_cpu_s_reused": float(cpu[reused].sum()),
           "fit_cpu_s_computed": float(cpu[~reused].sum())}
    for tag, want in (("reused", True), ("computed", False)):
        sel = [(c, df) for c, df in zip(chunks, shards) if bool(c["reused"]) is want]
        out[f"shards_{tag}"] = len(sel)
        out[f"runs_{tag}"] = int(sum(c["rows"] for c, _ in sel))
        out[f"score_cpu_s_{tag}"] = float(sum(_scoring_cpu(df) for _, df in sel))
    return out


def work_lines(w: dict) -> list[str]:
    """The work of a v5 run in words: one line per stage (console and report).

    Parameters
    ----------
    w : dict
        :func:`work_summary`.

    Returns
    -------
    list of str
        Calibration runs, fits (or reference maxima) and result shards: "N reused from WORK
        (computed earlier), M computed now".

    Examples
    --------
    >>> w = {"work_dir": "/w", "calibration_cached": 20, "calibration_simulated": 0,
    ...      "fit_label": "fits", "fits_reused": 2, "fits_computed": 0, "fit_cpu_s_reused": 1.0,
    ...      "fit_cpu_s_computed": 0.0, "shards_reused": 2, "shards_computed": 1,
    ...      "runs_reused": 48, "runs_computed": 0, "score_cpu_s_reused": 3.0,
    ...      "score_cpu_s_computed": 0.0}
    >>> work_lines(w)[1]
    'fits: 2 reused from /w (computed earlier, 1 CPU s), 0 computed now'
    >>> work_lines(w)[2]
    'result shards: 2 reused from /w (computed earlier, 48 verdicts, 3 CPU s), 1 computed now \
(0 verdicts, 0 CPU s)'
    """
    d = w["work_dir"]

    def part(n, tag, what):  # "N reused from D (computed earlier, ...)" / "M computed now (...)"
        head = f"{n} reused from {d}" if tag == "reused" else f"{n} computed now"
        if not n:
            return head
        return f"{head} ({'computed earlier, ' if tag == 'reused' else ''}{what})"

    fit = {t: part(w[f"fits_{t}"], t, f"{w[f'fit_cpu_s_{t}']:.3g} CPU s")
           for t in ("reused", "computed")}
    score = {t: part(w[f"shards_{t}"], t, f"{w[f'runs_{t}']} verdicts, "
                     f"{w[f'score_cpu_s_{t}']:.3g} CPU s") for t in ("reused", "computed")}
    return [f"calibration runs: {w['calibration_cached']} read from the simulation cache, "
            f"{w['calibration_simulated']} simulated now",
            f"{w['fit_label']}: {fit['reused']}, {fit['computed']}",
            f"result shards: {score['reused']}, {score['computed']}"]


def _plan_fleet(suites, methods, work, groups, fp, far, onset_method, cache_dir, budget,
                confidence=None) -> Plan:
    """Fleet mode: each method fitted once per group on its training units."""

    fit_cfgs, chunk_cfgs = [], []
    for key, group in groups.items():
        s = suites[key[0]]
        alarm = v5_alarm(far, s.duration_s, onset_method, confidence)
        cal = [c for c in group if c.role == "cal"]
        fits, fit_keys = [], []
        for m in methods:
            caps = budget.get(m)
            mcal = tuple(cal[: caps[0]] if caps else cal)
            k = _key([V5_VERSION, fp, m, asdict(alarm), [c.seed for c in mcal],
                      [c.to_dict() for c in mcal[:1]], simulator_has_machines(key[0])])
            p = str(work / "fits" / f"{m}-{k}.joblib")
            fit_cfgs.append(FitConfig(m, mcal, alarm, cache_dir, p))
            fits.append((m, p, caps[1:] if caps else None))
            fit_keys.append(k)
        test = [c for c in group if c.role != "cal"]
        for i in range(0, len(test), s.chunk):
            chunk = tuple(test[i: i + s.chunk])
            # the fits' keys, not their paths: the work folder reached by another path
            # (relative, a symlink, moved) reuses its shards
            k = _key([V5_VERSION, fp, [c.seed for c in chunk], fit_keys,
                      [f[2] for f in fits], simulator_has_machines(key[0])])
            chunk_cfgs.append(ChunkConfig(chunk, tuple(fits), str(work / "shards" / f"{k}.parquet")))
    # methods using the base class's fit share one read of each calibration run per group;
    # the others (own fit, feature-level state) read the runs themselves
    shared: dict[tuple, list] = {}
    alone = []
    for cfg in fit_cfgs:
        c0 = cfg.cases[0]
        if shares_fit(make_detector(cfg.method, c0.system, cfg.alarm)):
            shared.setdefault((c0.system, c0.load, c0.excitation), []).append(cfg)
        else:
            alone.append(cfg)
    tasks = [("alone", c) for c in alone] + [("shared", tuple(v)) for v in shared.values()]
    return Plan(_fit_task, tasks, "fit", score_chunk, chunk_cfgs, "score held-out runs",
                len(fit_cfgs))
