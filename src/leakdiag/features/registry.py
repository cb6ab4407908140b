"""The feature registry: everything the package knows about a windowed feature, in one record.

Every consumer of features reads this registry and nothing else: the method specifications
(:class:`~leakdiag.features.spec.MethodSpec`, validation and defaults), ``compute_feature``
(``leakdiag analyze``, the detectors), the sweep grids (:mod:`leakdiag.studies.grid`, through
the ``*_at`` entry point), the streaming monitor (:mod:`leakdiag.stream.feature`, through the
kernel), the command line's choices and the benchmarks' names. A feature's name is compared
with a string nowhere else.

Adding a feature is one kernel module plus one :func:`register_feature` call (worked example in
``docs/features.md``): a record given only the kernel
``(signals, setting, window, starts) -> (values, n_degenerate)`` gets its batch function and its
evaluate-at-starts function derived from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Literal

import numpy as np

from leakdiag._validation import check_finite, check_int, parse_lag_ratio
from leakdiag.features import _args
from leakdiag.features._degenerate import warn_degenerate
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import window_times

__all__ = [
    "FeatureRecord",
    "register_feature",
    "unregister_feature",
    "feature_record",
    "feature_names",
    "normalize_method",
    "compute",
    "compute_planned",
    "values_at",
]

SettingKind = Literal["lag", "lag_ratio", None]

#: Kernel contract: ``kernel(signals, setting, window, starts) -> (values, n_degenerate)`` with
#: ``signals`` a tuple of C-contiguous float64 arrays (one per channel, equal length, finite),
#: ``setting`` the checked lag / lag ratio (or None), ``starts`` sorted int64 window starts;
#: ``values`` float64 of shape ``(len(starts),)``, or ``(len(outputs), len(starts))``.
Kernel = Callable[[tuple, Any, int, np.ndarray], tuple]


@dataclass(frozen=True)
class FeatureRecord:
    """One windowed feature: name, channels, setting, direction and its three entry points.

    Parameters
    ----------
    name : str
        Canonical name (the command line's spelling, e.g. ``"cross-correlation"``).
    kernel : callable
        ``kernel(signals, setting, window, starts) -> (values, n_degenerate)``, the compute-only
        core (see :data:`Kernel`); the streaming monitor calls it on its buffer.
    channels : tuple of str
        Default channels (``(y, x)`` order for a two-channel feature).
    n_channels : int or None, default 1
        Channels the feature takes; ``None`` for one or more.
    setting : {"lag", "lag_ratio", None}, default None
        The feature's own setting: a lag in samples (Eq. 4.1-4.2), a lag ratio ``l:k``
        (Eq. 4.3), or none.
    default_setting : int or tuple of int, optional
        Value of the setting when none is given (e.g. ``1`` or ``(83, 3)``).
    min_lag : int, default 1
        Smallest lag accepted (``setting="lag"``).
    aliases : tuple of str, default ()
        Other accepted spellings (case-insensitive).
    outputs : tuple of str, default ()
        Names of the values per window when there are several (one series each); empty for
        one value per window.
    direction : {"up", "down", None}, default None
        Expected change of the feature under an internal leak (Ch. 5-6), used by the Sec. 5.2
        direction check; None when the thesis states none.
    equation : str, default ""
        The thesis equation(s), e.g. ``"Eq. 4.1"``.
    degenerate : str, default "zero variance"
        What makes a window degenerate (NaN), for the warning.
    batch : callable, optional
        ``batch(signals, setting, plan, channels)`` returning the :class:`FeatureSeries` (or
        one per output) over the regular windows of Sec. 4.4, from writeable C-contiguous
        float64 signals (whose finiteness it checks), a checked setting and a checked
        :class:`~leakdiag.features._args.WindowPlan`; default derived from ``kernel``.
    at : callable, optional
        ``at(signals, setting, starts, window)`` returning the values at arbitrary starts (any
        order); default derived from ``kernel``.
    streamable : bool, default True
        Whether the streaming monitor may compute it (single-valued features only).
    thesis_name : str, default ""
        The feature's spelling in the thesis's result tables (``studies/thesis_data``), for
        the reproduction's comparisons; empty for a feature the thesis does not have.
    sum_power : int, default 2
        Highest power of a sample in the feature's window sums (2: variances and products; 4:
        the kurtosis; 1: metric lengths): the magnitude a signal may have before they overflow
        float64 (:func:`~leakdiag.features._degenerate.check_magnitude`).

    Raises
    ------
    ValueError
        If the name is empty, the setting kind is unknown, or a multi-valued feature is
        declared streamable.
    """

    name: str
    kernel: Kernel
    channels: tuple[str, ...] = ("p1",)
    n_channels: int | None = 1
    setting: SettingKind = None
    default_setting: Any = None
    min_lag: int = 1
    aliases: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()
    direction: Literal["up", "down", None] = None
    equation: str = ""
    degenerate: str = "zero variance"
    batch: Callable | None = field(default=None, repr=False)
    at: Callable | None = field(default=None, repr=False)
    streamable: bool = True
    thesis_name: str = ""
    sum_power: int = 2

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"name={self.name!r} must be a non-empty string")
        if self.setting not in ("lag", "lag_ratio", None):
            raise ValueError(f"setting={self.setting!r} must be 'lag', 'lag_ratio' or None")
        if self.direction not in ("up", "down", None):
            raise ValueError(f"direction={self.direction!r} must be 'up', 'down' or None")
        if self.outputs and self.streamable:
            raise ValueError(f"{self.name}: a feature with several outputs {self.outputs} "
                             f"cannot be streamable (the monitor takes one value per window)")
        if self.n_channels is not None and len(self.channels) != self.n_channels:
            raise ValueError(f"{self.name}: default channels {self.channels} do not match "
                             f"n_channels={self.n_channels}")
        object.__setattr__(self, "name", self.name.strip().lower())
        object.__setattr__(self, "channels", tuple(self.channels))
        object.__setattr__(self, "aliases", tuple(a.strip().lower() for a in self.aliases))

    def check_setting(self, value, window: int | None = None):
        """The feature's setting, checked (default when ``value`` is None).

        Parameters
        ----------
        value : int, str, tuple or None
            A lag (``1``, ``"4"``), a lag ratio (``"83:3"``, ``(83, 3)``) or None.
        window : int, optional
            Window size in samples; the lag (or ``l``) must be smaller.

        Returns
        -------
        int, tuple of int or None

        Raises
        ------
        ValueError
            If the value does not fit the feature or the window.
        """
        if self.setting is None:
            if value is not None:
                raise ValueError(f"{self.name} takes no lag or lag ratio, got {value!r}")
            return None
        if value is None:
            value = self.default_setting
        if self.setting == "lag_ratio":
            return parse_lag_ratio(value, window)
        if isinstance(value, str) and ":" in value:
            raise ValueError(f"lag={value!r} is a lag ratio; {self.name} takes an integer lag")
        if isinstance(value, str):
            try:
                value = int(value.strip())
            except ValueError:
                raise ValueError(f"lag={value!r} must be an integer for {self.name}") from None
        return check_int(value, "lag", self.min_lag, window)

    def check_channels(self, channels) -> tuple[str, ...]:
        """Channels for this feature (the defaults when empty).

        Parameters
        ----------
        channels : sequence of str or str
            Names, or ``"p1,p2"``.

        Returns
        -------
        tuple of str

        Raises
        ------
        ValueError
            If the number of channels does not fit the feature.
        """
        if isinstance(channels, str):
            channels = tuple(c.strip() for c in channels.split(",") if c.strip())
        chans = tuple(channels) if channels else self.channels
        if self.n_channels is not None and len(chans) != self.n_channels:
            word = {1: "one channel", 2: "two channels (y, x)"}.get(
                self.n_channels, f"{self.n_channels} channels")
            raise ValueError(f"{self.name} takes {word}, got {chans}")
        return chans

    def setting_label(self, setting) -> str:
        """The thesis's spelling of a setting: ``"4"``, ``"83:3"`` or ``""``.

        Parameters
        ----------
        setting : int, tuple of int or None

        Returns
        -------
        str
        """
        if setting is None:
            return ""
        if isinstance(setting, tuple):
            return f"{setting[0]}:{setting[1]}"
        return str(setting)

    def setting_entries(self, setting) -> dict[str, Any]:
        """The setting as ``FeatureSeries.settings`` entries (``lag`` or ``lag_ratio``/l/k).

        Parameters
        ----------
        setting : int, tuple of int or None

        Returns
        -------
        dict
        """
        if self.setting == "lag":
            return {"lag": setting}
        if self.setting == "lag_ratio":
            return {"lag_ratio": self.setting_label(setting), "l": setting[0], "k": setting[1]}
        return {}


_REGISTRY: dict[str, FeatureRecord] = {}
_ALIASES: dict[str, str] = {}


def _spellings(record: FeatureRecord) -> set[str]:
    """The name and aliases, each also with ``-`` and ``_`` swapped."""
    out = set()
    for word in (record.name, *record.aliases):
        out |= {word, word.replace("-", "_"), word.replace("_", "-")}
    return out


def register_feature(record: FeatureRecord, replace: bool = False) -> FeatureRecord:
    """Add a feature to the registry (every command, sweep and monitor then knows it).

    Parameters
    ----------
    record : FeatureRecord
        The feature.
    replace : bool, default False
        Replace a registered feature of the same name.

    Returns
    -------
    FeatureRecord
        The record (so the call can be used as an expression).

    Raises
    ------
    ValueError
        If the name or an alias is already taken by another feature (and not ``replace``).
    TypeError
        If ``record`` is not a :class:`FeatureRecord`.
    """
    if not isinstance(record, FeatureRecord):
        raise TypeError(f"record must be a FeatureRecord, got {type(record).__name__}")
    if replace and record.name in _REGISTRY:
        unregister_feature(record.name)
    taken = {s: _ALIASES[s] for s in _spellings(record) if s in _ALIASES}
    if taken:
        raise ValueError(f"feature {record.name!r}: spelling(s) already registered: {taken}")
    _REGISTRY[record.name] = record
    for s in _spellings(record):
        _ALIASES[s] = record.name
    return record


def unregister_feature(name: str) -> FeatureRecord:
    """Remove a feature from the registry.

    Parameters
    ----------
    name : str
        Any spelling of the feature.

    Returns
    -------
    FeatureRecord
        The removed record.

    Raises
    ------
    ValueError
        If no such feature is registered.
    """
    record = feature_record(name)
    del _REGISTRY[record.name]
    for s in [s for s, n in _ALIASES.items() if n == record.name]:
        del _ALIASES[s]
    return record


def normalize_method(name: str) -> str:
    """Canonical feature name from any accepted spelling.

    Parameters
    ----------
    name : str
        E.g. ``"cross_correlation"``, ``"ratio_of_metric_lengths"``, ``"metric-length"``.

    Returns
    -------
    str
        A registered name (see :func:`feature_names`).

    Raises
    ------
    ValueError
        For an unknown name (lists the known ones).

    Examples
    --------
    >>> normalize_method("ratio_of_metric_lengths")
    'metric-length'
    """
    key = str(name).strip().lower()
    if key not in _ALIASES:
        aliases = sorted(a for r in _REGISTRY.values() for a in r.aliases)
        raise ValueError(f"unknown method {name!r}; known: {sorted(_REGISTRY)}"
                         + (f" (aliases: {', '.join(aliases)})" if aliases else ""))
    return _ALIASES[key]


def feature_record(name: str) -> FeatureRecord:
    """The registry record of a feature.

    Parameters
    ----------
    name : str
        Any accepted spelling.

    Returns
    -------
    FeatureRecord

    Raises
    ------
    ValueError
        For an unknown name.

    Examples
    --------
    >>> feature_record("acf").equation
    'Eq. 4.1'
    """
    return _REGISTRY[normalize_method(name)]


def feature_names(streamable: bool | None = None, single: bool | None = None) -> tuple[str, ...]:
    """Names of the registered features, in registration order.

    Parameters
    ----------
    streamable : bool, optional
        Keep only features the streaming monitor can (True) or cannot (False) compute.
    single : bool, optional
        Keep only single-valued (True) or multi-valued (False) features.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> feature_names(streamable=True)[:3]
    ('autocorrelation', 'cross-correlation', 'metric-length')
    """
    out = []
    for name, rec in _REGISTRY.items():
        if streamable is not None and rec.streamable != streamable:
            continue
        if single is not None and (not rec.outputs) != single:
            continue
        out.append(name)
    return tuple(out)


# ------------------------------------------------------------------ entry points
def _coerce(record: FeatureRecord, signals, finite: bool = True) -> tuple[np.ndarray, ...]:
    arrays = tuple(_args.signal_1d(s, f"{record.name} channel {i}", finite)
                   for i, s in enumerate(signals))
    if record.n_channels is not None and len(arrays) != record.n_channels:
        raise ValueError(f"{record.name} takes {record.n_channels} signal(s), got {len(arrays)}")
    lengths = {len(a) for a in arrays}
    if len(lengths) > 1:
        raise ValueError(f"{record.name}: signals differ in length {sorted(lengths)}")
    return arrays


def _kernel_series(record: FeatureRecord, arrays, setting, plan: _args.WindowPlan, channels):
    """The regular windows of Sec. 4.4 through the kernel (records without a batch function)."""
    for name, arr in zip(channels, arrays):
        check_finite(arr, name)
    starts = np.arange(plan.n_windows, dtype=np.int64) * plan.step
    values, n_bad = record.kernel(arrays, setting, plan.window, starts)
    warn_degenerate(int(n_bad), plan.n_windows, record.degenerate, stacklevel=5)
    time = window_times(starts, plan.window, plan.sample_rate, plan.start_time)
    geometry = plan.geometry(channels)
    values = np.asarray(values, dtype=np.float64)
    if not record.outputs:
        return FeatureSeries(time, values, record.name, record.setting_entries(setting),
                             **geometry)
    return tuple(FeatureSeries(time, values[i], out, {"moment": out}, **geometry)
                 for i, out in enumerate(record.outputs))


def compute(record: FeatureRecord, signals, setting=None, *, window: int, overlap: float,
            sample_rate: float = 1.0, start_time: float = 0.0, channels=()):
    """A feature over the regular windows of Sec. 4.4.

    Parameters
    ----------
    record : FeatureRecord
        The feature.
    signals : sequence of array_like
        One signal per channel, equal lengths.
    setting : int, str, tuple or None
        Lag or lag ratio (the record's default when None).
    window : int
        Window size in samples.
    overlap : float
        Overlap in percent.
    sample_rate : float, default 1.0
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of the first sample in seconds.
    channels : tuple of str, default ()
        Channel names recorded in the result.

    Returns
    -------
    FeatureSeries or tuple of FeatureSeries
        One series, or one per output for a multi-valued feature (e.g. moments).

    Raises
    ------
    ValueError
        For a setting that does not fit, a signal shorter than one window, NaN/inf.
    """
    arrays = _coerce(record, signals, finite=False)
    window = _args.check_window(window)
    setting = record.check_setting(setting, window)
    plan = _args.plan_windows(len(arrays[0]), window, overlap, sample_rate, start_time)
    return compute_planned(record, arrays, setting, plan, channels)


def compute_planned(record: FeatureRecord, arrays: tuple, setting, plan: _args.WindowPlan,
                    channels=()):
    """A feature over a checked window plan: the path behind every batch computation.

    Parameters
    ----------
    record : FeatureRecord
        The feature.
    arrays : tuple of numpy.ndarray
        Writeable C-contiguous float64 signals, one per channel, of ``plan``'s length
        (finiteness is checked here, with the kernels' help).
    setting : int, tuple or None
        The checked setting (:meth:`FeatureRecord.check_setting`).
    plan : WindowPlan
        The checked regular windows (:func:`leakdiag.features._args.plan_windows`).
    channels : tuple of str, default ()
        Channel names recorded in the result (default: positional names).

    Returns
    -------
    FeatureSeries or tuple of FeatureSeries
        As :func:`compute`.
    """
    chans = tuple(channels) or tuple(f"x[{i}]" for i in range(len(arrays)))
    if record.batch is None:
        return _kernel_series(record, arrays, setting, plan, chans)
    return record.batch(arrays, setting, plan, chans)


def values_at(record: FeatureRecord, signals, setting, starts, window: int) -> np.ndarray:
    """A feature's values at arbitrary window starts (any order, repeats allowed), O(n + m).

    Parameters
    ----------
    record : FeatureRecord
        The feature.
    signals : sequence of array_like
        One signal per channel.
    setting : int, str, tuple or None
        Lag or lag ratio.
    starts : array_like of int
        First sample of each window.
    window : int
        Window size in samples.

    Returns
    -------
    numpy.ndarray
        ``(len(starts),)``, or ``(len(outputs), len(starts))`` for a multi-valued feature.

    Raises
    ------
    ValueError
        As :func:`compute`, and for a start out of range.
    """
    if record.at is not None:
        return record.at(tuple(signals), setting, starts, window)
    arrays = _coerce(record, signals)
    window = _args.check_window(window)
    setting = record.check_setting(setting, window)
    starts = _args.check_starts(starts, len(arrays[0]), window)
    sorted_starts, order = _args.sort_starts(starts)
    values, n_bad = record.kernel(arrays, setting, window, sorted_starts)
    warn_degenerate(int(n_bad), len(starts), record.degenerate, stacklevel=3)
    return _args.unsort(np.asarray(values, dtype=np.float64), order)

