"""``leakdiag batch``: run a job (analyses, sweeps, fitted detectors) over many recordings on Dask."""

from __future__ import annotations

import click

__all__ = ["batch"]


@click.command()
@click.argument("inputs", nargs=-1, required=True)
@click.option("--config", "config_path", required=True,
              type=click.Path(exists=True, dir_okay=False), help="Job TOML (docs/operations.md).")
@click.option("--out", required=True, type=click.Path(),
              help="Results folder, a Parquet dataset (e.g. results.parquet); resumable.")
@click.option("--scheduler", default=None,
              help="Address of an existing Dask scheduler (default: a local cluster).")
@click.option("--workers", type=int, default=2, show_default=True,
              help="Worker processes of the local cluster.")
@click.option("--serial", is_flag=True, help="Run in this process, without Dask.")
@click.option("--retry-errors", is_flag=True, help="Re-run recordings whose result is an error.")
@click.option("--no-progress", is_flag=True, help="Hide the progress bar.")
@click.option("--store", default=None, help="Also write the job's rows to this event store "
              "(SQLite file or SQLAlchemy URL; actuator = recording file stem).")
def batch(inputs, config_path, out, scheduler, workers, serial, retry_errors, no_progress, store):
    """Run the job in --config on every recording matching INPUTS (quote globs: 'data/**/*.parquet').

    One row per recording and analysis/detector goes to --out; a bad file becomes a row with its
    error; a re-run skips finished recordings. Exit code 1 when any recording of the job is an
    error row or gives no usable feature value (shorter than a window, constant channel).
    """
    from leakdiag.batch import load_config, read_results, run_batch
    from leakdiag.batch.runner import LOCAL

    if workers < 1:
        raise click.BadParameter(f"--workers={workers} must be >= 1")
    cfg = load_config(config_path)
    sched = None if serial else (scheduler or LOCAL)
    s = run_batch(list(inputs), cfg, out, scheduler=sched, n_workers=workers,
                  progress=not no_progress, retry_errors=retry_errors)
    if s.n_inputs == 0:
        raise click.UsageError(f"no recording matches {' '.join(inputs)}")
    df = read_results(out)
    n_rows = int((df["job_digest"] == cfg.digest).sum())
    click.echo(f"{s.n_inputs} recording(s): {s.n_run} run, {s.n_skipped} already done, "
               f"{s.n_errors} error(s) in this run; {n_rows} row(s) for job {cfg.digest} in {out}")
    mine = df[df["job_digest"] == cfg.digest]
    if store:
        from leakdiag.store import EventStore
        from leakdiag.store.writers import record_batch

        st = EventStore(store)
        click.echo(f"{record_batch(st, df, cfg.digest)} run(s) written to {st.url}")
        st.close()
    bad = mine[mine["status"] == "error"]
    for _, r in bad.iterrows():
        click.echo(f"  error: {r['recording']}: {r['error']}", err=True)
    ok = mine[(mine["status"] == "ok") & (mine["kind"] == "analysis")]
    n_win = ok["n_windows"].fillna(0).astype(int)
    n_deg = ok["n_degenerate"].fillna(0).astype(int)
    empty = ok[(n_win == 0) | (n_deg == n_win)]
    for _, r in empty.iterrows():
        why = (f"{int(r['n_samples'])} samples is shorter than one window (window={r['window']})"
               if int(r["n_windows"]) == 0 else
               f"all {int(r['n_windows'])} windows degenerate (zero variance: constant channel?)")
        click.echo(f"  unusable: {r['recording']}: {r['name']}: {why}", err=True)
    if len(bad) or len(empty):  # scripts must see that not every recording was analysed
        raise click.exceptions.Exit(1)
