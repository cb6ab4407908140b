"""The results dataset: a folder of Parquet files, one per finished recording (resumable).

Each finished recording is written to ``<out>/<key>.parquet`` through a temporary file and an
atomic rename, so a killed run leaves only complete files; a re-run skips every key present.
The key hashes the recording's absolute path, size and modification time and the job digest, so
an edited recording or a changed job is computed again. ``pandas.read_parquet(out)`` or
:func:`read_results` reads the whole table.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["RESULT_COLUMNS", "result_key", "finished_keys", "write_rows", "read_results"]

#: Result columns and their Arrow types (a fixed schema so that all files concatenate).
RESULT_COLUMNS: dict[str, str] = {
    "path": "string", "recording": "string", "status": "string", "error": "string",
    "kind": "string", "name": "string", "method": "string", "channels": "string",
    "lag": "int64", "lag_ratio": "string", "window": "int64", "overlap": "float64",
    "sample_rate": "float64", "n_samples": "int64", "duration_s": "float64",
    "n_windows": "int64", "n_degenerate": "int64",
    "value_mean": "float64", "value_std": "float64", "value_min": "float64", "value_max": "float64",
    "onset_s": "float64", "mean_rms_before": "float64", "mean_rms_after": "float64",
    "pct_change": "float64", "pct_change_signed": "float64",
    "score_max": "float64", "alarm": "bool", "alarm_time_s": "float64",
    "elapsed_s": "float64", "job_digest": "string", "job_config": "string",
    "leakdiag_version": "string",
}


def _schema():
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(),
             "bool": pa.bool_()}
    return pa.schema([(k, types[v]) for k, v in RESULT_COLUMNS.items()])


def result_key(path: str | os.PathLike, job_digest: str) -> str:
    """File key of one recording's results under one job.

    Parameters
    ----------
    path : str or path-like
        Recording file.
    job_digest : str
        :attr:`BatchConfig.digest`.

    Returns
    -------
    str
        32 hex digits.

    Examples
    --------
    >>> len(result_key("/nonexistent.parquet", "abc"))
    32
    """
    p = os.path.abspath(os.fspath(path))
    try:
        st = os.stat(p)
        stamp = f"{st.st_size}:{st.st_mtime_ns}"
    except OSError:
        stamp = "missing"
    return hashlib.sha256(f"{p}|{stamp}|{job_digest}".encode()).hexdigest()[:32]


def finished_keys(out_dir: str | os.PathLike) -> set[str]:
    """Keys of the recordings already finished in ``out_dir``.

    Parameters
    ----------
    out_dir : str or path-like
        Results folder (may not exist yet).

    Returns
    -------
    set of str
    """
    d = Path(out_dir)
    if not d.is_dir():
        return set()
    return {p.stem for p in d.glob("*.parquet") if not p.name.startswith((".", "_"))}


def write_rows(rows: list[dict], out_dir: str | os.PathLike, key: str) -> Path:
    """Write one recording's rows atomically as ``<out_dir>/<key>.parquet``.

    Parameters
    ----------
    rows : list of dict
        Result rows (keys of :data:`RESULT_COLUMNS`; missing ones become null).
    out_dir : str or path-like
        Results folder (created if needed).
    key : str
        :func:`result_key` of the recording.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    cols = {k: [r.get(k) for r in rows] for k in RESULT_COLUMNS}
    table = pa.Table.from_pydict(cols, schema=_schema())
    final = d / f"{key}.parquet"
    tmp = d / f".{key}.{os.getpid()}.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, final)
    return final


def read_results(out_dir: str | os.PathLike):
    """All finished rows of a results folder as a DataFrame (sorted by path, kind, name, method).

    Parameters
    ----------
    out_dir : str or path-like
        Results folder.

    Returns
    -------
    pandas.DataFrame
        Columns of :data:`RESULT_COLUMNS`; empty if nothing is finished.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    files = sorted(p for p in Path(out_dir).glob("*.parquet") if not p.name.startswith((".", "_")))
    tables = [pq.read_table(p, schema=_schema()) for p in files]
    table = pa.concat_tables(tables) if tables else _schema().empty_table()
    df = table.to_pandas()
    order = ["path", "kind", "name", "method", "channels", "lag", "lag_ratio", "window", "overlap"]
    return df.sort_values(order, na_position="first", kind="stable").reset_index(drop=True)
