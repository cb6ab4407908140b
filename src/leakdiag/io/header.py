"""The leakdiag header stored with Parquet and HDF5 recordings: rate, start, units, meta as JSON."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import PurePath
from typing import Any

import numpy as np

from leakdiag.io.recording import Recording, RecordingError

__all__ = ["HEADER_FORMAT", "HEADER_VERSION", "encode_header", "decode_header"]

#: Value of the ``format`` key that marks a file written by :func:`write_recording`.
HEADER_FORMAT = "leakdiag-recording"
#: Layout version; bump when the stored layout changes.
HEADER_VERSION = 1


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, PurePath):
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    raise TypeError(f"{type(obj).__name__} {obj!r} is not JSON-serialisable")


def encode_header(rec: Recording, source: str | None = None) -> str:
    """JSON text of a recording's header (everything but the samples).

    Parameters
    ----------
    rec : Recording
        The recording.
    source : str, optional
        File being written, for messages (default: ``rec.meta["source"]``).

    Returns
    -------
    str
        JSON with keys ``format``, ``version``, ``sample_rate`` (Hz), ``start_time`` (s),
        ``channels`` (order), ``units`` and ``meta``.

    Raises
    ------
    RecordingError
        If ``meta`` holds a value JSON cannot store (the message names its key).

    Notes
    -----
    Floats are written with Python's shortest round-trip repr, so they read back bit for bit.
    NumPy scalars and arrays become numbers and lists, paths strings, dataclasses dicts, and
    tuples lists: that is what "exact" round-trip means for metadata.

    Examples
    --------
    >>> rec = Recording({"p1": np.zeros(3)}, sample_rate=1000.0, meta={"seed": np.int64(3)})
    >>> decode_header(encode_header(rec))["meta"]
    {'seed': 3}
    """
    header = {
        "format": HEADER_FORMAT,
        "version": HEADER_VERSION,
        "sample_rate": float(rec.sample_rate),
        "start_time": float(rec.start_time),
        "channels": list(rec.channels),
        "units": dict(rec.units),
        "meta": rec.meta,
    }
    try:
        return json.dumps(header, default=_jsonable, allow_nan=True)
    except (TypeError, ValueError) as exc:
        where = source if source is not None else rec.meta.get("source", "<recording>")
        bad = []
        for key, value in rec.meta.items():
            try:
                json.dumps(value, default=_jsonable, allow_nan=True)
            except (TypeError, ValueError):
                bad.append(key)
        raise RecordingError(
            f"{where}: metadata cannot be stored (key(s) {bad}): {exc}"
        ) from None


def decode_header(text: str | bytes, source: str = "<input>") -> dict[str, Any]:
    """Parse and check a header written by :func:`encode_header`.

    Parameters
    ----------
    text : str or bytes
        The JSON text.
    source : str
        File name for messages.

    Returns
    -------
    dict
        The header.

    Raises
    ------
    RecordingError
        If it is not valid JSON, not a leakdiag header, or of a newer version.

    Examples
    --------
    >>> decode_header('{"format": "leakdiag-recording", "version": 1, "sample_rate": 10.0, '
    ...               '"start_time": 0.0, "channels": [], "units": {}, "meta": {}}')["sample_rate"]
    10.0
    """
    try:
        header = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{source}: leakdiag header is not valid JSON: {exc}") from None
    if not isinstance(header, dict) or header.get("format") != HEADER_FORMAT:
        raise RecordingError(f"{source}: not a leakdiag recording header")
    version = header.get("version")
    if not isinstance(version, int) or version > HEADER_VERSION:
        raise RecordingError(
            f"{source}: leakdiag header version {version!r} is newer than this leakdiag "
            f"understands ({HEADER_VERSION}); upgrade leakdiag"
        )
    missing = [k for k in ("sample_rate", "start_time", "channels", "units", "meta")
               if k not in header]
    if missing:
        raise RecordingError(f"{source}: leakdiag header lacks {missing}")
    rate = header["sample_rate"]
    if not isinstance(rate, (int, float)) or not math.isfinite(rate) or rate <= 0:
        raise RecordingError(f"{source}: leakdiag header sample_rate={rate!r} must be > 0")
    return header
