"""On-disk cache of simulated recordings, keyed by a hash of everything that shapes them.

A simulation is identified by ``(system, every keyword argument, seed, leakdiag version)`` plus a
fingerprint of the source files the simulators run (:data:`SIM_CODE_PARTS`: ``sim/``, and the
argument checks and recording type they import, so an edit of any of them never reads stale
entries within one version) and the versions of Python and of the numerical libraries
(:func:`leakdiag._fingerprint.library_versions`: a new NumPy or SciPy may change the numbers). The
key is the SHA-256 of a canonical JSON rendering of that tuple, so a changed parameter misses
and an unchanged one hits. Entries are a Parquet file of the channels plus a JSON sidecar
(sample rate, start time, units, metadata, the key's inputs), written atomically so that several
Dask workers can fill the cache at once.

The cache folder is, in order: the ``cache_dir=`` argument, ``$LEAKDIAG_CACHE``,
``~/.cache/leakdiag``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from leakdiag._fingerprint import library_versions, parts_fingerprint
from leakdiag._version import __version__
from leakdiag.io.recording import Recording
from leakdiag.sim import simulate_eha, simulate_vca

__all__ = [
    "CACHE_ENV",
    "SIMULATORS",
    "resolve_cache_dir",
    "prepare_cache_dir",
    "canonical",
    "cache_key",
    "code_fingerprint",
    "SIM_CODE_PARTS",
    "simulation_code",
    "cached_simulation",
    "clear_cache",
]

#: Environment variable naming the cache folder.
CACHE_ENV = "LEAKDIAG_CACHE"

#: System name -> its simulator.
SIMULATORS: dict[str, Callable[..., Recording]] = {
    "vca": simulate_vca,
    "eha": simulate_eha,
}

#: Parts of leakdiag whose code makes a simulated recording: the simulators (``sim/`` with
#: ``vca/`` and ``eha/``), the argument checks they import (``_validation.py``: a check can
#: change a value, e.g. refuse or round it) and the recording type (``io/``). Until 2026-11-27
#: the key covered ``sim/`` only, so an edit of ``_validation.py`` served the former code's
#: recordings (cache audit of 2026-11-27, finding 3). ``tests/runtime/test_cache.py`` checks
#: that every leakdiag module the simulators import lies in one of these parts.
SIM_CODE_PARTS = ("_validation.py", "io", "sim")

#: Age in seconds after which :func:`clear_cache` takes a temporary file for the leftover of a
#: killed write (a write takes well under a second; an hour leaves room for a slow disk).
STALE_TEMP_S = 3600.0

#: Version of the on-disk entry layout; part of the key so a layout change never reads stale files.
_LAYOUT = 1


def resolve_cache_dir(cache_dir: str | os.PathLike | None = None) -> Path:
    """Folder of the simulation cache.

    Parameters
    ----------
    cache_dir : path-like, optional
        Explicit folder. Default: ``$LEAKDIAG_CACHE`` if set, else ``~/.cache/leakdiag``.

    Returns
    -------
    pathlib.Path
        The folder (not created here).

    Examples
    --------
    >>> resolve_cache_dir("/tmp/ld-cache").as_posix()
    '/tmp/ld-cache'
    """
    if cache_dir is not None:
        return Path(cache_dir).expanduser()
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "leakdiag"


def prepare_cache_dir(cache_dir: str | os.PathLike | None = None,
                      option: str = "cache_dir") -> Path:
    """Create the cache folder and check that it can be written, before the long work.

    A cache folder that cannot be made or written used to fail after the first simulation
    (when its entry is written), with the operating system's bare message.

    Parameters
    ----------
    cache_dir : path-like, optional
        Explicit folder (see :func:`resolve_cache_dir`).
    option : str, default "cache_dir"
        What names ``cache_dir`` in the message (``"--cache-dir"`` on the command line).

    Returns
    -------
    pathlib.Path
        The folder, created with its parents when missing.

    Raises
    ------
    OSError
        One line naming ``option`` (or ``$LEAKDIAG_CACHE``, or the default folder, when
        ``cache_dir`` is None) and the path, when the folder cannot be created or written.

    Examples
    --------
    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> prepare_cache_dir(f"{d}/a/b").is_dir()
    True
    >>> open(f"{d}/f", "w").close()
    >>> prepare_cache_dir(f"{d}/f/c", "--cache-dir")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    OSError: --cache-dir .../f/c: cannot create the folder: Not a directory
    """
    from leakdiag.runtime.paths import prepare_out_dir

    folder = resolve_cache_dir(cache_dir)
    if cache_dir is not None:
        label = option
    elif os.environ.get(CACHE_ENV):
        label = f"${CACHE_ENV}"
    else:
        label = "the default cache folder"
    return prepare_out_dir(folder, label)


def canonical(value: Any) -> Any:
    """Turn a parameter value into plain JSON data with one spelling per value.

    Dataclasses become ``{"__type__": name, fields...}``, numpy scalars and arrays become Python
    numbers and lists, tuples become lists, dict keys are sorted, floats keep their full ``repr``
    (NaN and infinities become strings).

    Parameters
    ----------
    value : object
        Parameter value.

    Returns
    -------
    object
        JSON-serialisable data.

    Raises
    ------
    TypeError
        For a value with no canonical form (e.g. a function), naming its type.

    Examples
    --------
    >>> canonical({"b": (1, 2.5), "a": np.float64(0.1)})
    {'a': 0.1, 'b': [1, 2.5]}
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {"__type__": type(value).__qualname__}
        for f in dataclasses.fields(value):
            out[f.name] = canonical(getattr(value, f.name))
        return out
    if isinstance(value, dict):
        return {str(k): canonical(value[k]) for k in sorted(value, key=str)}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if isinstance(value, np.ndarray):
        return [canonical(v) for v in value.tolist()]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else repr(v)
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"cannot build a cache key from a value of type {type(value).__name__}: {value!r}")


def cache_key(system: str, params: dict[str, Any], version: str = __version__) -> str:
    """SHA-256 key of a simulation: system, all parameters (seed included) and version.

    Parameters
    ----------
    system : str
        Simulator name, e.g. ``"vca"``.
    params : dict
        Every keyword argument passed to the simulator, the seed included.
    version : str, default leakdiag's version
        Package version; a new version never reuses old entries.

    Returns
    -------
    str
        64 hexadecimal characters.

    Examples
    --------
    >>> k1 = cache_key("vca", {"leak_lpm": 0.1, "seed": 1})
    >>> k2 = cache_key("vca", {"seed": 1, "leak_lpm": 0.1})
    >>> k1 == k2, k1 == cache_key("vca", {"leak_lpm": 0.1, "seed": 2})
    (True, False)
    """
    payload = {"system": str(system), "params": canonical(dict(params)),
               "version": str(version), "layout": _LAYOUT}
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _resolve_simulator(system: str) -> Callable[..., Recording]:
    if system not in SIMULATORS:
        raise ValueError(f"unknown system {system!r}; known: {sorted(SIMULATORS)}")
    return SIMULATORS[system]


def code_fingerprint(fn: Callable) -> str:
    """SHA-256 (16 hex digits) of the source files of the package holding ``fn``.

    Part of the cache key, so that a change to the simulator's code between releases (same
    version number) never serves a stale recording. For a function of ``leakdiag`` the package
    is the top-level folder under ``leakdiag`` (e.g. all of ``leakdiag/sim/`` with its
    ``vca/`` and ``eha/`` subpackages, for either simulator); otherwise the folder of its module.

    Parameters
    ----------
    fn : callable
        The simulator.

    Returns
    -------
    str
        ``""`` when the source cannot be located (e.g. a builtin).

    Examples
    --------
    >>> len(code_fingerprint(resolve_cache_dir))
    16
    """
    mod = sys.modules.get(getattr(fn, "__module__", ""), None)
    path = getattr(mod, "__file__", None)
    if not path:
        return ""
    parts = mod.__name__.split(".")
    if parts[0] == "leakdiag" and len(parts) > 2:
        return parts_fingerprint((parts[1],))
    folder = Path(path).parent
    return parts_fingerprint((folder.name,), folder.parent)


def simulation_code(fn: Callable) -> dict[str, Any]:
    """What of the code goes into a simulation's cache key: the source and the libraries.

    Parameters
    ----------
    fn : callable
        The simulator.

    Returns
    -------
    dict
        ``{"code": ..., "libraries": {...}}``: for leakdiag's simulators the fingerprint of
        :data:`SIM_CODE_PARTS`, for another function that of its package
        (:func:`code_fingerprint`); the libraries from
        :func:`leakdiag._fingerprint.library_versions`.

    Examples
    --------
    >>> sorted(simulation_code(simulate_vca))
    ['code', 'libraries']
    """
    if str(getattr(fn, "__module__", "")).startswith("leakdiag."):
        code = parts_fingerprint(SIM_CODE_PARTS)
    else:
        code = code_fingerprint(fn)
    return {"code": code, "libraries": library_versions()}


def _json_default(obj):
    try:
        return canonical(obj)
    except TypeError:
        return repr(obj)


def _write_entry(rec: Recording, folder: Path, key: str, inputs: dict) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    folder.mkdir(parents=True, exist_ok=True)
    table = pa.table({name: pa.array(values) for name, values in rec.channels.items()})
    side = {"key": key, "inputs": inputs, "sample_rate": rec.sample_rate,
            "start_time": rec.start_time, "units": rec.units, "meta": rec.meta,
            "channels": list(rec.channels)}
    # Write both files under temporary names, then rename: readers never see half an entry.
    fd, tmp_pq = tempfile.mkstemp(prefix=f".{key}.", suffix=".parquet", dir=folder)
    os.close(fd)
    fd, tmp_js = tempfile.mkstemp(prefix=f".{key}.", suffix=".json", dir=folder)
    os.close(fd)
    try:
        pq.write_table(table, tmp_pq)
        Path(tmp_js).write_text(json.dumps(side, default=_json_default, indent=1))
        os.replace(tmp_pq, folder / f"{key}.parquet")
        os.replace(tmp_js, folder / f"{key}.json")
    finally:
        for tmp in (tmp_pq, tmp_js):
            if os.path.exists(tmp):
                os.unlink(tmp)


def _read_entry(folder: Path, key: str) -> Recording | None:
    import pyarrow.parquet as pq

    pq_path, js_path = folder / f"{key}.parquet", folder / f"{key}.json"
    if not (pq_path.is_file() and js_path.is_file()):
        return None
    try:
        side = json.loads(js_path.read_text())
        table = pq.read_table(pq_path)
        chans = {name: table.column(name).to_numpy() for name in side["channels"]}
        meta = dict(side["meta"])
        meta["cache_key"] = key
        return Recording(chans, side["sample_rate"], side["start_time"], dict(side["units"]),
                         meta)
    except (OSError, ValueError, KeyError, TypeError):
        # a damaged entry (cut file, a sidecar without a field, a channel missing from the
        # Parquet file: KeyError) is a miss; it is rewritten
        return None


def cached_simulation(system: str, *, cache_dir: str | os.PathLike | None = None,
                      simulator: Callable[..., Recording] | None = None, refresh: bool = False,
                      **kwargs) -> Recording:
    """Simulate a recording, or read it from the on-disk cache if the same run was made before.

    Parameters
    ----------
    system : str
        ``"vca"`` or ``"eha"`` (:data:`SIMULATORS`), or any name when ``simulator`` is given.
    cache_dir : path-like, optional
        Cache folder (see :func:`resolve_cache_dir`).
    simulator : callable, optional
        Function ``simulator(**kwargs) -> Recording``; default the system's simulator in
        :mod:`leakdiag.sim`. Its qualified name is part of the key.
    refresh : bool, default False
        Ignore an existing entry and simulate again (the entry is overwritten).
    **kwargs
        Simulator arguments (``duration``, ``leak_lpm``, ``onset``, ``seed``, ``load``, ``params``
        ...); every one of them, leakdiag's version, the code fingerprint and the libraries'
        versions (:func:`simulation_code`) go into the key.

    Returns
    -------
    Recording
        The recording; ``meta['cache_key']`` holds the key and ``meta['cache_hit']`` whether it
        came from disk.

    Raises
    ------
    ValueError
        For an unknown system.
    TypeError
        If an argument has no canonical form for the key.

    Examples
    --------
    >>> import tempfile
    >>> def ramp(n, seed):
    ...     return Recording({"p1": np.arange(n) + seed}, sample_rate=10.0)
    >>> d = tempfile.mkdtemp()
    >>> a = cached_simulation("ramp", simulator=ramp, cache_dir=d, n=5, seed=1)
    >>> b = cached_simulation("ramp", simulator=ramp, cache_dir=d, n=5, seed=1)
    >>> a.meta["cache_hit"], b.meta["cache_hit"], b["p1"].tolist()
    (False, True, [1.0, 2.0, 3.0, 4.0, 5.0])
    """
    fn = simulator if simulator is not None else _resolve_simulator(system)
    name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"
    inputs = {"simulator": name, **simulation_code(fn), **kwargs}
    key = cache_key(system, inputs)
    folder = resolve_cache_dir(cache_dir)
    if not refresh:
        rec = _read_entry(folder, key)
        if rec is not None:
            rec.meta["cache_hit"] = True
            return rec
    _write_entry(fn(**kwargs), folder, key, canonical(inputs))
    # Return what was stored, so a cold and a warm run see exactly the same recording.
    rec = _read_entry(folder, key)
    rec.meta["cache_hit"] = False
    return rec


def clear_cache(cache_dir: str | os.PathLike | None = None) -> int:
    """Delete every cache entry in the folder; return the number of entries removed.

    Also removes the temporary files of writes that were cut (a killed process leaves
    ``.<key>.XXXX.parquet``/``.json``) once they are :data:`STALE_TEMP_S` old, so that a write
    in progress in another process is not broken.

    Parameters
    ----------
    cache_dir : path-like, optional
        Cache folder (see :func:`resolve_cache_dir`).

    Returns
    -------
    int
        Entries (Parquet + JSON pairs) removed.

    Examples
    --------
    >>> import tempfile
    >>> clear_cache(tempfile.mkdtemp())
    0
    """
    folder = resolve_cache_dir(cache_dir)
    if not folder.is_dir():
        return 0
    n = 0
    for js in folder.glob("*.json"):
        pq_path = js.with_suffix(".parquet")
        if len(js.stem) == 64:
            js.unlink()
            if pq_path.exists():
                pq_path.unlink()
            n += 1
    now = time.time()
    for tmp in folder.glob(".*.*"):
        parts = tmp.name.split(".")  # "", key, random part, suffix
        if len(parts) == 4 and len(parts[1]) == 64 and parts[3] in ("json", "parquet"):
            try:
                if now - tmp.stat().st_mtime >= STALE_TEMP_S:
                    tmp.unlink()
            except FileNotFoundError:  # its writer renamed or removed it meanwhile
                pass
    return n
