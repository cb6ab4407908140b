"""HDF5 recordings (h5py): one dataset per channel, attributes for rate, start, units, meta."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from leakdiag.io.header import HEADER_FORMAT, decode_header, encode_header
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.io.table import RawTable, flatten_arrays

__all__ = ["CHANNEL_GROUP", "read_hdf5", "read_hdf5_header", "write_hdf5", "hdf5_tree"]

#: Group holding one dataset per channel.
CHANNEL_GROUP = "channels"


def write_hdf5(rec: Recording, path: str | os.PathLike) -> None:
    """Write a recording as HDF5.

    Parameters
    ----------
    rec : Recording
        The recording.
    path : str or path-like
        Output file (overwritten).

    Raises
    ------
    RecordingError
        If a channel name contains ``/`` or the metadata is not JSON-serialisable.

    Notes
    -----
    Layout: datasets ``/channels/<name>`` (float64, attribute ``unit``) and ``/time`` (s);
    root attributes ``format`` (``"leakdiag-recording"``), ``version``, ``sample_rate`` (Hz),
    ``start_time`` (s), ``channels`` (JSON list, the order), ``units`` and ``meta`` (JSON).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> write_hdf5(Recording({"p1": np.array([1.0, 2.0])}, 2.0), p)
    >>> read_hdf5(p).header["units"]
    {'p1': 'Pa'}
    """
    import h5py

    bad = [n for n in rec.channels if "/" in n or n in (".", "")]
    if bad:
        raise RecordingError(f"{path}: channel name(s) {bad} cannot be HDF5 dataset names")
    header = json.loads(encode_header(rec, str(path)))
    with h5py.File(path, "w") as f:
        f.attrs["format"] = HEADER_FORMAT
        f.attrs["version"] = header["version"]
        f.attrs["sample_rate"] = header["sample_rate"]
        f.attrs["start_time"] = header["start_time"]
        f.attrs["channels"] = json.dumps(header["channels"])
        f.attrs["units"] = json.dumps(header["units"])
        f.attrs["meta"] = json.dumps(header["meta"], allow_nan=True)
        f.create_dataset("time", data=rec.time)
        group = f.create_group(CHANNEL_GROUP)
        for name, values in rec.channels.items():
            ds = group.create_dataset(name, data=values)
            if name in rec.units:
                ds.attrs["unit"] = rec.units[name]


def _attr_text(value) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


def hdf5_tree(group) -> dict:
    """Nested dict of the numeric datasets of an open h5py group (MATLAB v7.3 aware).

    Parameters
    ----------
    group : h5py.Group
        An open group (or file).

    Returns
    -------
    dict
        Name -> numpy array or nested dict. Datasets with a ``MATLAB_class`` attribute are
        transposed back to MATLAB's row/column orientation; MATLAB text, cells, empty
        arrays and the ``#refs#`` group are left out.

    Examples
    --------
    >>> import h5py, io
    >>> with h5py.File(io.BytesIO(), "w") as f:
    ...     f["daq/p"] = np.arange(3.0)
    ...     hdf5_tree(f)["daq"]["p"].tolist()
    [0.0, 1.0, 2.0]
    """
    import h5py

    out: dict = {}
    for key, item in group.items():
        if key.startswith("#"):
            continue
        if isinstance(item, h5py.Group):
            out[key] = hdf5_tree(item)
            continue
        mclass = _attr_text(item.attrs.get("MATLAB_class", b""))
        if mclass in ("char", "cell") or "MATLAB_empty" in item.attrs:
            continue
        if item.dtype.kind not in "biuf":
            continue
        data = item[()]
        out[key] = data.T if mclass and np.ndim(data) >= 2 else data
    return out


def _open(path):
    """The file open for reading; a file that is not HDF5 is a RecordingError naming it."""
    import h5py

    try:
        return h5py.File(Path(path), "r")
    except OSError as exc:
        raise RecordingError(f"{path}: unreadable as HDF5: {exc}") from None


def read_hdf5(path: str | os.PathLike, sep: str = "/") -> RawTable:
    """Read an HDF5 file into a :class:`RawTable`.

    Parameters
    ----------
    path : str or path-like
        The file: one written by :func:`write_hdf5`, or any HDF5 file whose numeric datasets
        are channels (a column per vector; see :func:`leakdiag.io.table.flatten_arrays`).
    sep : str, default "/"
        Joins group and dataset names of a generic file (``"."`` for MATLAB v7.3 files).

    Returns
    -------
    RawTable
        A leakdiag file gives its channels under their names, ``time``, and the header.

    Raises
    ------
    RecordingError
        If the file is not HDF5 or holds no numeric vectors.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> write_hdf5(Recording({"p1": np.array([1.0, 2.0])}, 2.0), p)
    >>> read_hdf5(p).names
    ['time', 'p1']
    """
    source = str(path)
    f = _open(path)
    with f:
        header = _header(f, source)
        if header is not None:
            group = f[CHANNEL_GROUP]
            missing = [n for n in header["channels"] if n not in group]
            if missing:
                raise RecordingError(f"{source}: header lists channel(s) {missing} that are "
                                     f"not in /{CHANNEL_GROUP}")
            columns = {"time": np.asarray(f["time"][()], dtype=np.float64)}
            columns.update({n: np.asarray(group[n][()], dtype=np.float64)
                            for n in header["channels"]})
            return RawTable(columns, source, header)
        tree = hdf5_tree(f)
    columns = dict(flatten_arrays(tree, sep=sep))
    if not columns:
        raise RecordingError(f"{source}: holds no numeric vectors (no channels)")
    return RawTable(columns, source)


def _header(f, source: str) -> dict | None:
    """The leakdiag header of an open HDF5 file: its root attributes when its ``format``
    attribute says leakdiag wrote it, else None (another program's attributes, even one named
    ``units``, are not a leakdiag header)."""
    if _attr_text(f.attrs.get("format", b"")) != HEADER_FORMAT:
        return None
    header = {
        "format": HEADER_FORMAT,
        "version": int(f.attrs["version"]),
        "sample_rate": float(f.attrs["sample_rate"]),
        "start_time": float(f.attrs["start_time"]),
        "channels": json.loads(_attr_text(f.attrs["channels"])),
        "units": json.loads(_attr_text(f.attrs["units"])),
        "meta": json.loads(_attr_text(f.attrs["meta"])),
    }
    return decode_header(json.dumps(header), source)


def read_hdf5_header(path: str | os.PathLike) -> dict | None:
    """The leakdiag header of an HDF5 file (its root attributes), read without its data.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    dict or None
        The header (:func:`leakdiag.io.header.decode_header`), or None for a file that
        :func:`write_hdf5` did not write (no ``format = "leakdiag-recording"`` attribute).

    Raises
    ------
    RecordingError
        If the file is not HDF5, or its leakdiag header is malformed or of a newer version.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.h5"
    >>> write_hdf5(Recording({"p1": np.array([1.0, 2.0])}, 2.0, units={"p1": "counts"}), p)
    >>> read_hdf5_header(p)["units"]
    {'p1': 'counts'}
    """
    source = str(path)
    f = _open(path)
    with f:
        return _header(f, source)
