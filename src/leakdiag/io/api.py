"""``read_recording`` and ``write_recording``: the file formats behind one pair of functions."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Collection, Mapping

from leakdiag.io.assemble import table_to_recording
from leakdiag.io.column_map import load_column_map
from leakdiag.io.hdf5 import read_hdf5, read_hdf5_header, write_hdf5
from leakdiag.io.header import encode_header
from leakdiag.io.matlab import read_mat
from leakdiag.io.parquet import read_parquet, read_parquet_header, write_parquet
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.text import read_text, write_csv

__all__ = ["READ_FORMATS", "WRITE_FORMATS", "read_recording", "write_recording",
           "recording_units"]

#: File extension -> format name, for reading.
READ_FORMATS: dict[str, str] = {
    ".csv": "text", ".tsv": "text", ".txt": "text", ".dat": "text",
    ".parquet": "parquet", ".pq": "parquet",
    ".h5": "hdf5", ".hdf5": "hdf5",
    ".mat": "mat",
}
#: File extension -> format name, for writing.
WRITE_FORMATS: dict[str, str] = {
    ".csv": "csv", ".parquet": "parquet", ".pq": "parquet", ".h5": "hdf5", ".hdf5": "hdf5",
}


def _format(path: Path, table: Mapping[str, str], verb: str) -> str:
    fmt = table.get(path.suffix.lower())
    if fmt is None:
        raise RecordingError(
            f"{path}: cannot {verb} files with extension {path.suffix or '(none)'!r}; "
            f"known: {', '.join(table)}"
        )
    return fmt


def read_recording(path: str | os.PathLike, column_map: Any = None, *,
                   sample_rate: float | None = None, resample: float | None = None,
                   units: Mapping[str, str] | None = None,
                   channels: Collection[str] | None = None) -> Recording:
    """Read a recording from CSV/TSV text, Parquet, HDF5 or MATLAB ``.mat``.

    Parameters
    ----------
    path : str or path-like
        The file; the format is chosen by extension (see :data:`READ_FORMATS`).
    column_map : ColumnMap, dict, str or pathlib.Path, optional
        Which column is which channel, its unit and scale, and file options (separator,
        sample rate, time column); a TOML file path or anything
        :func:`~leakdiag.io.column_map.load_column_map` accepts. Without a map, a file
        written by :func:`write_recording` is restored exactly, and any other file must name
        its columns ``time`` (s), ``p1``, ``p2`` (Pa), ``x`` (m), ``u`` (V), ``x_ref`` (m),
        ``leak_flow`` (m^3/s).
    sample_rate : float, optional
        Sample rate in Hz, when the file has no time column in seconds.
    resample : float, optional
        Target rate in Hz. Linearly interpolates the time axis (uniform or not) onto a uniform
        grid and records it in ``meta["resampled"]``. Without it, a non-uniform time axis is an
        error.
    units : dict of str to str, optional
        Channel -> unit of the values in the file, e.g. ``{"p1": "bar"}``.
    channels : collection of str, optional
        Read only these channels (of those the file or the map has): the other columns are
        neither converted nor checked, e.g. a text note beside the signals. A file written by
        :func:`write_recording` is restored whole.

    Returns
    -------
    Recording
        Channels in SI units (``counts`` when counts come without a gain).

    Raises
    ------
    RecordingError
        One message naming the file, channel or column, row and problem: file not found,
        unknown extension, unreadable or empty file, missing column (lists the available
        ones), a column read whose name appears twice in the header, a row too short to hold
        the columns read (truncated line), text in a mapped column, NaN/inf (first row),
        non-monotonic or non-uniform time (suggests ``--resample``), channels of different
        lengths, unknown unit (lists known ones), no sample rate. See ``docs/io.md`` for the
        catalogue.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = p.write_text("time,p1,x\\n0.000,1e5,0.01\\n0.001,2e5,0.02\\n0.002,3e5,0.03\\n")
    >>> rec = read_recording(p)
    >>> rec.sample_rate, rec["p1"].tolist(), rec.units["x"]
    (1000.0, [100000.0, 200000.0, 300000.0], 'm')
    >>> q = pathlib.Path(tempfile.mkdtemp()) / "rig.txt"
    >>> _ = q.write_text("n\\tPA_bar\\tnote\\n1\\t10\\tstart\\n2\\t12\\t\\n3\\t14\\t\\n")
    >>> rec = read_recording(q, {"file": {"time_column": "n", "time_unit": "samples"},
    ...                          "channels": {"p1": "PA_bar:bar"}}, sample_rate=100)
    >>> rec["p1"].tolist(), rec.units, rec.sample_rate
    ([1000000.0, 1200000.0, 1400000.0], {'p1': 'Pa'}, 100.0)
    """
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    if path.is_dir():
        raise RecordingError(f"{path}: is a directory, not a recording file")
    fmt = _format(path, READ_FORMATS, "read")
    try:
        cmap = None if column_map is None else load_column_map(column_map)
    except RecordingError as exc:
        if isinstance(column_map, (str, os.PathLike)):
            raise  # the message names the map file
        raise RecordingError(f"{path}: column map: {exc}") from None
    if fmt == "text":
        table = read_text(path, cmap.separator if cmap is not None else None)
    elif fmt == "parquet":
        table = read_parquet(path)
    elif fmt == "hdf5":
        table = read_hdf5(path)
    else:
        table = read_mat(path)
    return table_to_recording(table, cmap, sample_rate=sample_rate, resample=resample,
                              units=units, channels=channels)


def write_recording(rec: Recording, path: str | os.PathLike) -> Path:
    """Write a recording; the format is chosen by extension (.csv, .parquet, .h5/.hdf5).

    Parameters
    ----------
    rec : Recording
        The recording.
    path : str or path-like
        Output file; parent folders are created; an existing file is replaced atomically
        (written to a temporary file in the same folder, then renamed).

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    RecordingError
        Unknown extension, a channel named ``time``, or metadata that JSON cannot store.

    Notes
    -----
    Parquet and HDF5 keep the sample rate, start time, units and metadata, and read back
    exactly (bit-identical samples, equal ``units`` and ``meta``; tuples in ``meta`` come
    back as lists, NumPy scalars as Python numbers). CSV keeps only the time column and the
    samples (exactly); units are assumed SI when read back.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "run.parquet"
    >>> rec = Recording({"p1": np.array([1.5, 2.5])}, 1000.0, units={"p1": "counts"},
    ...                 meta={"onset": 0.001})
    >>> back = read_recording(write_recording(rec, p))
    >>> back.units, back.meta["onset"], back.meta["source"] == str(p), back["p1"].tolist()
    ({'p1': 'counts'}, 0.001, True, [1.5, 2.5])
    """
    path = Path(path)
    fmt = _format(path, WRITE_FORMATS, "write")
    if not isinstance(rec, Recording):
        raise TypeError(f"rec must be a Recording, got {type(rec).__name__}")
    if fmt != "csv":
        encode_header(rec, str(path))  # fail on unstorable metadata before touching the disk
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    try:
        if fmt == "csv":
            write_csv(rec, tmp)
        elif fmt == "parquet":
            write_parquet(rec, tmp)
        else:
            write_hdf5(rec, tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def recording_units(path: str | os.PathLike) -> dict[str, str] | None:
    """The channel units a recording file's leakdiag header states, read without its samples.

    A file that is read in chunks (:func:`leakdiag.stream.open_chunks`) keeps its samples as
    they are, so one written in ``counts`` (or any non-SI unit) stays in it; these are the
    units :func:`read_recording` would give it, for checking against a detector's.

    Parameters
    ----------
    path : str or path-like
        Recording file; the format is chosen by extension (see :data:`READ_FORMATS`).

    Returns
    -------
    dict of str to str, or None
        Channel -> unit from the header of a Parquet or HDF5 file written by
        :func:`write_recording`. None for a file that states no units: text (a plain CSV;
        SI is assumed, as :func:`read_recording` assumes it), MATLAB, and Parquet or HDF5 files
        written by other programs (an HDF5 file is leakdiag's only when its ``format``
        attribute says so; another program's ``units`` attribute is not read).

    Raises
    ------
    RecordingError
        If the file is missing, of an unknown extension, unreadable as its format, or its
        leakdiag header is malformed or newer than this leakdiag (as :func:`read_recording`).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> rec = Recording({"p1": np.array([1.5, 2.5])}, 1000.0, units={"p1": "counts"})
    >>> recording_units(write_recording(rec, d / "run.h5"))
    {'p1': 'counts'}
    >>> recording_units(write_recording(rec, d / "run.csv")) is None
    True
    """
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: file not found")
    fmt = _format(path, READ_FORMATS, "read")
    if fmt == "parquet":
        header = read_parquet_header(path)
    elif fmt == "hdf5":
        header = read_hdf5_header(path)
    else:
        return None
    if header is None or not isinstance(header["units"], dict):
        return None
    return {str(k): str(v) for k, v in header["units"].items()}
