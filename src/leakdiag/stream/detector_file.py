"""Fitted detectors on disk: a joblib file with a small metadata record checked on load.

``leakdiag fit`` writes the file; ``leakdiag detect --detector``, ``leakdiag monitor --detector``
and ``leakdiag batch`` (``[[detector]] path``) read it. The record holds the leakdiag version, a
fingerprint of the code that fitted the detector, the method, the system, the sample rate, the
channels and their units of the healthy recordings the detector was fitted on, and the SHA-256
of the pickled detector; :func:`load_detector_file` refuses a file that is not a detector file,
is damaged or whose record does not describe its detector, and warns when other code fitted it;
:func:`check_detector_fits` refuses a recording that disagrees.

Only load files you trust: joblib files are pickles and can run code.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import pickle
import re
import tempfile
import warnings
from dataclasses import MISSING, asdict, dataclass, field, fields, replace
from typing import Any

from leakdiag._version import __version__
from leakdiag.io.checks import same_rate
from leakdiag.io.recording import load_name, machine_unit

__all__ = ["DetectorMeta", "save_detector", "load_detector_file", "check_detector_fits",
           "sniff_detector_file", "detector_code_fingerprint", "DetectorFileWarning",
           "DETECTOR_FORMAT", "DETECTOR_FINGERPRINT_PARTS", "unchecked_note", "ADVICE_MAP",
           "ADVICE_JOB", "own_healthy_reason",
           "own_healthy_samples_reason", "fitted_machine"]

#: Tag of the record written by :func:`save_detector` (2: code fingerprint and SHA-256 of the
#: pickled detector, 2026-11-27; 1: the detector pickled inside the record, still read).
DETECTOR_FORMAT = "leakdiag-detector/2"
_FORMAT_1 = "leakdiag-detector/1"

#: Subpackages whose code fits and scores a detector (the detectors, their features, the
#: literature methods, the streaming scorer, the readers): the fingerprint of a detector file.
DETECTOR_FINGERPRINT_PARTS = ("detect", "features", "literature", "stream", "io")

#: First bytes of a joblib file: a pickle of protocol 2 or newer (what joblib and pickle write
#: since Python 3), or one of joblib's compressed containers (``joblib.compressor``).
_PICKLE_MAGIC = b"\x80"
_COMPRESSED_MAGIC = (b"\x1f\x8b", b"BZh", b"\xfd7zXZ", b"]\x00\x00", b'\x04"M\x18', b"ZF")
#: First bytes of files that are recordings or other data, never a detector file.
_OTHER_MAGIC = ((b"PAR1", "a Parquet file (a recording?)"),
                (b"\x89HDF\r\n\x1a\n", "an HDF5 file (a recording?)"),
                (b"PK\x03\x04", "a zip archive (.npz, .xlsx?)"),
                (b"\x93NUMPY", "a NumPy .npy array"),
                (b"SQLite format 3\x00", "an SQLite database (an event store?)"),
                (b"MATLAB", "a MATLAB .mat file (a recording?)"))
#: Bytes read to tell the kind of a file.
_SNIFF_BYTES = 512
#: The keys of a format-2 file.
_FILE_KEYS = {"format", "meta", "meta_sha256", "payload_sha256", "detector_pickle"}


class DetectorFileWarning(UserWarning):
    """A detector file loads, but something about it cannot be checked or may have changed."""


@dataclass(frozen=True)
class DetectorMeta:
    """What a fitted detector was fitted on.

    Attributes
    ----------
    method : str
        Registry name (:data:`leakdiag.bench.registry.METHODS`).
    system : str
        ``"vca"`` or ``"eha"``.
    sample_rate_hz : float
        Sample rate of the healthy recordings.
    channels : tuple of str
        Channels the detector reads.
    units : dict
        Unit of each of those channels.
    false_alarms_per_hour : float
        The CUSUM's false-alarm target on healthy operation.
    n_healthy : int
        Healthy recordings used.
    healthy_files : tuple of str
        Their paths, as given.
    healthy_sha256 : tuple of str
        SHA-256 of those files' bytes (``leakdiag batch`` refuses to judge one of them with the
        detector, as ``detect`` does by its samples); empty in files written before session 22.
    leakdiag_version : str
        Version that wrote the file.
    load : str or None
        The load named in every healthy recording's metadata (``"none"``, ``"spring"``); None
        when they do not say or differ (files written before it: None).
    code_fingerprint : str or None
        :func:`detector_code_fingerprint` of the code that fitted the detector (set by
        :func:`save_detector`); None in files written before 2026-11-27.
    machine : int, str or None
        The machine unit every healthy recording's metadata names (:func:`~leakdiag.io.recording.machine_unit`); None
        when they do not say or differ (a fleet fit; files written before 2026-11-29: None).
    """

    method: str
    system: str
    sample_rate_hz: float
    channels: tuple
    units: dict = field(default_factory=dict)
    false_alarms_per_hour: float = 1.0
    n_healthy: int = 0
    healthy_files: tuple = ()
    leakdiag_version: str = __version__
    load: str | None = None
    code_fingerprint: str | None = None
    healthy_sha256: tuple = ()
    machine: int | str | None = None


def common_machine(metas) -> int | str | None:
    """The machine unit every one of ``metas`` names (:func:`~leakdiag.io.recording.machine_unit`), or None when
    one does not say or they differ.

    Examples
    --------
    >>> three = {"machine": {"unit": 3}}
    >>> common_machine([three, three]), common_machine([three, {}])
    (3, None)
    """
    units = {machine_unit(m) for m in metas}
    return units.pop() if len(units) == 1 else None


#: A module of each part: :func:`leakdiag.runtime.cache.code_fingerprint` hashes the whole
#: top-level folder of the module it is given.
_FINGERPRINT_MODULES = {"detect": "leakdiag.detect.base", "features": "leakdiag.features.spec",
                        "literature": "leakdiag.literature.registry",
                        "stream": "leakdiag.stream.detector_file",
                        "io": "leakdiag.io.recording"}


@functools.lru_cache(maxsize=1)
def detector_code_fingerprint() -> str:
    """Fingerprint of the code that fits and scores detectors (16 hex digits).

    The simulation cache's hash of a package's source files
    (:func:`leakdiag.runtime.cache.code_fingerprint`, which keys the benchmark's simulated
    runs; ``bench.v5_common`` hashes its parts the same way, but ``stream`` may not import
    ``bench``) for each subpackage of :data:`DETECTOR_FINGERPRINT_PARTS`, combined in order as
    the benchmark's v5 fingerprint combines its parts (``part=hash;``). The version number stayed 0.1.0 across
    hundreds of commits; this changes with any edit to that code.

    Returns
    -------
    str

    Examples
    --------
    >>> len(detector_code_fingerprint())
    16
    """
    import importlib
    from types import SimpleNamespace

    from leakdiag.runtime.cache import code_fingerprint

    h = hashlib.sha256()
    for part in DETECTOR_FINGERPRINT_PARTS:
        mod = _FINGERPRINT_MODULES[part]
        importlib.import_module(mod)
        h.update(f"{part}={code_fingerprint(SimpleNamespace(__module__=mod))};".encode())
    return h.hexdigest()[:16]


def _type_name(obj: Any) -> str:
    if obj is None:
        return "None"
    t = type(obj)
    return t.__qualname__ if t.__module__ == "builtins" else f"{t.__module__}.{t.__qualname__}"


def _is_detector(obj: Any) -> bool:
    """A leakdiag detector (``fit``/``predict``) or a monitor scorer (``score_windows``)."""
    return any(callable(getattr(obj, m, None))
               for m in ("predict", "fit", "score_windows", "spec"))


def _fitted_problem(det: Any) -> str | None:
    check = getattr(det, "_check_fitted", None)
    if callable(check):
        try:
            check()
        except Exception as exc:  # noqa: BLE001 - NotFittedError or a subclass's own
            return str(exc)
        return None
    if hasattr(det, "threshold_") or callable(getattr(det, "alarm_windows", None)):
        return None
    return f"{type(det).__name__} has no threshold_ (not fitted?)"


def _record_mismatch(det: Any, meta: DetectorMeta) -> str | None:
    """Why the record does not describe ``det`` (None: it does, as far as ``det`` says).

    Compared where the detector has the attribute: its ``channels``, its ``system`` (flow
    balance) and the system of the recordings it was fitted on (``system_``). The method name
    is the registry's (``leakdiag.bench``), which this layer does not import: the record's
    SHA-256 (:func:`save_detector`) covers it.
    """
    out = []
    chans = getattr(det, "channels", None)
    if isinstance(chans, (list, tuple)) and chans and tuple(chans) != tuple(meta.channels):
        out.append(f"channels {','.join(meta.channels)}, but the detector reads "
                   f"{','.join(map(str, chans))}")
    for attr in ("system", "system_"):
        got = getattr(det, attr, None)
        if isinstance(got, str) and got.lower() != meta.system:
            out.append(f"system {meta.system!r}, but the detector was "
                       + (f"built for {got.lower()!r}" if attr == "system" else
                          f"fitted on {got.lower()!r} recordings"))
            break
    if not out:
        return None
    return f"its record says {meta.method} with {'; '.join(out)}"


def _meta_sha256(meta: dict) -> str:
    """SHA-256 of a record (its JSON with sorted keys: tuples and lists alike)."""
    text = json.dumps(meta, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def binary_kind(head: bytes) -> str | None:
    """What a file that starts with ``head`` is when its first bytes name a binary format
    leakdiag knows (a recording, an archive, an event store): ``"a Parquet file (a
    recording?)"``, ...; None otherwise (text, a pickle, unknown bytes).

    Parameters
    ----------
    head : bytes
        The file's first bytes (32 are enough).

    Returns
    -------
    str or None

    Examples
    --------
    >>> binary_kind(b"PAR1"), binary_kind(b"time,p1")
    ('a Parquet file (a recording?)', None)
    """
    return next((what for magic, what in _OTHER_MAGIC if head.startswith(magic)), None)


def sniff_detector_file(path: str | os.PathLike) -> str | None:
    """What a file is when it cannot be a detector file, from its first bytes.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    str or None
        The reason (``"empty"``, ``"a Parquet file (a recording?)"``, ...), or None when the
        file starts like a joblib file or a pickle of protocol 2 or newer (whether it is a
        detector file is only known by loading it).

    Raises
    ------
    OSError
        If the file cannot be read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = p.write_text("time,p1\\n0,1\\n")
    >>> sniff_detector_file(p)
    'a text file (a CSV recording?)'
    """
    with open(os.fspath(path), "rb") as f:
        head = f.read(_SNIFF_BYTES)
    if not head:
        return "empty (0 bytes)"
    what = binary_kind(head)
    if what is not None:
        return what
    if head.startswith(_PICKLE_MAGIC) or head.startswith(_COMPRESSED_MAGIC):
        return None
    # joblib's zlib container: a zlib header, 0x78 and a check byte (RFC 1950)
    if len(head) > 1 and head[0] == 0x78 and (head[0] * 256 + head[1]) % 31 == 0:
        return None
    for cut in range(4):  # the 512 bytes may end inside a UTF-8 character
        try:
            text = head[:len(head) - cut].decode("utf-8")
        except UnicodeDecodeError:
            continue
        if "\x00" not in text and all(c.isprintable() or c in "\r\n\t" for c in text):
            return "a text file (a CSV recording?)"
        break
    return (f"neither a joblib file nor a pickle (it starts with bytes "
            f"{head[:4].hex(' ')})")


_MODULE_RE = re.compile(r" on <module '([^']+)'[^>]*>")


def _unpickle(path: str, load) -> Any:
    """``load()``, its failures in words naming the file."""
    try:
        return load()
    except (AttributeError, ImportError) as exc:  # a class or module of other code
        why = _MODULE_RE.sub(r" in module \1", str(exc))
        raise ValueError(f"{path}: written by another leakdiag version whose classes this one "
                         f"does not have ({why}): re-fit it with leakdiag fit") from None
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - damaged bytes raise anything; name the file
        raise ValueError(f"{path}: truncated or not a detector file from leakdiag fit "
                         f"({type(exc).__name__}: {exc})") from None


_NUMBER = (int, float)


def _check_field(path: str, name: str, v: Any) -> None:
    def bad(expected: str) -> ValueError:
        return ValueError(f"{path}: its record's {name} is {v!r} ({_type_name(v)}), not "
                          f"{expected}: the file is damaged or was edited; re-fit it with "
                          "leakdiag fit")

    if name in ("method", "system", "leakdiag_version"):
        if not isinstance(v, str) or not v:
            raise bad("a non-empty string")
    elif name in ("load", "code_fingerprint"):
        if v is not None and not isinstance(v, str):
            raise bad("a string or None")
    elif name in ("sample_rate_hz", "false_alarms_per_hour"):
        if isinstance(v, bool) or not isinstance(v, _NUMBER) or not math.isfinite(v) or v <= 0:
            raise bad("a number > 0")
    elif name == "n_healthy":
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise bad("an integer >= 0")
    elif name in ("channels", "healthy_files", "healthy_sha256"):
        if not isinstance(v, (list, tuple)) or not all(isinstance(c, str) for c in v) or \
                (name == "channels" and not v):
            raise bad("a list of strings" + (" (at least one)" if name == "channels" else ""))
    elif name == "machine":
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, str))):
            raise bad("a machine unit (an integer or a name) or None")
    elif name == "units":
        if not isinstance(v, dict) or not all(isinstance(k, str) and
                                              (u is None or isinstance(u, str))
                                              for k, u in v.items()):
            raise bad("a table of channel -> unit")


def _parse_meta(path: str, raw: Any) -> DetectorMeta:
    """The record as a :class:`DetectorMeta`; a ValueError naming the file and what is wrong."""
    if not isinstance(raw, dict):
        what = "no 'meta' record" if raw is None else f"a 'meta' entry of type {_type_name(raw)}"
        raise ValueError(f"{path}: {what}, not a table of what the detector was fitted on: the "
                         "file is damaged or was not written by leakdiag fit; re-fit it")
    known = {f.name: f for f in fields(DetectorMeta)}
    unknown = sorted(set(raw) - set(known))
    if unknown:
        raise ValueError(f"{path}: its record has field(s) {', '.join(map(str, unknown))} that "
                         f"this leakdiag ({__version__}) does not know: written by a newer "
                         "leakdiag, whose checks this one cannot make; load it with that "
                         "version, or re-fit it with this one (leakdiag fit)")
    required = [n for n, f in known.items()
                if f.default is MISSING and f.default_factory is MISSING]
    missing = [n for n in required if n not in raw]
    if missing:
        raise ValueError(f"{path}: its record lacks {', '.join(missing)}: the file is damaged "
                         "or was edited; re-fit it with leakdiag fit")
    for name, v in raw.items():
        _check_field(path, name, v)
    d = dict(raw)
    d["channels"] = tuple(d["channels"])
    d["healthy_files"] = tuple(d.get("healthy_files", ()))
    d["healthy_sha256"] = tuple(d.get("healthy_sha256", ()))
    d["sample_rate_hz"] = float(d["sample_rate_hz"])
    return DetectorMeta(**d)


def save_detector(detector: Any, meta: DetectorMeta, path: str | os.PathLike) -> str:
    """Write a fitted detector and its metadata record (a joblib file).

    The detector is pickled on its own; the file holds that pickle, its SHA-256 and the record,
    which gets the fingerprint of the code that fitted the detector
    (:func:`detector_code_fingerprint`) and this leakdiag's version. The file is written under
    a temporary name in the same folder and renamed, so a failed write leaves no half file.

    Parameters
    ----------
    detector : Detector
        Fitted detector (a :class:`~leakdiag.detect.base.Detector`, or a monitor scorer with
        ``score_windows``).
    meta : DetectorMeta
        What it was fitted on.
    path : str or path-like
        Output file (``.joblib`` by convention).

    Returns
    -------
    str
        The path written.

    Raises
    ------
    TypeError
        For an object that is not a detector, or a ``meta`` that is not a DetectorMeta.
    ValueError
        For an unfitted detector, or a record whose channels or system do not describe it.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from leakdiag.detect.base import Alarm
    >>> from leakdiag.detect.methods import thesis_detector
    >>> from leakdiag.sim import simulate_vca
    >>> healthy = [simulate_vca(duration=30.0, leak_lpm=None, seed=s) for s in (1, 2)]
    >>> alarm = Alarm(false_alarms_per_hour=60.0, burn_in_s=1.0)
    >>> det = thesis_detector("vca", "autocorrelation", alarm=alarm).fit(healthy)
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "d.joblib"
    >>> _ = save_detector(det, DetectorMeta("acf-p1", "vca", 1000.0, ("p1",)), p)
    >>> loaded, meta = load_detector_file(p)
    >>> meta.method, loaded.threshold_ == det.threshold_
    ('acf-p1', True)
    """
    import joblib

    path = os.fspath(path)
    if not isinstance(meta, DetectorMeta):
        raise TypeError(f"{path}: not written: meta is a {_type_name(meta)}, not a DetectorMeta")
    if not _is_detector(detector):
        raise TypeError(f"{path}: not written: not a leakdiag detector (a "
                        f"{_type_name(detector)}: no fit, predict or score_windows)")
    why = _fitted_problem(detector)
    if why is not None:
        raise ValueError(f"{path}: not written: {why}")
    why = _record_mismatch(detector, meta)
    if why is not None:
        raise ValueError(f"{path}: not written: {why}")
    meta = replace(meta, leakdiag_version=__version__,
                   code_fingerprint=detector_code_fingerprint())
    payload = pickle.dumps(detector, protocol=pickle.HIGHEST_PROTOCOL)
    raw_meta = asdict(meta)
    record = {"format": DETECTOR_FORMAT, "meta": raw_meta, "meta_sha256": _meta_sha256(raw_meta),
              "payload_sha256": hashlib.sha256(payload).hexdigest(), "detector_pickle": payload}
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=".tmp", dir=folder)
    os.close(fd)
    try:
        joblib.dump(record, tmp)
        mask = os.umask(0)  # mkstemp made it 0600: give it the mode a new file gets
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _warn(msg: str) -> None:
    warnings.warn(msg, DetectorFileWarning, stacklevel=3)


def load_detector_file(path: str | os.PathLike) -> tuple[Any, DetectorMeta | None]:
    """Read a detector file written by :func:`save_detector` (or a bare pickled detector).

    Only load files you trust: a detector file is a pickle and runs code when loaded. The
    first bytes are checked before anything is unpickled (a recording, an empty or a text
    file is refused without unpickling it).

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    detector : object
        The fitted detector.
    meta : DetectorMeta or None
        Its record; None for a bare pickle (nothing can be checked; a warning says so).

    Raises
    ------
    ValueError
        Naming the file and what is wrong: not a detector file (empty, a recording, text,
        truncated), an object that is not a detector, a damaged record (missing or mistyped
        fields), fields a newer leakdiag added, a SHA-256 that does not match the detector or
        the record (damaged or edited after it was written: an edited method), a record whose
        channels or system do not describe the detector, or classes this leakdiag does not have
        (written by other code: re-fit it).

    Warns
    -----
    DetectorFileWarning
        When other code fitted the detector (its fingerprint differs from
        :func:`detector_code_fingerprint`), the code that fitted it is unknown (written before
        2026-11-27), or the file is a bare pickle without a record.

    Notes
    -----
    Decided: a record with a field this version does not know (written by a newer leakdiag)
    is refused, not loaded with the field ignored: the field may carry a constraint this
    version cannot check (as ``load`` did when it was added).
    """
    import joblib

    path = os.fspath(path)
    try:
        kind = sniff_detector_file(path)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if kind is not None:
        if kind.startswith("empty"):
            raise ValueError(f"{path}: empty (0 bytes): not a detector file from leakdiag fit")
        if kind.startswith("a text file"):
            raise ValueError(f"{path}: cannot load as a detector file: {kind}, not a detector "
                             "file from leakdiag fit")
        raise ValueError(f"{path}: {kind}, not a detector file from leakdiag fit")
    obj = _unpickle(path, lambda: joblib.load(path))
    if isinstance(obj, dict) and isinstance(obj.get("format"), str) and \
            obj["format"].startswith("leakdiag-detector/"):
        fmt = obj["format"]
        if fmt not in (DETECTOR_FORMAT, _FORMAT_1):
            raise ValueError(f"{path}: detector file format {fmt!r}, which this leakdiag "
                             f"({__version__}, reads {DETECTOR_FORMAT!r} and {_FORMAT_1!r}) does "
                             "not know: written by a newer leakdiag; re-fit it with this one")
        if fmt == DETECTOR_FORMAT:
            unknown = sorted(set(obj) - _FILE_KEYS)
            if unknown:
                raise ValueError(f"{path}: entries {', '.join(map(str, unknown))} that this "
                                 f"leakdiag ({__version__}) does not know: written by a newer "
                                 "leakdiag; load it with that version, or re-fit it with this "
                                 "one (leakdiag fit)")
        meta = _parse_meta(path, obj.get("meta"))
        if fmt == DETECTOR_FORMAT:
            payload, want = obj.get("detector_pickle"), obj.get("payload_sha256")
            if not isinstance(payload, bytes) or not isinstance(want, str) or \
                    not isinstance(obj.get("meta_sha256"), str):
                raise ValueError(f"{path}: its record has no detector or no SHA-256 of it: the "
                                 "file is damaged; re-fit it with leakdiag fit")
            if _meta_sha256(obj["meta"]) != obj["meta_sha256"]:
                raise ValueError(f"{path}: its record (method {meta.method}, system "
                                 f"{meta.system}, ...) does not match the SHA-256 leakdiag fit "
                                 "stored with it: the record was edited or the file is damaged; "
                                 "re-fit it with leakdiag fit")
            got = hashlib.sha256(payload).hexdigest()
            if got != want:
                raise ValueError(f"{path}: damaged: the detector's SHA-256 is {got[:16]}..., "
                                 f"its record says {want[:16]}...: the file changed after "
                                 "leakdiag fit wrote it; re-fit it")
            det = _unpickle(path, lambda: pickle.loads(payload))
        else:
            det = obj.get("detector")
        if not _is_detector(det):
            raise ValueError(f"{path}: not a leakdiag detector (holds {_type_name(det)})")
        why = _record_mismatch(det, meta)
        if why is not None:
            raise ValueError(f"{path}: {why}: the record was edited or the file is damaged; "
                             "re-fit it with leakdiag fit")
        mine = detector_code_fingerprint()
        if meta.code_fingerprint is None:
            _warn(f"{path}: the code that fitted it is unknown (leakdiag {meta.leakdiag_version},"
                  f" written before detector files recorded it); this code ({mine}) may score "
                  "it differently: re-fit it with leakdiag fit")
        elif meta.code_fingerprint != mine:
            _warn(f"{path}: fitted by leakdiag code {meta.code_fingerprint} (version "
                  f"{meta.leakdiag_version}), this is code {mine} (version {__version__}); it "
                  "may be scored differently than when it was fitted: re-fit it with "
                  "leakdiag fit")
        return det, meta
    if isinstance(obj, dict):
        raise ValueError(f"{path}: not a leakdiag detector file (a dict without a "
                         f"{DETECTOR_FORMAT!r} record)")
    if not _is_detector(obj):
        raise ValueError(f"{path}: not a leakdiag detector (holds {_type_name(obj)})")
    _warn(f"{path}: a bare pickled detector without a metadata record: its sample rate, "
          "channels, units, system and load cannot be checked against the recordings, and the "
          "code that fitted it is unknown; write it with leakdiag fit")
    return obj, None


def _assumed_si_units(channels) -> dict[str, str]:
    """The SI unit :func:`leakdiag.io.read_recording` gives each standard channel of a file that
    states no units (``{"p1": "Pa"}``); other channels have none."""
    from leakdiag.io.units import CHANNEL_QUANTITY, QUANTITY_SI_UNIT

    return {c: QUANTITY_SI_UNIT[CHANNEL_QUANTITY[c]] for c in channels if c in CHANNEL_QUANTITY}


def check_detector_fits(meta: DetectorMeta | None, *, sample_rate: float,
                        channels=None, units: dict | None = None, system: str | None = None,
                        source: str = "<recording>", path: str = "<detector>",
                        load: str | None = None, machine=None) -> None:
    """Refuse a recording that disagrees with what the detector was fitted on.

    Parameters
    ----------
    meta : DetectorMeta or None
        The detector's record (None: nothing to check).
    sample_rate : float
        The recording's sample rate in Hz.
    channels : iterable of str, optional
        The recording's channels.
    units : dict, optional
        The recording's channel units; None: the file states none (a plain CSV, stdin, another
        program's file), so its standard channels are taken as SI, as
        :func:`leakdiag.io.read_recording` takes them (``p1`` in Pa): ``monitor``, ``batch`` and
        ``detect`` then refuse alike a plain CSV against a detector fitted on counts (audit of
        users' recordings 2026-11-27, finding 8).
    system : str, optional
        The recording's system (from its metadata).
    source, path : str
        Names for the message.
    load : str, optional
        The recording's load (from its metadata): refused when the detector's healthy
        recordings all named another one (a detector fitted without load judged healthy spring
        runs LEAK).
    machine : int or str, optional
        The recording's machine unit (:func:`machine_unit` of its metadata): refused when the
        detector's healthy recordings all named another one (a CLI audit, 2026-11-29: feature
        detectors judged healthy runs of other units LEAK, 3 of 7 pairs; units differ more
        than a leak changes the features).

    Raises
    ------
    ValueError
        Naming the file, the detector file and what differs.

    Examples
    --------
    >>> m = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"})
    >>> check_detector_fits(m, sample_rate=500.0, source="r.csv", path="d.joblib")
    Traceback (most recent call last):
    ...
    ValueError: r.csv: sample rate 500 Hz, but d.joblib was fitted at 1000 Hz
    """
    if meta is None:
        return
    if not same_rate(sample_rate, meta.sample_rate_hz):
        raise ValueError(f"{source}: sample rate {sample_rate:g} Hz, but {path} was fitted at "
                         f"{meta.sample_rate_hz:g} Hz")
    if system and str(system).lower() != meta.system:
        raise ValueError(f"{source}: system {str(system).lower()!r}, but {path} was fitted on "
                         f"{meta.system!r} recordings")
    fitted_load, load = load_name(getattr(meta, "load", None)), load_name(load)
    if load is not None and fitted_load is not None and load != fitted_load:
        raise ValueError(f"{source}: load {str(load)!r}, but {path} was fitted on healthy "
                         f"recordings with load {fitted_load!r}; fit one on healthy recordings "
                         "under this load")
    fitted_unit = getattr(meta, "machine", None)
    if machine is not None and fitted_unit is not None and machine != fitted_unit:
        raise ValueError(f"{source}: machine unit {machine!r}, but {path} was fitted on healthy "
                         f"recordings of machine unit {fitted_unit!r}: machines differ more "
                         "than a leak changes what a detector measures; fit one on healthy "
                         "recordings of this machine")
    if channels is not None:
        missing = [c for c in meta.channels if c not in set(channels)]
        if missing:
            raise ValueError(f"{source}: no channel {', '.join(missing)}, which {path} reads")
    assumed = units is None  # a plain CSV or a stream: its columns taken as SI
    if assumed:
        units = _assumed_si_units(meta.channels)
    for c in meta.channels:
        want, got = meta.units.get(c), units.get(c)
        if want and got and want != got:
            # how to state the units where nothing did (a workflow audit, 2026-11-30: a
            # detector fitted on raw counts met a live stream, with no word that stdin and
            # --follow have no way to state them)
            how = (f"; the recording states no units, so its columns were taken as SI: state "
                   f"them for a file (a column map: --map, --col {c}=NAME:{want}, or a batch "
                   "job's column_map); stdin and --follow take SI values only, so to monitor "
                   "a live stream fit the detector on recordings converted to SI (a column map "
                   "with the sensor's gain, docs/io.md)") if assumed else ""
            raise ValueError(f"{source}: channel {c!r} is in {got!r}, but {path} was fitted "
                             f"on {want!r}{how}")


#: Where a ``detect`` or ``monitor`` user states a recording's rig and load
#: (:func:`unchecked_note`).
ADVICE_MAP = "a --map"
#: Where a ``batch`` user states them.
ADVICE_JOB = "the job's column map"


def own_healthy_reason(meta: DetectorMeta | None, sha256: str, source: str,
                       path: str) -> str | None:
    """Why a detector file does not judge a recording file: it is one of the healthy files the
    detector was fitted on (the same bytes, ``DetectorMeta.healthy_sha256``).

    Judged against a threshold it set itself, a leak reads NO LEAK and a false alarm LEAK: a
    CLI audit (2026-11-29) found one of a detector's 8 healthy files reading LEAK in ``batch``.
    ``detect`` refuses such a recording by its samples
    (:func:`leakdiag.detect.base.refuse_own_healthy`); ``batch`` and ``monitor``, which read a
    file in chunks, by its bytes with this function.

    Parameters
    ----------
    meta : DetectorMeta or None
        The detector's record (None, or no hashes recorded: files written before session 22,
        nothing to check).
    sha256 : str
        SHA-256 of the recording file's bytes (:func:`leakdiag.batch.store.content_hash`).
    source, path : str
        The recording and the detector file, for the message.

    Returns
    -------
    str or None
        The reason, naming both files; None when it is not one of them.

    Examples
    --------
    >>> m = DetectorMeta("flow-balance", "vca", 1000.0, ("p1",), healthy_sha256=("ab", "cd"))
    >>> own_healthy_reason(m, "cd", "h2.parquet", "fb.joblib")[:53]
    'h2.parquet: one of the 2 healthy recordings fb.joblib'
    >>> own_healthy_reason(m, "ef", "new.parquet", "fb.joblib") is None
    True
    """
    known = tuple(getattr(meta, "healthy_sha256", ()) or ())
    if sha256 not in known:
        return None
    return (f"{source}: one of the {len(known)} healthy recordings {path} was fitted on (the "
            "same bytes): judged against a threshold it set itself, a leak reads NO LEAK; "
            "judge recordings other than the healthy ones (or fit without this one)")


def own_healthy_samples_reason(detector, source: str, n_samples: int | None,
                               sample_rate: float, read, path: str) -> str | None:
    """Why ``detector`` does not judge the recording ``source``: it holds the same samples as
    one of its healthy recordings over the channels it reads (``detect``'s check,
    :func:`leakdiag.detect.base.refuse_own_healthy`), for ``monitor`` and ``batch``, which read
    a file in chunks and compared it by its bytes only: a healthy training file saved again
    with CRLF line ends, or as Parquet, was judged NO LEAK against the threshold it set (a
    user-data audit, 2026-11-29).

    The recording is read whole (``read(channels)``) only when its length and rate are those
    of a healthy recording (``healthy_shapes_``, recorded by ``fit`` since 2026-11-29;
    detectors fitted before keep the check by bytes only).

    Parameters
    ----------
    detector : Detector
        The fitted detector.
    source : str
        The recording, for the message.
    n_samples : int or None
        Its samples per channel, if known without reading it (None: read to find out).
    sample_rate : float
        Its sample rate, Hz.
    read : callable
        ``read(channels) -> Recording``: the recording's channels as the detector reads them.
    path : str
        The detector file, for the message.

    Returns
    -------
    str or None
    """
    from leakdiag.detect.base import own_healthy_words

    chans = getattr(detector, "fingerprint_channels_", None)
    shapes = getattr(detector, "healthy_shapes_", None)
    if not getattr(detector, "healthy_fingerprints_", None) or chans is None or not shapes:
        return None
    if n_samples is not None and (int(n_samples), float(sample_rate)) not in shapes:
        return None
    why = own_healthy_words(detector, read(list(chans)), fitted_on=path)
    return None if why is None else f"{source}: {why}"


def fitted_machine(detector, meta=None):
    """The machine unit of a detector's healthy recordings: the flow balance's
    ``operation_["machine"]`` (a unit id, ``"nominal"``, or None when unknown or mixed), a
    feature detector's ``healthy_machine_``, else the detector file's record
    (``meta.machine``, any method); None when none says.

    Parameters
    ----------
    detector : object
        A fitted detector.
    meta : DetectorMeta, optional
        Its file's record.

    Returns
    -------
    int, str or None

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> fitted_machine(SimpleNamespace(operation_={"machine": 57})), fitted_machine(object())
    (57, None)
    >>> fitted_machine(object(), SimpleNamespace(machine=3))
    3
    """
    op = getattr(detector, "operation_", None)
    unit = op.get("machine") if isinstance(op, dict) else None
    if unit is None:  # a feature detector's own record (since 2026-11-30)
        unit = getattr(detector, "healthy_machine_", None)
    return unit if unit is not None else getattr(meta, "machine", None)


def unchecked_note(source: str, meta, fitted, advice: str) -> str | None:
    """The one sentence ``detect``, ``monitor`` and ``batch`` say about a recording whose
    metadata do not state what its detectors' healthy recordings did (rig, load), so that it
    could not be checked against them.

    A recording of another rig or load than the healthy ones can look like a leak (an audit
    found a VCA detector judging a plain-CSV healthy EHA run LEAK), so an unchecked one is said,
    once per recording whatever the number of detectors.

    Parameters
    ----------
    source : str
        The recording, as the command names it.
    meta : mapping
        Its metadata (``Recording.meta``, ``ChunkSource.meta``).
    fitted : iterable of (str, str or None, str or None[, unit or None])
        For each detector judging it: what it was fitted on (a detector file, ``the --healthy
        recordings``), the rig and the load of its healthy recordings (None: unknown, not said),
        and optionally the machine unit (:func:`fitted_machine`: a flow balance is identified
        per machine). Two entries that say the same are said once.
    advice : str
        Where this command's user states them: :data:`ADVICE_MAP` or :data:`ADVICE_JOB`.

    Returns
    -------
    str or None
        None when nothing was left unchecked.

    Examples
    --------
    >>> unchecked_note("x.csv", {"system": "vca"}, [("d.joblib", "vca", "none")], ADVICE_JOB)
    ... # doctest: +NORMALIZE_WHITESPACE
    "x.csv states no load in its metadata, so it was not checked against the load 'none' of
    d.joblib (another load can look like a leak: state it as load in the [file] table of the
    job's column map, or in the file's metadata)"
    >>> unchecked_note("x.csv", {}, [("d.joblib", None, None)], ADVICE_MAP) is None
    True
    >>> unchecked_note("x.csv", {"system": "vca", "load": "spring"},
    ...                [("fb.joblib", "vca", "spring", 57)], ADVICE_MAP)[:98]
    'x.csv states no machine unit in its metadata, so it was not checked against the machine unit 57 of'
    """
    # the machine unit since 2026-11-29 (a flow-balance audit: a detector of unit 57 judged
    # healthy CSV exports of unit 31 LEAK at p = 1.9e-4, and the note named only rig and load)
    machine = meta.get("machine")
    stated = {"system": meta.get("system") is not None, "load": meta.get("load") is not None,
              "machine": isinstance(machine, dict) and "unit" in machine}
    props = [(key, what) for key, what in (("system", "rig"), ("load", "load"),
                                           ("machine", "machine unit")) if not stated[key]]
    against, used = [], set()
    for entry in fitted:
        fitted_on, system, load = entry[:3]
        values = {"system": system, "load": load, "machine": entry[3] if len(entry) > 3 else None}
        said = [(key, what, values[key]) for key, what in props if values[key] is not None]
        phrase = " and ".join(f"the {w} {v!r}" if k == "machine" else f"the {w} {str(v)!r}"
                              for k, w, v in said) + f" of {fitted_on}"
        if said and phrase not in against:
            against.append(phrase)
            used.update(key for key, _, _ in said)
    if not against:
        return None
    missing = [(key, what) for key, what in props if key in used]
    whats = [w for _, w in missing]
    return (f"{source} states {' and '.join('no ' + w for w in whats)} in its metadata, so it "
            f"was not checked against {'; '.join(against)} (another {' or '.join(whats)} can "
            f"look like a leak: state {'it' if len(whats) == 1 else 'them'} as "
            f"{' and '.join(k for k, _ in missing)} in the [file] table of {advice}, or in the "
            "file's metadata)")
