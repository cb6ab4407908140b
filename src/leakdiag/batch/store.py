"""The results dataset: a folder of Parquet files, one per finished recording (resumable).

Each finished recording is written to ``<out>/<key>.parquet`` through a temporary file and an
atomic rename, so a killed run leaves only complete files; a re-run skips every key present.
The key hashes the recording's absolute path and the job digest, so each recording has exactly one
current result file per job; the rows record the SHA-256 of the recording's content
(``recording_sha256``), so an edited recording is computed again and its new rows *replace* the
old ones (issue 15: one current row set per recording, never an old and a new one side by side). The
rows also record the code that computed them (``code_fingerprint``, ``library_versions``:
:func:`leakdiag.batch.runner.code_provenance`), so rows of other code are computed again too,
and replaced. ``pandas.read_parquet(out)`` or :func:`read_results` reads the whole table.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["RESULT_COLUMNS", "result_key", "finished_keys", "finished_state", "write_rows",
           "read_results", "content_hash"]

#: Result columns and their Arrow types (a fixed schema so that all files concatenate).
RESULT_COLUMNS: dict[str, str] = {
    "path": "string", "recording": "string", "status": "string", "error": "string",
    "system": "string",
    "kind": "string", "name": "string", "method": "string", "channels": "string",
    "lag": "int64", "lag_ratio": "string", "window": "int64", "overlap": "float64",
    "sample_rate": "float64", "n_samples": "int64", "duration_s": "float64",
    "n_windows": "int64", "n_degenerate": "int64",
    "value_mean": "float64", "value_std": "float64", "value_min": "float64", "value_max": "float64",
    "onset_s": "float64", "mean_rms_before": "float64", "mean_rms_after": "float64",
    "pct_change": "float64", "pct_change_signed": "float64",
    "score_max": "float64", "alarm": "bool", "alarm_time_s": "float64",
    "threshold": "float64", "p_value": "float64", "alarm_onset_s": "float64",
    "onset_method": "string", "alarm_onset_censored": "bool", "leak_lpm": "float64", "leak_lpm_low": "float64",
    "leak_lpm_high": "float64", "leak_lpm_in_range": "bool",
    "elapsed_s": "float64", "job_digest": "string", "job_config": "string",
    "leakdiag_version": "string", "recording_sha256": "string", "unchecked": "string",
    "code_fingerprint": "string", "library_versions": "string",
    # whole-recording detectors (the flow balance): the smallest leak a NO LEAK would have seen
    # and the verdict in words (size interval, sensitivity), as leakdiag detect prints it
    "detectable_lpm": "float64", "verdict": "string",
    # every leakdiag detector's row: the decision as leakdiag detect makes it (an alarm that a
    # healthy run this long expects by chance is "inconclusive"), the false alarms expected in
    # the run at the level judged at, and a long run's raised level in words; why an alarm
    # is no evidence (an inconclusive decision with an alarm)
    "decision": "string", "false_alarms_expected": "float64", "run_level": "string",
    "why_inconclusive": "string",
    # a whole-recording detector that alarmed and refused its own alarm (no lasting leak after
    # it, a leak fitted into the null offset from the start): judged, inconclusive (``alarm``
    # null, ``error`` says why); a row not judged leaves it null
    "alarm_refused": "bool",
    # the p-value is the smallest the healthy reference resolves (the score above every
    # healthy maximum): the true one may be smaller ("at most")
    "p_value_floor": "bool",
    # what a whole-recording detector's size interval holds, in its words (the flow balance's
    # model error), so that the store says what ``detect`` says, not "prediction interval"
    # (a batch audit, 2026-11-29)
    "leak_lpm_interval_holds": "string",
}


def _schema():
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(),
             "bool": pa.bool_()}
    return pa.schema([(k, types[v]) for k, v in RESULT_COLUMNS.items()])


def result_key(path: str | os.PathLike, job_digest: str) -> str:
    """File key of one recording's results under one job (stable when the file is edited).

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
    return hashlib.sha256(f"{p}|{job_digest}".encode()).hexdigest()[:32]


def content_hash(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, read in 1 MiB blocks ("missing" if it cannot be read).

    Parameters
    ----------
    path : str or path-like
        File.

    Returns
    -------
    str

    Examples
    --------
    >>> content_hash("/nonexistent")
    'missing'
    """
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return "missing"
    return h.hexdigest()


def finished_state(out_dir: str | os.PathLike) -> dict[str, tuple]:
    """Per finished key: the recording's content hash, whether its rows are an error, and the
    code that computed them.

    Parameters
    ----------
    out_dir : str or path-like
        Results folder (may not exist yet).

    Returns
    -------
    dict
        ``key -> (recording_sha256 or None, is_error, code_fingerprint or None,
        library_versions or None)`` (None: rows written before these columns existed).
    """
    import pyarrow.parquet as pq

    out = {}
    d = Path(out_dir)
    if not d.is_dir():
        return out
    for p in d.glob("*.parquet"):
        if p.name.startswith((".", "_")):
            continue
        names = set(pq.read_schema(p).names)
        cols = [c for c in ("recording_sha256", "status", "code_fingerprint",
                            "library_versions") if c in names]
        t = pq.read_table(p, columns=cols).to_pydict()
        first = {c: (t.get(c) or [None])[0] for c in cols}
        out[p.stem] = (first.get("recording_sha256"), "error" in (t.get("status") or []),
                       first.get("code_fingerprint"), first.get("library_versions"))
    return out


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
    tables = []
    for p in files:
        t = pq.read_table(p)
        for name in _schema().names:  # files of older versions lack new columns
            if name not in t.column_names:
                t = t.append_column(name, pa.nulls(len(t), _schema().field(name).type))
        tables.append(t.select(_schema().names).cast(_schema()))
    table = pa.concat_tables(tables) if tables else _schema().empty_table()
    df = table.to_pandas()
    order = ["path", "kind", "name", "method", "channels", "lag", "lag_ratio", "window", "overlap"]
    return df.sort_values(order, na_position="first", kind="stable").reset_index(drop=True)
