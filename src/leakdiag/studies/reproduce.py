"""``leakdiag reproduce``: run the thesis protocol on the simulators and compare with the thesis.

:func:`reproduce` runs every case of :func:`~leakdiag.studies.protocol.build_cases` on an
executor, then assembles: one row per row of the thesis's ``tables.csv`` with our measure beside
the thesis's and the direction verdicts (:func:`assemble_tables`), the preferred settings (rule
versus thesis), the sensitivity table and ranges, and the stationarity tests.
:func:`leakdiag.report.reproduction.write_outputs` writes ``tables.csv``, ``sensitivity.csv``,
``index.html`` and ``report.md``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from leakdiag._fingerprint import library_versions, parts_fingerprint
from leakdiag.features.registry import feature_record
from leakdiag.runtime.executor import run_cases
from leakdiag.studies.protocol import FULL, QUICK, ProtocolConfig, build_cases, run_case
from leakdiag.studies.select import THESIS_CHOICES, SelectionRule, preferred_setting
from leakdiag.studies.thesis import (THESIS_DATA, load_sensitivity, load_tables, row_sign, spearman,
                                     trend_sign, varied_value)

__all__ = ["Reproduction", "reproduce", "assemble_tables", "preferred_settings", "same_setting",
           "sensitivity_summary", "sensitivity_by_load", "CONTRACT_COLUMNS", "SETTING_COLUMNS",
           "experiment_settings", "unrecorded_settings", "PREVIOUS_COLUMNS", "per_table_agreement",
           "compare_runs", "read_previous", "setting_differences", "code_fingerprints",
           "CODE_PARTS", "NAN_COLUMNS"]

#: The parts of leakdiag a reproduction's numbers depend on (:func:`code_fingerprints`): the
#: protocol, measures and comparisons (``studies``), the simulators and what they call (``sim``,
#: ``io``, ``_validation.py``), the features and the Sec. 5.2 measure (``features``,
#: ``detect``) and the simulation cache the recordings are read back from (``runtime``). Left
#: out: ``report`` (formats the numbers, computes none), ``_version``, ``_fingerprint`` and
#: ``_numba_cache`` (no number); the thesis's tables are data, hashed apart (``thesis_data``).
CODE_PARTS = ("_validation.py", "detect", "features", "io", "runtime", "sim", "studies")

#: Columns of ``tables.csv`` written by :func:`leakdiag.report.reproduction.write_outputs`
#: (the outside contract).
CONTRACT_COLUMNS = [
    "table", "system", "case_study", "leak_lpm", "method", "signals", "varied", "lag", "window",
    "overlap_pct", "mean_rms_before", "mean_rms_after", "pct_change", "pct_change_signed",
    "thesis_mean_rms_before", "thesis_mean_rms_after", "thesis_pct_change",
    "thesis_pct_change_recomputed", "thesis_pct_change_signed", "direction_agrees",
    "trend_ours", "trend_thesis", "trend_agrees", "n_windows", "n_chunks_before",
    "n_chunks_after", "n_chunks_straddling", "n_chunks_empty", "n_nan_windows",
    "n_windows_before", "n_windows_after", "n_nan_windows_before", "n_nan_windows_after",
    "pct_change_signed_nan_as_0", "chunk", "note", "protocol", "load", "duration_s", "onset_s",
    "seed", "sensors",
]
#: The columns of :data:`CONTRACT_COLUMNS` that record the settings defining the experiment of
#: each row (:func:`experiment_settings`), so that ``--previous`` can tell a run made otherwise
#: (:func:`setting_differences`; an audit, 2026-11-29: only ``chunk`` and ``n_windows`` were
#: compared, so another protocol, load or seed went unnoticed).
SETTING_COLUMNS = ["protocol", "load", "duration_s", "onset_s", "seed", "sensors"]
_SETTING_WORDS = {"protocol": "protocol", "load": "load", "duration_s": "run length (s)",
                  "onset_s": "leak onset (s)", "seed": "seed", "sensors": "sensor chain"}
#: The columns of :data:`CONTRACT_COLUMNS` that disclose undefined (NaN, zero-variance) windows
#: (thesis audit 2026-11-28, F1): the measure's counts (``n_chunks_empty``, ``n_nan_windows``),
#: the windows in whole chunks and the NaN ones among them per side of the onset
#: (:func:`leakdiag.studies.nan_windows.nan_windows_by_side`), and the signed % change with the
#: NaN values counted as 0 (:func:`leakdiag.studies.nan_windows.pct_change_nan_as_zero`; a
#: sensitivity, not the measure).
NAN_COLUMNS = ["n_chunks_empty", "n_nan_windows", "n_windows_before", "n_windows_after",
               "n_nan_windows_before", "n_nan_windows_after", "pct_change_signed_nan_as_0"]

#: Columns of an earlier run's ``tables.csv`` that :func:`compare_runs` reads
#: (``leakdiag reproduce --previous``).
PREVIOUS_COLUMNS = ["system", "table", "method", "signals", "varied", "direction_agrees",
                    "trend_ours", "trend_thesis", "trend_agrees", "pct_change",
                    "thesis_pct_change"]


@dataclass
class Reproduction:
    """Everything one reproduction run computed (the report is built from this only).

    Attributes
    ----------
    config : ProtocolConfig
        Settings of the run.
    systems : tuple of str
        Systems run.
    tables : pandas.DataFrame
        :data:`CONTRACT_COLUMNS`, one row per thesis table row of the systems run.
    series : dict
        ``row_id`` -> ``(time, values)`` feature series of each table row.
    preferred : pandas.DataFrame
        Per sweep table: our rule's pick, the rule applied to the thesis's values, the thesis's
        choice.
    ofat : list of dict
        Sec. 4.4 procedure on the case-study-1 simulation per method (chosen values, tables).
    sensitivity : pandas.DataFrame
        One row per case-study-3 experiment and method.
    stationarity : dict
        System -> ``{"moments": {channel: DataFrame}, "tests": DataFrame}``.
    timing : dict
        Wall time, number of cases, cache hits, ``code`` (:func:`code_fingerprints` at the run).
    previous : pandas.DataFrame or None
        ``tables.csv`` of an earlier run to compare with (:func:`compare_runs`), if given.
    """

    config: ProtocolConfig
    systems: tuple
    tables: Any
    series: dict
    preferred: Any
    ofat: list
    sensitivity: Any
    stationarity: dict
    timing: dict = field(default_factory=dict)
    previous: Any = None


def experiment_settings(config: ProtocolConfig, system: str) -> dict:
    """The settings that define the case-study experiments of one system in a run (the
    :data:`SETTING_COLUMNS` of its rows in ``tables.csv``).

    Parameters
    ----------
    config : ProtocolConfig
        Settings of the run.
    system : str
        ``"vca"`` or ``"eha"`` (either case).

    Returns
    -------
    dict
        ``protocol`` (the config's name), ``load``, ``duration_s``, ``onset_s`` (s),
        ``seed`` (the tables' seed) and ``sensors`` (the sensor chain).

    Examples
    --------
    >>> experiment_settings(QUICK, "EHA")  # doctest: +NORMALIZE_WHITESPACE
    {'protocol': 'thesis-quick', 'load': 'none', 'duration_s': 40.0, 'onset_s': 20.0,
     'seed': 0, 'sensors': 'thesis'}
    """
    vca = str(system).lower() == "vca"
    return {"protocol": config.name, "load": config.vca_load if vca else config.eha_load,
            "duration_s": float(config.vca_duration_s if vca else config.eha_duration_s),
            "onset_s": float(config.vca_onset_s if vca else config.eha_onset_s),
            "seed": int(config.table_seed), "sensors": str(config.sensor_chain)}


def assemble_tables(thesis, rows: list[dict], config: ProtocolConfig | None = None):
    """Our measure beside the thesis's, with the direction and trend verdicts.

    Parameters
    ----------
    thesis : pandas.DataFrame
        :func:`leakdiag.studies.thesis.load_tables` (possibly filtered).
    rows : list of dict
        Our measure rows, each with ``row_id``.
    config : ProtocolConfig, optional
        Settings of the run, recorded per row in :data:`SETTING_COLUMNS`
        (:func:`experiment_settings`); without it those columns are empty.

    Returns
    -------
    pandas.DataFrame
        :data:`CONTRACT_COLUMNS` plus ``row_id``, in the thesis's row order.

    Notes
    -----
    ``direction_agrees``: ``sign(pct_change_signed) == sign(thesis after - before)``; false if
    our value is NaN. ``trend_*`` (sweep tables only, same value on every row of a table): sign
    of the Spearman correlation between the varied parameter and |% change| (0 = flat,
    ``|rho| < TREND_FLAT``); ``trend_agrees`` is empty for the signal tables.
    """
    import pandas as pd


    ours = pd.DataFrame(rows).set_index("row_id")
    t = thesis.set_index("row_id").copy()
    out = pd.DataFrame(index=t.index)
    for c in ("table", "system", "case_study", "leak_lpm", "method", "signals", "varied", "lag",
              "window", "overlap_pct"):
        out[c] = t[c]
    for c in ("mean_rms_before", "mean_rms_after", "pct_change", "pct_change_signed",
              "n_windows", "n_chunks_before", "n_chunks_after", "n_chunks_straddling",
              *NAN_COLUMNS, "chunk"):
        out[c] = ours[c].reindex(t.index)
    out["thesis_mean_rms_before"] = t["mean_rms_before"]
    out["thesis_mean_rms_after"] = t["mean_rms_after"]
    out["thesis_pct_change"] = t["pct_change_reported"]
    out["thesis_pct_change_recomputed"] = t["pct_change_recomputed"]
    out["thesis_pct_change_signed"] = t["thesis_sign"] * t["pct_change_recomputed"]
    our_sign = row_sign(out["pct_change_signed"])
    out["direction_agrees"] = (our_sign == t["thesis_sign"].to_numpy()) & (our_sign != 0)
    out["trend_ours"] = pd.array([pd.NA] * len(out), dtype="Int64")
    out["trend_thesis"] = pd.array([pd.NA] * len(out), dtype="Int64")
    out["trend_agrees"] = pd.array([pd.NA] * len(out), dtype="boolean")
    for _, g in out.groupby("table", sort=False):
        if g["varied"].iloc[0] == "signal" or len(g) < 2:
            continue
        x = [varied_value(v, lag, w, o) for v, lag, w, o in
             zip(g.varied, g.lag, g.window, g.overlap_pct)]
        ts_ours = trend_sign(x, g["pct_change"])
        ts_thesis = trend_sign(x, g["thesis_pct_change_recomputed"])
        out.loc[g.index, "trend_ours"] = ts_ours
        out.loc[g.index, "trend_thesis"] = ts_thesis
        out.loc[g.index, "trend_agrees"] = ts_ours == ts_thesis
    out["note"] = t["note"]
    for c in SETTING_COLUMNS:
        out[c] = [experiment_settings(config, sy)[c] if config is not None else None
                  for sy in out["system"]]
    return out.reset_index()[["row_id"] + CONTRACT_COLUMNS]


def preferred_settings(tables, rule=None):
    """Per sweep table: the rule's pick on our values, on the thesis's values, and the thesis's.

    Parameters
    ----------
    tables : pandas.DataFrame
        Output of :func:`assemble_tables`.
    rule : SelectionRule, optional
        Default :class:`~leakdiag.studies.select.SelectionRule` ().

    Returns
    -------
    pandas.DataFrame
        Columns ``table``, ``system``, ``method``, ``signals``, ``varied``, ``ours_rule``,
        ``ours_rule_pct``, ``thesis_values_rule``, ``thesis_choice``, ``thesis_choice_pct``,
        ``ours_agrees_with_thesis_choice``, ``thesis_values_rule_agrees`` (settings compared by
        :func:`same_setting`).
    """
    import pandas as pd


    rule = rule or SelectionRule()
    out = []
    for tab, g in tables.groupby("table", sort=False):
        v = g["varied"].iloc[0]
        if v == "signal":
            continue
        col = {"lag": "lag", "lag_ratio": "lag", "window": "window", "overlap": "overlap_pct"}[v]

        def frame(before, after, pct, signed, nb, na):
            return pd.DataFrame({"lag": pd.to_numeric(g["lag"].str.split(":").str[0]),
                                 "window": g["window"].to_numpy(),
                                 "overlap": g["overlap_pct"].to_numpy(), "pct_change": pct,
                                 "pct_change_signed": signed, "n_chunks_before": nb,
                                 "n_chunks_after": na, "value": g[col].to_numpy()})

        ours = frame(g.mean_rms_before, g.mean_rms_after, g["pct_change"].to_numpy(dtype=float),
                     g.pct_change_signed.to_numpy(dtype=float),
                     g.n_chunks_before.fillna(0).to_numpy(), g.n_chunks_after.fillna(0).to_numpy())
        th = frame(None, None, g.thesis_pct_change_recomputed.to_numpy(dtype=float),
                   g.thesis_pct_change_signed.to_numpy(dtype=float),
                   np.full(len(g), 10**6), np.full(len(g), 10**6))
        try:
            pick = preferred_setting(ours, rule)
            ours_v, ours_pct = pick["value"], float(pick["pct_change"])
        except ValueError:
            ours_v, ours_pct = None, float("nan")
        th_v = preferred_setting(th, rule)["value"]
        choice = THESIS_CHOICES.get(tab)
        match = g[[same_setting(x, choice) for x in g[col]]]
        out.append({"table": tab, "system": g.system.iloc[0], "method": g.method.iloc[0],
                    "signals": g.signals.iloc[0], "varied": v, "ours_rule": ours_v,
                    "ours_rule_pct": ours_pct, "thesis_values_rule": th_v,
                    "thesis_choice": choice,
                    "thesis_choice_pct": float(match.thesis_pct_change.iloc[0]) if len(match)
                    else float("nan"),
                    "ours_agrees_with_thesis_choice": same_setting(ours_v, choice),
                    "thesis_values_rule_agrees": same_setting(th_v, choice)})
    return pd.DataFrame(out)


def same_setting(a, b) -> bool:
    """Whether two settings of a sweep table are the same: as numbers when both are (a window
    picked from an all-numeric row comes back as ``100.0``, the thesis's choice is ``100``),
    else as text (lag ratios ``"1:4"``); None is never the same.

    Parameters
    ----------
    a, b : object
        Settings (numbers, numeric text, lag ratios ``"l:k"``, or None).

    Returns
    -------
    bool

    Examples
    --------
    >>> same_setting(100.0, 100), same_setting("100", 100.0), same_setting("1:4", "1:4")
    (True, True, True)
    >>> same_setting(None, 100), same_setting("1:4", "1:8"), same_setting(12.5, 12)
    (False, False, False)
    """
    if a is None or b is None:
        return False
    try:
        return float(a) == float(b)
    except (TypeError, ValueError):
        return str(a) == str(b)


def sensitivity_summary(sens, thesis_ranges=None):
    """Range of |% change| per system and method (Table 5-17) beside the thesis's range.

    Parameters
    ----------
    sens : pandas.DataFrame
        Sensitivity rows (``system``, ``method``, ``channels``, ``pct_change``, ``leak_lpm``).
    thesis_ranges : pandas.DataFrame, optional
        :func:`leakdiag.studies.thesis.load_sensitivity` (default: the shipped copy).

    Returns
    -------
    pandas.DataFrame
        Per (system, method, channels): ``min_pct``, ``max_pct``, ``n_runs``, the trend of
        |% change| along leak size, the feature's direction, and the thesis's range. The trend
        ``rho_pct_vs_leak`` is the mean Spearman rank correlation within each operating
        condition (``load`` and ``duration`` when the rows have them), and
        ``rho_pct_vs_leak_<load>`` the same within one load: pooled over loads it read 0.45 for
        every EHA method, whose runs rise with leak size at 0.96-1.0 within each load, because
        the loads' levels differ more than the sizes' (an audit, 2026-11-27). ``thesis_note``:
        the ``note`` of the thesis's range (empty when none), e.g. where the thesis states the
        range twice and differently.
    """
    import pandas as pd

    strata = [c for c in ("load", "duration") if c in sens]

    def trend(g) -> float:
        if not strata:
            return spearman(g["leak_lpm"], g["pct_change"])
        rhos = [spearman(h["leak_lpm"], h["pct_change"]) for _, h in g.groupby(strata)]
        rhos = [r for r in rhos if np.isfinite(r)]
        return float(np.mean(rhos)) if rhos else float("nan")

    loads = sorted(sens["load"].dropna().unique()) if "load" in sens else []

    th = load_sensitivity() if thesis_ranges is None else thesis_ranges
    out = []
    for (system, method, chans), g in sens.groupby(["system", "method", "channels"], sort=False):
        sig = chans.upper()
        m = th[(th.system == system.upper()) & (th.method == feature_record(method).thesis_name)]
        if len(m) > 1:
            m = m[m.signals.str.replace(" or ", ",").str.contains(sig.split(",")[0])]
            if sig.count(",") and len(m) > 1:
                m = m[m.signals == sig]
        m = m.iloc[0] if len(m) else None
        pct = g["pct_change"].to_numpy(dtype=float)
        out.append({"system": system, "method": method, "channels": chans,
                    "n_runs": int(np.isfinite(pct).sum()),
                    "min_pct": float(np.nanmin(pct)) if np.isfinite(pct).any() else np.nan,
                    "max_pct": float(np.nanmax(pct)) if np.isfinite(pct).any() else np.nan,
                    "rho_pct_vs_leak": trend(g),
                    **{f"rho_pct_vs_leak_{ld}": trend(g[g["load"] == ld]) for ld in loads},
                    "share_falling": float((g["pct_change_signed"] < 0).mean()),
                    "thesis_min_pct": np.nan if m is None else float(m.sensitivity_min_pct),
                    "thesis_max_pct": np.nan if m is None else float(m.sensitivity_max_pct),
                    "thesis_source": "" if m is None else m.source,
                    "thesis_note": "" if m is None or "note" not in m or pd.isna(m["note"])
                    else str(m["note"])})
    return pd.DataFrame(out)


def sensitivity_by_load(sens):
    """Case study 3 per system, method, channels and load, signed: where the feature goes.

    The pooled range of |% change| (:func:`sensitivity_summary`, the thesis's Table 5-17 form)
    hides a leak whose effect reverses between loads: an audit (2026-11-29) found the EHA's
    P1,P2 cross-correlation falling in all 10 runs without load (-15.2 to -5.1 %) and rising
    in all 10 with the spring (+1.5 to +4.2 %), which the pooled magnitudes showed as one range.

    Parameters
    ----------
    sens : pandas.DataFrame
        Sensitivity rows (``system``, ``method``, ``channels``, ``load``,
        ``pct_change_signed``, ``leak_lpm``; ``duration`` when there is one).

    Returns
    -------
    pandas.DataFrame
        One row per (system, method, channels, load), the loads of a method together:
        ``n_runs`` (runs with a measure), ``n_falling``, ``n_rising`` (signed % change below,
        above 0),
        ``min_pct_signed``, ``max_pct_signed`` (%), ``direction`` (``"falls"``, ``"rises"``,
        ``"mixed"``, or ``""`` without a measure) and ``rho_pct_vs_leak`` (Spearman rank
        correlation of |% change| with the leak size, averaged over the durations).

    Raises
    ------
    KeyError
        When a column named above is missing.

    Examples
    --------
    >>> import pandas as pd
    >>> s = pd.DataFrame({"system": "eha", "method": "cross-correlation", "channels": "p1,p2",
    ...                   "load": ["none", "none", "spring", "spring"],
    ...                   "leak_lpm": [0.8, 1.6, 0.8, 1.6],
    ...                   "pct_change_signed": [-5.1, -15.2, 1.5, 4.2]})
    >>> b = sensitivity_by_load(s)
    >>> b[["load", "n_falling", "n_rising", "min_pct_signed", "max_pct_signed",
    ...    "direction"]].values.tolist()
    [['none', 2, 0, -15.2, -5.1, 'falls'], ['spring', 0, 2, 1.5, 4.2, 'rises']]
    """
    import pandas as pd

    out = []
    parts = [(key, load, g) for key, m in sens.groupby(["system", "method", "channels"],
                                                       sort=False)
             for load, g in m.groupby("load", sort=False)]
    for (system, method, chans), load, g in parts:
        v = g["pct_change_signed"].to_numpy(dtype=float)
        ok = v[np.isfinite(v)]
        falling, rising = int((ok < 0).sum()), int((ok > 0).sum())
        direction = ("" if not len(ok) else "falls" if falling == len(ok) else
                     "rises" if rising == len(ok) else "mixed")
        groups = g.groupby("duration") if "duration" in g else [(None, g)]
        rhos = [spearman(h["leak_lpm"], h["pct_change_signed"].abs()) for _, h in groups]
        rhos = [r for r in rhos if np.isfinite(r)]
        out.append({"system": system, "method": method, "channels": chans, "load": load,
                    "n_runs": len(ok), "n_falling": falling, "n_rising": rising,
                    "min_pct_signed": float(ok.min()) if len(ok) else np.nan,
                    "max_pct_signed": float(ok.max()) if len(ok) else np.nan,
                    "direction": direction,
                    "rho_pct_vs_leak": float(np.mean(rhos)) if rhos else np.nan})
    return pd.DataFrame(out)


def per_table_agreement(tables):
    """Per thesis table: direction and trend agreement and our |% change| against the thesis's.

    Parameters
    ----------
    tables : pandas.DataFrame
        :data:`CONTRACT_COLUMNS` rows (``tables.csv`` of a run).

    Returns
    -------
    pandas.DataFrame
        One row per table: ``system``, ``table``, ``method``, ``signals``, ``varied``,
        ``rows``, ``direction_agrees`` (count), ``trend_ours``, ``trend_thesis`` (sign of the
        Spearman trend of |% change| along the varied setting), ``trend_agrees`` (sweep
        tables; NA for signal tables), ``median_pct_ours``, ``median_pct_thesis`` (printed |% change|) and
        ``ratio_ours_to_thesis``, the median over the table's rows of our |% change| divided
        by the thesis's.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"system": "VCA", "table": "5-1", "method": "autocorrelation",
    ...                   "signals": "P1", "varied": "lag", "direction_agrees": [True, False],
    ...                   "trend_ours": 1, "trend_thesis": 1,
    ...                   "trend_agrees": [True, True], "pct_change": [5.0, 2.0],
    ...                   "thesis_pct_change": [50.0, 10.0]})
    >>> float(per_table_agreement(t).ratio_ours_to_thesis.iloc[0])
    0.15
    """
    import pandas as pd

    t = tables.copy()
    t["_ratio"] = t["pct_change"].astype(float) / t["thesis_pct_change"].astype(float)
    out = t.groupby(["system", "table", "method", "signals", "varied"], sort=False).agg(
        rows=("direction_agrees", "size"),
        direction_agrees=("direction_agrees", lambda v: int(pd.Series(v).astype(bool).sum())),
        trend_ours=("trend_ours", "first"), trend_thesis=("trend_thesis", "first"),
        trend_agrees=("trend_agrees", "first"),
        median_pct_ours=("pct_change", "median"),
        median_pct_thesis=("thesis_pct_change", "median"),
        ratio_ours_to_thesis=("_ratio", "median")).reset_index()
    out["trend_agrees"] = out["trend_agrees"].astype("boolean")
    out.loc[out.varied == "signal", "trend_agrees"] = pd.NA
    return out


def compare_runs(new, old):
    """Per table, this run's agreement beside an earlier run's (the "what changed" table).

    Parameters
    ----------
    new, old : pandas.DataFrame
        ``tables.csv`` of this run and of the earlier one.

    Returns
    -------
    pandas.DataFrame
        :func:`per_table_agreement` of both, joined on the table (this run's tables, in its
        order; NaN where the earlier run lacks a table): columns suffixed ``_old``
        and ``_new``, plus ``rows``, ``system``, ``method``, ``signals``, ``varied``.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"system": "EHA", "table": "6-1", "method": "autocorrelation",
    ...                   "signals": "P1", "varied": "lag", "direction_agrees": [True],
    ...                   "trend_ours": 1, "trend_thesis": 1,
    ...                   "trend_agrees": [pd.NA], "pct_change": [4.0],
    ...                   "thesis_pct_change": [2.0]})
    >>> compare_runs(t, t.assign(pct_change=1.0))[["ratio_ours_to_thesis_old",
    ...                                           "ratio_ours_to_thesis_new"]].values.tolist()
    [[0.5, 2.0]]
    """
    a = per_table_agreement(old)
    b = per_table_agreement(new)
    keys = ["system", "table", "method", "signals", "varied"]
    cols = ["direction_agrees", "trend_agrees", "median_pct_ours", "ratio_ours_to_thesis"]
    m = a[keys + ["rows"] + cols].merge(b[keys + cols + ["median_pct_thesis"]], on=keys,
                                        how="right", suffixes=("_old", "_new"))
    return m[keys + ["rows", "median_pct_thesis"] + [f"{c}_{s}" for c in cols
                                                     for s in ("old", "new")]]


def setting_differences(new, old) -> list[str]:
    """How an earlier run's tables were made otherwise than this run's (sentences; empty when
    alike): per system the settings of :data:`SETTING_COLUMNS` (protocol, load, run length,
    onset, seed, sensor chain; compared when both tables have them, see
    :func:`unrecorded_settings`), the RMS chunk (``chunk``) and, per table, the number of
    windows (``n_windows``: another run length, e.g. a ``--quick`` run against a full one). A
    comparison of two such runs mixes those changes with the code's, so the report says so.

    Parameters
    ----------
    new, old : pandas.DataFrame
        ``tables.csv`` of this run and of the earlier one.

    Returns
    -------
    list of str

    Examples
    --------
    >>> import pandas as pd
    >>> a = pd.DataFrame({"table": ["5-1", "5-2"], "chunk": 10, "n_windows": [2105, 2105]})
    >>> setting_differences(a, a)
    []
    >>> setting_differences(a.assign(chunk=5, n_windows=[309, 2105]), a)  # doctest: +ELLIPSIS
    ['RMS chunk: 10 feature values before, 5 now', 'windows per experiment differ in 1 of 2 ...']
    >>> setting_differences(a.iloc[1:], a)  # one table of the earlier run's two: no difference
    []
    >>> b = a.assign(system="VCA", load="none", seed=0)
    >>> setting_differences(b.assign(load="spring", seed=2), b)
    ['load (VCA): none before, spring now', 'seed (VCA): 0 before, 2 now']
    """
    out = []
    systems = [sy for sy in dict.fromkeys(new["system"].astype(str))
               if sy in set(old["system"].astype(str))] if "system" in new and \
        "system" in old else []
    for c in SETTING_COLUMNS:
        if c not in new or c not in old:
            continue
        for sy in systems:
            a = _setting_values(old.loc[old["system"].astype(str) == sy, c])
            b = _setting_values(new.loc[new["system"].astype(str) == sy, c])
            if a and b and a != b:
                out.append(f"{_SETTING_WORDS[c]} ({sy}): {', '.join(a)} before, "
                           f"{', '.join(b)} now")
    if "chunk" in new and "chunk" in old:
        a, b = sorted(set(old["chunk"].dropna())), sorted(set(new["chunk"].dropna()))
        if a != b:
            out.append(f"RMS chunk: {', '.join(f'{x:g}' for x in a)} feature values before, "
                       f"{', '.join(f'{x:g}' for x in b)} now")
    if "n_windows" in new and "n_windows" in old:
        # rows are the same row by their table and setting (not by position: an earlier run of
        # other systems holds its rows elsewhere), the n-th of equal settings with the n-th
        keys = [c for c in ("table", "lag", "window", "overlap_pct", "leak_lpm")
                if c in new and c in old]

        def keyed(t):
            t = t[keys + ["n_windows"]].astype({k: str for k in keys})
            return t.assign(nth=t.groupby(keys).cumcount())

        m = keyed(new).merge(keyed(old), on=keys + ["nth"], suffixes=("_new", "_old"))
        diff = m[m.n_windows_new != m.n_windows_old]
        if len(diff):
            tabs = list(dict.fromkeys(diff.table.astype(str)))
            out.append(f"windows per experiment differ in {len(diff)} of {len(m)} rows shared "
                       f"(tables {', '.join(tabs[:4])}{', ...' if len(tabs) > 4 else ''}): "
                       "other run lengths, e.g. a --quick run against a full one")
    return out


def _setting_values(values) -> list[str]:
    """The distinct values of a setting column as text, numbers without a trailing ``.0``."""
    def word(v):
        try:
            return f"{float(v):g}" if not isinstance(v, str) else v
        except (TypeError, ValueError):
            return str(v)

    return sorted({word(v) for v in values.dropna()})


def unrecorded_settings(old) -> list[str]:
    """The :data:`SETTING_COLUMNS` an earlier run's ``tables.csv`` lacks (written before they
    were recorded): its settings of those could not be compared with this run's.

    Parameters
    ----------
    old : pandas.DataFrame
        ``tables.csv`` of the earlier run.

    Returns
    -------
    list of str
        Column names, in the order of :data:`SETTING_COLUMNS`; empty when all are there and
        hold a value.

    Examples
    --------
    >>> import pandas as pd
    >>> unrecorded_settings(pd.DataFrame({"table": ["5-1"], "load": ["none"]}))
    ['protocol', 'duration_s', 'onset_s', 'seed', 'sensors']
    """
    return [c for c in SETTING_COLUMNS if c not in old or old[c].isna().all()]


def read_previous(path, systems=None):
    """Read and check the ``tables.csv`` of an earlier run, for :func:`compare_runs`.

    ``leakdiag reproduce --previous`` calls it before the long run, so that a file it cannot
    compare with is refused before anything is computed or written.

    Parameters
    ----------
    path : str or path-like
        The earlier run's ``tables.csv``.
    systems : sequence of str, optional
        Systems of this run (``"vca"``, ``"eha"``): the file must have rows of at least one.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    ValueError
        One line naming ``path``: not a CSV table, no rows, a column of :data:`PREVIOUS_COLUMNS`
        missing, ``direction_agrees`` not True/False, a % change column not numeric, or no row
        of the systems of this run.
    """
    import pandas as pd

    try:
        t = pd.read_csv(path)
    except ValueError as exc:  # EmptyDataError, ParserError, UnicodeDecodeError
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{path}: cannot read it as a CSV table ({first})") from None
    missing = [c for c in PREVIOUS_COLUMNS if c not in t.columns]
    if missing:
        cols = ", ".join(map(str, t.columns[:6])) + (", ..." if len(t.columns) > 6 else "")
        raise ValueError(f"{path}: no column {', '.join(missing)}: not a tables.csv written by "
                         f"leakdiag reproduce (its columns: {cols})")
    if t.empty:
        raise ValueError(f"{path}: no rows: nothing to compare with")
    if not pd.api.types.is_bool_dtype(t["direction_agrees"]):
        raise ValueError(f"{path}: column direction_agrees must hold True or False in every "
                         "row")
    for c in ("pct_change", "thesis_pct_change"):
        if not pd.api.types.is_numeric_dtype(t[c]) or pd.api.types.is_bool_dtype(t[c]):
            raise ValueError(f"{path}: column {c} must be numeric (empty for no measure)")
    if systems is not None:
        have = set(t["system"].astype(str).str.lower())
        if not have & {str(s).lower() for s in systems}:
            raise ValueError(f"{path}: its rows are of {', '.join(sorted(have)).upper()}, this "
                             f"run is of {', '.join(systems).upper()}: nothing to compare")
    try:  # what the report computes from it: fails now, not after the run
        per_table_agreement(t)
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"{path}: cannot compare with it: {exc}") from None
    return t


def code_fingerprints() -> dict[str, str]:
    """Fingerprints of the code and data a reproduction's numbers come from.

    A committed report whose values differ from today's was made by other code, data or
    libraries: rerun it.

    Returns
    -------
    dict
        ``code``: :func:`~leakdiag._fingerprint.parts_fingerprint` of :data:`CODE_PARTS`;
        ``thesis_data``: SHA-256 (16 hex digits) of the thesis's tables
        (``studies/thesis_data/*.csv``); ``libraries``: the versions of
        :func:`~leakdiag._fingerprint.library_versions`, as ``"numba 0.60.0, numpy ..."``.

    Examples
    --------
    >>> fp = code_fingerprints()
    >>> sorted(fp), len(fp["code"]), len(fp["thesis_data"])
    (['code', 'libraries', 'thesis_data'], 16, 16)
    """
    import hashlib

    h = hashlib.sha256()
    for f in sorted(THESIS_DATA.glob("*.csv")):
        h.update(f.name.encode() + b"\0" + f.read_bytes())
    libs = ", ".join(f"{k} {v}" for k, v in sorted(library_versions().items()))
    return {"code": parts_fingerprint(CODE_PARTS), "thesis_data": h.hexdigest()[:16],
            "libraries": libs}


def reproduce(systems=("vca", "eha"), config: ProtocolConfig | None = None, *, quick=False,
              scheduler: str | None = "local", n_workers: int | None = None,
              progress: bool = True) -> Reproduction:
    """Run the thesis protocol on the simulators and gather everything the report needs.

    Parameters
    ----------
    systems : sequence of {"vca", "eha"}
        Systems.
    config : ProtocolConfig, optional
        Settings (default :data:`~leakdiag.studies.protocol.FULL`, or ``QUICK`` if ``quick``).
    quick : bool, default False
        Use the short protocol.
    scheduler : str or None, default "local"
        Executor: ``"serial"``, ``"local"`` (a Dask LocalCluster) or a scheduler address.
    n_workers : int, optional
        Workers of the local cluster.
    progress : bool, default True
        Progress bars.

    Returns
    -------
    Reproduction
    """
    import pandas as pd


    cfg = config or (QUICK if quick else FULL)
    systems = tuple(systems)
    t0 = time.perf_counter()
    cases = build_cases(cfg, systems)
    results = run_cases(run_case, cases, scheduler=scheduler, n_workers=n_workers,
                        desc=f"reproduce {'+'.join(systems)} ({cfg.name})", progress=progress)
    thesis = load_tables()
    thesis = thesis[thesis.system.str.lower().isin(systems)]
    rows, series, ofat, sens, stat = [], {}, [], [], {}
    for cr in results:
        res, case = cr.result, cr.config
        if case["kind"] == "tables":
            for r in res["rows"]:
                series[r["row_id"]] = (r.pop("series_time"), r.pop("series_values"))
                rows.append(r)
            for o in res["ofat"]:
                ofat.append({"system": case["system"], **o})
        elif case["kind"] == "sensitivity":
            sens += res["rows"]
        elif case["kind"] == "stationarity":
            stat[case["system"]] = {"moments": res["moments"],
                                    "tests": pd.DataFrame(res["tests"])}
    tables = assemble_tables(thesis, rows, cfg)
    timing = {"wall_s": time.perf_counter() - t0, "n_cases": len(cases),
              "cache_hits": sum(bool(cr.result.get("cache_hit")) for cr in results),
              "case_s": float(sum(cr.elapsed_s for cr in results)), "code": code_fingerprints()}
    return Reproduction(cfg, systems, tables, series, preferred_settings(tables), ofat,
                        pd.DataFrame(sens), stat, timing)
