"""Streaming: windowed features, detector scores and alarms computed chunk by chunk.

Given a :class:`~leakdiag.features.spec.MethodSpec`, :class:`StreamingFeature` computes
Eq. 4.1-4.3 incrementally with a state of less than one window per channel; :class:`Monitor`
combines features with detectors (the :class:`WindowScorer` protocol) into :class:`WindowEvent` s;
:mod:`leakdiag.stream.files` reads Parquet/HDF5/CSV files in chunks (larger than memory),
:mod:`leakdiag.stream.live` follows growing files and stdin and paces replays;
:func:`save_detector` and :func:`load_detector_file` write and read the detector files of
``leakdiag fit`` (pickles: load only files you trust). See ``docs/operations.md``.
"""

from leakdiag.stream.feature import StreamingFeature, stream_methods
from leakdiag.stream.detector import DetectorScorer
from leakdiag.stream.monitor import Monitor, WindowEvent, WindowScorer, check_scorer
from leakdiag.stream.chunks import ChunkSource, recording_chunks
from leakdiag.stream.files import open_chunks
from leakdiag.stream.live import csv_lines, paced, tail_csv
from leakdiag.stream.summary import stream_feature
from leakdiag.stream.detector_file import (DetectorFileWarning, DetectorMeta, check_detector_fits,
                                           load_detector_file, save_detector)

__all__ = [
    "stream_methods",
    "StreamingFeature",
    "Monitor",
    "WindowEvent",
    "WindowScorer",
    "check_scorer",
    "DetectorScorer",
    "ChunkSource",
    "open_chunks",
    "recording_chunks",
    "csv_lines",
    "tail_csv",
    "paced",
    "stream_feature",
    "DetectorMeta",
    "DetectorFileWarning",
    "save_detector",
    "load_detector_file",
    "check_detector_fits",
]
