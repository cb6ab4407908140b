"""``leakdiag benchmark``: the detection benchmark (suite, scores, HTML report)."""

from __future__ import annotations

import sys

import click

__all__ = ["benchmark"]


@click.command("benchmark")
@click.option("--out", "out_dir", default=None, type=click.Path(file_okay=False),
              help="Output folder (index.html, results.csv, summary.csv, ...).")
@click.option("--quick", is_flag=True, help="Small CI suite: short runs, few seeds, large leaks.")
@click.option("--methods", default=None,
              help="Comma-separated method names (default: all thesis methods + combined).")
@click.option("--systems", default=None, help="Comma-separated rigs (vca, eha).")
@click.option("--excitations", default=None,
              help="Comma-separated excitation conditions (operating, structured).")
@click.option("--max-test-runs", default=None, type=click.IntRange(min=1),
              help="Reduced suite: at most N held-out healthy runs and N leaking runs per size "
                   "in every group (same seeds as the full suite).")
@click.option("--false-alarm-rate", "far", default=0.01, show_default=True, type=float,
              help="Target false-alarm probability per healthy run.")
@click.option("--onset", "onset_method", default="binseg", show_default=True,
              type=click.Choice(["binseg", "pelt", "cusum"]), help="Onset estimator.")
@click.option("--scheduler", default="serial", show_default=True,
              help="'serial', 'local' (Dask LocalCluster) or a Dask scheduler address.")
@click.option("--workers", "n_workers", default=None, type=int, help="Dask workers.")
@click.option("--cache-dir", default=None, type=click.Path(file_okay=False),
              help="Simulation cache (default $LEAKDIAG_CACHE or ~/.cache/leakdiag).")
@click.option("--list-methods", is_flag=True, help="Print the registered methods and exit.")
@click.option("--no-progress", is_flag=True, help="No progress bars.")
def benchmark(out_dir, quick, methods, systems, excitations, max_test_runs, far, onset_method, scheduler,
              n_workers, cache_dir, list_methods, no_progress):
    """Run the detection benchmark and write its report to --out."""
    from leakdiag.bench.benchmark import run_benchmark
    from leakdiag.bench.registry import METHODS

    if list_methods:
        click.echo("\n".join(sorted(METHODS)))
        return
    if out_dir is None:
        raise click.UsageError("--out DIR is required")
    split = lambda s: [v.strip() for v in s.split(",") if v.strip()] if s else None  # noqa: E731
    res = run_benchmark(out_dir, quick=quick, methods=split(methods), systems=split(systems),
                        excitations=split(excitations), max_test_runs=max_test_runs,
                        false_alarm_per_run=far, onset_method=onset_method, scheduler=scheduler,
                        n_workers=n_workers, cache_dir=cache_dir, progress=not no_progress,
                        command="leakdiag " + " ".join(sys.argv[1:]))
    cols = ["method", "system", "excitation", "min_detectable_lpm", "min_detectable_pct_rated",
            "false_alarm_rate", "cpu_s_per_hour"]
    click.echo(res.summary[cols].to_string(index=False))
    click.echo(f"report: {res.paths['html']}")
