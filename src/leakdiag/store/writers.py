"""Write the results of ``leakdiag batch`` and ``leakdiag detect`` to the event store."""

from __future__ import annotations

import math
import uuid
from pathlib import Path

from leakdiag.store.database import EventStore
from leakdiag.store.summary import AlarmRecord, ChunkSummary

__all__ = ["record_batch", "record_verdicts"]


def _num(v) -> float | None:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _flag(v) -> bool | None:
    """A result cell as a flag, None for a missing one (None, NaN, pandas.NA).

    Examples
    --------
    >>> _flag(True), _flag(0), _flag(float("nan")), _flag(None)
    (True, False, None, None)
    """
    if v is None or (isinstance(v, float) and v != v) or str(v) == "<NA>":
        return None
    return bool(v)


def _text(v) -> str | None:
    """A result cell as text, None for a missing one (None, NaN, pandas.NA, empty)."""
    if v is None or (isinstance(v, float) and v != v) or str(v) in ("", "<NA>", "nan"):
        return None
    return str(v)


#: How ``leakdiag batch --store`` names a recording's actuator.
ACTUATOR_FROM = ("folder", "stem")


def actuator_names(paths, actuator_from: str = "folder") -> dict[str, str]:
    """Actuator of each recording path: its folder's name (one folder per actuator, its runs
    inside) or its file stem (one file per actuator).

    Parameters
    ----------
    paths : iterable of str
        Recording paths.
    actuator_from : {"folder", "stem"}, default "folder"

    Returns
    -------
    dict
        Path to actuator name.

    Raises
    ------
    ValueError
        If ``actuator_from`` is unknown, or two different folders have the same name with
        ``"folder"``, or two files in different folders the same stem with ``"stem"`` (their
        runs would be merged into one actuator).

    Examples
    --------
    >>> actuator_names(["rec/rig1/run1.parquet", "rec/rig2/run1.parquet"])
    {'rec/rig1/run1.parquet': 'rig1', 'rec/rig2/run1.parquet': 'rig2'}
    """
    if actuator_from not in ACTUATOR_FROM:
        raise ValueError(f"actuator_from={actuator_from!r} must be one of {ACTUATOR_FROM}")
    out, seen, folders = {}, {}, {}
    for p in dict.fromkeys(str(x) for x in paths):
        pp = Path(p)
        if actuator_from == "folder":
            folder = pp.resolve().parent
            name = folder.name or "/"
            if folders.setdefault(name, folder) != folder:
                raise ValueError(
                    f"{folders[name]} and {folder} have the same folder name {name!r}: with one "
                    "actuator per folder their runs would be merged into one actuator; rename "
                    "a folder or give the recordings of one of them in another job")
        else:
            name = pp.stem
            if seen.setdefault(name, p) != p:
                raise ValueError(
                    f"{seen[name]} and {p} have the same file stem {name!r}: with one actuator "
                    "per file stem their runs would be merged into one actuator; use "
                    "--actuator-from folder (one folder per actuator) or rename the files")
        out[p] = name
    return out


def record_batch(store: EventStore, results, job_digest: str,
                 actuator_from: str = "folder") -> int:
    """Store the rows of one batch job: a run per recording and row, one summary per row.

    The actuator is the recording's folder name (``actuator_from="folder"``: one folder per
    actuator, its runs inside) or its file stem (``"stem"``; two files of one stem in different
    folders are refused, :func:`actuator_names`). Analysis rows become a summary of the whole
    recording (``t_start_s`` 0, ``t_end_s`` its duration, the row's value statistics); detector
    rows also carry the score maximum, and an alarm at ``alarm_time_s`` when one was raised.
    Error rows become a run with status ``failed``, a detector row that was not judged (no
    alarm value: too short for the burn-in) one with status ``unjudged``. A row already in the
    store (same job, recording path and content, kind and name) is not written again.

    Parameters
    ----------
    store : EventStore
        Open store.
    results : pandas.DataFrame
        :func:`leakdiag.batch.read_results` (all jobs; only ``job_digest`` rows are written).
    job_digest : str
        The job's digest.
    actuator_from : {"folder", "stem"}, default "folder"
        Where the actuator's name comes from.

    Returns
    -------
    int
        Runs written.

    Raises
    ------
    ValueError
        From :func:`actuator_names` (nothing is written then).
    """
    rows = results[results["job_digest"] == job_digest]
    names = actuator_names(rows["path"].astype(str), actuator_from)
    inv = uuid.uuid4().hex
    stored = store.batch_row_keys()
    n = 0
    for r in rows.to_dict("records"):
        actuator = names[str(r["path"])]
        feature = str(r["name"]) if r.get("name") is not None and r["name"] == r["name"] \
            else "batch"
        # one stored run per result row: a re-run of a finished job writes nothing again
        key = "|".join(str(r.get(c)) for c in ("job_digest", "path", "recording_sha256",
                                                "kind", "name"))
        if key in stored:
            continue
        run = store.start_run(actuator, command="batch", source=str(r["path"]), feature=feature,
                              sample_rate_hz=_num(r.get("sample_rate")), invocation=inv,
                              threshold=_num(r.get("threshold")), system=_text(r.get("system")),
                              config={"job_digest": job_digest, "kind": r.get("kind"),
                                      "row": key})
        n += 1
        if r["status"] != "ok":
            store.end_run(run, "failed", _text(r.get("error")))
            continue
        n_win = int(r["n_windows"]) if _num(r.get("n_windows")) is not None else 0
        judged = r.get("kind") == "detector" and r.get("alarm") is not None \
            and r.get("alarm") == r.get("alarm")  # None / NaN: the detector was not judged
        summ = None
        if n_win:
            summ = ChunkSummary(0.0, _num(r.get("duration_s")) or 0.0, n_win,
                                int(_num(r.get("n_degenerate")) or 0), _num(r.get("value_mean")),
                                _num(r.get("value_min")), _num(r.get("value_max")), None,
                                _num(r.get("score_max")), None,
                                bool(r.get("alarm")) if judged else None)
        alarms = []
        if judged and bool(r.get("alarm")) and _num(r.get("alarm_time_s")) is not None:
            alarms.append(AlarmRecord(
                _num(r["alarm_time_s"]), _num(r.get("score_max")), _num(r.get("threshold")),
                _num(r.get("alarm_onset_s")), _num(r.get("leak_lpm")),
                _num(r.get("leak_lpm_low")), _num(r.get("leak_lpm_high")), detector=feature,
                onset_censored=_flag(r.get("alarm_onset_censored"))))
        if summ is not None or alarms:
            store.add_chunk(run, summ, alarms)
        unjudged = r.get("kind") == "detector" and not judged
        store.end_run(run, "unjudged" if unjudged else "finished",
                      _text(r.get("error")) if unjudged else None)
    return n


def record_verdicts(store: EventStore, actuator: str, file: str, table) -> int:
    """Store the verdicts of ``leakdiag detect``: one run per method, an alarm per leak found.

    Parameters
    ----------
    store : EventStore
        Open store.
    actuator : str
        Actuator name.
    file : str
        The judged recording.
    table : pandas.DataFrame
        :func:`leakdiag.cli.detect.verdict_table` (its ``attrs["system"]`` names the rig).

    Returns
    -------
    int
        Alarms written.
    """
    inv = uuid.uuid4().hex
    n = 0
    system = _text(table.attrs.get("system"))
    for r in table.to_dict("records"):
        err = r.get("error")
        failed = isinstance(err, str) and bool(err)
        run = store.start_run(actuator, command="detect", source=str(file), feature=str(r["method"]),
                              threshold=_num(r.get("threshold")), invocation=inv, system=system,
                              config={"method": r["method"]})
        if not failed and bool(r.get("leak")) and _num(r.get("alarm_time_s")) is not None:
            store.add_chunk(run, None, [AlarmRecord(
                _num(r["alarm_time_s"]), _num(r.get("score_max")), _num(r.get("threshold")),
                _num(r.get("onset_s")), _num(r.get("leak_lpm")), _num(r.get("leak_lpm_low")),
                _num(r.get("leak_lpm_high")), detector=str(r["method"]),
                onset_censored=_flag(r.get("onset_censored")))])
            n += 1
        store.end_run(run, "failed" if failed else "finished", err if failed else None)
    return n
