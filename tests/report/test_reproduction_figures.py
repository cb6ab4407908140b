"""Figures and case study 3 of the reproduction report (an audit, 2026-11-29): axis labels and
units, the thesis figure each one reproduces, and the leak's direction per load."""

from types import SimpleNamespace

import matplotlib
import numpy as np
import pandas as pd
import pytest

from leakdiag.report.html import Report
from leakdiag.report.reproduction import (SENSITIVITY_FIGURES, STATIONARITY_FIGURES,
                                          _direction_lines, _sensitivity_section,
                                          thesis_series_figure)
from leakdiag.report.study_plots import plot_moments, plot_sensitivity, plot_stacked
from leakdiag.studies.protocol import QUICK, SENSITIVITY_METHODS
from leakdiag.studies.reproduce import sensitivity_by_load
from leakdiag.studies.thesis import load_tables

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def test_each_table_names_the_thesis_figure_of_its_series():
    """From the captions: Fig. 5-7 is Table 5-1's lag sweep (AC P1, window 200, 5 %), Fig. 5-22
    Table 5-16 (RML P1 and P2, small leak); Ch. 6 puts a sensitivity figure after every four
    tables (6-5, 6-10, 6-15, 6-20)."""
    tables = list(dict.fromkeys(load_tables()["table"]))
    figs = [thesis_series_figure(t) for t in tables]
    assert figs[:16] == [f"5-{k}" for k in range(7, 23)]
    assert figs[16:] == ["6-1", "6-2", "6-3", "6-4", "6-6", "6-7", "6-8", "6-9", "6-11",
                         "6-12", "6-13", "6-14", "6-16", "6-17", "6-18", "6-19"]
    sens = {f for (s, *_), f in SENSITIVITY_FIGURES.items() if s == "eha"}
    assert sens == {"6-5", "6-10", "6-15", "6-20"} and not sens & set(figs)
    assert sorted(f for (s, *_), f in SENSITIVITY_FIGURES.items() if s == "vca") == \
        [f"5-{k}" for k in range(23, 29)]
    assert sorted(STATIONARITY_FIGURES.values()) == [f"4-{k}" for k in range(13, 21)]
    with pytest.raises(ValueError, match="table='5-17' must be a table 5-1..5-16"):
        thesis_series_figure("5-17")


def test_every_sensitivity_method_has_its_thesis_figure():
    for system, methods in SENSITIVITY_METHODS.items():
        for method, chans, *_ in methods:
            assert (system, method, chans) in SENSITIVITY_FIGURES, (system, method, chans)


def test_feature_panels_have_a_y_label():
    t = np.linspace(0, 1, 50)
    fig = plot_stacked([(t, t), (t, -t)], onset=0.5, ylabel="autocorrelation coefficient")
    assert [a.get_ylabel() for a in fig.axes] == ["autocorrelation coefficient"] * 2
    plt.close(fig)


def test_moments_in_kpa_and_kpa_squared():
    df = pd.DataFrame({"time": [0.2, 0.4], "mean": [8.6e6, 8.5e6], "variance": [2.0e8, 3.0e8],
                       "skewness": [0.1, 0.2], "kurtosis": [3.0, 3.1]})
    fig = plot_moments(df, "p1", 0.3, unit="kPa", scale=1e-3)
    assert [a.get_ylabel() for a in fig.axes] == ["mean (kPa)", "variance (kPa²)",
                                                  "skewness (-)", "kurtosis (-)"]
    np.testing.assert_allclose(fig.axes[0].get_lines()[0].get_ydata(), [8600.0, 8500.0])
    np.testing.assert_allclose(fig.axes[1].get_lines()[0].get_ydata(), [200.0, 300.0])
    np.testing.assert_allclose(fig.axes[2].get_lines()[0].get_ydata(), [0.1, 0.2])
    plt.close(fig)


def _eha_cc(k=10):
    """The audit's EHA P1,P2 cross-correlation: every run falls without load, rises with the
    spring (the ranges of the full run)."""
    leak = np.tile([0.77, 0.98, 1.2, 1.4, 1.63], k // 5)
    none = np.linspace(-5.1, -15.2, k)
    spring = np.linspace(1.5, 4.2, k)
    rows = pd.DataFrame({"system": "eha", "method": "cross-correlation", "channels": "p1,p2",
                         "load": ["none"] * k + ["spring"] * k, "duration": 180.0,
                         "leak_lpm": np.r_[leak, leak], "pct_change_signed": np.r_[none, spring],
                         "seed": 1})
    ac = rows.assign(method="autocorrelation", channels="p1",
                     pct_change_signed=-rows["pct_change_signed"].abs())
    out = pd.concat([rows, ac], ignore_index=True)
    return out.assign(pct_change=out["pct_change_signed"].abs())


def test_case_study_3_per_load_and_signed():
    b = sensitivity_by_load(_eha_cc())
    cc = b[b.method == "cross-correlation"]
    assert cc[["load", "n_runs", "n_falling", "n_rising", "min_pct_signed", "max_pct_signed",
               "direction"]].values.tolist() == [["none", 10, 10, 0, -15.2, -5.1, "falls"],
                                                 ["spring", 10, 0, 10, 1.5, 4.2, "rises"]]
    lines = _direction_lines(b)
    assert lines == [
        "EHA cross-correlation p1,p2: the leak's effect on the feature reverses between loads: "
        "load 'none' 10 of 10 runs fall, 0 rise (-15.2 to -5.1 %); load 'spring' 0 of 10 runs "
        "fall, 10 rise (+1.5 to +4.2 %). The pooled |% change| range hides this.",
        "The feature goes the same way under every load in 1 of 2 methods: EHA "
        "autocorrelation p1 (falls)."]


def test_the_report_shows_case_study_3_per_load_signed():
    r = Report("t")
    _sensitivity_section(SimpleNamespace(sensitivity=_eha_cc(), config=QUICK), r,
                         figures=False)
    md = r.to_markdown()
    assert "**Signed % change per method and load: runs falling and rising, range, trend " \
           "with leak size; the thesis's range of |% change|**" in md
    assert "| eha | cross-correlation | p1,p2 | none | 10 | 10 | 0 | -15.2 | -5.1 | falls |" in md
    assert "| eha | cross-correlation | p1,p2 | spring | 10 | 0 | 10 | 1.5 | 4.2 | rises |" in md
    assert "the leak's effect on the feature reverses between loads" in md


def test_sensitivity_figure_plots_the_signed_change_per_load():
    g = _eha_cc()
    g = g[g.method == "cross-correlation"]
    fig = plot_sensitivity(g, "eha", figures={("cross-correlation", "p1,p2"): "6-10"})
    (ax,) = [a for a in fig.axes if a.get_visible()]
    none, spring = ax.collections[:2]
    assert (none.get_offsets()[:, 1] < 0).all() and (spring.get_offsets()[:, 1] > 0).all()
    assert not np.allclose(none.get_facecolor()[0], spring.get_facecolor()[0])
    labels = ax.get_legend_handles_labels()[1]
    assert labels[:2] == ["load none", "load spring"]
    assert ax.get_title(loc="left") == "EHA cross-correlation p1,p2 (cf. thesis Fig. 6-10)"
    assert ax.get_ylabel() == "% change (signed)"
    plt.close(fig)
