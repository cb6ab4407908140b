"""Run a batch job over many recordings: a pure per-recording ``run_case``, serial or on Dask.

:func:`run_case` streams one recording through every analysis and detector of the job in a single
pass of chunks (so files larger than memory work) and returns its result rows; any failure becomes
one row with ``status="error"`` and the message. :func:`run_batch` runs the cases that are not
finished yet, in this process or on a ``dask.distributed`` cluster, and writes each recording's
rows as soon as it is done (:mod:`leakdiag.batch.store`).
"""

from __future__ import annotations

import functools
import glob
import os
import re
import time
import warnings
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from leakdiag._version import __version__
from leakdiag.batch.config import BatchConfig
from leakdiag.batch.store import content_hash, finished_state, result_key, write_rows
from leakdiag.detect.measure import rms_change
from leakdiag.features.series import FeatureSeries
from leakdiag.io.checks import RESAMPLE_ADVICE
from leakdiag.io.recording import machine_unit
from leakdiag.runtime.executor import LOCAL, run_cases
from leakdiag.stream.detector import as_scorer
from leakdiag.stream.detector_file import (ADVICE_JOB, check_detector_fits, fitted_machine,
                                            load_detector_file, unchecked_note)
from leakdiag.stream.feature import StreamingFeature
from leakdiag.stream.files import open_recording
from leakdiag.stream.segments import judges_whole

__all__ = ["run_case", "run_batch", "expand_inputs", "batch_inputs", "warn_job_detectors",
           "BatchSummary", "LOCAL", "CODE_PARTS", "code_provenance"]

#: The parts of leakdiag whose code a batch result depends on (hashed by
#: :func:`leakdiag._fingerprint.parts_fingerprint` into each row's ``code_fingerprint``; a
#: finished recording whose rows hold another fingerprint is computed again): batch itself,
#: the streaming pass and the recording readers (``stream``, ``io``), the features and the
#: Sec. 5.2 measure (``features``, ``detect``), the detectors a detector file can hold
#: (``detect``, ``literature``), the simulator parameters the whole-recording detectors (flow
#: balance, EKF) read (``sim``) and the checks and holds they all use (``_validation.py``,
#: ``_holds.py``), and ``_format.py``, which writes the instants of a row's words). Left out: ``runtime`` (where a case runs, not what it computes), ``store``,
#: ``report``, ``cli`` and ``_version`` (no number).
CODE_PARTS = ("_format.py", "_holds.py", "_validation.py", "batch", "detect", "features", "io",
              "literature", "sim", "stream")


def code_provenance() -> dict[str, str]:
    """What a batch row records of the code that computed it, and is checked against on resume.

    Returns
    -------
    dict
        ``code_fingerprint``: :func:`~leakdiag._fingerprint.parts_fingerprint` of
        :data:`CODE_PARTS`; ``library_versions``: JSON of
        :func:`~leakdiag._fingerprint.library_versions` (Python, NumPy, SciPy, Numba, pandas,
        pyarrow: a new version of any can change a number, so it counts as other code).

    Examples
    --------
    >>> sorted(code_provenance())
    ['code_fingerprint', 'library_versions']
    """
    import json

    from leakdiag._fingerprint import library_versions, parts_fingerprint

    return {"code_fingerprint": parts_fingerprint(CODE_PARTS),
            "library_versions": json.dumps(library_versions(), sort_keys=True)}


def expand_inputs(patterns: Iterable[str]) -> list[str]:
    """Absolute paths matching glob patterns (``**`` recurses), sorted, without duplicates.

    A pattern without wildcards that matches nothing is kept, so that a missing file becomes an
    error row instead of disappearing.

    Parameters
    ----------
    patterns : iterable of str
        Paths or glob patterns.

    Returns
    -------
    list of str

    Examples
    --------
    >>> expand_inputs(["/no/such/file.parquet"])
    ['/no/such/file.parquet']
    """
    out: set[str] = set()
    for pat in patterns:
        hits = glob.glob(os.fspath(pat), recursive=True)
        if not hits and not glob.has_magic(os.fspath(pat)):
            hits = [os.fspath(pat)]
        out.update(os.path.abspath(h) for h in hits if not os.path.isdir(h))
    return sorted(out)


def batch_inputs(patterns: Iterable[str],
                 out_dir: str | os.PathLike) -> tuple[list[str], list[str]]:
    """The recordings of a batch run: :func:`expand_inputs` without batch's own output.

    A glob that covers ``out_dir`` (``'data/**/*.parquet'`` with ``-o data/results.parquet``)
    would read the result files of earlier runs as recordings (error rows "missing
    channel(s)"); they are left out.

    Parameters
    ----------
    patterns : iterable of str
        Paths or glob patterns.
    out_dir : str or path-like
        The results folder (``--out``).

    Returns
    -------
    paths : list of str
        Recordings, absolute, sorted.
    own : list of str
        Matched files inside ``out_dir``, left out.

    Examples
    --------
    >>> batch_inputs(["/data/a.parquet", "/data/res/k.parquet"], "/data/res")
    (['/data/a.parquet'], ['/data/res/k.parquet'])
    """
    out = os.path.abspath(os.fspath(out_dir))
    paths, own = [], []
    for p in expand_inputs(patterns):
        (own if p == out or p.startswith(out.rstrip(os.sep) + os.sep) else paths).append(p)
    return paths, own


def _summary(values: np.ndarray) -> dict:
    finite = values[np.isfinite(values)]
    if not len(finite):
        return {"value_mean": None, "value_std": None, "value_min": None, "value_max": None}
    return {"value_mean": float(finite.mean()), "value_std": float(finite.std()),
            "value_min": float(finite.min()), "value_max": float(finite.max())}


def _measure(spec, t, v, onset, chunk, sample_rate) -> dict:
    if onset is None:
        return {}
    fs = FeatureSeries(t, v, spec.method, window=spec.window, sample_rate=sample_rate)
    try:
        r = rms_change(fs, onset, chunk)
    except ValueError as exc:
        return {"onset_s": onset, "error": f"Sec. 5.2 measure: {exc}"}
    return {"onset_s": onset, "mean_rms_before": r.mean_rms_before,
            "mean_rms_after": r.mean_rms_after, "pct_change": r.pct_change,
            "pct_change_signed": r.pct_change_signed}


def _in_job_words(msg: str) -> str:
    """A reader's message with advice a batch job can follow (batch has no --resample or
    --sample-rate: the job's column_map gives a rate, files are resampled beforehand)."""
    msg = msg.replace(RESAMPLE_ADVICE, "batch needs a uniform time axis: resample the file "
                      "first and batch the copy (in Python: leakdiag.io.write_recording("
                      "leakdiag.io.read_recording(FILE, resample=RATE_HZ), OUT); batch has no "
                      "--resample)")
    msg = msg.replace("give a column map (--map FILE or --col p1=COLUMN:UNIT)",
                      'give the job a column map (column_map = "map.toml" under [job])')
    return re.sub(r"\(--sample-rate, or sample_rate_hz in (a column|the) map\)",
                  "(sample_rate_hz in the job's column_map)", msg)


def _load_job_detector(ref):
    """A job's detector file, loaded for one recording with its warnings silenced:
    :func:`run_batch` shows them once per file (here they would repeat for every recording,
    or vanish into a Dask worker's log)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return load_detector_file(ref.path)
        except ValueError as exc:
            if ref.origin and ref.origin != "--detector":
                raise ValueError(f"{ref.origin}: {exc}") from None
            raise


def warn_job_detectors(config: BatchConfig) -> list:
    """Load every detector file of a job once, letting its warnings through.

    Parameters
    ----------
    config : BatchConfig
        The job.

    Returns
    -------
    list of DetectorRef
        The bare pickles among them (no record: nothing is checked against the recordings).

    Warns
    -----
    DetectorFileWarning
        Once per file: other code fitted it, the code that fitted it is unknown, or it is a
        bare pickle (:func:`leakdiag.stream.detector_file.load_detector_file`). A file that
        cannot be loaded is left to the recordings' error rows.
    """
    bare = []
    for ref in config.detectors:
        try:
            _, meta = load_detector_file(ref.path)
        except ValueError:
            continue
        if meta is None:
            bare.append(ref)
    return bare


def run_case(path: str, config: BatchConfig) -> list[dict]:
    """Run every analysis and detector of ``config`` on one recording, in one streaming pass.

    Parameters
    ----------
    path : str
        Recording file (Parquet/HDF5/CSV are read in chunks; other formats whole).
    config : BatchConfig
        The job.

    Returns
    -------
    list of dict
        One row per analysis and per detector (columns of
        :data:`leakdiag.batch.store.RESULT_COLUMNS`); a detector that disagrees with the
        recording (system, load, sample rate, units) gets a row with ``status="error"`` and
        the message while the others are computed; a single row with ``status="error"`` if
        anything else fails. Never raises for a bad file.

    Raises
    ------
    ValueError
        Only internally: a detector that cannot be streamed or that disagrees with the recording
        raises inside, and the error becomes the recording's error row.

    Notes
    -----
    Pure: the rows depend only on the file and the configuration (plus ``elapsed_s``), so serial
    and Dask runs give the same table. The Sec. 5.2 measure (Eq. 5-1 to 5-3) is computed for the
    analysis rows when an onset is known (``config.onset_s`` or the file's ``meta['onset']``);
    a detector row holds the detector's verdict only (until 2026-11-28 it also held the
    measure, and a measure that could not be computed put its note in the ``error`` of an
    ``ok`` detector row: streams audit 2026-11-27, finding 9).
    """
    t0 = time.perf_counter()
    base = {"path": os.path.abspath(path), "recording": os.path.basename(path),
            "job_digest": config.digest, "job_config": config.to_json(),
            "leakdiag_version": __version__}
    try:
        dets, whole = [], []
        for ref in config.detectors:
            det, meta = _load_job_detector(ref)
            if callable(getattr(det, "spec", None)):
                dets.append((ref.name, det, meta, ref.path))
            elif judges_whole(det):  # the flow balance, EKF, combined...: read whole
                whole.append((ref.name, det, meta, ref.path))
            else:
                raise ValueError(f"detector {ref.name} ({ref.path}) can neither be streamed "
                                 "nor judge a whole recording")
        items = [("analysis", s.label, s, None) for s in config.analyses]
        items += [("detector", name, d.spec(), d) for name, d, _, _ in dets]
        if not items:  # only whole-recording detectors: no streaming pass
            rows = _whole_rows(path, config, whole, base)
            elapsed = time.perf_counter() - t0
            for r in rows:
                r["elapsed_s"] = elapsed
            return rows
        channels = sorted({c for _, _, s, _ in items for c in s.channels})
        src, units = open_recording(path, channels, config.chunk_samples,
                                    column_map=config.column_map)
        # a detector that disagrees with the recording (system, load, rate, units) gets its own
        # error row; the analyses and the other detectors are still computed
        refused = {}
        for name, _, meta, dpath in dets:
            try:
                check_detector_fits(meta, sample_rate=src.sample_rate, channels=src.channels,
                                    units=units, system=src.meta.get("system"), source=path,
                                    path=dpath, load=src.meta.get("load"),
                                    machine=machine_unit(src.meta))
            except ValueError as exc:
                refused[name] = _in_job_words(str(exc))
        items = [it for it in items if not (it[0] == "detector" and it[1] in refused)]
        # a detector's own healthy file (its bytes or its samples): not judged by it
        own = _own_healthy(path, dets, src, config.column_map)
        # what of the recording its metadata leave unchecked (rig, load): one note per file
        # (with the whole-recording detectors': one sentence for the file, not one per kind
        # of detector, which batch printed twice per CSV file; a batch audit, 2026-11-29)
        unchecked = unchecked_note(path, src.meta, [
            (dpath, getattr(meta, "system", None), getattr(meta, "load", None),
             getattr(meta, "machine", None))
            for name, _, meta, dpath in dets if name not in refused] + [
            (dpath, getattr(meta, "system", None), getattr(meta, "load", None),
             fitted_machine(det, meta)) for _, det, meta, dpath in whole], ADVICE_JOB)
        feats = [StreamingFeature(s, src.sample_rate, src.start_time) for _, _, s, _ in items]
        # a leakdiag Detector judges the whole streamed feature at the end (predict_series);
        # another scorer (anything with score_windows) scores it chunk by chunk
        scorers = [None if d is None or _judges_series(d) else
                   as_scorer(d, s, src.sample_rate, src.start_time) for _, _, s, d in items]
        parts: list[list[tuple]] = [[] for _ in items]
        for chunk in src:
            for feat, scorer, acc in zip(feats, scorers, parts):
                fs = feat.push(chunk)
                if len(fs):
                    sc = None if scorer is None else scorer.score_windows(fs.values, fs.time)
                    acc.append((fs, sc))
        # the rig: the recording's metadata, else the detectors' (check_detector_fits above
        # refused a detector of another rig than the recording's)
        system = src.meta.get("system") or next(
            (m.system for _, _, m, _ in dets if getattr(m, "system", None)), None)
        base = {**base, "system": None if system is None else str(system)}
        onset = config.onset_s if config.onset_s is not None else src.meta.get("onset")
        onset = None if onset is None else float(onset)
        rows = []
        for (kind, name, spec, det), feat, scorer, acc in zip(items, feats, scorers, parts):
            t = np.concatenate([a[0].time for a in acc]) if acc else np.empty(0)
            v = np.concatenate([a[0].values for a in acc]) if acc else np.empty(0)
            row = {**base, "status": "ok", "kind": kind, "name": name, **spec.as_dict(),
                   "sample_rate": src.sample_rate, "n_samples": feat.n_samples_seen,
                   "duration_s": feat.n_samples_seen / src.sample_rate,
                   "n_windows": feat.n_windows, "n_degenerate": feat.n_degenerate,
                   **_summary(v)}
            if kind == "analysis":  # a detector row is its verdict, not the Sec. 5.2 measure
                row.update(_measure(spec, t, v, onset, config.rms_chunk, src.sample_rate))
            unusable = _unusable(feat, spec)
            if unusable is not None:  # kept with the row (and the store), not only printed
                note = row.get("error")
                row["error"] = unusable + (f"; {note}" if note else "")
            if kind == "detector" and name in own:
                row.update({"alarm": None, "decision": None,
                            "error": f"detector not judged: {own[name]}"})
            elif scorer is not None:
                s = np.concatenate([a[1] for a in acc]) if acc else np.empty(0)
                row.update(_scorer_columns(det, scorer, t, s, row["duration_s"]))
            elif det is not None:
                row.update(_verdict_columns(det, [a[0] for a in acc], t, v, row["duration_s"],
                                            src.start_time, path))
            if unusable is not None and row.get("alarm") is None and kind == "detector":
                row["error"] = f"detector not judged: {unusable}"
            if kind == "detector":
                row["unchecked"] = unchecked
            rows.append(row)
        rows += [{**base, "status": "error", "kind": "detector", "name": name, "error": msg}
                 for name, msg in refused.items()]
        if whole:
            rows += _whole_rows(path, config, whole, base, unchecked)
    except Exception as exc:  # noqa: BLE001 - a bad file must become a row, not stop the run
        msg = _in_job_words(str(exc))  # leakdiag's messages name file, channel and row
        if config.column_map is None and "missing channel(s)" in msg and "column map" not in msg:
            msg += '; give the job a column map (column_map = "map.toml" under [job])'
        # bad input (ValueError, RecordingError) in leakdiag's words, the file named once; the
        # class is named only for an unexpected failure (until 2026-11-28 a NaN sample read
        # ".../nan_p1.parquet: ValueError: channel 'p1' is not finite at sample 50000")
        if not isinstance(exc, ValueError):
            err = f"{path}: {type(exc).__name__}: {msg}"
        elif path in msg or os.path.basename(path) in msg:
            err = msg
        else:
            err = f"{path}: {msg}"
        rows = [{**base, "status": "error", "error": err}]
    elapsed = time.perf_counter() - t0
    for r in rows:
        r["elapsed_s"] = elapsed
    return rows


@dataclass(frozen=True)
class BatchSummary:
    """What :func:`run_batch` did.

    Attributes
    ----------
    n_inputs : int
        Recordings matched.
    n_skipped : int
        Already finished (resumed).
    n_run : int
        Computed in this call.
    n_errors : int
        Of those, recordings that gave an error row.
    out_dir : str
        Results folder.
    n_own : int, default 0
        Files the inputs matched inside the results folder (batch's own results), left out.
    n_other_code : int, default 0
        Of ``n_run``: recordings whose finished rows (content unchanged) came from other
        leakdiag code (another ``code_fingerprint``, or none recorded), computed again.
    n_other_libraries : int, default 0
        Of ``n_run``: the same for rows of the same code under other library versions.
    paths : tuple of str, default ()
        The recordings matched (absolute, sorted; :func:`batch_inputs`), those whose rows
        this run's summary is about: a file added to the folder while the job ran is not.
    """

    n_inputs: int
    n_skipped: int
    n_run: int
    n_errors: int
    out_dir: str
    n_own: int = 0
    n_other_code: int = 0
    n_other_libraries: int = 0
    paths: tuple[str, ...] = ()


def _todo(paths, config, out_dir, retry_errors, code):
    """Recordings to (re)compute: new, edited since their result (content hash), computed by
    other code (``code``: :func:`code_provenance`) or errors with ``retry_errors``; their keys,
    content hashes and the counts of recordings redone for other code / other libraries."""
    done = finished_state(out_dir)
    keys = {p: result_key(p, config.digest) for p in paths}
    shas = {p: content_hash(p) for p in paths}
    todo, n_code, n_lib = [], 0, 0
    for p in paths:
        state = done.get(keys[p])
        if state is None or state[0] != shas[p] or (retry_errors and state[1]):
            todo.append(p)
        elif state[2] != code["code_fingerprint"]:
            todo.append(p)
            n_code += 1
        elif state[3] != code["library_versions"]:
            todo.append(p)
            n_lib += 1
    return todo, keys, shas, n_code, n_lib


def run_batch(inputs: Sequence[str], config: BatchConfig, out_dir: str | os.PathLike, *,
              scheduler: str | None = None, n_workers: int = 2, progress: bool = True,
              retry_errors: bool = False) -> BatchSummary:
    """Run ``config`` on every recording not yet finished in ``out_dir``.

    Parameters
    ----------
    inputs : sequence of str
        Recording paths or glob patterns (``**`` recurses). Files inside ``out_dir`` are
        left out (:func:`batch_inputs`).
    config : BatchConfig
        The job.
    out_dir : str or path-like
        Results folder (a Parquet dataset; one file per recording).
    scheduler : str, optional
        None runs serially in this process; ``"local"`` starts a
        ``dask.distributed.LocalCluster`` with ``n_workers`` worker processes; an address
        (e.g. ``"tcp://10.0.0.5:8786"``) uses an existing scheduler
        (:func:`leakdiag.runtime.executor.run_cases`).
    n_workers : int, default 2
        Worker processes of the local cluster (one thread each).
    progress : bool, default True
        Show a tqdm progress bar (recordings).
    retry_errors : bool, default False
        Also re-run recordings whose finished result is an error row.

    Returns
    -------
    BatchSummary

    Raises
    ------
    ValueError
        For a scheduler that is neither None, ``"serial"``, ``"local"`` nor an address.

    Warns
    -----
    DetectorFileWarning
        Once per detector file of the job, before the recordings are run
        (:func:`warn_job_detectors`).

    Notes
    -----
    Each recording's rows are written as soon as it finishes (atomic rename), so a killed run
    keeps every finished recording and a re-run computes only the rest. A worker that dies
    turns its recording into an error row. A finished recording counts only when its rows came
    from this code and these library versions (:func:`code_provenance`); rows of other code
    are computed again and replaced, counted in ``n_other_code`` / ``n_other_libraries``.
    """
    from tqdm.auto import tqdm

    paths, own = batch_inputs(inputs, out_dir)  # never batch's own result files
    code = code_provenance()
    todo, keys, shas, n_code, n_lib = _todo(paths, config, out_dir, retry_errors, code)
    if todo:
        warn_job_detectors(config)  # once per detector file; run_case silences them
    n_err = 0
    bar = tqdm(total=len(todo), unit="rec", desc="batch", disable=not progress, leave=True,
               dynamic_ncols=True, mininterval=0.5)

    def finish(path, rows):
        nonlocal n_err
        for r in rows:
            r["recording_sha256"] = shas[path]
            r.update(code)
        write_rows(rows, out_dir, keys[path])
        n_err += any(r["status"] == "error" for r in rows)
        bar.update(1)

    try:
        run_cases(functools.partial(run_case, config=config), todo, scheduler=scheduler,
                  n_workers=n_workers, progress=False,
                  on_result=lambda case: finish(case.config, case.result),
                  on_error=functools.partial(_lost_case_rows, config=config))
    finally:
        bar.close()
    return BatchSummary(len(paths), len(paths) - len(todo), len(todo), n_err, os.fspath(out_dir),
                        len(own), n_code, n_lib, tuple(paths))


def _whole_rows(path: str, config: BatchConfig, whole: list, base: dict,
                unchecked: str | None = None) -> list[dict]:
    """Rows of the whole-recording detectors of a job: the file read whole (as ``leakdiag
    detect`` reads it) and judged by each detector's ``predict``.

    A detector that disagrees with the recording (system, load, sample rate, units), whose
    healthy recordings include this very file, or that cannot judge it (``RecordingError``:
    too short, a stuck or missing channel, the model does not describe it) gets its own row
    with the reason (``alarm`` null); the file is read once for all of them.
    """
    from leakdiag.detect.base import refuse_own_healthy
    from leakdiag.detect.decision import judge_run
    from leakdiag.detect.flow_balance import RefusedAlarm
    from leakdiag.io import read_recording
    from leakdiag.io.errors import RecordingError

    rec = read_recording(path, column_map=config.column_map)
    base = {**base, "system": base.get("system") or rec.meta.get("system")}
    rows = []
    for name, det, meta, dpath in whole:
        chans = tuple(getattr(det, "channels", None) or ())
        row = {**base, "kind": "detector", "name": name,
               "method": meta.method if meta is not None else type(det).__name__,
               "channels": ",".join(chans) or None, "sample_rate": rec.sample_rate,
               "n_samples": rec.n_samples, "duration_s": rec.duration}
        try:
            check_detector_fits(meta, sample_rate=rec.sample_rate, channels=rec.channels,
                                units=rec.units, system=rec.meta.get("system"), source=path,
                                path=dpath, load=rec.meta.get("load"),
                                machine=machine_unit(rec.meta))
        except ValueError as exc:
            rows.append({**row, "status": "error", "error": _in_job_words(str(exc))})
            continue
        row["unchecked"] = unchecked if unchecked is not None else unchecked_note(
            path, rec.meta, [(dpath, getattr(meta, "system", None),
                              getattr(meta, "load", None), fitted_machine(det, meta))], ADVICE_JOB)
        row["status"], row["threshold"] = "ok", float(det.threshold_)
        try:
            refuse_own_healthy(det, rec, "batch")
            j = judge_run(det, rec)  # a long run at the level that holds it to a segment's rate
        except RecordingError as exc:  # nothing was judged, or an alarm it refused
            # a refused alarm was judged: inconclusive, as detect says; not judged: no
            # decision (as detect's table leaves it; until session 23 "inconclusive" too)
            refused = isinstance(exc, RefusedAlarm)
            rows.append({**row, "alarm": None, "decision": "inconclusive" if refused else None,
                         "alarm_refused": True if refused else None,
                         "threshold": _level_judged_at(det, rec.n_samples, rec.sample_rate),
                         "error": f"{'alarm refused' if refused else 'detector not judged'}: "
                                  f"{exc}"})
            continue
        v, d = j.verdict, j.verdict.as_dict()
        if j.run_level is not None:
            row["threshold"] = float(j.run_level)
        rows.append({**row, "alarm": bool(v.leak), "decision": j.decision,
                     "why_inconclusive": j.why_inconclusive,
                     "false_alarms_expected": j.expected,
                     "run_level": j.run_level_words(float(det.threshold_)),
                     "alarm_time_s": d["alarm_time_s"],
                     "score_max": d["score_max"], "p_value": d["confidence"],
                     "p_value_floor": d.get("confidence_floor"),
                     "n_windows": d.get("n_windows"),
                     "alarm_onset_s": d["onset_s"],
                     "onset_method": d["onset_method"] if v.leak else None,
                     "alarm_onset_censored": d["onset_censored"] if v.leak else None,
                     "leak_lpm": d["leak_lpm"], "leak_lpm_low": d["leak_lpm_low"],
                     "leak_lpm_high": d["leak_lpm_high"],
                     "leak_lpm_in_range": d["leak_lpm_in_range"],
                     "leak_lpm_interval_holds": d.get("leak_lpm_interval_holds"),
                     "detectable_lpm": d.get("detectable_lpm"), "verdict": str(v)})
    return rows


def _own_healthy(path: str, dets, src, column_map) -> dict:
    """The job's detectors fitted on this very file, each with why it does not judge it: the
    same bytes (their healthy files' SHA-256, :func:`~leakdiag.stream.detector_file.
    own_healthy_reason`), or the same samples over the channels they read (another copy:
    CRLF line ends, Parquet; :func:`~leakdiag.stream.detector_file.own_healthy_samples_reason`;
    a user-data audit, 2026-11-29: compared by bytes only, such a copy was judged NO LEAK).

    The file is hashed only when a detector file records its healthy files' hashes (fitted
    since session 22): a second read of it, as :func:`run_batch` hashed it already; passing
    every file's hash to each case would ship the job's whole table to every Dask task. It is
    read whole once more, once, only when its length and rate are a healthy recording's."""
    from leakdiag.batch.store import content_hash
    from leakdiag.io import read_recording
    from leakdiag.stream.detector_file import own_healthy_reason, own_healthy_samples_reason

    out: dict = {}
    if any(getattr(meta, "healthy_sha256", ()) for _, _, meta, _ in dets):
        sha = content_hash(path)
        for name, _, meta, dpath in dets:
            why = own_healthy_reason(meta, sha, path, dpath)
            if why is not None:
                out[name] = why
    cache: dict = {}

    def read(chans):
        key = tuple(chans)
        if key not in cache:
            cache[key] = read_recording(path, column_map, channels=list(chans))
        return cache[key]

    for name, det, _, dpath in dets:
        if name not in out:
            why = own_healthy_samples_reason(det, path, src.n_samples, src.sample_rate, read,
                                             str(dpath))
            if why is not None:
                out[name] = why
    return out


def _level_judged_at(det, n_samples: int, sample_rate_hz: float) -> float:
    """The level a run is judged at (its run level when longer than a healthy segment, else
    the fitted threshold): the ``threshold`` of a row whose judgement the detector refused,
    which its message names (an audit, 2026-11-29: the row, and ``--store``, kept the fitted
    threshold while the refusal said "level 3.76")."""
    from leakdiag.detect.decision import raised_level

    found = raised_level(det, n_samples, sample_rate_hz)
    return float(det.threshold_) if found is None else float(found[0])


def _judges_series(det) -> bool:
    """Whether a job's detector is a fitted leakdiag Detector (it gives a whole Verdict)."""
    return callable(getattr(det, "predict_series", None)) and hasattr(det, "threshold_")


def _unusable(feat: StreamingFeature, spec) -> str | None:
    """Why a feature gave nothing to use: no window at all, or only degenerate ones."""
    if feat.n_windows == 0:
        return (f"no window: {feat.n_samples_seen} samples is shorter than one window "
                f"(window={int(spec.window)})")
    if feat.n_degenerate == feat.n_windows:
        return (f"all {feat.n_windows} windows degenerate (zero variance: constant "
                "channel?)")
    return None


def _not_judged(det, n_windows: int, duration_s: float) -> str:
    burn = float(getattr(getattr(det, "alarm", None), "burn_in_s", 0.0) or 0.0)
    return (f"detector not judged: no window of {n_windows} was scored (the recording, "
            f"{duration_s:.4g} s, is too short for the {burn:g}-s burn-in, or its feature "
            "values are not finite)")


def _scorer_columns(det, scorer, t: np.ndarray, s: np.ndarray, duration_s: float) -> dict:
    """A detector row from a scorer that is not a leakdiag Detector: CUSUM-like scores and an
    alarm where they reach its ``threshold_`` (no onset or leak size: it has none)."""
    alarms = scorer.alarm_windows(s) if hasattr(scorer, "alarm_windows") else (
        s >= scorer.threshold_)
    thr = getattr(scorer, "threshold_", None)
    out = {"threshold": None if thr is None else float(thr),
           "score_max": float(np.nanmax(s)) if np.isfinite(s).any() else None,
           "alarm": bool(np.any(alarms)),
           "alarm_time_s": float(t[np.argmax(alarms)]) if np.any(alarms) else None}
    if out["score_max"] is None:  # no window scored: nothing was tested
        out.update(alarm=None, error=_not_judged(det, len(s), duration_s))
    return out


def _verdict_columns(det, parts: list[FeatureSeries], t: np.ndarray, v: np.ndarray,
                     duration_s: float, start_time: float, path: str) -> dict:
    """A detector row's verdict: what ``leakdiag detect --detector`` says of the recording.

    The streamed windows are judged by :meth:`leakdiag.detect.base.Detector.predict_series`
    through :func:`leakdiag.detect.decision.judge` (a run longer than a healthy segment at its
    run level, as ``detect`` judges it):
    alarm, alarm time, onset estimate (the detector's own onset method), p-value, CUSUM
    maximum and threshold, and the leak size with its interval when the detector is
    calibrated. A recording with no finite window after the burn-in is not judged (``alarm``
    null, the reason in ``error``).
    """
    from leakdiag.detect.decision import judge
    from leakdiag.io.errors import RecordingError

    cols = {"threshold": float(det.threshold_)}
    if not parts:  # no window at all (run_case says why: _unusable)
        return {**cols, "alarm": None, "decision": None,
                "error": _not_judged(det, 0, duration_s)}
    # as detect judges a file: a run longer than a healthy segment at the level that holds it
    # to one segment's rate (leakdiag.detect.decision.judge_run)
    series = parts[0].with_values(v, time=t)
    fs = float(series.sample_rate)
    try:
        j = judge(det, int(round(duration_s * fs)), fs, duration_s,
                  lambda level: det.predict_series(series, duration_s, start_time,
                                                   source=path, level=level))
    except RecordingError as exc:  # nothing was tested: the detector says why
        return {**cols, "alarm": None, "decision": None,
                "threshold": _level_judged_at(det, int(round(duration_s * fs)), fs),
                "error": f"detector not judged: {exc}"}
    verdict, expected = j.verdict, j.expected
    d = verdict.as_dict()
    cols["threshold"] = float(verdict.threshold)  # the level judged at
    if j.run_level is not None:
        cols["run_level"] = j.run_level_words(float(det.threshold_))
    leak = None if verdict.leak is None else bool(verdict.leak)
    return {**cols, "alarm": leak, "decision": j.decision,
            "why_inconclusive": j.why_inconclusive,
            "false_alarms_expected": expected, "alarm_time_s": d["alarm_time_s"],
            "score_max": d["score_max"], "p_value": d["confidence"],
            "p_value_floor": d.get("confidence_floor"),
            "alarm_onset_s": d["onset_s"], "onset_method": d["onset_method"] if verdict.leak
            else None, "alarm_onset_censored": d["onset_censored"] if verdict.leak else None, "leak_lpm": d["leak_lpm"], "leak_lpm_low": d["leak_lpm_low"],
            "leak_lpm_high": d["leak_lpm_high"], "leak_lpm_in_range": d["leak_lpm_in_range"]}


def _lost_case_rows(path: str, exc: Exception, config: BatchConfig) -> list[dict]:
    """The error row of a recording whose case raised outside :func:`run_case` (a worker that
    died, a lost task)."""
    return [{"path": path, "recording": os.path.basename(path), "status": "error",
             "error": f"{type(exc).__name__}: {exc}", "job_digest": config.digest,
             "job_config": config.to_json(), "leakdiag_version": __version__}]
