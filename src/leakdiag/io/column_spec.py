"""The command-line column-spec mini-syntax: ``p1=PG_1:counts-8192*0.5`` and ``--map`` + ``--col``.

Grammar (see ``docs/io.md``)::

    CHANNEL=COLUMN[:UNIT[-OFFSET|+OFFSET][*GAIN][->SI_UNIT]]

meaning ``si = (raw - OFFSET) * GAIN * factor(UNIT)``; ``time=COLUMN[:s|ms|us|samples]`` names the
time column.
"""

from __future__ import annotations

import re
from dataclasses import replace
from typing import Any, Iterable

from leakdiag.io.column_map import (
    FILE_KEYS,
    CHANNEL_NAME_RE,
    TIME_UNITS,
    ChannelSpec,
    ColumnMap,
    load_column_map,
)
from leakdiag.io.recording import RecordingError

__all__ = ["parse_column_spec", "build_column_map"]

_NUM = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_SCALE_RE = re.compile(
    rf"^\s*(?P<unit>[^\s*+\->]+?)?\s*"
    rf"(?:(?P<sign>[-+])\s*(?P<offset>{_NUM}))?\s*"
    rf"(?:\*\s*(?P<gain>[-+]?{_NUM}))?\s*"
    rf"(?:->\s*(?P<si>\S+))?\s*$"
)


def _last_top_level_colon(text: str) -> int:
    """Index of the last ``:`` outside parentheses (``data(:,2)`` keeps its colon), or -1."""
    depth, cut = 0, -1
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth = max(depth - 1, 0)
        elif ch == ":" and depth == 0:
            cut = i
    return cut


def parse_column_spec(spec: str) -> tuple[str, ChannelSpec]:
    """Parse one command-line column spec ``CHANNEL=COLUMN[:UNIT[-OFFSET|+OFFSET][*GAIN][->SI]]``.

    Parameters
    ----------
    spec : str
        E.g. ``"p1=PG_1:psi"``, ``"p1=PG_1:counts*0.5"``, ``"p1=PG_1:counts-8192*0.5"``
        (``si = (raw - 8192) * 0.5``), ``"angle=Angle:counts*0.00038->rad"``, or
        ``"time=Time:samples"`` (the time column and its unit, see :func:`build_column_map`).
        The column is everything between ``=`` and the **last** ``:`` outside parentheses
        (so ``p1=data(:,2):bar`` works); other names containing ``:`` need a TOML map.

    Returns
    -------
    channel : str
        Channel name.
    spec : ChannelSpec
        Column, unit, gain, offset and si_unit. For ``time`` the unit is the time unit.

    Raises
    ------
    RecordingError
        If the spec does not follow the syntax or names an unknown unit.

    Examples
    --------
    >>> parse_column_spec("p1=PG_1:counts-8192*0.5")
    ('p1', ChannelSpec(column='PG_1', unit='counts', gain=0.5, offset=8192.0, si_unit=None))
    >>> parse_column_spec("x = Pos:mm")
    ('x', ChannelSpec(column='Pos', unit='mm', gain=None, offset=0.0, si_unit=None))
    """
    syntax = "CHANNEL=COLUMN[:UNIT[-OFFSET][*GAIN][->SI_UNIT]]"
    if not isinstance(spec, str) or "=" not in spec:
        raise RecordingError(f"column spec {spec!r} must look like {syntax}, e.g. p1=PG_1:psi")
    name, rhs = (s.strip() for s in spec.split("=", 1))
    if not CHANNEL_NAME_RE.match(name):
        raise RecordingError(f"column spec {spec!r}: channel name {name!r} must be an identifier")
    cut = _last_top_level_colon(rhs)
    column, scale = (rhs, None) if cut < 0 else (rhs[:cut], rhs[cut + 1:])
    column = column.strip()
    if not column:
        raise RecordingError(f"column spec {spec!r}: empty column name; syntax {syntax}")
    if scale is None:
        return name, ChannelSpec(column)
    m = _SCALE_RE.match(scale)
    if m is None:
        raise RecordingError(f"column spec {spec!r}: cannot parse {scale!r}; syntax {syntax}")
    unit = m["unit"]
    if name == "time":
        if unit not in TIME_UNITS or m["gain"] or m["offset"] or m["si"]:
            raise RecordingError(
                f"column spec {spec!r}: the time column takes only a unit, one of "
                f"{', '.join(TIME_UNITS)}"
            )
        return name, ChannelSpec(column, None if unit == "samples" else unit)
    offset = 0.0
    if m["offset"] is not None:
        offset = float(m["offset"]) * (1.0 if m["sign"] == "-" else -1.0)
    gain = None if m["gain"] is None else float(m["gain"])
    try:
        return name, ChannelSpec(column, unit, gain, offset, m["si"])
    except RecordingError as exc:
        raise RecordingError(f"column spec {spec!r}: {exc}") from None


def build_column_map(specs: Iterable[str] = (), *, base: Any = None, **file_options: Any
                     ) -> ColumnMap:
    """Build a :class:`ColumnMap` from command-line specs, optionally on top of a map file.

    This is what ``--map map.toml --col p1=PG_1:psi --col time=Time:samples`` maps to.

    Parameters
    ----------
    specs : iterable of str
        Column specs for :func:`parse_column_spec`; they add or replace channels of ``base``.
        ``time=COLUMN[:UNIT]`` sets ``time_column`` (and ``time_unit``) instead of a channel.
    base : ColumnMap, dict, str or pathlib.Path, optional
        A map to start from (anything :func:`load_column_map` accepts).
    **file_options
        ``separator``, ``sample_rate_hz``, ``time_column``, ``time_unit``; None values are
        ignored, others override ``base``.

    Returns
    -------
    ColumnMap

    Raises
    ------
    RecordingError
        Bad spec, unknown unit or file option.

    Examples
    --------
    >>> cmap = build_column_map(["p1=PG_1:counts", "time=Time:samples"], sample_rate_hz=1000)
    >>> cmap.time_column, cmap.time_unit, cmap.sample_rate_hz, list(cmap.channels)
    ('Time', 'samples', 1000.0, ['p1'])
    """
    cmap = ColumnMap() if base is None else load_column_map(base)
    unknown = sorted(set(file_options) - set(FILE_KEYS))
    if unknown:
        raise RecordingError(f"unknown file option(s) {unknown}; allowed: {list(FILE_KEYS)}")
    options = {k: v for k, v in file_options.items() if v is not None}
    channels = dict(cmap.channels)
    if isinstance(specs, str):
        specs = [specs]
    for s in specs:
        name, chan = parse_column_spec(s)
        if name == "time":
            options["time_column"] = chan.column
            if _last_top_level_colon(s.split("=", 1)[1]) >= 0:
                options["time_unit"] = "samples" if chan.unit is None else chan.unit
        else:
            channels[name] = chan
    return replace(cmap, channels=channels, **options)
