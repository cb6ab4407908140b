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


def test_a_step_goes_at_most_twice_as_far_as_the_proportional_one():
    # a nearly flat mean leak below a knee (as the VCA's without load near 0.5 L/min): the
    # secant slope 0.11 is taken as MIN_SLOPE = 0.5, so the third run is at
    # k1 (q*/q1)^2, not k1 (q*/q1)^9 far past the knee
    from leakdiag.sim.calibration import MIN_SLOPE

    def q(k):
        return 0.4 * k ** 0.11 if k < 2.0 else 0.4 * 2.0 ** 0.11 * (k / 2.0) ** 3

    res = calibrate_leak_coefficient(q, 0.5, 1.0)
    (k0, _), (k1, q1), (k2, _) = res.history[:3]
    assert MIN_SLOPE == 0.5 and k1 == pytest.approx(1.25, rel=1e-12)
    assert k2 == pytest.approx(1.25 * (0.5 / q1) ** 2, rel=1e-12)
    assert res.relative_error <= 0.02


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


# ------------------------------------------------------------------ restarts, tolerance, reports
import leakdiag as _ld  # noqa: E402
from leakdiag.sim.leak import (  # noqa: E402
    LEAK_REFERENCE_DP_PA, calibrate_with_pilot, check_calibrated, reaction_step,
)


@pytest.mark.parametrize("load, model", [("none", "turbulent"), ("spring", "turbulent"),
                                         ("none", "laminar")])
def test_60_s_run_at_0047_lpm_holds_the_2_percent_tolerance(load, model):
    # issue 14: a 60 s run long enough to calibrate delivers 0.047 L/min within 2 %
    rec = _ld.sim.simulate_vca(duration=60.0, leak_lpm=0.047, onset=30.0, load=load,
                               leak_model=model)
    q = np.mean(np.abs(rec["leak_flow"][30_000:])) * 60_000
    assert q == pytest.approx(rec.meta["leak_lpm_achieved"], rel=1e-12)
    assert abs(q / 0.047 - 1) <= 0.02


@pytest.mark.parametrize("system", ["vca", "eha"])
def test_calibrated_run_equals_a_whole_run_with_its_coefficient(system):
    # the restart after the onset is bit-identical to integrating the whole run
    fn = _ld.sim.simulate_vca if system == "vca" else _ld.sim.simulate_eha
    kw = dict(duration=12.0, onset=5.0, seed=3, machine=4)
    a = fn(leak_lpm=0.3 if system == "vca" else 1.0, **kw)
    b = fn(leak_coefficient=a.meta["leak_coefficient"], **kw)
    for name in a.channel_names:
        assert np.array_equal(a[name], b[name]), name
    assert a.meta["calibration_runs"] >= 1


def test_too_short_run_says_so():
    with pytest.raises(LeakCalibrationError, match=r"too short to calibrate a 0.1 L/min leak: "
                                                   r"1 s after the onset"):
        _ld.sim.simulate_vca(duration=2.0, leak_lpm=0.1, onset=1.0)


def test_reference_flow_in_meta():
    # turbulent law at the 1 MPa reference: k * 1e6 / (1e12 + 1e8)^(1/4) (regularised, Eq. 2-4)
    rec = _ld.sim.simulate_vca(duration=3.0, onset=1.0, leak_coefficient=1e-8)
    assert rec.meta["leak_reference_dp_pa"] == LEAK_REFERENCE_DP_PA == 1e6
    want = 1e-8 * 1e6 / (1e12 + 1e8) ** 0.25 * 60_000
    assert rec.meta["leak_lpm_at_reference_dp"] == pytest.approx(want, rel=1e-12)
    eha = _ld.sim.simulate_eha(duration=2.0, onset=1.0, leak_coefficient=1e-8)
    assert eha.meta["leak_lpm_at_reference_dp"] == pytest.approx(want, rel=1e-12)


def _first_order_reaction(k):
    # q = k (1 - 0.5 q): the pressures fall in proportion to the leak flow; q = k / (1 + 0.5 k)
    return k / (1.0 + 0.5 * k)


def test_check_calibrated_and_pilot():
    with pytest.raises(LeakCalibrationError, match=r"2.80% from the target 0.047 L/min"):
        check_calibrated(0.047 * 0.972, 0.047, 0.02)
    # no-reaction guess k0 = 0.5; the 0.5 %-biased pilot gives 0.4 * 0.995 = 0.398, so
    # k1 = 0.5 / (2 - 0.5 / 0.398) = 0.67230 and the full run 0.67230 / 1.33615 = 0.50316
    pilot = lambda k: 0.995 * _first_order_reaction(k)  # noqa: E731
    res = calibrate_with_pilot(_first_order_reaction, pilot, 0.5, 0.5)
    assert res.n_evaluations == 1 and res.n_pilot_evaluations == 1
    assert res.coefficient == pytest.approx(0.5 / (2 - 0.5 / 0.398), rel=1e-12)
    assert res.achieved_lpm == pytest.approx(0.50316, abs=1e-5)
    assert res.history[-1][1] == res.achieved_lpm
    with pytest.raises(LeakCalibrationError, match=r"pilot_fn\(0.5\) returned mean leak 0"):
        calibrate_with_pilot(_first_order_reaction, lambda k: 0.0, 0.5, 0.5)


def test_reaction_step_hand_values_and_first_step():
    # 20 % low: 1 / (2 - 1.25); outside [2/3, 1.5] the proportional correction
    assert reaction_step(0.5, 0.4, 0.5) == pytest.approx(0.5 / 0.75, rel=1e-15)
    assert reaction_step(1.0, 1.1, 1.0) == pytest.approx(1.0 / (2.0 - 1.0 / 1.1), rel=1e-15)
    assert reaction_step(1.0, 0.25, 1.0) == 4.0 and reaction_step(1.0, 2.0, 1.0) == 0.5
    # a first-order reaction: the reaction step lands exactly on the second run (0.6667 ->
    # 0.5), the proportional one needs a third (0.625 -> 0.47619, then the secant)
    res = calibrate_leak_coefficient(_first_order_reaction, 0.5, 0.5, first_step="reaction")
    assert res.n_evaluations == 2 and res.achieved_lpm == pytest.approx(0.5, rel=1e-12)
    prop = calibrate_leak_coefficient(_first_order_reaction, 0.5, 0.5)
    assert prop.n_evaluations == 3 and prop.history[1][1] == pytest.approx(0.625 / 1.3125)
    with pytest.raises(ValueError, match="first_step='newton' must be"):
        calibrate_leak_coefficient(_first_order_reaction, 0.5, 0.5, first_step="newton")


def test_first_slope_pilot_takes_the_first_step_with_its_slope():
    # q = 3 k^0.8 from k = 1 to 0.1 L/min: the proportional step (k = 1/30) gives 0.197, 97 %
    # too much; with the pilot's slope 0.8 the second run hits 0.1 (to rounding)
    q = lambda k: 3.0 * k ** 0.8  # noqa: E731
    calls = []

    def slope(k0, k1):
        calls.append((k0, k1))
        return math.log(q(k1) / q(k0)) / math.log(k1 / k0)

    res = calibrate_leak_coefficient(q, 0.1, 1.0, first_slope=slope)
    assert (res.n_evaluations, res.n_pilot_evaluations) == (2, 1)
    assert calls == [(1.0, pytest.approx(1.0 / 30.0, rel=1e-15))]
    assert res.coefficient == pytest.approx((1.0 / 30.0) ** 1.25, rel=1e-12)
    assert res.achieved_lpm == pytest.approx(0.1, rel=1e-12)
    # a first run that lands needs no pilot; the slope is clipped to [0.5, 5]: a step goes at
    # most twice as far in log k as the proportional one
    assert calibrate_leak_coefficient(q, 3.0, 1.0, first_slope=slope).n_pilot_evaluations == 0
    flat = calibrate_leak_coefficient(q, 0.1, 1.0, first_slope=lambda a, b: 0.01)
    assert flat.history[1][0] == pytest.approx(30.0 ** -2, rel=1e-12)
    with pytest.raises(LeakCalibrationError, match=r"first_slope\(1, 0.0333333\) returned nan"):
        calibrate_leak_coefficient(q, 0.1, 1.0, first_slope=lambda a, b: math.nan)
    # a pilot without a slope (None): the proportional step, 1/30
    prop = calibrate_leak_coefficient(q, 0.1, 1.0, first_slope=lambda a, b: None)
    assert prop.history[1][0] == pytest.approx(1.0 / 30.0, rel=1e-12)


def test_log_slope_by_hand_and_undefined():
    from leakdiag.sim.leak import log_slope

    assert log_slope(1e-8, 2.0, 1.5e-8, 2.0 * 1.5 ** 1.2) == pytest.approx(1.2, rel=1e-12)
    assert log_slope(2.0, 1.0, 1.0, 2.0) == pytest.approx(-1.0, rel=1e-12)
    for bad in [(0.0, 1.0, 1.0, 2.0), (1.0, 1.0, 1.0, 2.0), (1.0, 1.0, 2.0, 1.0),
                (1.0, np.inf, 2.0, 1.0), (1.0, 1.0, 2.0, -1.0)]:
        assert log_slope(*bad) is None


def test_bracketed_search_uses_illinois_on_a_convex_response():
    # a kink (slope 1, then 10: a large leak without load turns superlinear, docs/models.md):
    # once runs bracket the target the regula falsi keeps the bracket and halves a stuck
    # end's residual: 6 runs (the secant through the last two runs alone took 11)
    def kinked(k):
        return k if k <= 1.0 else 1.0 + 10.0 * (k - 1.0)

    res = calibrate_leak_coefficient(kinked, 1.5, 1.0, rtol=1e-3, max_evaluations=40)
    assert abs(res.achieved_lpm / 1.5 - 1) <= 1e-3 and res.n_evaluations == 6
    h = res.history
    first = next(i for i in range(len(h)) if {q < 1.5 for _, q in h[:i + 1]} == {True, False})
    assert first == 1
    for i in range(first + 1, len(h)):  # every later run lies inside the bracket before it
        lo = max(k for k, q in h[:i] if q < 1.5)
        hi = min(k for k, q in h[:i] if q > 1.5)
        assert lo < h[i][0] < hi
