"""The thesis's "preferred setting" made explicit: maximum % change under stated constraints.

Sec. 4.4: "The higher the percentage change the better the result." The thesis then often picks
another setting for visual reasons (Sec. 5.3.1: lag 1 "even though it has a percentage change of
42.5% and not the highest"). :func:`preferred_setting` applies a written rule
(:class:`SelectionRule`) to a sweep table; :data:`THESIS_CHOICES` records what the thesis chose
for each sweep table, so that both can be shown side by side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from leakdiag._validation import check_int

__all__ = ["SelectionRule", "NoEligibleSettingError", "preferred_setting", "THESIS_CHOICES",
           "VARIED_COLUMN"]

#: Column of a sweep table holding each varied parameter.
VARIED_COLUMN = {"lag": "lag", "lag_ratio": "lag_ratio", "window": "window", "overlap": "overlap"}

#: Setting the thesis chose after each sweep table (its text, Ch. 5 and 6). Values are written as
#: in the table: lag (int), lag ratio ("l:k"), window (samples), overlap (%).
THESIS_CHOICES: dict[str, object] = {
    "5-1": 1,  # Sec. 5.3.1: lag 1 "even though ... not the highest"
    "5-2": 200,  # Sec. 5.3.2: window 200, "not the highest"
    "5-3": 5.0,  # Sec. 5.3.3: overlap 5 %, the highest
    "5-5": 1,  # Sec. 5.4.1
    "5-6": 100,  # Sec. 5.4.2
    "5-7": 5.0,  # Sec. 5.4.3 (not the highest: "varying the overlap does not affect")
    "5-9": 1,  # Sec. 5.5.1
    "5-10": 100,  # Sec. 5.5.2
    "5-11": 5.0,  # Sec. 5.5.3 (not the highest)
    "5-13": "83:3",  # Sec. 5.6.1
    "5-14": 500,  # Sec. 5.6.2
    "5-15": 5.0,  # Sec. 5.6.3
    "6-1": 1,  # Sec. 6.1.1
    "6-2": 200,  # Sec. 6.1.2 (not the highest)
    "6-3": 10.0,  # Sec. 6.1.3
    "6-5": 16,  # Sec. 6.2.1
    "6-6": 100,  # Sec. 6.2.2
    "6-7": 10.0,  # Sec. 6.2.3
    "6-9": 8,  # Sec. 6.3.1
    "6-10": 100,  # Sec. 6.3.2 (the summary says 200)
    "6-11": 5.0,  # Sec. 6.3.3 (not the highest, for visual reasons)
    "6-13": "43:3",  # Sec. 6.4.1
    "6-14": 400,  # Sec. 6.4.2
    "6-15": 5.0,  # Sec. 6.4.3 (not the highest)
}


@dataclass(frozen=True)
class SelectionRule:
    """How a preferred setting is picked from a sweep table.

    Parameters
    ----------
    min_chunks_per_side : int, default 3
        A setting is eligible only with at least this many whole RMS chunks before *and* after
        the onset (a % change from one or two chunks is noise).
    direction : {0, 1, -1}, default 0
        ``+1`` / ``-1``: only settings whose feature rises / falls after the leak are eligible;
        ``0``: any direction.
    tolerance_pct : float, default 0.0
        Settings within this many percentage points of the best |% change| count as ties;
        ties go to the smallest lag, then the smallest window, then the smallest overlap
        (cheapest to compute, shortest detection delay).

    Examples
    --------
    >>> SelectionRule(tolerance_pct=3.0).tolerance_pct
    3.0
    """

    min_chunks_per_side: int = 3
    direction: int = 0
    tolerance_pct: float = 0.0

    def __post_init__(self) -> None:
        check_int(self.min_chunks_per_side, "min_chunks_per_side", 1)
        if self.direction not in (0, 1, -1):
            raise ValueError(f"direction={self.direction!r} must be 0, 1 or -1")
        tol = float(self.tolerance_pct)
        if not np.isfinite(tol) or tol < 0:
            raise ValueError(f"tolerance_pct={self.tolerance_pct!r} must be a finite number >= 0")
        object.__setattr__(self, "tolerance_pct", tol)


class NoEligibleSettingError(ValueError):
    """No row of a sweep table meets the selection rule.

    Parameters
    ----------
    message : str
        What failed, with the counts.
    tables : dict, optional
        Sweep tables computed before the rule failed, by stage (``"lag"``, ``"window"``,
        ``"overlap"``), the failing stage last (:func:`~leakdiag.studies.sweep.ofat_sweep`).
    stage : str, optional
        The stage whose table had no eligible row.

    Attributes
    ----------
    tables : dict
        As given (empty from :func:`preferred_setting`, which has the table already).
    stage : str or None
        As given.
    """

    def __init__(self, message: str, tables: dict | None = None, stage: str | None = None):
        super().__init__(message)
        self.tables = dict(tables or {})
        self.stage = stage


def _lag_key(df):
    import pandas as pd

    lag = pd.to_numeric(df["lag"], errors="coerce").astype("float64")
    if "lag_ratio" in df:
        ratio = df["lag_ratio"].map(lambda s: float(str(s).split(":")[0]) if isinstance(s, str)
                                    else np.nan)
        lag = lag.fillna(ratio)
    return lag.fillna(0.0).to_numpy()


def preferred_setting(table, rule: SelectionRule = SelectionRule()):
    """Pick the preferred row of a sweep table: the largest |% change| that meets the rule.

    Parameters
    ----------
    table : pandas.DataFrame
        A sweep table (columns ``pct_change``, ``pct_change_signed``, ``n_chunks_before``,
        ``n_chunks_after``, ``lag``, ``window``, ``overlap``; ``lag_ratio`` optional).
    rule : SelectionRule, optional
        Constraints and tie-break.

    Returns
    -------
    pandas.Series
        The chosen row, with an added ``n_eligible`` (rows meeting the rule).

    Raises
    ------
    NoEligibleSettingError
        A ``ValueError``: no row meets the rule (the message gives the counts).

    Notes
    -----
    Objective: maximise ``pct_change = |RMS_l - RMS_nl| / RMS_nl * 100`` (Eq. 5-3), the thesis's
    criterion of Sec. 4.4, over eligible rows. Among rows within ``tolerance_pct`` points of the
    best, the smallest (lag, window, overlap) wins. Lag ratios compare by their ``l``.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"lag": [1, 2, 4], "window": 200, "overlap": 5.0,
    ...                   "pct_change": [42.5, 43.4, 43.6], "pct_change_signed": [-42.5, -43.4, -43.6],
    ...                   "n_chunks_before": 10, "n_chunks_after": 10})
    >>> int(preferred_setting(t).lag), int(preferred_setting(t, SelectionRule(tolerance_pct=3)).lag)
    (4, 1)
    """
    df = table.reset_index(drop=True)
    ok = (np.isfinite(df["pct_change"].to_numpy(dtype=float))
          & (df["n_chunks_before"].to_numpy() >= rule.min_chunks_per_side)
          & (df["n_chunks_after"].to_numpy() >= rule.min_chunks_per_side))
    if rule.direction:
        ok &= np.sign(df["pct_change_signed"].to_numpy(dtype=float)) == rule.direction
    n_ok = int(ok.sum())
    if n_ok == 0:
        raise NoEligibleSettingError(
            f"no setting meets the rule {rule}: {len(df)} row(s), "
            f"{int(np.isfinite(df['pct_change'].to_numpy(dtype=float)).sum())} with a finite % change"
        )
    pct = df["pct_change"].to_numpy(dtype=float)
    best = np.max(pct[ok])
    tied = ok & (pct >= best - rule.tolerance_pct)
    order = np.lexsort((df["overlap"].to_numpy(dtype=float), df["window"].to_numpy(dtype=float),
                        _lag_key(df)))
    pick = next(i for i in order if tied[i])
    row = df.iloc[pick].copy()
    row["n_eligible"] = n_ok
    return row
