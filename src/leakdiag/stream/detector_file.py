"""Fitted detectors on disk: a joblib file with a small metadata record checked on load.

``leakdiag fit`` writes the file; ``leakdiag detect --detector``, ``leakdiag monitor --detector``
and ``leakdiag batch`` (``[[detector]] path``) read it. The record holds the leakdiag version, the
method, the system, the sample rate, the channels and their units of the healthy recordings the
detector was fitted on; :func:`check_detector_fits` refuses a recording that disagrees.

Only load files you trust: joblib files are pickles and can run code.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import asdict, dataclass, field
from typing import Any

from leakdiag._version import __version__

__all__ = ["DetectorMeta", "save_detector", "load_detector_file", "check_detector_fits",
           "DETECTOR_FORMAT"]

#: Tag of the record written by :func:`save_detector`.
DETECTOR_FORMAT = "leakdiag-detector/1"


@dataclass(frozen=True)
class DetectorMeta:
    """What a fitted detector was fitted on.

    Attributes
    ----------
    method : str
        Registry name (:data:`leakdiag.bench.registry.METHODS`).
    system : str
        ``"vca"`` or ``"eha"``.
    sample_rate_hz : float
        Sample rate of the healthy recordings.
    channels : tuple of str
        Channels the detector reads.
    units : dict
        Unit of each of those channels.
    false_alarms_per_hour : float
        The CUSUM's false-alarm target on healthy operation.
    n_healthy : int
        Healthy recordings used.
    healthy_files : tuple of str
        Their paths, as given.
    leakdiag_version : str
        Version that wrote the file.
    load : str or None
        The load named in every healthy recording's metadata (``"none"``, ``"spring"``); None
        when they do not say or differ (files written before it: None).
    """

    method: str
    system: str
    sample_rate_hz: float
    channels: tuple
    units: dict = field(default_factory=dict)
    false_alarms_per_hour: float = 1.0
    n_healthy: int = 0
    healthy_files: tuple = ()
    leakdiag_version: str = __version__
    load: str | None = None


def save_detector(detector: Any, meta: DetectorMeta, path: str | os.PathLike) -> str:
    """Write a fitted detector and its metadata record with joblib.

    Parameters
    ----------
    detector : Detector
        Fitted detector.
    meta : DetectorMeta
        What it was fitted on.
    path : str or path-like
        Output file (``.joblib`` by convention).

    Returns
    -------
    str
        The path written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "d.joblib"
    >>> _ = save_detector({"toy": 1}, DetectorMeta("acf-p1", "vca", 1000.0, ("p1",)), p)
    >>> load_detector_file(p)[1].method
    'acf-p1'
    """
    import joblib

    path = os.fspath(path)
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    joblib.dump({"format": DETECTOR_FORMAT, "meta": asdict(meta), "detector": detector}, path)
    return path


def load_detector_file(path: str | os.PathLike) -> tuple[Any, DetectorMeta | None]:
    """Read a detector file written by :func:`save_detector` (or a bare pickled detector).

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    detector : object
        The fitted detector.
    meta : DetectorMeta or None
        Its record; None for a bare pickle (nothing can be checked; a warning says so).

    Raises
    ------
    ValueError
        If the file cannot be read as a detector file.

    Warns
    -----
    UserWarning
        When the file was written by another leakdiag version, or has no metadata record.
    """
    import joblib

    path = os.fspath(path)
    try:
        obj = joblib.load(path)
    except Exception as exc:  # noqa: BLE001 - garbage bytes raise anything; name the file
        raise ValueError(f"{path}: cannot load as a detector file (leakdiag fit -o ...): "
                         f"{type(exc).__name__}: {exc}") from None
    if isinstance(obj, dict) and obj.get("format") == DETECTOR_FORMAT:
        raw = dict(obj["meta"])
        raw["channels"] = tuple(raw.get("channels", ()))
        raw["healthy_files"] = tuple(raw.get("healthy_files", ()))
        meta = DetectorMeta(**raw)
        if meta.leakdiag_version != __version__:
            warnings.warn(f"{path}: written by leakdiag {meta.leakdiag_version}, this is "
                          f"{__version__}; re-fit it (leakdiag fit) if loading misbehaves",
                          UserWarning, stacklevel=2)
        return obj["detector"], meta
    if isinstance(obj, dict):
        raise ValueError(f"{path}: not a leakdiag detector file (no {DETECTOR_FORMAT!r} record)")
    warnings.warn(f"{path}: a bare pickled detector without a metadata record: its sample "
                  "rate, channels and units cannot be checked; write it with leakdiag fit",
                  UserWarning, stacklevel=2)
    return obj, None


def check_detector_fits(meta: DetectorMeta | None, *, sample_rate: float,
                        channels=None, units: dict | None = None, system: str | None = None,
                        source: str = "<recording>", path: str = "<detector>",
                        load: str | None = None) -> None:
    """Refuse a recording that disagrees with what the detector was fitted on.

    Parameters
    ----------
    meta : DetectorMeta or None
        The detector's record (None: nothing to check).
    sample_rate : float
        The recording's sample rate in Hz.
    channels : iterable of str, optional
        The recording's channels.
    units : dict, optional
        The recording's channel units.
    system : str, optional
        The recording's system (from its metadata).
    source, path : str
        Names for the message.
    load : str, optional
        The recording's load (from its metadata): refused when the detector's healthy
        recordings all named another one (a detector fitted without load judged healthy spring
        runs LEAK).

    Raises
    ------
    ValueError
        Naming the file, the detector file and what differs.

    Examples
    --------
    >>> m = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"})
    >>> check_detector_fits(m, sample_rate=500.0, source="r.csv", path="d.joblib")
    Traceback (most recent call last):
    ...
    ValueError: r.csv: sample rate 500 Hz, but d.joblib was fitted at 1000 Hz
    """
    if meta is None:
        return
    if abs(float(sample_rate) - meta.sample_rate_hz) > 1e-9 * meta.sample_rate_hz:
        raise ValueError(f"{source}: sample rate {sample_rate:g} Hz, but {path} was fitted at "
                         f"{meta.sample_rate_hz:g} Hz")
    if system and str(system).lower() != meta.system:
        raise ValueError(f"{source}: system {str(system).lower()!r}, but {path} was fitted on "
                         f"{meta.system!r} recordings")
    fitted_load = getattr(meta, "load", None)
    if load is not None and fitted_load is not None and str(load) != fitted_load:
        raise ValueError(f"{source}: load {str(load)!r}, but {path} was fitted on healthy "
                         f"recordings with load {fitted_load!r}; fit one on healthy recordings "
                         "under this load")
    if channels is not None:
        missing = [c for c in meta.channels if c not in set(channels)]
        if missing:
            raise ValueError(f"{source}: no channel {', '.join(missing)}, which {path} reads")
    for c in meta.channels:
        want, got = meta.units.get(c), (units or {}).get(c)
        if want and got and want != got:
            raise ValueError(f"{source}: channel {c!r} is in {got!r}, but {path} was fitted "
                             f"on {want!r}")
