"""The thesis's tables (Ch. 5 and 6) as data, and the direction-agreement rules.

The package ships a copy of ``shared/thesis/tables.csv`` and ``sensitivity.csv``
(``studies/thesis_data``). Direction agreement (documented in ``docs/studies.md``):

* **row**: the sign of our ``pct_change_signed`` equals the sign of the thesis's
  ``mean_rms_after - mean_rms_before`` (does the feature rise or fall after the leak?);
* **trend** (sweep tables only): the sign of the Spearman rank correlation between the varied
  parameter (lag; ``l`` of a lag ratio; window; overlap) and ``|% change|`` is the same for our
  values and for the thesis's (recomputed from its own RMS columns). Rank correlations with
  ``|rho| < TREND_FLAT`` count as flat (sign 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["THESIS_DATA", "TREND_FLAT", "SIGNALS", "load_tables", "load_sensitivity",
           "channels_of", "varied_value", "spearman", "trend_sign", "row_sign",
           "PRINTED_MISMATCH_POINTS", "printed_mismatch"]

#: Folder of the shipped thesis tables.
THESIS_DATA = Path(__file__).with_name("thesis_data")

#: |Spearman rho| below which a trend counts as flat (decision, docs/studies.md).
TREND_FLAT = 0.2

#: A printed % change further than this (percentage points) from the one recomputed from its
#: own RMS columns (Eq. 5-3) is inconsistent: the ``consistent`` column of ``tables.csv``
#: (tests/detect/test_measure.py checks the flags against this rule).
PRINTED_MISMATCH_POINTS = 0.5

#: Thesis signal names -> channels (P1 -> p1, ...); "P1,P2" = cross-correlation(y=p1, x=p2).
SIGNALS = {"P1": "p1", "P2": "p2", "U": "u", "X": "x"}


def load_tables(path: str | Path | None = None):
    """The thesis's result tables, one row per table row (``tables.csv``).

    Parameters
    ----------
    path : path-like, optional
        Another copy of ``tables.csv`` (default: the one shipped with leakdiag).

    Returns
    -------
    pandas.DataFrame
        Columns as in the file; ``lag`` stays a string (``"1"`` or ``"83:3"``); an added
        ``thesis_sign`` is ``sign(mean_rms_after - mean_rms_before)`` and ``row_id`` numbers
        the rows in file order.

    Examples
    --------
    >>> t = load_tables()
    >>> len(t), t.loc[0, "table"], int(t.loc[0, "thesis_sign"])
    (110, '5-1', -1)
    """
    import pandas as pd

    p = Path(path) if path is not None else THESIS_DATA / "tables.csv"
    df = pd.read_csv(p, dtype={"table": str, "lag": str, "signals": str, "note": str},
                     keep_default_na=False, na_values={"mean_rms_before": [""]})
    df["note"] = df["note"].fillna("")
    df["thesis_sign"] = np.sign(df["mean_rms_after"] - df["mean_rms_before"]).astype(int)
    df.insert(0, "row_id", np.arange(len(df)))
    return df


def load_sensitivity(path: str | Path | None = None):
    """The thesis's sensitivity ranges (Table 5-17, Sec. 6.1.5-6.4.5).

    Parameters
    ----------
    path : path-like, optional
        Another copy of ``sensitivity.csv``.

    Returns
    -------
    pandas.DataFrame

    Examples
    --------
    >>> load_sensitivity().shape
    (8, 8)
    """
    import pandas as pd

    p = Path(path) if path is not None else THESIS_DATA / "sensitivity.csv"
    return pd.read_csv(p)


def channels_of(signals: str) -> tuple[str, ...]:
    """Channels of a thesis signal spec: ``"P1"`` -> ``("p1",)``, ``"U,X"`` -> ``("u", "x")``.

    Parameters
    ----------
    signals : str
        As in ``tables.csv``.

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        For an unknown signal name.

    Examples
    --------
    >>> channels_of("P1,P2")
    ('p1', 'p2')
    """
    out = []
    for s in str(signals).split(","):
        s = s.strip().upper()
        if s not in SIGNALS:
            raise ValueError(f"unknown thesis signal {s!r} in {signals!r}; known: {list(SIGNALS)}")
        out.append(SIGNALS[s])
    return tuple(out)


def varied_value(varied: str, lag, window, overlap) -> float:
    """The varied parameter of a sweep row as a number (``l`` for a lag ratio ``l:k``).

    Parameters
    ----------
    varied : {"lag", "lag_ratio", "window", "overlap"}
        Varied parameter.
    lag : int or str
        Lag or lag ratio.
    window : int
        Window size.
    overlap : float
        Overlap in percent.

    Returns
    -------
    float
        NaN for ``varied="signal"``.

    Examples
    --------
    >>> varied_value("lag_ratio", "83:3", 500, 5), varied_value("overlap", 1, 100, 25)
    (83.0, 25.0)
    """
    if varied in ("lag", "lag_ratio"):
        return float(str(lag).split(":")[0])
    if varied == "window":
        return float(window)
    if varied == "overlap":
        return float(overlap)
    return float("nan")


def spearman(x, y) -> float:
    """Spearman rank correlation (average ranks for ties); 0 when either input is constant.

    Parameters
    ----------
    x, y : array_like
        Paired values (NaN pairs dropped).

    Returns
    -------
    float
        In ``[-1, 1]``; NaN with fewer than 2 pairs.

    Examples
    --------
    >>> spearman([1, 2, 3], [10, 20, 15]), spearman([1, 2, 3], [3, 2, 1])
    (0.5, -1.0)
    """
    from scipy.stats import rankdata

    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if len(x) < 2:
        return float("nan")
    rx, ry = rankdata(x), rankdata(y)
    if np.ptp(rx) == 0 or np.ptp(ry) == 0:
        return 0.0
    return float(np.corrcoef(rx, ry)[0, 1])


def trend_sign(x, y, flat: float = TREND_FLAT) -> int:
    """Trend of ``y`` along ``x``: +1 rising, -1 falling, 0 flat (``|rho| < flat``) or unknown.

    Parameters
    ----------
    x, y : array_like
        Varied parameter and |% change|.
    flat : float, default TREND_FLAT
        Threshold on |Spearman rho|.

    Returns
    -------
    int

    Examples
    --------
    >>> trend_sign([100, 200, 400], [64.9, 50.0, 27.7])
    -1
    """
    rho = spearman(x, y)
    if not np.isfinite(rho) or abs(rho) < flat:
        return 0
    return int(np.sign(rho))


def row_sign(pct_change_signed) -> np.ndarray:
    """Direction of the feature after the leak: +1 rises, -1 falls, 0 no change or unknown.

    Parameters
    ----------
    pct_change_signed : array_like
        Signed % change (Eq. 5-3).

    Returns
    -------
    numpy.ndarray of int

    Examples
    --------
    >>> row_sign([-42.5, 3.1, float("nan")]).tolist()
    [-1, 1, 0]
    """
    v = np.asarray(pct_change_signed, dtype=float)
    return np.where(np.isfinite(v), np.sign(v), 0).astype(int)


def printed_mismatch(printed, recomputed) -> np.ndarray:
    """Which thesis rows print a % change that disagrees with their own RMS columns.

    Parameters
    ----------
    printed : array_like
        The thesis's printed |% change| (``pct_change_reported``).
    recomputed : array_like
        |% change| recomputed from the same row's mean RMS before and after (Eq. 5-3).

    Returns
    -------
    numpy.ndarray of bool
        ``|printed - recomputed| > PRINTED_MISMATCH_POINTS``.

    Examples
    --------
    >>> printed_mismatch([43.59, 42.52], [83.23, 42.52]).tolist()  # Table 5-1, lags 4 and 1
    [True, False]
    """
    p = np.asarray(printed, dtype=float)
    r = np.asarray(recomputed, dtype=float)
    return np.abs(p - r) > PRINTED_MISMATCH_POINTS
