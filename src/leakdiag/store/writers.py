"""Write the results of ``leakdiag batch`` and ``leakdiag detect`` to the event store."""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from pathlib import Path

from leakdiag.store.database import ActuatorRigError, EventStore, StoreError
from leakdiag.store.summary import AlarmRecord, ChunkSummary, FinishedRun

__all__ = ["record_batch", "record_verdicts", "BatchWrite", "default_actuator",
           "check_stdin_named"]


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


@dataclass(frozen=True)
class BatchWrite:
    """What :func:`record_batch` wrote.

    Attributes
    ----------
    n_runs : int
        Runs written.
    n_stored : int
        Result rows skipped because the store already had them.
    refused : tuple of str
        One message per actuator whose rows were not written (its recordings say another rig
        than the store, or than each other); the other actuators' rows are written.
    """

    n_runs: int
    n_stored: int
    refused: tuple = ()


def _no_evidence(source, method: str, r: dict) -> str:
    """Why a run's alarm is stored as no evidence (``inconclusive``): its row's
    ``why_inconclusive``, or that a run this long expects such an alarm by chance.

    Examples
    --------
    >>> _no_evidence("a.csv", "acf-p1", {"alarm_time_s": 12.5, "why_inconclusive": None})
    'a.csv: acf-p1 alarmed at 12.5 s, but a run this long expects such an alarm by chance'
    """
    why = _text(r.get("why_inconclusive"))
    return (f"{source}: {method} alarmed at {_num(r.get('alarm_time_s'))} s, but "
            + (why or "a run this long expects such an alarm by chance"))


#: What the bracket of a calibrated detector's leak size is, as ``leakdiag detect`` says it
#: (the verdict rows do not carry the calibration's level; the live page, which has it, says
#: "90 % prediction interval").
PREDICTION_INTERVAL = "prediction interval"


def _leak_words(r: dict) -> dict:
    """``leak_extrapolated`` and ``leak_interval`` of a verdict row's alarm, as ``detect``
    prints them: the size an extrapolation where the shift lies outside the calibrated range
    (``leak_lpm_in_range`` False), and the interval a prediction interval, or in the
    detector's words where it says what its interval holds (the flow balance's
    ``leak_lpm_interval_holds``).

    Examples
    --------
    >>> _leak_words({"leak_lpm": 0.2, "leak_lpm_in_range": False})
    {'leak_extrapolated': True, 'leak_interval': 'prediction interval'}
    >>> _leak_words({"leak_lpm": None, "leak_lpm_in_range": None})
    {'leak_extrapolated': None, 'leak_interval': None}
    """
    if _num(r.get("leak_lpm")) is None:
        return {"leak_extrapolated": None, "leak_interval": None}
    in_range = _flag(r.get("leak_lpm_in_range"))
    holds = _text(r.get("leak_lpm_interval_holds"))
    return {"leak_extrapolated": None if in_range is None else not in_range,
            "leak_interval": f"interval: {holds}" if holds else PREDICTION_INTERVAL}


def _batch_run(r: dict, job_digest: str) -> FinishedRun:
    """One batch result row as a stored run: its summary, its alarm, its end."""
    feature = str(r["name"]) if r.get("name") is not None and r["name"] == r["name"] \
        else "batch"
    # one stored run per result row: a re-run of a finished job writes nothing again
    key = "|".join(str(r.get(c)) for c in ("job_digest", "path", "recording_sha256",
                                            "kind", "name"))
    common = {"command": "batch", "source": str(r["path"]), "feature": feature,
              "sample_rate_hz": _num(r.get("sample_rate")),
              "threshold": _num(r.get("threshold")), "system": _text(r.get("system")),
              "config": {"job_digest": job_digest, "kind": r.get("kind")}, "key": key}
    if r["status"] != "ok":
        return FinishedRun(**common, status="failed", error=_text(r.get("error")))
    n_win = int(r["n_windows"]) if _num(r.get("n_windows")) is not None else 0
    judged = r.get("kind") == "detector" and r.get("alarm") is not None \
        and r.get("alarm") == r.get("alarm")  # None / NaN: the detector was not judged
    why_not = None
    inconclusive = r.get("kind") == "detector" and _flag(r.get("alarm_refused")) is True
    if inconclusive:  # it alarmed and refused its alarm: judged, no evidence
        why_not = _text(r.get("error"))
    elif judged and bool(r.get("alarm")) and r.get("decision") == "inconclusive":
        # an alarm batch reads as no evidence (a run this long expects it by chance):
        # inconclusive, with why, as detect --store stores it; not an alarm
        judged, inconclusive = False, True
        why_not = _no_evidence(r.get("recording", r["path"]), feature, r)
    summ = None
    if n_win:
        summ = ChunkSummary(0.0, _num(r.get("duration_s")) or 0.0, n_win,
                            int(_num(r.get("n_degenerate")) or 0), _num(r.get("value_mean")),
                            _num(r.get("value_min")), _num(r.get("value_max")), None,
                            _num(r.get("score_max")), None,
                            bool(r.get("alarm")) if judged else None)
    alarms = ()
    if judged and bool(r.get("alarm")) and _num(r.get("alarm_time_s")) is not None:
        alarms = (AlarmRecord(
            _num(r["alarm_time_s"]), _num(r.get("score_max")), _num(r.get("threshold")),
            _num(r.get("alarm_onset_s")), _num(r.get("leak_lpm")),
            _num(r.get("leak_lpm_low")), _num(r.get("leak_lpm_high")), detector=feature,
            onset_censored=_flag(r.get("alarm_onset_censored")), **_leak_words(r)),)
    unjudged = r.get("kind") == "detector" and not judged and not inconclusive
    return FinishedRun(**common, status="inconclusive" if inconclusive else
                       "unjudged" if unjudged else "finished",
                       error=(why_not or _text(r.get("error")))
                       if unjudged or inconclusive else None,
                       summary=summ, alarms=alarms)


def record_batch(store: EventStore, results, job_digest: str,
                 actuator_from: str = "folder") -> BatchWrite:
    """Store the rows of one batch job: a run per recording and row, one summary per row.

    The actuator is the recording's folder name (``actuator_from="folder"``: one folder per
    actuator, its runs inside) or its file stem (``"stem"``; two files of one stem in different
    folders are refused, :func:`actuator_names`). Analysis rows become a summary of the whole
    recording (``t_start_s`` 0, ``t_end_s`` its duration, the row's value statistics); detector
    rows also carry the score maximum, and an alarm at ``alarm_time_s`` when one was raised.
    Error rows become a run with status ``failed``, a detector row that was not judged (no
    alarm value: too short for the burn-in) one with status ``unjudged``, one whose alarm is no
    evidence (refused by the detector, ``alarm_refused``, or expected by chance in a run this
    long) one with status ``inconclusive``.

    Each actuator's rows are written in one transaction
    (:meth:`~leakdiag.store.database.EventStore.add_finished_runs`): each run with its summary,
    alarm and end, all or none. A row already in the store (same job, recording path and
    content, kind and name) is not written again, checked inside that transaction, so two
    batch runs writing at once store each row once. An actuator whose recordings say another
    rig than the store (or than each other) is not written at all and is reported; the other
    actuators are written.

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
    BatchWrite
        Runs written, rows already stored, actuators refused (with the reason).

    Raises
    ------
    ValueError
        From :func:`actuator_names` (nothing is written then).
    StoreError
        For any other trouble with the store than an actuator of another rig (e.g. a store
        that became read-only during the job): the job stops, it is not "refused".
    """
    rows = results[results["job_digest"] == job_digest]
    names = actuator_names(rows["path"].astype(str), actuator_from)
    inv = uuid.uuid4().hex
    per_actuator: dict[str, list[FinishedRun]] = {}
    paths_of: dict[str, set[str]] = {}
    for r in rows.to_dict("records"):
        name = names[str(r["path"])]
        per_actuator.setdefault(name, []).append(_batch_run(r, job_digest))
        paths_of.setdefault(name, set()).add(str(r["path"]))
    n = skipped = 0
    refused = []
    known = set(store.actuator_names())
    for actuator, runs in per_actuator.items():
        other = _other_folder(store, actuator, paths_of[actuator], known)
        if other is not None:  # none of this actuator's rows: stored, they would merge
            refused.append(other)
            continue
        try:
            ids = store.add_finished_runs(actuator, runs, invocation=inv)
        except ActuatorRigError as exc:  # another rig: none of this actuator's rows, say why
            # (any other StoreError, e.g. a store that became read-only, stops the job)
            msg = str(exc)
            refused.append(msg.split(": ", 1)[1] if msg.startswith(store.shown_url) else msg)
            continue
        n += sum(i is not None for i in ids)
        skipped += sum(i is None for i in ids)
    return BatchWrite(n, skipped, tuple(refused))


def _other_folder(store: EventStore, actuator: str, paths, known) -> str | None:
    """Why a batch job's runs of ``actuator`` (recordings ``paths``) may not join the store's
    runs of that name, or None: the store holds runs of it from files in another folder
    (absolute sources; older relative ones are not compared). Within one job
    :func:`actuator_names` refuses such a pair; across jobs a second job's healthy
    ``siteB/rig1`` was stored under ``siteA/rig1``'s name and the fleet page showed the leak
    OK (a store audit, 2026-11-29)."""
    if actuator not in known:
        return None
    mine = {Path(p).resolve().parent for p in paths}
    for src in store.runs_of(actuator)["source"].dropna():
        o = Path(str(src).split(" [", 1)[0])  # a monitor segment's source ends " [a-b s]"
        if o.is_absolute() and o.resolve().parent not in mine:
            here = sorted(mine)[0]
            return (f"actuator {actuator!r} already holds runs of {o}, a file in another "
                    f"folder than {here}: stored under one name their runs would merge into "
                    "one actuator (a healthy run hiding another's leak); store this job in "
                    "another store, or name the folders apart")
    return None


def check_stdin_named(source: str, actuator: str | None) -> None:
    """Refuse a stored run from standard input without ``--actuator`` (see
    :func:`default_actuator`); callable before the store or a detector is opened.

    Parameters
    ----------
    source : str
        The input: a file path, or ``-`` / ``<stdin>``.
    actuator : str or None
        ``--actuator``.

    Raises
    ------
    StoreError
        For standard input without an actuator name.
    """
    if actuator is None and source in ("-", "<stdin>"):
        raise StoreError("--store with standard input needs --actuator NAME: every run from "
                         "standard input would otherwise be one actuator 'stdin'")


def default_actuator(store: EventStore, source: str) -> str:
    """The actuator of a ``detect`` or ``monitor`` run given no ``--actuator``: the file's stem,
    unless that would merge two actuators.

    The stem alone merged ``rigA/run1.parquet`` (a leak) and ``rigB/run1.parquet`` (healthy)
    into one actuator ``run1``, shown OK: the later run hid the leak (store audit 2026-11-27,
    finding 2). So the stem is refused when the store already holds it with a run of a file in
    another folder (the runs' sources, stored as absolute paths since then; older relative ones
    are not compared), and standard input, which has no name, needs ``--actuator``.

    Parameters
    ----------
    store : EventStore
        Open store.
    source : str
        The input: a file path, or ``-`` / ``<stdin>``.

    Returns
    -------
    str
        The file's stem.

    Raises
    ------
    StoreError
        For standard input, or a stem that the store holds for a file in another folder.
    """
    check_stdin_named(source, None)
    here = Path(source).resolve()
    name = here.stem
    if name not in store.actuator_names():  # a new actuator (any other store error raises)
        return name
    for other in store.runs_of(name)["source"].dropna():
        o = Path(str(other))
        # compared resolved (a folder reached through a symbolic link is the same folder)
        if o.is_absolute() and o.resolve().parent != here.parent:
            raise StoreError(
                f"{store.shown_url}: actuator {name!r} (the file's stem) already holds runs of "
                f"{o}, a file in another folder than {here}: stored under one name their runs "
                "would merge into one actuator (a healthy run hiding another's leak); give "
                f"--actuator NAME (e.g. --actuator {here.parent.name}) to name the actuator")
    return name


def record_verdicts(store: EventStore, actuator: str, file: str, table,
                    command: str = "detect", config: dict | None = None) -> int:
    """Store the verdicts of ``leakdiag detect``: one run per method, an alarm per leak found.

    A method that could not judge the file (its row has an ``error``, or no verdict) is stored
    ``unjudged`` with the reason, as ``batch`` stores such a row: the fleet page shows
    ``NOT JUDGED``. A method whose alarm is no evidence of a leak (it refused the alarm,
    ``alarm_refused``, or the run expects it by chance: ``decision`` inconclusive) is stored
    ``inconclusive`` with why, without an alarm: the fleet page shows ``INCONCLUSIVE``.
    (``detect`` reads the file before it stores anything, so a failure to read it never
    reaches the store.)

    Every method's run goes in with its alarm and its end in one transaction
    (:meth:`~leakdiag.store.database.EventStore.add_finished_runs`): an interruption stores all
    of them or none, never a run left ``running``.

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
    command : str, default "detect"
        The command stored with the runs (``monitor`` for a segment judged by a
        whole-recording detector).
    config : dict, optional
        More settings stored with each run besides its method (``monitor --segment``: its
        session, :meth:`~leakdiag.store.database.EventStore.end_session`).

    Returns
    -------
    int
        Alarms written.

    Raises
    ------
    StoreError
        If the file says another rig than the actuator's in the store (nothing is written).
    """
    system = _text(table.attrs.get("system"))
    runs = []
    for r in table.to_dict("records"):
        err = r.get("error")
        inconclusive = _flag(r.get("alarm_refused")) is True  # it alarmed and refused it
        failed = isinstance(err, str) and bool(err) and not inconclusive
        if not failed and not inconclusive and (_flag(r.get("leak")) is None or
                                                ("score_max" in r and
                                                 _num(r["score_max"]) is None)):
            # no verdict, or no window scored (detect stops with "no finite score"): say so
            failed, err = True, (f"{file}: {r['method']} scored no window (no finite score: "
                                 "every feature value undefined, a constant channel?)")
        if not failed and bool(r.get("leak")) and r.get("decision") == "inconclusive":
            # an alarm detect reads as no evidence (a run this long expects it by chance):
            # inconclusive, with why, as monitor --segment stores such a segment; not an alarm
            inconclusive, err = True, _no_evidence(file, r["method"], r)
        alarms = ()
        if not failed and not inconclusive and bool(r.get("leak")) and \
                _num(r.get("alarm_time_s")) is not None:
            alarms = (AlarmRecord(
                _num(r["alarm_time_s"]), _num(r.get("score_max")), _num(r.get("threshold")),
                _num(r.get("onset_s")), _num(r.get("leak_lpm")), _num(r.get("leak_lpm_low")),
                _num(r.get("leak_lpm_high")), detector=str(r["method"]),
                onset_censored=_flag(r.get("onset_censored")), **_leak_words(r)),)
        # a method that could not judge the file (it was read: detect stops before storing
        # otherwise) is not judged, as batch stores the same row: NOT JUDGED, not FAILED
        status = "inconclusive" if inconclusive else "unjudged" if failed else "finished"
        runs.append(FinishedRun(command, str(file), str(r["method"]), status,
                                err if failed or inconclusive else None,
                                threshold=_num(r.get("threshold")), system=system,
                                config={**(config or {}), "method": r["method"]},
                                alarms=alarms))
    store.add_finished_runs(actuator, runs)  # one transaction: no run left 'running'
    return sum(len(r.alarms) for r in runs)
