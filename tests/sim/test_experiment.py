"""The shared experiment module and the one simulator signature of both rigs."""

import inspect

import numpy as np
import pytest

from leakdiag.sim import LeakCalibrationError, simulate_eha, simulate_vca
from leakdiag.sim.experiment import (
    calibrate_leak, coefficient_from_healthy, plan_leak, random_streams,
)

SHARED = ["duration", "leak_lpm", "onset", "leak_kind", "ramp_duration", "leak_model",
          "leak_coefficient", "calibration_rtol", "load", "seed", "sample_rate", "sensors",
          "sensor_params", "params", "conditions", "machine", "progress"]


@pytest.mark.parametrize("fn", [simulate_vca, simulate_eha])
def test_one_keyword_only_signature(fn):
    params = inspect.signature(fn).parameters
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params.values())
    assert list(params)[:len(SHARED)] == SHARED


@pytest.mark.parametrize("fn", [simulate_vca, simulate_eha])
def test_positional_call_is_refused(fn):
    with pytest.raises(TypeError, match="positional"):
        fn(4.0)


def test_plan_leak_onset_sample_and_window():
    # onset 2.0005 s at 1 kHz: the first sample at or after it is 2001 (t = 2.001 s)
    p = plan_leak(0.2, 2.0005, "ramp", 3.0, n=12_000, sample_rate=1000.0, duration=12.0)
    assert p.onset_index == 2001 and p.window_s == pytest.approx(9.999)
    assert p.schedule.kind == "ramp" and p.schedule.ramp_duration_s == 3.0
    # mean |Q| over samples 2001.. only: 1e-5 m^3/s there = 0.6 L/min
    q = np.zeros(12_000)
    q[2001:] = -1e-5
    q[:2001] = 5.0                      # ignored: before the onset
    assert p.mean_lpm(q) == pytest.approx(0.6, rel=1e-12)
    none = plan_leak(0, 2.0, "step", 1.0, n=100, sample_rate=10.0, duration=10.0)
    assert not none.active and none.target_lpm == 0.0 and none.mean_lpm(q[:100]) == 0.0


def test_plan_leak_checks_target_before_onset():
    calls = []
    with pytest.raises(ValueError, match="onset=50 s"):
        plan_leak(0.1, 50.0, "step", 1.0, n=1000, sample_rate=100.0, duration=10.0,
                  check_target=calls.append)
    assert calls == [0.1]
    with pytest.raises(ValueError, match="leak_lpm=-1"):
        plan_leak(-1, 1.0, "step", 1.0, n=1000, sample_rate=100.0, duration=10.0)


def test_coefficient_from_healthy_hand_computed():
    # turbulent, dp = 1e8 Pa >> p_tr = 1 Pa: g = 1e4 Pa^0.5; step -> mean s = 1;
    # k = (0.6 L/min = 1e-5 m^3/s) / 1e4 = 1e-9
    fs = 100.0
    p = plan_leak(0.6, 5.0, "step", 1.0, n=1000, sample_rate=fs, duration=10.0)
    p1, p2 = np.full(1000, 1.01e8), np.full(1000, 1e6)
    assert coefficient_from_healthy(p1, p2, 499, p, 1.0, False) == pytest.approx(1e-9, rel=1e-9)
    # a ramp of 10 s over the 5 s after the onset: mean s = mean(0, 0.001, ..., 0.499) = 0.2495
    r = plan_leak(0.6, 5.0, "ramp", 10.0, n=1000, sample_rate=fs, duration=10.0)
    assert coefficient_from_healthy(p1, p2, 499, r, 1.0, False) == pytest.approx(
        1e-9 / 0.2495, rel=1e-9)
    # under 1 s of healthy samples after the first second: no guess
    assert coefficient_from_healthy(p1, p2, 150, p, 1.0, False) is None
    assert coefficient_from_healthy(p2, p2, 499, p, 1.0, False) is None


def test_calibrate_leak_rewords_a_failure_on_a_short_run():
    short = plan_leak(0.1, 1.0, "step", 1.0, n=5000, sample_rate=1000.0, duration=5.0)
    with pytest.raises(LeakCalibrationError, match="too short to calibrate a 0.1 L/min"):
        calibrate_leak(short, lambda k: -1.0, 1.0, 0.02, [(1.0, -1.0)])
    long = plan_leak(0.1, 1.0, "step", 1.0, n=20_000, sample_rate=1000.0, duration=20.0)
    with pytest.raises(LeakCalibrationError, match="must be finite and > 0"):
        calibrate_leak(long, lambda k: -1.0, 1.0, 0.02, [])


def test_random_streams_are_those_of_both_simulators():
    drive, noise = random_streams(7)
    ref = np.random.SeedSequence(7).spawn(2)
    assert drive.entropy == ref[0].entropy and drive.spawn_key == ref[0].spawn_key
    assert noise.spawn_key == ref[1].spawn_key


def test_eha_reports_progress_over_its_runs():
    done = []
    rec = simulate_eha(duration=25.0, onset=12.0, leak_lpm=1.0, seed=2, progress=done.append)
    n, split = 25_000, 11_999
    runs = rec.meta["calibration_runs"] + rec.meta["calibration_pilot_runs"]
    assert done == [split] + [n - split] * runs
    healthy = []
    simulate_eha(duration=2.0, leak_lpm=None, progress=healthy.append)
    assert healthy == [2000]


def _steps(rng, n_holds, hold, lo, hi):
    levels = rng.uniform(lo, hi, n_holds) * rng.choice([-1.0, 1.0], n_holds)
    return np.repeat(levels, hold)


def test_coefficient_from_healthy_predicts_the_window_after_the_onset_from_the_reference():
    # the load pressure is a linear response of the reference (dp = 1e6 x, a spring): the
    # steps after the onset are twice as large, so the mean law there is twice the one before,
    # and the guess is Q* / mean|dp after the onset| (laminar g = |dp|), not Q* / mean before
    fs, n = 100.0, 20_000
    rng = np.random.default_rng(3)
    x = np.concatenate([_steps(rng, 100, 100, 1.0, 2.0), _steps(rng, 100, 100, 2.0, 4.0)])
    p2 = np.full(n, 5e6)
    p1 = p2 + 1e6 * x
    p = plan_leak(0.6, 100.0, "step", 1.0, n=n, sample_rate=fs, duration=200.0)
    exact = 1e-5 / np.mean(np.abs(1e6 * x[10_000:]))
    before = 1e-5 / np.mean(np.abs(1e6 * x[100:9_999]))
    got = coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True, reference=x)
    assert got == pytest.approx(exact, rel=1e-6)
    assert abs(before / exact - 1) > 0.4  # without the reference the guess is far off
    assert coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True) == pytest.approx(before,
                                                                                rel=1e-12)
    # under MIN_FIT_S = 20 s of healthy samples to fit (here 1-19.99 s) no prediction is made
    assert coefficient_from_healthy(p1, p2, 1_999, p, 1.0, True, reference=x) == \
        coefficient_from_healthy(p1, p2, 1_999, p, 1.0, True)
    assert coefficient_from_healthy(p1, p2, 2_101, p, 1.0, True, reference=x) != \
        coefficient_from_healthy(p1, p2, 2_101, p, 1.0, True)


def test_coefficient_from_healthy_ignores_a_reference_the_pressure_does_not_follow():
    # no load: the pressure is not a linear response of the reference (here: independent
    # noise, R^2 ~ 0 < MIN_R2), so the guess stays the mean before the onset
    fs, n = 100.0, 20_000
    rng = np.random.default_rng(4)
    x = _steps(rng, 200, 100, 1.0, 4.0)
    p2 = np.full(n, 5e6)
    p1 = p2 + 1e6 * rng.standard_normal(n)
    p = plan_leak(0.6, 100.0, "step", 1.0, n=n, sample_rate=fs, duration=200.0)
    assert coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True, reference=x) == \
        coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True)
    # a constant reference cannot be fitted either
    assert coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True, reference=np.ones(n)) == \
        coefficient_from_healthy(p1, p2, 9_999, p, 1.0, True)


def test_slope_pilot_stretch():
    # 10 % of the window after the onset, at least 10 s, none above a quarter of the window
    def plan(duration, onset):
        return plan_leak(0.1, onset, "step", 1.0, n=int(duration * 1000), sample_rate=1000.0,
                         duration=duration)

    assert plan(400.0, 200.0).pilot_stop == 200_000 + 20_000
    assert plan(120.0, 60.0).pilot_stop == 60_000 + 10_000      # 6 s -> the 10 s minimum
    assert plan(100.0, 60.0).pilot_stop == 60_000 + 10_000      # 10 s of 40 s: a quarter
    assert plan(100.0, 61.0).pilot_stop is None                 # 10 s of 39 s
    p = plan(400.0, 200.0)
    flow = np.zeros(400_000)
    flow[200_000:220_000] = 2.0 / 60_000  # 2 L/min over the stretch, 0 after it
    assert p.pilot_mean_lpm(flow) == pytest.approx(2.0, rel=1e-12)


def test_a_given_coefficient_needs_a_leak_and_states_what_it_leaks():
    # an API audit, 2026-11-29: without leak_lpm the coefficient and the onset were dropped
    # without a word; with it, meta['leak_lpm'] kept a target of 0.1 beside 0.51 achieved
    import numpy as np
    import pytest

    import leakdiag as ld

    r = ld.sim.simulate_vca(duration=20.0, leak_lpm=0.1, onset=10.0, seed=1)
    k = r.meta["leak_coefficient"]
    r5 = ld.sim.simulate_vca(duration=20.0, leak_lpm=0.1, onset=10.0, seed=1,
                             leak_coefficient=5 * k)
    mean = float(np.mean(np.abs(r5["leak_flow"][10000:]))) * 6e4
    assert r5.meta["leak_lpm"] == r5.meta["leak_lpm_achieved"] == pytest.approx(mean)
    assert r5.meta["leak_lpm"] > 0.3
    assert r.meta["leak_lpm"] == 0.1  # a calibrated run keeps its target
    for fn in (ld.sim.simulate_vca, ld.sim.simulate_eha):
        with pytest.raises(ValueError, match="leak_coefficient=1e-09 is for a leaking run: "
                                             "give leak_lpm > 0 too"):
            fn(duration=4.0, leak_lpm=None, onset=2.0, seed=1, leak_coefficient=1e-9)
    with pytest.raises(ValueError, match="reference_seed=-3 must be >= 0"):
        ld.sim.simulate_vca(duration=2.0, leak_lpm=0, reference_seed=-3)
