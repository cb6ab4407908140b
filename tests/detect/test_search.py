"""CUSUM, change points, threshold calibration and leak-size calibration against references."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.detect.cusum import cusum, cusum_alarm_count
from leakdiag.detect.leaksize import fit_leak_calibration
from leakdiag.detect.onset import best_split_gain, change_points, cusum_onset


def _cusum_ref(z, k, h=np.inf):
    sp = sn = 0.0
    up, dn, count = [], [], 0
    for v in z:
        if not np.isnan(v):
            sp, sn = max(0.0, sp + v - k), max(0.0, sn - v - k)
        up.append(sp)
        dn.append(sn)
        if sp >= h or sn >= h:
            count, sp, sn = count + 1, 0.0, 0.0
    return np.array(up), np.array(dn), count


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-5, 5) | st.just(float("nan")), min_size=1, max_size=60),
       st.floats(0, 2), st.floats(0.5, 8))
def test_cusum_equals_plain_reference(z, k, h):
    up, dn = cusum(z, k)
    ru, rd, rc = _cusum_ref(z, k)
    np.testing.assert_allclose(up, ru)
    np.testing.assert_allclose(dn, rd)
    assert cusum_alarm_count(z, h, k) == _cusum_ref(z, k, h)[2]


def test_cusum_direction_and_strided_input():
    z = np.array([0.0, 9.0, 3.0, 9.0, -3.0, 9.0])[::2]  # strided view [0, 3, -3]
    up, dn = cusum(z, 0.5, "up")
    assert up.tolist() == [0.0, 2.5, 0.0] and dn.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="direction='left'"):
        cusum(z, 0.5, "left")
    with pytest.raises(ValueError, match="drift=-1.0"):
        cusum(z, -1.0)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-10, 10), min_size=10, max_size=40))
def test_best_split_gain_equals_brute_force(z):
    z = np.array(z)
    cost = lambda s: float(((s - s.mean()) ** 2).sum())  # noqa: E731
    ref = max(cost(z) - cost(z[:t]) - cost(z[t:]) for t in range(5, len(z) - 4))
    assert best_split_gain(z, 5) == pytest.approx(ref, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("method", ["pelt", "binseg"])
def test_change_points_planted_step(method):
    rng = np.random.default_rng(3)
    z = rng.standard_normal(300)
    z[180:] += 1.5
    healthy_pen = max(best_split_gain(rng.standard_normal(300)) for _ in range(20))
    cps = change_points(z, healthy_pen, method)
    assert len(cps) == 1 and abs(cps[0] - 180) <= 5
    assert change_points(rng.standard_normal(300), 3 * healthy_pen, method) == []


def test_cusum_onset_and_penalty_validation():
    assert cusum_onset([1.0, 2.0, 3.0], 2) == 0
    with pytest.raises(ValueError, match="penalty"):
        change_points(np.zeros(20), 0.0)


def test_leak_calibration_interval_covers_truth():
    rng = np.random.default_rng(11)
    q = np.repeat([0.1, 0.2, 0.3, 0.4], 10)
    shift = 2.0 + 10.0 * q + rng.normal(0, 0.2, q.size)
    cal = fit_leak_calibration(shift, q)
    assert cal.slope_lpm == pytest.approx(0.1, rel=0.1)
    hits = 0
    for _ in range(200):
        qt = rng.uniform(0.1, 0.4)
        est, (lo, hi), inside = cal.estimate(2.0 + 10.0 * qt + rng.normal(0, 0.2))
        hits += lo <= qt <= hi
    assert 0.8 <= hits / 200 <= 0.98  # nominal 90 %
    with pytest.raises(ValueError, match="all feature shifts are equal"):
        fit_leak_calibration([1.0, 1.0, 1.0], [0.1, 0.2, 0.3])
    with pytest.raises(ValueError, match=">= 3"):
        fit_leak_calibration([1.0, 2.0], [0.1, 0.2])


def test_a_calibration_whose_shift_does_not_follow_the_leak_is_refused():
    # audit 2026-11-27: shifts that do not follow the leak (t = 0.2) were accepted and sized
    # a 0.5 L/min leak 0.04 [0, 0.32] L/min. By hand: shifts 0, 1, 2, 3 against flows
    # 0.1, 0.3, 0.1, 0.3 give slope 0.04, residual std sqrt(0.032 / 2) = 0.1265, standard error
    # 0.1265 / sqrt(5) = 0.0566, t = 0.707 < t(0.975, 2) = 4.303
    with pytest.raises(ValueError, match=r"slope 0\.04 L/min per healthy std, standard error "
                       r"0\.0566 \(t = 0\.71, below 4\.30, the two-sided 5% level\)"):
        fit_leak_calibration([0.0, 1.0, 2.0, 3.0], [0.1, 0.3, 0.1, 0.3])
    with pytest.raises(ValueError, match=r"all 3 runs have the same leak flow \(0 L/min\)"):
        fit_leak_calibration([0.0, 1.0, 2.0], [0.0, 0.0, 0.0])
    # flows 0.1, 0.2, 0.4, 0.4 on shifts 0..3: slope 0.11, t = 4.16, still below 4.30; with
    # 0.1, 0.2, 0.3, 0.41 the slope 0.103 has t = 59.5 and passes
    with pytest.raises(ValueError, match=r"t = 4\.16, below 4\.30"):
        fit_leak_calibration([0.0, 1.0, 2.0, 3.0], [0.1, 0.2, 0.4, 0.4])
    cal = fit_leak_calibration([0.0, 1.0, 2.0, 3.0], [0.1, 0.2, 0.3, 0.41])
    assert cal.slope_lpm == pytest.approx(0.103)


def test_step_information_is_the_inverse_variance_of_the_weighted_least_squares_step():
    """Reference: the (1, 1) element of (X' W X)^-1 for X = [phi 1(w >= j), nuisance]."""
    from leakdiag.detect._flow_balance_search import step_information

    rng = np.random.default_rng(4)
    n = 60
    phi, w = rng.normal(size=n), rng.uniform(0.5, 2.0, n)
    t = np.arange(n) / n
    for nu in (np.zeros((n, 0)), np.ones((n, 1)), np.column_stack([np.ones(n), 1e3 * t])):
        for j in (10, 45):
            x = np.column_stack([phi * (np.arange(n) >= j), nu])
            ref = 1.0 / np.linalg.inv(x.T @ (w[:, None] * x))[0, 0]
            assert step_information(phi, w, nu, j) == pytest.approx(ref, rel=1e-9)
    # a step the nuisance spans exactly (a constant from window 0) is not determined
    assert step_information(np.ones(n), w, np.ones((n, 1)), 0) == 0.0
