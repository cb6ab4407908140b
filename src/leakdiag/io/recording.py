"""The :class:`Recording`: a uniformly sampled multichannel time series with units and metadata."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.io.checks import check_same_length, infer_sample_rate, same_rate
from leakdiag.io.errors import RecordingError

__all__ = ["Recording", "STANDARD_CHANNELS", "RecordingError", "load_name", "machine_unit"]

#: Standard channels and their SI units (thesis notation: P1, P2, X, U).
STANDARD_CHANNELS: dict[str, str] = {
    "p1": "Pa",  # chamber 1 pressure
    "p2": "Pa",  # chamber 2 pressure
    "x": "m",  # piston position
    "u": "V",  # control signal
    "x_ref": "m",  # reference position (closed loop)
    "leak_flow": "m^3/s",  # true internal leakage flow (simulations)
    "speed": "rad/s",  # motor/pump shaft speed (pump-driven EHA)
}



def load_name(value) -> str | None:
    """A load as recordings, maps and detectors compare it: stripped and lower-cased (None for
    no load stated).

    Parameters
    ----------
    value : object
        ``meta["load"]`` or a map's / detector file's load.

    Returns
    -------
    str or None

    Examples
    --------
    >>> load_name(" Spring "), load_name(None), load_name("")
    ('spring', None, None)
    """
    if value is None:
        return None
    name = str(value).strip().lower()
    return name or None


def machine_unit(meta) -> int | str | None:
    """The machine unit a recording's metadata name: ``meta["machine"]["unit"]`` as the
    simulators write it (``"nominal"`` for the nominal unit), else None (not said).

    Parameters
    ----------
    meta : mapping
        The recording's metadata.

    Returns
    -------
    int, str or None

    Examples
    --------
    >>> machine_unit({"machine": {"unit": 17}}), machine_unit({"machine": {"unit": None}})
    (17, 'nominal')
    >>> machine_unit({}) is None
    True
    """
    m = meta.get("machine") if meta is not None else None
    if isinstance(m, dict) and "unit" in m:
        return "nominal" if m["unit"] is None else m["unit"]
    return None


@dataclass
class Recording:
    """Uniformly sampled multichannel recording.

    Parameters
    ----------
    channels : dict of str to numpy.ndarray
        Channel name -> samples (1-D float64, all the same length). Standard names are
        ``p1``, ``p2`` (Pa), ``x`` (m), ``u`` (V), ``x_ref`` (m), ``leak_flow`` (m^3/s).
    sample_rate : float
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of the first sample in seconds.
    units : dict of str to str, optional
        Unit per channel; standard channels default to their SI unit.
    meta : dict, optional
        Metadata: ``onset`` (leak onset time in s, if known), ``leak_lpm`` (leak size in L/min),
        ``source`` (file name or simulator), and anything else (parameters, seed, version).

    Raises
    ------
    RecordingError
        If channels differ in length, are not 1-D, or the sample rate is not positive.

    Examples
    --------
    >>> rec = Recording({"p1": np.zeros(4), "p2": np.ones(4)}, sample_rate=2.0)
    >>> rec.time.tolist()
    [0.0, 0.5, 1.0, 1.5]
    >>> rec.duration
    2.0
    """

    channels: dict[str, np.ndarray]
    sample_rate: float
    start_time: float = 0.0
    units: dict[str, str] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        source = self.meta.get("source", "<recording>")
        try:
            self.sample_rate = check_positive(self.sample_rate, "sample_rate")
        except (TypeError, ValueError) as exc:
            raise RecordingError(f"{source}: {exc}") from None
        # (an API audit, 2026-11-29: a NaN start time, complex samples and text were taken or
        # failed with numpy's words)
        try:
            start = float(self.start_time)
        except (TypeError, ValueError):
            start = float("nan")
        if isinstance(self.start_time, bool) or not np.isfinite(start):
            raise RecordingError(f"{source}: start_time={self.start_time!r} must be a finite "
                                 "number of seconds")
        self.start_time = start
        lengths = {}
        chans = {}
        for name, values in self.channels.items():
            raw = np.asarray(values)
            if np.iscomplexobj(raw):
                raise RecordingError(f"{source}: channel {name!r} holds complex values (their "
                                     "imaginary part would be dropped)")
            try:
                arr = np.ascontiguousarray(raw.astype(np.float64, copy=False))
            except (TypeError, ValueError):
                raise RecordingError(f"{source}: channel {name!r} holds values that are not "
                                     f"numbers (dtype {raw.dtype})") from None
            if arr.ndim != 1:
                raise RecordingError(
                    f"{source}: channel {name!r} must be 1-D, got shape {arr.shape}"
                )
            chans[name] = arr
            lengths[name] = len(arr)
        check_same_length(lengths, source)
        self.channels = chans
        units = {k: STANDARD_CHANNELS[k] for k in chans if k in STANDARD_CHANNELS}
        units.update(self.units)
        # a standard channel holds its SI unit (or raw counts): another label was kept and
        # written, while every method read the values as SI (an API audit, 2026-11-29: p1
        # labelled 'bar' went through fit, predict and Parquet as Pa)
        for k, u in units.items():
            if k in chans and k in STANDARD_CHANNELS and u not in (STANDARD_CHANNELS[k],
                                                                   "counts"):
                raise RecordingError(
                    f"{source}: channel {k!r} is labelled {u!r}, but a Recording holds "
                    f"standard channels in SI units ({STANDARD_CHANNELS[k]!r}, or 'counts'): "
                    "convert the values (leakdiag.io.units.to_si, or read the file with a "
                    "column map that states its unit)")
        self.units = units

    # ------------------------------------------------------------------ access
    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.channels[name]
        except KeyError:
            raise KeyError(
                f"{self.meta.get('source', '<recording>')}: no channel {name!r}; "
                f"available: {sorted(self.channels)}"
            ) from None

    def __contains__(self, name: str) -> bool:
        return name in self.channels

    @property
    def channel_names(self) -> list[str]:
        """Channel names in insertion order."""
        return list(self.channels)

    @property
    def n_samples(self) -> int:
        """Number of samples (0 for a recording with no channels)."""
        return len(next(iter(self.channels.values()))) if self.channels else 0

    @property
    def duration(self) -> float:
        """Duration in seconds, ``n_samples / sample_rate``."""
        return self.n_samples / self.sample_rate

    @property
    def time(self) -> np.ndarray:
        """Sample times in seconds, ``start_time + i / sample_rate``."""
        return self.start_time + np.arange(self.n_samples) / self.sample_rate

    @property
    def onset(self) -> float | None:
        """Leak onset time in seconds from ``meta['onset']``, or None if unknown."""
        v = self.meta.get("onset")
        return None if v is None else float(v)

    def require(self, *names: str) -> None:
        """Raise :class:`RecordingError` naming any missing channel.

        Parameters
        ----------
        *names : str
            Channels needed.

        Raises
        ------
        RecordingError
            If one is missing.
        """
        missing = [n for n in names if n not in self.channels]
        if missing:
            raise RecordingError(
                f"{self.meta.get('source', '<recording>')}: missing channel(s) {missing}; "
                f"available: {sorted(self.channels)}"
            )

    def slice_time(self, t0: float | None = None, t1: float | None = None) -> "Recording":
        """Samples with ``t0 <= time < t1`` as a new recording.

        Parameters
        ----------
        t0, t1 : float, optional
            Bounds in seconds.

        Returns
        -------
        Recording
            A copy holding the selected samples.

        Raises
        ------
        ValueError
            If a bound is NaN or infinite.
        """
        for name, t in (("t0", t0), ("t1", t1)):
            if t is not None and not np.isfinite(t):
                raise ValueError(f"{name}={t!r} must be a finite time in s, or None")
        i0 = 0 if t0 is None else max(0, int(np.ceil((t0 - self.start_time) * self.sample_rate - 1e-9)))
        i1 = self.n_samples if t1 is None else max(0, int(np.ceil((t1 - self.start_time) * self.sample_rate - 1e-9)))
        return Recording(
            {k: v[i0:i1].copy() for k, v in self.channels.items()},
            self.sample_rate,
            self.start_time + i0 / self.sample_rate,
            dict(self.units),
            copy.deepcopy(self.meta),
        )

    # ------------------------------------------------------------------ pandas
    def to_pandas(self):
        """Return a :class:`pandas.DataFrame` with a ``time`` column (s) and one column per channel.

        Units and metadata go to ``df.attrs['units']`` and ``df.attrs['meta']``.

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        df = pd.DataFrame({"time": self.time, **self.channels})
        df.attrs["units"] = dict(self.units)
        df.attrs["meta"] = copy.deepcopy(self.meta)
        df.attrs["sample_rate"] = self.sample_rate
        return df

    @classmethod
    def from_pandas(cls, df, sample_rate: float | None = None, time_column: str = "time",
                    units: Mapping[str, str] | None = None, meta: Mapping[str, Any] | None = None,
                    ) -> "Recording":
        """Build a recording from a DataFrame.

        Parameters
        ----------
        df : pandas.DataFrame
            One column per channel, plus optionally a time column in seconds.
        sample_rate : float, optional
            Sample rate in Hz; if None, derived from the time column (which must be uniform).
        time_column : str, default "time"
            Name of the time column.
        units, meta : dict, optional
            Override ``df.attrs['units']`` / ``df.attrs['meta']``.

        Returns
        -------
        Recording

        Raises
        ------
        RecordingError
            If there is neither a sample rate nor a usable time column.
        """
        meta = dict(meta if meta is not None else df.attrs.get("meta", {}))
        source = meta.get("source", "<DataFrame>")
        start = 0.0
        if time_column in df.columns:
            t = np.asarray(df[time_column], dtype=np.float64)
            fs = infer_sample_rate(t, source=source)
            # a given rate is a cross-check of the time column's, as in every reader (an API
            # audit, 2026-11-29: 1000 Hz given for a 500-Hz column halved every time)
            if sample_rate is not None and not same_rate(float(sample_rate), fs):
                raise RecordingError(
                    f"{source}: sample_rate={float(sample_rate):g} Hz was given, but the "
                    f"{time_column!r} column says {fs:g} Hz; leave sample_rate out (the "
                    "column's is used) or fix the column")
            sample_rate = fs
            start = float(t[0]) if len(t) else 0.0
        if sample_rate is None:
            sample_rate = df.attrs.get("sample_rate")
        if sample_rate is None:
            raise RecordingError(f"{source}: no {time_column!r} column and no sample_rate given")
        chans = {c: np.asarray(df[c], dtype=np.float64) for c in df.columns if c != time_column}
        return cls(chans, float(sample_rate), start,
                   dict(units if units is not None else df.attrs.get("units", {})), meta)
