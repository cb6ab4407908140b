"""Fast grids of the Sec. 5.2 measure over (lag, window, overlap) on one recording.

For every lag and window size the feature is evaluated once, at the union of the window starts of
all requested overlaps, with the features' ``*_at`` kernels (cost O(n + starts) per call, flat in
the window size); each overlap then picks its own windows out of that union. The Sec. 5.2 measure
(chunk RMS, mean RMS before/after, % change; :func:`leakdiag.detect.rms_change`) is taken for
every setting. :func:`grid_loop` is the plain per-setting loop (one full feature computation per
setting) that the fast path must equal.
"""

from __future__ import annotations

import contextlib
import itertools
import warnings
from typing import Iterable, Sequence

import numpy as np

from leakdiag._validation import check_int
from leakdiag.detect.measure import TooFewChunksError, chunk_rms, pct_change, rms_change
from leakdiag.features import DegenerateWindowWarning
from leakdiag.features.registry import feature_names, feature_record, values_at
from leakdiag.features.series import FeatureSeries
from leakdiag.features.spec import MethodSpec, compute_feature
from leakdiag.features.windowing import (
    window_first_times,
    window_starts,
    window_step,
    window_times,
)

__all__ = ["MEASURE_COLUMNS", "SETTING_COLUMNS", "parse_lag", "lag_label", "grid", "grid_loop",
           "measure_row", "quiet_degenerate"]

#: Setting columns of every sweep table (one row per setting).
SETTING_COLUMNS = ["method", "channels", "lag", "lag_ratio", "window", "overlap"]
#: Measure columns (thesis: mean RMS before, after, % change) plus counts. Every count means
#: what the field of that name of :class:`leakdiag.detect.RMSChange` means (also in a row
#: without a measure): ``n_nan_windows`` counts the NaN values inside whole chunks, a chunk of
#: NaN values only is ``n_chunks_empty`` (not straddling), trailing values that do not fill a
#: chunk are ``n_windows_dropped``.
MEASURE_COLUMNS = ["mean_rms_before", "mean_rms_after", "pct_change", "pct_change_signed",
                   "n_windows", "n_windows_dropped", "n_chunks_before", "n_chunks_after",
                   "n_chunks_straddling", "n_chunks_empty", "n_nan_windows", "chunk"]


@contextlib.contextmanager
def quiet_degenerate():
    """Silence the features' zero-variance warning inside a sweep.

    A sweep evaluates thousands of settings; each degenerate (zero-variance) window is already
    a NaN value and is counted per setting in the ``n_nan_windows`` column, so the per-call
    warning is redundant there. Other warnings pass through.

    Yields
    ------
    None
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateWindowWarning)
        yield


def parse_lag(method: str, lag) -> int | tuple[int, int]:
    """A lag as the method takes it: an int for correlations, ``(l, k)`` for metric length.

    Parameters
    ----------
    method : str
        Method name (any spelling the feature registry accepts).
    lag : int, str or tuple
        ``1``, ``"4"``, ``"83:3"`` or ``(83, 3)``.

    Returns
    -------
    int or tuple of int

    Raises
    ------
    ValueError
        If the lag does not fit the method.

    Examples
    --------
    >>> parse_lag("ratio_of_metric_lengths", "83:3"), parse_lag("acf", "4")
    ((83, 3), 4)
    """
    rec = feature_record(method)
    if rec.setting is None:
        raise ValueError(f"{rec.name} has no lag to sweep")
    return rec.check_setting(lag)


def lag_label(lag) -> str:
    """The thesis's spelling of a lag: ``"4"`` or ``"83:3"``.

    Parameters
    ----------
    lag : int or tuple of int
        Lag or lag ratio.

    Returns
    -------
    str

    Examples
    --------
    >>> lag_label((83, 3)), lag_label(4)
    ('83:3', '4')
    """
    if isinstance(lag, tuple):
        return f"{lag[0]}:{lag[1]}"
    return str(lag)


def _spec(method, channels, lag, window, overlap):
    if isinstance(lag, tuple):
        return MethodSpec(method, tuple(channels), lag_ratio=lag, window=window, overlap=overlap)
    return MethodSpec(method, tuple(channels), lag=lag, window=window, overlap=overlap)


def measure_row(fs: FeatureSeries, onset: float, chunk: int, method: str, channels, lag,
                window: int, overlap: float) -> dict:
    """One tidy row: the setting and the Sec. 5.2 measure of a feature series.

    Parameters
    ----------
    fs : FeatureSeries
        Feature series at that setting.
    onset : float
        Leak onset in seconds.
    chunk : int
        Chunk length in feature values.
    method : str
        Canonical method name.
    channels : sequence of str
        Channels, ``(y, x)`` for cross-correlation.
    lag : int or tuple of int
        Lag or lag ratio.
    window : int
        Window size in samples.
    overlap : float
        Overlap in percent.

    Returns
    -------
    dict
        Keys :data:`SETTING_COLUMNS` + :data:`MEASURE_COLUMNS`; measure values are NaN when
        there is no whole chunk on one side of the onset (the counts are then those that
        :func:`~leakdiag.detect.rms_change` found, :attr:`TooFewChunksError.partial`).

    Raises
    ------
    ValueError
        If ``chunk < 1`` (checked first: the NaN row is for too few chunks, not a bad chunk).
    """
    check_int(chunk, "chunk", 1)
    row = _setting_row(method, channels, lag, window, overlap)
    try:
        res = rms_change(fs, onset, chunk=chunk)
    except TooFewChunksError as exc:  # no measure: NaN, with the counts that say why
        res = exc.partial
    d = res.as_dict()
    row.update({k: d[k] for k in MEASURE_COLUMNS})
    return row


def _frame(rows):
    import pandas as pd

    df = pd.DataFrame(rows, columns=SETTING_COLUMNS + MEASURE_COLUMNS)
    df["lag"] = df["lag"].astype("Int64")
    return df


def _prepare(recording, method, channels, lags, onset):
    rec = feature_record(method)
    if rec.outputs:
        raise ValueError(f"{rec.name} has {len(rec.outputs)} values per window "
                         f"{rec.outputs}; a grid sweeps single-valued features "
                         f"({', '.join(feature_names(single=True))})")
    chans = rec.check_channels(channels)
    recording.require(*chans)
    lag_values = [parse_lag(rec.name, lag) for lag in lags]
    if onset is None:
        onset = recording.onset
    if onset is None:
        raise ValueError("no leak onset: pass onset= (s) or use a recording with meta['onset']")
    return rec, chans, lag_values, float(onset)


def grid(recording, method: str, channels: Sequence[str] | str | None,
         lags: Iterable, windows: Iterable[int], overlaps: Iterable[float], *,
         onset: float | None = None, chunk: int = 10):
    """Sec. 5.2 measure for every (lag, window, overlap), reusing work across overlaps.

    Parameters
    ----------
    recording : Recording
        The recording (``meta['onset']`` is the default onset).
    method : str
        ``autocorrelation``, ``cross-correlation`` or ``metric-length`` (aliases accepted).
    channels : sequence of str or str, optional
        Channels (``"p1,p2"`` = cross-correlation of p1 as y with p2 as x); default the method's.
    lags : iterable
        Lags (ints) or lag ratios (``"83:3"``) for metric length.
    windows : iterable of int
        Window sizes in samples.
    overlaps : iterable of float
        Overlaps in percent.
    onset : float, optional
        Leak onset in seconds (default ``recording.onset``).
    chunk : int, default 10
        Chunk length of the RMS in feature values (see ``docs/studies.md``).

    Returns
    -------
    pandas.DataFrame
        One row per valid setting (a lag not smaller than its window, and a window longer
        than the recording, are skipped: compare the row count with the settings), columns
        :data:`SETTING_COLUMNS` + :data:`MEASURE_COLUMNS`, ordered lag, window, overlap.

    Raises
    ------
    ValueError
        If there is no onset, a lag does not fit the method, or ``chunk < 1``.
    TypeError
        If ``chunk`` is not an integer.

    Notes
    -----
    Equal to :func:`grid_loop` (the plain loop over settings) up to floating-point rounding;
    the per-setting measure is Eq. 5-1 to 5-3 of the thesis.

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> rng = np.random.default_rng(0)
    >>> e = rng.normal(size=4000)
    >>> x = np.empty(4000); x[0] = 0.0
    >>> for i in range(1, 4000):
    ...     x[i] = (0.9 if i < 2000 else 0.3) * x[i - 1] + e[i]
    >>> rec = Recording({"p1": x}, sample_rate=100.0, meta={"onset": 20.0})
    >>> t = grid(rec, "autocorrelation", "p1", [1], [100], [0, 50])
    >>> bool((t.pct_change_signed < -40).all()), t.n_windows.tolist()
    (True, [40, 79])
    """
    check_int(chunk, "chunk", 1)  # the chunk sides divide by it
    rec, chans, lag_values, onset = _prepare(recording, method, channels, lags, onset)
    m = rec.name
    signals = [recording[c] for c in chans]
    windows = [int(w) for w in windows]
    overlaps = [float(o) for o in overlaps]
    n, rate, t0 = recording.n_samples, recording.sample_rate, recording.start_time
    keyed = []
    for wi, window in enumerate(windows):
        if window > n or not any((lg[0] if isinstance(lg, tuple) else lg) < window
                                 for lg in lag_values):
            continue
        per_ov = {ov: window_starts(n, window, ov) for ov in overlaps}
        # Union of the starts of every overlap, and each start's position in it: computed once
        # per window, shared by all lags.
        mask = np.zeros(n - window + 1, dtype=bool)
        for st in per_ov.values():
            mask[st] = True
        union = np.flatnonzero(mask)
        pos = np.cumsum(mask) - 1
        plans = {}
        for ov, st in per_ov.items():
            t_last = window_times(st, window, rate, t0)
            t_first = window_first_times(t_last, window, rate, t0)
            plans[ov] = (st, pos[st], _chunk_sides(t_last, t_first, onset, chunk))
        for li, lag in enumerate(lag_values):
            top = lag[0] if isinstance(lag, tuple) else lag
            if top >= window:
                continue
            with quiet_degenerate():
                vals = values_at(rec, signals, lag, union, window)
            for oi, ov in enumerate(overlaps):
                st, idx, sides = plans[ov]
                row = _setting_row(m, chans, lag, window, ov)
                row.update(_fast_measure(vals[idx], sides, chunk))
                keyed.append(((li, wi, oi), row))
    keyed.sort(key=lambda kv: kv[0])
    return _frame([row for _, row in keyed])


def _setting_row(method, channels, lag, window, overlap) -> dict:
    return {"method": method, "channels": ",".join(channels),
            "lag": None if isinstance(lag, tuple) else int(lag),
            "lag_ratio": lag_label(lag) if isinstance(lag, tuple) else None,
            "window": int(window), "overlap": float(overlap)}


def _chunk_sides(t_last, t_first, onset, chunk):
    """Per chunk: -1 wholly before the onset, +1 wholly after, 0 straddling (as rms_change)."""
    m = len(t_last)
    k = m // chunk
    before = (t_last < onset)[: k * chunk].reshape(k, chunk).all(axis=1)
    after = (t_first >= onset)[: k * chunk].reshape(k, chunk).all(axis=1)
    return m, k, np.where(before, -1, np.where(after, 1, 0)).astype(np.int8)


def _fast_measure(values, sides, chunk) -> dict:
    """The Sec. 5.2 measure of :func:`leakdiag.detect.rms_change`, vectorised for a grid.

    Every value, counts included, equals that of ``rms_change`` on the same series (and, where
    it raises :class:`TooFewChunksError`, that of its ``partial``): NaN means, same counts.
    """
    m, k, side0 = sides
    rms, n_valid = chunk_rms(values, chunk)
    side = np.where(n_valid > 0, side0, 2)  # 2: NaN values only, "empty" as in rms_change
    nb, na = int((side == -1).sum()), int((side == 1).sum())
    out = {"n_windows": m, "n_windows_dropped": m - k * chunk, "n_chunks_before": nb,
           "n_chunks_after": na, "n_chunks_straddling": int((side == 0).sum()),
           "n_chunks_empty": int((side == 2).sum()),
           "n_nan_windows": int(k * chunk - n_valid.sum()), "chunk": chunk}
    if nb == 0 or na == 0:
        return {"mean_rms_before": np.nan, "mean_rms_after": np.nan, "pct_change": np.nan,
                "pct_change_signed": np.nan, **out}
    before = float(rms[side == -1].mean())
    after = float(rms[side == 1].mean())
    signed = pct_change(before, after)
    return {"mean_rms_before": before, "mean_rms_after": after, "pct_change": abs(signed),
            "pct_change_signed": signed, **out}


def _feature(recording, method, chans, lag, window, overlap) -> FeatureSeries:
    with quiet_degenerate():
        return compute_feature(recording, _spec(method, chans, lag, window, overlap))


def grid_loop(recording, method: str, channels: Sequence[str] | str | None,
              lags: Iterable, windows: Iterable[int], overlaps: Iterable[float], *,
              onset: float | None = None, chunk: int = 10):
    """The plain loop: one full feature computation per setting (reference for :func:`grid`).

    Parameters
    ----------
    recording : Recording
        The recording.
    method : str
        Method name.
    channels : sequence of str or str, optional
        Channels.
    lags, windows, overlaps : iterable
        Settings, as for :func:`grid`.
    onset : float, optional
        Leak onset in seconds.
    chunk : int, default 10
        Chunk length in feature values.

    Returns
    -------
    pandas.DataFrame
        Same rows and columns as :func:`grid`.
    """
    rec, chans, lag_values, onset = _prepare(recording, method, channels, lags, onset)
    m = rec.name
    rows = []
    for lag, window, ov in itertools.product(lag_values, [int(w) for w in windows],
                                             [float(o) for o in overlaps]):
        top = lag[0] if isinstance(lag, tuple) else lag
        if top >= window or window > recording.n_samples:
            continue
        window_step(window, ov)  # validates overlap like the fast path
        fs = _feature(recording, m, chans, lag, window, ov)
        rows.append(measure_row(fs, onset, chunk, m, chans, lag, window, ov))
    return _frame(rows)
