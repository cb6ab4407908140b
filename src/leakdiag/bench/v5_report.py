"""``run_benchmark_v5``: benchmark v5 from suite to report (Markdown + CSV + figures)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from leakdiag.bench.outputs import (NothingJudgedError, earlier_outputs, prepare_folder,
                                    remove_stale_outputs)
from leakdiag.bench.registry import METHODS, thesis_methods
from leakdiag.bench.report import method_style
from leakdiag.bench.suite import EXCITATIONS
from leakdiag.bench.v5_run import run_v5, work_lines
from leakdiag.bench.v5_scoring import false_alarm_table, rate_text, size_table, summary_v5
from leakdiag.bench.v5_suite import (V5_DEFAULT_FAR, V5_QUICK_FAR, V5_QUICK_SUITES, V5_SUITES,
                                     restrict_sizes)
from leakdiag.runtime.cache import resolve_cache_dir

__all__ = ["run_benchmark_v5", "write_v5_report", "console_table", "nothing_judged_message",
           "failure_warnings"]


def run_benchmark_v5(out_dir, *, quick: bool = False, methods=None, systems=None,
                     excitations=None, loads=None, false_alarm_per_run: float | None = None,
                     n_cal: int | None = None, n_test_healthy: int | None = None,
                     n_test_leak: int | None = None, onset_method: str = "binseg",
                     scheduler: str = "serial", n_workers: int | None = None,
                     cache_dir: str | None = None, work_dir: str | None = None,
                     progress: bool = True, command: str = "leakdiag benchmark --suite v5",
                     unit_fit: int = 0, full_budget: bool = False,
                     confidence: float | None = None, first_index: int | None = None,
                     sizes=None):
    """Run benchmark v5 and write its report.

    Parameters
    ----------
    out_dir : path-like
        Report folder: ``report.md``, ``summary.csv``, ``false_alarms.csv``, ``detection.csv``,
        ``fits.csv``, ``runs.csv.gz``, ``settings.json``, ``figures/``.
    quick : bool, default False
        The small CI suite (:data:`~leakdiag.bench.v5_suite.V5_QUICK_SUITES`).
    methods : sequence of str, optional
        Registry names (default: every registered method; the quick suite: the thesis methods
        and the combined detector).
    systems, excitations, loads : sequence of str, optional
        Restrict the suite.
    false_alarm_per_run : float, optional
        Target per healthy run (default 1 %, quick 5 %).
    n_cal, n_test_healthy, n_test_leak : int, optional
        Mid-size variants: override the suite's run counts (same seeds for the runs kept).
    onset_method, scheduler, n_workers, cache_dir, progress
        As :func:`leakdiag.bench.benchmark.run_benchmark`.
    work_dir : str, optional
        Resumable state (fits, shards); default ``<cache>/bench-v5``.
    command : str
        Command line recorded in the report.
    unit_fit : int, default 0
        Per-unit mode with this many own healthy runs per unit (0: fleet mode).
    full_budget : bool, default False
        Run the expensive methods (EMD, EKF) on the suite's full run counts too, instead of
        :data:`~leakdiag.bench.v5_run.REDUCED_BUDGET`.
    confidence : float, optional
        Calibration-conditional thresholds: every fitted level holds the target with this
        probability over its healthy data (``Alarm.confidence``). None: the marginal rank.
    first_index : int, optional
        First held-out index of each role and size (``V5Suite.first_test_index``): a fresh
        block of seeds.
    sizes : sequence of float, optional
        Leak sizes (L/min) to run, each one of every selected rig's suite; their runs keep the
        whole suite's seeds (``V5Suite.size_indexes``).

    Returns
    -------
    dict
        ``summary``, ``detection``, ``false_alarms``, ``fits``, ``runs`` (DataFrames), ``paths``,
        ``settings`` (``settings["work"]``: what was reused from ``work_dir`` and what was
        computed now, :func:`~leakdiag.bench.v5_run.work_summary`), ``removed`` (files of an
        earlier run removed from ``out_dir``).

    Raises
    ------
    ValueError
        Unknown method, system, load, excitation or size; ``out_dir``, ``work_dir`` or the cache
        folder cannot be written (checked before any work).
    NothingJudgedError
        No held-out run was judged (every fit failed): the report of the fits is written, and
        the message names the first error and the option that changes it.

    Notes
    -----
    After the report is written, the files an earlier benchmark run wrote into ``out_dir`` and
    this one did not rewrite are removed (:func:`~leakdiag.bench.outputs.remove_stale_outputs`;
    other files stay).
    """

    base = V5_QUICK_SUITES if quick else V5_SUITES
    if methods is None:
        methods = [*thesis_methods(), "combined"] if quick else list(METHODS)
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"unknown method {m!r}; known: {sorted(METHODS)}")
    systems = list(systems or base)
    for s in systems:
        if s not in base:
            raise ValueError(f"unknown system {s!r}; the suite has {sorted(base)}")
    suites = {}
    for s in systems:
        v = base[s]
        if loads is not None:
            bad = [x for x in loads if x not in V5_SUITES[s].loads]
            if bad:
                raise ValueError(f"unknown load {bad[0]!r}; known: {list(V5_SUITES[s].loads)}")
            v = replace(v, loads=tuple(x for x in v.loads if x in loads) or tuple(loads))
        if sizes is not None:
            v = restrict_sizes(v, sizes)
        if excitations is not None:
            bad = [x for x in excitations if x not in EXCITATIONS]
            if bad:
                raise ValueError(f"unknown excitation {bad[0]!r}; known: {list(EXCITATIONS)}")
            v = replace(v, excitations=tuple(excitations))
        for name, val in (("n_cal", n_cal), ("n_test_healthy", n_test_healthy),
                          ("n_test_leak", n_test_leak), ("first_test_index", first_index)):
            if val is not None:
                v = replace(v, **{name: int(val)})
        suites[s] = v
    far = false_alarm_per_run if false_alarm_per_run is not None else (
        V5_QUICK_FAR if quick else V5_DEFAULT_FAR)
    work = Path(work_dir) if work_dir else resolve_cache_dir(cache_dir) / "bench-v5"
    # every folder written to is checked before any work
    out = prepare_folder(out_dir, "--out")
    prepare_folder(work, "--work-dir")
    prepare_folder(resolve_cache_dir(cache_dir),
                   "--cache-dir" if cache_dir else "simulation cache")
    before = earlier_outputs(out)
    t0 = time.time()
    runs, fits, settings = run_v5(suites, methods, work, false_alarm_per_run=far,
                                  onset_method=onset_method, scheduler=scheduler,
                                  n_workers=n_workers, cache_dir=cache_dir, progress=progress,
                                  unit_fit=int(unit_fit), full_budget=bool(full_budget),
                                  confidence=confidence)
    settings.update(command=command, quick=quick, wall_total_s=time.time() - t0,
                    suites={k: _jsonable(asdict(v)) for k, v in suites.items()},
                    scheduler=scheduler, n_workers=n_workers)
    judged = runs[runs.role != "error"] if len(runs) else runs
    if not len(judged):
        failure = nothing_judged_message(fits, runs, suites, settings, out / "fits.csv")
        write_v5_report(out, runs, fits, None, None, None, settings, failure=failure)
        remove_stale_outputs(out, before)  # its report lists fits.csv and settings.json only
        raise NothingJudgedError(failure)
    summary, det = summary_v5(runs)
    far_tab = false_alarm_table(runs)
    paths = write_v5_report(out, runs, fits, summary, det, far_tab, settings)
    removed = remove_stale_outputs(out, before)
    return {"summary": summary, "detection": det, "false_alarms": far_tab, "fits": fits,
            "runs": runs, "paths": paths, "settings": settings, "removed": removed}


def nothing_judged_message(fits, runs, suites, settings, fits_path) -> str:
    """Why no held-out run was judged: the first error and the option that changes it.

    Parameters
    ----------
    fits : pandas.DataFrame
        Fit (or reference-maxima) rows, ``error`` column.
    runs : pandas.DataFrame
        Per-run rows (error rows only, or empty).
    suites : dict
        Rig -> suite (run counts).
    settings : dict
        Settings of the run (target, confidence, per-unit mode, reduced budget).
    fits_path : pathlib.Path
        Where the fits table is written.

    Returns
    -------
    str
        One line: ``no held-out run was judged: ...; first: <method> on <rig> <load> <input>:
        <error>`` and, for too few healthy maxima, which of ``--n-cal``,
        ``--false-alarm-rate``, ``--confidence`` or ``--full-budget`` would give enough.
    """
    errs = fits[fits["error"].notna()] if "error" in fits else fits.iloc[0:0]
    label = settings.get("work", {}).get("fit_label", "fits")
    if len(errs):
        where = f"{len(errs)} of {len(fits)} {label} failed (listed in {fits_path})"
        row = errs.iloc[0]
    elif len(runs):
        where = (f"every method failed on all {len(runs)} held-out runs (listed in "
                 f"{fits_path.parent / 'runs.csv.gz'})")
        row = runs.iloc[0]
    else:
        return "no held-out run was judged and no method reported an error"
    first = str(row["error"])
    msg = (f"no held-out run was judged: {where}; first: {row['method']} on {row['system']} "
           f"{row['load']} {row['excitation']}: {first}")
    return msg + _hint(first, row, suites, settings)


def _hint(error: str, row, suites, settings) -> str:
    """The options that would give a threshold enough healthy maxima (or "")."""
    import re

    got = re.search(r"needs at least (\d+) maxima", error)
    if not got:
        return ""
    need, n_cal = int(got.group(1)), suites[row["system"]].n_cal
    own = int(settings.get("unit_fit") or 0)
    cap = (settings.get("reduced_budget") or {}).get(row["method"])
    basis = (f"{n_cal} training units' reference maxima and {own} own runs per unit" if own
             else f"{min(n_cal, cap[0]) if cap else n_cal} calibration runs per group")
    opts = [f"--n-cal {max(need - own, 1)} or more"]
    if cap and cap[0] < need - own:
        opts = [f"--full-budget with --n-cal {max(need - own, 1)} or more ({row['method']} "
                f"is fitted on at most {cap[0]} calibration runs without it)"]
    opts.append(f"a larger --false-alarm-rate (now {settings['false_alarm_per_run']:g})")
    conf = settings.get("threshold_confidence")
    if conf is not None:
        opts.append(f"a lower --confidence (now {conf:g})")
    return f". The thresholds rest on {basis}: give {', '.join(opts[:-1])}, or {opts[-1]}"


def failure_warnings(fits, runs, out) -> list[str]:
    """What failed in a run that judged some held-out runs: fits and verdicts that are errors.

    Parameters
    ----------
    fits, runs : pandas.DataFrame
        Fit (or reference-maxima) rows and per-run rows of the run.
    out : pathlib.Path
        Report folder (where ``fits.csv`` and ``runs.csv.gz`` are).

    Returns
    -------
    list of str
        Up to two lines (none when nothing failed): ``"N of M fits failed (listed in ...);
        first: ..."`` and ``"N of M verdicts are errors (listed in ...); first: ..."``.
    """
    lines = []
    for df, what, name in ((fits, "fits", "fits.csv"), (runs, "verdicts", "runs.csv.gz")):
        if "error" not in df or not len(df):
            continue
        bad = df[df["error"].notna()]
        if len(bad):
            r = bad.iloc[0]
            lines.append(f"{len(bad)} of {len(df)} {what} failed (listed in {out / name}); "
                         f"first: {r['method']} on {r['system']} {r['load']} "
                         f"{r['excitation']}: {r['error']}")
    return lines


def console_table(summary, det) -> str:
    """The summary for the console: every rate with its count, n and 95 % interval.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`~leakdiag.bench.v5_scoring.summary_v5`.
    det : pandas.DataFrame
        :func:`~leakdiag.bench.v5_scoring.detection_table` (counts at the minimum detectable
        leak).

    Returns
    -------
    str
        One row per method, rig, load and input; ``--`` where a value is undefined (no
        minimum detectable leak, no onset error).
    """
    import pandas as pd

    rows = []
    for _, r in summary.iterrows():
        mdl = r["min_detectable_lpm_10s"]
        at = det[(det.method == r.method) & (det.system == r.system) & (det.load == r.load)
                 & (det.excitation == r.excitation) & (det.leak_lpm == mdl)]
        rows.append({"method": r.method, "rig": r.system, "load": r.load, "input": r.excitation,
                     "false alarms [95 % CI]": rate_text(r.false_alarms, r.n_healthy),
                     "MDL 10 s (L/min)": _fmt(mdl),
                     "detected at MDL [95 % CI]": (rate_text(at.iloc[0]["detected_10s"],
                                                            at.iloc[0]["n_leak"])
                                                  if len(at) else "--"),
                     "onset error median (s)": _fmt(r.onset_error_median_s),
                     "goal met": _fmt(bool(r.goal_met))})
    return pd.DataFrame(rows).to_string(index=False)


def _threshold_words(confidence) -> str:
    if confidence is None:
        return "conformal threshold: the bound holds on average over calibrations"
    return (f"calibration-conditional conformal threshold: each fitted level holds the target "
            f"with probability {100 * confidence:g} % over its healthy data")


def _jsonable(d):
    return json.loads(json.dumps(d, default=lambda o: list(o) if isinstance(o, tuple) else str(o)))


def _fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "--"
    if isinstance(x, (bool, np.bool_)):
        return "yes" if x else "no"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    return f"{float(x):.{digits}g}"


def _md_table(df, cols, headers) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for _, r in df.iterrows():
        lines.append("| " + " | ".join(_fmt(r[c]) if not isinstance(r[c], str) else r[c]
                                       for c in cols) + " |")
    return "\n".join(lines)


def _figures(det, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    names = []
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for (system, load, exc), g in det.groupby(["system", "load", "excitation"], sort=False):
        fig, ax = plt.subplots(figsize=(7.0, 4.2))
        for j, (m, gm) in enumerate(g.groupby("method", sort=False)):
            gm = gm.sort_values("leak_lpm")
            y = gm["detection_rate_10s"].to_numpy()
            err = np.vstack([y - gm["det_low_10s"].to_numpy(), gm["det_high_10s"].to_numpy() - y])
            ax.errorbar(gm.leak_lpm, y, yerr=err, ms=3, capsize=2, label=m, **method_style(j))
        ax.axhline(0.9, color="0.5", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_xlabel("leak (L/min)")
        ax.set_ylabel("detected within 10 s of the onset")
        ax.set_ylim(-0.03, 1.03)
        ax.set_title(f"{system.upper()}, load {load}, {exc} input (95 % Clopper-Pearson bars)")
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        name = f"figures/detection_{system}_{load}_{exc}.png"
        fig.savefig(out / name, dpi=110)
        plt.close(fig)
        names.append(name)
    return names


def write_v5_report(out: Path, runs, fits, summary, det, far_tab, settings,
                    failure: str | None = None) -> dict:
    """Write the v5 report files (see :func:`run_benchmark_v5`).

    Parameters
    ----------
    out : pathlib.Path
        Report folder.
    runs, fits, summary, det, far_tab : pandas.DataFrame or None
        Tables of :func:`run_benchmark_v5`.
    settings : dict
        Settings (command, timing, work reused and computed, suites).
    failure : str, optional
        Why no held-out run was judged (:func:`nothing_judged_message`): said first.

    Returns
    -------
    dict
        Name -> written path; ``report.md`` lists exactly these files.
    """
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, df in (("summary", summary), ("detection", det), ("false_alarms", far_tab),
                     ("fits", fits)):
        if df is not None:
            paths[name] = out / f"{name}.csv"
            df.to_csv(paths[name], index=False)
    sizes = size_table(runs) if runs is not None and len(runs) else None
    if sizes is not None and len(sizes):
        paths["size"] = out / "size.csv"
        sizes.to_csv(paths["size"], index=False)
    if runs is not None and len(runs):
        paths["runs"] = out / "runs.csv.gz"
        runs.to_csv(paths["runs"], index=False)
    paths["settings"] = out / "settings.json"
    paths["settings"].write_text(json.dumps(settings, indent=2, sort_keys=True, default=str),
                                 encoding="utf-8")
    figs = _figures(det, out) if det is not None and len(det) else []
    w = settings.get("wall_s", {})
    md = [f"# Benchmark v5 (suite {settings['suite_version']})", "",
          f"Command: `{settings['command']}`", ""]
    if failure is not None:
        md += ["## No held-out run was judged", "", failure + ".", ""]
    if settings.get("work"):
        md += [f"Work (resumable state in `{settings['work']['work_dir']}`):", "",
               *[f"* {line}" for line in work_lines(settings["work"])], ""]
    md += [f"Wall time of this run: {settings['wall_total_s']:.0f} s (simulate calibration "
           f"runs {w.get('simulate_calibration', 0):.0f} s, fit {w.get('fit', 0):.0f} s, score "
           f"{w.get('score', 0):.0f} s; scheduler {settings['scheduler']}, workers "
           f"{settings['n_workers']}); work reused from an earlier run is not in it (its CPU "
           "time, recorded when it was computed, is listed above). Target: "
           f"{100 * settings['false_alarm_per_run']:g} % false alarms per healthy run "
           f"({_threshold_words(settings.get('threshold_confidence'))}, one segment per run).",
           "",
          f"Virtual machines in the simulator: {settings['virtual_machines']} (False: machine "
          "ids recorded, the nominal unit simulated). Reduced budget (calibration, healthy, "
          f"leaking per size): {settings['reduced_budget'] or 'none'}.", ""]
    if "library_versions" in settings:
        libs = ", ".join(f"{k} {v}" for k, v in sorted(settings["library_versions"].items()))
        md += [f"Code: fingerprint `{settings['code_fingerprint']}` (part of every fit, "
               f"reference and shard key), leakdiag {settings['leakdiag_version']}; libraries "
               f"{libs} (recorded, not part of the keys).", ""]
    if summary is not None:
        md += ["## Summary (per rig, load, excitation; loads never pooled)", "",
               "MDL: minimum detectable leak (L/min), >= 90 % detected within the deadline at "
               "that size and every larger one; `--` not reached. FA: false alarms per held-out "
               "healthy run with its 95 % Clopper-Pearson interval.", "",
               _md_table(summary, ["system", "load", "excitation", "method", "n_healthy",
                                   "false_alarm_rate", "far_low", "far_high",
                                   "min_detectable_lpm_5s", "min_detectable_lpm_10s",
                                   "mdl_det_low_10s", "min_detectable_lpm_30s",
                                   "onset_error_median_s", "goal_met"],
                         ["rig", "load", "input", "method", "n healthy", "FA", "FA low",
                          "FA high", "MDL 5 s", "MDL 10 s", "rate low at MDL 10 s",
                          "MDL 30 s", "onset error median (s)", "goal met"]), ""]
    if settings.get("unit_fit"):
        md += [f"Per-unit mode: every unit fitted on {settings['unit_fit']} own healthy runs, "
               "threshold from the reference maxima of the training units (table below: "
               "reference maxima per method and group).", ""]
        if runs is not None and "threshold_method" in runs:
            # the basis each held-out run was judged on (a fallback to a model level shows)
            basis = (runs[runs["role"] != "error"]
                     .groupby(["system", "load", "method", "threshold_method", "threshold_k",
                               "threshold_n"], dropna=False).size().reset_index(name="runs"))
            md += ["Threshold basis of the held-out runs (k-th largest of n; k = 0: no "
                   "conformal level, the method's model level):", "",
                   _md_table(basis, list(basis.columns), list(basis.columns)), ""]
    if sizes is not None and (sizes.n_sized > 0).any():
        md += ["## Leak size (runs detected within 10 s of the onset)", "",
               "Estimate / truth (the run's achieved mean leak flow after the onset) and how "
               "often the method's interval held the truth, with its 95 % Clopper-Pearson "
               "interval.", "",
               _md_table(sizes[sizes.n_sized > 0],
                         ["system", "load", "method", "leak_lpm", "n_sized", "ratio_median",
                          "ratio_p10", "ratio_p90", "covered", "coverage", "coverage_low",
                          "coverage_high"],
                         ["rig", "load", "method", "leak (L/min)", "runs", "ratio median",
                          "ratio p10", "ratio p90", "held", "coverage", "low", "high"]), ""]
    if fits is not None and len(fits):
        cols = [c for c in ("system", "load", "method", "n", "k", "threshold",
                            "bound_per_segment", "conditional_upper_95", "n_reference",
                            "n_units", "error") if c in fits]
        md += ["## Thresholds (conformal basis per method and group)", "",
               _md_table(fits, cols, cols), ""]
    md += [f"![{f}]({f})" for f in figs]
    described = {"detection": "detection.csv (per size: detection within 5/10/30 s, early "
                              "alarms, each with its interval)",
                 "size": "size.csv (leak-size estimates and interval coverage)"}
    files = [described.get(k, p.name) for k, p in paths.items()]
    md += ["", f"Files: {', '.join(files)}."]
    paths["report"] = out / "report.md"
    paths["report"].write_text("\n".join(md) + "\n", encoding="utf-8")
    return paths
