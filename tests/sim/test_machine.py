"""Virtual machines: reproducible per-unit tolerances of the VCA and EHA rigs."""

import dataclasses
import json

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.sim import machine as mach
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.leak import LeakSchedule
from leakdiag.sim.machine import EHAMachine, VCAMachine, draw_machine, resolve_machine
from leakdiag.sim.sensor_chain import antialias_sos
from leakdiag.sim.sensors import SensorParams, measure_pressure
from leakdiag.sim.vca.conditions import OperatingConditions
from leakdiag.sim.vca.control import FixedGainController
from leakdiag.sim.vca.integrate import integrate_closed_loop
from leakdiag.sim.vca.model import default_inputs, vca_rhs
from leakdiag.sim.vca.params import VCAParams
from leakdiag.sim.reference import SampledReference


# ------------------------------------------------------------------ drawing
def test_draw_is_reproducible_and_units_differ():
    assert draw_machine("vca", 17) == draw_machine("vca", 17)
    assert draw_machine("vca", 17) != draw_machine("vca", 18)
    assert draw_machine("eha", 17) == draw_machine("eha", 17)
    assert draw_machine("vca", 3).unit == 3 and draw_machine("eha", 3).system == "eha"


def test_draws_fill_their_tolerance_bands():
    vca = [draw_machine("vca", u) for u in range(300)]
    eha = [draw_machine("eha", u) for u in range(300)]

    def check(values, lo, hi):
        values = np.asarray(values)
        assert values.min() >= lo and values.max() <= hi
        # uniform over the band: 300 draws come within 3 % of the band's width of each end
        assert values.min() < lo + 0.03 * (hi - lo) and values.max() > hi - 0.03 * (hi - lo)

    check([m.valve_flow_gain_factor for m in vca], 0.95, 1.05)
    check([m.valve_null_offset_v for m in vca], -0.1, 0.1)  # 1 % of the 10 V rated input
    check([m.valve_null_shift_v_per_k for m in vca], -0.2 / 38, 0.2 / 38)
    check([m.valve_bandwidth_factor for m in vca], 0.8, 1.2)
    check([m.supply_pressure_factor for m in vca], 0.98, 1.02)
    check([m.bulk_modulus_factor for m in vca], 0.9, 1.1)
    check([np.log(m.valve_null_leakage_lpm()) for m in vca], np.log(0.05), np.log(0.3))
    fs = SensorParams().pressure_full_scale_pa
    check([m.p1_offset_pa for m in vca], -0.0025 * fs, 0.0025 * fs)
    check([m.p2_gain for m in eha], 0.9975, 1.0025)
    check([m.antialias_cutoff_hz for m in vca], 225.0, 275.0)
    check([m.pump_displacement_factor for m in eha], 0.98, 1.02)
    check([np.log(m.pump_internal_leakage_factor) for m in eha], np.log(0.5), np.log(2.0))
    check([m.motor_constant_factor for m in eha], 0.9, 1.1)
    # independent draws: flow gain and supply of the same units are uncorrelated
    r = np.corrcoef([m.valve_flow_gain_factor for m in vca],
                    [m.supply_pressure_factor for m in vca])[0, 1]
    assert abs(r) < 0.2


def test_machine_stream_is_independent_of_the_run_seed():
    a = ld.sim.simulate_vca(duration=1.0, leak_lpm=None, seed=1, machine=5)
    b = ld.sim.simulate_vca(duration=1.0, leak_lpm=None, seed=2, machine=5)
    assert a.meta["machine"] == b.meta["machine"] == draw_machine("vca", 5).to_dict()
    assert not np.array_equal(a["p1"], b["p1"])  # the noise still follows the seed


def test_nominal_machine_is_bit_identical_to_no_machine():
    kw = dict(duration=3.0, leak_lpm=0.1, onset=1.0, seed=4, load="spring")
    a = ld.sim.simulate_vca(**kw)
    b = ld.sim.simulate_vca(**kw, machine=VCAMachine())
    for name in a.channel_names:
        assert np.array_equal(a[name], b[name]), name
    assert a.meta["machine"]["unit"] is None and VCAMachine.from_dict(a.meta["machine"]).is_nominal
    e1 = ld.sim.simulate_eha(duration=2.0, leak_lpm=None, seed=4)
    e2 = ld.sim.simulate_eha(duration=2.0, leak_lpm=None, seed=4, machine=EHAMachine())
    for name in e1.channel_names:
        assert np.array_equal(e1[name], e2[name]), name
    assert EHAParams.from_dict(e1.meta["params"]) == EHAParams()


def test_meta_round_trip_and_json():
    rec = ld.sim.simulate_eha(duration=1.0, leak_lpm=None, machine=17)
    json.dumps(rec.meta["machine"])
    assert EHAMachine.from_dict(rec.meta["machine"]) == draw_machine("eha", 17)
    m = draw_machine("eha", 17)
    assert EHAParams.from_dict(rec.meta["params"]) == m.apply_params(EHAParams())
    assert rec.meta["sensors"]["p2_offset_pa"] == m.p2_offset_pa


# ------------------------------------------------------------------ physics of the deviations
def test_apply_params_multiplies_and_adds():
    m = VCAMachine(valve_flow_gain_factor=1.05, valve_bandwidth_factor=0.8,
                   supply_pressure_factor=1.02, bulk_modulus_factor=0.9,
                   valve_null_offset_v=0.05, valve_leakage_m3_per_s_pa=2e-13)
    p = m.apply_params(VCAParams(valve_null_offset_v=0.01))
    assert p.valve_flow_gain_m1_5_per_kg0_5 == pytest.approx(0.0292 * 1.05, rel=1e-15)
    assert p.valve_natural_frequency_hz == pytest.approx(120.0, rel=1e-15)
    assert p.supply_pressure_pa == pytest.approx(17.544e6, rel=1e-15)
    assert p.bulk_modulus_pa == pytest.approx(620.1e6, rel=1e-15)
    assert p.valve_null_offset_v == pytest.approx(0.06, rel=1e-15)
    # null leakage c_v (P_s - P_r) = 2e-13 * 17.544e6 m^3/s = 0.2105 L/min
    assert m.valve_null_leakage_lpm() == pytest.approx(2e-13 * 17.544e6 * 60_000, rel=1e-12)
    e = EHAMachine(motor_constant_factor=1.1, pump_internal_leakage_factor=2.0)
    q = e.apply_params(EHAParams())
    assert q.torque_constant_n_m_per_a == q.back_emf_v_s_per_rad == pytest.approx(0.6963 * 1.1)
    assert q.pump_internal_leakage_m3_per_s_pa == pytest.approx(1.3e-12)


def test_valve_spool_leakage_in_the_model():
    # valve closed, P1 = 10 MPa, P2 = 5 MPa, at rest: only the land leakage moves the pressures
    # dP1/dt = beta/V * c (Ps + Pr - 2 P1) = 689e6/234e-6 * 1e-12 * (17.2e6 - 20e6)
    prm = VCAParams(valve_leakage_m3_per_s_pa=1e-12).to_array()
    d = vca_rhs(0.0, np.array([0.0, 0.0, 10e6, 5e6, 0.0, 0.0]), default_inputs(), prm)
    beta_v = 689e6 / 234e-6
    assert d[2] == pytest.approx(beta_v * 1e-12 * (17.2e6 - 20e6), rel=1e-12)
    assert d[3] == pytest.approx(beta_v * 1e-12 * (17.2e6 - 10e6), rel=1e-12)


def _hold(value, n):
    return SampledReference(np.full(n, value))


def test_null_offset_is_cancelled_by_the_integral_and_drifts_with_temperature():
    # held position, no load, no leak, ideal sensors: at rest the spool must sit at null, so
    # the command settles at -(u0 + s_T dT(t)); the temperature rises 0 -> 10 K over 20 s
    m = VCAMachine(valve_null_offset_v=0.08, valve_null_shift_v_per_k=-0.004)
    n = 20_000
    rec = ld.sim.simulate_vca(duration=20.0, leak_lpm=None, sensors=False, machine=m,
                              reference=_hold(5e-3, n),
                              conditions=OperatingConditions(temperature_rise_k=10.0))
    t, u = rec.time, rec["u"]
    want = -(0.08 - 0.004 * 10.0 * t / 20.0)
    late = t > 5.0
    np.testing.assert_allclose(u[late], want[late], atol=2e-4)
    assert abs(np.mean(rec["x"][late]) - 5e-3) < 2e-5


def test_pump_displacement_sets_piston_speed_at_fixed_motor_speed():
    # the PI speed loop holds w = K_w u whatever the pump, so A v = q_b w / 2 pi scales with q_b
    kw = dict(duration=2.0, leak_lpm=None, sensors=False, input_signal=np.full(2000, 1.0))
    a = ld.sim.simulate_eha(**kw)
    b = ld.sim.simulate_eha(**kw, machine=EHAMachine(pump_displacement_factor=1.02))
    va = np.gradient(a["x"], 1e-3)[1000:].mean()
    vb = np.gradient(b["x"], 1e-3)[1000:].mean()
    assert vb / va == pytest.approx(1.02, rel=1e-3)
    np.testing.assert_allclose(b["speed"][1000:], a["speed"][1000:], rtol=1e-4)


# ------------------------------------------------------------------ sensor errors
def _closed_loop(sens, sos=None, n=1500):
    prm = VCAParams().to_array()
    return integrate_closed_loop(
        np.full(n, 4e-3), 1000.0, 4, prm, FixedGainController().to_array(), 10.0, 0.0,
        LeakSchedule().to_array(), OperatingConditions().to_array(n / 1000.0),
        [0, 0, 8.6e6, 8.6e6, 0, 0], np.zeros(n), np.zeros(n), sens, antialias_sos=sos)


def test_transducer_gain_and_offset_in_the_loop():
    sp = SensorParams()
    q = sp.pressure_quantum_pa
    sens = [sp.position_resolution_m, sp.pressure_full_scale_pa, q, 20 / 4096,
            1.004, 30e3, 0.997, -20e3]
    res = _closed_loop(sens)
    top = sp.pressure_full_scale_pa - q
    want1 = np.clip(np.round((1.004 * res.state[:, 2] + 30e3) / q) * q, 0, top)
    want2 = np.clip(np.round((0.997 * res.state[:, 3] - 20e3) / q) * q, 0, top)
    np.testing.assert_array_equal(res.measured[:, 1], want1)
    np.testing.assert_array_equal(res.measured[:, 2], want2)


def test_antialias_filter_in_the_loop_matches_the_sensor_chain():
    sp = SensorParams(pressure_noise_std_pa=0.0, p1_gain=1.002, p1_offset_pa=5e3,
                      antialias_cutoff_hz=250.0)
    q = sp.pressure_quantum_pa
    sens = [sp.position_resolution_m, sp.pressure_full_scale_pa, q, 20 / 4096,
            1.002, 5e3, 1.0, 0.0]
    res = _closed_loop(sens, antialias_sos(250.0, 1000.0))
    ref = measure_pressure(res.state[:, 2], sp, np.random.default_rng(0), channel="p1",
                           sample_rate=1000.0)
    diff = np.abs(res.measured[:, 1] - ref)
    # same recursion as scipy's sosfilt: equal except for rare rounding ties (one quantum)
    assert diff.max() <= q * (1 + 1e-12) and np.mean(diff > 0) < 0.01


def test_drawn_unit_still_tracks_and_records_its_machine():
    rec = ld.sim.simulate_vca(duration=10.0, leak_lpm=None, seed=2, machine=17, load="spring")
    e = rec["x_ref"] - rec["x"]
    assert np.sqrt(np.mean(e[2000:] ** 2)) < 2e-3
    m = draw_machine("vca", 17)
    assert rec.meta["machine"] == m.to_dict()
    assert rec.meta["sensors"]["antialias_cutoff_hz"] == m.antialias_cutoff_hz
    assert VCAParams(**rec.meta["params"]) == m.apply_params(VCAParams())


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("call, exc, match", [
    (lambda: draw_machine("pump", 1), ValueError, r"system='pump' must be one of \['vca', 'eha'\]"),
    (lambda: draw_machine("vca", -1), ValueError, "unit=-1 must be a non-negative integer"),
    (lambda: resolve_machine(EHAMachine(), "vca"), TypeError,
     "machine must be None, a unit number .* or a VCAMachine; got EHAMachine"),
    (lambda: resolve_machine("17", "eha"), TypeError, "got str"),
    (lambda: VCAMachine(valve_flow_gain_factor=0.0), ValueError,
     "valve_flow_gain_factor=0.0 must be > 0"),
    (lambda: VCAMachine(valve_leakage_m3_per_s_pa=-1e-13), ValueError, "must be >= 0"),
    (lambda: EHAMachine(p1_offset_pa=float("nan")), ValueError, "p1_offset_pa=nan must be"),
    (lambda: VCAMachine.from_dict({"system": "eha"}), ValueError, "does not match VCAMachine"),
    (lambda: EHAMachine.from_dict({"pump": 1.0}), ValueError, r"unknown EHAMachine field"),
    (lambda: ld.sim.simulate_vca(duration=1.0, leak_lpm=None, machine=3, sample_rate=400.0),
     ValueError, r"antialias_cutoff_hz=.* must be below the Nyquist frequency of "
                 r"sample_rate=400 Hz"),
    (lambda: ld.sim.simulate_eha(duration=1.0, leak_lpm=None, machine=3, sample_rate=400.0),
     ValueError, "must be below the Nyquist frequency"),
])
def test_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_public_names():
    assert ld.sim.VCAMachine is VCAMachine and ld.sim.EHAMachine is EHAMachine
    assert ld.sim.draw_machine is draw_machine
    assert dataclasses.is_dataclass(VCAMachine) and mach.MACHINE_SYSTEMS == ("vca", "eha")


@pytest.mark.parametrize("system", ["vca", "eha"])
def test_every_deviation_has_one_rule(system):
    """One code path: each parameter deviation of a machine is one row of its _APPLY table,
    and each row names a field of the rig's parameters."""
    from dataclasses import fields

    from leakdiag.sim import VCAParams

    cls = mach.MACHINES[system]
    params = {f.name for f in fields(VCAParams if system == "vca" else EHAParams)}
    sensor_fields = {"unit", "p1_offset_pa", "p2_offset_pa", "p1_gain", "p2_gain",
                     "antialias_cutoff_hz"}
    deviations = {f.name for f in fields(cls)} - sensor_fields
    assert {name for name, _, _ in cls._APPLY} == deviations
    assert all(target in params and op in ("mul", "add") for _, target, op in cls._APPLY)
    # a hand-made unit moves exactly its parameters: +1 % on one factor -> x1.01 on its target
    name, target, op = cls._APPLY[0]
    base = (VCAParams if system == "vca" else EHAParams)()
    moved = cls(**{name: 1.01 if op == "mul" else 0.01}).apply_params(base)
    changed = {k for k, v in moved.to_dict().items() if v != base.to_dict()[k]}
    assert changed == {target}
