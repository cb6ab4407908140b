"""Recordings in and out: the :class:`Recording` model, readers and writers, column maps, units.

Public API::

    read_recording(path, column_map=None, *, sample_rate=None, resample=None, units=None)
    write_recording(rec, path)                       # .csv, .parquet, .h5/.hdf5
    recording_units(path)                            # units a file's header states
    load_column_map(source) / build_column_map(specs, *, base=None, **file_options)
    parse_column_spec("p1=PG_1:counts*0.5")          # -> ("p1", ChannelSpec)
    check_length(rec, window, channel=None)
    to_si(values, unit, ...), unit_factor(unit), unit_quantity(unit), known_units()

See ``docs/io.md`` for formats, the column-map syntax, units and the error catalogue.
"""

from leakdiag.io.api import read_recording, recording_units, write_recording
from leakdiag.io.checks import check_channel_finite, check_length, infer_sample_rate
from leakdiag.io.column_map import ChannelSpec, ColumnMap, load_column_map, parse_column_spec
from leakdiag.io.column_spec import build_column_map
from leakdiag.io.errors import CutLastRowWarning
from leakdiag.io.recording import STANDARD_CHANNELS, Recording, RecordingError, load_name
from leakdiag.io.resample import resample_linear
from leakdiag.io.units import known_units, to_si, unit_factor, unit_quantity

__all__ = [
    "load_name",
    "Recording",
    "RecordingError",
    "CutLastRowWarning",
    "STANDARD_CHANNELS",
    "read_recording",
    "write_recording",
    "recording_units",
    "ChannelSpec",
    "ColumnMap",
    "load_column_map",
    "build_column_map",
    "parse_column_spec",
    "check_length",
    "check_channel_finite",
    "infer_sample_rate",
    "resample_linear",
    "known_units",
    "to_si",
    "unit_factor",
    "unit_quantity",
]
