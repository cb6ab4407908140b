"""The friction laws' smooth sign (leakdiag.sim.friction) against NumPy's tanh."""

import numpy as np
import pytest

from leakdiag.sim.friction import smooth_sign


def _grid():
    rng = np.random.default_rng(7)
    scales = (1e-12, 1e-6, 1e-3, 0.1, 1.0, 5.0, 30.0)
    z = np.concatenate([rng.normal(0.0, s, 20_000) for s in scales])
    return np.concatenate([z, [0.0, 18.9, 19.1, 22.0, 700.0, 1e300, 5e-324]])


def test_within_two_roundings_of_tanh_everywhere():
    z = _grid()
    got = np.array([smooth_sign(v) for v in z])
    assert np.max(np.abs(got - np.tanh(z))) <= 2.3e-16


def test_odd_zero_at_zero_and_saturated_like_tanh():
    z = _grid()
    pos = np.array([smooth_sign(v) for v in z])
    neg = np.array([smooth_sign(-v) for v in z])
    assert np.array_equal(neg, -pos)
    assert smooth_sign(0.0) == 0.0
    big = z[np.abs(z) >= 19.1]
    assert np.array_equal([smooth_sign(v) for v in big], np.tanh(big))   # exactly +-1


@pytest.mark.parametrize("z", [1e-9, 0.01, 0.4, 2.0, 9.0])
def test_slope_is_that_of_tanh(z):
    # the friction mode's stiffness, F_c / (v_c m) (docs/models.md), is the slope 1 - tanh^2
    h = 1e-6 * max(z, 1e-3)
    slope = (smooth_sign(z + h) - smooth_sign(z - h)) / (2 * h)
    assert slope == pytest.approx(1.0 - np.tanh(z) ** 2, rel=1e-6, abs=1e-9)
