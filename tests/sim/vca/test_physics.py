"""Physics checks of the VCA model: equilibrium, Eq. 2-6 natural frequency and damping, spring."""

import dataclasses

import numpy as np
import pytest
from scipy.signal import find_peaks

from leakdiag.sim import (
    FixedGainController,
    LeakSchedule,
    OperatingConditions,
    VCAParams,
    default_inputs,
    integrate_closed_loop,
    rk4_advance,
    simulate_vca,
    vca_rhs,
)

# Eq. 2-1 exactly: no Coulomb friction (it would stop the free oscillation)
P0 = dataclasses.replace(VCAParams(), coulomb_friction_n=0.0)
P_MID = 0.5 * P0.supply_pressure_pa


def _free_ring(leak_coefficient, leak_model="laminar", fs=20_000, duration=0.2):
    """Centred piston, valve pulsed open for 2 ms, then closed; returns time and P1 - P2."""
    prm = P0.to_array(leak_model, "none")
    sched = LeakSchedule("step", onset_s=0.0).to_array()
    cond = OperatingConditions().to_array(duration)
    s = np.array([0.0, 0.0, P_MID, P_MID, 0.0, 0.0])
    n = int(duration * fs)
    out = np.empty((n, 6))
    for k in range(n):
        t = k / fs
        out[k] = s
        rk4_advance(s, t, 1.0 / fs / 5, 5, 1.0 if t < 0.002 else 0.0, leak_coefficient, sched,
                    cond, prm)
    t = np.arange(n) / fs
    keep = t > 0.02  # spool closed again (150 Hz, 0.7 damping)
    return t[keep], out[keep, 2] - out[keep, 3], out[keep]


def _frequency_and_decay(t, y):
    sign = np.signbit(y)
    zc = np.flatnonzero(sign[1:] != sign[:-1])
    dt = t[1] - t[0]
    tz = t[zc] - y[zc] / (y[zc + 1] - y[zc]) * dt  # linear interpolation of crossings
    omega = 2 * np.pi / (2 * np.mean(np.diff(tz[:10])))
    peaks, _ = find_peaks(np.abs(y))
    peaks = peaks[:10]
    sigma = -np.polyfit(t[peaks], np.log(np.abs(y[peaks])), 1)[0]
    return omega, sigma


def test_at_rest_valve_closed_no_leak_rhs_is_zero_and_pressures_hold():
    s = np.array([0.05, 0.0, 9.0e6, 7.0e6, 0.0, 0.0])  # off-centre, unequal pressures
    prm = P0.to_array("turbulent", "none")
    # force balance is off (A (P1-P2) != 0) so the piston accelerates, but no fluid flows:
    d = vca_rhs(0.0, s, default_inputs(), prm)
    assert d[2] == 0.0 and d[3] == 0.0 and d[4] == 0.0 and d[5] == 0.0
    assert d[1] == pytest.approx(P0.piston_area_m2 * 2e6 / P0.mass_kg, rel=1e-12)
    # balanced pressures: nothing moves over 1 s of simulated time, exactly
    s = np.array([0.05, 0.0, P_MID, P_MID, 0.0, 0.0])
    rk4_advance(s, 0.0, 2.5e-4, 4000, 0.0, 0.0, LeakSchedule().to_array(),
                OperatingConditions().to_array(1.0), prm)
    assert s.tolist() == [0.05, 0.0, P_MID, P_MID, 0.0, 0.0]


def test_natural_frequency_matches_eq_2_6():
    t, pl, _ = _free_ring(0.0)
    omega, _ = _frequency_and_decay(t, pl)
    omega_h = P0.hydraulic_natural_frequency_rad_s  # sqrt(2 beta A^2 / (m V)) = 438.0 rad/s
    assert omega_h == pytest.approx(np.sqrt(2 * 689e6 * 633e-6**2 / (12.3 * 234e-6)))
    assert omega == pytest.approx(omega_h, rel=0.05)
    assert omega == pytest.approx(omega_h, rel=0.005)  # in fact much closer


@pytest.mark.parametrize("k_leak", [2e-12, 5e-12])
def test_leak_damps_faster_as_eq_2_6_predicts(k_leak):
    t0, pl0, _ = _free_ring(0.0)
    t1, pl1, _ = _free_ring(k_leak)
    w0, s0 = _frequency_and_decay(t0, pl0)
    w1, s1 = _frequency_and_decay(t1, pl1)
    assert s1 > 1.3 * s0
    # zeta_h = d V w_h / (4 beta A^2) + m K_l w_h / (2 A^2) (Eq. 2-6, laminar K_l = k_l)
    wh = P0.hydraulic_natural_frequency_rad_s
    a, m, v, b = P0.piston_area_m2, P0.mass_kg, P0.chamber_volume_m3, P0.bulk_modulus_pa
    zeta0 = P0.viscous_damping_n_s_per_m * v * wh / (4 * b * a**2)
    zeta1 = zeta0 + m * k_leak * wh / (2 * a**2)
    assert s0 / w0 == pytest.approx(zeta0, rel=0.05)
    assert s1 / w1 == pytest.approx(zeta1, rel=0.05)


def test_turbulent_leak_also_damps_faster():
    t0, pl0, _ = _free_ring(0.0)
    t1, pl1, _ = _free_ring(5e-9, "turbulent")
    assert _frequency_and_decay(t1, pl1)[1] > 2 * _frequency_and_decay(t0, pl0)[1]


def test_spring_steady_state_force_balance():
    rec = simulate_vca(duration=3.0, leak_lpm=None, load="spring", sensors=False,
                       reference=np.full(3000, 10e-3), seed=0)
    x, dp = rec["x"][-1], rec["p1"][-1] - rec["p2"][-1]
    k_s = VCAParams().spring_stiffness_n_per_m
    assert x == pytest.approx(10e-3, abs=0.05e-3)
    # (P1 - P2) A = k_s x at rest (friction vanishes at v = 0)
    assert dp * VCAParams().piston_area_m2 == pytest.approx(k_s * x, rel=0.01)


def test_pressures_stay_between_tank_and_supply_on_violent_steps():
    # full-stroke reference jumps saturate the valve and hit the end stops
    ref = np.where((np.arange(4000) // 1000) % 2 == 0, 0.35, -0.35)
    rec = simulate_vca(duration=4.0, leak_lpm=None, sensors=False, reference=ref, seed=0)
    p = VCAParams()
    for ch in ("p1", "p2"):
        assert rec[ch].min() >= p.tank_pressure_pa
        assert rec[ch].max() <= p.supply_pressure_pa
    # the end stops hold the piston near +-L/2 (1e8 N/m stop: a few tenths of a mm)
    assert np.abs(rec["x"]).max() <= p.stroke_m / 2 + 1e-3
    assert np.abs(rec["x"]).max() > p.stroke_m / 2 - 1e-3


def test_closed_loop_tracks_steps():
    rec = simulate_vca(duration=20.0, leak_lpm=None, sensors=True, seed=4)
    err = rec["x"] - rec["x_ref"]
    edges = np.flatnonzero(np.diff(rec["x_ref"])) + 1
    # 0.8 s after every step the error is below 0.1 mm (a few encoder counts)
    settled = [abs(err[i + 800]) for i in edges if i + 800 < rec.n_samples]
    assert len(settled) > 3
    assert max(settled) < 0.1e-3


def test_leak_needs_more_control_at_steady_state_under_spring():
    # with a leak under a spring load the valve must stay open to feed the leak
    ref = np.full(4000, 15e-3)
    kw = dict(duration=4.0, load="spring", sensors=False, reference=ref, seed=0, onset=0.0)
    no = simulate_vca(leak_lpm=None, **kw)
    yes = simulate_vca(leak_lpm=0.5, **kw)
    assert abs(no["u"][-1]) < 1e-3
    # u = Q_leak / (kv Kv w sqrt(Ps - P1)) at rest: a positive hold current
    p = VCAParams()
    q = yes["leak_flow"][-1]
    u_expected = q / (p.spool_gain_m_per_v * p.valve_flow_gain_m1_5_per_kg0_5
                      * p.orifice_area_gradient_m * np.sqrt(p.supply_pressure_pa - yes["p1"][-1]))
    assert yes["u"][-1] == pytest.approx(u_expected, rel=1e-3)
    # the same flow leaves chamber 2 through the matched orifice: Ps - P1 = P2 - Pt
    assert yes["p1"][-1] + yes["p2"][-1] == pytest.approx(p.supply_pressure_pa, rel=1e-3)


def test_fixed_gain_controller_zero_gains_keep_valve_closed():
    res = integrate_closed_loop(np.full(500, 5e-3), 1000.0, 4, VCAParams().to_array(),
                                FixedGainController(0.0, 0.0, 0.0).to_array(), 10.0, 0.0,
                                LeakSchedule().to_array(), OperatingConditions().to_array(0.5),
                                [0, 0, P_MID, P_MID, 0, 0])
    assert np.all(res.u == 0.0)
    assert np.all(res.state[:, 0] == 0.0)


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-0.29, 0.29),
    v=st.floats(-0.5, 0.5),
    p1=st.floats(0.1e6, 17e6),
    p2=st.floats(0.1e6, 17e6),
    k_leak=st.floats(0.0, 1e-7),
    laminar=st.booleans(),
)
def test_closed_valve_conserves_fluid_volume(x, v, p1, p2, k_leak, laminar):
    """Valve closed: V1 dP1/beta + V2 dP2/beta = 0 (what leaves chamber 1 enters chamber 2)."""
    prm = P0.to_array("laminar" if laminar else "turbulent", "none")
    k = k_leak * 1e-4 if laminar else k_leak
    d = vca_rhs(0.0, np.array([x, v, p1, p2, 0.0, 0.0]), default_inputs(0.0, k), prm)
    a, vol, b = P0.piston_area_m2, P0.chamber_volume_m3, P0.bulk_modulus_pa
    dv1 = (vol + a * x) * d[2] / b  # fluid volume rate into chamber 1 (compressibility)
    dv2 = (vol - a * x) * d[3] / b
    assert dv1 + dv2 == pytest.approx(0.0, abs=1e-12 * (1 + abs(dv1)))
    # and the leak flows from high to low pressure
    q = dv1 + a * v  # = -Q_l with the valve closed
    assert q * np.sign(p1 - p2) <= 1e-12 * abs(a * v) + 1e-30
