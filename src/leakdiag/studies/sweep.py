"""One-factor-at-a-time sweeps of thesis Sec. 4.4 and parsing of sweep ranges.

Sec. 4.4: "The analysis starts by varying the lag while the window size and overlap is held
constant. [...] a high performing one is chosen [...]. The next step varies the window size while
the overlap and preferred lag is held constant. [...] finally the preferred window size and
preferred lag is held constant while the overlap is varied." :func:`ofat_sweep` does exactly
that, choosing at each stage with an explicit :class:`~leakdiag.studies.select.SelectionRule`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from leakdiag.features.registry import feature_record
from leakdiag.studies.grid import grid, lag_label, parse_lag
from leakdiag.studies.select import NoEligibleSettingError, SelectionRule, preferred_setting

__all__ = ["parse_values", "one_factor_sweep", "OFATResult", "ofat_sweep", "VARIED"]

#: The parameters a one-factor sweep can vary.
VARIED = ("lag", "window", "overlap")


def parse_values(text: str, kind: type = int) -> list:
    """Parse a sweep range: ``"1,2,4,8"``, ``"100:800:100"`` (start:stop:step, stop included)
    or lag ratios ``"83:3,57:3"``.

    Parameters
    ----------
    text : str
        Comma-separated values or one ``start:stop:step`` range (stop included).
    kind : type, default int
        ``int``, ``float`` or ``str`` (``str`` keeps items such as ``"83:3"`` as they are).

    Returns
    -------
    list

    Raises
    ------
    ValueError
        For an empty list, a zero or negative step, or an unparsable item.

    Examples
    --------
    >>> parse_values("100:800:100")
    [100, 200, 300, 400, 500, 600, 700, 800]
    >>> parse_values("5,25,50", float), parse_values("83:3,57:3", str)
    ([5.0, 25.0, 50.0], ['83:3', '57:3'])
    """
    text = str(text).strip()
    if not text:
        raise ValueError("empty list of values")
    if kind is not str and text.count(":") == 2 and "," not in text:
        a, b, c = (kind(v) for v in text.split(":"))
        if c <= 0:
            raise ValueError(f"range {text!r}: step must be > 0")
        n = int(np.floor((b - a) / c + 1e-9)) + 1
        if n < 1:
            raise ValueError(f"range {text!r} is empty (start > stop)")
        return [kind(a + i * c) for i in range(n)]
    items = [t.strip() for t in text.split(",") if t.strip()]
    try:
        return [kind(t) for t in items]
    except ValueError:
        raise ValueError(f"cannot read {text!r} as a list of {kind.__name__}") from None


def one_factor_sweep(recording, method: str, channels, varied: str, values: Sequence, *,
                     lag=1, window: int = 200, overlap: float = 5.0, onset: float | None = None,
                     chunk: int = 10):
    """Vary one of lag, window, overlap; hold the other two (one table of Sec. 5.3-6.4).

    Parameters
    ----------
    recording : Recording
        The recording.
    method : str
        Method name.
    channels : sequence of str or str
        Channels.
    varied : {"lag", "window", "overlap"}
        The parameter varied (``lag`` means the lag ratio for metric length).
    values : sequence
        Its values.
    lag : int or str, default 1
        Held lag (or lag ratio ``"83:3"``).
    window : int, default 200
        Held window size in samples.
    overlap : float, default 5.0
        Held overlap in percent.
    onset : float, optional
        Leak onset in seconds (default ``recording.onset``).
    chunk : int, default 10
        Chunk length in feature values.

    Returns
    -------
    pandas.DataFrame
        Tidy table, one row per value (in the given order), with a ``varied`` column.

    Raises
    ------
    ValueError
        For an unknown ``varied``.
    """
    if varied not in VARIED:
        raise ValueError(f"varied={varied!r} must be one of {VARIED}")
    lags = list(values) if varied == "lag" else [lag]
    windows = list(values) if varied == "window" else [window]
    overlaps = list(values) if varied == "overlap" else [overlap]
    table = grid(recording, method, channels, lags, windows, overlaps, onset=onset, chunk=chunk)
    table.insert(0, "varied", varied)
    return table


@dataclass(frozen=True)
class OFATResult:
    """Result of :func:`ofat_sweep`.

    Attributes
    ----------
    tables : dict
        ``"lag"``, ``"window"``, ``"overlap"`` -> sweep table of that stage.
    chosen : dict
        Preferred value after each stage (lag as int or ``"l:k"``).
    rule : SelectionRule
        The rule used.
    config : dict
        Every setting of the sweep (method, channels, values, start window/overlap, chunk).
    """

    tables: dict[str, Any]
    chosen: dict[str, Any]
    rule: SelectionRule
    config: dict[str, Any] = field(default_factory=dict)

    def table(self):
        """All stages in one tidy DataFrame (column ``varied`` tells the stage).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        return pd.concat([self.tables[k] for k in VARIED if k in self.tables], ignore_index=True)


def _value(row, varied, method):
    if varied == "lag":
        if feature_record(method).setting == "lag_ratio":
            return row["lag_ratio"]
        return int(row["lag"])
    if varied == "window":
        return int(row["window"])
    return float(row["overlap"])


def ofat_sweep(recording, method: str, channels, lags: Sequence, windows: Sequence[int],
               overlaps: Sequence[float], *, start_window: int | None = None,
               start_overlap: float | None = None, rule: SelectionRule = SelectionRule(),
               onset: float | None = None, chunk: int = 10) -> OFATResult:
    """The Sec. 4.4 procedure: vary lag, keep the best; vary window; vary overlap.

    Parameters
    ----------
    recording : Recording
        The recording.
    method : str
        Method name.
    channels : sequence of str or str
        Channels.
    lags : sequence
        Lags (or lag ratios) of stage 1.
    windows : sequence of int
        Window sizes of stage 2.
    overlaps : sequence of float
        Overlaps of stage 3.
    start_window : int, optional
        Window held in stage 1 (default the first of ``windows``).
    start_overlap : float, optional
        Overlap held in stages 1 and 2 (default the first of ``overlaps``).
    rule : SelectionRule, optional
        How each stage picks its preferred value.
    onset : float, optional
        Leak onset in seconds.
    chunk : int, default 10
        Chunk length in feature values.

    Returns
    -------
    OFATResult

    Raises
    ------
    ValueError
        If a window (or ``start_window``) is longer than the recording: every window is
        computed, none is left out (:func:`~leakdiag.studies.grid.grid` would skip it without
        a row, and a first window held through stage 1 would leave that stage empty).
    NoEligibleSettingError
        A ``ValueError``: a stage has no eligible setting. Its ``tables`` hold the stages run
        so far (the failing one last) and ``stage`` names it: the later stages are not run.
    """
    n = recording.n_samples
    long = [int(w) for w in [*windows, *([] if start_window is None else [start_window])]
            if int(w) > n]
    if long:
        raise ValueError(f"window {long[0]} is longer than the recording ({n} samples): "
                         "ofat_sweep computes every window (the first is held while the lag "
                         "varies) and skips none")
    start_window = int(windows[0] if start_window is None else start_window)
    start_overlap = float(overlaps[0] if start_overlap is None else start_overlap)
    kw = dict(onset=onset, chunk=chunk)
    tables, chosen = {}, {}

    def pick(stage):
        try:
            chosen[stage] = _value(preferred_setting(tables[stage], rule), stage, method)
        except NoEligibleSettingError as exc:  # keep what was computed
            raise NoEligibleSettingError(str(exc), tables, stage) from None

    tables["lag"] = one_factor_sweep(recording, method, channels, "lag", lags,
                                     window=start_window, overlap=start_overlap, **kw)
    pick("lag")
    tables["window"] = one_factor_sweep(recording, method, channels, "window", windows,
                                        lag=chosen["lag"], overlap=start_overlap, **kw)
    pick("window")
    tables["overlap"] = one_factor_sweep(recording, method, channels, "overlap", overlaps,
                                         lag=chosen["lag"], window=chosen["window"], **kw)
    pick("overlap")
    config = {"method": method, "channels": channels if isinstance(channels, str) else
              ",".join(channels or ()), "lags": [lag_label(parse_lag(method, v)) for v in lags],
              "windows": [int(w) for w in windows], "overlaps": [float(o) for o in overlaps],
              "start_window": start_window, "start_overlap": start_overlap, "chunk": chunk,
              "onset": onset if onset is not None else recording.onset}
    return OFATResult(tables, chosen, rule, config)
