"""Where Numba keeps leakdiag's compiled kernels: a folder named by the kernels' source code.

Numba's on-disk cache (``@njit(cache=True)``) checks only the stamp of the file that holds a
kernel. A kernel that calls a function of another file (``sim/vca/integrate.py`` calls the
leak law of ``sim/leak.py``), or that froze a constant of another module when it was compiled,
keeps running its old machine code after that other file is edited, or after an upgrade that
changed only that file; the caches built on top (simulations, benchmark results) then file the
old code's numbers under the new code's key. Measured by the cache audit of 2026-11-27
(finding 2): a threefold leak law in ``sim/vca/model.py`` left the simulated pressures
unchanged until Numba's cache was deleted by hand; 31 cached kernels call across files.

So leakdiag points Numba's cache at a folder named by a fingerprint of all the code its kernels
can reach (:data:`leakdiag._fingerprint.KERNEL_PARTS`): ``leakdiag-<16 hex digits>``. An edit
of any of that code, or another installed version, makes a new folder, and the kernels are
compiled afresh once (15-60 s); switching back to a former version finds its folder again.

The folder's parent is, in order: the parent the user chose with ``NUMBA_CACHE_DIR`` (leakdiag
adds its own folder below it; a value that already ends in a ``leakdiag-<hex>`` folder was set
by a leakdiag process for its children, and its parent is taken), the package's own
``__pycache__/numba`` (beside the sources, as Numba's default), or, where the package's folder
is not writable (a system-wide install), ``$XDG_CACHE_HOME/leakdiag/numba``
(``~/.cache/leakdiag/numba``). :func:`configure` sets ``NUMBA_CACHE_DIR`` (and Numba's
configuration, if Numba was imported already) before any kernel is defined: the packages that
hold kernels (``sim``, ``features``, ``detect``, ``literature``) call it first thing. It keeps
the :data:`KEEP` most recently used folders of former code and removes older ones once they have
not been used for :data:`PRUNE_AFTER_S`.
"""

from __future__ import annotations

import os
from pathlib import Path
import re
import shutil
import sys
import time

from leakdiag._fingerprint import KERNEL_PARTS, PACKAGE_ROOT, parts_fingerprint

__all__ = ["ENV", "configure", "kernel_cache_dir", "KEEP", "PRUNE_AFTER_S"]

#: Numba's environment variable for its cache folder.
ENV = "NUMBA_CACHE_DIR"
#: Folders of former code kept besides the current one (most recently used first).
KEEP = 3
#: A folder of former code beyond :data:`KEEP` is removed once unused for this many seconds
#: (a process of that code still running, e.g. a test of an older tree, is not disturbed).
PRUNE_AFTER_S = 86400.0

_NAME = re.compile(r"leakdiag-[0-9a-f]{16}")
_configured: Path | None = None


def _writable_parent(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK | os.X_OK)


def _base(environ) -> Path:
    given = environ.get(ENV, "")
    if given:
        p = Path(given)
        return p.parent if _NAME.fullmatch(p.name) else p
    own = PACKAGE_ROOT / "__pycache__" / "numba"
    if _writable_parent(own):
        return own
    xdg = environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "leakdiag" / "numba"


def kernel_cache_dir(environ=None) -> Path:
    """The folder Numba's cache of leakdiag's kernels uses (for this code), without setting it.

    Parameters
    ----------
    environ : mapping, optional
        The environment (default ``os.environ``).

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> kernel_cache_dir({"NUMBA_CACHE_DIR": "/tmp/nc"}).parent.as_posix()
    '/tmp/nc'
    """
    environ = os.environ if environ is None else environ
    return _base(environ) / f"leakdiag-{parts_fingerprint(KERNEL_PARTS)}"


def _prune(base: Path, keep: Path) -> None:
    """Remove the folders of former code beyond the :data:`KEEP` most recently used."""
    try:
        olds = [(d.stat().st_mtime, d) for d in base.iterdir()
                if d != keep and d.is_dir() and _NAME.fullmatch(d.name)]
    except OSError:
        return
    now = time.time()
    for mtime, d in sorted(olds, reverse=True)[KEEP:]:
        if now - mtime >= PRUNE_AFTER_S:
            shutil.rmtree(d, ignore_errors=True)


def configure() -> Path | None:
    """Point Numba's cache at the folder of this code (:func:`kernel_cache_dir`); idempotent.

    Sets ``NUMBA_CACHE_DIR`` (inherited by child processes: Dask workers, the monitor's
    sidecar) and, when Numba is imported already, its configuration; marks the folder as used
    and prunes folders of former code.

    Returns
    -------
    pathlib.Path or None
        The folder, or None when no folder can be written (Numba then falls back to its own
        places and warns when it cannot cache).
    """
    global _configured
    if _configured is not None and os.environ.get(ENV) == str(_configured):
        return _configured
    d = kernel_cache_dir()
    if not _writable_parent(d):
        return None
    os.environ[ENV] = str(d)
    config = sys.modules.get("numba.core.config")
    if config is not None:
        config.CACHE_DIR = str(d)
    try:
        os.utime(d)  # "recently used", for _prune in other versions' processes
    except OSError:
        pass
    _prune(d.parent, d)
    _configured = d
    return d
