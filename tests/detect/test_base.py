"""Detector protocol: sklearn conventions, threshold calibration, planted onsets, verdicts."""

import numpy as np
import pytest
from sklearn.base import clone

from leakdiag.detect.base import Alarm, Verdict
from leakdiag.detect.cusum import cusum, cusum_alarm_count

from _detect_helpers import RATE, WINDOW, WindowMeanDetector, synthetic

SIGMA = 1.0 / np.sqrt(WINDOW)  # std of a window mean of unit white noise


@pytest.fixture(scope="module")
def fitted():
    healthy = [synthetic(600.0, seed) for seed in range(6)]
    return WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=1.0, burn_in_s=0.0)).fit(healthy)


def test_clone_and_params_roundtrip():
    det = WindowMeanDetector(window=20, alarm=Alarm(drift=0.7))
    c = clone(det)
    assert c.get_params() == det.get_params()
    assert c is not det and not hasattr(c, "threshold_")
    c.set_params(window=30)
    assert c.window == 30 and det.window == 20


def test_fit_learns_healthy_distribution(fitted):
    # the window mean of unit white noise: mean 0, std 1/sqrt(50)
    assert abs(fitted.mean_) < 4 * SIGMA / np.sqrt(6 * 1200)
    assert fitted.std_ == pytest.approx(SIGMA, rel=0.05)
    assert fitted.n_healthy_ == 6
    assert fitted.healthy_hours_ == pytest.approx(1.0)


def test_predict_before_fit_raises():
    with pytest.raises(ValueError, match="not fitted"):
        WindowMeanDetector().predict(synthetic(10.0, 0))


def test_zero_variance_feature_rejected():
    from leakdiag.io.recording import Recording

    rec = Recording({"p1": np.ones(5000)}, RATE)
    with pytest.raises(ValueError, match="zero variance"):
        WindowMeanDetector(alarm=Alarm(burn_in_s=0.0)).fit([rec])


@pytest.mark.parametrize("bad,match", [({"drift": -1.0}, "drift"), ({"direction": "left"}, "direction"),
                                       ({"onset_method": "magic"}, "onset_method"),
                                       ({"false_alarms_per_hour": 0}, "false_alarms_per_hour")])
def test_alarm_validation(bad, match):
    with pytest.raises(ValueError, match=match):
        Alarm(**bad)


def test_false_alarm_rate_on_held_out_healthy_data(fitted):
    # 1 h of healthy data in 6 runs cannot show the 1/h target directly: the threshold comes
    # from the Gumbel fit to the 6 per-run CUSUM maxima. On 20 h of held-out white noise the
    # achieved rate should be near the target. Tolerance: for 20 expected alarms, [5, 45] is far
    # beyond 3 sigma of Poisson error (6 maxima make the fitted quantile itself uncertain), but
    # still catches an order-of-magnitude miscalibration.
    assert fitted.alarm_threshold_.method == "run-maxima"
    rng = np.random.default_rng(1234)
    n_windows = int(20 * 3600 * RATE / WINDOW)
    z = rng.standard_normal(n_windows) * SIGMA / fitted.std_ + (0 - fitted.mean_) / fitted.std_
    alarms = cusum_alarm_count(z, fitted.threshold_, 0.5, "both")
    assert 5 <= alarms <= 45


def test_planted_step_found_by_all_onset_methods(fitted):
    rec = synthetic(300.0, 99, onset=150.0, step=0.5)  # 0.5 = 3.5 healthy std of the feature
    for method in ("binseg", "pelt", "cusum"):
        det = clone(fitted).set_params(alarm=Alarm(onset_method=method, burn_in_s=0.0))
        det.fit([synthetic(600.0, s) for s in range(6)])
        v = det.predict(rec)
        assert isinstance(v, Verdict) and v.leak
        assert abs(v.onset_s - 150.0) <= 1.5, (method, v.onset_s)  # within 3 windows
        assert 150.0 <= v.alarm_time_s <= 155.0  # the CUSUM needs a few windows after the onset
        assert v.confidence > 0.99
        assert v.shift == pytest.approx(0.5 / fitted.std_, rel=0.2)


def test_healthy_recording_gives_no_leak_and_low_confidence(fitted):
    v = fitted.predict(synthetic(300.0, 77))
    assert not v.leak and v.onset_s is None and v.alarm_time_s is None
    assert v.score_max < v.threshold
    assert 0.0 <= v.confidence < 0.9


def test_score_is_cusum_of_standardised_feature(fitted):
    rec = synthetic(60.0, 5, onset=30.0, step=0.3)
    fs = fitted.score(rec)
    z = fitted.standardize(rec).values
    up, down = cusum(z, 0.5, "both")
    np.testing.assert_allclose(fs.values, np.maximum(up, down))
    # hand check of the standardisation on the first window
    assert z[0] == pytest.approx((rec["p1"][:WINDOW].mean() - fitted.mean_) / fitted.std_)


def test_leak_size_calibration_recovers_linear_truth(fitted):
    det = clone(fitted).fit([synthetic(600.0, s) for s in range(6)])
    cal_runs = [synthetic(200.0, 100 + i, onset=100.0, step=q) for i, q in
                enumerate([0.05, 0.1, 0.2, 0.3, 0.4, 0.5] * 2)]
    det.calibrate(cal_runs, validity={"rig": "synthetic"})
    v = det.predict(synthetic(200.0, 500, onset=100.0, step=0.25))
    assert v.leak and v.leak_lpm == pytest.approx(0.25, abs=0.05)
    lo, hi = v.leak_lpm_interval
    assert lo < 0.25 < hi and v.leak_lpm_in_range
    assert det.calibration_.validity == {"rig": "synthetic"}
