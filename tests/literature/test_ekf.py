import numpy as np
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.literature.ekf import EKFParams, ekf_feature, run_vca_ekf


@pytest.fixture(scope="module")
def noise_free_leak():
    from leakdiag.sim.vca.simulate import simulate_vca

    return simulate_vca(duration=30.0, leak_lpm=0.5, onset=10.0, seed=3, sensors=False)


def test_leak_coefficient_converges_on_noise_free_run(noise_free_leak):
    rec = noise_free_leak
    res = run_vca_ekf(rec)
    t = res.time
    k_true = rec.meta["leak_coefficient"]
    k_hat = res.leak_coefficient
    assert np.mean(k_hat[t >= 20]) == pytest.approx(k_true, rel=0.02)
    assert np.max(k_hat[(t > 2) & (t < 10)]) < 0.02 * k_true  # no leak before the onset
    # leak size in L/min from the filter equals the simulator's mean |Q_l| after the onset
    q_true = np.abs(rec["leak_flow"][t >= 20]).mean() * 60_000.0
    assert np.abs(res.leak_flow_lpm[t >= 20]).mean() == pytest.approx(q_true, rel=0.03)
    assert res.n_skipped == 0
    # the tracked pressures follow the measurements closely (residuals << 1 bar)
    assert np.sqrt(np.mean(res.innovations[t > 2, 1:] ** 2)) < 1e4


def test_feature_leak_flow_rises_at_onset(noise_free_leak):
    fs = ekf_feature(noise_free_leak, EKFParams(window=1000, overlap=0))
    before = fs.values[(fs.time > 2) & (fs.time < 10)]
    after = fs.values[fs.time > 20]
    t = noise_free_leak.time
    q_true = np.abs(noise_free_leak["leak_flow"][t >= 19]).mean() * 60_000.0
    assert before.max() < 0.01 and after.mean() == pytest.approx(q_true, rel=0.03)
    assert fs.name == "ekf_leak_flow" and fs.params["sample_rate"] == 1000.0


def test_residual_feature_is_normalised():
    n = 2000
    rng = np.random.default_rng(0)
    rec = Recording({"u": np.zeros(n), "x": np.zeros(n),
                     "p1": 8.6e6 + 1e4 * rng.standard_normal(n),
                     "p2": 8.6e6 + 1e4 * rng.standard_normal(n)}, 1000.0)
    fs = ekf_feature(rec, EKFParams(feature="residual", overlap=0))
    # innovations of pure measurement noise matching R on p1, p2 and none on x (x is exactly 0):
    # E[NIS] <= 2 of the 3 components, so sqrt(NIS / 3) sits just below sqrt(2/3) = 0.816
    assert fs.values.shape == (2,)
    assert np.all((fs.values > 0.7) & (fs.values < np.sqrt(2 / 3)))
    # at rest the filter is linear in the measurement noise: twice the noise, twice the residual
    rec2 = Recording({"u": np.zeros(n), "x": np.zeros(n),
                      "p1": 8.6e6 + 2 * (rec["p1"] - 8.6e6), "p2": 8.6e6 + 2 * (rec["p2"] - 8.6e6)},
                     1000.0)
    fs2 = ekf_feature(rec2, EKFParams(feature="residual", overlap=0))
    np.testing.assert_allclose(fs2.values, 2 * fs.values, rtol=0.02)


def test_errors():
    n = 10
    rec = Recording({"u": np.zeros(n), "x": np.zeros(n), "p1": np.zeros(n)}, 1000.0)
    with pytest.raises(RecordingError, match=r"missing channel\(s\) \['p2'\]"):
        run_vca_ekf(rec)
    bad = Recording({"u": np.zeros(n), "x": np.zeros(n), "p1": np.zeros(n),
                     "p2": np.r_[np.zeros(n - 1), np.nan]}, 1000.0)
    with pytest.raises(RecordingError, match=r"^<recording>: channel .p2. has 1 non-finite "
                                             r"value\(s\); first NaN at row 9; the EKF needs "
                                             r"finite samples: fill or cut the gap$"):
        run_vca_ekf(bad)
    with pytest.raises(ValueError, match="feature='x' must be one of"):
        EKFParams(feature="x")
    with pytest.raises(ValueError, match="load='heavy' must be one of"):
        EKFParams(load="heavy")


@pytest.fixture(scope="module")
def noisy_spring_run():
    from leakdiag.sim.sensors import SensorParams
    from leakdiag.sim.vca.simulate import simulate_vca

    return simulate_vca(duration=12.0, leak_lpm=0.0, load="spring", seed=5,
                        sensor_params=SensorParams(pressure_noise_std_pa=40e3))


def test_measurement_noise_matched_on_the_filters_own_model(noisy_spring_run):
    from leakdiag.literature.ekf import match_measurement_noise

    # the nominal actuator is the filter's own model: the matched noise is the sensor's,
    # 40 kPa white noise + 5.05 kPa ADC quantum (uniform: 1.46 kPa) -> 40.03 kPa
    m = match_measurement_noise(noisy_spring_run, EKFParams(load="spring"))
    assert m.pressure_noise_std_pa == pytest.approx(40e3, rel=0.05)
    res = run_vca_ekf(noisy_spring_run, EKFParams(load="spring", pressure_noise_std_pa=None))
    assert res.pressure_noise_std_pa == (m.pressure_noise_std_pa,) * 2
    # with the right R the normalised innovations are about unit size (NIS ~ chi2(3), mean 3)
    assert 2.7 < np.nanmean(res.nis[2000:]) < 3.3


def test_load_force_state_absorbs_an_unmodelled_spring(noisy_spring_run):
    # the filter assumes no load; the 50 kN/m spring force goes to the disturbance state
    res = run_vca_ekf(noisy_spring_run, EKFParams(load="none", pressure_noise_std_pa=None))
    t = res.time
    spring = -50e3 * noisy_spring_run["x"]
    f_d = res.load_force_disturbance_n
    late = t > 3
    assert np.corrcoef(f_d[late], spring[late])[0, 1] > 0.9
    # ... not into the leak coefficient, which is left unclipped and scatters around 0
    k = res.leak_coefficient[late]
    assert k.min() < 0.0  # no projection onto k >= 0 hides a bias
    assert abs(np.mean(k)) < 3.0 * np.sqrt(np.mean(res.leak_coefficient_var[late]))


def test_coefficient_feature_is_standardised(noisy_spring_run):
    fs = ekf_feature(noisy_spring_run, EKFParams(load="spring", pressure_noise_std_pa=None,
                                                 feature="coefficient", overlap=0))
    assert fs.name == "ekf_coefficient" and len(fs.values) == 12
    assert np.all(np.abs(fs.values[3:]) < 5.0)
