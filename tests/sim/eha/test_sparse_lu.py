"""Sparse elimination of the ROS2 matrix W = I - gamma h J (sim/eha/sparse_lu.py)."""

from pathlib import Path

import numpy as np
import pytest

import leakdiag.sim.eha._sparse_lu_kernel as kernel_module
from leakdiag.sim.eha._sparse_lu_kernel import _w_factor, _w_solve
from leakdiag.sim.eha.drive import build_inputs
from leakdiag.sim.eha.integrate import GAMMA, _STATE_SCALE, integrate_fast
from leakdiag.sim.eha.jacobian import _jacobian_into
from leakdiag.sim.eha.model import N_STATES, S_V, S_X, S_Z
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.eha.simulate import initial_state
from leakdiag.sim.eha.sparse_lu import (
    ELIMINATION_ORDER, JACOBIAN_PATTERN, PIVOT_FLOOR, elimination_plan, generate_source,
)
from leakdiag.sim.leak import LeakSchedule

FS = 1000.0


def _mask():
    m = np.eye(N_STATES, dtype=bool)
    for r, cols in JACOBIAN_PATTERN.items():
        m[r, list(cols)] = True
    return m


def _run(mode, load, leak, seconds=6.0, machine_scale=1.0):
    prm = EHAParams()
    t = np.arange(int(seconds * FS)) / FS
    inputs = build_inputs(t, prm, mode, load, 3.0 if mode == "open-loop" else 0.05, 4.0,
                          leak_coefficient=leak,
                          leak_schedule=LeakSchedule("step", onset_s=seconds / 2),
                          rng=np.random.default_rng(1))
    p = prm.to_array(closed_loop=(mode == "closed-loop"))
    return initial_state(prm), inputs, p


CASES = [("open-loop", "none", 0.0), ("open-loop", "spring", 8e-8),
         ("closed-loop", "none", 8e-8), ("closed-loop", "spring", 0.0)]


def test_committed_kernel_is_what_the_plan_generates():
    assert Path(kernel_module.__file__).read_text() == generate_source()


def test_plan_by_hand():
    # 2 states coupled both ways: one update of the second row, no fill
    entries, fill, steps = elimination_plan({0: (1,), 1: (0,)}, (0, 1))
    assert entries == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert fill == [] and steps == [(0, [1], [1]), (1, [], [])]
    # an arrow (first state coupled to both others) eliminated from its head fills both ways
    _, fill, _ = elimination_plan({0: (1, 2), 1: (0,), 2: (0,)}, (0, 1, 2))
    assert sorted(fill) == [(1, 2), (2, 1)]
    # the same arrow eliminated from its tip does not fill
    _, fill, _ = elimination_plan({0: (1, 2), 1: (0,), 2: (0,)}, (1, 2, 0))
    assert fill == []
    assert sorted(ELIMINATION_ORDER) == list(range(N_STATES))


@pytest.mark.parametrize("mode, load, leak", CASES)
def test_jacobian_has_no_entry_outside_the_pattern(mode, load, leak):
    y0, inputs, p = _run(mode, load, leak)
    sol = integrate_fast(y0, inputs, p, FS)
    outside = ~_mask()
    jac = np.empty((N_STATES, N_STATES))
    rng = np.random.default_rng(2)
    states = sol.states[::25].copy()
    # also beyond the end stops, at the saturations and with reversed flows
    wild = states[rng.integers(0, len(states), 200)] * rng.uniform(-3, 3, (200, N_STATES))
    for k, y in enumerate(np.vstack([states, wild])):
        _jacobian_into(0.0, y, inputs[(25 * k) % len(inputs)], p, jac)
        assert not np.any(jac[outside]), np.argwhere((jac != 0) & outside)


@pytest.mark.parametrize("mode, load, leak", CASES)
def test_solve_matches_a_scaled_pivoting_solve(mode, load, leak):
    # W from the run's own states at steps of 1 us .. 1 ms; the reference solves the scaled
    # system D^-1 W D (states in the integrator's units) with LAPACK's partial pivoting
    y0, inputs, p = _run(mode, load, leak)
    sol = integrate_fast(y0, inputs, p, FS)
    d = _STATE_SCALE
    rng = np.random.default_rng(3)
    jac = np.empty((N_STATES, N_STATES))
    a = np.empty((N_STATES, N_STATES))
    worst = 0.0
    for j in range(0, len(inputs), 37):
        _jacobian_into(j / FS, sol.states[j], inputs[j], p, jac)
        for h in (1e-6, 1e-5, 1e-4, 1e-3):
            w = np.eye(N_STATES) - GAMMA * h * jac
            b = rng.standard_normal(N_STATES) * d
            ref = np.linalg.solve(w / d[:, None] * d[None, :], b / d) * d
            assert _w_factor(jac, GAMMA * h, a, PIVOT_FLOOR)
            x = b.copy()
            _w_solve(a, x)
            worst = max(worst, np.max(np.abs(x - ref) / d) / np.max(np.abs(ref) / d))
    assert worst < 1e-11


def test_diagonal_jacobian_by_hand():
    jac = np.diag(-np.arange(1.0, N_STATES + 1.0))
    a = np.empty((N_STATES, N_STATES))
    assert _w_factor(jac, 0.5, a, PIVOT_FLOOR)
    b = np.ones(N_STATES)
    _w_solve(a, b)
    np.testing.assert_array_equal(b, 1.0 / (1.0 + 0.5 * np.arange(1.0, N_STATES + 1.0)))


def test_small_or_nan_pivot_is_refused():
    a = np.empty((N_STATES, N_STATES))
    jac = np.zeros((N_STATES, N_STATES))
    jac[S_Z, S_Z] = 1.0  # W[z, z] = 1 - 1 = 0, the first pivot
    assert not _w_factor(jac, 1.0, a, PIVOT_FLOOR)
    jac[S_Z, S_Z] = 0.0
    jac[S_X, S_V] = np.nan
    assert not _w_factor(jac, 1.0, a, PIVOT_FLOOR)
    jac[S_X, S_V] = 1.0
    assert _w_factor(jac, 1.0, a, PIVOT_FLOOR)
    assert not _w_factor(jac, 1.0, a, np.inf)


@pytest.mark.parametrize("mode, load, leak", CASES)
def test_dense_fallback_gives_the_same_run(mode, load, leak):
    # pivot_floor=inf takes the dense LU with partial pivoting at every step: the same solution
    # to within the rounding of the two eliminations, amplified by the step controller
    case = _run(mode, load, leak, seconds=3.0)
    sparse = integrate_fast(*case, FS)
    dense = integrate_fast(*case, FS, pivot_floor=np.inf)
    assert sparse.n_dense == 0
    assert dense.n_dense == dense.n_accepted + dense.n_rejected
    scale = np.std(dense.states, axis=0) + 1e-12
    err = np.max(np.abs(sparse.states - dense.states) / scale)
    assert err < 1e-6  # measured 6e-11 .. 5e-8


def test_pivot_floor_is_checked():
    with pytest.raises(ValueError, match="pivot_floor=-1.0 must be >= 0"):
        integrate_fast(*_run("open-loop", "none", 0.0, seconds=0.1), FS, pivot_floor=-1.0)
    with pytest.raises(ValueError, match="pivot_floor=nan must be >= 0"):
        integrate_fast(*_run("open-loop", "none", 0.0, seconds=0.1), FS, pivot_floor=np.nan)
