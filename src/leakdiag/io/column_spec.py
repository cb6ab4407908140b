"""The command line's column map: ``--map map.toml`` plus ``--col p1=PG_1:counts-8192*0.5``.

One spec's grammar (:func:`parse_column_spec`, in :mod:`leakdiag.io.column_map` since a TOML map
takes the same strings; see ``docs/io.md``)::

    CHANNEL=COLUMN[:UNIT[-OFFSET|+OFFSET][*GAIN][->SI_UNIT]]

meaning ``si = (raw - OFFSET) * GAIN * factor(UNIT)``; ``time=COLUMN[:s|ms|us|samples]`` names the
time column.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Iterable

from leakdiag.io.column_map import (
    FILE_KEYS,
    ColumnMap,
    _last_top_level_colon,
    load_column_map,
    parse_column_spec,
)
from leakdiag.io.errors import RecordingError

__all__ = ["build_column_map"]

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
