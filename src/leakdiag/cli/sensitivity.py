"""``leakdiag sensitivity``: case study 3, % change against leak size for every method."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import click

from leakdiag.cli._options import scheduler_option

__all__ = ["sensitivity"]


@click.command(epilog="Example: leakdiag sensitivity vca --quick --scheduler serial -o sens/")
@click.argument("system", type=click.Choice(["vca", "eha", "all"]))
@click.option("--quick", is_flag=True, help="Short experiments, two leak sizes, one seed.")
@click.option("--leaks", default=None, help="Leak sizes in L/min, e.g. 0.047,0.1,0.5.")
@click.option("--seeds", default=None, help="Seeds, e.g. 1,2,3.")
@click.option("--durations", default=None, help="Experiment lengths in s (VCA), e.g. 300,400,600.")
@click.option("--loads", default=None, help="Loads: spring,none.")
@scheduler_option()
@click.option("--workers", type=int, default=None, help="Workers of the local cluster.")
@click.option("--cache-dir", type=click.Path(file_okay=False), default=None,
              help="Simulation cache (default $LEAKDIAG_CACHE or ~/.cache/leakdiag).")
@click.option("--no-progress", is_flag=True, help="Hide the progress bar.")
@click.option("--out", "-o", type=click.Path(file_okay=False), default=None,
              help="Folder for sensitivity.csv, sensitivity_summary.csv and figures.")
def sensitivity(system, quick, leaks, seeds, durations, loads, scheduler, workers, cache_dir,
                no_progress, out):
    """Run case study 3 on the simulator(s) and print the range of % change per method."""
    from leakdiag.report.figures import save_figure
    from leakdiag.report.study_plots import plot_sensitivity
    from leakdiag.studies.protocol import FULL, QUICK
    from leakdiag.studies.sensitivity import run_sensitivity
    from leakdiag.studies.sweep import parse_values

    systems = ("vca", "eha") if system == "all" else (system,)
    cfg = QUICK if quick else FULL
    changes = {"cache_dir": cache_dir}
    if leaks:
        vals = tuple(parse_values(leaks, float))
        changes.update(vca_sensitivity_lpm=vals, eha_sensitivity_lpm=vals)
    if seeds:
        changes["sensitivity_seeds"] = tuple(parse_values(seeds, int))
    if durations:
        changes["vca_sensitivity_durations_s"] = tuple(parse_values(durations, float))
    if loads:
        changes["loads"] = tuple(parse_values(loads, str))
    cfg = dataclasses.replace(cfg, **changes)
    rows, summary = run_sensitivity(systems, cfg, scheduler=scheduler, n_workers=workers,
                                    progress=not no_progress)
    click.echo(summary.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    if out:
        o = Path(out)
        o.mkdir(parents=True, exist_ok=True)
        rows.to_csv(o / "sensitivity.csv", index=False)
        summary.to_csv(o / "sensitivity_summary.csv", index=False)
        for s, g in rows.groupby("system"):
            save_figure(plot_sensitivity(g, s, summary[summary.system == s]),
                        o / f"sensitivity_{s}.png")
        click.echo(f"wrote {o}/sensitivity.csv, sensitivity_summary.csv, sensitivity_*.png")
