"""EHA right-hand side: hand-computed derivatives, orifice laws, equilibrium (Eqs. 3-1..3-19)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.sim.eha.model import (
    IN_BETA_SCALE, IN_FV_SCALE, IN_KLEAK, IN_SPRING, IN_U, IN_XREF, N_INPUTS, N_STATES, S_I,
    S_P1, S_P2, S_PA, S_PB, S_V, S_W, S_X, S_Z, eha_command, eha_leak_flow, eha_rhs,
)
from leakdiag.sim.eha.flows import check_valve_flow, line_orifice_flow, orifice_flow
from leakdiag.sim.eha.params import EHAParams

PRM = EHAParams()
P = PRM.to_array()
PACC = PRM.accumulator_pressure_pa


def rest_state():
    y = np.zeros(N_STATES)
    y[S_P1:S_PB + 1] = PACC
    return y


def nominal_inputs():
    u = np.zeros(N_INPUTS)
    u[IN_BETA_SCALE] = u[IN_FV_SCALE] = 1.0
    return u


def test_rest_at_accumulator_pressure_is_equilibrium():
    assert np.all(eha_rhs(0.0, rest_state(), nominal_inputs(), P) == 0.0)


def test_piston_acceleration_hand_value():
    y = rest_state()
    y[S_P1] += 1e5  # 0.1 MPa * 633 mm^2 = 63.3 N on 12.3 kg
    d = eha_rhs(0.0, y, nominal_inputs(), P)
    assert d[S_V] == pytest.approx(1e5 * 633e-6 / 12.3, rel=1e-12)
    assert d[S_X] == 0.0


def test_friction_viscous_preload_and_spring_hand_value():
    y = rest_state()
    y[S_V] = 0.05
    y[S_X] = 0.01
    u = nominal_inputs()
    u[IN_SPRING] = 2e4
    d = eha_rhs(0.0, y, u, P)
    force = -25.0 * math.tanh(0.05 / 0.01) - 300.0 * 0.05 - 2e4 * 0.01
    assert d[S_V] == pytest.approx(force / 12.3, rel=1e-12)
    # moving piston with closed lines: chamber 1 expands -> its pressure falls (Eq. 3-18)
    assert d[S_P1] < 0 < d[S_P2]


def test_end_stop_pushes_back():
    y = rest_state()
    y[S_X] = 0.3 + 1e-4
    d = eha_rhs(0.0, y, nominal_inputs(), P)
    assert d[S_V] == pytest.approx(-1e8 * 1e-4 / 12.3, rel=1e-9)


def test_motor_equations_hand_values():
    # Eq. 3-3: L di/dt = V - R i - Ce w, Eq. 3-4: J dw/dt = Cm i - B w - qb/(2 pi) (P1 - P2)
    y = rest_state()
    y[S_I] = 2.0
    y[S_W] = 10.0
    y[S_Z] = 0.5
    y[S_PA] += 1e6
    u = nominal_inputs()
    u[IN_U] = 1.0
    d = eha_rhs(0.0, y, u, P)
    wd = 4000 * 2 * math.pi / 60 / 10 * 1.0
    volt = 0.5 * (wd - 10.0) + 20.0 * 0.5
    assert d[S_Z] == pytest.approx(wd - 10.0, rel=1e-12)
    assert d[S_I] == pytest.approx((volt - 0.73 * 2.0 - 0.6963 * 10.0) / 3.55e-3, rel=1e-12)
    torque = 0.6963 * 2.0 - 0.0004855 * 10.0 - 4.9e-6 / (2 * math.pi) * 1e6
    assert d[S_W] == pytest.approx(torque / 0.000874, rel=1e-12)


def test_pump_flow_is_conserved_between_lines():
    # Eq. 3-6: the pump moves q_b w / 2 pi from line b to line a; nothing else flows when the
    # line pressures equal the chambers and the accumulator.
    y = rest_state()
    y[S_W] = 50.0
    d = eha_rhs(0.0, y, nominal_inputs(), P)
    q = 4.9e-6 / (2 * math.pi) * 50.0
    vol = PRM.line_volume_m3
    assert d[S_PA] == pytest.approx(689e6 / vol * q, rel=1e-12)
    assert d[S_PB] == pytest.approx(-689e6 / vol * q, rel=1e-12)


def test_leak_flow_moves_fluid_from_high_to_low_chamber():
    y = rest_state()
    y[S_P1] += 4e6
    u = nominal_inputs()
    u[IN_KLEAK] = 1e-8
    q = eha_leak_flow(y, u, P)
    assert q == pytest.approx(1e-8 * 4e6 / (4e6**2 + 1e4**2) ** 0.25, rel=1e-12)
    assert q == pytest.approx(1e-8 * 2000.0, rel=1e-5)  # sqrt(4 MPa) = 2000 sqrt(Pa)
    d_leak = eha_rhs(0.0, y, u, P)
    d_none = eha_rhs(0.0, y, nominal_inputs(), P)
    va = vb = PRM.chamber_volume_m3
    assert d_leak[S_P1] - d_none[S_P1] == pytest.approx(-689e6 / va * q, rel=1e-9)
    assert d_leak[S_P2] - d_none[S_P2] == pytest.approx(689e6 / vb * q, rel=1e-9)


def test_bulk_modulus_input_scales_pressure_rates():
    y = rest_state()
    y[S_W] = 20.0
    u = nominal_inputs()
    u[IN_BETA_SCALE] = 0.9
    assert eha_rhs(0.0, y, u, P)[S_PA] == pytest.approx(
        0.9 * eha_rhs(0.0, y, nominal_inputs(), P)[S_PA], rel=1e-12)


def test_orifice_law_hand_values():
    k = 1.7e-6
    assert orifice_flow(k, 1e8, 1e4) == pytest.approx(k * 1e4, rel=1e-8)
    assert orifice_flow(k, 0.0, 1e4) == 0.0
    # laminar core: slope k / sqrt(p_t) at zero
    assert orifice_flow(k, 1.0, 1e4) == pytest.approx(k / 100.0, rel=1e-8)


def test_line_orifice_free_and_restricted_directions():
    # outside the +-p_t blend band the coefficients are exactly Eqs. 3-9..3-12
    kf, kr = 2.0, 0.2
    assert line_orifice_flow(kf, kr, 5e5, 1e4) == orifice_flow(kf, 5e5, 1e4)
    assert line_orifice_flow(kf, kr, -5e5, 1e4) == orifice_flow(kr, -5e5, 1e4)
    assert line_orifice_flow(kf, kr, 0.0, 1e4) == 0.0


@settings(max_examples=200, deadline=None)
@given(a=st.floats(-1e7, 1e7), b=st.floats(-1e7, 1e7))
def test_flows_monotone_in_pressure_drop(a, b):
    lo, hi = min(a, b), max(a, b)
    assert orifice_flow(1.0, lo, 1e4) <= orifice_flow(1.0, hi, 1e4)
    assert orifice_flow(1.0, -a, 1e4) == -orifice_flow(1.0, a, 1e4)
    assert line_orifice_flow(1.0, 0.1, lo, 1e4) <= line_orifice_flow(1.0, 0.1, hi, 1e4)
    assert check_valve_flow(1.0, lo, 5e4, 1e4) <= check_valve_flow(1.0, hi, 5e4, 1e4)
    assert check_valve_flow(1.0, lo, 5e4, 1e4) >= 0.0


def test_check_valve_closed_below_and_open_above():
    assert check_valve_flow(1e-6, -1.0, 5e4, 1e4) == 0.0
    assert check_valve_flow(1e-6, 0.0, 5e4, 1e4) == 0.0
    assert check_valve_flow(1e-6, 1e6, 5e4, 1e4) == pytest.approx(orifice_flow(1e-6, 1e6, 1e4))
    # half-way through the opening band the smoothstep is exactly 1/2
    assert check_valve_flow(1e-6, 2.5e4, 5e4, 1e4) == pytest.approx(
        0.5 * orifice_flow(1e-6, 2.5e4, 1e4), rel=1e-12)


def test_command_open_and_closed_loop_with_saturation():
    y = rest_state()
    u = nominal_inputs()
    u[IN_U] = 12.0
    assert eha_command(y, u, P) == 10.0  # +-10 V drive input
    pc = PRM.to_array(closed_loop=True)
    u[IN_XREF] = 0.002
    y[S_X] = -0.001
    assert eha_command(y, u, pc) == pytest.approx(400.0 * 0.003)
    u[IN_XREF] = -1.0
    assert eha_command(y, u, pc) == -10.0


@pytest.mark.parametrize("closed", [False, True])
def test_analytic_jacobian_matches_central_differences(closed):
    from leakdiag.sim.eha.jacobian import _jacobian_into
    from leakdiag.sim.eha.model import _rhs_into

    p = PRM.to_array(closed_loop=closed)
    rng = np.random.default_rng(5)
    scale = np.array([1e-2, 1e-1, 1e6, 1e6, 1e6, 1e6, 100.0, 100.0, 1.0])
    for _ in range(40):
        y = rest_state()
        y[S_X] = rng.uniform(-0.25, 0.25)
        y[S_V] = rng.uniform(-0.2, 0.2)
        y[S_P1:S_PB + 1] = PACC + rng.uniform(-0.3e6, 1.5e6, 4)
        y[S_I] = rng.uniform(-2, 2)
        y[S_W] = rng.uniform(-150, 150)
        y[S_Z] = rng.uniform(-5, 5)
        u = nominal_inputs()
        u[IN_U] = rng.uniform(-3, 3)
        u[IN_XREF] = rng.uniform(-0.04, 0.04)
        u[IN_SPRING] = 2e4
        u[IN_KLEAK] = 8e-8
        jac = np.zeros((N_STATES, N_STATES))
        _jacobian_into(0.0, y, u, p, jac)
        num = np.zeros((N_STATES, N_STATES))
        fp = np.empty(N_STATES)
        fm = np.empty(N_STATES)
        for m in range(N_STATES):
            d = 1e-7 * scale[m]
            yp, ym = y.copy(), y.copy()
            yp[m] += d
            ym[m] -= d
            _rhs_into(0.0, yp, u, p, fp)
            _rhs_into(0.0, ym, u, p, fm)
            num[:, m] = (fp - fm) / (2 * d)
        tol = 1e-5 * (np.abs(num) + np.abs(jac)) + 1e-9 * scale[:, None] / scale[None, :]
        assert np.all(np.abs(jac - num) <= tol)
