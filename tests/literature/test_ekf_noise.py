"""The EKF's pressure noise is matched to its innovations at fit time (robust covariance
matching: the median normalised innovation at its chi-square value), not read off the ADC step: the former median-of-second-differences estimate gave 3057, 9170
and 12226 Pa on virtual machine 3 with 10, 25 and 40 kPa of sensor noise (multiples of
1.4826 * 5050 Pa / sqrt(6)), and the filter's mean NIS was 45-69 instead of about 3."""

import numpy as np
import pytest
from sklearn.base import clone

from leakdiag.detect.base import Alarm
from leakdiag.io.recording import Recording
from leakdiag.literature.ekf import (NOISE_FLOOR_PA, EKFParams, match_measurement_noise,
                                     run_vca_ekf)
from leakdiag.literature.registry import ekf
from leakdiag.sim.sensors import SensorParams


def _run(noise_pa, machine, seed=5, duration=30.0, load="none"):
    from leakdiag.sim.vca.simulate import simulate_vca

    return simulate_vca(duration=duration, leak_lpm=None, seed=seed, machine=machine,
                        load=load, sensor_params=SensorParams(pressure_noise_std_pa=noise_pa))


def test_white_noise_at_rest_is_matched_to_its_std():
    # at rest the pressures are constant: the innovations are the measurement noise alone.
    # The filter assumes 2 kPa of process noise per sample on each pressure, so part of the
    # innovations is its own: the consistent R is a little below the sensor's and approaches
    # it as the noise grows past the process noise
    rng = np.random.default_rng(4)
    n = 20_000
    for sd, rel in ((5e3, 0.89), (20e3, 0.99), (80e3, 0.99)):
        rec = Recording({"u": np.zeros(n), "x": np.zeros(n),
                         "p1": 8.6e6 + sd * rng.standard_normal(n),
                         "p2": 8.6e6 + sd * rng.standard_normal(n)}, 1000.0)
        m = match_measurement_noise(rec)
        assert m.pressure_noise_std_pa / sd == pytest.approx(rel, abs=0.02)
        assert 0.98 <= m.median_ratio <= 1.0  # the bisection stops just on the consistent side
        assert 0.5 * (m.ratio[1] + m.ratio[2]) == pytest.approx(1.0, abs=0.03)  # Gaussian
        assert m.mean_nis == pytest.approx(2.0, abs=0.06)  # x is exactly 0: no NIS term
    # a flat (noise-free) pressure is matched at the floor, not at 0
    flat = Recording({"u": np.zeros(3000), "x": np.zeros(3000), "p1": np.full(3000, 8.6e6),
                      "p2": np.full(3000, 8.6e6)}, 1000.0)
    assert match_measurement_noise(flat).pressure_noise_std_pa == NOISE_FLOOR_PA


def _chain_noise_std(rec, noise_pa):
    """Reference: std of the machine's pressure chain (anti-alias filter, ADC) driven by white
    noise of ``noise_pa`` at a constant pressure (leakdiag.sim.sensor_chain)."""
    from leakdiag.sim.sensor_chain import pressure_chain

    sensors = SensorParams(pressure_noise_std_pa=noise_pa,
                           antialias_cutoff_hz=rec.meta["sensors"]["antialias_cutoff_hz"])
    rng = np.random.default_rng(0)
    n = 100_000
    out = pressure_chain(np.full(n, 8.6e6), noise_pa * rng.standard_normal(n), sensors,
                         sample_rate=rec.sample_rate)
    return float(np.std(out[1000:]))


@pytest.mark.slow
@pytest.mark.parametrize("machine,load", [(None, "none"), (3, "spring"), (3, "none")])
def test_matched_noise_grows_with_the_sensor_noise(machine, load):
    noise = (10e3, 25e3, 40e3)
    runs = [_run(sd, machine, load=load) for sd in noise]
    found = [match_measurement_noise(r, EKFParams(load=load)) for r in runs]
    sig = np.array([m.pressure_noise_std_pa for m in found])
    assert sig[0] < sig[1] < sig[2]  # monotone and continuous: no 3057-Pa quantum steps
    for m in found:  # the bulk of the pressure innovations is consistent by construction
        assert 0.98 <= m.median_ratio <= 1.0
    if machine is None:
        # the filter's own model: the matched value is the sensor noise, the mean NIS 3
        np.testing.assert_allclose(sig, noise, rtol=0.05)
        for m in found:
            assert 2.85 < m.mean_nis < 3.15
    elif load == "spring":
        # the bulk of the innovations is the chain's noise after the anti-alias filter (about
        # 0.72 of the white noise); the transients the model misses lift the mean NIS to 7-33
        chain = np.array([_chain_noise_std(r, sd) for r, sd in zip(runs, noise)])
        np.testing.assert_allclose(sig, chain, rtol=0.1)
        for m in found:
            assert 5.0 < m.mean_nis < 40.0
    else:
        # without load the model misses the bulk too: the machine's error adds to the noise
        # (about 84 kPa at 10 kPa of sensor noise), still growing with it
        assert 60e3 < sig[0] and sig[2] < 1.2 * sig[0]


@pytest.fixture(scope="module")
def fitted_registry_ekf():
    fit = [_run(10e3, machine=m, seed=20 + m, duration=20.0) for m in (1, 2, 3)]
    alarm = Alarm(false_alarms_per_hour=70.0)  # 3 x 15 s support 1/4 per run
    return clone(ekf("vca", alarm)).fit(fit), fit


def test_detector_matches_once_at_fit_and_filters_every_recording_alike(fitted_registry_ekf):
    det, fit = fitted_registry_ekf
    assert det.pressure_noise_std_pa is None
    m = det.noise_match_
    assert det.pressure_noise_std_pa_ == m.pressure_noise_std_pa
    assert m.signal_s == pytest.approx(3 * 19.0)  # all three 20-s runs after the 1-s skip
    assert m == match_measurement_noise(fit, EKFParams(load="none"))
    # any recording judged is filtered with the fitted value, not one of its own
    for noise in (10e3, 40e3):
        rec = _run(noise, machine=4, seed=30)
        p = det.ekf_params(rec)
        assert p.pressure_noise_std_pa == det.pressure_noise_std_pa_
        assert run_vca_ekf(rec, p).pressure_noise_std_pa == (det.pressure_noise_std_pa_,) * 2


def test_the_match_takes_recordings_by_their_samples_not_their_order(monkeypatch):
    """A review (2026-11-27): the first MATCH_MAX_SIGNAL_S seconds in the order given were
    used, so one healthy set gave 75 kPa in one order and 83 kPa reversed. They are now taken
    in the order of their samples' digest: any order of the same set gives the same value."""
    import leakdiag.literature.detectors as detectors

    monkeypatch.setattr(detectors, "MATCH_MAX_SIGNAL_S", 12.0)  # 2 of the 3 recordings
    recs = [_run(10e3, 3, seed=s, duration=8.0) for s in (11, 12, 13)]
    a = ekf("vca", Alarm(false_alarms_per_hour=200.0, burn_in_s=1.0))  # 3 x 7 s: 1/4 per run
    values = {clone(a).fit(order).pressure_noise_std_pa_
              for order in (recs, recs[::-1], recs[1:] + recs[:1])}
    assert len(values) == 1


def test_the_match_filters_only_the_seconds_it_uses():
    """A review (2026-11-27): each pass filtered every recording whole and then kept its first
    seconds (a 600-s recording took 40 CPU s per fit). The filter is causal, so filtering only
    the part used gives the same numbers, bit for bit."""
    from leakdiag.literature.ekf import _innovation_stats

    rec = _run(10e3, 3, duration=20.0)
    p = EKFParams()
    whole = _innovation_stats([rec], p, 10e3, 1.0, 6.0)
    cut = _innovation_stats([rec.slice_time(None, rec.start_time + 7.0)], p, 10e3, 1.0, 6.0)
    assert whole[0] == cut[0] and whole[2] == cut[2] and whole[3] == cut[3] == 6.0
    np.testing.assert_array_equal(whole[1], cut[1])


def test_an_ekf_detector_fitted_before_the_hold_limits_is_refused_clearly(fitted_registry_ekf):
    """A review (2026-11-27): a detector fitted before 2026-11-27 (no max_hold_s_, no matched
    noise) loaded and judged with the old behaviour (a frozen p1 read LEAK, 11-15 filter
    passes per recording); it is refused, saying to fit it again."""
    import copy

    from leakdiag.io.errors import RecordingError

    old = copy.deepcopy(fitted_registry_ekf[0])
    del old.max_hold_s_, old.pressure_noise_std_pa_, old.longest_hold_s_
    with pytest.raises(RecordingError, match=r"^this EKF detector was fitted before the EKF "
                                             r"learned its channels' hold limits .*fit it "
                                             r"again \(leakdiag fit\)$"):
        old.predict(_run(10e3, 3, seed=21, duration=8.0))
