"""``leakdiag sensitivity``: case study 3, % change against leak size for every method."""

from __future__ import annotations

import dataclasses
import math

import click

from leakdiag.cli._options import (check_workers, list_option_values, prepare_out_dir,
                                   scheduler_option, workers_option)
from leakdiag.runtime.memory import memory_bytes, size_words

__all__ = ["sensitivity"]

#: Loads of the case-study-3 experiments (``--loads``).
LOADS = ("spring", "none")
#: Systems of the command; each measured one gets a figure ``sensitivity_<system>.png``.
SYSTEMS = ("vca", "eha")
#: Peak memory of one case-study-3 VCA experiment per sample, bytes (simulation with its leak
#: calibration, then the six methods' features): 184-185 B measured with ``tracemalloc`` over
#: ``protocol.run_case`` on 20-, 40- and 80-s runs at 1000 Hz (2026-11-27), rounded up.
VCA_BYTES_PER_SAMPLE = 200


def _check_run_memory(durations, scheduler, workers) -> None:
    """Refuse a ``--durations`` run that cannot fit in memory, before any experiment.

    One run needs about :data:`VCA_BYTES_PER_SAMPLE` bytes per sample at the simulator's rate;
    the runs that share this machine at once (``--scheduler local``: one per worker, by default
    one per core) share its physical memory, as Dask's local workers do (each gets its share).
    """
    import inspect
    import os

    from leakdiag.sim import simulate_vca

    rate = float(inspect.signature(simulate_vca).parameters["sample_rate"].default)
    total = memory_bytes()
    at_once = (workers or os.cpu_count() or 1) if scheduler == "local" else 1
    budget = total / at_once
    max_s = budget / VCA_BYTES_PER_SAMPLE / rate
    for d in durations:
        n = d * rate
        if n * VCA_BYTES_PER_SAMPLE > budget:
            share = (f"{size_words(total)} of memory / {at_once} local workers" if at_once > 1
                     else "this machine's memory")
            raise click.BadParameter(
                f"{d:g}: a {d:g}-s run is {n:.3g} samples at {rate:g} Hz and needs about "
                f"{size_words(n * VCA_BYTES_PER_SAMPLE)} of memory ({VCA_BYTES_PER_SAMPLE} bytes "
                f"per sample); one run may use {size_words(budget)} ({share}): give run lengths "
                f"of at most {math.floor(max_s):d} s", param_hint="'--durations'")


@click.command(epilog="Example: leakdiag sensitivity vca --quick --scheduler serial -o sens/")
@click.argument("system", type=click.Choice(["vca", "eha", "all"]))
@click.option("--quick", is_flag=True, help="Short experiments, two leak sizes, one seed.")
@click.option("--leaks", default=None, help="Leak sizes in L/min, e.g. 0.047,0.1,0.5.")
@click.option("--seeds", default=None, help="Seeds, e.g. 1,2,3.")
@click.option("--durations", default=None,
              help="Run lengths in s of the VCA's experiments, e.g. 300,400,600 (the EHA's are "
                   "fixed: 180 s, 40 s with --quick; refused for eha). A run must fit in memory: "
                   f"about {VCA_BYTES_PER_SAMPLE} bytes per sample at 1000 Hz, within this "
                   "machine's memory divided by the local workers running at once.")
@click.option("--loads", default=None, help="Loads: spring,none (either or both).")
@scheduler_option()
@workers_option
@click.option("--cache-dir", type=click.Path(file_okay=False), default=None,
              help="Simulation cache (default $LEAKDIAG_CACHE or ~/.cache/leakdiag); "
                   "created and checked writable before the experiments run.")
@click.option("--no-progress", is_flag=True, help="Hide the progress bar.")
@click.option("--out", "-o", type=click.Path(file_okay=False), default=None,
              help="Folder for sensitivity.csv, sensitivity_summary.csv and one figure per "
                   "system, sensitivity_vca.png and/or sensitivity_eha.png (created before the "
                   "experiments run). These files of an earlier run are replaced: its figure of "
                   "a system this run does not measure is removed, other files are kept.")
def sensitivity(system, quick, leaks, seeds, durations, loads, scheduler, workers, cache_dir,
                no_progress, out):
    """Run case study 3 on the simulator(s) and print the range of % change per method."""
    from leakdiag.runtime.cache import prepare_cache_dir
    from leakdiag.studies.protocol import FULL, QUICK
    from leakdiag.studies.sensitivity import run_sensitivity

    # every option is checked here, before the first experiment: none fails late
    check_workers(scheduler, workers)
    systems = SYSTEMS if system == "all" else (system,)
    cfg = QUICK if quick else FULL
    changes = {"cache_dir": cache_dir}
    if leaks is not None:
        vals = list_option_values("--leaks", leaks, float, "0.047,0.1,0.5",
                                  lambda v: math.isfinite(v) and v >= 0,
                                  "a leak size must be a finite number of L/min >= 0 (0: no leak)")
        changes.update(vca_sensitivity_lpm=vals, eha_sensitivity_lpm=vals)
    if seeds is not None:
        changes["sensitivity_seeds"] = list_option_values("--seeds", seeds, int, "1,2,3",
                                                          lambda v: v >= 0, "a seed must be >= 0")
    if durations is not None:
        if system == "eha":
            raise click.UsageError(
                f"--durations sets the VCA's run lengths only; the EHA's case-study-3 runs last "
                f"{cfg.eha_sensitivity_duration_s:g} s{' with --quick' if quick else ''}: drop "
                "--durations for eha")
        changes["vca_sensitivity_durations_s"] = list_option_values(
            "--durations", durations, float, "300,400,600",
            lambda v: math.isfinite(v) and v > 0, "a run length must be a finite number of s > 0")
        _check_run_memory(changes["vca_sensitivity_durations_s"], scheduler, workers)
    if loads is not None:
        changes["loads"] = list_option_values("--loads", loads, str, "spring,none",
                                              lambda v: v in LOADS,
                                              f"a load must be one of {', '.join(LOADS)}")
    cfg = dataclasses.replace(cfg, **changes)
    prepare_cache_dir(cache_dir, "--cache-dir")  # as --out: said now, not after a simulation
    o = prepare_out_dir(out) if out else None  # a folder that cannot be written: said now
    rows, summary = run_sensitivity(systems, cfg, scheduler=scheduler, n_workers=workers,
                                    progress=not no_progress)
    click.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    if o is not None:
        _write(o, rows, summary)


def _write(o, rows, summary) -> None:
    """Write the tables and one figure per system measured, remove this command's figures of
    an earlier run for other systems (they would sit beside tables without their rows), and
    say exactly which files were written and removed."""
    from leakdiag.report.figures import save_figure
    from leakdiag.report.study_plots import plot_sensitivity

    rows.to_csv(o / "sensitivity.csv", index=False)
    summary.to_csv(o / "sensitivity_summary.csv", index=False)
    written = ["sensitivity.csv", "sensitivity_summary.csv"]
    for s, g in rows.groupby("system"):
        save_figure(plot_sensitivity(g, s, summary[summary.system == s]),
                    o / f"sensitivity_{s}.png")
        written.append(f"sensitivity_{s}.png")
    stale = [o / f"sensitivity_{s}.png" for s in SYSTEMS
             if f"sensitivity_{s}.png" not in written and (o / f"sensitivity_{s}.png").is_file()]
    for p in stale:
        p.unlink()
    click.echo(f"wrote {o}/: {', '.join(written)}")
    if stale:
        click.echo(f"removed {', '.join(p.name for p in stale)} from {o}/ (an earlier run's "
                   "figure of a system this run does not measure)")
