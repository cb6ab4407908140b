"""The benchmark's report: tables and figures (ROC curves, detection rate against leak size,
onset error) in a self-contained HTML page (:class:`leakdiag.report.html.Report`)."""

from __future__ import annotations

import numpy as np

from leakdiag._version import __version__
from leakdiag.bench.scoring import roc_curve
from leakdiag.report.html import Report

__all__ = ["build_report", "method_style", "not_reached"]


#: Markers cycled beside the colours, so that methods stay distinct beyond ten (issue 15).
_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "<", ">", "*", "h", "p")


def method_style(i: int) -> dict:
    """Colour and marker of the ``i``-th method in a figure: distinct for up to 240 methods.

    Colours come from matplotlib's 20-colour ``tab20`` map (``i mod 20``), markers from a
    12-marker cycle at ``(i mod 20 + i div 20) mod 12``: for one colour the marker takes 12
    different values over the next 12 colour cycles, so the first 240 pairs are all different.

    Parameters
    ----------
    i : int
        Index of the method (0-based), >= 0.

    Returns
    -------
    dict
        ``color`` (RGBA tuple) and ``marker`` (matplotlib marker), for ``ax.plot(**style)``.

    Raises
    ------
    ValueError
        If ``i`` is negative.

    Examples
    --------
    >>> a, b = method_style(0), method_style(10)
    >>> a["color"] != b["color"] and a["marker"] != b["marker"]
    True
    >>> len({(method_style(i)["color"], method_style(i)["marker"]) for i in range(240)})
    240
    """
    from matplotlib import colormaps

    if i < 0:
        raise ValueError(f"i={i!r} must be >= 0")
    color = tuple(colormaps["tab20"](i % 20))
    marker = _MARKERS[(i % 20 + i // 20) % len(_MARKERS)]
    return {"color": color, "marker": marker}


def not_reached(summary, columns=("min_detectable_lpm", "min_detectable_pct_rated")):
    """A display copy of a minimum-detectable-leak table with NaN written as ``not reached``.

    Parameters
    ----------
    summary : pandas.DataFrame
        Table with minimum-detectable-leak columns (NaN where no size was detected).
    columns : tuple of str
        Columns to rewrite (those absent are ignored).

    Returns
    -------
    pandas.DataFrame
        Copy with those columns as objects: the number, or the text ``not reached``.

    Examples
    --------
    >>> import pandas as pd
    >>> not_reached(pd.DataFrame({"min_detectable_lpm": [0.2, float("nan")]})).iloc[1, 0]
    'not reached'
    """
    out = summary.copy()
    for c in columns:
        if c in out:
            col = out[c].astype(object)
            out[c] = col.where(col.notna(), "not reached")
    return out


def _roc_figure(runs, system):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    sub = runs[runs.system == system]
    methods = list(dict.fromkeys(sub.method))
    ncol = min(3, len(methods))
    nrow = int(np.ceil(len(methods) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.4 * nrow), squeeze=False)
    for ax, m in zip(axes.flat, methods):
        g = sub[sub.method == m]
        null = g[g.role == "test_healthy"].score_max
        for q, lk in g[g.role == "test_leak"].groupby("leak_lpm"):
            fpr, tpr = roc_curve(null, lk.score_max)
            ax.step(fpr, tpr, where="post", label=f"{q:g} L/min")
        ax.plot([0, 1], [0, 1], color="0.7", lw=0.8, ls="--")
        ax.set_title(m)
        ax.set_xlabel("false-alarm rate (per run)")
        ax.set_ylabel("detection rate")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="lower right")
    for ax in list(axes.flat)[len(methods):]:
        ax.axis("off")
    fig.tight_layout()
    return fig


def _rate_figure(results, system, rated, target=0.01):
    import matplotlib.pyplot as plt

    sub = results[results.system == system]
    fig, ax = plt.subplots(figsize=(6.5, 4.0))
    for i, (m, g) in enumerate(sub.groupby("method", sort=False)):
        ax.plot(g.leak_lpm, g.detection_rate, label=m, **method_style(i))
    ax.axhline(0.9, color="0.5", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("leak (L/min)")
    ax.set_ylabel(f"detection rate at the {100 * target:g} % per-run false-alarm threshold")
    ax.set_ylim(-0.03, 1.03)
    if system in rated:
        sec = ax.secondary_xaxis("top", functions=(lambda q: 100 * q / rated[system],
                                                    lambda p: p * rated[system] / 100))
        sec.set_xlabel("% of rated flow")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    ax.set_title(system.upper())
    fig.tight_layout()
    return fig


def _onset_figure(runs, system):
    import matplotlib.pyplot as plt
    import pandas as pd

    sub = runs[(runs.system == system) & (runs.role == "test_leak")].copy()
    on = pd.to_numeric(sub.onset_true_s, errors="coerce")
    sub["err"] = (pd.to_numeric(sub.onset_est_s, errors="coerce") - on)
    ok = sub.alarm.astype(bool) & (pd.to_numeric(sub.alarm_time_s, errors="coerce") >= on)
    sub = sub[ok]
    methods = list(dict.fromkeys(runs[runs.system == system].method))
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    data = [sub[sub.method == m].err.to_numpy() for m in methods]
    ax.boxplot([d if len(d) else [np.nan] for d in data], showfliers=True)
    ax.set_xticks(range(1, len(methods) + 1), methods, rotation=30, ha="right")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_ylabel("onset estimate - true onset (s)")
    ax.set_title(f"{system.upper()}: onset error of detected runs")
    fig.tight_layout()
    return fig


def build_report(suite_run, results, summary, by_condition, command: str,
                 summary_by_condition=None):
    """Assemble the benchmark report.

    Parameters
    ----------
    suite_run : SuiteRun
        Output of :func:`leakdiag.bench.run.run_suite`.
    results, summary, by_condition : pandas.DataFrame
        Results per leak size, minimum detectable leak, and results per load and noise level.
    command : str
        The command line that made the report (printed in it).
    summary_by_condition : pandas.DataFrame, optional
        Minimum detectable leak per load and noise level.

    Returns
    -------
    leakdiag.report.html.Report
    """
    s = suite_run.settings
    rep = Report("leakdiag detection benchmark")
    rep.paragraph(f"Made by `{command}` (suite version {s['suite_version']}, leakdiag "
                  f"{_version()}). Systems: {', '.join(s['systems'])}. Methods: "
                  f"{', '.join(s['methods'])}.")
    rep.heading("How to read it")
    a = s["alarm"]
    rep.bullets([
        "Every method is fitted on healthy runs of its group (rig, load, noise level) and scored "
        "on held-out runs of the same group; leak-size calibrations use other leaking runs. "
        "Seeds are fixed (see docs/detect.md).",
        "Healthy and leaking runs both vary the reference sequence, supply-pressure ripple "
        "(VCA), fluid temperature (bulk modulus and damping), load-spring stiffness (under load) "
        "and sensor noise; only the leak differs systematically.",
        f"Per-run statistic: the largest CUSUM value (drift {a.drift}, direction "
        f"{a.direction}) after a {a.burn_in_s} s burn-in. AUC: held-out healthy runs against "
        "leaking runs of one size.",
        f"Threshold: set on the fitting runs for a false-alarm probability of "
        f"{100 * s['false_alarm_per_run']:g} % per run (converted to alarms per hour). "
        "false_alarm_rate is measured on the held-out healthy runs, per run.",
        "Detection: an alarm at or after the true onset. Minimum detectable leak: the smallest "
        "size detected in >= 90 % of runs, with every larger size also >= 90 %.",
        "Rows pooled over loads and noise levels mix groups whose detectors were fitted "
        "separately; AUC pooled this way compares statistics across groups. The tables per "
        "load and noise level are the ones to read for a given machine.",
        f"Onset estimate: {a.onset_method} change points on the standardised feature (penalty "
        "from the healthy runs), falling back to the CUSUM's excursion start.",
        "cpu_s_per_hour: CPU seconds (time.process_time) of scoring one held-out run -- "
        "features, score, alarm search, onset and size -- per hour of signal, median over the "
        "method's held-out runs; loading the recording is not counted. Measured on the "
        "benchmark's workers, so it includes their contention on a shared machine.",
        "Comparison table (minimum detectable leak): auc_max_leak is the AUC at the largest "
        "leak size; onset error and delay are medians over leak sizes of the per-size medians.",
    ])
    rep.heading("Minimum detectable leak")
    rep.table(not_reached(summary), "Minimum detectable leak per method and rig")
    if summary_by_condition is not None and len(summary_by_condition):
        rep.table(not_reached(summary_by_condition), "Minimum detectable leak per load and noise level "
                  "(each group's detector fitted on that group's healthy runs)")
    rep.heading("Results per leak size")
    rep.table(results, "One row per method, rig and leak size")
    for system in dict.fromkeys(results.system):
        rep.heading(system.upper(), level=3)
        rep.figure(_rate_figure(results, system, suite_run.rated_flow_lpm,
                                s["false_alarm_per_run"]),
                   f"{system.upper()}: detection rate against leak size")
        rep.figure(_roc_figure(suite_run.runs, system), f"{system.upper()}: ROC curves per method")
        rep.figure(_onset_figure(suite_run.runs, system),
                   f"{system.upper()}: onset error of detected runs")
    rep.heading("Results per load and noise level")
    rep.table(by_condition, "Detection rate and AUC per condition")
    errors = suite_run.runs[suite_run.runs.role == "error"] if "role" in suite_run.runs else []
    if len(errors):
        rep.heading("Methods that could not be fitted")
        rep.table(errors[["method", "system", "load", "noise_level", "error"]])
    return rep


def _version() -> str:
    return __version__
