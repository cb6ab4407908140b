"""EHA integrators: accuracy against SciPy Radau and against a halved step, LU kernel, input checks."""

import numpy as np
import pytest

from leakdiag.sim.eha.simulate import initial_state
from leakdiag.sim.eha.drive import build_inputs
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.eha.integrate import (
    CLOSED_LOOP_RTOL, DEFAULT_RTOL, _lu_factor, _lu_solve, integrate_fast, integrate_reference,
)
from leakdiag.sim.leak import LeakSchedule

PRM = EHAParams()
FS = 1000.0
CHANNELS = {"x": 0, "p1": 2, "p2": 3, "pa": 4, "pb": 5}


def rel_rms(a, ref):
    """RMS difference over the standard deviation (not the mean) of the reference."""
    return float(np.sqrt(np.mean((a - ref) ** 2)) / np.std(ref))


@pytest.fixture(scope="module")
def case():
    t = np.arange(1500) / FS  # 1.5 s of 3 sin 4t, leak step at 0.75 s
    inputs = build_inputs(t, PRM, leak_coefficient=8e-8,
                          leak_schedule=LeakSchedule("step", onset_s=0.75))
    return initial_state(PRM), inputs, PRM.to_array()


@pytest.fixture(scope="module")
def reference(case):
    return integrate_reference(*case, sample_rate=FS, rtol=1e-7)


def test_fast_matches_scipy_radau_within_half_percent(case, reference):
    fast = integrate_fast(*case, sample_rate=FS).states
    for name, i in CHANNELS.items():
        assert rel_rms(fast[:, i], reference[:, i]) < 0.005, name


def test_closed_loop_spring_matches_scipy_radau_at_its_tolerance():
    t = np.arange(1500) / FS
    inputs = build_inputs(t, PRM, "closed-loop", "spring", amplitude=0.04,
                          leak_coefficient=8e-8, leak_schedule=LeakSchedule("step", 0.75))
    args = (initial_state(PRM), inputs, PRM.to_array(closed_loop=True))
    ref = integrate_reference(*args, sample_rate=FS, rtol=1e-7)
    fast = integrate_fast(*args, sample_rate=FS, rtol=CLOSED_LOOP_RTOL).states
    for name, i in CHANNELS.items():
        assert rel_rms(fast[:, i], ref[:, i]) < 0.005, name


def test_quarter_tolerance_halves_step_and_agrees(case, reference):
    coarse = integrate_fast(*case, sample_rate=FS)
    fine = integrate_fast(*case, sample_rate=FS, rtol=DEFAULT_RTOL / 4)
    # a local-error tolerance / 4 halves the steps of this order-2 pair (err ~ h^2)
    assert 1.6 < fine.n_accepted / coarse.n_accepted < 2.4
    for name, i in CHANNELS.items():
        assert rel_rms(coarse.states[:, i], fine.states[:, i]) < 0.005, name
        # and the finer run is closer to the reference
        assert rel_rms(fine.states[:, i], reference[:, i]) <= rel_rms(
            coarse.states[:, i], reference[:, i]) * 1.05, name


def test_deterministic_bit_for_bit(case):
    a = integrate_fast(*case[:2], case[2], sample_rate=FS).states
    b = integrate_fast(*case[:2], case[2], sample_rate=FS).states
    assert np.array_equal(a, b)


def test_accepts_strided_and_readonly_inputs(case):
    y0, inputs, p = case
    wide = np.zeros((inputs.shape[0], 2 * inputs.shape[1]))
    wide[:, ::2] = inputs
    ro = inputs[:200].copy()
    ro.flags.writeable = False
    a = integrate_fast(y0, wide[:200, ::2], p, FS).states
    b = integrate_fast(y0, ro, p, FS).states
    assert np.array_equal(a, b)


def test_lu_kernel_matches_numpy():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(9, 9)) + np.diag([1e6, 1, 1e-3, 5, 1, 1, 1, 1, 1])
    b = rng.normal(size=9)
    lu = a.copy()
    piv = np.empty(9, dtype=np.int64)
    _lu_factor(lu, piv)
    x = b.copy()
    _lu_solve(lu, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"y0": np.zeros(3)}, r"y0 must have shape \(9,\)"),
        ({"inputs": np.zeros((5, 4))}, r"inputs must have shape \(n >= 1, 6\)"),
        ({"sample_rate": 0.0}, "sample_rate=0.0 must be a finite number > 0"),
        ({"rtol": -1.0}, "rtol=-1.0 must be a finite number > 0"),
        ({"inputs": np.full((5, 6), np.nan)}, "y0 and inputs must be finite"),
    ],
)
def test_input_validation(case, kwargs, match):
    args = {"y0": case[0], "inputs": case[1][:5], "params": case[2], "sample_rate": FS}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        integrate_fast(**args)


@pytest.mark.parametrize("sched", [LeakSchedule("step", onset_s=0.75),
                                   LeakSchedule("ramp", onset_s=0.5, ramp_duration_s=0.4)])
def test_kernel_applies_the_schedule_as_the_precomputed_column(sched):
    """One convention: the kernel scales the leak column by s(t) (as the VCA kernel does);
    the full coefficient plus the schedule equals the coefficient in force, bit for bit, and
    so does a run resumed at sample 600 (the calibration's restart)."""
    t = np.arange(1200) / FS
    base = build_inputs(t, PRM)
    y0, p = initial_state(PRM), PRM.to_array()
    in_force = build_inputs(t, PRM, leak_coefficient=8e-8, leak_schedule=sched)
    full = base.copy()
    full[:, 5] = 8e-8                          # IN_KLEAK: the full coefficient
    want = integrate_fast(y0, in_force, p, FS).states
    got = integrate_fast(y0, full, p, FS, leak_schedule=sched)
    assert np.array_equal(got.states, want)
    assert not np.array_equal(integrate_fast(y0, full, p, FS).states, want)  # s(t) matters
    pre = integrate_fast(y0, full[:601], p, FS, leak_schedule=sched.to_array())
    post = integrate_fast(pre.states[-1], full[600:], p, FS, resume=pre.resume,
                          leak_schedule=sched)
    assert np.array_equal(np.concatenate([pre.states[:-1], post.states]), want)
    ref = integrate_reference(y0, full[:300], p, FS, leak_schedule=sched)
    assert np.array_equal(ref, integrate_reference(y0, in_force[:300], p, FS))


def test_bad_leak_schedule_is_refused():
    with pytest.raises(ValueError, match="leak_schedule"):
        integrate_fast(initial_state(PRM), build_inputs(np.arange(5) / FS, PRM),
                       PRM.to_array(), FS, leak_schedule=[1.0, 2.0])
