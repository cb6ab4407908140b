"""``leakdiag batch`` (and ``monitor``, ``detect`` where they share it) after the batch/store
audit of 2026-11-27: --store values that cannot be a store (finding 10)."""

import os

import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca


def _run(args, cwd=None):
    """``leakdiag ARGS`` through the entry point: exit code, stdout, stderr."""
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with CliRunner().isolation() as (out, err, _):
            code = main([str(a) for a in args])
            return code, out.getvalue().decode(), err.getvalue().decode()
    finally:
        os.chdir(old)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """A detector fitted with ``leakdiag fit`` on two healthy 20-s VCA runs (acf-p1, Pa, rig
    vca, load none) and a 30-s leaking VCA recording."""
    d = tmp_path_factory.mktemp("batchaudit")
    h = [write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=s),
                         d / f"h{s}.parquet") for s in (1, 2)]
    code, out, err = _run(["fit", "--healthy", h[0], "--healthy", h[1], "-m", "acf-p1",
                           "--false-alarm-rate", "100", "--no-progress", "-o",
                           d / "det.joblib"])
    assert code == 0, err
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=3)
    (d / "rigL").mkdir()
    write_recording(leak, d / "rigL" / "leak.parquet")
    (d / "job.toml").write_text('[[detector]]\nname = "acf"\npath = "det.joblib"\n')
    return {"dir": d, "det": d / "det.joblib", "leak": leak,
            "leak_path": d / "rigL" / "leak.parquet"}


def _batch(case, inputs, tmp_path, *extra, job=None):
    return _run(["batch", *inputs, "--config", job or case["dir"] / "job.toml", "-o",
                 tmp_path / "res", "--scheduler", "serial", "--no-progress", *extra])


@pytest.mark.parametrize("store, why", [
    ("", "--store needs a file path or a database URL, got ''"),
    ("sqlite:///", "--store sqlite:///: an in-memory SQLite database ends with the connection "
                   "that made it: nothing would be kept, and every other connection (the page, "
                   "another command) sees an empty one; give a file, e.g. --store events.db"),
    ("sqlite:/x.db", "--store sqlite:/x.db: looks like a database URL, but a URL needs '//' "
                     "after 'sqlite:' (sqlite:///events.db is the file events.db, "
                     "sqlite:////data/events.db an absolute path); for a file of this name "
                     "write ./sqlite:/x.db"),
])
def test_store_values_that_cannot_be_a_store_are_refused_before_the_work(case, tmp_path,
                                                                         store, why):
    """Finding 10: 'sqlite:///' made batch do all the work, then crash ("no such table:
    runs"), detect write into a vanishing database and monitor say "empty database"; '' was
    ignored by batch and detect; 'sqlite:/x.db' became a file 'sqlite%3A/x.db'."""
    code, out, err = _batch(case, [case["leak_path"]], tmp_path, "--store", store)
    assert (code, out, err) == (2, "", f"leakdiag: error: {why}\n")
    assert not (tmp_path / "res").exists()
    code, out, err = _run(["detect", case["leak_path"], "--detector", case["det"], "--store",
                           store], cwd=tmp_path)
    assert code == 2 and out == "" and err.endswith(f"leakdiag: error: {why}\n")
    code, out, err = _run(["monitor", case["leak_path"], "--detector", case["det"],
                           "--store", store], cwd=tmp_path)
    assert code == 2 and out == "" and err.endswith(f"leakdiag: error: {why}\n")
    assert sorted(os.listdir(tmp_path)) == []  # no file of any name