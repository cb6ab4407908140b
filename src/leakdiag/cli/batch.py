"""``leakdiag batch``: run a job (analyses, sweeps, fitted detectors) over many recordings on Dask."""

from __future__ import annotations

import click

from leakdiag._format import seconds
from leakdiag.cli._options import check_workers, scheduler_option, workers_option

__all__ = ["batch"]


def _stderr_is_terminal() -> bool:
    """A redrawn bar belongs on a terminal; in a log it repeats itself on every update."""
    import sys

    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def _check_detectors(cfg) -> list:
    """Load every detector file of the job once, before any recording is read: refuse one
    that cannot be loaded, streamed or judge a whole recording (naming the option or the job
    file's entry), let its warnings through once, and return the bare pickles among them
    (nothing is checked)."""
    import warnings

    from leakdiag.stream.segments import judges_whole
    from leakdiag.cli.monitor import check_streamable
    from leakdiag.stream.detector_file import load_detector_file

    bare = []
    for ref in cfg.detectors:
        given = ref.origin == "--detector"
        try:
            try:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")  # once per file, whatever ran before
                    det, meta = load_detector_file(ref.path)
            except ValueError as exc:
                raise click.BadParameter(str(exc), param_hint="--detector") from None
            if not judges_whole(det):  # whole-recording ones read each file whole
                if callable(getattr(det, "predict", None)) and \
                        not callable(getattr(det, "spec", None)) and \
                        not hasattr(det, "threshold_"):
                    raise click.BadParameter(
                        f"{ref.path}: {type(det).__name__} is not fitted (no threshold): "
                        "fit it with leakdiag fit", param_hint="--detector")
                check_streamable(det, meta, ref.path)
        except click.BadParameter as exc:
            if given:
                raise
            raise ValueError(f"{ref.origin or 'job file'}: {exc.message}") from None
        for w in caught:
            click.echo(f"leakdiag: warning: {w.message}", err=True)
        if meta is None:
            bare.append(ref)
    return bare


@click.command(epilog="Example: leakdiag batch 'recordings/**/*.parquet' --config job.toml "
                      "-o results.parquet --scheduler serial")
@click.argument("inputs", nargs=-1, required=True)
@click.option("--config", "config_path", default=None,
              type=click.Path(exists=True, dir_okay=False),
              help="Job TOML: analyses, detectors (from leakdiag fit), column_map "
                   "(docs/operations.md); not needed for a job of --detector files alone.")
@click.option("--detector", "detectors", multiple=True, type=click.Path(exists=True, dir_okay=False),
              help="Detector file from leakdiag fit, run on every recording (repeatable; adds "
                   "to the job's [[detector]] entries). It is a pickle: loading it runs code, "
                   "so load only files you trust.")
@click.option("--out", "-o", required=True, type=click.Path(),
              help="Results folder, a Parquet dataset (e.g. results.parquet); resumable.")
@scheduler_option()
@workers_option
@click.option("--retry-errors", is_flag=True, help="Re-run recordings whose result is an error.")
@click.option("--no-progress", is_flag=True,
              help="Hide the progress bar (shown only at a terminal: logs get the summary line).")
@click.option("--store", default=None, help="Also write the job's rows to this event store "
              "(SQLite file or SQLAlchemy URL; actuator: see --actuator-from).")
@click.option("--actuator-from", type=click.Choice(["folder", "stem"]), default="folder",
              show_default=True, help="With --store, each recording's actuator: the name of its "
              "folder (one folder per actuator, its runs inside) or its file stem (one file "
              "per actuator; two files of one stem in different folders are refused).")
def batch(inputs, config_path, detectors, out, scheduler, workers, retry_errors, no_progress, store,
          actuator_from):
    """Run the job in --config on every recording matching INPUTS (quote globs: 'data/**/*.parquet').

    One row per recording and analysis/detector goes to --out; a bad file becomes a row with its
    error; a re-run skips recordings whose content is unchanged (rows of the same leakdiag code
    and library versions) and replaces the rows of edited ones or of other code. Files inside --out are not inputs. Exit code 1 when any matched recording's current
    result is an error, gives no usable feature value (shorter than a window, constant
    channel) or a detector could not judge it ("not judged"); 2 when --store refuses an
    actuator (its recordings say another rig).
    """
    from leakdiag.batch import load_config, read_results, run_batch
    from leakdiag.batch.runner import LOCAL, batch_inputs

    if config_path is None and not detectors:
        raise click.UsageError("give --config JOB.toml (analyses, detectors) or --detector "
                               "FILE (from leakdiag fit), or both")
    check_workers(scheduler, workers)  # None: one worker per core (as every command)
    import os

    suffix = os.path.splitext(str(out))[1].lower()
    if suffix in (".csv", ".txt", ".tsv", ".xlsx", ".json") and not os.path.isdir(str(out)):
        # a folder named res.csv was made without a word (a flow-balance audit, 2026-11-29)
        raise click.BadParameter(f"{out}: batch writes a results folder (a Parquet dataset, "
                                 "e.g. results.parquet), not a single file; name it without "
                                 f"{suffix} (read it with leakdiag.batch.read_results or "
                                 "pandas.read_parquet)", param_hint="--out")
    st = None
    if store is not None:  # refused before the work: '', an in-memory database, 'sqlite:/x'
        from leakdiag.store import store_url

        store_url(store)
    cfg = load_config(config_path, detectors=detectors)
    bare = _check_detectors(cfg)
    if store is not None:  # opened before the work: a store that cannot be opened stops it
        from leakdiag.store import EventStore

        st = EventStore(store)
        click.get_current_context().call_on_close(st.close)
        # the actuators' names come from the paths: two folders of one name are refused now,
        # not after the whole job (a batch audit, 2026-11-29: nothing was stored then, and the
        # decisions were never printed)
        from leakdiag.store.writers import actuator_names

        actuator_names(batch_inputs(list(inputs), out)[0], actuator_from)
    sched = None if scheduler == "serial" else scheduler
    if sched == "local":
        sched = LOCAL
    import warnings

    from leakdiag.stream.detector_file import DetectorFileWarning

    with warnings.catch_warnings():  # shown once per file above, not again by run_batch
        warnings.simplefilter("ignore", DetectorFileWarning)
        s = run_batch(list(inputs), cfg, out, scheduler=sched, n_workers=workers,
                      progress=not no_progress and _stderr_is_terminal(),
                      retry_errors=retry_errors)
    if s.n_inputs == 0:
        raise click.UsageError(f"no recording matches {' '.join(inputs)}" + (
            f" ({s.n_own} file(s) inside --out {out}, batch's result files, left out)"
            if s.n_own else ""))

    df = read_results(out)
    mine = df[(df["job_digest"] == cfg.digest) & df["path"].isin(set(s.paths))]
    n_rows = len(mine)
    # a detector row that judged nothing (alarm empty: too short, a stuck channel, ...); one
    # whose detector alarmed and refused its alarm was judged, inconclusive (as detect says)
    refused_alarm = mine["alarm_refused"].eq(True)  # read_results gives every column
    unjudged = mine[(mine["status"] == "ok") & (mine["kind"] == "detector")
                    & mine["alarm"].isna() & ~refused_alarm]
    click.echo(f"{s.n_inputs} recording(s): {s.n_run} run, {s.n_skipped} already done, "
               f"{s.n_errors} error(s) in this run; {n_rows} current row(s) for job {cfg.digest} "
               f"in {out}, {len(unjudged)} of them not judged")
    if s.n_other_code or s.n_other_libraries:  # never silently: say what was redone and why
        from leakdiag.batch.runner import CODE_PARTS

        why = ([f"{s.n_other_code} had rows of other leakdiag code (another fingerprint of "
                f"{', '.join(CODE_PARTS)})"] if s.n_other_code else []) + (
            [f"{s.n_other_libraries} had rows of other library versions (Python, NumPy, SciPy, "
             "Numba, pandas, pyarrow)"] if s.n_other_libraries else [])
        click.echo(f"leakdiag: note: {s.n_other_code + s.n_other_libraries} finished "
                   f"recording(s) in {out} computed again, their rows replaced: "
                   f"{'; '.join(why)}", err=True)
    if s.n_own:  # a glob that covers --out: batch's own result files are not recordings
        click.echo(f"leakdiag: note: {s.n_own} file(s) that the inputs match inside --out "
                   f"{out} (batch's result files, not recordings) left out", err=True)
    refused = ()
    if st is not None:
        from leakdiag.store.writers import record_batch

        w = record_batch(st, mine, cfg.digest, actuator_from)
        click.echo(f"{w.n_runs} run(s) written to {st.shown_url}"
                   + (f" ({w.n_stored} already there)" if w.n_stored else ""))
        refused = w.refused
    from leakdiag.cli._options import HIGH_RATE_HZ, LOW_RATE_HZ, rate_basis, rate_warning

    odd = mine[(mine["status"] == "ok") & ((mine["sample_rate"] < LOW_RATE_HZ)
                                           | (mine["sample_rate"] > HIGH_RATE_HZ))]
    for (rec_name, rec_path), rate in odd.groupby(["recording", "path"])[
            "sample_rate"].first().items():  # where the rate came from: the file and the map
        msg = rate_warning(rec_name, rate, rate_basis(rec_path, cfg.column_map, rate),
                           'give the job a column map ([job] column_map = "map.toml" with '
                           '[file] time_unit = "ms")',
                           "Then drop the map's time_unit (s is the default)")
        click.echo(f"leakdiag: warning: {msg}", err=True)
    for ref in bare:  # after the bar and the rows' count, where the warning above scrolled
        click.echo(f"leakdiag: warning: detector {ref.name}: {ref.path} is a bare pickle "
                   "without a record: its rows were not checked against the recordings' "
                   "sample rate, channels, units, system or load", err=True)
    notes = mine[mine["unchecked"].notna()].drop_duplicates(["path", "unchecked"])
    for note in notes["unchecked"]:  # once per recording, not once per detector row
        click.echo(f"leakdiag: warning: {note}", err=True)
    bad = mine[mine["status"] == "error"]
    for _, r in bad.iterrows():
        click.echo(f"  error: {r['recording']}: {r['error']}", err=True)
    for _, r in unjudged.iterrows():
        click.echo(f"  not judged: {r['recording']}: {r['name']}: "
                   f"{str(r['error']).removeprefix('detector not judged: ')}", err=True)
    judged = mine[(mine["status"] == "ok") & (mine["kind"] == "detector")
                  & (mine["alarm"].notna() | refused_alarm)]
    if len(judged) and "decision" in judged:  # the decisions, as detect makes them
        count = judged["decision"].value_counts()
        click.echo("detector decisions: " + ", ".join(
            f"{int(count.get(d, 0))} {w}" for d, w in (("leak", "LEAK"), ("no-leak", "NO LEAK"),
                                                      ("inconclusive", "INCONCLUSIVE"))))
        if "false_alarms_expected" in judged:  # the counts' basis (a batch audit, 2026-11-29:
            # 214 LEAKs of 300 files, 18 leaking, were printed without it)
            exp = judged.groupby("name", sort=True)["false_alarms_expected"].sum(min_count=1)
            exp = exp[exp.notna()]
            if len(exp):
                click.echo("  basis: were every recording healthy, chance alone would give "
                           "about " + ", ".join(f"{v:.3g} LEAK(s) from {n}"
                                                for n, v in exp.items())
                           + " (the sum of each run's false_alarms_expected, at the level it "
                           "was judged at)")
        for _, r in judged[refused_alarm.loc[judged.index]].iterrows():
            click.echo(f"  inconclusive: {r['recording']}: {r['name']}: "
                       f"{str(r['error']).removeprefix('alarm refused: ')}", err=True)
        no_evidence = judged[judged["decision"].eq("inconclusive")
                             & judged["alarm"].fillna(False).astype(bool)]
        for _, r in no_evidence.iterrows():  # an alarm that is no evidence: say why
            why = r.get("why_inconclusive")
            click.echo(f"  inconclusive: {r['recording']}: {r['name']}: alarm at "
                       f"{seconds(r['alarm_time_s'], 6)} s, but "
                       + (why if isinstance(why, str) and why else
                          "a run this long expects such an alarm by chance"), err=True)
    ok = mine[(mine["status"] == "ok") & (mine["kind"] == "analysis")]
    n_win = ok["n_windows"].fillna(0).astype(int)
    n_deg = ok["n_degenerate"].fillna(0).astype(int)
    empty = ok[(n_win == 0) | (n_deg == n_win)]
    for _, r in empty.iterrows():
        why = (f"{int(r['n_samples'])} samples is shorter than one window "
               f"(window={int(r['window'])})"
               if int(r["n_windows"]) == 0 else
               f"all {int(r['n_windows'])} windows degenerate (zero variance: constant channel?)")
        click.echo(f"  unusable: {r['recording']}: {r['name']}: {why}", err=True)
    for msg in refused:  # the results are complete; these actuators are not in the store
        click.echo(f"  not stored: {msg}", err=True)
    if refused:  # as detect and monitor refuse a run of another rig (exit code 2)
        raise click.exceptions.Exit(2)
    if len(bad) or len(empty) or len(unjudged):  # scripts must see that not every recording
        raise click.exceptions.Exit(1)           # was analysed and judged
