"""The batch job configuration: which analyses (with sweeps) and detectors run on every recording.

Read from TOML (schema in ``docs/operations.md``)::

    [job]
    chunk_samples = 1048576   # samples per read chunk (memory bound)
    rms_chunk = 10            # feature values per RMS chunk (Sec. 5.2)
    # onset_s = 30.0          # leak onset for the Sec. 5.2 measure; default: each file's meta
    # column_map = "map.toml" # your own files: column map (docs/io.md), relative to this TOML

    [[analysis]]
    method = "autocorrelation"
    channels = ["p1"]
    lag = [1, 5]              # a list sweeps: one analysis per combination
    window = 200
    overlap = 5

    [[detector]]
    name = "ac-p1"
    path = "det.joblib"       # detector file from leakdiag fit, relative to the TOML file
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
from dataclasses import dataclass, field
from typing import Any, Mapping

from leakdiag._validation import check_int
from leakdiag.features.spec import MethodSpec
from leakdiag.stream.feature import stream_methods

__all__ = ["BatchConfig", "DetectorRef", "load_config", "config_from_dict", "detector_ref",
           "DEFAULT_CHUNK_SAMPLES", "DEFAULT_RMS_CHUNK"]

#: Samples per read chunk: 1 Mi samples = 8 MB per float64 channel.
DEFAULT_CHUNK_SAMPLES = 1 << 20
#: Feature values per RMS chunk of the Sec. 5.2 measure (the analyze command's default).
DEFAULT_RMS_CHUNK = 10

_ANALYSIS_KEYS = {"method", "channels", "lag", "lag_ratio", "window", "overlap"}
_SWEEPABLE = ("lag", "lag_ratio", "window", "overlap")


@dataclass(frozen=True)
class DetectorRef:
    """A fitted detector file (``leakdiag fit``) to run on every recording.

    Parameters
    ----------
    name : str
        Name in the results table.
    path : str
        Absolute path of the detector file.
    sha256 : str
        Digest of the file, so that a re-fitted detector invalidates finished results.
    origin : str, default ""
        Where the job names it, for messages: ``"job.toml: [[detector]] #2 (path =
        'det.joblib')"`` or ``"--detector"`` (not part of the job's digest).
    """

    name: str
    path: str
    sha256: str
    origin: str = field(default="", compare=False)


@dataclass(frozen=True)
class BatchConfig:
    """Everything a batch run computes; stored (as JSON) with every result row.

    Parameters
    ----------
    analyses : tuple of MethodSpec
        Streamable features (sweeps already expanded).
    detectors : tuple of DetectorRef
        Fitted detectors.
    chunk_samples : int
        Samples per read chunk.
    rms_chunk : int
        Feature values per RMS chunk (Sec. 5.2).
    onset_s : float or None
        Leak onset for the Sec. 5.2 measure; None uses each recording's ``meta['onset']``.
    column_map : str or None
        Absolute path of a column map TOML for every recording (files are then read whole).
    column_map_sha256 : str or None
        Its digest (a changed map invalidates finished results).

    Raises
    ------
    ValueError
        If there is nothing to run or a method cannot be streamed.

    Examples
    --------
    >>> cfg = config_from_dict({"analysis": [{"method": "autocorrelation", "lag": [1, 2]}]})
    >>> [s.lag for s in cfg.analyses], len(cfg.digest)
    ([1, 2], 16)
    """

    analyses: tuple[MethodSpec, ...] = ()
    detectors: tuple[DetectorRef, ...] = ()
    chunk_samples: int = DEFAULT_CHUNK_SAMPLES
    rms_chunk: int = DEFAULT_RMS_CHUNK
    onset_s: float | None = None
    column_map: str | None = None
    column_map_sha256: str | None = None

    def __post_init__(self) -> None:
        if not self.analyses and not self.detectors:
            raise ValueError("the batch config has no [[analysis]] and no [[detector]]")
        for s in self.analyses:
            if s.method not in stream_methods():
                raise ValueError(f"analysis method={s.method!r} is not one of {stream_methods()}")
        object.__setattr__(self, "chunk_samples", check_int(self.chunk_samples, "chunk_samples", 1))
        object.__setattr__(self, "rms_chunk", check_int(self.rms_chunk, "rms_chunk", 1))
        if self.onset_s is not None:
            # a CLI audit, 2026-11-29: onset_s = nan replaced each file's own onset, and every
            # row read "0 before and 0 after" the onset with status ok
            onset = self.onset_s
            if isinstance(onset, bool) or not isinstance(onset, (int, float)) \
                    or not math.isfinite(onset) or onset < 0:
                raise ValueError(f"[job] onset_s = {onset!r}: must be a finite number of "
                                 "seconds >= 0 (leave it out to use each recording's own "
                                 "onset)")
            object.__setattr__(self, "onset_s", float(onset))

    def to_dict(self) -> dict:
        """JSON-serialisable form (stored with the results).

        Returns
        -------
        dict
        """
        return {"analyses": [s.as_dict() for s in self.analyses],
                "detectors": [{"name": d.name, "path": d.path, "sha256": d.sha256}
                              for d in self.detectors],
                "chunk_samples": self.chunk_samples, "rms_chunk": self.rms_chunk,
                "onset_s": self.onset_s, "column_map": self.column_map,
                "column_map_sha256": self.column_map_sha256}

    def to_json(self) -> str:
        """Canonical JSON text of :meth:`to_dict` (sorted keys).

        Returns
        -------
        str
        """
        return json.dumps(self.to_dict(), sort_keys=True)

    @property
    def digest(self) -> str:
        """First 16 hex digits of the SHA-256 of :meth:`to_json`; identifies the job's results."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()[:16]


def _as_list(v) -> list:
    return list(v) if isinstance(v, (list, tuple)) else [v]


def _expand(entry: Mapping[str, Any], i: int) -> list[MethodSpec]:
    unknown = set(entry) - _ANALYSIS_KEYS
    if unknown:
        raise ValueError(f"[[analysis]] #{i + 1}: unknown key(s) {sorted(unknown)}; "
                         f"allowed: {sorted(_ANALYSIS_KEYS)}")
    if "method" not in entry:
        raise ValueError(f"[[analysis]] #{i + 1}: needs a method")
    chans = entry.get("channels", ())
    chans = tuple(c.strip() for c in chans.split(",")) if isinstance(chans, str) else tuple(chans)
    keys = [k for k in _SWEEPABLE if k in entry]
    specs = []
    for combo in itertools.product(*(_as_list(entry[k]) for k in keys)):
        kw = dict(zip(keys, combo))
        try:
            specs.append(MethodSpec(entry["method"], chans, **kw))
        except (TypeError, ValueError) as exc:
            where = ", ".join(f"{k} = {v!r}" for k, v in kw.items())
            raise ValueError(f"[[analysis]] #{i + 1}" + (f" ({where})" if where else "")
                             + f": {exc}") from None
    return specs


def _check_repeats(made: list[tuple[MethodSpec, str]]) -> None:
    """Refuse a feature that the job computes twice (its rows and store keys would be one);
    ``made``: each setting with the entry that made it."""
    first: dict = {}
    for spec, entry in made:
        if spec in first:
            was = first[spec]
            raise ValueError(
                f"{entry} repeats " + ("a setting of its own" if was == entry else was)
                + f": {spec.label} would be computed twice, with two result rows of one name; "
                "give each setting once")
        first[spec] = entry


def detector_ref(path: str | os.PathLike, name: str | None = None,
                 origin: str = "") -> DetectorRef:
    """A :class:`DetectorRef` for a detector file (digest of its bytes).

    Parameters
    ----------
    path : str or path-like
        Detector file (``leakdiag fit -o ...``).
    name : str, optional
        Name in the results (default: the file name without suffix).
    origin : str, default ""
        Where the job names it (:attr:`DetectorRef.origin`).

    Returns
    -------
    DetectorRef

    Raises
    ------
    OSError
        If the file cannot be read.
    """
    path = os.path.abspath(os.fspath(path))
    with open(path, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    return DetectorRef(name or os.path.splitext(os.path.basename(path))[0], path, digest,
                       origin)


#: The keys of a ``[[detector]]`` entry (a detector file keeps its own settings).
_DETECTOR_KEYS = frozenset({"path", "name"})


def _detector(entry: Mapping[str, Any], i: int, base_dir: str, where: str) -> DetectorRef:
    unknown = set(entry) - _DETECTOR_KEYS
    if unknown:  # a CLI audit, 2026-11-29: a misspelt name or a false_alarm_rate was dropped
        raise ValueError(f"[[detector]] #{i + 1}: unknown key(s) {sorted(unknown)}; allowed: "
                         f"{sorted(_DETECTOR_KEYS)} (a detector file keeps the settings it "
                         "was fitted with: leakdiag fit)")
    if "path" not in entry:
        raise ValueError(f"[[detector]] #{i + 1}: needs a path to a detector file (leakdiag fit)")
    path = os.path.abspath(os.path.join(base_dir, entry["path"]))
    origin = f"{where}[[detector]] #{i + 1} (path = {str(entry['path'])!r})"
    try:
        return detector_ref(path, None if "name" not in entry else str(entry["name"]), origin)
    except OSError as exc:
        raise ValueError(f"[[detector]] #{i + 1}: cannot read {path} (path = "
                         f"{str(entry['path'])!r}): {exc.strerror or exc}") from None


def _check_names(dets: list[DetectorRef], where: str) -> None:
    """Refuse two detectors of one name: their rows, their refusals and their stored runs
    could not be told apart (a detector's name is its key in the results and the store)."""
    seen: dict[str, DetectorRef] = {}
    for d in dets:
        first = seen.setdefault(d.name, d)
        if first is not d:
            def said(ref):
                if ref.origin == "--detector":
                    return f"--detector {ref.path}"
                return ref.origin[len(where):] if where and ref.origin.startswith(where) \
                    else ref.origin or ref.path
            raise ValueError(f"{said(first)} and {said(d)} have the same detector name "
                             f"{d.name!r}: their rows and stored runs could not be told apart; "
                             "give each [[detector]] its own name = \"...\" (a --detector file "
                             "is named after its file stem)")


def config_from_dict(d: Mapping[str, Any], base_dir: str = ".", *, source: str | None = None,
                     extra_detectors: tuple[DetectorRef, ...] = ()) -> BatchConfig:
    """Build a :class:`BatchConfig` from the parsed TOML (sweeps expanded).

    Parameters
    ----------
    d : dict
        Tables ``job`` (optional), ``analysis`` (list), ``detector`` (list).
    base_dir : str, default "."
        Directory that relative detector paths are relative to.
    source : str, optional
        The job file's name, for the entries' :attr:`DetectorRef.origin`.
    extra_detectors : tuple of DetectorRef, default ()
        Detectors added to the ``[[detector]]`` entries (``leakdiag batch --detector``).

    Returns
    -------
    BatchConfig

    Raises
    ------
    ValueError
        For unknown tables or keys, bad settings (the message names the entry), two detectors
        of one name (naming both), a feature made twice (naming the entries), or no work.
    """
    unknown = set(d) - {"job", "analysis", "detector"}
    if unknown:
        raise ValueError(f"unknown table(s) {sorted(unknown)}; allowed: job, analysis, detector")
    job = dict(d.get("job", {}))
    bad = set(job) - {"chunk_samples", "rms_chunk", "onset_s", "column_map"}
    if bad:
        raise ValueError(f"[job]: unknown key(s) {sorted(bad)}")
    where = f"{source}: " if source else ""
    made = [(s, f"[[analysis]] #{i + 1}") for i, e in enumerate(d.get("analysis", []))
            for s in _expand(e, i)]
    _check_repeats(made)
    specs = [s for s, _ in made]
    dets = [_detector(e, i, base_dir, where) for i, e in enumerate(d.get("detector", []))]
    dets += list(extra_detectors)
    _check_names(dets, where)
    onset = job.get("onset_s")
    cmap = cmap_sha = None
    if job.get("column_map") is not None:
        cmap = os.path.abspath(os.path.join(base_dir, str(job["column_map"])))
        try:
            with open(cmap, "rb") as f:
                cmap_sha = hashlib.sha256(f.read()).hexdigest()
        except OSError as exc:
            raise ValueError(f"[job] column_map: cannot read {cmap}: {exc}") from None
    return BatchConfig(tuple(specs), tuple(dets), job.get("chunk_samples", DEFAULT_CHUNK_SAMPLES),
                       job.get("rms_chunk", DEFAULT_RMS_CHUNK),
                       onset, cmap, cmap_sha)


def load_config(path: str | os.PathLike | None, detectors=()) -> BatchConfig:
    """Read a batch job TOML file.

    Parameters
    ----------
    path : str or path-like or None
        The TOML file; None: a job of the ``detectors`` alone, with the default settings
        (``leakdiag batch --detector`` without ``--config``).
    detectors : sequence of path-like, default ()
        More detector files (``leakdiag batch --detector``; relative to the working directory),
        added to the job's ``[[detector]]`` entries, so a job may consist of them alone.

    Returns
    -------
    BatchConfig

    Raises
    ------
    FileNotFoundError
        If it does not exist.
    ValueError
        For invalid TOML or settings (the message names the file).
    """
    import tomllib

    try:
        extra = tuple(detector_ref(p, origin="--detector") for p in detectors)
    except OSError as exc:
        raise ValueError(f"--detector: cannot read {exc.filename}: {exc.strerror}") from None
    if path is None:
        if not extra:
            raise ValueError("a job needs a job file (--config) or a detector (--detector)")
        return config_from_dict({}, extra_detectors=extra)
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            d = tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: invalid TOML: {exc}") from None
    try:
        return config_from_dict(d, os.path.dirname(os.path.abspath(path)), source=path,
                                extra_detectors=extra)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
