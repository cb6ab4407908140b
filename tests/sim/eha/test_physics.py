"""EHA physics: rest, flow balance at constant speed, open-loop stroke of 3 sin 4t, leak effect."""

import numpy as np
import pytest

from leakdiag.sim.eha.simulate import initial_state
from leakdiag.sim.eha.drive import build_inputs
from leakdiag.sim.eha.model import IN_BETA_SCALE, IN_FV_SCALE, IN_KLEAK, IN_U, N_INPUTS
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.eha.integrate import integrate_fast

PRM = EHAParams()
P = PRM.to_array()
FS = 1000.0
PACC = PRM.accumulator_pressure_pa


def constant_inputs(n, u=0.0, k_leak=0.0):
    inp = np.zeros((n, N_INPUTS))
    inp[:, IN_U] = u
    inp[:, IN_BETA_SCALE] = inp[:, IN_FV_SCALE] = 1.0
    inp[:, IN_KLEAK] = k_leak
    return inp


def test_zero_input_from_rest_stays_exactly_at_rest():
    y0 = initial_state(PRM)
    ys = integrate_fast(y0, constant_inputs(500), P, FS).states
    assert np.array_equal(ys[-1], y0)


def test_zero_input_settles_to_charge_pressure_and_does_not_move():
    # start with every pressure below the charge pressure: the check valves refill the lines
    y0 = initial_state(PRM)
    y0[2:6] = [0.3e6, 0.5e6, 0.2e6, 0.4e6]
    ys = integrate_fast(y0, constant_inputs(3000, k_leak=5e-8), P, FS).states
    final = ys[-1]
    assert np.all(np.abs(final[2:6] / PACC - 1.0) < 0.02)
    assert np.ptp(final[2:6]) < 1e-3 * PACC  # chambers and lines equalised
    assert np.abs(ys[:, 0]).max() < 0.5e-3  # piston moves less than 0.5 mm while filling
    assert abs(final[1]) < 1e-6
    # and nothing moves in the last second
    assert np.ptp(ys[-1000:, 0]) < 1e-6


@pytest.mark.parametrize("k_leak", [0.0, 8e-8])
def test_constant_command_moves_at_net_pump_flow_over_area(k_leak):
    n = 4000
    ys = integrate_fast(initial_state(PRM), constant_inputs(n, 1.0, k_leak), P, FS).states
    sl = slice(1000, 3000)  # after transients, far from the end stops (x < 0.1 m)
    assert ys[sl, 0].max() < 0.25
    v = (ys[3000, 0] - ys[1000, 0]) / 2.0
    omega = ys[sl, 7]
    # speed loop holds the set-point 41.9 rad/s per V (Eq. 3-1, integral action)
    assert omega.mean() == pytest.approx(PRM.speed_command_gain_rad_per_s_per_v, rel=1e-3)
    q_pump = PRM.pump_flow_per_rad_m3 * omega.mean()
    dp = ys[sl, 2] - ys[sl, 3]
    q_leak = np.mean(k_leak * dp / np.sqrt(np.sqrt(dp**2 + PRM.laminar_transition_pa**2)))
    expected = (q_pump - q_leak) / PRM.piston_area_m2
    assert v == pytest.approx(expected, rel=0.02)
    if k_leak:
        assert q_leak > 0.2 * q_pump  # the leak is a real fraction at this low speed
        assert v < 0.8 * q_pump / PRM.piston_area_m2


def test_open_loop_sine_stroke_follows_pump_volume():
    # 3 sin 4t V -> omega = 125.7 sin 4t rad/s -> x = (q_b/2pi) 125.7 / (4 A) (1 - cos 4t)
    t = np.arange(4000) / FS
    ys = integrate_fast(initial_state(PRM), build_inputs(t, PRM), P, FS).states
    peak_to_peak = PRM.pump_flow_per_rad_m3 * 3 * PRM.speed_command_gain_rad_per_s_per_v * 2 / (
        PRM.piston_area_m2 * 4.0)
    assert peak_to_peak == pytest.approx(0.07741, rel=1e-3)  # 77.4 mm
    assert np.ptp(ys[:1600, 0]) == pytest.approx(peak_to_peak, rel=0.03)


def test_spring_load_raises_pressure_difference():
    t = np.arange(2000) / FS
    free = integrate_fast(initial_state(PRM), build_inputs(t, PRM), P, FS).states
    sprung = integrate_fast(initial_state(PRM), build_inputs(t, PRM, load="spring"), P, FS).states
    # spring force k x must be carried by the chambers: (p1 - p2) A ~ k x at the stroke ends
    i = int(np.argmax(sprung[:, 0]))
    force = (sprung[i, 2] - sprung[i, 3]) * PRM.piston_area_m2
    assert force == pytest.approx(PRM.spring_stiffness_n_per_m * sprung[i, 0], rel=0.01)
    # the full Newton balance, m a + F_v v + F_pr tanh(v / V_th) + k x, closes to ~0.1 N
    acc = np.gradient(sprung[:, 1], 1.0 / FS)[i]
    v = sprung[i, 1]
    rhs = (PRM.mass_kg * acc + PRM.viscous_damping_n_s_per_m * v
           + PRM.preload_force_n * np.tanh(v / PRM.velocity_threshold_m_per_s)
           + PRM.spring_stiffness_n_per_m * sprung[i, 0])
    assert force == pytest.approx(rhs, abs=1.0)
    assert np.std(sprung[:, 2] - sprung[:, 3]) > 3 * np.std(free[:, 2] - free[:, 3])
