"""Each literature method flags a planted leak and leaves a held-out healthy run alone."""

from dataclasses import replace

import numpy as np
import pytest
from sklearn.base import clone

from leakdiag.detect.base import Alarm

from leakdiag.literature.detectors import (EKFDetector, EMDHilbertDetector, FFTBandDetector,
                                        WaveletDetector)

ONSET_S = 30.0  # as in conftest.vca_runs

DETECTORS = [WaveletDetector(), FFTBandDetector(),
             pytest.param(EMDHilbertDetector(), marks=pytest.mark.xfail(
                 strict=True, reason="with 4 healthy runs the honest (conformal, k = 1) threshold "
                 "is the largest healthy CUSUM maximum; the EMD feature crosses it 20 s before "
                 "the onset of the leaking run (the former Gumbel extrapolation set it higher)")),
             EKFDetector()]


@pytest.mark.parametrize("detector", DETECTORS,
                         ids=["WaveletDetector", "FFTBandDetector", "EMDHilbertDetector",
                              "EKFDetector"])
def test_planted_leak_flagged_healthy_not(detector, vca_runs):
    # 4 healthy runs (55 s monitored) support a per-run false-alarm probability of 1/5 at best
    # (conformal: the largest healthy maximum); 14 alarms/h over 55 s = 0.21 per run
    alarm = replace(detector.alarm or Alarm(), false_alarms_per_hour=14.0)
    det = clone(detector).set_params(alarm=alarm).fit(vca_runs["fit"])
    leak = det.predict(vca_runs["leak"])
    healthy = det.predict(vca_runs["healthy"])
    assert leak.leak, f"{type(det).__name__} missed a 1 L/min leak"
    assert leak.alarm_time_s >= ONSET_S and leak.alarm_time_s < ONSET_S + 15.0
    assert abs(leak.onset_s - ONSET_S) < 5.0
    assert not healthy.leak, f"{type(det).__name__} flagged a healthy run"


def test_signal_features_fall_and_ekf_leak_flow_rises(vca_runs):
    """Direction of the change: leakage damps the pressure near the natural frequency
    (thesis Sec. 1.2, items 4-5) so the band features fall; the EKF's leak estimate rises."""
    rec = vca_runs["leak"]
    for det, sign in [(WaveletDetector(), -1), (FFTBandDetector(), -1),
                      (EMDHilbertDetector(), -1), (EKFDetector(), +1)]:
        fs = det._feature_series(rec)
        before = fs.values[(fs.time > 5) & (fs.time < ONSET_S)].mean()
        after = fs.values[fs.time > ONSET_S + 2].mean()
        assert np.sign(after - before) == sign, type(det).__name__


def test_ekf_sizes_the_leak(vca_runs):
    rec = vca_runs["leak"]
    size = EKFDetector().leak_size_lpm(rec, ONSET_S)
    t = rec.time
    true = np.abs(rec["leak_flow"][t >= ONSET_S]).mean() * 60_000.0
    assert size == pytest.approx(true, rel=0.1)


def test_get_params_round_trip():
    det = EMDHilbertDetector(block=4000, sifting_iterations=None)
    assert clone(det).get_params() == det.get_params()
    assert EKFDetector(load="auto").ekf_params().load == "none"
