"""``leakdiag analyze``: thesis features and the Sec. 5.2 verdict for one recording file."""

from __future__ import annotations

import warnings
from pathlib import Path

import click

__all__ = ["analyze", "format_verdict"]

_METHOD_CHOICES = ["autocorrelation", "cross-correlation", "metric-length", "moments", "all"]


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
    show = table.copy()
    cols = ["method", "channels", "setting", "window", "overlap", "n_windows"]
    if show["mean_rms_before"].notna().any():
        show["mean_rms_before"] = show["mean_rms_before"].map(lambda v: f"{v:.5g}")
        show["mean_rms_after"] = show["mean_rms_after"].map(lambda v: f"{v:.5g}")
        show["% change"] = show["pct_change"].map(lambda v: f"{v:.2f}")
        show["signed"] = show["pct_change_signed"].map(lambda v: f"{v:+.2f}")
        show["chunks b/a/x"] = [
            f"{int(b)}/{int(a)}/{int(x)}" for b, a, x in
            zip(show["n_chunks_before"], show["n_chunks_after"], show["n_chunks_straddling"])]
        cols += ["mean_rms_before", "mean_rms_after", "% change", "signed", "chunks b/a/x"]
    if show["n_nan_windows"].fillna(0).astype(int).any():
        show["NaN windows"] = show["n_nan_windows"].fillna(0).astype(int)
        cols.append("NaN windows")
    show["overlap"] = show["overlap"].map(lambda v: f"{v:g}%")
    return show[cols].to_string(index=False)


def _specs(method, channels, lag, lag_ratio, window, overlap, system):
    from leakdiag.features.methods import MethodSpec, thesis_defaults

    if "all" in method:
        return list(thesis_defaults(system))
    specs = []
    for m in method:
        kw = {}
        if m in ("autocorrelation", "cross-correlation"):
            kw["lag"] = 1 if lag is None else lag
        if m == "metric-length":
            kw["lag_ratio"] = lag_ratio or "83:3"
        specs.append(MethodSpec(m, tuple(channels.split(",")) if channels else (),
                                window=window, overlap=overlap, **kw))
    return specs


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--map", "column_map", type=click.Path(exists=True, dir_okay=False),
              help="TOML column map: which column is which channel, its unit or scale.")
@click.option("--col", "cols", multiple=True, metavar="CH=COLUMN[:UNIT[*GAIN]]",
              help="Column mapping on the command line, e.g. --col p1=PG_1:psi (repeatable).")
@click.option("--sample-rate", type=float, help="Sample rate in Hz when the file has no time column.")
@click.option("--resample", type=float, metavar="HZ",
              help="Interpolate a non-uniform time axis onto a uniform grid at this rate.")
@click.option("--method", "-m", multiple=True, type=click.Choice(_METHOD_CHOICES),
              default=["autocorrelation"], show_default=True,
              help="Method(s); 'all' runs the four thesis methods at the thesis's preferred settings.")
@click.option("--system", type=click.Choice(["vca", "eha"]), default=None,
              help="Whose preferred settings 'all' uses (default: the recording's meta, else vca).")
@click.option("--channels", "-c", default=None, help="Channels, e.g. p1 | p1,p2 | u,x.")
@click.option("--lag", type=int, default=None, help="Lag tau in samples (correlations; default 1).")
@click.option("--lag-ratio", default=None, help="Metric-length lag ratio l:k, e.g. 83:3.")
@click.option("--window", "-w", type=int, default=200, show_default=True, help="Window N (samples).")
@click.option("--overlap", "-o", type=float, default=5.0, show_default=True, help="Overlap (%).")
@click.option("--onset", type=float, default=None,
              help="Leak onset (s) for the before/after measure; default: the file's metadata.")
@click.option("--chunk", type=int, default=10, show_default=True,
              help="Feature values per RMS chunk (Sec. 5.2).")
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Folder for verdict.csv, features.parquet and features.png.")
def analyze(file, column_map, cols, sample_rate, resample, method, system, channels, lag, lag_ratio,
            window, overlap, onset, chunk, out):
    """Analyse FILE with the thesis's windowed features and print the verdict table."""
    import leakdiag.io as lio
    from leakdiag.detect.analysis import analyze_recording

    cmap = _column_map(column_map, cols)
    rec = lio.read_recording(file, column_map=cmap, sample_rate=sample_rate, resample=resample)
    if rec.meta.get("source") != str(file):  # messages name the file being analysed
        rec.meta["origin"] = rec.meta.get("source")
        rec.meta["source"] = str(file)
    system = system or str(rec.meta.get("system", "vca")).lower()
    specs = _specs(method, channels, lag, lag_ratio, window, overlap, system)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = analyze_recording(rec, specs, onset=onset, chunk=chunk)
    _fail_if_nothing_computed(file, result.table)
    for w in caught:  # re-issued only when there is a result to qualify
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    head = f"{file}: {rec.n_samples} samples at {rec.sample_rate:g} Hz ({rec.duration:g} s)"
    if result.onset is not None:
        head += f", leak onset {result.onset:g} s"
    else:
        head += "; no onset given (use --onset) so no before/after measure"
    click.echo(head)
    click.echo(format_verdict(result.table))
    if out:
        outp = Path(out)
        _write_outputs(result, outp)
        click.echo(f"wrote {outp / 'verdict.csv'}, features.parquet, features.png")


def _fail_if_nothing_computed(file, table) -> None:
    """Raise when every window of every method is NaN (e.g. constant channels): no verdict exists."""
    n_win = table["n_windows"].fillna(0).astype(int)
    n_nan = table["n_nan_windows"].fillna(0).astype(int)
    if len(table) and bool((n_win > 0).all() and (n_nan == n_win).all()):
        labels = "; ".join(f"{m} {c} (lag {s}, N={w})" for m, c, s, w in
                           zip(table["method"], table["channels"], table["setting"], table["window"]))
        raise ValueError(f"{file}: every window is NaN for {labels}: the channel(s) have zero "
                         "variance (constant signal?), so there is nothing to analyse")


def _column_map(column_map, cols):
    if not cols:
        return column_map
    import leakdiag.io as lio

    return lio.build_column_map(list(cols), base=column_map)


def _write_outputs(result, out: Path) -> None:
    from leakdiag.report.figures import plot_feature_series, save_figure

    out.mkdir(parents=True, exist_ok=True)
    result.table.to_csv(out / "verdict.csv", index=False)
    result.features_frame().to_parquet(out / "features.parquet", index=False)
    rms = result.results if result.onset is not None else None
    fig = plot_feature_series(result.series, onset=result.onset, rms=rms)
    save_figure(fig, out / "features.png")
