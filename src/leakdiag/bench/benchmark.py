"""``run_benchmark``: the whole benchmark from suite to report files."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import leakdiag.sim as sim
from leakdiag.bench.registry import DEFAULT_METHODS, METHODS
from leakdiag.bench.report import build_report
from leakdiag.bench.run import run_suite
from leakdiag.bench.scoring import minimum_detectable, summarise
from leakdiag.bench.suite import EXCITATIONS, QUICK_SUITES, SUITES
from leakdiag.detect.base import Alarm

__all__ = ["run_benchmark", "BenchmarkResult"]


@dataclass
class BenchmarkResult:
    """Tables and files of one benchmark run.

    Attributes
    ----------
    results : pandas.DataFrame
        ``results.csv``: one row per method, rig and leak size.
    summary : pandas.DataFrame
        ``summary.csv``: minimum detectable leak per method and rig.
    by_condition : pandas.DataFrame
        ``results_by_condition.csv``: as ``results`` per load and noise level.
    runs : pandas.DataFrame
        ``runs.csv``: one row per method and held-out run.
    paths : dict
        Name -> written file.
    """

    results: Any
    summary: Any
    by_condition: Any
    runs: Any
    paths: dict


def _by_condition(runs, rated):
    import pandas as pd


    parts = []
    ok = runs[runs.role.isin(["test_healthy", "test_leak"])]
    for (load, noise), g in ok.groupby(["load", "noise_level"], sort=False):
        r = summarise(g, rated)
        r.insert(2, "load", load)
        r.insert(3, "noise_level", noise)
        parts.append(r)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


def _summary_by_condition(by_cond, rated, target):
    import pandas as pd


    parts = []
    for (load, noise), g in by_cond.groupby(["load", "noise_level"], sort=False):
        r = minimum_detectable(g, rated, target)
        r.insert(2, "load", load)
        r.insert(3, "noise_level", noise)
        parts.append(r)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


def run_benchmark(out_dir, *, quick: bool = False, methods=None, systems=None,
                  excitations=None, max_test_runs: int | None = None,
                  false_alarm_per_run: float = 0.01, onset_method: str = "binseg",
                  scheduler: str = "serial", n_workers: int | None = None,
                  cache_dir: str | None = None, progress: bool = True,
                  command: str = "leakdiag benchmark") -> BenchmarkResult:
    """Run the benchmark and write its report.

    Parameters
    ----------
    out_dir : path-like
        Output folder: ``index.html``, ``report.md`` (+ figures), ``results.csv``,
        ``summary.csv``, ``results_by_condition.csv``, ``runs.csv``, ``simulations.csv``,
        ``settings.json``.
    quick : bool, default False
        Use :data:`~leakdiag.bench.suite.QUICK_SUITES` (CI) instead of the full suite.
    methods : sequence of str, optional
        Registry names (default :data:`~leakdiag.bench.registry.DEFAULT_METHODS`).
    systems : sequence of str, optional
        Rigs (default: every rig of the suite whose simulator is available).
    excitations : sequence of str, optional
        Restrict every rig's excitation conditions (default: all of the suite's); the seeds of
        the selected runs do not change.
    max_test_runs : int, optional
        Reduced suite: at most this many held-out healthy runs and leaking runs per size in
        every group (the first ones of the full suite, same seeds); fitting and calibration
        runs are unchanged. Default: the full suite.
    false_alarm_per_run : float, default 0.01
        Target false-alarm probability per healthy run.
    onset_method : {"binseg", "pelt", "cusum"}, default "binseg"
        Onset estimator.
    scheduler : str, default "serial"
        ``"serial"``, ``"local"`` (Dask LocalCluster) or a scheduler address.
    n_workers : int, optional
        Dask workers.
    cache_dir : str, optional
        Simulation cache folder.
    progress : bool, default True
        Progress bars.
    command : str
        Command line recorded in the report.

    Returns
    -------
    BenchmarkResult

    Raises
    ------
    ValueError
        Unknown method or system.
    """
    methods = list(methods or DEFAULT_METHODS)
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"unknown method {m!r}; known: {sorted(METHODS)}")
    base = QUICK_SUITES if quick else SUITES
    if systems is None:
        systems = [s for s in base if hasattr(sim, f"simulate_{s}")]
    for s in systems:
        if s not in base:
            raise ValueError(f"unknown system {s!r}; the suite has {sorted(base)}")
    suites = {s: base[s] for s in systems}
    if excitations is not None:
        for e in excitations:
            if e not in EXCITATIONS:
                raise ValueError(f"unknown excitation {e!r}; known: {list(EXCITATIONS)}")
        suites = {k: replace(v, excitations=tuple(e for e in v.excitations if e in excitations))
                  for k, v in suites.items()}
    if max_test_runs is not None:
        if int(max_test_runs) < 1:
            raise ValueError(f"max_test_runs={max_test_runs!r} must be >= 1")
        m = int(max_test_runs)
        suites = {k: replace(v, n_test_healthy=min(v.n_test_healthy, m),
                              n_test_leak=min(v.n_test_leak, m)) for k, v in suites.items()}
    alarm = Alarm(onset_method=onset_method)
    sr = run_suite(suites, methods, false_alarm_per_run=false_alarm_per_run, alarm=alarm,
                   scheduler=scheduler, n_workers=n_workers, cache_dir=cache_dir,
                   progress=progress)
    if len(sr.runs) == 0 or (sr.runs.role == "error").all():
        first = sr.runs.error.iloc[0] if len(sr.runs) else "no runs"
        raise ValueError(f"no method could be fitted on any group; first reason: {first}")
    results = summarise(sr.runs[sr.runs.role != "error"], sr.rated_flow_lpm)
    summary = minimum_detectable(results, sr.rated_flow_lpm, false_alarm_per_run)
    by_cond = _by_condition(sr.runs, sr.rated_flow_lpm)
    summary_cond = _summary_by_condition(by_cond, sr.rated_flow_lpm, false_alarm_per_run)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = build_report(sr, results, summary, by_cond, command, summary_cond).write(out)
    for name, df in (("results", results), ("summary", summary),
                     ("summary_by_condition", summary_cond),
                     ("results_by_condition", by_cond), ("runs", sr.runs),
                     ("simulations", sr.simulations)):
        paths[name] = out / f"{name}.csv"
        df.to_csv(paths[name], index=False)
    settings = {**sr.settings, "alarm": asdict(sr.settings["alarm"]), "quick": quick,
                "max_test_runs": max_test_runs,
                "command": command, "suites": {k: _jsonable(asdict(v)) for k, v in suites.items()},
                "rated_flow_lpm": sr.rated_flow_lpm}
    paths["settings"] = out / "settings.json"
    paths["settings"].write_text(json.dumps(settings, indent=2, sort_keys=True), encoding="utf-8")
    return BenchmarkResult(results, summary, by_cond, sr.runs, paths)


def _jsonable(d):
    return json.loads(json.dumps(d, default=lambda o: list(o) if isinstance(o, tuple) else str(o)))
