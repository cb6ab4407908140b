"""Accuracy of the fixed-step RK4 kernel: step halving and the SciPy implicit reference."""

import numpy as np
import pytest

from leakdiag.sim import (
    FixedGainController,
    LeakSchedule,
    OperatingConditions,
    PseudoRandomSteps,
    VCAParams,
    integrate_closed_loop,
)
from leakdiag.sim.vca.scipy_reference import integrate_closed_loop_scipy
from leakdiag.sim.vca.simulate import DEFAULT_MAX_STEP_S

FS = 1000.0
N_SUB = round(1 / (FS * DEFAULT_MAX_STEP_S))  # 4 RK4 steps per 1 ms sample
P_MID = 8.6e6


def _rel_rms(a, ref):
    """RMS difference relative to the RMS variation of the reference signal."""
    return np.sqrt(np.mean((a - ref) ** 2)) / np.sqrt(np.mean((ref - ref.mean()) ** 2))


def _case(load, leak_model, k_leak, conditions=None, n=1000):
    xr = PseudoRandomSteps(min_hold_s=0.2, max_hold_s=0.4).samples(
        np.arange(n) / FS, np.random.default_rng(7))
    args = (VCAParams().to_array(leak_model, load), FixedGainController().to_array(), 10.0,
            k_leak, LeakSchedule("step", onset_s=0.3).to_array(),
            (conditions or OperatingConditions()).to_array(n / FS),
            [0.0, 0.0, P_MID, P_MID, 0.0, 0.0])
    return xr, args


CASES = [
    ("none", "turbulent", 3e-8, None),
    ("spring", "laminar", 5e-12, None),
    ("spring", "turbulent", 5e-9, OperatingConditions(supply_ripple_pa=3e5)),
]


@pytest.mark.parametrize("load, leak_model, k_leak, cond", CASES)
def test_halving_the_step_changes_little(load, leak_model, k_leak, cond):
    xr, args = _case(load, leak_model, k_leak, cond)
    a = integrate_closed_loop(xr, FS, N_SUB, *args)
    b = integrate_closed_loop(xr, FS, 2 * N_SUB, *args)
    for j in (0, 2, 3):  # x, p1, p2
        assert _rel_rms(a.state[:, j], b.state[:, j]) < 0.005
    assert _rel_rms(a.leak_flow, b.leak_flow) < 0.005


@pytest.mark.parametrize("load, leak_model, k_leak, cond", CASES[:2])
def test_fast_solver_matches_scipy_radau(load, leak_model, k_leak, cond):
    xr, args = _case(load, leak_model, k_leak, cond, n=600)
    fast = integrate_closed_loop(xr, FS, N_SUB, *args)
    ref = integrate_closed_loop_scipy(xr, FS, *args)
    for j in (0, 2, 3):
        assert _rel_rms(fast.state[:, j], ref.state[:, j]) < 0.005
    assert _rel_rms(fast.leak_flow, ref.leak_flow) < 0.005
    assert _rel_rms(fast.u, ref.u) < 0.005
    # and the comparison can fail: a 4x coarser step than stable is clearly off
    coarse = integrate_closed_loop(xr, FS, 1, *args)
    assert not np.allclose(coarse.state[:, 2], ref.state[:, 2], rtol=0, atol=1.0)


def test_chunked_integration_is_bit_identical():
    xr, args = _case("spring", "turbulent", 5e-9)
    whole = integrate_closed_loop(xr, FS, N_SUB, *args)
    calls = []
    parts = integrate_closed_loop(xr, FS, N_SUB, *args, chunk=137, callback=calls.append)
    assert np.array_equal(whole.state, parts.state)
    assert np.array_equal(whole.u, parts.u)
    assert sum(calls) == len(xr) and len(calls) == int(np.ceil(len(xr) / 137))


def test_integrate_validates_shapes():
    xr, args = _case("none", "turbulent", 0.0)
    with pytest.raises(ValueError, match="state0 must have 6 entries"):
        integrate_closed_loop(xr, FS, N_SUB, *args[:-1], [0.0, 0.0])
    with pytest.raises(ValueError, match="n_sub=0 must be"):
        integrate_closed_loop(xr, FS, 0, *args)
    with pytest.raises(ValueError, match="noise1/noise2 must have"):
        integrate_closed_loop(xr, FS, N_SUB, *args, np.zeros(3), np.zeros(3), np.ones(4))


def test_strided_readonly_and_pandas_references_give_the_same_run():
    import pandas as pd

    from leakdiag.sim import simulate_vca

    base = np.repeat(np.array([5e-3, -8e-3, 12e-3]), 400)
    strided = np.repeat(base, 2)[::2]
    strided.flags.writeable = False
    kw = dict(duration=1.2, leak_lpm=None, sensors=False, seed=0)
    a = simulate_vca(reference=base, **kw)
    b = simulate_vca(reference=strided, **kw)
    c = simulate_vca(reference=pd.Series(base), **kw)
    assert np.array_equal(a["x"], b["x"]) and np.array_equal(a["x"], c["x"])


@pytest.mark.parametrize("fs", [500.0, 2000.0])
def test_other_sample_rates_agree_with_1khz(fs):
    from leakdiag.sim import simulate_vca

    ref = np.full(int(1.0 * fs), 6e-3)
    r = simulate_vca(duration=1.0, leak_lpm=None, sensors=False, sample_rate=fs, reference=ref,
                     seed=0)
    assert r.meta["rk4_step_s"] <= DEFAULT_MAX_STEP_S
    # the step response settles on the reference whatever the control rate
    assert r["x"][-1] == pytest.approx(6e-3, abs=0.05e-3)


def test_per_sample_leak_coefficient_array_equals_schedule():
    xr, args = _case("spring", "turbulent", 5e-9)
    params, gains, u_max, _, sched, cond, s0 = args
    a = integrate_closed_loop(xr, FS, N_SUB, *args)  # step at 0.3 s via the schedule
    k = np.where(np.arange(len(xr)) / FS >= 0.3, 5e-9, 0.0)
    b = integrate_closed_loop(xr, FS, N_SUB, params, gains, u_max, k,
                              LeakSchedule("step", onset_s=0.0).to_array(), cond, s0)
    assert np.array_equal(a.state, b.state) and np.array_equal(a.leak_flow, b.leak_flow)
    with pytest.raises(ValueError, match="leak_coefficient must be a number or have"):
        integrate_closed_loop(xr, FS, N_SUB, params, gains, u_max, k[:5], sched, cond, s0)
