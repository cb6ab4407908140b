"""``leakdiag analyze``: thesis features and the Sec. 5.2 verdict for one recording file."""

from __future__ import annotations

import warnings
from pathlib import Path

import click

from leakdiag.cli._features import FeatureChoice, check_setting_options, spec_from_options
from leakdiag.cli._options import false_alarm_option, healthy_option, recording_options
from leakdiag.features.spec import thesis_defaults

__all__ = ["analyze", "format_verdict", "decision_words", "verdict_table"]

#: The feature settings that are options of this command: messages name the option.
_OPTION_OF = {"window": "--window", "overlap": "--overlap", "lag": "--lag",
              "lag_ratio": "--lag-ratio"}


def format_verdict(table) -> str:
    """Render the verdict table for the terminal.

    Parameters
    ----------
    table : pandas.DataFrame
        Columns of :data:`leakdiag.detect.analysis.VERDICT_COLUMNS`.

    Returns
    -------
    str
        Fixed-width text.
    """
    show = table[table["skipped"].isna()].copy() if "skipped" in table else table.copy()
    cols = ["method", "channels", "setting", "window", "overlap", "n_windows"]
    if show["mean_rms_before"].notna().any():
        show["mean_rms_before"] = show["mean_rms_before"].map(lambda v: f"{v:.5g}" if v == v
                                                              else "-")
        show["mean_rms_after"] = show["mean_rms_after"].map(lambda v: f"{v:.5g}" if v == v
                                                            else "-")
        show["% change"] = show["pct_change"].map(lambda v: f"{v:.2f}" if v == v else "-")
        show["signed"] = show["pct_change_signed"].map(lambda v: f"{v:+.2f}" if v == v else "-")
        show["chunks b/a/x"] = [
            f"{int(b)}/{int(a)}/{int(x)}" if b == b else "-" for b, a, x in
            zip(show["n_chunks_before"], show["n_chunks_after"], show["n_chunks_straddling"])]
        cols += ["mean_rms_before", "mean_rms_after", "% change", "signed", "chunks b/a/x"]
    if show["n_nan_windows"].fillna(0).astype(int).any():
        show["NaN windows"] = show["n_nan_windows"].fillna(0).astype(int)
        cols.append("NaN windows")
    if "decision" in show and show["decision"].notna().any():
        show["decision"] = show["decision"].fillna("")
        show["p"] = show["p_value"].map(lambda v: f"{v:.2g}" if v == v else "-")
        cols += ["decision", "p"]
    show["overlap"] = show["overlap"].map(lambda v: f"{v:g}%")
    show["n_windows"] = show["n_windows"].astype(int)
    return show[cols].to_string(index=False)


def _with_option_names(exc: Exception) -> Exception:
    """The same error with the settings' Python names written as this command's options
    (``window=1 must be >= 2`` -> ``--window 1 must be >= 2``; the window a lag must be below
    is named too)."""
    import re

    from leakdiag.cli._words import option_names

    msg = option_names(str(exc), _OPTION_OF)
    msg = re.sub(r"^(--lag \S+ must be in \[1, )(\d+)\)", r"\1--window \2)", msg)
    if msg == str(exc):
        return exc
    try:
        return type(exc)(msg)
    except Exception:  # noqa: BLE001 - an error class that takes more than a message
        return (TypeError if isinstance(exc, TypeError) else ValueError)(msg)


def _specs(method, channels, lag, lag_ratio, window, overlap, system):
    if "all" in method:
        given = [name for name, v in (("--channels", channels), ("--lag", lag),
                                      ("--lag-ratio", lag_ratio), ("--window", window),
                                      ("--overlap", overlap)) if v is not None]
        if given:
            raise click.UsageError(
                f"--method all runs each thesis method at the thesis's preferred settings for "
                f"the {system.upper()} and does not use {', '.join(given)}; drop "
                f"{'it' if len(given) == 1 else 'them'} or name the methods (--method "
                "autocorrelation ...)")
        return list(thesis_defaults(system))
    check_setting_options(method, lag, lag_ratio)
    try:
        return [spec_from_options(m, channels, lag, lag_ratio, 200 if window is None else window,
                                  5.0 if overlap is None else overlap) for m in method]
    except (ValueError, TypeError) as exc:
        raise _with_option_names(exc) from None


def decision_words(table, false_alarm_rate: float) -> str:
    """The decisions of a verdict table in words: one line per method and an overall line.

    Parameters
    ----------
    table : pandas.DataFrame
        Verdict table with decision columns (:data:`leakdiag.detect.analysis.DECISION_COLUMNS`).
    false_alarm_rate : float
        Overall false-alarm rate per run (split over the methods, Bonferroni).

    Returns
    -------
    str
    """
    from leakdiag.detect.analysis import overall_decision

    words = {"leak": "LEAK", "no-leak": "NO LEAK", "inconclusive": "INCONCLUSIVE"}
    lines = []
    for r in table.to_dict("records"):
        label = f"{r['method']} {r['channels']}".strip()
        if isinstance(r.get("skipped"), str):
            lines.append(f"  {label}: skipped ({r['skipped']})")
            continue
        change = r.get("pct_change_signed")
        pct = "" if change is None or change != change else f"{change:+.1f} %, "
        basis = {"before-after": "before vs after the onset", "healthy": "against healthy "
                 "references", "none": "no reference"}.get(r["basis"], r["basis"])
        if pct and r["basis"] != "before-after":  # the percentage is the file's own change
            # (Sec. 5.2), not the change against the references that decided (a CLI audit,
            # 2026-11-29: "+5.5 %, against healthy references", the same +5.5 % as without them)
            pct = f"{change:+.1f} % after vs before the onset; decided "
        lines.append(f"  {label}: {words[r['decision']]} ({pct}{basis}; {r['reason']})")
    dec, why = overall_decision(table, false_alarm_rate)
    lines.append(f"Decision: {words[dec]} -- {why}.")
    if dec == "no-leak":  # no significant change, which is not "no leak of any size" (a CLI
        # audit, 2026-11-29: rig.csv, 0.5 L/min, -48 %, p = 0.03, read NO LEAK without a word)
        lines.append("  sensitivity: not stated: NO LEAK here means no change significant at "
                     "this rate; a leak whose change the chunks do not resolve is not ruled out "
                     "(the flow balance, leakdiag detect, states the smallest leak it would "
                     "have seen; docs/detect.md section 6)")
    return "\n".join(lines)


@click.command(epilog="Example: leakdiag analyze run.parquet --method all --onset 200 -o analysis/")
@click.argument("file", type=click.Path(dir_okay=False))
@recording_options
@click.option("--resample", type=float, metavar="HZ",
              help="Interpolate a non-uniform time axis onto a uniform grid at this rate.")
@click.option("--method", "-m", multiple=True, type=FeatureChoice(extra=("all",)),
              default=["autocorrelation"], show_default=True,
              help="Method(s); 'all' runs the four thesis methods at the thesis's preferred "
                   "settings and skips those whose channels the file lacks.")
@click.option("--system", type=click.Choice(["vca", "eha"]), default=None,
              help="The rig: whose preferred settings 'all' uses (default: the recording's "
                   "meta, else vca), and the decision's direction (one-sided on the VCA and an "
                   "unknown rig, two-sided on the EHA; docs/measure.md).")
@click.option("--channels", "-c", default=None, help="Channels, e.g. p1 | p1,p2 | u,x.")
@click.option("--lag", type=int, default=None, help="Lag tau in samples (correlations; default 1).")
@click.option("--lag-ratio", default=None, help="Metric-length lag ratio l:k (default 83:3).")
@click.option("--window", "-w", type=int, default=None, help="Window N (samples; default 200).")
@click.option("--overlap", type=float, default=None, help="Overlap (%; default 5).")
@click.option("--onset", type=float, default=None,
              help="Leak onset (s) for the before/after measure; default: the file's metadata.")
@click.option("--chunk", type=click.IntRange(min=1), default=10, show_default=True,
              help="Feature values per RMS chunk (Sec. 5.2).")
@healthy_option
@false_alarm_option(upper=0.5)
@click.option("--out", "-o", type=click.Path(file_okay=False), default=None,
              help="Folder for verdict.csv, features.parquet and features.png.")
def analyze(file, column_map, cols, sample_rate, time_unit, resample, method, system, channels,
            lag, lag_ratio, window, overlap, onset, chunk, healthy, false_alarm_rate, out):
    """Analyse FILE with the thesis's windowed features: % change and a leak decision.

    Per method: the thesis's Sec. 5.2 measure (mean chunk RMS before/after the onset, % change)
    and a decision LEAK / NO LEAK / INCONCLUSIVE from a Mann-Whitney test of the chunk RMS
    values after the onset against those before it, or against --healthy recordings
    (docs/measure.md, "Decisions").
    """
    from leakdiag.cli._options import column_map_from, read_healthy, read_with
    from leakdiag.detect.analysis import analyze_recording

    cmap = column_map_from(column_map, cols, time_unit)
    # only the channels the features read (a CLI audit, 2026-11-29: a text note column beside
    # the signals was refused here, where monitor and batch, which read only what they use,
    # judged the file); an option error is said below, after the file's own errors, as before
    try:
        wanted = sorted({c for rig in ([system] if system else ["vca", "eha"])
                         for spec in _specs(method, channels, lag, lag_ratio, window, overlap,
                                            rig)
                         for c in spec.channels})
    except (click.UsageError, ValueError, TypeError):
        wanted = None
    rec = read_with(file, cmap, sample_rate, resample, channels=wanted)
    if rec.meta.get("system"):  # a --system against the file's own word is refused
        from leakdiag.cli.fit import system_of

        system = system_of([rec], system, [str(file)])
    said = system or rec.meta.get("system")
    system = str(said or "vca").lower()
    specs = _specs(method, channels, lag, lag_ratio, window, overlap, system)
    _check_onset(file, rec, onset)
    needed = sorted({c for s in specs for c in s.channels if c in rec.channels})
    refs = read_healthy(healthy, rec, cmap, sample_rate, needed) if healthy else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = analyze_recording(rec, specs, onset=onset, chunk=chunk, healthy=refs,
                                       false_alarm_rate=false_alarm_rate,
                                       skip_missing="all" in method,
                                       system=None if said is None else system)
        except (ValueError, TypeError) as exc:  # e.g. a --window longer than the recording
            if "all" in method:  # the thesis's settings, not options given
                raise
            raise _with_option_names(exc) from None
    _fail_if_nothing_computed(file, result.table)
    for w in caught:  # re-issued only when there is a result to qualify
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    head = f"{file}: {rec.n_samples} samples at {rec.sample_rate:g} Hz ({rec.duration:g} s)"
    if result.onset is not None:
        head += f", leak onset {result.onset:g} s"
    else:
        head += "; no onset given (use --onset) so no before/after measure"
    if "all" in method:  # whose settings, and why: never a silent default
        head += (f"; --method all at the thesis's {system.upper()} settings"
                 + ("" if said else " (the file does not say its system; --system eha for "
                                    "the EHA's)"))
    click.echo(head)
    click.echo(format_verdict(result.table))
    click.echo(decision_words(result.table, false_alarm_rate))
    counts = sorted({c for s in specs if s.method == "moments" for c in s.channels
                     if str(rec.units.get(c, "")).lower() == "counts"})
    if counts:  # a user-data audit, 2026-11-29: raw ADC counts, nothing said
        click.echo(f"leakdiag: warning: {file}: the moments of {', '.join(counts)} are in ADC "
                   "counts, whose zero is the converter's, not 0 Pa: the mean's change (Eq. 5-3, "
                   "a ratio) depends on that offset (the variance's, skewness's and kurtosis's "
                   "do not); give the channel's offset and gain to pascals in the map for a "
                   "change of the pressure's mean", err=True)
    if out:
        outp = Path(out)
        _write_outputs(result, outp, false_alarm_rate)
        click.echo(f"wrote {outp / 'verdict.csv'}, features.parquet, features.png")


def _check_onset(file, rec, onset) -> None:
    """Refuse an onset outside the recording: bad input, not a case the measure cannot judge."""
    given = onset is not None
    onset = onset if given else rec.onset
    if onset is None:
        return
    # the last sample's time, not start + duration (an audit, 2026-11-29: "0.001 to 3.001 s"
    # for samples from 0.001 to 3.000 s)
    t0, t1 = rec.start_time, rec.start_time + (rec.n_samples - 1) / rec.sample_rate
    if not t0 < onset < t1:
        where = "" if given else " (from the file's metadata; give --onset to override it)"
        raise click.UsageError(f"{file}: onset {onset:g} s{where} is outside the recording "
                               f"(samples from {t0:g} to {t1:g} s): nothing to compare before and after it")


def _fail_if_nothing_computed(file, table) -> None:
    """Raise when every window of every method is NaN (constant channels): no verdict exists."""
    n_win = table["n_windows"].fillna(0).astype(int)
    n_nan = table["n_nan_windows"].fillna(0).astype(int)
    if len(table) and bool((n_win > 0).all() and (n_nan == n_win).all()):
        labels = "; ".join(f"{m} {c} (lag {s}, N={w})" for m, c, s, w in
                           zip(table["method"], table["channels"], table["setting"],
                               table["window"]))
        raise ValueError(f"{file}: every window is NaN for {labels}: the channel(s) have zero "
                         "variance (constant signal?), so there is nothing to analyse")


def verdict_table(table, false_alarm_rate: float):
    """The verdict table as ``verdict.csv`` holds it: each method's row with the run's overall
    decision beside it.

    A method's ``decision`` is at its own ``false_alarm_rate``; the run's decision splits that
    rate over the methods (:func:`~leakdiag.detect.analysis.overall_decision`), so a method can
    read ``leak`` where the run reads ``inconclusive`` (a CLI audit, 2026-11-29: a script
    reading ``decision`` took a method's "leak" for the run's). ``overall_decision`` and
    ``overall_reason`` (the same on every row) say the run's, ``method_level`` the rate each
    method's p-value was held to for it.

    Parameters
    ----------
    table : pandas.DataFrame
        The verdict table (:attr:`leakdiag.detect.analysis.AnalysisResult.table`).
    false_alarm_rate : float
        The run's false-alarm rate.

    Returns
    -------
    pandas.DataFrame
        A copy with the three columns added.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"method": ["a", "b"], "decision": ["leak", "no-leak"],
    ...                   "p_value": [0.005, 0.4]})
    >>> verdict_table(t, 0.01)[["decision", "overall_decision", "method_level"]].values.tolist()
    [['leak', 'no-leak', 0.005], ['no-leak', 'no-leak', 0.005]]
    """
    from leakdiag.detect.analysis import overall_decision, split_level

    dec, why = overall_decision(table, false_alarm_rate)
    out = table.copy()
    out["overall_decision"] = dec
    out["overall_reason"] = why
    out["method_level"] = split_level(table, false_alarm_rate)
    return out


def _write_outputs(result, out: Path, false_alarm_rate: float) -> None:
    from leakdiag.report.figures import plot_feature_series, save_figure

    out.mkdir(parents=True, exist_ok=True)
    verdict_table(result.table, false_alarm_rate).to_csv(out / "verdict.csv", index=False)
    result.features_frame().to_parquet(out / "features.parquet", index=False)
    rms = result.results if result.onset is not None else None
    fig = plot_feature_series(result.series, onset=result.onset, rms=rms)
    save_figure(fig, out / "features.png")
