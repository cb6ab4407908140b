"""Tests of the one executor: serial and Dask give the same results in input order; a failed
case stops the run, or becomes its result through on_error (the batch runner's setting)."""

import math
import os

import pytest

from leakdiag.runtime.executor import run_cases


def square_plus_seed(cfg):
    return cfg["x"] ** 2 + cfg["seed"]


CONFIGS = [{"x": x, "seed": s} for x, s in [(3, 1), (-2, 0), (5, 7), (0, 2)]]


def test_serial_order_and_configs():
    out = run_cases(square_plus_seed, CONFIGS, progress=False)
    assert [c.result for c in out] == [10, 4, 32, 2]
    assert [c.config for c in out] == CONFIGS
    assert all(c.elapsed_s >= 0 for c in out)


def test_dask_local_equals_serial():
    serial = run_cases(square_plus_seed, CONFIGS, progress=False)
    dask = run_cases(square_plus_seed, CONFIGS, scheduler="local", n_workers=1, progress=False)
    assert [c.result for c in dask] == [c.result for c in serial]
    assert [c.config for c in dask] == CONFIGS


def test_bad_scheduler():
    with pytest.raises(ValueError, match="scheduler='fast' must be"):
        run_cases(square_plus_seed, CONFIGS, scheduler="fast")


def fails_on_negative(cfg):
    if cfg["x"] < 0:
        raise ArithmeticError(f"x={cfg['x']}")
    return cfg["x"] ** 2 + cfg["seed"]


def as_failure(cfg, exc):
    return f"failed: {type(exc).__name__}: {exc}"


def test_a_failed_case_stops_the_run_by_default():
    with pytest.raises(ArithmeticError, match="x=-2"):
        run_cases(fails_on_negative, CONFIGS, progress=False)


@pytest.mark.parametrize("scheduler", ["serial", pytest.param("local", marks=pytest.mark.slow)])
def test_on_error_turns_a_failed_case_into_its_result(scheduler):
    seen = []
    out = run_cases(fails_on_negative, CONFIGS, scheduler=scheduler, n_workers=1, progress=False,
                    on_result=seen.append, on_error=as_failure)
    assert [c.result for c in out] == [10, "failed: ArithmeticError: x=-2", 32, 2]
    assert math.isnan(out[1].elapsed_s) and not math.isnan(out[0].elapsed_s)
    # on_result saw every case once, as it finished (input order when serial)
    assert sorted(c.config["x"] for c in seen) == [-2, 0, 3, 5]
    if scheduler == "serial":
        assert seen == out


def test_no_cases_no_cluster():
    assert run_cases(square_plus_seed, [], scheduler="local", progress=False) == []


@pytest.mark.parametrize("n, exc, message", [
    (0, ValueError, "n_workers=0 must be >= 1 (--workers at the command line): a local Dask "
                    "cluster without workers never runs a case"),
    (-1, ValueError, "n_workers=-1 must be >= 1 (--workers at the command line): a local Dask "
                     "cluster without workers never runs a case"),
    (2.5, TypeError, "n_workers=2.5 must be an integer >= 1 (--workers at the command line)"),
    (True, TypeError, "n_workers=True must be an integer >= 1 (--workers at the command line)"),
])
def test_a_cluster_without_workers_is_refused_before_it_starts(monkeypatch, n, exc, message):
    """Audit 2026-11-27: LocalCluster(n_workers=0 or -1) waited at 0 % until killed."""
    import leakdiag.runtime.executor as ex

    monkeypatch.setattr(ex, "_run_dask", lambda *a: pytest.fail("a cluster was started"))
    for scheduler in ("local", "serial"):  # refused whatever the scheduler: never a valid count
        with pytest.raises(exc) as info:
            run_cases(square_plus_seed, CONFIGS, scheduler=scheduler, n_workers=n,
                      progress=False)
        assert str(info.value) == message


def test_our_local_workers_are_quietened_before_the_cluster_closes(capfd, monkeypatch,
                                                                   tmp_path):
    """A docs audit (2026-11-29): at load 3, one in three ``batch`` runs printed a worker's
    "Failed to communicate with scheduler during heartbeat" traceback after its results. Once
    the cases are done, our own workers' ``distributed`` loggers go to CRITICAL
    (``_quiet_shutdown``, run on each of the 2 workers: checked by a stand-in that leaves one
    file per worker process); the run itself prints nothing from Dask."""
    import logging

    import leakdiag.runtime.executor as ex

    logger = logging.getLogger("distributed")
    before = logger.level
    try:
        ex._quiet_shutdown()
        assert logger.level == logging.CRITICAL
    finally:
        logger.setLevel(before)
    marks = tmp_path / "marks"
    marks.mkdir()

    def mark():  # pickled by value: runs in the worker processes
        import os

        (marks / str(os.getpid())).touch()

    monkeypatch.setattr(ex, "_quiet_shutdown", mark)
    out = run_cases(square_plus_seed, CONFIGS, scheduler="local", n_workers=2, progress=False)
    assert [c.result for c in out] == [square_plus_seed(c) for c in CONFIGS]
    pids = {int(p.name) for p in marks.iterdir()}
    assert len(pids) == 2 and os.getpid() not in pids
    err = capfd.readouterr().err
    assert "Traceback" not in err and "distributed.worker - ERROR" not in err
