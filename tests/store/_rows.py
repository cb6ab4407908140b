"""Shared helpers of the store tests (and of the dashboard's store tests): chunk summaries, batch
result rows without running a batch (the columns of :data:`leakdiag.batch.store.RESULT_COLUMNS`;
the rest null), the environment of a writer child process, and a store of an older schema
version upgraded by a writer."""

import os
import sqlite3
from pathlib import Path

import pandas as pd

from leakdiag.batch.store import RESULT_COLUMNS
from leakdiag.store import AlarmRecord, ChunkSummary, EventStore

JOB = "0123456789abcdef"
#: The source folder, put first on a child process's PYTHONPATH.
SRC = str(Path(__file__).resolve().parents[2] / "src")
#: Why :func:`upgrade_and_write`'s failed run failed.
WHY_FAILED = "b.csv: line 3, channel 'p1': 'x' is not a number"


def child_env():
    """The environment of a child process that imports this checkout's leakdiag."""
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}


def summary(i, alarm=None):
    """Chunk ``i``'s summary: windows from ``i`` s to ``i + 0.5`` s, 3 windows of which 1
    degenerate, value mean ``0.1 i`` (min -1, max 1, last 0.5), score max ``2 i``."""
    return ChunkSummary(float(i), float(i) + 0.5, 3, 1, 0.1 * i, -1.0, 1.0, 0.5, 2.0 * i, 1.5,
                        alarm)


def drop_version_5_columns(con) -> None:
    """Drop the columns schema version 5 added (``alarms.leak_extrapolated``,
    ``alarms.leak_interval``) from an open sqlite3 connection's store."""
    con.execute("alter table alarms drop column leak_extrapolated")
    con.execute("alter table alarms drop column leak_interval")


def downgrade(db, version):
    """Make the SQLite store ``db`` a store of schema ``version`` (1 to 4), as an older leakdiag
    wrote it."""
    con = sqlite3.connect(db)
    if version < 5:
        drop_version_5_columns(con)
    if version < 3:
        con.execute("alter table alarms drop column onset_censored")
    if version < 2:
        con.execute("alter table runs drop column error")
    con.execute(f"update schema_version set version = {version}")
    con.commit()
    con.close()


def upgrade_and_write(db, version):
    """Open the store ``db`` of schema ``version`` as a writer in another process would (it is
    upgraded to 5, with its warning) and write what the columns added since show: rigA a
    ``detect`` alarm with a censored onset (4.85 s), rigB a failed ``batch`` run with its
    reason (:data:`WHY_FAILED`)."""
    import pytest

    with pytest.warns(UserWarning, match=f"upgraded from schema version {version} to 5"):
        writer = EventStore(db)
    run = writer.start_run("rigA", command="detect", source="a.parquet", feature="fb")
    writer.add_chunk(run, None, [AlarmRecord(7.1, onset_s=4.85, onset_censored=True)])
    writer.end_run(run)
    bad = writer.start_run("rigB", command="batch", source="b.csv", feature="acf")
    writer.end_run(bad, "failed", WHY_FAILED)
    writer.close()


def row(path, kind="detector", name="det", alarm=None, alarm_time_s=None, system="vca",
        status="ok", error=None, leak_lpm=None, onset_s=None, sha="sha-1", n_windows=631):
    """One result row of recording ``path`` (a detector row unless ``kind='analysis'``)."""
    r = dict.fromkeys(RESULT_COLUMNS)
    r.update(path=str(path), recording=str(path).rsplit("/", 1)[-1], status=status,
             error=error, kind=kind, name=name, system=system, sample_rate=1000.0,
             n_samples=120000, duration_s=120.0, n_windows=n_windows, n_degenerate=0,
             value_mean=0.5, value_min=0.1, value_max=0.9, job_digest=JOB,
             recording_sha256=sha)
    if kind == "detector" and status == "ok":
        r.update(alarm=alarm, alarm_time_s=alarm_time_s, score_max=40.0, threshold=33.22,
                 alarm_onset_s=onset_s, leak_lpm=leak_lpm,
                 leak_lpm_low=None if leak_lpm is None else leak_lpm / 2,
                 leak_lpm_high=None if leak_lpm is None else leak_lpm * 2)
    return r


def frame(rows):
    """The rows as :func:`leakdiag.batch.read_results` gives them."""
    return pd.DataFrame(rows, columns=list(RESULT_COLUMNS))


def fleet_rows(n_folders=4, per_folder=3):
    """``n_folders`` actuators (folders rig0, rig1, ...) of ``per_folder`` recordings each,
    an analysis and a detector row per recording; the last recording of every folder leaks."""
    rows = []
    for f in range(n_folders):
        for k in range(per_folder):
            p = f"/data/rig{f}/run{k}.parquet"
            leak = k == per_folder - 1
            rows.append(row(p, kind="analysis", name="autocorrelation p1 1 N=200 5%"))
            rows.append(row(p, alarm=leak, alarm_time_s=64.229 if leak else None,
                            onset_s=60.1 if leak else None))
    return frame(rows)
