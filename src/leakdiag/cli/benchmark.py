"""``leakdiag benchmark``: the detection benchmark (suite v5 by default; v4 on request) and the
literature comparison of ``docs/literature.md`` (``--suite comparison``)."""

from __future__ import annotations

from pathlib import Path

import click
from click.core import ParameterSource

from leakdiag.cli._options import check_workers, scheduler_option, workers_option

__all__ = ["benchmark"]


def _command_line() -> str:
    """The command as given (options that differ from their defaults), for the report."""
    ctx = click.get_current_context()
    parts = ["leakdiag", ctx.info_name or "benchmark"]
    for p in ctx.command.params:
        v = ctx.params.get(p.name)
        if v is None or v is False or v == p.default:
            continue
        flag = max(p.opts, key=len)
        parts += [flag] if v is True else [flag, str(v)]
    return " ".join(parts)


@click.command("benchmark", epilog="Example: leakdiag benchmark --quick -o bench/")
@click.option("-o", "--out", "out_dir", default=None, type=click.Path(file_okay=False),
              help="Output folder of the report; files an earlier benchmark run wrote there "
                   "and this run did not rewrite are removed after it, nothing else (v5, v4; "
                   "--suite comparison rewrites its four files and removes nothing).")
@click.option("--suite", default="v5", show_default=True,
              type=click.Choice(["v5", "v4", "comparison"]),
              help="v5: training and test units disjoint, >= 300 calibration, 1000 held-out "
                   "healthy and 50 leaking runs per size per load; v4: the former suite; "
                   "comparison: the literature comparison of docs/literature.md (VCA, both "
                   "excitations, its 10 methods; writes runs.csv, results.csv, summary.csv, "
                   "table.md).")
@click.option("--quick", is_flag=True, help="Small CI suite: short runs, few seeds, large leaks.")
@click.option("--methods", default=None, help="Comma-separated method names (default: all).")
@click.option("--systems", default=None, help="Comma-separated rigs (vca, eha).")
@click.option("--loads", default=None, help="v5: comma-separated loads (none, spring).")
@click.option("--sizes", default=None,
              help="v5: comma-separated leak sizes (L/min), each one of every selected rig's "
                   "suite; their runs keep the whole suite's seeds.")
@click.option("--excitations", default=None,
              help="Comma-separated excitation conditions (operating, structured).")
@click.option("--n-cal", default=None, type=click.IntRange(min=1),
              help="v5: calibration runs per group (mid-size variants; same seeds).")
@click.option("--n-healthy", "n_test_healthy", default=None, type=click.IntRange(min=1),
              help="v5: held-out healthy runs per group.")
@click.option("--n-leak", "n_test_leak", default=None, type=click.IntRange(min=1),
              help="v5: leaking runs per size and group.")
@click.option("--first-index", default=None, type=click.IntRange(min=0),
              help="v5: first index of the held-out runs of each role and size (a fresh block "
                   "of seeds for a final measurement: indexes 0-999 healthy and 0-49 leaking "
                   "are the suite's, which development has seen).")
@click.option("--unit-fit", default=0, show_default=True, type=click.IntRange(min=0),
              help="v5: fit every unit on N of its own healthy runs, threshold from the training "
                   "units' reference maxima (0: one fit on the training units for all).")
@click.option("--full-budget", is_flag=True,
              help="v5: run EMD and the EKF on the suite's full run counts too (default: 100 "
                   "calibration, 100 healthy and 10 leaking runs per size for those two).")
@click.option("--max-test-runs", default=None, type=click.IntRange(min=1),
              help="v4 only: at most N held-out healthy and leaking runs per size per group.")
@click.option("--n-fit", default=None, type=click.IntRange(min=1),
              help="comparison only: healthy fitting runs per excitation, one CUSUM maximum "
                   "each for the threshold (default 19, the fewest that support its 5 % "
                   "target).")
@click.option("--false-alarm-rate", "far", default=None, type=click.FloatRange(0, 1, min_open=True,
                                                                               max_open=True),
              help="Target false-alarm probability per healthy run (default 0.01; --quick: v5 "
                   "0.05, v4 0.12, what its 8 fitting runs support; --suite comparison: 0.05, "
                   "what its 19 fitting runs per excitation support).")
@click.option("--confidence", default=None, type=click.FloatRange(0, 1, min_open=True,
                                                                  max_open=True),
              help="v5: calibration-conditional thresholds: each fitted level holds the target "
                   "with this probability over its healthy data (e.g. 0.95; needs 299 maxima "
                   "for 1 %). Default: the marginal conformal rank.")
@click.option("--onset-method", "onset_method", default="binseg", show_default=True,
              type=click.Choice(["binseg", "pelt", "cusum"]), help="Onset estimator.")
@scheduler_option(default="serial")
@workers_option
@click.option("--cache-dir", default=None, type=click.Path(file_okay=False),
              help="Simulation cache (default $LEAKDIAG_CACHE or ~/.cache/leakdiag).")
@click.option("--work-dir", default=None, type=click.Path(file_okay=False),
              help="v5: resumable state (fits, result shards); default <cache>/bench-v5.")
@click.option("--list-methods", is_flag=True, help="Print the registered methods and exit.")
@click.option("--no-progress", is_flag=True, help="No progress bars.")
def benchmark(out_dir, suite, quick, methods, systems, loads, sizes, excitations, n_cal,
              n_test_healthy, n_test_leak, first_index, unit_fit, full_budget, max_test_runs,
              n_fit, far, confidence, onset_method, scheduler, workers, cache_dir, work_dir,
              list_methods, no_progress):
    """Run the detection benchmark and write its report to --out (--suite comparison: the
    literature comparison's tables)."""
    from leakdiag.bench.registry import METHODS

    if list_methods:
        click.echo("\n".join(sorted(METHODS)))
        return
    if out_dir is None:
        raise click.UsageError("--out DIR is required")
    check_workers(scheduler, workers)  # ignored otherwise: refused before any folder is made
    split = lambda s: [v.strip() for v in s.split(",") if v.strip()] if s else None  # noqa: E731
    command = _command_line()
    ctx = click.get_current_context()

    def given_of(options):
        return [flag for name, flag in options if ctx.get_parameter_source(name)
                not in (None, ParameterSource.DEFAULT)]

    if suite == "comparison":
        _comparison(given_of(_NOT_COMPARISON), out_dir, n_fit, far, scheduler, workers,
                    cache_dir, no_progress)
        return
    if n_fit is not None:
        raise click.UsageError("--n-fit is for --suite comparison only")
    given = given_of(_V5_ONLY)
    if suite == "v4" and given:
        raise click.UsageError(f"{', '.join(given)} {'is' if len(given) == 1 else 'are'} for "
                               "--suite v5 only")
    if suite == "v5":
        from leakdiag.bench.v5_report import console_table, failure_warnings, run_benchmark_v5
        from leakdiag.bench.v5_run import work_lines

        if max_test_runs is not None:
            raise click.UsageError("--max-test-runs is for --suite v4; use --n-healthy/--n-leak")
        size_list = None
        if sizes is not None:
            try:
                size_list = [float(x) for x in split(sizes) or []]
            except ValueError:
                raise click.UsageError(f"--sizes {sizes!r}: not a comma-separated list of leak "
                                       "sizes in L/min (e.g. 0.005,0.02)") from None
            if not size_list:
                raise click.UsageError("--sizes: no size given")
        try:
            res = run_benchmark_v5(out_dir, quick=quick, methods=split(methods),
                                   systems=split(systems), excitations=split(excitations),
                                   loads=split(loads), false_alarm_per_run=far, n_cal=n_cal,
                                   n_test_healthy=n_test_healthy, n_test_leak=n_test_leak,
                                   onset_method=onset_method, scheduler=scheduler,
                                   n_workers=workers, cache_dir=cache_dir, work_dir=work_dir,
                                   progress=not no_progress, command=command,
                                   unit_fit=unit_fit, full_budget=full_budget,
                                   confidence=confidence, first_index=first_index,
                                   sizes=size_list)
        except ValueError as exc:
            raise click.UsageError(str(exc)) from None
        _echo_removed(res["removed"], out_dir)
        for line in work_lines(res["settings"]["work"]):
            click.echo(line)
        for line in failure_warnings(res["fits"], res["runs"], Path(out_dir)):
            click.echo(f"leakdiag: warning: {line}", err=True)
        click.echo(console_table(res["summary"], res["detection"]))
        click.echo(f"report: {res['paths']['report']}")
        return
    from leakdiag.bench.benchmark import console_table_v4, run_benchmark

    try:
        res = run_benchmark(out_dir, quick=quick, methods=split(methods), systems=split(systems),
                            excitations=split(excitations), max_test_runs=max_test_runs,
                            false_alarm_per_run=far, onset_method=onset_method,
                            scheduler=scheduler, n_workers=workers, cache_dir=cache_dir,
                            progress=not no_progress, command=command)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    _echo_removed(res.removed, out_dir)
    click.echo(console_table_v4(res.summary, res.results))
    click.echo(f"report: {res.paths['html']}")


#: Options of suite v5 only (parameter name, flag): refused with --suite v4.
_V5_ONLY = (("loads", "--loads"), ("sizes", "--sizes"), ("n_cal", "--n-cal"),
            ("n_test_healthy", "--n-healthy"), ("n_test_leak", "--n-leak"),
            ("first_index", "--first-index"), ("unit_fit", "--unit-fit"),
            ("full_budget", "--full-budget"), ("confidence", "--confidence"),
            ("work_dir", "--work-dir"))


#: Options that do not apply to --suite comparison (parameter name, flag): refused with it.
_NOT_COMPARISON = (("quick", "--quick"), ("methods", "--methods"), ("systems", "--systems"),
                   ("loads", "--loads"), ("sizes", "--sizes"), ("excitations", "--excitations"),
                   ("n_cal", "--n-cal"),
                   ("n_test_healthy", "--n-healthy"), ("n_test_leak", "--n-leak"),
                   ("first_index", "--first-index"), ("unit_fit", "--unit-fit"),
                   ("full_budget", "--full-budget"), ("max_test_runs", "--max-test-runs"), ("confidence", "--confidence"),
                   ("onset_method", "--onset-method"), ("work_dir", "--work-dir"))


def _comparison(given, out_dir, n_fit, far, scheduler, workers, cache_dir,
                no_progress) -> None:
    """--suite comparison: refuse the options it has no use for, then run and write it
    (:func:`leakdiag.bench.comparison.write_comparison`; its target check comes before any
    folder) and print its table."""
    from leakdiag.bench.comparison import COMPARISON_FAR, COMPARISON_N_FIT, write_comparison

    if given:
        raise click.UsageError(f"{', '.join(given)} {'does' if len(given) == 1 else 'do'} not "
                               "apply to --suite comparison")
    try:
        table = write_comparison(
            out_dir, false_alarm_per_run=COMPARISON_FAR if far is None else far,
            n_fit=COMPARISON_N_FIT if n_fit is None else n_fit, scheduler=scheduler,
            n_workers=workers, cache_dir=cache_dir, progress=not no_progress)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    click.echo(table.to_string(index=False))


def _echo_removed(removed, out_dir) -> None:
    """Say which files of an earlier run were removed from --out (none: nothing said)."""
    if removed:
        click.echo(f"removed from {out_dir} the {len(removed)} file(s) an earlier benchmark "
                   f"run wrote there: {', '.join(removed)}")
