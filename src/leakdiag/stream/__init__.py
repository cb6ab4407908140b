"""Streaming: windowed features, detector scores and alarms computed chunk by chunk.

Given a :class:`~leakdiag.features.spec.MethodSpec`, :class:`StreamingFeature` computes
Eq. 4.1-4.3 incrementally with a state of less than one window per channel; :class:`Monitor`
combines features with detectors (the :class:`WindowScorer` protocol) into :class:`WindowEvent` s;
:mod:`leakdiag.stream.files` reads Parquet/HDF5/CSV files in chunks (larger than memory),
:mod:`leakdiag.stream.live` follows growing files and stdin and paces replays;
:func:`save_detector` and :func:`load_detector_file` write and read the detector files of
``leakdiag fit`` (pickles: load only files you trust). See ``docs/operations.md``.
"""

import importlib
from typing import Any

#: Where each public name lives: the package imports a submodule when one of its names is first
#: used, so that importing a light submodule (``leakdiag.stream.blind`` in the monitor's page
#: sidecar) does not import the detectors and scikit-learn (1 s) with it.
_WHERE = {
    "StreamingFeature": "feature", "stream_methods": "feature",
    "DetectorScorer": "detector",
    "Monitor": "monitor", "WindowEvent": "monitor", "WindowScorer": "monitor",
    "check_scorer": "monitor",
    "ChunkSource": "chunks", "recording_chunks": "chunks",
    "open_chunks": "files",
    "csv_lines": "live", "paced": "live", "tail_csv": "live",
    "stream_feature": "summary",
    "DetectorFileWarning": "detector_file", "DetectorMeta": "detector_file",
    "check_detector_fits": "detector_file", "load_detector_file": "detector_file",
    "save_detector": "detector_file",
    "SegmentJudge": "segments", "SegmentVerdict": "segments", "judges_whole": "segments",
    "BlindSpans": "blind",
}
_SUBMODULES = {"blind", "chunks", "detector", "detector_file", "episodes", "feature", "files",
               "live", "monitor", "segments", "summary"}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        value = getattr(importlib.import_module(f"leakdiag.stream.{_WHERE[name]}"), name)
        globals()[name] = value  # the next lookup is a plain attribute
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"leakdiag.stream.{name}")
    raise AttributeError(f"module 'leakdiag.stream' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(__all__) | _SUBMODULES)


__all__ = list(_WHERE)
