"""What both modes of benchmark v5 share: the alarm, keys, lazy calibration runs, held-out rows.

:mod:`leakdiag.bench.v5_run` (fleet mode and the runner) and :mod:`leakdiag.bench.v5_unit`
(per-unit mode) both import from here, so neither imports the other's module at load time.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import leakdiag.sim as sim
from leakdiag.bench._workfiles import write_atomic
from leakdiag.bench.run import _recording, simulator_kwargs
from leakdiag.detect.base import Alarm

__all__ = ["LazyRecordings", "Plan", "v5_alarm", "run_row", "error_row", "write_shard",
           "shard_rows", "FINGERPRINT_PARTS", "FINGERPRINT_EXCLUDED"]


class LazyRecordings(Sequence):
    """Calibration runs read from the simulation cache one at a time (``Detector.fit`` input).

    Parameters
    ----------
    cases : sequence of BenchCase
        Runs (already in the cache, or simulated into it on access).
    cache_dir : str or None
        Simulation cache.
    """

    def __init__(self, cases, cache_dir):
        self.cases = list(cases)
        self.cache_dir = cache_dir

    def __len__(self) -> int:
        return len(self.cases)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return LazyRecordings(self.cases[i], self.cache_dir)
        return _recording(self.cases[i], self.cache_dir)


def v5_alarm(false_alarm_per_run: float, duration_s: float, onset_method: str = "binseg",
             confidence: float | None = None):
    """The alarm of a v5 group: one segment per run, ``false_alarm_per_run`` per segment.

    Parameters
    ----------
    false_alarm_per_run : float
        Target false-alarm probability per healthy run, in (0, 1).
    duration_s : float
        Run duration (s); the segment is the monitored span ``duration_s - burn_in``.
    onset_method : str, default "binseg"
        Onset estimator.
    confidence : float, optional
        Calibration-conditional rank (:class:`~leakdiag.detect.base.Alarm`); None: marginal.

    Returns
    -------
    Alarm
        ``segment_s = duration_s - 5``, ``false_alarms_per_hour = p * 3600 / segment_s``.

    Examples
    --------
    >>> a = v5_alarm(0.01, 60.0)
    >>> a.segment_s, round(a.false_alarms_per_hour * a.segment_s / 3600, 12)
    (55.0, 0.01)
    """
    base = Alarm(onset_method=onset_method, confidence=confidence)
    seg = duration_s - base.burn_in_s
    return replace(base, segment_s=seg, false_alarms_per_hour=false_alarm_per_run * 3600.0 / seg)


#: What the resume key of a v5 result hashes: every part of the package whose code can change
#: a result -- the simulators (held-out runs are simulated afresh, calibration runs are read
#: through the cache), the recording type and readers, the cache and executor, the argument
#: checks, the detectors, features, literature methods and the benchmark itself. Subfolders
#: count too (``sim/vca``, ``features/_kernels``).
FINGERPRINT_PARTS = ("_validation.py", "_holds.py", "bench", "detect", "features", "io",
                     "literature", "runtime", "sim")
#: Parts the v5 pipeline imports that cannot change a result (checked by the tests).
FINGERPRINT_EXCLUDED = {"report": "HTML pages and figure styles (bench.report.method_style)",
                        "_version": "the version number, not code",
                        "_format": "instants written as text in messages, no number",
                        "_fingerprint": "computes this fingerprint (hashes, no result)",
                        "_numba_cache": "names the folder of Numba's compiled kernels"}


def _part_fingerprint(part: str) -> str:
    """SHA-256 (16 hex digits) of one part of the package (a module file or a folder)."""
    root = Path(__file__).resolve().parents[1]  # the leakdiag package
    h = hashlib.sha256()
    p = root / part
    files = [p] if p.is_file() else sorted(p.rglob("*.py"))
    for f in files:
        h.update(f.relative_to(root).as_posix().encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:16]


def _fingerprint() -> str:
    """Code fingerprint of a v5 result: every part of :data:`FINGERPRINT_PARTS`, in order.

    Returns
    -------
    str
        16 hex digits; part of every fit, reference and shard key, so that a change to any of
        that code (a simulator edit included) never reads a result of the former code.
    """
    h = hashlib.sha256()
    for part in FINGERPRINT_PARTS:
        h.update(f"{part}={_part_fingerprint(part)};".encode())
    return h.hexdigest()[:16]


def _key(obj) -> str:
    txt = json.dumps(obj, sort_keys=True, default=str)
    return hashlib.sha256(txt.encode()).hexdigest()[:24]


def _simulate(case):
    return getattr(sim, f"simulate_{case.system}")(**simulator_kwargs(case))


def error_row(case, method: str, exc: Exception) -> dict:
    """The row of a held-out run a method could not judge (recorded, never dropped).

    Parameters
    ----------
    case, method : BenchCase, str
        The run and the registry name of the method.
    exc : Exception
        What failed.

    Returns
    -------
    dict
        Role ``"error"``, the run's own role as ``refused_role`` (a refused leaking run counts
        as not detected, :func:`~leakdiag.bench.v5_scoring.detection_table`) and the error's
        type and message.
    """
    return {"method": method, "system": case.system, "load": case.load,
            "excitation": case.excitation, "role": "error", "refused_role": case.role,
            "seed": case.seed, "leak_lpm": case.leak_lpm, "onset_true_s": case.onset_s,
            "error": f"{type(exc).__name__}: {exc}"}


def run_row(case, method: str, rec, v, cpu_s: float, sim_cpu_s: float) -> dict:
    """The row of one judged held-out run (both modes; per-unit mode adds threshold columns).

    Parameters
    ----------
    case : BenchCase
        The run.
    method : str
        Registry name.
    rec : Recording
        Its simulation (achieved leak in the metadata).
    v : Verdict
        The method's verdict.
    cpu_s, sim_cpu_s : float
        CPU seconds of judging and of simulating.

    Returns
    -------
    dict
        The columns of ``runs.csv``.
    """
    return {"method": method, "system": case.system, "load": case.load,
            "excitation": case.excitation, "role": case.role, "leak_lpm": case.leak_lpm,
            "seed": case.seed, "machine": case.nuisance["machine"],
            "duration_s": case.duration_s, "onset_true_s": case.onset_s,
            "leak_lpm_achieved": rec.meta.get("leak_lpm_achieved"),
            "noise_std_pa": case.noise_std_pa, "score_max": v.score_max,
            "alarm": bool(v.leak), "alarm_time_s": v.alarm_time_s,
            "onset_est_s": v.onset_s, "leak_lpm_est": v.leak_lpm,
            **{k: v.as_dict()[k] for k in ("leak_lpm_low", "leak_lpm_high")},
            "confidence": v.confidence,
            "threshold": v.threshold, "cpu_s": cpu_s, "sim_cpu_s": sim_cpu_s}


def deadline_alarms(det, rec, case, deadlines: Sequence[float] | None = None) -> dict:
    """Whether a whole-recording detector has a LEAK by each deadline after the onset, from the
    recording cut there: what the user would know at that moment.

    A whole-recording detector (the flow balance) fits the recording's own nuisance on all of
    it and refuses alarms from data after them, so its alarm time on the whole recording is not
    what it would say at the deadline (benchmark audit 2026-11-28, finding 6: 3 of 64 runs
    "detected within 10 s" got no verdict when cut at onset + 10 s). For a leaking run each
    deadline ``d`` judges ``rec.slice_time(None, onset + d)``; a LEAK whose alarm is at or
    after the onset is a detection by ``d`` (a refusal or an earlier alarm is not). Other
    detectors and runs give an empty dict (their alarm time is causal: the window scores).

    Parameters
    ----------
    det : Detector
        The fitted detector.
    rec : Recording
        The whole run.
    case : BenchCase
        The run's case (role, onset).
    deadlines : sequence of float, optional
        Seconds after the onset (default :data:`~leakdiag.bench.v5_suite.DEADLINES_S`).

    Returns
    -------
    dict
        ``alarm_by_<d>s`` -> bool for each deadline within the run.
    """
    from leakdiag.bench.v5_suite import DEADLINES_S
    from leakdiag.io.errors import RecordingError
    from leakdiag.stream.segments import judges_whole

    if case.role != "test_leak" or case.onset_s is None or not judges_whole(det):
        return {}
    out = {}
    end = rec.start_time + rec.duration
    for d in DEADLINES_S if deadlines is None else deadlines:
        t1 = float(case.onset_s) + float(d)
        try:
            v = det.predict(rec if t1 >= end else rec.slice_time(None, t1))
        except (RecordingError, ValueError, ArithmeticError):
            out[f"alarm_by_{d:g}s"] = False
            continue
        out[f"alarm_by_{d:g}s"] = bool(v.leak) and v.alarm_time_s >= float(case.onset_s)
    return out


def write_shard(rows: list, path) -> int:
    """Write one result shard atomically (Parquet).

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`run_row` / :func:`error_row`.
    path : path-like
        Shard file.

    Returns
    -------
    int
        Rows written.
    """
    import pandas as pd

    df = pd.DataFrame(rows)
    for col in ("onset_true_s", "alarm_time_s", "onset_est_s", "leak_lpm_achieved",
                "leak_lpm_est", "leak_lpm_low", "leak_lpm_high"):
        if col in df:
            df[col] = pd.to_numeric(df[col], errors="coerce")
    write_atomic(path, lambda tmp: df.to_parquet(tmp, index=False))  # a temp file per writer
    return len(df)


def shard_rows(path) -> int:
    """Rows of a written shard, from its Parquet metadata (an empty shard has no columns).

    Parameters
    ----------
    path : path-like
        Shard file.

    Returns
    -------
    int
        Rows in the shard (0 for a chunk none of whose methods could judge).
    """
    import pyarrow.parquet as pq

    return int(pq.ParquetFile(path).metadata.num_rows)


@dataclass(frozen=True)
class Plan:
    """Stages 2 and 3 of a v5 run: fit tasks and scoring chunks, with their functions."""

    fit: Any
    fit_tasks: list
    fit_desc: str
    score: Any
    chunks: list
    score_desc: str
    n_fit_tasks: int
