"""Study figures: what is drawn matches the data given."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from leakdiag.report.study_plots import (  # noqa: E402
    PLOT_MAX_POINTS, plot_pct_vs_parameter, plot_sensitivity, plot_stacked)


def test_pct_vs_parameter_lines():
    fig = plot_pct_vs_parameter([1, 2, 4], [10.0, 20.0, 30.0], [42.5, 43.4, 43.6],
                                xticklabels=["1", "2", "4"])
    lines = fig.axes[0].get_lines()
    assert [ln.get_ydata().tolist() for ln in lines] == [[10.0, 20.0, 30.0], [42.5, 43.4, 43.6]]
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == ["1", "2", "4"]
    plt.close(fig)


def test_stacked_panels_and_decimation():
    t = np.arange(10 * PLOT_MAX_POINTS, dtype=float)
    fig = plot_stacked([(t, np.sin(t)), (t[:100], np.ones(100))], onset=50.0,
                       titles=["a", "b"], rms=[(1.0, 0.5, -50.0), None])
    assert len(fig.axes) == 2
    assert len(fig.axes[0].get_lines()[0].get_xdata()) == PLOT_MAX_POINTS
    assert len(fig.axes[1].get_lines()[0].get_xdata()) == 100
    assert "-50.0%" in fig.axes[0].texts[0].get_text()
    plt.close(fig)


def test_sensitivity_panels_per_method():
    sens = pd.DataFrame({"method": ["autocorrelation"] * 2 + ["metric-length"] * 2,
                         "channels": ["p1"] * 4, "leak_lpm": [0.1, 0.5, 0.1, 0.5],
                         "load": ["spring", "none"] * 2, "pct_change": [1.0, 2.0, 3.0, 4.0],
                         "pct_change_signed": [1.0, -2.0, 3.0, -4.0]})
    fig = plot_sensitivity(sens, "vca")
    visible = [a for a in fig.axes if a.get_visible()]
    assert len(visible) == 2
    assert visible[1].get_title(loc="left") == "VCA metric-length p1"
    plt.close(fig)


def test_feature_series_rms_is_drawn_as_a_magnitude_on_a_signed_feature():
    """A CLI audit (2026-11-28, finding 6): the mean RMS (a magnitude) was drawn at +RMS only,
    above a feature that was negative throughout, reading as its level."""
    from leakdiag.detect.measure import rms_change
    from leakdiag.features.series import FeatureSeries
    from leakdiag.report.figures import plot_feature_series

    t = np.arange(1, 201, dtype=float)
    for sign in (1.0, -1.0):
        vals = sign * np.where(t <= 100, 0.8, 0.4)
        fs = FeatureSeries(time=t, values=vals, name="cross-correlation")
        r = rms_change(fs, 100.5, chunk=10)
        # magnitudes either way
        assert np.allclose((r.mean_rms_before, r.mean_rms_after), (0.8, 0.4))
        fig = plot_feature_series(fs, onset=100.5, rms=r)
        segs = [s for c in fig.axes[0].collections for s in c.get_segments()]
        levels = sorted(float(s[0][1]) for s in segs)
        assert np.allclose(levels, [0.4, 0.8] if sign > 0 else [-0.8, -0.4, 0.4, 0.8])
        labels = fig.axes[0].get_legend_handles_labels()[1]
        assert any(lb.startswith("mean RMS before " + ("+-" if sign < 0 else "") + "0.8")
                   for lb in labels)
        plt.close(fig)
