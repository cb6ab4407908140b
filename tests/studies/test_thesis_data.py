"""The shipped thesis data and the decisions taken on them (thesis audit 2026-11-28, F2, F3, F4,
F7): rules checked on the data, and the docs' counts checked against the data."""

from pathlib import Path

import numpy as np
import pandas as pd

from leakdiag.studies.thesis import (PRINTED_MISMATCH_POINTS, THESIS_DATA, load_sensitivity,
                                     load_tables, printed_mismatch)

DOCS = Path(__file__).resolve().parents[2] / "docs"
PRINTED = ["mean_rms_before", "mean_rms_after", "pct_change_reported"]
SAME_EXPERIMENT = ["system", "case_study", "method", "signals"]


def _setting_conflicts(t):
    """Groups of rows with identical printed numbers (same experiment and method) but
    different settings: the docs/studies.md rule says there are none."""
    out = []
    for _, g in t.groupby(SAME_EXPERIMENT + PRINTED):
        if len(g.drop_duplicates(["lag", "window", "overlap_pct"])) > 1:
            out.append(sorted(g["table"]))
    return out


def test_rows_with_identical_printed_numbers_share_their_setting(shared_dir):
    shipped = pd.read_csv(THESIS_DATA / "tables.csv", dtype={"table": str, "lag": str})
    assert _setting_conflicts(shipped) == []
    # the shared copy carries Table 5-5 at the text's window 200 while its lag-1 row is Table
    # 5-6's window-100 row (and 5-7's first row): the rule would have caught it (F2)
    shared = pd.read_csv(shared_dir / "thesis" / "tables.csv", dtype={"table": str, "lag": str})
    assert _setting_conflicts(shared) == [["5-5", "5-6", "5-7"]]


def test_table_5_5_is_computed_at_window_100():
    t = load_tables()
    t55 = t[t.table == "5-5"]
    assert t55.window.tolist() == [100] * 4 and t55.lag.tolist() == ["1", "4", "8", "10"]
    assert t55.overlap_pct.tolist() == [5.0] * 4
    assert all("so it is computed at window 100" in n for n in t55.note)
    w100 = t[(t.table == "5-6") & (t.window == 100)].iloc[0]
    w200 = t[(t.table == "5-6") & (t.window == 200)].iloc[0]
    first = t55.iloc[0]
    assert [first[c] for c in PRINTED] == [w100[c] for c in PRINTED] == [0.55308, 0.194, 64.9233]
    assert [first[c] for c in PRINTED] != [w200[c] for c in PRINTED]


def test_shipped_copy_differs_from_the_shared_one_only_where_documented(shared_dir):
    shipped = pd.read_csv(THESIS_DATA / "tables.csv", dtype={"table": str, "lag": str})
    shared = pd.read_csv(shared_dir / "thesis" / "tables.csv", dtype={"table": str, "lag": str})
    assert shipped.shape == shared.shape and list(shipped.columns) == list(shared.columns)
    differ = {}
    for c in shipped.columns:
        a, b = shipped[c].fillna(""), shared[c].fillna("")
        rows = set(shipped.loc[a.astype(str) != b.astype(str), "table"])
        if rows:
            differ[c] = rows
    # docs/studies.md, "Notes added to the shipped copy" and "Table 5-5"
    assert differ == {"note": {"5-5", "5-11", "6-3"}, "window": {"5-5"}}


def test_inconsistent_printed_rows_counted_from_the_data():
    t = load_tables()
    bad = t[printed_mismatch(t.pct_change_reported, t.pct_change_recomputed)]
    # the `consistent` flags of the shipped copy follow the 0.5-point rule
    assert (~t.consistent.astype(bool)).tolist() == \
        printed_mismatch(t.pct_change_reported, t.pct_change_recomputed).tolist()
    assert PRINTED_MISMATCH_POINTS == 0.5
    assert bad.table.tolist() == ["5-1", "5-2", "5-2", "5-7", "5-7", "6-13", "6-14"]
    distinct = bad.drop_duplicates(SAME_EXPERIMENT + ["lag", "window", "overlap_pct"])
    assert (len(bad), len(distinct)) == (7, 6)
    studies = (DOCS / "studies.md").read_text(encoding="utf-8")
    assert (f"because seven rows (six distinct settings" in studies
            and "four printed percentages" not in studies)


def test_vca_direction_count_in_measure_md_is_the_datas():
    t = load_tables()
    v = t[t.system == "VCA"]
    expected = v.method.map({"autocorrelation": -1, "cross_correlation": -1,
                             "ratio_of_metric_lengths": 1})
    agree = v.thesis_sign == expected
    assert sorted(set(v.table), key=lambda s: int(s.split("-")[1]))[-1] == "5-16"
    assert (int(agree.sum()), len(v)) == (64, 65)
    odd = v[~agree].iloc[0]
    assert (odd.table, odd.window) == ("5-2", 600)
    text = " ".join((DOCS / "measure.md").read_text(encoding="utf-8").split())
    assert (f"Tables 5-1 to 5-16), where {int(agree.sum())} of the {len(v)} rows of "
            "`tables.csv` move that way") in text


def test_vca_ux_sensitivity_range_is_table_5_17s(shared_dir):
    s = load_sensitivity()
    ux = s[(s.system == "VCA") & (s.signals == "U,X")].iloc[0]
    assert (ux.sensitivity_min_pct, ux.sensitivity_max_pct, ux.source) == (20, 63, "Table 5-17")
    assert "Sec. 5.8 says 25%-63%" in ux.note
    assert s.note.notna().sum() == 1  # the only range the thesis states twice, differently
    thesis = (shared_dir / "thesis" / "thesis.md").read_text(encoding="utf-8")
    assert "Cross Correlation (Piston displacement and control signal)\t20%-63%" in thesis
    assert "control signal shows a change in the range of 25%-63% (Figure 5-26)" in thesis
    # the shared copy's values are the same; only the note was added
    shared = pd.read_csv(shared_dir / "thesis" / "sensitivity.csv")
    np.testing.assert_array_equal(shared.sensitivity_min_pct, s.sensitivity_min_pct)


def test_rows_at_one_setting_with_different_printed_numbers_are_the_documented_ones():
    """Thesis audit 2026-11-29: groups of rows that state one setting but print different
    numbers are the four docs/studies.md lists, and Table 6-15 is computed at window 400 (its
    5 % row near Table 6-14's window-400 row, far from its window-200 row)."""
    t = load_tables()
    setting = SAME_EXPERIMENT + ["lag", "window", "overlap_pct"]
    groups = sorted(sorted(set(g["table"])) for _, g in t.groupby(setting)
                    if len(g.drop_duplicates(PRINTED)) > 1)
    assert groups == [["5-1", "5-2", "5-3"], ["5-10", "5-9"], ["6-14", "6-15"],
                      ["6-5", "6-6", "6-7"]]
    studies = " ".join((DOCS / "studies.md").read_text(encoding="utf-8").split())
    for rows in ("5-1 and 5-3", "5-9 (lag 1", "6-5 (lag 16", "6-14 (43:3"):
        assert f"| {rows}" in studies
    t615 = t[t.table == "6-15"]
    assert t615.window.tolist() == [400] * 3 and t615.overlap_pct.tolist() == [5.0, 15.0, 25.0]
    w = t[t.table == "6-14"].set_index("window")
    first = t615.iloc[0]
    near = [abs(first[c] / w.loc[400, c] - 1) for c in PRINTED[:2]]
    far = [abs(first[c] / w.loc[200, c] - 1) for c in PRINTED[:2]]
    assert max(near) < 0.013 and min(far) > 0.1
