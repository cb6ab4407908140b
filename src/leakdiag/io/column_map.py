"""Column maps: which file column is which channel, in which unit and scale.

A column map is a :class:`ColumnMap` (file options plus one :class:`ChannelSpec` per channel). It
is built from a TOML file or a dict here; one channel's string (``p1=PG_1:counts*0.5``, the same
in a map and on the command line) is read by :func:`parse_column_spec`; the command line's
``--map`` + ``--col`` are combined in :mod:`leakdiag.io.column_spec`. See ``docs/io.md`` for the
syntax.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Mapping

from leakdiag.io.errors import RecordingError
from leakdiag.io.units import COUNTS, QUANTITY_SI_UNIT, UNITS, known_units

__all__ = [
    "ChannelSpec",
    "ColumnMap",
    "TIME_UNITS",
    "FILE_KEYS",
    "CHANNEL_KEYS",
    "CHANNEL_NAME_RE",
    "load_column_map",
    "parse_column_spec",
]

#: Units of a time column: seconds and sub-multiples, or a sample counter.
TIME_UNITS = ("s", "ms", "us", "samples")

#: Keys allowed in the ``[file]`` table.
FILE_KEYS = ("separator", "sample_rate_hz", "time_column", "time_unit", "system", "load",
             "machine")
#: Rigs a map's ``system`` may name.
SYSTEMS = ("vca", "eha")
#: Keys allowed in a ``[channels.<name>]`` table.
CHANNEL_KEYS = ("column", "unit", "gain", "offset", "si_unit")
#: A channel name is an identifier.
CHANNEL_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class ChannelSpec:
    """Where one channel comes from and how to scale it to SI.

    ``si = (raw - offset) * gain * factor(unit)`` (see :func:`leakdiag.io.units.to_si`).

    Parameters
    ----------
    column : str
        Column (or variable) name in the file.
    unit : str, optional
        Unit of the column, e.g. ``"psi"``, ``"mm"``, ``"counts"``; None = already SI.
    gain : float, optional
        Scale after subtracting ``offset``; required to turn ``counts`` into SI (without it
        counts are kept as counts).
    offset : float, default 0.0
        Raw value subtracted before ``gain``.
    si_unit : str, optional
        SI unit of scaled counts for a non-standard channel (e.g. ``"rad"``).

    Raises
    ------
    RecordingError
        If the unit is unknown, or gain/offset are not finite, or gain is zero.

    Examples
    --------
    >>> ChannelSpec("PG_1", unit="counts", gain=0.5).gain
    0.5
    """

    column: str
    unit: str | None = None
    gain: float | None = None
    offset: float = 0.0
    si_unit: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.column, str) or not self.column:
            raise RecordingError(f"column={self.column!r} must be a non-empty string")
        if self.unit is not None and self.unit != COUNTS and self.unit not in UNITS:
            raise RecordingError(
                f"column {self.column!r}: unknown unit {self.unit!r}; "
                f"known units: {', '.join(known_units())}"
            )
        if self.gain is not None:
            g = _finite(self.gain, "gain", f"column {self.column!r}")
            if g == 0.0:
                raise RecordingError(f"column {self.column!r}: gain={self.gain!r} must not be 0")
            object.__setattr__(self, "gain", g)
        object.__setattr__(self, "offset", _finite(self.offset, "offset", f"column {self.column!r}"))
        si_units = sorted(set(QUANTITY_SI_UNIT.values()))
        if self.si_unit is not None and self.si_unit not in si_units:
            raise RecordingError(
                f"column {self.column!r}: si_unit={self.si_unit!r} must be one of "
                f"{', '.join(si_units)}"
            )


def _finite(value: Any, name: str, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise RecordingError(f"{where}: {name}={value!r} must be a number") from None
    if not math.isfinite(v):
        raise RecordingError(f"{where}: {name}={value!r} must be finite")
    return v


@dataclass(frozen=True)
class ColumnMap:
    """File options and channel specs for reading a recording.

    Parameters
    ----------
    channels : dict of str to ChannelSpec
        Channel name (``p1``, ``p2``, ``x``, ``u``, ``x_ref``, ``leak_flow`` or any identifier)
        -> its spec. Only these columns are read; other columns are ignored.
    separator : str, optional
        Field separator of a text file; None = auto-detect.
    sample_rate_hz : float, optional
        Sample rate when there is no time column in seconds.
    time_column : str, optional
        Name of the time column (default: a column named ``time`` if present).
    time_unit : {"s", "ms", "us", "samples"}, default "s"
        Unit of the time column; ``samples`` is a sample counter that needs ``sample_rate_hz``.
    system : {"vca", "eha"}, optional
        The rig the file comes from, stored as ``meta["system"]`` of the recording (a CSV keeps
        no metadata): detectors then check it against the rig they were fitted on.
    load : str, optional
        The load the file was recorded under (``"none"``, ``"spring"`` or a name of yours,
        lower-cased), stored as ``meta["load"]``: checked against the detectors' healthy
        recordings likewise. A file whose own metadata say otherwise is refused.
    machine : int or str, optional
        The machine (unit) the file comes from: a virtual unit's number or your own name, stored
        as ``meta["machine"] = {"unit": ...}``: the flow balance, identified per machine,
        refuses a recording of another unit than its healthy ones (without it a detector of
        unit 57 judged healthy CSV exports of unit 31 LEAK at p = 1.9e-4: a flow-balance audit,
        2026-11-29).

    Raises
    ------
    RecordingError
        Bad channel name, bad time unit, non-positive sample rate, unknown rig, empty load.

    Examples
    --------
    >>> cmap = ColumnMap({"p1": ChannelSpec("PG_1", "counts")}, sample_rate_hz=1000)
    >>> cmap.channels["p1"].column, cmap.sample_rate_hz
    ('PG_1', 1000.0)
    """

    channels: dict[str, ChannelSpec] = field(default_factory=dict)
    separator: str | None = None
    sample_rate_hz: float | None = None
    time_column: str | None = None
    time_unit: str = "s"
    system: str | None = None
    load: str | None = None
    machine: int | str | None = None

    def __post_init__(self) -> None:
        chans = {}
        for name, spec in dict(self.channels).items():
            if not isinstance(name, str) or not CHANNEL_NAME_RE.match(name):
                raise RecordingError(f"channel name {name!r} must be an identifier like 'p1'")
            if name == "time":
                raise RecordingError(
                    "'time' is not a channel; set time_column (and time_unit) in [file]"
                )
            if not isinstance(spec, ChannelSpec):
                raise RecordingError(f"channel {name!r}: spec must be a ChannelSpec, got {spec!r}")
            chans[name] = spec
        object.__setattr__(self, "channels", chans)
        if self.time_unit not in TIME_UNITS:
            raise RecordingError(
                f"time_unit={self.time_unit!r} must be one of {', '.join(TIME_UNITS)}"
            )
        if self.sample_rate_hz is not None:
            v = _finite(self.sample_rate_hz, "sample_rate_hz", "[file]")
            if v <= 0:
                raise RecordingError(f"sample_rate_hz={self.sample_rate_hz!r} must be > 0")
            object.__setattr__(self, "sample_rate_hz", v)
        if self.separator is not None and (not isinstance(self.separator, str)
                                           or not self.separator):
            raise RecordingError(f"separator={self.separator!r} must be a non-empty string")
        if self.system is not None:
            if not isinstance(self.system, str) or self.system.lower() not in SYSTEMS:
                raise RecordingError(f"system={self.system!r} must be one of "
                                     f"{', '.join(SYSTEMS)}")
            object.__setattr__(self, "system", self.system.lower())
        if self.load is not None:
            if not isinstance(self.load, str) or not self.load.strip():
                raise RecordingError(f"load={self.load!r} must be a non-empty name, e.g. "
                                     "'none' or 'spring'")
            object.__setattr__(self, "load", self.load.strip().lower())
        if self.machine is not None:
            m = self.machine
            if isinstance(m, bool) or not (isinstance(m, int) and m >= 0
                                           or isinstance(m, str) and m.strip()):
                raise RecordingError(f"machine={m!r} must be a unit number >= 0 or a non-empty "
                                     "name")
            if isinstance(m, str):
                object.__setattr__(self, "machine", m.strip())

    def to_dict(self) -> dict[str, Any]:
        """The map as a TOML-shaped dict (``{"file": {...}, "channels": {...}}``), Nones dropped.

        Returns
        -------
        dict
            Round-trips through :func:`load_column_map`.

        Examples
        --------
        >>> ColumnMap({"p1": ChannelSpec("P", "bar")}).to_dict()
        {'file': {'time_unit': 's'}, 'channels': {'p1': {'column': 'P', 'unit': 'bar', 'offset': 0.0}}}
        """
        file = {k: getattr(self, k) for k in FILE_KEYS if getattr(self, k) is not None}
        chans = {n: {k: v for k, v in asdict(s).items() if v is not None}
                 for n, s in self.channels.items()}
        return {"file": file, "channels": chans}


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


def _spec_from_value(name: str, value: Any, where: str) -> ChannelSpec:
    if isinstance(value, ChannelSpec):
        return value
    if isinstance(value, str):
        return parse_column_spec(f"{name}={value}")[1]
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(CHANNEL_KEYS))
        if unknown:
            raise RecordingError(
                f"{where}channel {name!r}: unknown key(s) {unknown}; allowed: {list(CHANNEL_KEYS)}"
            )
        if "column" not in value:
            raise RecordingError(f"{where}channel {name!r}: missing key 'column'")
        try:
            return ChannelSpec(**dict(value))
        except RecordingError as exc:
            raise RecordingError(f"{where}channel {name!r}: {exc}") from None
    raise RecordingError(
        f"{where}channel {name!r}: expected a column name, a table or a ChannelSpec, got {value!r}"
    )


def _from_dict(data: Mapping[str, Any], where: str = "") -> ColumnMap:
    if set(data) <= {"file", "channels"}:
        file = dict(data.get("file", {}))
        chans = data.get("channels", {})
    else:  # flat shorthand {"p1": "PG_1:counts", ...}
        file, chans = {}, data
    unknown = sorted(set(file) - set(FILE_KEYS))
    if unknown:
        raise RecordingError(f"{where}[file]: unknown key(s) {unknown}; allowed: {list(FILE_KEYS)}")
    if not isinstance(chans, Mapping):
        raise RecordingError(f"{where}[channels] must be a table, got {chans!r}")
    specs = {name: _spec_from_value(name, v, where) for name, v in chans.items()}
    try:
        return ColumnMap(specs, **file)
    except RecordingError as exc:
        raise RecordingError(f"{where}{exc}") from None


def load_column_map(source: "ColumnMap | Mapping[str, Any] | str | Path") -> ColumnMap:
    """Load a column map from a TOML file, a dict or an existing :class:`ColumnMap`.

    Parameters
    ----------
    source : ColumnMap, dict, str or pathlib.Path
        A TOML file path; a dict shaped like the TOML (``{"file": {...}, "channels": {...}}``);
        or a flat dict ``{"p1": "PG_1:counts*0.5", "p2": {"column": "PG_2"}}`` whose string
        values use the right-hand side of :func:`parse_column_spec`.

    Returns
    -------
    ColumnMap

    Raises
    ------
    RecordingError
        Missing or unparsable TOML file, unknown keys (typos), unknown units, bad values;
        the message names the map file.

    Examples
    --------
    >>> cmap = load_column_map({"file": {"sample_rate_hz": 1000},
    ...                         "channels": {"p1": {"column": "PG_1", "unit": "psi"}}})
    >>> cmap.channels["p1"]
    ChannelSpec(column='PG_1', unit='psi', gain=None, offset=0.0, si_unit=None)
    >>> load_column_map({"p1": "PG_1:counts*0.5"}).channels["p1"].gain
    0.5
    """
    if isinstance(source, ColumnMap):
        return source
    if isinstance(source, Mapping):
        return _from_dict(source)
    if not isinstance(source, (str, Path)):
        raise TypeError(f"column map must be a ColumnMap, dict or TOML path, got {source!r}")
    path = Path(source)
    if not path.is_file():
        raise RecordingError(f"{path}: column map file not found")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{path}: not a valid TOML column map: {exc}") from None
    return _from_dict(data, where=f"{path}: ")
