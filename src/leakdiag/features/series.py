"""The :class:`FeatureSeries`: one value per window, with the window's timestamp and geometry."""

from __future__ import annotations

import numbers
from dataclasses import KW_ONLY, dataclass, field
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from leakdiag.features.windowing import window_first_times

__all__ = ["FeatureSeries", "GEOMETRY_FIELDS"]

#: The typed window-geometry fields of a :class:`FeatureSeries` (never keys of ``settings``).
GEOMETRY_FIELDS = ("window", "overlap", "step", "channels", "sample_rate", "start_time")


def _optional_int(value, name: str, minimum: int) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, float)) or (
            isinstance(value, float) and not value.is_integer()):
        raise TypeError(f"{name}={value!r} must be an integer number of samples")
    if int(value) < minimum:
        raise ValueError(f"{name}={value!r} must be >= {minimum}")
    return int(value)


@dataclass(frozen=True)
class FeatureSeries:
    """A windowed feature as a time series (one value per window, Sec. 4.4).

    Parameters
    ----------
    time : numpy.ndarray
        Timestamp of each window in seconds (or samples when ``sample_rate=1``), shape ``(m,)``.
        Convention: the time of the window's **last** sample, i.e. the moment its value is
        known (see ``docs/features.md``).
    values : numpy.ndarray
        Feature value per window, shape ``(m,)``; NaN where the window is degenerate
        (zero variance).
    name : str, default "feature"
        Feature name: the registry's canonical name for a feature of Ch. 4 (e.g.
        ``"cross-correlation"``), the moment's name for :func:`~leakdiag.features.moments`.
    settings : mapping, optional
        The feature's own settings (``lag``, ``lag_ratio``, ``moment``, ...); stored read-only.
        Window geometry is not a setting: it has the typed fields below.
    window : int, optional
        Window size N in samples. ``None`` declares values that belong to an instant, not to a
        window (their window start is their time).
    overlap : float, optional
        Overlap of consecutive windows in percent.
    step : int, optional
        Samples between consecutive window starts.
    channels : tuple of str, default ()
        Channels the feature was computed on (``(y, x)`` for a cross-correlation).
    sample_rate : float, optional
        Sample rate in Hz; required with ``window``.
    start_time : float, optional
        Time of the signal's first sample in seconds.

    Raises
    ------
    ValueError
        If ``time`` and ``values`` differ in shape, a geometry value is out of range, a window
        comes without a sample rate, or ``settings`` holds a geometry key.
    TypeError
        If ``window``/``step`` are not integers or ``channels`` is not a tuple of names.

    Notes
    -----
    The series is immutable: derived series are new objects
    (:meth:`with_values`, :func:`dataclasses.replace`).

    Examples
    --------
    >>> fs = FeatureSeries(np.array([0.1, 0.2]), np.array([1.0, 0.5]), "demo")
    >>> fs.to_pandas().tolist()
    [1.0, 0.5]
    >>> fs = FeatureSeries(np.array([0.199, 0.389]), np.array([1.0, 0.5]), "demo",
    ...                    window=200, step=190, sample_rate=1000.0)
    >>> fs.window_start.round(3).tolist()
    [0.0, 0.19]
    """

    time: np.ndarray
    values: np.ndarray
    name: str = "feature"
    settings: Mapping[str, Any] = field(default_factory=dict)
    _: KW_ONLY
    window: int | None = None
    overlap: float | None = None
    step: int | None = None
    channels: tuple[str, ...] = ()
    sample_rate: float | None = None
    start_time: float | None = None

    def __post_init__(self) -> None:
        if np.shape(self.time) != np.shape(self.values):
            raise ValueError(
                f"time and values must have the same shape, got {np.shape(self.time)} "
                f"and {np.shape(self.values)}"
            )
        clash = sorted(set(self.settings) & set(GEOMETRY_FIELDS))
        if clash:
            raise ValueError(f"settings must not hold window geometry {clash}: pass them as "
                             f"the fields {', '.join(c + '=' for c in clash)}")
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))
        object.__setattr__(self, "window", _optional_int(self.window, "window", 2))
        object.__setattr__(self, "step", _optional_int(self.step, "step", 1))
        if isinstance(self.channels, str) or not all(isinstance(c, str) for c in self.channels):
            raise TypeError(f"channels={self.channels!r} must be a tuple of channel names")
        object.__setattr__(self, "channels", tuple(self.channels))
        for name in ("overlap", "sample_rate", "start_time"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, float(v))
        if self.sample_rate is not None and not self.sample_rate > 0:
            raise ValueError(f"sample_rate={self.sample_rate!r} must be > 0 (Hz)")
        if self.window is not None and self.sample_rate is None:
            raise ValueError(f"window={self.window} needs sample_rate= (Hz) to place the "
                             f"windows in time")

    @classmethod
    def _trusted(cls, time, values, name: str, settings: Mapping, geometry: dict
                 ) -> "FeatureSeries":
        """A series from parts already checked (the streaming path: one per pushed chunk).

        ``settings`` must be a read-only mapping and ``geometry`` the checked fields of another
        series (:meth:`geometry`); nothing is validated again.
        """
        self = object.__new__(cls)
        self.__dict__.update(time=time, values=values, name=name, settings=settings, **geometry)
        return self

    def __len__(self) -> int:
        return len(self.values)

    @property
    def n_windows(self) -> int:
        """Number of windows (int)."""
        return len(self.values)

    @property
    def window_start(self) -> np.ndarray:
        """Time of each window's first sample in seconds, shape ``(m,)``.

        ``time - (window - 1) / sample_rate`` (Sec. 4.4), on the recording's sample grid when
        the series knows its ``start_time`` (:func:`~leakdiag.features.windowing.\
window_first_times`); equal to ``time`` when the series has no window (instantaneous values).
        """
        if self.window is None:
            return np.array(self.time, dtype=np.float64)
        return window_first_times(self.time, self.window, self.sample_rate, self.start_time)

    @property
    def params(self) -> Mapping[str, Any]:
        """Settings and geometry in one read-only mapping (for tables and labels).

        Returns
        -------
        mapping
            The ``settings`` followed by the geometry fields that are set.
        """
        out = dict(self.settings)
        for name in GEOMETRY_FIELDS:
            v = getattr(self, name)
            if v is not None and v != ():
                out[name] = v
        return MappingProxyType(out)

    def geometry(self) -> dict[str, Any]:
        """The geometry fields as keyword arguments for a derived series.

        Returns
        -------
        dict
            ``window``, ``overlap``, ``step``, ``channels``, ``sample_rate``, ``start_time``.
        """
        return {name: getattr(self, name) for name in GEOMETRY_FIELDS}

    def with_values(self, values, name: str | None = None, settings: Mapping | None = None,
                    time=None) -> "FeatureSeries":
        """A new series with the same windows (geometry) and other values.

        Parameters
        ----------
        values : numpy.ndarray
            New values, shape ``(m,)`` (or the shape of ``time`` when given).
        name : str, optional
            New name (default: this one).
        settings : mapping, optional
            New settings (default: this one's).
        time : numpy.ndarray, optional
            New window times (a subset of windows); default this one's.

        Returns
        -------
        FeatureSeries
        """
        return FeatureSeries(self.time if time is None else time, values,
                             self.name if name is None else name,
                             self.settings if settings is None else settings, **self.geometry())

    def to_pandas(self):
        """Return the series as a :class:`pandas.Series` indexed by time in seconds.

        Returns
        -------
        pandas.Series
            Values indexed by ``time``; the series name is the feature name.
        """
        import pandas as pd

        return pd.Series(self.values, index=pd.Index(self.time, name="time"), name=self.name)
