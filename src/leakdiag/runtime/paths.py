"""Output paths of long commands, checked before the work (``--out``, ``--work-dir``, ...).

A folder that cannot be created or written, or a file that cannot be written, is said in one
line naming the option and the path before hours of simulation, not after. Used by
``reproduce``, ``sensitivity`` and ``benchmark`` (``leakdiag.bench``).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["prepare_out_dir", "prepare_out_file"]


def _probe(folder: Path, option: str, path) -> None:
    """Write and remove an empty file in ``folder``: a folder we cannot write in is said now."""
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".leakdiag-probe-")
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise OSError(f"{option} {path}: cannot write in {folder}: "
                      f"{exc.strerror or exc}") from None


def prepare_out_dir(path, option: str = "--out", files=(), folders=()) -> Path:
    """Create an output folder and check that it can be written, before the long work.

    Parameters
    ----------
    path : str or path-like
        The folder (created with its parents when missing).
    option : str, default "--out"
        Option name for the message.
    files : sequence of str, default ()
        Names of the files the command will write in the folder: none of them may be a
        folder (an earlier file there is replaced).
    folders : sequence of str, default ()
        Names of the sub-folders the command will write in: each must be a folder that can be
        written, or be absent (it is made when the results are written).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OSError
        One line naming the option and the path when the folder cannot be created or written,
        or when one of ``files`` is a folder or one of ``folders`` is not a writable folder,
        e.g. ``--out rep: rep/figures exists and is not a folder``.
    """
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"{option} {path}: cannot create the folder: "
                      f"{exc.strerror or exc}") from None
    _probe(p, option, path)
    for name in files:
        if (p / name).is_dir():
            raise OSError(f"{option} {path}: {p / name} exists and is a folder, not a file")
    for name in folders:
        sub = p / name
        if sub.exists() or sub.is_symlink():
            if not sub.is_dir():
                raise OSError(f"{option} {path}: {sub} exists and is not a folder")
            _probe(sub, option, path)
    return p


def prepare_out_file(path, option: str) -> Path:
    """Check, before the long work, that a file can be written at ``path`` (its folder is
    created when missing; an existing file is left as it is until it is written).

    Parameters
    ----------
    path : str or path-like
        The file.
    option : str
        Option name for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    OSError
        One line naming the option and the path when the file cannot be written there.
    """
    p = Path(path)
    if p.is_dir():
        raise OSError(f"{option} {path}: is a folder; give a file name")
    if p.parent.exists() and not p.parent.is_dir():
        raise OSError(f"{option} {path}: {p.parent} is a file, not a folder")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"{option} {path}: cannot create its folder {p.parent}: "
                      f"{exc.strerror or exc}") from None
    _probe(p.parent, option, path)
    if p.exists() and not os.access(p, os.W_OK):
        raise OSError(f"{option} {path}: the file exists and cannot be written")
    return p
