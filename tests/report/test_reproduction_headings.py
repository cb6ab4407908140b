"""Table headings of the reproduction report: the settings held fixed, the run, both signals
(an audit, 2026-11-29: Table 5-4's heading said "autocorrelation of P1" over rows of P1 and P2,
and no heading said the window, overlap, lag, run length or load)."""

import dataclasses

import pytest

from leakdiag.report.reproduction import _short_runs, _table_title
from leakdiag.studies.protocol import QUICK, THESIS
from leakdiag.studies.thesis import load_tables


def _titles(cfg):
    t = load_tables()
    return {tab: _table_title(g, cfg) for tab, g in t.groupby("table", sort=False)}


def test_every_heading_names_what_is_held_fixed():
    titles = _titles(THESIS)
    assert len(titles) == 32
    assert titles["5-1"] == ("Table 5-1: VCA case study 1, autocorrelation of P1, lag varied; "
                             "window 200, overlap 5 % held fixed; leak 0.1 L/min, leak at 200 s "
                             "of a 400 s run, load 'none'")
    assert titles["5-14"].startswith("Table 5-14: VCA case study 1, ratio of metric lengths of "
                                     "P1, window varied; lag ratio 83:3, overlap 5 % held fixed")
    assert titles["6-7"].startswith("Table 6-7: EHA case study 1, cross correlation of P1,P2, "
                                    "overlap varied; lag 16, window 100 held fixed; leak 1.2 "
                                    "L/min, leak at 90 s of a 180 s run")


@pytest.mark.parametrize("table, what", [
    ("5-4", "autocorrelation of P1 and of P2 (one row each); lag 1, window 200, overlap 5 %"),
    ("5-16", "ratio of metric lengths of P1 and of P2 (one row each); lag ratio 83:3, window "
             "500, overlap 5 %"),
    ("6-4", "autocorrelation of P1 and of P2 (one row each); lag 1, window 200, overlap 10 %"),
    ("6-16", "ratio of metric lengths of P1 and of P2 (one row each); lag ratio 43:3, window "
             "400, overlap 5 %"),
])
def test_two_signal_tables_name_both_signals(table, what):
    assert f" {what} held fixed; " in _titles(THESIS)[table]


def test_quick_headings_say_the_runs_are_shorter_than_the_thesiss():
    titles = _titles(QUICK)
    assert titles["5-1"].endswith("leak at 30 s of a 60 s run (shorter than the thesis's 400 s: "
                                  "--quick), load 'none'")
    assert "of a 40 s run (shorter than the thesis's 180 s: --quick)" in titles["6-1"]
    assert not any("shorter" in t for t in _titles(THESIS).values())
    assert _short_runs(QUICK, ("vca", "eha")) == ["VCA 60 s against the thesis's 400 s",
                                                  "EHA 40 s against the thesis's 180 s"]
    assert _short_runs(THESIS, ("vca", "eha")) == []
    assert _short_runs(dataclasses.replace(THESIS, eha_duration_s=100.0), ("vca",)) == []
