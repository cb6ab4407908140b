"""Tests of the leak schedule and the leak-coefficient calibration (leakdiag.sim.leak)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.sim.leak import (
    LPM_PER_M3S,
    LeakCalibrationError,
    LeakSchedule,
    calibrate_leak_coefficient,
    leak_multiplier,
    lpm_to_m3s,
    m3s_to_lpm,
)


def test_unit_conversion_hand_values():
    # 0.1 L/min = 1e-4 m^3 / 60 s
    assert lpm_to_m3s(0.1) == pytest.approx(1e-4 / 60, rel=1e-15)
    assert m3s_to_lpm(1e-3) == pytest.approx(60.0)
    assert LPM_PER_M3S == 60_000.0


def test_step_schedule_values():
    s = LeakSchedule("step", onset_s=200.0)
    t = np.array([0.0, 199.999, 200.0, 300.0])
    assert s.multipliers(t).tolist() == [0.0, 0.0, 1.0, 1.0]
    assert [leak_multiplier(x, s.to_array()) for x in t] == [0.0, 0.0, 1.0, 1.0]


def test_none_schedule_is_zero_everywhere():
    s = LeakSchedule("none", onset_s=0.0)
    assert not s.active
    assert s.multipliers(np.linspace(0, 1000, 11)).tolist() == [0.0] * 11
    assert s.multiplier(1e6) == 0.0


@settings(max_examples=50, deadline=None)
@given(
    onset=st.floats(0, 500),
    ramp=st.floats(1e-3, 500),
    t=st.floats(0, 2000),
)
def test_ramp_numba_matches_plain_formula(onset, ramp, t):
    s = LeakSchedule("ramp", onset_s=onset, ramp_duration_s=ramp)
    expected = 0.0 if t < onset else min(1.0, (t - onset) / ramp)
    assert s.multiplier(t) == pytest.approx(expected, abs=1e-12)
    assert s.multipliers(np.array([t]))[0] == pytest.approx(expected, abs=1e-12)
    assert 0.0 <= s.multiplier(t) <= 1.0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"kind": "pulse"}, "kind='pulse' must be one of"),
        ({"kind": "step", "onset_s": -1.0}, "onset_s=-1.0 must be"),
        ({"kind": "step", "onset_s": float("nan")}, "onset_s=nan must be"),
        ({"kind": "ramp", "ramp_duration_s": 0.0}, "ramp_duration_s=0.0 must be"),
    ],
)
def test_schedule_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        LeakSchedule(**kwargs)


@pytest.mark.parametrize("power", [0.5, 1.0, 1.3])
@pytest.mark.parametrize("target", [0.047, 0.1, 0.5])
def test_calibration_hits_target_on_power_law(power, target):
    calls = []

    def fake(k):
        calls.append(k)
        return 2.0 * k**power

    res = calibrate_leak_coefficient(fake, target, initial_coefficient=1.0)
    assert abs(res.achieved_lpm - target) <= 0.02 * target
    assert res.relative_error <= 0.02
    # achieved value is the simulator's answer at the returned coefficient
    assert fake(res.coefficient) == pytest.approx(res.achieved_lpm, rel=1e-12)
    assert res.n_evaluations == len(res.history) == len(calls) - 1
    # exact solution k* = (target/2)^(1/power)
    assert res.coefficient == pytest.approx((target / 2.0) ** (1 / power), rel=0.03)
    if power == 1.0:  # proportional: one correction is exact
        assert res.n_evaluations == 2


def test_calibration_rejects_zero_flow():
    with pytest.raises(LeakCalibrationError, match="must be finite and > 0"):
        calibrate_leak_coefficient(lambda k: 0.0, 0.1, 1.0)


def test_calibration_gives_up_after_max_evaluations():
    # a flat response can never be moved to the target
    with pytest.raises(LeakCalibrationError, match="did not reach target_lpm=0.1"):
        calibrate_leak_coefficient(lambda k: 1.0 + 0.0 * k, 0.1, 1.0, max_evaluations=3)


@pytest.mark.parametrize(
    "args, match",
    [
        ((0.0, 1.0), "target_lpm=0.0 must be"),
        ((0.1, -1.0), "initial_coefficient=-1.0 must be"),
    ],
)
def test_calibration_validation(args, match):
    with pytest.raises(ValueError, match=match):
        calibrate_leak_coefficient(lambda k: k, *args)


def test_calibration_nonfinite_flow():
    with pytest.raises(LeakCalibrationError, match=r"simulate_fn\(1\) returned mean leak nan L/min; it must be finite"):
        calibrate_leak_coefficient(lambda k: math.nan, 0.1, 1.0)
