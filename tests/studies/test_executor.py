"""Tests of the executors: serial and Dask give the same results in input order."""

import pytest

from leakdiag.studies.executor import run_cases


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
