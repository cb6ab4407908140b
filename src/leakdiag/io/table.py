"""The raw table every reader produces before columns become channels.

A :class:`RawTable` is what a file holds: named 1-D columns as read (numbers or text, possibly of
different lengths for MATLAB files) and, for files written by leakdiag, the stored header.
:func:`flatten_arrays` turns nested MATLAB/HDF5 variables into such columns.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterator, Mapping

import numpy as np

from leakdiag.io.errors import RecordingError

__all__ = ["RawTable", "flatten_arrays"]



def repeated_names(names) -> dict[str, list[int]]:
    """Names that a header holds more than once -> their 0-based positions.

    Examples
    --------
    >>> repeated_names(["t", "P", "x", "P"])
    {'P': [1, 3]}
    """
    positions: dict[str, list[int]] = {}
    for j, name in enumerate(names):
        positions.setdefault(name, []).append(j)
    return {name: js for name, js in positions.items() if len(js) > 1}

@dataclass
class RawTable:
    """Columns of a file as read, before mapping and unit conversion.

    Parameters
    ----------
    columns : dict of str to numpy.ndarray
        Column name -> 1-D array (numeric, or object for text), in file order.
    source : str
        File name for messages.
    header : dict, optional
        The leakdiag header (see :mod:`leakdiag.io.header`) if the file was written by leakdiag.
    duplicates : dict of str to list of int, optional
        Names that the file's header holds more than once -> their 0-based positions. Such
        columns are not in ``columns``: which one a name means cannot be told, so reading one
        is an error (:meth:`require_unique`); unused duplicates do no harm.

    Examples
    --------
    >>> RawTable({"p1": np.zeros(2)}, "a.csv").names
    ['p1']
    """

    columns: dict[str, np.ndarray]
    source: str
    header: dict[str, Any] | None = None
    duplicates: dict[str, list[int]] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """Column names in file order (names that occur more than once are left out)."""
        return list(self.columns)

    def require_unique(self, column: str, label: str) -> None:
        """Raise if ``column`` is a name the file's header holds more than once.

        Parameters
        ----------
        column : str
            Column about to be read.
        label : str
            What it is read as, for the message, e.g. ``"channel 'p1'"`` or ``"time column"``.

        Raises
        ------
        RecordingError
            Naming the file, the column, what it is read as and its positions (1-based).

        Examples
        --------
        >>> t = RawTable({"t": np.zeros(2)}, "a.csv", duplicates={"P": [1, 3]})
        >>> t.require_unique("t", "time column")
        >>> t.require_unique("P", "channel 'p1'")
        Traceback (most recent call last):
        ...
        leakdiag.io.errors.RecordingError: a.csv: column 'P' (channel 'p1') appears 2 times in
        the header, at fields 2 and 4 (counting from 1); ...
        """
        positions = self.duplicates.get(column)
        if positions:
            where = [str(p + 1) for p in positions]
            fields = ", ".join(where[:-1]) + " and " + where[-1]
            raise RecordingError(
                f"{self.source}: column {column!r} ({label}) appears {len(positions)} times in "
                f"the header, at fields {fields} (counting from 1); which one is meant cannot "
                f"be told: rename the others"
            )

    def require_all_unique(self, time_column: str, advice: str) -> None:
        """Raise if the header repeats any name, when every column is read (no map or list).

        Parameters
        ----------
        time_column : str
            The time column's name (labelled ``time column``, the others as channels).
        advice : str
            Appended to the message: how to read fewer columns.

        Raises
        ------
        RecordingError
            :meth:`require_unique`'s message for the first repeated name, then ``advice``.
        """
        for name in self.duplicates:
            try:
                self.require_unique(name, "time column" if name == time_column
                                    else f"channel {name!r}")
            except RecordingError as exc:
                raise RecordingError(f"{exc}; {advice}") from None

    def check_rows(self, columns: Mapping[str, str]) -> None:
        """Raise if a row of the file is too short to hold the columns read from it.

        Only row-oriented files (delimited text, :class:`leakdiag.io.text.TextTable`) can have
        short rows; for the other formats this does nothing.

        Parameters
        ----------
        columns : dict of str to str
            What a column is read as (``"channel 'p1'"``, ``"time column"``) -> column name.

        Examples
        --------
        >>> RawTable({"p1": np.zeros(2)}, "a.h5").check_rows({"channel 'p1'": "p1"})
        """


def _is_numeric(arr: np.ndarray) -> bool:
    return arr.dtype.kind in "biuf"


def flatten_arrays(obj: Any, name: str = "", sep: str = ".") -> Iterator[tuple[str, np.ndarray]]:
    """Yield ``(column name, 1-D float array)`` for every numeric vector inside ``obj``.

    Parameters
    ----------
    obj : dict, list or numpy.ndarray
        Nested variables: dicts (MATLAB structs, HDF5 groups), lists (struct arrays, 1-based
        ``name(i)``), arrays.
    name : str
        Name prefix.
    sep : str, default "."
        Joins nested names (``"."`` for MATLAB struct fields, ``"/"`` for HDF5 groups).

    Yields
    ------
    name : str
        A vector becomes ``name``; the columns of an ``n x k`` matrix (``k > 1``) become
        ``name(:,1)`` ... ``name(:,k)`` (MATLAB's 1-based notation).
    values : numpy.ndarray
        float64, 1-D.

    Notes
    -----
    Scalars, empty arrays, text, complex numbers and arrays of more than two non-singleton
    dimensions are skipped: they cannot be channels.

    Examples
    --------
    >>> data = {"t": np.arange(3.0), "sig": {"values": np.ones((3, 2))}}
    >>> [n for n, _ in flatten_arrays(data)]
    ['t', 'sig.values(:,1)', 'sig.values(:,2)']
    """
    if isinstance(obj, dict):
        for key, value in obj.items():
            if str(key).startswith(("#", "__")):
                continue
            yield from flatten_arrays(value, f"{name}{sep}{key}" if name else str(key), sep)
        return
    if isinstance(obj, (list, tuple)):
        if all(isinstance(v, (dict, list, tuple, np.ndarray)) for v in obj):
            for i, value in enumerate(obj, start=1):
                yield from flatten_arrays(value, f"{name}({i})", sep)
            return
        obj = np.asarray(obj)
    arr = np.asarray(obj)
    if arr.dtype == object and arr.size and all(isinstance(v, dict) for v in arr.flat):
        for i, value in enumerate(arr.flat, start=1):
            yield from flatten_arrays(value, f"{name}({i})", sep)
        return
    if not _is_numeric(arr) or arr.size < 2:
        return
    shape = [d for d in arr.shape if d != 1]
    if len(shape) == 1:
        yield name, np.asarray(arr.reshape(-1), dtype=np.float64)
    elif len(shape) == 2:
        mat = arr.reshape(shape)
        for j in range(mat.shape[1]):
            yield f"{name}(:,{j + 1})", np.ascontiguousarray(mat[:, j], dtype=np.float64)
