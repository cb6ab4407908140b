"""Preferred-setting selection (explicit rule) and the Sec. 4.4 one-factor-at-a-time sweep."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.studies.select import THESIS_CHOICES, SelectionRule, preferred_setting
from leakdiag.studies.sweep import ofat_sweep, parse_values

from .test_grid import ar_recording


def table(pct, signed=None, nb=10, na=10, lag=None, window=200, overlap=5.0):
    n = len(pct)
    return pd.DataFrame({
        "lag": lag if lag is not None else list(range(1, n + 1)), "window": window,
        "overlap": overlap, "pct_change": pct,
        "pct_change_signed": signed if signed is not None else [-p for p in pct],
        "n_chunks_before": nb, "n_chunks_after": na})


def test_maximum_pct_change_wins():
    assert preferred_setting(table([42.5, 43.4, 44.9, 44.6])).lag == 3


def test_too_few_chunks_excluded():
    t = table([40.0, 90.0, 50.0], nb=[10, 2, 10])
    row = preferred_setting(t)
    assert row.lag == 3 and row.n_eligible == 2
    assert preferred_setting(t, SelectionRule(min_chunks_per_side=2)).lag == 2


def test_direction_constraint():
    t = table([40.0, 90.0, 50.0], signed=[-40.0, 90.0, -50.0])
    assert preferred_setting(t).lag == 2
    assert preferred_setting(t, SelectionRule(direction=-1)).lag == 3
    assert preferred_setting(t, SelectionRule(direction=1)).lag == 2


def test_tolerance_ties_go_to_smallest_setting():
    # Table 5-1 shape: all lags within 3 points -> tolerance 3 picks lag 1 like the thesis.
    t = table([42.52, 43.40, 43.59, 44.62, 44.67, 44.93], lag=[1, 2, 4, 8, 12, 18])
    assert preferred_setting(t).lag == 18
    assert preferred_setting(t, SelectionRule(tolerance_pct=3.0)).lag == 1
    assert preferred_setting(t, SelectionRule(tolerance_pct=0.5)).lag == 8


def test_exact_tie_breaks_on_window_then_overlap():
    t = pd.DataFrame({"lag": [1, 1, 1], "window": [200, 100, 100], "overlap": [5.0, 50.0, 25.0],
                      "pct_change": [50.0, 50.0, 50.0], "pct_change_signed": [50.0] * 3,
                      "n_chunks_before": 5, "n_chunks_after": 5})
    row = preferred_setting(t)
    assert (row.window, row.overlap) == (100, 25.0)


def test_no_eligible_row_raises():
    with pytest.raises(ValueError, match="no setting meets the rule"):
        preferred_setting(table([np.nan, 10.0], nb=[10, 1]))
    with pytest.raises(ValueError, match="direction=2"):
        SelectionRule(direction=2)


def test_thesis_choices_cover_every_sweep_table(shared_dir):
    t = pd.read_csv(shared_dir / "thesis" / "tables.csv")
    sweeps = set(t.loc[t.varied != "signal", "table"])
    assert sweeps == set(THESIS_CHOICES)


def test_ofat_holds_chosen_values():
    rec = ar_recording()
    res = ofat_sweep(rec, "autocorrelation", "p1", [1, 2, 5], [60, 100, 200], [0, 25, 50],
                     chunk=5)
    lag_t, win_t, ov_t = res.tables["lag"], res.tables["window"], res.tables["overlap"]
    assert set(lag_t.window) == {60} and set(lag_t.overlap) == {0.0}
    assert res.chosen["lag"] == int(preferred_setting(lag_t).lag)
    assert set(win_t.lag) == {res.chosen["lag"]} and set(win_t.overlap) == {0.0}
    assert res.chosen["window"] == int(preferred_setting(win_t).window)
    assert set(ov_t.window) == {res.chosen["window"]}
    assert res.chosen["overlap"] == float(preferred_setting(ov_t).overlap)
    assert list(res.table().varied) == ["lag"] * 3 + ["window"] * 3 + ["overlap"] * 3


def test_parse_values():
    assert parse_values("1,2,4,8") == [1, 2, 4, 8]
    assert parse_values("100:300:100") == [100, 200, 300]
    assert parse_values("0:90:45", float) == [0.0, 45.0, 90.0]
    with pytest.raises(ValueError, match="step must be > 0"):
        parse_values("1:5:0")
    with pytest.raises(ValueError, match="cannot read 'a,b'"):
        parse_values("a,b")


def test_tolerance_3_picks_lag_1_on_printed_but_lag_4_on_recomputed_table_5_1():
    """docs/studies.md, "Preferred setting" (thesis audit 2026-11-28, F9): the lag-1 pick at
    tolerance 3 holds on the printed column only; the report applies the rule to the
    percentages recomputed from the table's RMS columns, where lag 4 is 83.23 %."""
    from leakdiag.studies.thesis import load_tables

    t = load_tables()
    t51 = t[t.table == "5-1"]
    lags = [int(x) for x in t51.lag]
    assert lags == [1, 2, 4, 8, 12, 18]
    printed = table(t51.pct_change_reported.tolist(), lag=lags)
    recomputed = table(t51.pct_change_recomputed.tolist(), lag=lags)
    assert preferred_setting(printed, SelectionRule(tolerance_pct=3.0)).lag == 1
    assert preferred_setting(recomputed, SelectionRule(tolerance_pct=3.0)).lag == 4
    assert preferred_setting(recomputed).lag == 4  # what preferred.csv's thesis_values_rule has
    # the smallest lag within the tolerance of 83.23 is 4 until lag 2 (43.40) enters at 39.83
    assert preferred_setting(recomputed, SelectionRule(tolerance_pct=39.8)).lag == 4
    assert preferred_setting(recomputed, SelectionRule(tolerance_pct=39.9)).lag == 2
    assert preferred_setting(recomputed, SelectionRule(tolerance_pct=40.8)).lag == 1  # 83.23 - 42.52
