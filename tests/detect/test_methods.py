"""Thesis-method detectors on simulated VCA runs; combined detector; sklearn tooling."""

import numpy as np
import pytest
from sklearn.base import clone

from leakdiag.detect.base import Alarm
from leakdiag.detect.methods import CombinedDetector, FeatureDetector, thesis_detector


@pytest.fixture(scope="module")
def vca_runs():
    from leakdiag.sim import simulate_vca

    healthy = [simulate_vca(duration=30.0, leak_lpm=None, seed=s, reference_seed=100 + s)
               for s in range(3)]
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=10, reference_seed=110)
    return healthy, leak


def test_thesis_detector_settings():
    det = thesis_detector("eha", "cross-correlation", ("p1", "p2"))
    assert (det.lag, det.window, det.overlap) == (16, 100, 10.0)
    assert thesis_detector("vca", "metric-length").lag_ratio == "83:3"
    with pytest.raises(ValueError, match="no thesis setting"):
        thesis_detector("vca", "autocorrelation", ("q",))


def test_feature_detector_flags_large_vca_leak_after_onset(vca_runs):
    healthy, leak = vca_runs
    det = FeatureDetector("cross-correlation", ("p1", "p2"), lag=1, window=100, overlap=5,
                          alarm=Alarm(false_alarms_per_hour=40.0)).fit(healthy)
    v = det.predict(leak)
    assert v.leak and v.alarm_time_s >= 15.0
    assert abs(v.onset_s - 15.0) < 3.0
    # 3 x 25 s of healthy data support 1/4 per run at best (40/h = 0.28 per run, k = 1: the
    # threshold is the largest healthy maximum): no alarm on the runs it was fitted on
    assert all(not det.predict(h).leak for h in healthy)
    c = clone(det)
    assert c.get_params() == det.get_params() and not hasattr(c, "mean_")


def test_moments_is_rejected(vca_runs):
    with pytest.raises(ValueError, match="not moments"):
        FeatureDetector("moments", ("p1",)).fit(vca_runs[0])


def test_combined_detector_fits_healthy_mean_and_covariance(vca_runs):
    healthy, _ = vca_runs
    parts = [FeatureDetector("autocorrelation", ("p1",)), FeatureDetector("metric-length", ("p1",),
                                                                           window=500)]
    det = CombinedDetector(parts, alarm=Alarm(direction="up", false_alarms_per_hour=40.0)
                           ).fit(healthy)
    assert det.feature_cov_.shape == (2, 2)
    np.testing.assert_allclose(det.feature_cov_, det.feature_cov_.T)
    # on its own healthy data the squared distance averages to the number of features
    d2 = np.concatenate([det._feature_series(h).values ** 2 for h in healthy])
    assert np.nanmean(d2) == pytest.approx(2.0, rel=0.35)
    with pytest.raises(ValueError, match="at least one detector"):
        CombinedDetector([]).fit(healthy)
