"""MATLAB ``.mat`` files: v4/v5/v7 through SciPy, v7.3 (HDF5) through h5py."""

from __future__ import annotations

import os
from pathlib import Path

from leakdiag.io.hdf5 import read_hdf5
from leakdiag.io.recording import RecordingError
from leakdiag.io.table import RawTable, flatten_arrays

__all__ = ["read_mat"]


def read_mat(path: str | os.PathLike) -> RawTable:
    """Read the numeric vectors of a MATLAB ``.mat`` file into a :class:`RawTable`.

    Parameters
    ----------
    path : str or path-like
        The file. v7.3 files are HDF5 and are read with h5py, others with
        :func:`scipy.io.loadmat`.

    Returns
    -------
    RawTable
        One column per numeric vector, named after its variable: ``t``; columns of an
        ``n x k`` matrix as ``data(:,1)`` ... ``data(:,k)`` (1-based, as in MATLAB); struct
        fields joined with dots, e.g. ``ScopeData.signals.values(:,2)`` (Simulink "structure
        with time" logs); struct-array elements as ``signals(2).values``. Columns may differ
        in length; the mapped ones are checked when the recording is built.

    Raises
    ------
    RecordingError
        If the file is not a MAT file or holds no numeric vectors.

    Notes
    -----
    Row vectors (``1 x n``) count as vectors. Scalars, text, cells of text, complex data and
    MATLAB objects (``timeseries``, ``Simulink.SimulationData.Dataset``; save their data as
    plain arrays or structs instead) are skipped.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np, scipy.io
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "log.mat"
    >>> scipy.io.savemat(p, {"t": np.arange(3) / 10, "y": np.ones((3, 2))})
    >>> read_mat(p).names
    ['t', 'y(:,1)', 'y(:,2)']
    """
    import h5py
    import scipy.io
    from scipy.io.matlab import MatReadError

    source = str(path)
    path = Path(path)
    if h5py.is_hdf5(path):
        table = read_hdf5(path, sep=".")
        return RawTable(table.columns, source)
    try:
        data = scipy.io.loadmat(path, simplify_cells=True)
    except (MatReadError, ValueError, TypeError, OSError, NotImplementedError) as exc:
        raise RecordingError(f"{source}: unreadable as a MATLAB .mat file: {exc}") from None
    columns = dict(flatten_arrays({k: v for k, v in data.items() if not k.startswith("__")}))
    if not columns:
        raise RecordingError(f"{source}: holds no numeric vectors (no channels); variables: "
                             f"{sorted(k for k in data if not k.startswith('__'))}")
    return RawTable(columns, source)
