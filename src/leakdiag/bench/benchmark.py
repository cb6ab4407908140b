"""``run_benchmark``: the whole benchmark from suite to report files."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import leakdiag.sim as sim
from leakdiag.bench.outputs import (NothingJudgedError, earlier_outputs, prepare_folder,
                                    remove_stale_outputs)
from leakdiag.bench.registry import DEFAULT_METHODS, METHODS, make_detector
from leakdiag.bench.report import build_report
from leakdiag.bench.run import per_run_target_per_hour, run_suite
from leakdiag.bench.scoring import minimum_detectable, summarise
from leakdiag.bench.suite import EXCITATIONS, QUICK_FAR, QUICK_SUITES, SUITES
from leakdiag.detect.base import Alarm
from leakdiag.runtime.cache import resolve_cache_dir

__all__ = ["run_benchmark", "BenchmarkResult", "console_table_v4", "check_target_supported",
           "unsupported_target"]


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
    removed : list of str
        Files of an earlier benchmark run removed from the output folder (not rewritten).
    """

    results: Any
    summary: Any
    by_condition: Any
    runs: Any
    paths: dict
    removed: list = field(default_factory=list)


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
                  false_alarm_per_run: float | None = None, onset_method: str = "binseg",
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
    false_alarm_per_run : float, optional
        Target false-alarm probability per healthy run (default 0.01; ``quick``:
        :data:`~leakdiag.bench.suite.QUICK_FAR`, what its 8 fitting runs per group support).
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
        Unknown method, system or excitation; a target the suite's fitting runs cannot support
        (:func:`check_target_supported`); an output or cache folder that cannot be written.
        All checked before any work.
    NothingJudgedError
        No method could be fitted on any group (the first reason, with the option to change).

    Notes
    -----
    After the report is written, the files an earlier benchmark run wrote into ``out_dir`` and
    this one did not rewrite are removed (:func:`~leakdiag.bench.outputs.remove_stale_outputs`;
    other files stay; a run that fails leaves the earlier report whole).
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
    if false_alarm_per_run is None:
        false_alarm_per_run = QUICK_FAR if quick else 0.01
    alarm = Alarm(onset_method=onset_method)
    check_target_supported(suites, methods, false_alarm_per_run, alarm.burn_in_s)
    out = prepare_folder(out_dir, "--out")
    prepare_folder(resolve_cache_dir(cache_dir),
                   "--cache-dir" if cache_dir else "simulation cache")
    before = earlier_outputs(out)
    sr = run_suite(suites, methods, false_alarm_per_run=false_alarm_per_run, alarm=alarm,
                   scheduler=scheduler, n_workers=n_workers, cache_dir=cache_dir,
                   progress=progress)
    if len(sr.runs) == 0 or (sr.runs.role == "error").all():
        if not len(sr.runs):
            raise NothingJudgedError("no method could be fitted on any group: no runs")
        r = sr.runs.iloc[0]
        s = suites[r.system]
        low, give = _smallest_target(s, alarm.burn_in_s)
        hint = (f". Suite v4 fits each threshold on {s.n_fit} healthy fitting runs per group, "
                f"which support a false-alarm target of at least {low:.3g} per run: give "
                f"--false-alarm-rate {give:.2f} or more" if "maxima" in str(r.error) else "")
        raise NothingJudgedError(
            f"no method could be fitted on any group; first reason: {r.method} on {r.system} "
            f"{r.load} {r.noise_level} {r.excitation}: {r.error}{hint}")
    results = summarise(sr.runs[sr.runs.role != "error"], sr.rated_flow_lpm)
    summary = minimum_detectable(results, sr.rated_flow_lpm, false_alarm_per_run)
    by_cond = _by_condition(sr.runs, sr.rated_flow_lpm)
    summary_cond = _summary_by_condition(by_cond, sr.rated_flow_lpm, false_alarm_per_run)
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
    removed = remove_stale_outputs(out, before)
    return BenchmarkResult(results, summary, by_cond, sr.runs, paths, removed)


def check_target_supported(suites, methods, per_run: float, burn_in_s: float = 5.0) -> None:
    """Refuse, before any simulation, a target the suite's fitting runs cannot support.

    A method with the detectors' common fit (``Detector.fit``) sets its threshold from one
    CUSUM maximum per healthy fitting run (the segment is the run's monitored span), so a
    group's ``n_fit`` runs support a per-run target ``p`` only if ``n_fit >=
    min_maxima(-log(1 - p))``; so does a method whose features have their own fit (combined,
    EKF). Methods with their own ``fit`` (flow balance) are not checked here; when none of them
    can be fitted either, the run ends with
    :class:`~leakdiag.bench.outputs.NothingJudgedError`.

    Parameters
    ----------
    suites : dict
        Rig -> :class:`~leakdiag.bench.suite.SystemSuite`.
    methods : sequence of str
        Registry names.
    per_run : float
        Target false-alarm probability per healthy run.
    burn_in_s : float, default 5.0
        Leading seconds of a run not monitored.

    Raises
    ------
    ValueError
        Naming the fitting runs, the smallest target they support and the
        ``--false-alarm-rate`` to give.

    Examples
    --------
    >>> check_target_supported(QUICK_SUITES, ["acf-p1"], 0.12)
    >>> check_target_supported(QUICK_SUITES, ["acf-p1"], 0.05)
    Traceback (most recent call last):
    ...
    ValueError: suite v4 fits each threshold on 8 healthy fitting runs per group (vca), one \
maximum each: they support a false-alarm target of at least 0.111 per run, and \
--false-alarm-rate 0.05 needs 19 such runs; give --false-alarm-rate 0.12 or more
    """
    for name, s in suites.items():
        short = unsupported_target(name, s, methods, per_run, burn_in_s)
        if short is None:
            continue
        _, need, low, give = short
        raise ValueError(f"suite v4 fits each threshold on {s.n_fit} healthy fitting runs per "
                         f"group ({name}), one maximum each: they support a false-alarm target "
                         f"of at least {low:.3g} per run, and --false-alarm-rate {per_run:g} "
                         f"needs {need} such runs; give --false-alarm-rate {give:.2f} or more")


def unsupported_target(system: str, s, methods, per_run: float, burn_in_s: float = 5.0):
    """Whether one suite's fitting runs fall short of a per-run target for the methods whose
    threshold is one CUSUM maximum per fitting run (``Detector.fit``; whatever their features'
    own fit: the EKF learns its noise and hold limits in ``_fit_features``).

    Parameters
    ----------
    system : str
        The suite's rig (``"vca"``, ``"eha"``).
    s : SystemSuite
        The suite.
    methods : sequence of str
        Registry names.
    per_run : float
        Target false-alarm probability per healthy run.
    burn_in_s : float, default 5.0
        Leading seconds of a run not monitored.

    Returns
    -------
    tuple or None
        None when the runs suffice (or no method takes the common threshold); else
        ``(method, runs_needed, smallest_supported_target, that_target_rounded_up_to_0.01)``.
    """
    from leakdiag.detect.base import Detector
    from leakdiag.detect.threshold import min_maxima

    common = [m for m in methods if type(make_detector(m, system, Alarm())).fit is Detector.fit]
    need = min_maxima(_segment_target(per_run, s, burn_in_s))
    if not common or s.n_fit >= need:
        return None
    return (common[0], need, *_smallest_target(s, burn_in_s))


def _segment_target(per_run: float, s, burn_in_s: float) -> float:
    """The fit's target per segment for a per-run target (one segment per run)."""
    seg = s.duration_s - burn_in_s
    return per_run_target_per_hour(per_run, s.duration_s, burn_in_s) * seg / 3600.0


def _smallest_target(s, burn_in_s: float) -> tuple[float, float]:
    """The smallest per-run target ``n_fit`` maxima support, and it rounded up to 0.01."""
    from leakdiag.detect.threshold import min_maxima

    low = 1.0 / (s.n_fit + 1)  # target per segment (one segment per run) 1 / (n + 1)
    give = math.ceil(100 * low) / 100
    while min_maxima(_segment_target(give, s, burn_in_s)) > s.n_fit:
        give += 0.01
    return low, give


def console_table_v4(summary, results=None) -> str:
    """The v4 summary for the console: false alarms and detections with n and 95 % intervals.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`~leakdiag.bench.scoring.minimum_detectable` of the run.
    results : pandas.DataFrame, optional
        :func:`~leakdiag.bench.scoring.summarise` of the run (``results.csv``): gives the
        detections at the minimum detectable leak (count of ``n_runs``, 95 % interval).

    Returns
    -------
    str
        The false-alarm target per run (when the summary has it), then one row per method, rig
        and input; ``--`` where a value is undefined (minimum detectable leak not reached).
    """
    import pandas as pd

    from leakdiag.bench.v5_scoring import rate_text

    def num(x):
        return "--" if x is None or not math.isfinite(float(x)) else f"{float(x):.3g}"

    def at_mdl(r):
        if results is None or not math.isfinite(float(r.min_detectable_lpm)):
            return "--"
        g = results[(results.method == r.method) & (results.system == r.system)
                     & (results.leak_lpm == r.min_detectable_lpm)]
        if "excitation" in g and "excitation" in r:
            g = g[g.excitation == r.excitation]
        if len(g) != 1:
            return "--"
        n = int(g.n_runs.iloc[0])
        return rate_text(int(round(float(g.detection_rate.iloc[0]) * n)), n)

    rows = [{"method": r.method, "rig": r.system, "input": r.excitation,
             "false alarms [95 % CI]": rate_text(r.false_alarms, r.n_test_healthy),
             "MDL (L/min)": num(r.min_detectable_lpm),
             "MDL (% rated)": num(r.min_detectable_pct_rated),
             **({"detected at MDL [95 % CI]": at_mdl(r)} if results is not None else {}),
             "CPU s per hour": num(r.cpu_s_per_hour)} for _, r in summary.iterrows()]
    table = pd.DataFrame(rows).to_string(index=False)
    if "false_alarm_target" in summary and len(summary):
        target = float(summary.false_alarm_target.iloc[0])
        table = f"false-alarm target: {target:.3g} per run\n" + table
    return table


def _jsonable(d):
    return json.loads(json.dumps(d, default=lambda o: list(o) if isinstance(o, tuple) else str(o)))
