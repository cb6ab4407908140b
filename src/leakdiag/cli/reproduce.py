"""``leakdiag reproduce vca|eha|all``: the thesis protocol on the simulators, as a report."""

from __future__ import annotations

import dataclasses
import shlex
import sys

import click

from leakdiag.cli._options import (check_workers, prepare_out_file, scheduler_option,
                                   workers_option)

__all__ = ["reproduce"]


@click.command(epilog="Example: leakdiag reproduce vca --quick --scheduler serial -o repro/")
@click.argument("system", type=click.Choice(["vca", "eha", "all"]))
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
@click.option("--previous", type=click.Path(dir_okay=False, exists=True), default=None,
              help="tables.csv of an earlier run: the report adds a per-table comparison "
                   "(checked before the run).")
@click.option("--no-progress", is_flag=True, help="Hide progress bars.")
@click.option("--save-results", type=click.Path(dir_okay=False), default=None,
              help="Also pickle the computed results (to rebuild the report of this run); "
                   "checked before the run, written before the report.")
def reproduce(system, quick, out, scheduler, workers, cache_dir, chunk, protocol, previous,
              no_progress, save_results):
    """Reproduce the thesis's case studies, tables, sensitivity and stationarity analysis."""
    import time

    from leakdiag.studies.protocol import protocol_config
    from leakdiag.studies.reproduce import read_previous
    from leakdiag.studies.reproduce import reproduce as run

    t0 = time.perf_counter()
    from leakdiag.report.reproduction import check_out_dir, write_outputs
    from leakdiag.runtime.cache import prepare_cache_dir

    systems = ("vca", "eha") if system == "all" else (system,)
    # every option and path is checked before the run: nothing fails after the long work
    check_workers(scheduler, workers)
    cfg = dataclasses.replace(protocol_config(protocol, quick), cache_dir=cache_dir, chunk=chunk)
    if previous:
        try:
            previous = read_previous(previous, systems)
        except ValueError as exc:
            raise ValueError(f"--previous {exc}") from None
    prepare_cache_dir(cache_dir, "--cache-dir")
    check_out_dir(out)  # and every file and folder the report writes in it
    if save_results:
        prepare_out_file(save_results, "--save-results")
    rep = run(systems, cfg, scheduler=scheduler, n_workers=workers, progress=not no_progress)
    rep.previous = previous
    command = "leakdiag " + " ".join(shlex.quote(a) for a in sys.argv[1:]) \
        if sys.argv and sys.argv[0].endswith("leakdiag") else f"leakdiag reproduce {system}" + (
            " --quick" if quick else "") + (f" --protocol {protocol}" if protocol != "thesis"
                                             else "")
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
