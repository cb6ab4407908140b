"""Files of the benchmark's resumable work folder: written whole or not at all, read or redone.

Every fit, reference and shard file is written to a temporary file of its own in the target's
folder (:func:`tempfile.mkstemp`: a unique name per writer) and then renamed over the target
(:func:`os.replace`, atomic on one file system). Two runs writing the same file at once (two
benchmark runs on the default work folder) therefore each move a complete file into place;
with one fixed ``.tmp`` name they wrote into the same temporary file, and an empty or cut file
could be renamed into place (audit 2026-11-27, finding 6). A writer that fails removes its
temporary file.

A file that is there but cannot be read back (cut by a full disk, damaged by hand or by an
older version's race) is not an error of the run: :func:`read_or_discard` warns naming the
file (:class:`DamagedWorkFileWarning`), removes it and lets the caller compute it again. Until
2026-11-27 such a file stopped every later run (a Parquet error shown as a usage error that
did not name the file, an ``UnpicklingError`` traceback for a fit) until it was found and
deleted by hand.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any, Callable

__all__ = ["DamagedWorkFileWarning", "write_atomic", "read_or_discard", "remove_stale_temps",
           "STALE_TEMP_S"]

#: Age after which a temporary file of :func:`write_atomic` is a leftover of a killed writer (no
#: work file takes an hour to write; the simulation cache uses the same rule).
STALE_TEMP_S = 3600.0


class DamagedWorkFileWarning(UserWarning):
    """A work file could not be read back; it was removed and is computed again."""


def write_atomic(path, write: Callable[[Path], Any]) -> Path:
    """Write ``path`` through a temporary file of this writer's own and an atomic rename.

    Parameters
    ----------
    path : path-like
        Target file (its folder is created if needed).
    write : callable
        ``write(tmp_path)`` writes the whole content to ``tmp_path``.

    Returns
    -------
    pathlib.Path
        The target.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> p = write_atomic(d / "a" / "x.txt", lambda t: t.write_text("done"))
    >>> p.read_text(), sorted(f.name for f in p.parent.iterdir())
    ('done', ['x.txt'])
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:  # a failed or interrupted write leaves no temporary file behind
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return path


def read_or_discard(path, read: Callable[[Path], Any], what: str) -> Any:
    """Read a reused work file; None when it is missing or damaged (then it is removed).

    Parameters
    ----------
    path : path-like
        Work file.
    read : callable
        ``read(path)`` returns the content, raising for a file it cannot use.
    what : str
        What the file holds, for the warning ("fit", "result shard", ...).

    Returns
    -------
    object or None
        ``read(path)``, or None: no such file, or one that could not be read.

    Warns
    -----
    DamagedWorkFileWarning
        Naming the file and the error, when it exists but cannot be read (it is removed).

    Notes
    -----
    Any exception of ``read`` counts as damage (a cut Parquet file raises ``ArrowInvalid``, a
    cut pickle ``EOFError`` or ``UnpicklingError``, a foreign one anything): the file is a cache
    of this run's own computation, so recomputing it is always right.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "s.txt"
    >>> read_or_discard(p, Path.read_text, "shard") is None
    True
    """
    path = Path(path)
    if not path.is_file():
        return None
    try:
        return read(path)
    except Exception as exc:  # noqa: BLE001 -- see Notes
        why = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        try:
            path.unlink()
        except FileNotFoundError:  # another run removed (or replaced) it first
            pass
        except OSError as err:
            raise OSError(f"{path}: damaged {what} file ({why}) could not be removed: "
                          f"{err}") from exc
        warnings.warn(f"{path}: damaged {what} file ({why}); removed, "
                      "computed again", DamagedWorkFileWarning, stacklevel=2)
        return None


def remove_stale_temps(folder, older_than_s: float = STALE_TEMP_S) -> int:
    """Remove temporary files of :func:`write_atomic` left in ``folder`` by killed writers.

    Only hidden ``.<name>.<random>.tmp`` files last modified more than ``older_than_s`` ago:
    a writer still at work (another run on the same folder) keeps its file.

    Parameters
    ----------
    folder : path-like
        A work folder (a missing one has nothing to remove).
    older_than_s : float, default :data:`STALE_TEMP_S`
        Age in seconds.

    Returns
    -------
    int
        Files removed.

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / ".x.parquet.abc123.tmp").write_bytes(b"half")
    >>> remove_stale_temps(d), remove_stale_temps(d, older_than_s=-1.0)
    (0, 1)
    """
    folder = Path(folder)
    if not folder.is_dir():
        return 0
    now, n = time.time(), 0
    for f in folder.glob(".*.tmp"):
        with contextlib.suppress(OSError):  # gone already, or another run's to remove
            if now - f.stat().st_mtime > older_than_s:
                f.unlink()
                n += 1
    return n
