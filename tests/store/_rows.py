"""Batch result rows for the store tests, without running a batch (the columns of
:data:`leakdiag.batch.store.RESULT_COLUMNS`; the rest null)."""

import pandas as pd

from leakdiag.batch.store import RESULT_COLUMNS

JOB = "0123456789abcdef"


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
