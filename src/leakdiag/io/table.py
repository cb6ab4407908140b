"""The raw table every reader produces before columns become channels.

A :class:`RawTable` is what a file holds: named 1-D columns as read (numbers or text, possibly of
different lengths for MATLAB files) and, for files written by leakdiag, the stored header.
:func:`flatten_arrays` turns nested MATLAB/HDF5 variables into such columns.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

__all__ = ["RawTable", "flatten_arrays"]


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

    Examples
    --------
    >>> RawTable({"p1": np.zeros(2)}, "a.csv").names
    ['p1']
    """

    columns: dict[str, np.ndarray]
    source: str
    header: dict[str, Any] | None = None

    @property
    def names(self) -> list[str]:
        """Column names in file order."""
        return list(self.columns)


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
