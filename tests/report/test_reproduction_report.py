"""Pieces of the reproduction report that state counts (thesis audit 2026-11-28): the undefined
windows per side (F1), the thesis's inconsistent rows (F3), counted from the data."""

import pandas as pd
import pytest

from leakdiag.report.reproduction import _mismatch_words, _nan_lines, _side_by_side
from leakdiag.studies.reproduce import CONTRACT_COLUMNS
from leakdiag.studies.thesis import load_tables


def _rows(**cols):
    """Two rows of a U-X lag table with every contract column (hand values)."""
    base = {c: [0, 0] for c in CONTRACT_COLUMNS}
    base.update({"table": ["5-9", "5-9"], "system": "VCA", "case_study": 1, "leak_lpm": 0.1,
                 "method": "cross_correlation", "signals": "U,X", "varied": "lag",
                 "lag": ["1", "20"], "window": 200, "overlap_pct": 5.0,
                 "mean_rms_before": [0.6, 0.2], "mean_rms_after": [0.58, 0.3],
                 "pct_change_signed": [-3.3333, 50.0], "thesis_mean_rms_before": [0.5, 0.5],
                 "thesis_mean_rms_after": [0.25, 0.25], "thesis_pct_change": [50.0, 50.0],
                 "direction_agrees": [True, False], "n_windows": 2105,
                 "n_chunks_before": [100, 100], "n_chunks_after": [80, 80],
                 "n_windows_before": [1000, 1000], "n_windows_after": [800, 800],
                 "n_nan_windows_before": [50, 100], "n_nan_windows_after": [200, 400],
                 "n_nan_windows": [251, 500], "n_chunks_empty": [3, 7],
                 "pct_change_signed_nan_as_0": [-20.0, 12.5], "note": ""})
    base.update(cols)
    return pd.DataFrame(base)


def test_nan_windows_per_side_in_the_table_and_the_words():
    g = _rows()
    t = _side_by_side(g)
    assert t["NaN windows before"].tolist() == ["50 of 1000 (5.0 %)", "100 of 1000 (10.0 %)"]
    assert t["NaN windows after"].tolist() == ["200 of 800 (25.0 %)", "400 of 800 (50.0 %)"]
    assert t["chunks of NaN only"].tolist() == [3, 7]
    assert t["sensitivity: % change, NaN as 0"].tolist() == [-20.0, 12.5]
    (line,) = _nan_lines(g)
    assert "in 2 of 2 rows some windows have zero variance" in line
    assert "before the onset 5.0 % to 10.0 %, after it 25.0 % to 50.0 %" in line
    assert "skips them (-3.33 % to +50 %)" in line
    assert "counted as 0 instead, a sensitivity and not the measure, it would read -20 % to " \
           "+12.5 %" in line


def test_a_table_without_nan_windows_has_no_nan_columns_or_words():
    g = _rows(n_nan_windows=[0, 0], n_nan_windows_before=[0, 0], n_nan_windows_after=[0, 0],
              n_chunks_empty=[0, 0])
    assert _nan_lines(g) == []
    assert not any("NaN" in c for c in _side_by_side(g).columns)


def test_inconsistent_thesis_rows_counted_and_named_from_the_data():
    t = load_tables().rename(columns={"pct_change_reported": "thesis_pct_change",
                                      "pct_change_recomputed": "thesis_pct_change_recomputed"})
    words = _mismatch_words(t)
    assert words.startswith("7 rows (6 distinct settings: a row printed in two tables counts "
                            "twice) print a % change more than 0.5 points")
    assert ("5-1 lag 4, 5-2 window 200, 5-2 window 600, 5-7 overlap 50, 5-7 overlap 75, "
            "6-13 lag ratio 43:3, 6-14 window 200") in words
    only_vca = t[t.system == "VCA"]
    assert _mismatch_words(only_vca).startswith("5 rows print")
    fine = t[t.table == "5-3"]
    assert _mismatch_words(fine) == \
        "no row prints a % change that disagrees with its own RMS columns"


@pytest.mark.parametrize("k,n,want", [(1, 3, "33.3 %"), (0, 0, ""), (5, float("nan"), "")])
def test_share(k, n, want):
    from leakdiag.report.reproduction import _share

    assert _share(k, n) == want


def test_case_study_3_undefined_windows_per_load():
    from leakdiag.report.reproduction import _sensitivity_nan_lines

    s = pd.DataFrame({"system": "vca", "method": "cross-correlation", "channels": "u,x",
                      "load": ["none", "none", "spring"], "pct_change": [2.0, 5.0, 1.0],
                      "pct_change_signed_nan_as_0": [-20.0, -30.0, -1.5],
                      "n_nan_windows": [30, 50, 0], "n_windows_before": [100, 100, 100],
                      "n_windows_after": [100, 100, 100], "n_nan_windows_before": [10, 10, 0],
                      "n_nan_windows_after": [20, 40, 0]})
    (line,) = _sensitivity_nan_lines(s)  # the spring run has none: no line for it
    assert line.startswith("Undefined windows, VCA cross-correlation u,x, load 'none' (2 runs): "
                           "10.0 % of the windows before the onset and 30.0 % after it are NaN")
    assert "|% change| 2-5 % as measured, 20-30 % with them counted as 0" in line
    assert _sensitivity_nan_lines(s.drop(columns=["n_nan_windows_after"])) == []


def test_stationarity_states_the_thesiss_verdict_and_counts_our_disagreements():
    """An audit (2026-11-29): the section did not say the thesis found every signal stationary
    (Sec. 4.7.3), nor where ADF/KPSS on ours disagree (the EHA's x was non-stationary)."""
    from leakdiag.report.reproduction import _stationarity_verdict_lines

    def tests(*verdicts):
        return {"tests": pd.DataFrame({"channel": ["p1", "p1", "x", "x"],
                                       "part": ["whole", "before leak"] * 2,
                                       "verdict": list(verdicts)})}

    st = {"vca": tests("stationary", "stationary", "stationary", "inconclusive"),
          "eha": tests("stationary", "stationary", "non-stationary", "non-stationary")}
    thesis, ours = _stationarity_verdict_lines(st)
    assert thesis.startswith("The thesis's verdict (Sec. 4.7.3): the first four moments of "
                             "every signal")
    assert '"the signals produced from the test rig are stationary"' in thesis
    assert ours == ("Ours (ADF and KPSS at 5 %, each signal over the whole run and before the "
                    "leak): 'stationary' in 5 of 8 tests (VCA 3 of 4, EHA 2 of 4), so ours "
                    "disagrees with the thesis in 3: VCA x before leak (inconclusive), EHA x "
                    "whole (non-stationary), EHA x before leak (non-stationary).")
    st = {"vca": tests(*["stationary"] * 4)}
    assert _stationarity_verdict_lines(st)[1].endswith(
        "'stationary' in 4 of 4 tests (VCA 4 of 4): ours agrees with the thesis in every test.")
    assert _stationarity_verdict_lines({}) == []
