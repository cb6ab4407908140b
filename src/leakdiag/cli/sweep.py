"""``leakdiag sweep``: one-factor-at-a-time (Sec. 4.4) or full grid of the Sec. 5.2 measure."""

from __future__ import annotations

import math
import re
from pathlib import Path

import click

from leakdiag.cli._features import FeatureChoice
from leakdiag.cli._options import (FiniteFloat, list_option_values, recording_options,
                                   resample_option)
from leakdiag.features.registry import feature_record

__all__ = ["sweep", "format_table", "DEFAULT_LAGS", "DEFAULT_LAG_RATIOS"]

#: ``--lags`` of the correlations when not given: the first four lags of the thesis's lag sweep,
#: Table 5-1 (Sec. 5.3.1: 1, 2, 4, 8, 12, 18; Table 6-1, the EHA's: 1, 2, 4).
DEFAULT_LAGS = "1,2,4,8"
#: ``--lags`` of metric-length when not given: the lag ratios of the thesis's lag-ratio sweep,
#: Table 5-13 (Sec. 5.6.1, VCA, window 500); they span the EHA's Table 6-13 (43:3, 40:3, 37:3,
#: Sec. 6.4.1) and hold both preferred ratios, 83:3 (VCA) and 43:3 (EHA). All fit a window of 100.
DEFAULT_LAG_RATIOS = "83:3,57:3,43:3,28:3,23:3,16:3"


def format_table(table) -> str:
    """Render a sweep table for the terminal (thesis columns first).

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep table.

    Returns
    -------
    str
        A missing measure (no whole chunk on a side) prints as ``-``; the columns
        ``n_nan_windows`` and ``n_chunks_empty`` are shown when a setting has NaN windows.
    """
    show = table.copy()
    show["setting"] = [lr if isinstance(lr, str) else str(lag) for lag, lr in
                       zip(show["lag"], show["lag_ratio"])]
    cols = [c for c in ("varied",) if c in show] + ["setting", "window", "overlap",
                                                     "mean_rms_before", "mean_rms_after",
                                                     "pct_change", "pct_change_signed",
                                                     "n_windows", "n_chunks_before",
                                                     "n_chunks_after"]
    cols += [c for c in ("n_nan_windows", "n_chunks_empty") if c in show and show[c].any()]
    for c, fmt in (("mean_rms_before", "{:.5g}"), ("mean_rms_after", "{:.5g}"),
                   ("pct_change", "{:.2f}"), ("pct_change_signed", "{:+.2f}")):
        show[c] = show[c].map(lambda v, fmt=fmt: fmt.format(v) if v == v else "-")
    show["overlap"] = show["overlap"].map(lambda v: f"{v:g}")
    return show[cols].to_string(index=False)


#: Names of the figures ``sweep -o`` draws (any other file in the folder is kept).
_SWEEP_FIGURES = re.compile(r"(?:panels|pct_vs)_(?:lag|window|overlap)\.png|grid_heatmap\.png")


def _figures(rec, table, method, channels, onset, out: Path, varied_groups) -> list[Path]:
    """The stacked panels and % change curves per varied parameter; ``channels`` is the
    resolved ``"p1,p2"`` (the feature's own channels when ``--channels`` is not given)."""
    from leakdiag.features.spec import compute_feature
    from leakdiag.report.figures import save_figure
    from leakdiag.report.study_plots import plot_pct_vs_parameter, plot_stacked
    from leakdiag.studies.grid import _spec, parse_lag, quiet_degenerate

    source = rec.meta.get("source", "recording")
    written = []
    for varied, g in varied_groups:
        if len(g) == 0:
            continue
        series, rms, titles, xs, labels = [], [], [], [], []
        for r in g.itertuples(index=False):
            lag = parse_lag(method, r.lag_ratio if isinstance(r.lag_ratio, str) else r.lag)
            with quiet_degenerate():
                fs = compute_feature(rec, _spec(r.method, r.channels.split(","), lag, r.window,
                                                r.overlap))
            series.append((fs.time, fs.values))
            rms.append((r.mean_rms_before, r.mean_rms_after, r.pct_change_signed)
                       if r.mean_rms_before == r.mean_rms_before else None)
            lab = r.lag_ratio if isinstance(r.lag_ratio, str) else str(r.lag)
            titles.append(f"{r.method} {r.channels}: lag {lab}, window {r.window}, "
                          f"overlap {r.overlap:g}%")
            xs.append({"lag": float(lab.split(":")[0]), "window": r.window,
                       "overlap": r.overlap}[varied])
            labels.append({"lag": lab, "window": str(r.window),
                           "overlap": f"{r.overlap:g}"}[varied])
        if len(series) > 6:
            keep = sorted(set(int(round(i)) for i in
                              [k * (len(series) - 1) / 5 for k in range(6)]))
            panels = [series[i] for i in keep], [titles[i] for i in keep], [rms[i] for i in keep]
        else:
            panels = series, titles, rms
        p = out / f"panels_{varied}.png"
        save_figure(plot_stacked(panels[0], onset=onset, titles=panels[1], rms=panels[2]), p)
        written.append(p)
        p = out / f"pct_vs_{varied}.png"
        unit = {"lag": "lag ratio l:k" if feature_record(method).setting == "lag_ratio"
                else "lag (samples)",
                "window": "window N (samples)", "overlap": "overlap (%)"}[varied]
        save_figure(plot_pct_vs_parameter(xs, g["pct_change"].to_numpy(), xlabel=unit,
                                          title=f"{method} {channels}: % change against {varied}",
                                          xticklabels=labels, label=Path(str(source)).name), p)
        written.append(p)
    return written


@click.command(epilog="Example: leakdiag sweep run.parquet -m autocorrelation -c p1 --lags 1,2,4 "
                      "--windows 100:400:100 --onset 200 -o sweep/")
@click.argument("file", type=click.Path(dir_okay=False))
@recording_options
@resample_option
@click.option("--method", "-m", default="autocorrelation", show_default=True,
              type=FeatureChoice(single=True),
              help="A single-valued feature of the registry (thesis spellings too).")
@click.option("--channels", "-c", default=None, help="Channels, e.g. p1 | p1,p2 | u,x.")
@click.option("--lags", default=None,
              help=f"Lags (1,2,4 or 1:30:1), or lag ratios l:k for metric-length (83:3,57:3). "
                   f"Default: {DEFAULT_LAGS} (from the thesis's lag sweep, Table 5-1); for "
                   f"metric-length {DEFAULT_LAG_RATIOS} (its lag-ratio sweep, Table 5-13, "
                   "Sec. 5.6.1).")
@click.option("--windows", default="100:800:100", show_default=True,
              help="Window sizes in samples (list or start:stop:step). ofat mode refuses a "
                   "window longer than the recording; grid mode skips it and says so.")
@click.option("--overlaps", default="5,25,50", show_default=True, help="Overlaps in percent.")
@click.option("--mode", type=click.Choice(["ofat", "grid"]), default="ofat", show_default=True,
              help="ofat: Sec. 4.4 (vary lag, keep the best; window; overlap). grid: all combos.")
@click.option("--onset", type=float, default=None, help="Leak onset (s); default: file metadata.")
@click.option("--chunk", type=click.IntRange(min=1), default=10, show_default=True,
              help="Feature values per RMS chunk (Sec. 5.2).")
@click.option("--min-chunks", type=click.IntRange(min=1), default=3, show_default=True,
              help="Selection rule: whole RMS chunks needed on each side of the onset.")
@click.option("--tolerance", type=FiniteFloat(min=0), default=0.0, show_default=True,
              help="Selection rule: % points within the best that count as ties.")
@click.option("--out", "-o", type=click.Path(file_okay=False), default=None,
              help="Folder for sweep.csv, sweep.parquet and the figures.")
@click.option("--no-figures", is_flag=True, help="Skip the figures.")
def sweep(file, column_map, cols, sample_rate, time_unit, resample, method, channels, lags,
          windows, overlaps, mode, onset, chunk, min_chunks, tolerance, out, no_figures):
    """Sweep lag, window and overlap on FILE; print the table of the Sec. 5.2 measure."""
    from leakdiag.studies.select import SelectionRule

    m = method
    lag_values, win_values, ov_values = _check_settings(m, lags, windows, overlaps, mode)
    from leakdiag.cli._options import column_map_from, read_with

    rec = read_with(file, column_map_from(column_map, cols, time_unit), sample_rate, resample)
    _check_input(file, rec, m, channels, lags, lag_values, windows, win_values, mode)
    rule = SelectionRule(min_chunks_per_side=min_chunks, tolerance_pct=tolerance)
    onset = onset if onset is not None else rec.onset
    if onset is None:
        raise click.UsageError(f"{file}: the file's metadata has no leak onset: give --onset "
                               "SECONDS (the sweep compares the feature before and after it)")
    # the last sample's time, not start + duration (an audit, 2026-11-29: "0.001 to 3.001 s"
    # for samples from 0.001 to 3.000 s)
    t0, t1 = rec.start_time, rec.start_time + (rec.n_samples - 1) / rec.sample_rate
    if not t0 < onset < t1:
        raise click.UsageError(f"{file}: onset {onset:g} s is outside the recording "
                               f"(samples from {t0:g} to {t1:g} s): nothing to compare before and after it")
    try:
        table, chosen, groups, failed = _run(rec, m, channels, lag_values, win_values,
                                             ov_values, rule, onset, chunk, mode)
    except ValueError as exc:
        raise ValueError(f"{file}: {exc}") from None
    skipped = _skipped_words(m, rec.n_samples, lag_values, win_values, ov_values, len(table)) \
        if mode == "grid" else ""
    chans = channels or ",".join(feature_record(m).channels)
    click.echo(f"{file}: {rec.n_samples} samples at {rec.sample_rate:g} Hz, onset {onset:g} s, "
               f"{m} {chans}, {len(table)} settings ({mode}){skipped}")
    click.echo(format_table(table))
    _warn_nan_windows(file, m, chans, table)
    if chosen is not None:
        click.echo(f"preferred (max |% change|, >= {min_chunks} chunks per side, tolerance "
                   f"{tolerance:g}): lag {chosen['lag']}, window {chosen['window']}, overlap "
                   f"{chosen['overlap']:g}%")
    if out:
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        table.to_csv(o / "sweep.csv", index=False)
        table.astype({"lag_ratio": "string"}).to_parquet(o / "sweep.parquet", index=False)
        written = ["sweep.csv", "sweep.parquet"]
        if not no_figures and chosen is not None:
            written += [p.name for p in _figures(rec, table, m, chans, onset, o, groups)]
            if mode == "grid" and len(win_values) > 1 and len(ov_values) > 1:
                from leakdiag.report.figures import save_figure
                from leakdiag.report.study_plots import plot_grid_heatmap

                save_figure(plot_grid_heatmap(table, chosen["lag"]), o / "grid_heatmap.png")
                written.append("grid_heatmap.png")
        # an earlier sweep's figures this run did not draw would sit beside this run's table
        stale = sorted(p for p in o.iterdir() if p.name not in written and p.is_file()
                       and _SWEEP_FIGURES.fullmatch(p.name))
        for p in stale:
            p.unlink()
        click.echo(f"wrote {o}/: {', '.join(written)}"
                   + (" (no figures: no setting was chosen)"
                      if chosen is None and not no_figures else ""))
        if stale:
            click.echo(f"removed {', '.join(p.name for p in stale)} from {o}/ (an earlier "
                       "sweep's figures, which this run did not draw)")
    if failed is not None:  # the table is printed (and written): then the error, exit code 2
        stage = f" at the {failed.stage} stage" if failed.stage else ""
        msg = str(failed).replace(f"the rule {rule}", f"the rule (at least --min-chunks "
                                  f"{min_chunks} whole RMS chunks of --chunk {chunk} feature "
                                  f"values on each side of the onset {onset:g} s){stage}")
        later = [v for v in ("window", "overlap") if failed.stage and v not in failed.tables]
        if later:
            msg += (f" (the {' and '.join(later)} stage{'s' if len(later) > 1 else ''} could "
                    "not run)")
        kept = "; the table is printed above" + (f" and in {Path(out) / 'sweep.csv'}"
                                                  if out else "")
        raise ValueError(f"{file}: {msg}; lower --min-chunks or --chunk, or check --onset{kept}")


def _warn_nan_windows(file, method, channels, table) -> None:
    """Say that windows had zero variance (NaN values), as ``leakdiag analyze`` does."""
    import warnings

    from leakdiag.features import DegenerateWindowWarning

    hit = table[table["n_nan_windows"] > 0]
    if not len(hit):
        return
    in_chunks = hit["n_windows"] - hit["n_windows_dropped"]
    r = hit.loc[(hit["n_nan_windows"] / in_chunks).idxmax()]
    lag = r["lag_ratio"] if isinstance(r["lag_ratio"], str) else int(r["lag"])
    n_in = int(r["n_windows"] - r["n_windows_dropped"])
    empty = int(r["n_chunks_empty"])
    warnings.warn(
        f"{file}: {method} {channels}: in {len(hit)} of {len(table)} settings, windows have "
        f"zero variance; their values are NaN (skipped inside their chunk's RMS, column "
        f"n_nan_windows; a chunk of NaN values only is left out, column n_chunks_empty); "
        f"the most at lag {lag}, window {int(r['window'])}, overlap {r['overlap']:g}%: "
        f"{int(r['n_nan_windows'])} of the {n_in} windows in whole chunks, {empty} "
        f"chunk{'' if empty == 1 else 's'} of NaN values only", DegenerateWindowWarning,
        stacklevel=2)


def _run(rec, m, channels, lag_values, win_values, ov_values, rule, onset, chunk, mode):
    """The sweep: ``(table, chosen, groups, None)``, or ``(table, None, [], error)`` when no
    setting meets the rule (the table holds every setting computed)."""
    import pandas as pd

    from leakdiag.studies.grid import grid
    from leakdiag.studies.select import NoEligibleSettingError, preferred_setting
    from leakdiag.studies.sweep import VARIED, ofat_sweep

    if mode == "ofat":
        try:
            res = ofat_sweep(rec, m, channels, lag_values, win_values, ov_values, rule=rule,
                             onset=onset, chunk=chunk)
        except NoEligibleSettingError as exc:
            tables = [exc.tables[k] for k in VARIED if k in exc.tables]
            return pd.concat(tables, ignore_index=True), None, [], exc
        table = res.table()
        chosen = res.chosen
        groups = [(k, res.tables[k]) for k in ("lag", "window", "overlap")]
    else:
        table = grid(rec, m, channels, lag_values, win_values, ov_values, onset=onset,
                     chunk=chunk)
        try:
            best = preferred_setting(table, rule)
        except NoEligibleSettingError as exc:
            return table, None, [], exc
        chosen = {"lag": best["lag_ratio"] if isinstance(best["lag_ratio"], str)
                  else int(best["lag"]), "window": int(best["window"]),
                  "overlap": float(best["overlap"])}
        groups = [("lag", table[(table.window == chosen["window"])
                                & (table.overlap == chosen["overlap"])]),
                  ("window", _at_lag(table, chosen["lag"]).query("overlap == @chosen['overlap']")),
                  ("overlap", _at_lag(table, chosen["lag"]).query("window == @chosen['window']"))]
    return table, chosen, groups, None


def _fits(record, lag, window) -> bool:
    try:
        record.check_setting(lag, window)
    except (ValueError, TypeError):
        return False
    return True


def _check_settings(method, lags, windows, overlaps, mode):
    """``--lags``, ``--windows`` and ``--overlaps`` read and checked before the file is read:
    ``(lags, windows, overlaps)``, or a usage error naming the option and the value.

    Every window must be >= 2 samples, every overlap in [0, 100) %, every lag (or lag ratio) one
    the method takes. In ofat mode every lag must also be smaller than every window (the lag
    stage holds the first window, the window stage the chosen lag: a setting that does not fit
    would be left out without a word); in grid mode the combinations that do not fit are left
    out and counted, and at least one must fit. Windows longer than the recording are checked
    once it is read (:func:`_check_input`).
    """
    record = feature_record(method)
    is_ratio = record.setting == "lag_ratio"
    given = lags is not None
    if not given:
        lags = DEFAULT_LAG_RATIOS if is_ratio else DEFAULT_LAGS
    win_values = list_option_values("--windows", windows, int, "100:800:100",
                                    lambda w: w >= 2, "a window must be >= 2 samples")
    ov_values = list_option_values("--overlaps", overlaps, float, "5,25,50",
                                   lambda o: math.isfinite(o) and 0 <= o < 100,
                                   "an overlap must be in [0, 100) percent")
    lag_values = list_option_values("--lags", lags, str if is_ratio else int,
                                    "83:3,57:3" if is_ratio else "1,2,4,8")
    if record.setting is None:
        return list(lag_values), list(win_values), list(ov_values)
    note = "" if given else f" (the default --lags of {method})"
    where = ("" if len(lag_values) == 1 else f" in {lags!r}") + note
    for v in lag_values:
        try:
            record.check_setting(v)
        except (ValueError, TypeError) as exc:
            raise click.BadParameter(f"{v!r}{where}: {exc}", param_hint="'--lags'") from None
    if mode == "ofat":
        w_min = min(win_values)
        for v in lag_values:
            if not _fits(record, v, w_min):
                raise click.BadParameter(
                    f"{v}{note} does not fit window {w_min} (the smallest of --windows): in "
                    "ofat mode every lag must be smaller than every window (the chosen lag is "
                    "held while the window varies)", param_hint="'--lags'")
    elif not any(_fits(record, v, w) for v in lag_values for w in win_values):
        raise click.BadParameter(f"no value of {lags!r}{note} is smaller than a window of "
                                 f"{windows!r}: no setting to compute", param_hint="'--lags'")
    return list(lag_values), list(win_values), list(ov_values)


def _skipped_words(method, n, lag_values, win_values, ov_values, n_rows) -> str:
    """What a grid left out and why, e.g. ``"; 2 of 6 skipped: window 1000000 is longer than the
    recording (60000 samples)"``; ``""`` when nothing was."""
    record = feature_record(method)
    n_ov = len(ov_values)
    n_all = len(lag_values) * len(win_values) * n_ov
    if n_all == n_rows:
        return ""
    long = [w for w in win_values if w > n]
    n_long = len(long) * len(lag_values) * n_ov
    n_lag = sum(not _fits(record, v, w) for v in lag_values for w in win_values if w <= n) * n_ov
    lag_why = "a lag not smaller than its window"
    if not n_long:
        return f"; {n_all - n_rows} of {n_all} skipped: {lag_why}"
    windows = f"window{'s' if len(long) > 1 else ''} {_and(long)}"
    long_why = f"longer than the recording ({n} samples)"
    if not n_lag:
        why = f"{windows} {'are' if len(long) > 1 else 'is'} {long_why}"
    else:
        why = f"{n_lag} with {lag_why}, {n_long} with {windows} {long_why}"
    return f"; {n_all - n_rows} of {n_all} skipped: {why}"


def _and(values) -> str:
    """``[1]`` -> ``"1"``; ``[1, 2, 3]`` -> ``"1, 2 and 3"``."""
    v = [str(x) for x in values]
    return v[0] if len(v) == 1 else f"{', '.join(v[:-1])} and {v[-1]}"


def _check_input(file, rec, method, channels, lags, lag_values, windows, win_values, mode
                 ) -> None:
    """One clear error naming FILE for inputs no setting can use (too short, constant channel),
    or for a window longer than the recording in ofat mode (grid mode skips and counts it)."""
    import numpy as np

    n = rec.n_samples
    long = [w for w in win_values if w > n]
    if mode == "ofat" and long:
        raise ValueError(
            f"{file}: window{'s' if len(long) > 1 else ''} {_and(long)} of --windows {windows!r} "
            f"{'are' if len(long) > 1 else 'is'} longer than the recording ({n} samples): in "
            "ofat mode every window is computed (the first is held while the lag varies) and "
            f"none is skipped; give windows of at most {n} samples")
    if len(long) == len(win_values):  # grid mode from here: long windows are skipped
        raise ValueError(f"{file}: every window of --windows {windows!r} is longer than the "
                         f"recording ({n} samples): no setting to compute; give windows of at "
                         f"most {n} samples")
    record = feature_record(method)
    fitted = [w for w in win_values if any(_fits(record, v, w) for v in lag_values)]
    if record.setting is not None and all(w > n for w in fitted):
        raise ValueError(f"{file}: no setting to compute: the lags of --lags {lags!r} fit only "
                         f"window{'s' if len(fitted) > 1 else ''} {_and(fitted)} of --windows "
                         f"{windows!r}, longer than the recording ({n} samples)")
    for ch in feature_record(method).check_channels(channels):
        x = rec[ch]
        if x.size and np.all(x == x[0]):
            raise ValueError(f"{file}: channel {ch!r} is constant ({x[0]:g} throughout): zero "
                             f"variance, so its {method} is undefined in every window")


def _at_lag(table, lag):
    if isinstance(lag, str):
        return table[table.lag_ratio == lag]
    return table[table.lag == lag]
