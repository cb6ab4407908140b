"""The EKF reports the leak's size with the sign of its coefficient: k_l |g(dP)|. A negative
coefficient (model bias) used to be folded into a positive flow by abs(): a healthy run of
virtual machine 5 (k_l < 0 in 99 % of its samples) read a 0.206 L/min leak."""

import numpy as np
import pytest

from leakdiag.literature.detectors import EKFDetector
from leakdiag.literature.ekf import EKFParams, EKFResult, ekf_feature, run_vca_ekf
from leakdiag.sim.leak import LPM_PER_M3S
from leakdiag.sim.vca.model import vca_leak_flow
from leakdiag.sim.vca.params import VCAParams


def test_leak_size_keeps_the_coefficient_sign_hand_computed():
    # four samples: (dP sign, k_l sign) = (+,+), (-,+), (+,-), (-,-); flow Q = k g(dP)
    states = np.zeros((4, 8))
    states[:, 2] = [5e6, 4e6, 5e6, 4e6]
    states[:, 3] = [4e6, 5e6, 4e6, 5e6]
    states[:, 6] = [1e-9, 1e-9, -1e-9, -1e-9]
    q = np.array([0.06, -0.06, -0.06, 0.06])  # L/min, k sgn(dP) sqrt(1 MPa) = 1e-6 m^3/s
    res = EKFResult(np.arange(4.0), states, np.zeros((4, 3)), np.zeros(4), q)
    assert res.leak_size_lpm.tolist() == [0.06, 0.06, -0.06, -0.06]
    assert np.abs(q).tolist() == [0.06] * 4  # what abs() reported


@pytest.fixture(scope="module")
def machine5_healthy():
    from leakdiag.sim.vca.simulate import simulate_vca

    return simulate_vca(duration=20.0, leak_lpm=None, seed=105, machine=5)


def test_biased_coefficient_reads_as_negative_size_not_a_leak(machine5_healthy):
    rec = machine5_healthy
    p = EKFParams(overlap=0)  # Table 2-1 model: machine 5's parameters differ from it
    res = run_vca_ekf(rec, p)
    late = res.time >= 8.0
    assert np.mean(res.leak_coefficient[late] < 0) > 0.95
    # reference: k_l |g(dP)| from the leak law itself, g odd in dP
    prm = VCAParams().to_array("turbulent", "none")
    dp = np.abs(res.states[:, 2] - res.states[:, 3])
    ref = np.array([vca_leak_flow(d, 0.0, k, prm) for d, k in
                    zip(dp, res.leak_coefficient)]) * LPM_PER_M3S
    np.testing.assert_allclose(res.leak_size_lpm, ref, rtol=1e-12, atol=1e-15)
    fs = ekf_feature(rec, p)
    size = fs.values[fs.time >= 8.999]
    np.testing.assert_allclose(size, [ref[i - 999:i + 1].mean() for i in (8999, 9999, 10999,
                                      11999, 12999, 13999, 14999, 15999, 16999, 17999, 18999,
                                      19999)], rtol=1e-9)
    assert size.mean() < -0.15  # abs() made it +0.206 L/min
    assert np.abs(res.leak_flow_lpm[late]).mean() > 0.15


def test_leak_size_lpm_keeps_the_sign(machine5_healthy):
    rec = machine5_healthy
    det = EKFDetector()
    res = run_vca_ekf(rec, det.ekf_params(rec))
    q = res.leak_size_lpm
    expected = q[res.time >= 10.0].mean() - q[res.time < 10.0].mean()
    assert det.leak_size_lpm(rec, 10.0) == pytest.approx(expected, rel=1e-12)
    folded = np.abs(res.leak_flow_lpm)
    assert expected != pytest.approx(folded[res.time >= 10].mean() - folded[res.time < 10].mean(),
                                     rel=0.01)
