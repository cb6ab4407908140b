"""``leakdiag reproduce vca|eha|all``: the thesis protocol on the simulators, as a report."""

from __future__ import annotations

import dataclasses
import shlex
import sys

import click

from leakdiag.cli._options import (check_workers, prepare_out_file, scheduler_option,
                                   workers_option)

__all__ = ["reproduce"]


@click.command(epilog="\b\nExample: leakdiag reproduce vca --quick --scheduler serial -o repro/\n"
                      "Its report again from --save-results r.pkl:\n"
                      "         leakdiag reproduce --from-results r.pkl -o repro/")
@click.argument("system", type=click.Choice(["vca", "eha", "all"]), required=False)
@click.option("--quick", is_flag=True,
              help="Short version (VCA 60 s, EHA 40 s, fewer leak sizes and seeds) for CI.")
@click.option("--out", "-o", type=click.Path(file_okay=False), default="reproduction",
              show_default=True,
              help="Output folder (index.html, report.md, tables.csv, ..., figures/), created "
                   "before the run. Files of an earlier reproduction there are replaced: its "
                   "figures that this run does not make are removed, other files are kept.")
@scheduler_option()
@workers_option
@click.option("--cache-dir", type=click.Path(file_okay=False), default=None,
              help="Simulation cache (default $LEAKDIAG_CACHE or ~/.cache/leakdiag); "
                   "created and checked writable before the run.")
@click.option("--chunk", type=click.IntRange(min=1), default=10, show_default=True,
              help="Feature values per RMS chunk (Sec. 5.2; not stated in the thesis).")
@click.option("--protocol", type=click.Choice(["thesis", "v1"]), default="thesis",
              show_default=True,
              help="thesis: case studies as Sec. 5.1 states them (VCA 1-2 without load, stated "
                   "step amplitudes, the rigs' sensor chains); v1: the earlier setup (spring "
                   "load, 2-20 mm, default sensors), for side-by-side comparison.")
@click.option("--table-seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the case-study runs (one simulated run per table row). A trend "
                   "verdict whose |% change| varies little along its setting can change with "
                   "it: rerun with other seeds to see which (docs/reproduction/README.md).")
@click.option("--previous", type=click.Path(dir_okay=False, exists=True), default=None,
              help="tables.csv of an earlier run: the report adds a per-table comparison "
                   "(checked before the run).")
@click.option("--no-progress", is_flag=True, help="Hide progress bars.")
@click.option("--save-results", type=click.Path(dir_okay=False), default=None,
              help="Also pickle the computed results (to rebuild the report of this run with "
                   "--from-results); checked before the run, written before the report.")
@click.option("--from-results", type=click.Path(dir_okay=False, exists=True), default=None,
              help="Rebuild the report (tables, figures, pages) of a run saved with "
                   "--save-results into --out, without simulating; SYSTEM may be left out. "
                   "Only for files you trust: loading a pickle can run code.")
def reproduce(system, quick, out, scheduler, workers, cache_dir, chunk, protocol, table_seed,
              previous, no_progress, save_results, from_results):
    """Reproduce the thesis's case studies, tables, sensitivity and stationarity analysis."""
    import time

    if from_results:
        return _rebuild(system, from_results, out, previous)
    if system is None:
        raise click.UsageError("Missing argument 'SYSTEM' (vca, eha or all), or give "
                               "--from-results PKL to rebuild a saved run's report.")

    from leakdiag.studies.protocol import protocol_config
    from leakdiag.studies.reproduce import read_previous
    from leakdiag.studies.reproduce import reproduce as run

    t0 = time.perf_counter()
    from leakdiag.report.reproduction import check_out_dir, write_outputs
    from leakdiag.runtime.cache import prepare_cache_dir

    systems = ("vca", "eha") if system == "all" else (system,)
    # every option and path is checked before the run: nothing fails after the long work
    check_workers(scheduler, workers)
    cfg = dataclasses.replace(protocol_config(protocol, quick), cache_dir=cache_dir, chunk=chunk,
                              table_seed=table_seed)
    if previous:
        try:
            previous = read_previous(previous, systems)
        except ValueError as exc:
            raise ValueError(f"--previous {exc}") from None
        _warn_settings(previous, cfg, systems)
    prepare_cache_dir(cache_dir, "--cache-dir")
    check_out_dir(out)  # and every file and folder the report writes in it
    if save_results:
        prepare_out_file(save_results, "--save-results")
    rep = run(systems, cfg, scheduler=scheduler, n_workers=workers, progress=not no_progress)
    rep.previous = previous
    command = "leakdiag " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
        if sys.argv and sys.argv[0].endswith("leakdiag") else f"leakdiag reproduce {system}" + (
            " --quick" if quick else "") + (f" --protocol {protocol}" if protocol != "thesis"
                                             else "") + (f" --table-seed {table_seed}"
                                                         if table_seed else "")
    if save_results:
        _save(save_results, (rep, command))
    if not no_progress:  # the figures and pages take tens of seconds after the bar's 100 %
        click.echo(f"writing the report (tables, figures, HTML and Markdown) to {out} ...",
                   err=True)
    paths = write_outputs(rep, out, command=command)
    t = rep.tables
    click.echo(f"{len(t)} table rows; direction agrees in {int(t.direction_agrees.sum())}; "
               f"{rep.timing['n_cases']} experiments ({rep.timing['cache_hits']} from cache) in "
               f"{rep.timing['wall_s']:.0f} s")
    click.echo("wrote " + ", ".join(str(p) for k, p in paths.items()
                                    if k not in ("figures", "removed")))
    removed = paths.get("removed") or []
    if removed:
        click.echo(f"removed {len(removed)} figure(s) of an earlier run from "
                   f"{removed[0].parent} (this run does not make them): "
                   + ", ".join(p.name for p in removed[:3]) + (", ..." if len(removed) > 3
                                                                else ""))
    click.echo(f"total {time.perf_counter() - t0:.0f} s (report included)")


#: Options that configure a new run, refused with ``--from-results`` (the saved run's are used).
_RUN_OPTIONS = ("quick", "scheduler", "workers", "cache_dir", "chunk", "protocol",
                "table_seed", "save_results")


def _load_results(path):
    """The ``(Reproduction, command)`` pickled by ``--save-results``, checked."""
    import pickle

    from leakdiag.studies.reproduce import Reproduction

    try:
        with open(path, "rb") as fh:
            obj = pickle.load(fh)
    except (pickle.UnpicklingError, EOFError, AttributeError, ImportError, IndexError,
            ValueError, TypeError) as exc:
        raise ValueError(f"--from-results {path}: cannot read it as results saved by "
                         f"--save-results ({type(exc).__name__}: {exc})") from None
    if not (isinstance(obj, tuple) and len(obj) == 2 and isinstance(obj[0], Reproduction)
            and isinstance(obj[1], str)):
        raise ValueError(f"--from-results {path}: not results saved by leakdiag reproduce "
                         f"--save-results (it holds a {type(obj).__name__})")
    return obj


def _rebuild(system, path, out, previous) -> None:
    """``--from-results``: the report of a saved run, written as the run would have."""
    from click.core import ParameterSource

    from leakdiag.report.reproduction import check_out_dir, write_outputs
    from leakdiag.studies.reproduce import read_previous

    ctx = click.get_current_context()
    given = [f"--{p.replace('_', '-')}" for p in _RUN_OPTIONS
             if ctx.get_parameter_source(p) == ParameterSource.COMMANDLINE]
    if given:
        raise click.UsageError(f"{', '.join(given)}: for a new run; --from-results rebuilds "
                               "the report of a saved one, with its settings: drop "
                               f"{'it' if len(given) == 1 else 'them'}")
    rep, command = _load_results(path)
    if system is not None:
        want = ("vca", "eha") if system == "all" else (system,)
        if tuple(want) != tuple(rep.systems):
            raise ValueError(f"--from-results {path}: the saved run is of "
                             f"{'+'.join(rep.systems).upper()}, not {system.upper()}: give "
                             "its system or none")
    if previous:
        try:
            rep.previous = read_previous(previous, rep.systems)
        except ValueError as exc:
            raise ValueError(f"--previous {exc}") from None
        _warn_settings(rep.previous, rep.config, rep.systems)
    check_out_dir(out)
    paths = write_outputs(rep, out, command=command)
    click.echo(f"rebuilt the report of `{command}` from {path}")
    click.echo("wrote " + ", ".join(str(p) for k, p in paths.items()
                                    if k not in ("figures", "removed")))


def _warn_settings(previous, cfg, systems) -> None:
    """Say before the run when the ``--previous`` run was made with other settings (or does not
    record them): its comparison would mix those changes with the code's."""
    import pandas as pd

    from leakdiag.studies.reproduce import (experiment_settings, setting_differences,
                                            unrecorded_settings)

    new = pd.DataFrame([{"system": s.upper(), "chunk": cfg.chunk,
                         **experiment_settings(cfg, s)} for s in systems])
    diff = setting_differences(new, previous)
    if diff:
        click.echo("leakdiag: warning: the --previous run was made with other settings, so the "
                   "comparison is not of the code alone: " + "; ".join(diff), err=True)
    missing = unrecorded_settings(previous)
    if missing:
        click.echo(f"leakdiag: warning: the --previous tables.csv has no {', '.join(missing)} "
                   "(an older run): its settings could not be compared with this run's",
                   err=True)


def _save(path, obj) -> None:
    """Pickle ``obj`` to ``path`` atomically (a temporary file beside it, then a rename)."""
    import os
    import pickle
    import tempfile

    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)),
                               prefix=".leakdiag-results-")
    try:
        with os.fdopen(fd, "wb") as fh:
            pickle.dump(obj, fh)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # as open() would make it (mkstemp's file is 0600)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
