"""The reproduction report: every thesis table beside ours, with honest direction verdicts.

:func:`build_report` turns a :class:`~leakdiag.studies.reproduce.Reproduction` into a
:class:`~leakdiag.report.html.Report`. Every number and every verdict in it is read from that
object, i.e. computed in the same run. :func:`write_outputs` writes it with the run's tables
(``leakdiag reproduce``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from leakdiag.report.html import Report
from leakdiag.report.study_plots import (plot_moments, plot_pct_vs_parameter, plot_sensitivity,
                                         plot_stacked)
from leakdiag.studies.reproduce import (Reproduction, compare_runs, per_table_agreement,
                                        sensitivity_by_load, sensitivity_summary,
                                        setting_differences, unrecorded_settings)
from leakdiag.studies.thesis import (PRINTED_MISMATCH_POINTS, printed_mismatch, row_sign,
                                     varied_value)

__all__ = ["build_report", "direction_word", "trend_word", "write_outputs", "FIGURE_NAMES",
           "OUTPUT_FILES", "FIGURE_DIR", "check_out_dir", "thesis_series_figure",
           "SENSITIVITY_FIGURES", "STATIONARITY_FIGURES"]

#: Files ``write_outputs`` writes at the top of its folder (every run writes all of them).
OUTPUT_FILES = ("tables.csv", "sensitivity.csv", "preferred.csv", "index.html", "report.md")
#: Sub-folder of the figures (the Markdown report links them there).
FIGURE_DIR = "figures"
#: Names of the figures a reproduction writes into ``figures/`` (the ``fig-NNN.png`` of runs
#: before the figures were named after their table included; ``sec-``: the EHA's sensitivity,
#: Secs. 6.1.5-6.4.5, which have no table); any other file there is kept.
FIGURE_NAMES = re.compile(r"(?:(?:table|stationarity|sec)-[A-Za-z0-9_.-]+|fig-\d{3})\.png")

#: The y axis of a table's feature series, per method.
_FEATURE_LABEL = {"autocorrelation": "autocorrelation coefficient",
                  "cross_correlation": "cross-correlation coefficient",
                  "ratio_of_metric_lengths": "ratio of metric lengths"}
#: Thesis figures of case study 3 per (system, method, channels), from their captions (Sec.
#: 5.8 for the VCA, Secs. 6.1.5, 6.2.5, 6.3.5 and 6.4.5 for the EHA).
SENSITIVITY_FIGURES = {
    ("vca", "autocorrelation", "p1"): "5-23", ("vca", "autocorrelation", "p2"): "5-24",
    ("vca", "cross-correlation", "p1,p2"): "5-25", ("vca", "cross-correlation", "u,x"): "5-26",
    ("vca", "metric-length", "p1"): "5-27", ("vca", "metric-length", "p2"): "5-28",
    ("eha", "autocorrelation", "p1"): "6-5", ("eha", "cross-correlation", "p1,p2"): "6-10",
    ("eha", "cross-correlation", "u,x"): "6-15", ("eha", "metric-length", "p1"): "6-20"}
#: Thesis figures of the windowed moments per (system, channel), from their captions (Secs.
#: 4.7.1 and 4.7.2; the thesis's signals come from its Ch. 4 experiments, see the section).
STATIONARITY_FIGURES = {
    ("vca", "p1"): "4-13", ("vca", "p2"): "4-14", ("vca", "x"): "4-15", ("vca", "u"): "4-16",
    ("eha", "p1"): "4-17", ("eha", "p2"): "4-18", ("eha", "x"): "4-19", ("eha", "u"): "4-20"}
#: Unit each channel's moments are drawn in, and the factor from the recording's SI unit
#: (pressures in kPa as thesis Fig. 5-2, displacement in mm as Fig. 5-3).
_MOMENT_UNITS = {"p1": ("kPa", 1e-3), "p2": ("kPa", 1e-3), "x": ("mm", 1e3), "u": ("V", 1.0)}


def thesis_series_figure(table: str) -> str:
    """The thesis figure that plots the feature series of a table (Figs. 5-7 to 5-22, 6-1 to
    6-19), read from the figures' captions: each names the method, signals, leak and settings
    of its table. Table 5-k is Fig. 5-(k+6); in Ch. 6 one sensitivity figure (6-5, 6-10, 6-15,
    6-20) follows every four tables.

    Parameters
    ----------
    table : str
        Thesis table, ``"5-1"`` to ``"5-16"`` or ``"6-1"`` to ``"6-16"``.

    Returns
    -------
    str
        The figure, e.g. ``"5-7"``.

    Raises
    ------
    ValueError
        For a table without a feature-series figure.

    Examples
    --------
    >>> thesis_series_figure("5-1"), thesis_series_figure("5-16"), thesis_series_figure("6-5")
    ('5-7', '5-22', '6-6')
    """
    chapter, _, k = str(table).partition("-")
    if chapter not in ("5", "6") or not k.isdigit() or not 1 <= int(k) <= 16:
        raise ValueError(f"{table=} must be a table 5-1..5-16 or 6-1..6-16 (the tables with a "
                         "feature-series figure)")
    k = int(k)
    return f"5-{k + 6}" if chapter == "5" else f"6-{k + (k - 1) // 4}"


_SETTING_LABEL = {"lag": "lag", "lag_ratio": "lag ratio", "window": "window (samples)",
                  "overlap": "overlap (%)", "signal": "signal"}


def direction_word(sign: int) -> str:
    """``+1`` -> ``"rises"``, ``-1`` -> ``"falls"``, else ``"does not change"``.

    Parameters
    ----------
    sign : int
        Direction.

    Returns
    -------
    str

    Examples
    --------
    >>> direction_word(-1)
    'falls'
    """
    return {1: "rises", -1: "falls"}.get(int(sign), "does not change")


def trend_word(sign) -> str:
    """Trend of % change along the varied parameter in words.

    Parameters
    ----------
    sign : int or NA
        +1, -1, 0.

    Returns
    -------
    str

    Examples
    --------
    >>> trend_word(1)
    'rises'
    """
    try:
        s = int(sign)
    except (TypeError, ValueError):
        return "n/a"
    return {1: "rises", -1: "falls", 0: "is flat"}[s]


def _setting_col(g):
    v = g["varied"].iloc[0]
    if v in ("lag", "lag_ratio"):
        return g["lag"].astype(str).tolist()
    if v == "window":
        return g["window"].astype(int).astype(str).tolist()
    if v == "overlap":
        return [f"{o:g}" for o in g["overlap_pct"].astype(float)]
    return g["signals"].tolist()


def _share(k, n) -> str:
    """``k`` of ``n`` as a percentage with one decimal ("" when ``n`` is 0 or unknown)."""
    k, n = float(k), float(n)
    return f"{100 * k / n:.1f} %" if np.isfinite(n) and n > 0 and np.isfinite(k) else ""


def _has_nan_windows(g) -> bool:
    """Whether any row of a table has undefined (NaN) windows in whole chunks."""
    return bool((g["n_nan_windows"].fillna(0).astype(float) > 0).any())


def _side_by_side(g):
    import pandas as pd

    out = pd.DataFrame({
        _SETTING_LABEL.get(g["varied"].iloc[0], "setting"): _setting_col(g),
        "ours: mean RMS before": g["mean_rms_before"].to_numpy(),
        "ours: mean RMS after": g["mean_rms_after"].to_numpy(),
        "ours: % change (signed)": g["pct_change_signed"].to_numpy(),
        "thesis: mean RMS before": g["thesis_mean_rms_before"].to_numpy(),
        "thesis: mean RMS after": g["thesis_mean_rms_after"].to_numpy(),
        "thesis: % change (printed)": g["thesis_pct_change"].to_numpy(),
        "direction agrees": g["direction_agrees"].astype(bool).to_numpy(),
        "windows": g["n_windows"].to_numpy(),
        "chunks before/after": [f"{int(b)}/{int(a)}" if np.isfinite(b) else "" for b, a in
                                zip(g["n_chunks_before"].astype(float),
                                    g["n_chunks_after"].astype(float))],
    })
    if _has_nan_windows(g):  # disclosed where the result is shown (thesis audit, F1)
        out["NaN windows before"] = [f"{int(k)} of {int(n)} ({_share(k, n)})" for k, n in
                                     zip(g["n_nan_windows_before"], g["n_windows_before"])]
        out["NaN windows after"] = [f"{int(k)} of {int(n)} ({_share(k, n)})" for k, n in
                                    zip(g["n_nan_windows_after"], g["n_windows_after"])]
        out["chunks of NaN only"] = g["n_chunks_empty"].astype(int).to_numpy()
        out["sensitivity: % change, NaN as 0"] = g["pct_change_signed_nan_as_0"].to_numpy()
    return out


def _nan_lines(g) -> list[str]:
    """What the undefined windows of a table are and how much skipping them matters."""
    if not _has_nan_windows(g):
        return []
    nb = g["n_nan_windows_before"].astype(float) / g["n_windows_before"].astype(float)
    na = g["n_nan_windows_after"].astype(float) / g["n_windows_after"].astype(float)
    k = int((g["n_nan_windows"].fillna(0) > 0).sum())
    ours = g["pct_change_signed"].astype(float)
    zero = g["pct_change_signed_nan_as_0"].astype(float)

    def span(v, fmt):
        lo, hi = np.nanmin(v), np.nanmax(v)
        return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else \
            f"{fmt.format(lo)} to {fmt.format(hi)}"

    return [f"Undefined windows: in {k} of {len(g)} rows some windows have zero variance "
            f"(a correlation is then undefined: NaN); the Sec. 5.2 measure skips them inside "
            f"their chunk and leaves out chunks of NaN values only. Share of NaN windows before "
            f"the onset {span(100 * nb, '{:.1f} %')}, after it {span(100 * na, '{:.1f} %')}. "
            f"The signed % change above skips them ({span(ours, '{:+.3g} %')}); counted as 0 "
            f"instead, a sensitivity and not the measure, it would read "
            f"{span(zero, '{:+.3g} %')} (docs/studies.md, 'Degenerate windows')."]


def _run_words(cfg, system) -> str:
    """The case-study run of a system in words: leak onset, run length, load; a run shorter than
    the thesis's (``--quick``) says so.

    Examples
    --------
    >>> from leakdiag.studies.protocol import QUICK, THESIS
    >>> _run_words(THESIS, "VCA")
    "leak at 200 s of a 400 s run, load 'none'"
    >>> _run_words(QUICK, "eha")
    "leak at 20 s of a 40 s run (shorter than the thesis's 180 s: --quick), load 'none'"
    """
    from leakdiag.studies.protocol import EHA_DURATION_S, VCA_DURATION_S

    vca = str(system).lower() == "vca"
    dur, onset, load, full = ((cfg.vca_duration_s, cfg.vca_onset_s, cfg.vca_load,
                               VCA_DURATION_S) if vca else
                              (cfg.eha_duration_s, cfg.eha_onset_s, cfg.eha_load,
                               EHA_DURATION_S))
    short = f" (shorter than the thesis's {full:g} s: --quick)" if dur < full else ""
    return f"leak at {onset:g} s of a {dur:g} s run{short}, load '{load}'"


def _short_runs(cfg, systems) -> list[str]:
    """Per system run, ``"VCA 60 s"`` when its case-study runs are shorter than the thesis's."""
    from leakdiag.studies.protocol import EHA_DURATION_S, VCA_DURATION_S

    out = []
    for s in systems:
        vca = str(s).lower() == "vca"
        dur, full = ((cfg.vca_duration_s, VCA_DURATION_S) if vca
                     else (cfg.eha_duration_s, EHA_DURATION_S))
        if dur < full:
            out.append(f"{str(s).upper()} {dur:g} s against the thesis's {full:g} s")
    return out


def _held_fixed(g) -> str:
    """The settings of a table that are the same in every row (all but the varied one)."""
    r = g.iloc[0]
    v = r["varied"]
    ratio = ":" in str(r["lag"])
    parts = []
    if v not in ("lag", "lag_ratio"):
        parts.append(f"{'lag ratio' if ratio else 'lag'} {r['lag']}")
    if v != "window":
        parts.append(f"window {int(r['window'])}")
    if v != "overlap":
        parts.append(f"overlap {float(r['overlap_pct']):g} %")
    return ", ".join(parts)


def _table_title(g, cfg) -> str:
    """Heading of one thesis table: what is compared, what is varied, what is held fixed (the
    other settings, the run's length and load).

    Examples
    --------
    >>> import pandas as pd
    >>> from leakdiag.studies.protocol import THESIS
    >>> g = pd.DataFrame({"table": "5-4", "system": "VCA", "case_study": 2, "leak_lpm": 0.047,
    ...                   "method": "autocorrelation", "signals": ["P1", "P2"],
    ...                   "varied": "signal", "lag": "1", "window": 200, "overlap_pct": 5.0})
    >>> import textwrap
    >>> print(textwrap.fill(_table_title(g, THESIS), 88))
    Table 5-4: VCA case study 2, autocorrelation of P1 and of P2 (one row each); lag 1,
    window 200, overlap 5 % held fixed; leak 0.047 L/min, leak at 200 s of a 400 s run, load
    'none'
    """
    r = g.iloc[0]
    v = r["varied"]
    signals = list(dict.fromkeys(g["signals"].astype(str)))
    what = (" and of ".join(signals) + " (one row each)") if len(signals) > 1 else signals[0]
    varied = "" if v == "signal" else f", {_SETTING_LABEL.get(v, v).split(' (')[0]} varied"
    return (f"Table {r['table']}: {r['system']} case study {int(r['case_study'])}, "
            f"{r['method'].replace('_', ' ')} of {what}{varied}; {_held_fixed(g)} held fixed; "
            f"leak {r['leak_lpm']:g} L/min, {_run_words(cfg, r['system'])}")


def _verdict(g) -> list[str]:
    ours = row_sign(g["pct_change_signed"])
    th = np.sign(g["thesis_mean_rms_after"] - g["thesis_mean_rms_before"]).astype(int)
    n = len(g)
    agree = int(g["direction_agrees"].sum())
    txt = [f"Direction after the leak: the feature falls in {int((ours < 0).sum())} and rises in "
           f"{int((ours > 0).sum())} of our {n} rows; in the thesis it falls in "
           f"{int((th < 0).sum())} and rises in {int((th > 0).sum())}. Direction agrees in "
           f"{agree} of {n} rows."]
    if g["varied"].iloc[0] != "signal" and g["trend_agrees"].notna().any():
        to, tt = g["trend_ours"].iloc[0], g["trend_thesis"].iloc[0]
        ok = bool(g["trend_agrees"].iloc[0])
        txt.append(f"Trend of |% change| along the {_SETTING_LABEL[g['varied'].iloc[0]]}: ours "
                   f"{trend_word(to)}, the thesis's {trend_word(tt)}: "
                   f"{'agrees' if ok else 'DISAGREES'}.")
    if str(g["note"].iloc[0]):
        txt.append(f"Note on the thesis's settings: {g['note'].iloc[0]}.")
    return txt + _nan_lines(g)


def _panels(rep, g):
    series, rms, titles = [], [], []
    for _, r in g.iterrows():
        if r["row_id"] not in rep.series:
            continue
        series.append(rep.series[r["row_id"]])
        rms.append(None if not np.isfinite(r["mean_rms_before"]) else (
            r["mean_rms_before"], r["mean_rms_after"], r["pct_change_signed"]))
        titles.append(f"{r['method']} {r['signals']}: lag {r['lag']}, window {int(r['window'])}, "
                      f"overlap {float(r['overlap_pct']):g}%")
    if not series:
        return None
    if len(series) > 6:  # keep panels readable: first, middle and last settings
        idx = sorted(set(np.linspace(0, len(series) - 1, 6).round().astype(int)))
        series = [series[i] for i in idx]
        rms = [rms[i] for i in idx]
        titles = [titles[i] for i in idx]
    return plot_stacked(series, onset=_onset(rep, g["system"].iloc[0]), titles=titles, rms=rms,
                        ylabel=_FEATURE_LABEL.get(g["method"].iloc[0]))


def _onset(rep, system) -> float:
    s = str(system).lower()
    return rep.config.vca_onset_s if s == "vca" else rep.config.eha_onset_s


def _code_sentence(code) -> str:
    """The code fingerprints of the run, or nothing for a run that did not record them."""
    if not code:
        return ""
    if "code" not in code:  # recorded before 2026-11-27: the simulators and features only
        return (f" Code: simulators `{code.get('sim', '?')}`, features "
                f"`{code.get('features', '?')}` (the fingerprints of that time, of these two "
                "packages only).")
    from leakdiag.studies.reproduce import CODE_PARTS

    return (f" Code: `{code['code']}` (leakdiag's {', '.join(CODE_PARTS)}), thesis data "
            f"`{code['thesis_data']}`, libraries {code['libraries']} "
            "(`leakdiag.studies.reproduce.code_fingerprints()`; other values today mean that the "
            "code, the data or a library has changed since this run, so its numbers may differ: "
            "rerun it).")


def _provenance_sentence(n: int, hits: int) -> str:
    """What of the run's simulations was computed in it and what was read from the cache.

    Examples
    --------
    >>> _provenance_sentence(7, 7)
    '7 simulated experiments: none simulated in this run, all 7 read from the simulation cache'
    >>> _provenance_sentence(98, 2)
    '98 simulated experiments: 96 simulated in this run, 2 read from the simulation cache'
    """
    if hits == 0:
        return f"{n} simulated experiments, all simulated in this run"
    now = "none simulated in this run, all" if hits == n else f"{n - hits} simulated in this run,"
    return f"{n} simulated experiments: {now} {hits} read from the simulation cache"


def _summary(rep, r: Report) -> None:
    t = rep.tables
    r.heading("Summary")
    n, agree = len(t), int(t["direction_agrees"].sum())
    sweeps = t[t.varied != "signal"].drop_duplicates("table")
    n_tr, agree_tr = len(sweeps), int(sweeps["trend_agrees"].fillna(False).astype(bool).sum())
    hits = int(rep.timing.get("cache_hits", 0))
    cached = (" (recordings written to it earlier, by this run or an earlier one; the cache key "
              "holds the fingerprint of the simulators' code and the library versions)"
              if hits else "")
    r.paragraph(
        f"This report was generated by `{rep.timing.get('command', 'leakdiag reproduce')}` "
        f"(protocol '{rep.config.name}', "
        f"{_provenance_sentence(int(rep.timing.get('n_cases', 0)), hits)}{cached}; "
        f"simulations and measures took {rep.timing.get('wall_s', float('nan')):.0f} s of wall "
        f"time). Every feature, measure, table and comparison below was computed in this run "
        f"from these recordings of leakdiag's simulators; the thesis's numbers come from "
        f"physical test rigs." + _code_sentence(rep.timing.get("code")))
    short = _short_runs(rep.config, list(dict.fromkeys(t["system"].astype(str).str.lower())))
    if short:
        r.paragraph(
            f"**A --quick run**: its case-study runs are shorter than the thesis's ("
            f"{'; '.join(short)}), so each measure averages fewer RMS chunks, and case study 3 "
            f"has fewer leak sizes, durations and seeds. It checks that the reproduction runs; "
            f"its numbers are not the reproduction of the thesis (`leakdiag reproduce all` "
            f"without --quick).")
    by_sys = t.groupby("system")["direction_agrees"].agg(["sum", "count"])
    items = [f"Feature direction after the leak (rise or fall) agrees with the thesis in "
             f"{agree} of {n} table rows ("
             + ", ".join(f"{s}: {int(v['sum'])}/{int(v['count'])}" for s, v in by_sys.iterrows())
             + ")."]
    seed = getattr(getattr(rep, "config", None), "table_seed", None)
    items.append(f"Trend of |% change| along the varied parameter agrees in {agree_tr} of "
                 f"{n_tr} sweep tables. Each row is one simulated run"
                 + (f" (table seed {seed})" if seed is not None else "")
                 + ": a trend whose |% change| varies little along its setting can change with "
                 "the seed, the direction of a row rarely (rerun with `--table-seed` to see "
                 "which).")
    for s, g in t.groupby("system", sort=False):
        items.append(f"Magnitude ({s}): median |% change| {np.nanmedian(g['pct_change']):.3g} % "
                     f"in ours against {np.nanmedian(g['thesis_pct_change']):.3g} % in the "
                     f"thesis (rows with a measure: {int(g['pct_change'].notna().sum())} of "
                     f"{len(g)}).")
    nan_tabs = [g for _, g in t.groupby("table", sort=False) if _has_nan_windows(g)]
    if nan_tabs:
        b = t[t["table"].isin([g["table"].iloc[0] for g in nan_tabs])]
        nb = b["n_nan_windows_before"].sum() / b["n_windows_before"].sum()
        na = b["n_nan_windows_after"].sum() / b["n_windows_after"].sum()
        items.append(
            f"Undefined (zero-variance, NaN) windows, skipped by the Sec. 5.2 measure: in "
            f"{len(nan_tabs)} tables ({', '.join(g['table'].iloc[0] for g in nan_tabs)}); "
            f"pooled over their rows {100 * nb:.1f} % of the windows before the onset and "
            f"{100 * na:.1f} % after it. Per row and side in the tables below (columns 'NaN "
            f"windows before/after'), with the % change they would give if counted as 0.")
    p = rep.preferred
    if len(p):
        items.append(f"The explicit selection rule (maximum |% change|, at least 3 RMS chunks per "
                     f"side) applied to our values picks the thesis's own choice in "
                     f"{int(p.ours_agrees_with_thesis_choice.sum())} of {len(p)} sweep tables; "
                     f"applied to the thesis's own values it picks the thesis's choice in "
                     f"{int(p.thesis_values_rule_agrees.sum())}"
                     f" of {len(p)} (the thesis often chose for visual reasons).")
    r.bullets(items)
    r.table(per_table_agreement(t), "Agreement per table: direction (rows agreeing), trend "
            "(sweep tables), median |% change| ours and thesis's, and the median over the "
            "table's rows of ours / thesis's")
    if getattr(rep, "previous", None) is not None:
        _changes_section(rep, r)
    r.heading("Main disagreements", 3)
    bad = t[~t["direction_agrees"].astype(bool)]
    if len(bad):
        worst = bad.groupby(["system", "method", "signals"]).size().sort_values(ascending=False)
        items = []
        for (s, m, sig), k in worst.items():
            g = t[(t.system == s) & (t.method == m) & (t.signals == sig)]
            ours = np.sign(g["pct_change_signed"].to_numpy(dtype=float))
            th = np.sign(g["thesis_mean_rms_after"] - g["thesis_mean_rms_before"]).to_numpy()
            items.append(
                f"{s} {m} {sig}: direction disagrees in {k} of {len(g)} row(s); in the thesis "
                f"the feature rises in {int((th > 0).sum())} and falls in {int((th < 0).sum())} "
                f"rows, in ours it rises in {int((ours > 0).sum())} and falls in "
                f"{int((ours < 0).sum())}; our |% change| spans "
                f"{np.nanmin(g['pct_change']):.3g}-{np.nanmax(g['pct_change']):.3g} % against "
                f"the thesis's {g['thesis_pct_change'].min():.3g}-"
                f"{g['thesis_pct_change'].max():.3g} %.")
        r.bullets(items)
    r.paragraph(
        "Why the simulator and the rig can disagree: (1) the simulators are models of Ch. 2-3 "
        "with parameters the thesis does not give (load spring, friction, sensor noise, "
        "controller gains, the rig's pseudorandom reference) chosen by the simulator authors, "
        "not fitted to the rig; the windowed correlations respond to how the leak changes the "
        "noise and the closed-loop dynamics, which is exactly what those parameters set. "
        "(2) The thesis does not state the RMS chunk length, the exact onset, nor how windows "
        "that straddle the onset are treated; our choices are in docs/studies.md. (3) Several "
        f"thesis tables disagree with their own text (see the notes), and {_mismatch_words(t)}. "
        "(4) Each thesis table is one experiment on one rig; ours is one seeded simulation. No "
        "model was tuned to the printed numbers.")


def _mismatch_words(t) -> str:
    """How many thesis rows print a % change their own RMS columns do not give, counted."""
    bad = t[printed_mismatch(t["thesis_pct_change"], t["thesis_pct_change_recomputed"])]
    if bad.empty:
        return "no row prints a % change that disagrees with its own RMS columns"
    keys = ["system", "case_study", "method", "signals", "lag", "window", "overlap_pct"]
    distinct = len(bad.drop_duplicates(keys))
    rows = ", ".join(f"{tab} {label} {value}" for tab, label, value in zip(
        bad["table"], bad["varied"].map(lambda v: _SETTING_LABEL.get(v, v).split(" (")[0]),
        [_setting_col(bad.loc[[i]])[0] for i in bad.index]))
    same = f" ({distinct} distinct settings: a row printed in two tables counts twice)" \
        if distinct != len(bad) else ""
    return (f"{len(bad)} rows{same} print a % change more than {PRINTED_MISMATCH_POINTS:g} "
            f"points from the one their own RMS columns give: {rows}; trends use the "
            "recomputed values")


def _changes_section(rep, r: Report) -> None:
    """Per table, this run beside the previous one (numbers only; the why is in the README)."""
    c = compare_runs(rep.tables, rep.previous)
    r.heading("What changed against the previous run", 3)
    old, new = rep.previous, rep.tables
    r.paragraph(
        f"Direction agrees in {int(old.direction_agrees.astype(bool).sum())} of {len(old)} rows "
        f"before and {int(new.direction_agrees.astype(bool).sum())} of {len(new)} now; median "
        f"ratio of our |% change| to the thesis's "
        f"{np.nanmedian(old['pct_change'] / old['thesis_pct_change']):.3g} before, "
        f"{np.nanmedian(new['pct_change'] / new['thesis_pct_change']):.3g} now.")
    diff = setting_differences(new, old)
    if diff:
        r.paragraph("**The previous run was made with other settings**, so these changes are "
                    "not the code's alone: " + "; ".join(diff) + ".")
    missing = unrecorded_settings(old)
    if missing:
        r.paragraph(f"**Settings not compared**: the previous run's tables.csv has no "
                    f"{', '.join(missing)} (written before leakdiag recorded them), so whether "
                    "it was made with the same protocol, load, run length, onset, seed and "
                    "sensor chain could not be checked.")
    r.table(c, "Per table: previous run (_old) and this run (_new)")


def _sweep_section(rep, r: Report, figures: bool) -> None:
    t = rep.tables
    for system in rep.systems:
        ts = t[t.system.str.lower() == system]
        if ts.empty:
            continue
        short = _short_runs(rep.config, [system])
        r.heading(f"{system.upper()}: thesis tables reproduced"
                  + (f" (--quick: {short[0]})" if short else ""))
        for _, g in ts.groupby("table", sort=False):
            r.heading(_table_title(g, rep.config), 3)
            for line in _verdict(g):
                r.paragraph(line)
            r.table(_side_by_side(g))
            if not figures:
                continue
            fig = _panels(rep, g)
            if fig is not None:
                tab = g["table"].iloc[0]
                r.figure(fig, f"Feature series of Table {tab} (ours; cf. thesis Fig. "
                              f"{thesis_series_figure(tab)}), leak onset dashed; horizontal "
                              "lines: mean RMS before/after.",
                         name=f"table-{g['table'].iloc[0]}-series")
            if g["varied"].iloc[0] != "signal" and len(g) > 1:
                x = [varied_value(v, lag, w, o) for v, lag, w, o in
                     zip(g.varied, g.lag, g.window, g.overlap_pct)]
                fig = plot_pct_vs_parameter(
                    x, g["pct_change"], g["thesis_pct_change"],
                    xlabel=_SETTING_LABEL[g["varied"].iloc[0]],
                    title=f"Table {g['table'].iloc[0]}: % change",
                    xticklabels=_setting_col(g))
                r.figure(fig, f"|% change| against the varied parameter, Table "
                              f"{g['table'].iloc[0]}: ours and the thesis's.",
                         name=f"table-{g['table'].iloc[0]}-pct-change")


def _preferred_section(rep, r: Report) -> None:
    import pandas as pd

    r.heading("Preferred settings: explicit rule versus the thesis's choice")
    r.paragraph("Rule (docs/studies.md): the largest |% change| among settings with at least 3 "
                "whole RMS chunks on each side of the onset; ties go to the smallest lag, window, "
                "overlap. 'rule on thesis values' applies the same rule to the thesis's printed "
                "RMS columns.")
    if len(rep.preferred):
        r.table(rep.preferred, "Preferred setting per sweep table")
    if rep.ofat:
        rows = [{k: v for k, v in o.items() if k != "table"} for o in rep.ofat]
        r.heading("The Sec. 4.4 procedure run on the simulator", 3)
        r.paragraph("Vary lag (window and overlap held at the thesis's first values), keep the "
                    "rule's pick; vary window; vary overlap, with the thesis's value lists "
                    "(case study 1).")
        r.table(pd.DataFrame(rows), "Our one-factor-at-a-time choices")


def _sensitivity_section(rep, r: Report, figures: bool) -> None:
    if rep.sensitivity is None or len(rep.sensitivity) == 0:
        return
    r.heading("Case study 3: sensitivity to leak size (Table 5-17, Sec. 6.x.5)")
    s = rep.sensitivity
    cfg = rep.config
    ran = set(s["system"].str.lower())  # a VCA-only run describes no EHA experiments
    what = ([f"VCA leaks {list(cfg.vca_sensitivity_lpm)} L/min, durations "
             f"{list(cfg.vca_sensitivity_durations_s)} s"] if "vca" in ran else []) + (
        [f"EHA leaks {list(cfg.eha_sensitivity_lpm)} L/min, "
         f"{cfg.eha_sensitivity_duration_s:g} s"] if "eha" in ran else [])
    r.paragraph(f"Experiments: {'; '.join(what)}; loads {list(cfg.loads)}; seeds "
                f"{list(cfg.sensitivity_seeds)}; leak at half time; each method at the thesis's "
                f"preferred setting.")
    summ = sensitivity_summary(s)
    keys = ["system", "method", "channels"]
    if "load" in s:
        by_load = sensitivity_by_load(s).merge(
            summ[keys + ["thesis_min_pct", "thesis_max_pct"]], on=keys, how="left")
        r.paragraph("Per load, signed: a negative % change means the feature falls after the "
                    "leak. The thesis prints magnitudes only, so its range (thesis_min_pct to "
                    "thesis_max_pct) is of |% change|; rho_pct_vs_leak: Spearman rank "
                    "correlation of |% change| with the leak size within the load (averaged "
                    "over durations).")
        r.table(by_load, "Signed % change per method and load: runs falling and rising, range, "
                         "trend with leak size; the thesis's range of |% change|")
        for line in _direction_lines(by_load):
            r.paragraph(line)
    r.paragraph("Pooled over loads and durations (the form of the thesis's Table 5-17, which "
                "hides a direction that reverses between loads): rho_pct_vs_leak: Spearman rank "
                "correlation of |% change| with the leak size within each operating condition "
                "(load and duration), averaged; rho_pct_vs_leak_<load>: the same within one load "
                "(pooled over loads the loads' levels, not the sizes, would order the runs).")
    r.table(summ.drop(columns=["thesis_note"], errors="ignore"),
            "Range of |% change| per method, pooled over loads, ours beside the thesis's")
    if "thesis_note" in summ:
        for row in summ[summ["thesis_note"].astype(str).str.len() > 0].itertuples():
            r.paragraph(f"Note on the thesis's range for {row.system.upper()} {row.method} "
                        f"{row.channels}: {row.thesis_note}.")
    for line in _sensitivity_nan_lines(s):
        r.paragraph(line)
    if figures:
        for system, g in s.groupby("system", sort=False):
            # Table 5-17 is the VCA's summary; the EHA's results are Secs. 6.1.5-6.4.5 (no table)
            vca = system.lower() == "vca"
            figs = {(m, c): f for (sy, m, c), f in SENSITIVITY_FIGURES.items()
                    if sy == system.lower()}
            shown = [figs[k] for k in dict.fromkeys(zip(g["method"], g["channels"]))
                     if k in figs]
            cf = f"; cf. thesis Figs. {', '.join(shown)}" if shown else ""
            r.figure(plot_sensitivity(g, system, summ[summ.system == system], figures=figs),
                     f"{system.upper()}: signed % change against mean leak size, one marker "
                     f"and colour per load (the thesis's |% change| range shaded on both sides "
                     f"of 0; {'Table 5-17' if vca else 'Secs. 6.1.5-6.4.5'}{cf}).",
                     name="table-5-17-sensitivity-vca" if vca else
                     f"sec-6-x-5-sensitivity-{system.lower()}")


def _direction_lines(by_load) -> list[str]:
    """Per method of case study 3 whose direction differs between loads (or within one): the
    runs falling and rising per load, in words; then how many methods go one way throughout.

    Examples
    --------
    >>> import pandas as pd
    >>> b = pd.DataFrame({"system": "eha", "method": "cross-correlation", "channels": "p1,p2",
    ...                   "load": ["none", "spring"], "n_runs": 10, "n_falling": [10, 0],
    ...                   "n_rising": [0, 10], "min_pct_signed": [-15.2, 1.5],
    ...                   "max_pct_signed": [-5.1, 4.2], "direction": ["falls", "rises"]})
    >>> import textwrap
    >>> print(textwrap.fill(_direction_lines(b)[0], 88))
    EHA cross-correlation p1,p2: the leak's effect on the feature reverses between loads:
    load 'none' 10 of 10 runs fall, 0 rise (-15.2 to -5.1 %); load 'spring' 0 of 10 runs
    fall, 10 rise (+1.5 to +4.2 %). The pooled |% change| range hides this.
    """
    out, same = [], []
    for (system, method, chans), g in by_load.groupby(["system", "method", "channels"],
                                                     sort=False):
        dirs = [d for d in g["direction"] if d]
        if len(set(dirs)) <= 1 and "mixed" not in dirs:
            same.append(f"{system.upper()} {method} {chans} ({dirs[0] if dirs else 'n/a'})")
            continue
        what = ("reverses between loads" if {"falls", "rises"} <= set(dirs)
                else "differs between loads" if len(set(dirs)) > 1
                else "is not the same in every run")
        per = "; ".join(
            f"load '{row.load}' {row.n_falling} of {row.n_runs} runs fall, {row.n_rising} rise "
            f"({row.min_pct_signed:+.3g} to {row.max_pct_signed:+.3g} %)"
            for row in g.itertuples())
        out.append(f"{system.upper()} {method} {chans}: the leak's effect on the feature {what}: "
                   f"{per}. The pooled |% change| range hides this.")
    if same:
        out.append(f"The feature goes the same way under every load in {len(same)} of "
                   f"{len(same) + len(out)} methods: {', '.join(same)}.")
    return out


def _sensitivity_nan_lines(s) -> list[str]:
    """Per method and load of case study 3 with undefined windows: their share per side and
    the |% change| range skipped (the measure) and counted as 0 (a sensitivity)."""
    cols = ("n_nan_windows", "n_windows_before", "n_windows_after", "n_nan_windows_before",
            "n_nan_windows_after", "pct_change_signed_nan_as_0")
    if not all(c in s for c in cols):
        return []
    out = []
    keys = ["system", "method", "channels"] + (["load"] if "load" in s else [])
    for key, g in s.groupby(keys, sort=False):
        if not (g["n_nan_windows"].fillna(0) > 0).any():
            continue
        nb = 100 * g["n_nan_windows_before"].sum() / g["n_windows_before"].sum()
        na = 100 * g["n_nan_windows_after"].sum() / g["n_windows_after"].sum()
        skipped = g["pct_change"].astype(float)
        zero = g["pct_change_signed_nan_as_0"].astype(float).abs()
        load = f", load '{key[3]}'" if len(key) > 3 else ""
        out.append(f"Undefined windows, {key[0].upper()} {key[1]} {key[2]}{load} ({len(g)} runs): "
                   f"{nb:.1f} % of the windows before the onset and {na:.1f} % after it are "
                   f"NaN (pooled) and skipped by the measure; |% change| "
                   f"{np.nanmin(skipped):.3g}-{np.nanmax(skipped):.3g} % as measured, "
                   f"{np.nanmin(zero):.3g}-{np.nanmax(zero):.3g} % with them counted as 0 (a "
                   "sensitivity, not the measure; column pct_change_signed_nan_as_0 of "
                   "sensitivity.csv).")
    return out


def _stationarity_section(rep, r: Report, figures: bool) -> None:
    if not rep.stationarity:
        return
    r.heading("Stationarity (Sec. 4.7)")
    cfg = rep.config
    r.paragraph("Windowed mean, variance, skewness and kurtosis (window 400, overlap 50 %) of each "
                f"signal of the case-study-1 experiment (load: VCA '{cfg.vca_load}', EHA "
                f"'{cfg.eha_load}'), plus ADF (null: unit root) and KPSS "
                "(null: level stationary) tests at 5 %, on the signal block-averaged to at most "
                "4000 points. Which experiment is a decision: Secs. 4.5 and 4.6 say the signals "
                "are tested before they are analysed, and the case studies are analysed, so "
                "their experiment is used; but Ch. 4 shows its signals from experiments under "
                "a load emulating a spring (Sec. 4.6 says so for the EHA), and a verdict can "
                "depend on the load (docs/studies.md, 'Stationarity tests').")
    for line in _stationarity_verdict_lines(rep.stationarity):
        r.paragraph(line)
    for system, st in rep.stationarity.items():
        r.heading(f"{system.upper()} stationarity tests", 3)
        r.table(st["tests"])
        if figures:
            for ch, df in st["moments"].items():
                unit, scale = _MOMENT_UNITS.get(ch, ("", 1.0))
                fig_no = STATIONARITY_FIGURES.get((system, ch))
                cf = f" (cf. thesis Fig. {fig_no})" if fig_no else ""
                r.figure(plot_moments(df, ch, _onset(rep, system),
                                      f"{system.upper()} {ch}: windowed moments (400, 50 %)",
                                      unit=unit, scale=scale),
                         f"{system.upper()} {ch}: windowed moments{cf}, leak onset dashed.",
                         name=f"stationarity-{system}-{ch}")


def _stationarity_verdict_lines(stationarity) -> list[str]:
    """The thesis's stationarity verdict (Sec. 4.7.3) and where our tests disagree, counted.

    Examples
    --------
    >>> import pandas as pd
    >>> tests = pd.DataFrame({"channel": ["p1", "p1", "x", "x"],
    ...                       "part": ["whole", "before leak"] * 2,
    ...                       "verdict": ["stationary", "stationary", "non-stationary",
    ...                                   "trend/difference stationary?"]})
    >>> import textwrap
    >>> print(textwrap.fill(_stationarity_verdict_lines({"eha": {"tests": tests}})[1], 88))
    Ours (ADF and KPSS at 5 %, each signal over the whole run and before the leak):
    'stationary' in 2 of 4 tests (EHA 2 of 4), so ours disagrees with the thesis in 2: EHA x
    whole (non-stationary), EHA x before leak (trend/difference stationary?).
    """
    rows = [(system, t) for system, st in stationarity.items()
            for t in st["tests"].itertuples()]
    if not rows:
        return []
    ok = [(s, t) for s, t in rows if t.verdict == "stationary"]
    bad = [(s, t) for s, t in rows if t.verdict != "stationary"]
    per = ", ".join(f"{s.upper()} {sum(1 for x, _ in ok if x == s)} of "
                    f"{sum(1 for x, _ in rows if x == s)}" for s in stationarity)
    said = (f", so ours disagrees with the thesis in {len(bad)}: "
            + ", ".join(f"{s.upper()} {t.channel} {t.part} ({t.verdict})" for s, t in bad)
            if bad else ": ours agrees with the thesis in every test")
    return ["The thesis's verdict (Sec. 4.7.3): the first four moments of every signal "
            "\"appear to be unrelated to time regardless of the size of the window, or amount of "
            "overlap\", so \"the signals produced from the test rig are stationary\" (a verdict "
            "read from the plots, Figs. 4-13 to 4-20; no test statistic is given).",
            f"Ours (ADF and KPSS at 5 %, each signal over the whole run and before the leak): "
            f"'stationary' in {len(ok)} of {len(rows)} tests ({per}){said}."]


def build_report(rep, command: str = "", figures: bool = True) -> Report:
    """The reproduction report (HTML + Markdown) of a reproduction run.

    Parameters
    ----------
    rep : Reproduction
        Results of :func:`leakdiag.studies.reproduce.reproduce`.
    command : str, optional
        Command line that made the run.
    figures : bool, default True
        Include figures.

    Returns
    -------
    Report
    """
    if command:
        rep.timing["command"] = command
    quick = ", --quick: runs shorter than the thesis's" if _short_runs(rep.config,
                                                                        rep.systems) else ""
    r = Report(f"leakdiag reproduction of the thesis ({'+'.join(rep.systems).upper()}, "
               f"{rep.config.name}{quick})")
    _summary(rep, r)
    r.heading("Method and decisions")
    r.paragraph(
        "How to read the tables: each thesis method turns a signal into one number per window "
        "(e.g. the lag-1 autocorrelation of chamber pressure P1 over 200 samples). The thesis's "
        "measure (Sec. 5.2) takes the RMS of those numbers over consecutive chunks, averages the "
        "chunk RMS before and after the leak onset, and reports the relative change in percent "
        "(Eq. 5-3). A negative signed change means the feature falls after the leak (e.g. the "
        "pressure becomes less correlated); the thesis prints only the magnitude, so its "
        "direction is read from its before/after columns. Each table below shows our simulator's "
        "values and the thesis's rig values at the same settings, then states whether the "
        "direction, and the trend along the varied setting, agree.")
    r.bullets([
        f"Measure: Sec. 5.2 with RMS chunks of {rep.config.chunk} feature values; a chunk "
        "holding a window that spans the onset is left out (leakdiag.detect.rms_change).",
        "Direction agrees: sign of our signed % change equals the sign of the thesis's "
        "(mean RMS after - mean RMS before).",
        "Trend: sign of the Spearman rank correlation between the varied parameter (l of a lag "
        "ratio) and |% change|; |rho| < 0.2 counts as flat.",
        f"Case studies 1-2: VCA {rep.config.vca_duration_s:g} s, leak at "
        f"{rep.config.vca_onset_s:g} s, load '{rep.config.vca_load}'; EHA "
        f"{rep.config.eha_duration_s:g} s, leak at {rep.config.eha_onset_s:g} s, load "
        f"'{rep.config.eha_load}'; seed {rep.config.table_seed}.",
        "Signals: P1->p1, P2->p2, U->u, X->x; 'P1,P2' is cross_correlation(y=p1, x=p2).",
    ])
    _sweep_section(rep, r, figures)
    _preferred_section(rep, r)
    _sensitivity_section(rep, r, figures)
    _stationarity_section(rep, r, figures)
    r.heading("Run configuration")
    cfg = rep.config.as_dict()
    import pandas as pd

    r.table(pd.DataFrame({"setting": list(cfg), "value": [str(v) for v in cfg.values()]}))
    return r


def _stale_figures(fig_dir: Path, keep) -> list[Path]:
    """Figures of an earlier reproduction in ``fig_dir`` that this run did not write."""
    if not fig_dir.is_dir():
        return []
    return sorted(p for p in fig_dir.iterdir() if p.is_file() and p.name not in keep
                  and FIGURE_NAMES.fullmatch(p.name))


def check_out_dir(out_dir, option: str = "--out") -> Path:
    """Check, before the run, every path :func:`write_outputs` will write in ``out_dir``.

    Parameters
    ----------
    out_dir : path-like
        Output folder (created when missing).
    option : str, default "--out"
        Option name for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OSError
        One line naming the problem: the folder cannot be created or written, one of
        :data:`OUTPUT_FILES` is a folder, or ``figures`` is not a writable folder
        (``--out rep: rep/figures exists and is not a folder``).
    """
    from leakdiag.runtime.paths import prepare_out_dir

    return prepare_out_dir(out_dir, option, files=OUTPUT_FILES, folders=(FIGURE_DIR,))


def _move_in(stage: Path, out: Path, names) -> None:
    """Move the staged files ``names`` (paths relative to ``stage``) to the same place in
    ``out``, replacing the earlier ones; if a move fails, the ones made are undone (the
    earlier files put back) before the error propagates."""
    import os

    backup = stage / ".earlier"
    done = []  # (target, its earlier file in backup or None)
    made = []  # folders made here
    try:
        for name in names:
            dst, bak = out / name, backup / name
            if not dst.parent.is_dir():
                dst.parent.mkdir()
                made.append(dst.parent)
            if dst.exists() or dst.is_symlink():
                bak.parent.mkdir(parents=True, exist_ok=True)
                os.replace(dst, bak)
                done.append((dst, bak))
            else:
                done.append((dst, None))
            os.replace(stage / name, dst)
    except BaseException:
        for dst, bak in reversed(done):
            if bak is not None:
                os.replace(bak, dst)
            else:
                dst.unlink(missing_ok=True)
        for d in reversed(made):
            d.rmdir()
        raise


def write_outputs(rep: Reproduction, out_dir, command: str = "") -> dict:
    """Write ``tables.csv``, ``sensitivity.csv``, ``preferred.csv``, ``index.html``, ``report.md``
    and ``figures/``; remove the figures an earlier reproduction left in ``figures/``.

    Parameters
    ----------
    rep : Reproduction
        Results of :func:`leakdiag.studies.reproduce.reproduce`.
    out_dir : path-like
        Output folder (created).
    command : str, optional
        Command line that made the run (printed in the report).

    Returns
    -------
    dict
        Name -> path of every file written (``"figures"``: the folder), and ``"removed"``: the
        list of stale figures removed.

    Raises
    ------
    OSError
        Before anything is built or written, when a path of the output is not what it must be
        (:func:`check_out_dir`); or when writing fails (the earlier files are then as they
        were).

    Notes
    -----
    The paths are checked first (:func:`check_out_dir`), then the report is built, then every
    file is written into a staging folder inside ``out_dir`` (``.leakdiag-staging-*``) and
    only then moved in place, one rename each, replacing the earlier run's files: a failure
    while building or writing leaves the earlier run's files as they were, and one while
    moving puts back those already replaced. The files of :data:`OUTPUT_FILES` are
    overwritten. In ``figures/``, a file named as a reproduction names its figures
    (:data:`FIGURE_NAMES`) that this run did not write is removed, after the new files are in
    place, so that the folder holds this run's report only (a ``vca`` run over an earlier
    ``all`` run used to keep the EHA's figures beside the VCA report). Every other file in
    the folder is kept.
    """
    import shutil
    import tempfile

    out = check_out_dir(out_dir, "out_dir")
    report = build_report(rep, command=command)
    stage = Path(tempfile.mkdtemp(dir=out, prefix=".leakdiag-staging-"))
    try:
        rep.tables.drop(columns=["row_id"]).to_csv(stage / "tables.csv", index=False)
        rep.sensitivity.to_csv(stage / "sensitivity.csv", index=False)
        rep.preferred.to_csv(stage / "preferred.csv", index=False)
        report.write(stage, figure_dir=FIGURE_DIR)
        _move_in(stage, out, list(OUTPUT_FILES)
                 + [f"{FIGURE_DIR}/{name}" for name in report.figures])
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    fig_dir = out / FIGURE_DIR
    paths: dict = {"tables": out / "tables.csv", "sensitivity": out / "sensitivity.csv",
                   "preferred": out / "preferred.csv", "html": out / "index.html",
                   "markdown": out / "report.md", "figures": fig_dir}
    stale = _stale_figures(fig_dir, set(report.figures))
    for p in stale:
        p.unlink()
    paths["removed"] = stale
    return paths
