"""A windowed feature computed incrementally over chunks of any size.

:class:`~leakdiag.features.spec.MethodSpec` says *what* is computed (method, channels,
window, overlap, lag or lag ratio);
:class:`StreamingFeature` keeps the smallest state that lets it compute each window as soon as
its last sample arrives: the samples from the start of the next incomplete window onward, i.e.
fewer than ``window`` samples per channel (the lag lies inside the window in Eq. 4.1-4.3).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from leakdiag._validation import as_1d_float, check_positive
from leakdiag.features._degenerate import check_magnitude
from leakdiag.features.registry import feature_names
from leakdiag.features.series import FeatureSeries
from leakdiag.features.spec import MethodSpec
from leakdiag.features.windowing import window_step

__all__ = ["StreamingFeature", "stream_methods"]


def stream_methods() -> tuple[str, ...]:
    """Features the streaming path computes: the registry's streamable ones.

    Returns
    -------
    tuple of str
        Canonical names (see :func:`leakdiag.features.feature_names`).
    """
    return feature_names(streamable=True)


def _as_column(values, name: str) -> np.ndarray:
    """Fast path for a contiguous 1-D float64 array; :func:`as_1d_float` otherwise."""
    if (type(values) is np.ndarray and values.dtype == np.float64 and values.ndim == 1
            and values.flags.c_contiguous):
        return values
    return as_1d_float(values, name)


class StreamingFeature:
    """Compute a windowed feature chunk by chunk; each window as soon as it completes.

    Parameters
    ----------
    spec : MethodSpec
        Method and settings; a streamable feature (:func:`stream_methods`).
    sample_rate : float, default 1.0
        Sample rate in Hz (1.0 gives times in samples).
    start_time : float, default 0.0
        Time of the first sample in seconds.

    Notes
    -----
    Window ``m`` covers global samples ``[m*step, m*step + N)`` and is stamped with the time of
    its last sample, as in :mod:`leakdiag.features.windowing`; the values are Eq. 4.1-4.3
    computed window by window, so any chunking gives the same values as one batch pass.
    The state is fewer than ``N`` samples per channel. A window whose samples are all equal
    gives NaN and is counted in :attr:`n_degenerate` (no warning per chunk).

    References
    ----------
    Thesis Sec. 4.1-4.4.

    Examples
    --------
    >>> spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=4, overlap=50)
    >>> sf = StreamingFeature(spec, sample_rate=1.0)
    >>> len(sf.push({"p1": [1.0, 2.0, 3.0]}))
    0
    >>> fs = sf.push({"p1": [4.0, 1.0, 2.0]})
    >>> fs.time.tolist(), fs.values.round(6).tolist()
    ([3.0, 5.0], [0.25, -0.15])
    """

    def __init__(self, spec: MethodSpec, sample_rate: float = 1.0, start_time: float = 0.0):
        if not isinstance(spec, MethodSpec):
            raise TypeError(f"spec must be a MethodSpec, got {type(spec).__name__}")
        if not spec.record.streamable:
            raise ValueError(
                f"method={spec.method!r} cannot be streamed; use one of {stream_methods()}")
        self.spec = spec
        self._kernel = spec.record.kernel
        self._setting = spec.value
        self.sample_rate = check_positive(sample_rate, "sample_rate")
        self.start_time = float(start_time)
        self._step = window_step(spec.window, spec.overlap)
        self._n_ch = len(spec.channels)
        self._cap = max(2 * spec.window, 4096)
        self._buf = np.empty((self._n_ch, self._cap))
        self._len = 0
        self.n_samples_seen = 0
        self.n_windows = 0
        self.n_degenerate = 0
        # checked once here; every push builds its series from these without re-checking
        template = FeatureSeries(np.empty(0), np.empty(0), spec.method,
                                 spec.record.setting_entries(spec.value), window=spec.window,
                                 overlap=spec.overlap, step=self._step, channels=spec.channels,
                                 sample_rate=self.sample_rate, start_time=self.start_time)
        self._settings = template.settings
        self._geometry = template.geometry()

    @property
    def state_samples(self) -> int:
        """Samples per channel held between chunks (always ``< window``)."""
        return self._len

    def _coerce(self, chunk) -> list[np.ndarray]:
        names = self.spec.channels
        if type(chunk) is dict or isinstance(chunk, Mapping) or hasattr(chunk, "columns"):
            missing = [c for c in names if c not in chunk]
            if missing:
                raise KeyError(f"chunk has no channel(s) {missing}; has {sorted(chunk)}")
            cols = [_as_column(chunk[c], c) for c in names]
        else:
            arr = np.asarray(chunk, dtype=np.float64)
            if arr.ndim == 1 and self._n_ch == 1:
                cols = [np.ascontiguousarray(arr)]
            elif arr.ndim == 2 and arr.shape[1] == self._n_ch:
                cols = [np.ascontiguousarray(arr[:, i]) for i in range(self._n_ch)]
            else:
                raise ValueError(
                    f"chunk of shape {arr.shape} does not fit channels {names}; pass a dict "
                    f"or an array of shape (samples, {self._n_ch})"
                )
        n = len(cols[0])
        for name, col in zip(names, cols):
            if len(col) != n:
                raise ValueError(
                    f"chunk channels differ in length: {names[0]}={n}, {name}={len(col)}")
            if np.isfinite(np.add.reduce(col)):  # fast path: a finite sum means all are finite
                continue
            bad = np.flatnonzero(~np.isfinite(col))
            if len(bad):
                raise ValueError(
                    f"channel {name!r} is not finite at sample {self.n_samples_seen + int(bad[0])}"
                )
        return cols

    def push(self, chunk) -> FeatureSeries:
        """Add samples; return the windows that completed inside them.

        Parameters
        ----------
        chunk : dict of str to array_like, pandas.DataFrame, or array_like
            New samples per channel (any length, also 0 or 1), or an array of shape
            ``(samples,)`` / ``(samples, channels)`` in the order of ``spec.channels``.

        Returns
        -------
        FeatureSeries
            Time (s) and value of every window completed by this chunk; empty if none.

        Raises
        ------
        KeyError
            If a channel is missing from the dict.
        ValueError
            If channels differ in length or hold NaN/inf (the message names the sample).
        """
        cols = self._coerce(chunk)
        c = len(cols[0])
        n_old = self._len
        total = n_old + c
        if total <= self._cap:
            work = self._buf
            for i, col in enumerate(cols):
                work[i, n_old:total] = col
        else:
            work = np.empty((self._n_ch, total))
            for i, col in enumerate(cols):
                work[i, :n_old] = self._buf[i, :n_old]
                work[i, n_old:] = col
        n_win = 0 if total < self.spec.window else (total - self.spec.window) // self._step + 1
        values = self._compute(work[:, :total], n_win) if n_win else np.empty(0)
        consumed = n_win * self._step
        tail = total - consumed
        self._buf[:, :tail] = work[:, consumed:total]
        self._len = tail
        first = self.n_windows
        self.n_windows += n_win
        self.n_samples_seen += c
        if n_win:
            bad = int(np.count_nonzero(np.isnan(values)))
            if bad or not np.isfinite(values).all():  # degenerate, or out of float64's range
                check_magnitude(values, bad, work[:, :total], self.spec.channels,
                                self.spec.record.sum_power, self.spec.window)
            self.n_degenerate += bad
        starts = (first + np.arange(n_win, dtype=np.float64)) * self._step
        times = self.start_time + (starts + (self.spec.window - 1)) / self.sample_rate
        return FeatureSeries._trusted(times, values, self.spec.method, self._settings,
                                      self._geometry)

    def _compute(self, work: np.ndarray, n_win: int) -> np.ndarray:
        """The feature's registry kernel on the buffer (first sample = a window start)."""
        starts = np.arange(n_win, dtype=np.int64) * self._step
        values, _ = self._kernel(tuple(work), self._setting, self.spec.window, starts)
        return values
