"""Fingerprints of leakdiag's own source code and of the libraries a result depends on.

Every cache that keeps a computed result (the simulation cache, the benchmark's work files,
batch results, Numba's compiled kernels) must miss when the code that computed it changes. The
version number does not say that (it stayed 0.1.0 over hundreds of commits), so the caches key
their entries with a hash of the source files themselves: :func:`parts_fingerprint` over the
*parts* of the package a result depends on (a module file such as ``_validation.py`` or a
subpackage folder such as ``sim``, with its subfolders), and :func:`library_versions` for the
numerical libraries underneath.

This module imports nothing of leakdiag and no third-party package, so that it can run before
Numba is imported (:mod:`leakdiag._numba_cache`).
"""

from __future__ import annotations

import functools
import hashlib
from importlib import metadata
from pathlib import Path

__all__ = ["PACKAGE_ROOT", "parts_fingerprint", "library_versions", "KERNEL_PARTS"]

#: The folder of the ``leakdiag`` package.
PACKAGE_ROOT = Path(__file__).resolve().parent

#: Parts whose code Numba compiles into leakdiag's kernels: the kernels themselves (``sim``,
#: ``features``, ``detect``, ``literature``) and what their code reads at compile time (the
#: helpers of other files they call, the module constants they freeze, ``_validation.py`` and
#: ``_holds.py``, ``io`` for the recording type). A test checks that every module importing
#: Numba lies in one of them (``tests/test_fingerprint.py``).
KERNEL_PARTS = ("_holds.py", "_validation.py", "detect", "features", "io", "literature", "sim")


@functools.lru_cache(maxsize=None)
def parts_fingerprint(parts: tuple[str, ...], root: Path | None = None) -> str:
    """SHA-256 (16 hex digits) of the Python source of some parts of the package.

    Each part is a module file (``"_validation.py"``) or a folder (``"sim"``: every ``*.py``
    below it); each file contributes its path relative to the package and its bytes, in sorted
    order, so a renamed, added, removed or edited file changes the result and nothing else
    does. Cached for the life of the process (the sources of a running program do not change
    under it; a test that edits a copy calls ``parts_fingerprint.cache_clear()``).

    Parameters
    ----------
    parts : tuple of str
        Names relative to ``root``, in the order they are hashed.
    root : pathlib.Path, optional
        The folder the parts lie in (default: the leakdiag package, :data:`PACKAGE_ROOT`).

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If a part does not exist (a typo would otherwise hash nothing and never change).

    Examples
    --------
    >>> len(parts_fingerprint(("sim", "_validation.py")))
    16
    """
    root = PACKAGE_ROOT if root is None else root
    h = hashlib.sha256()
    for part in parts:
        p = root / part
        if p.is_file():
            files = [p]
        elif p.is_dir():
            files = sorted(p.rglob("*.py"))
        else:
            raise ValueError(f"{root} has no module or folder {part!r} to fingerprint")
        h.update(f"<{part}>".encode())
        for f in files:
            h.update(f.relative_to(root).as_posix().encode() + b"\0")
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def library_versions() -> dict[str, str]:
    """Installed versions of Python and the libraries leakdiag's numbers depend on.

    NumPy (random streams, linear algebra), SciPy (filters, fits), Numba (compiled kernels) and
    pandas/pyarrow (what is read back). A library that is not installed is ``"absent"``.

    Returns
    -------
    dict of str to str

    Examples
    --------
    >>> sorted(library_versions())
    ['numba', 'numpy', 'pandas', 'pyarrow', 'python', 'scipy']
    """
    import platform

    out = {"python": platform.python_version()}
    for name in ("numba", "numpy", "pandas", "pyarrow", "scipy"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "absent"
    return out
