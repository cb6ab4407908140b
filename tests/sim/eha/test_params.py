"""EHAParams: Table 3-1 values, decided values, derived quantities, validation, TOML."""

import dataclasses
import math

import numpy as np
import pytest

from leakdiag.sim.eha.params import _FIELD_ORDER, N_PARAMS, P_CLOSED, P_KFREE, P_KRESTR, EHAParams


def test_table_3_1_values():
    p = EHAParams()
    assert p.preload_force_n == 25.0
    assert p.mass_kg == 12.3
    assert p.viscous_damping_n_s_per_m == 300.0
    assert p.stroke_m == 0.6
    assert p.piston_area_m2 == pytest.approx(633e-6)
    assert p.velocity_threshold_m_per_s == 0.01
    assert p.pump_displacement_m3_per_rev == pytest.approx(4.9e-6)
    assert p.bulk_modulus_pa == 689e6
    assert p.motor_resistance_ohm == 0.73
    assert p.motor_inductance_h == pytest.approx(3.55e-3)
    assert p.back_emf_v_s_per_rad == p.torque_constant_n_m_per_a == 0.6963
    assert p.inertia_kg_m2 == 0.000874
    assert p.fluid_density_kg_per_m3 == 847.0
    assert p.orifice_discharge_coefficient == 0.92
    assert p.line_diameter_m == 7e-3


def test_decided_geometry_hand_values():
    p = EHAParams()
    # pi * 7^2 / 4 = 38.4845 mm^2; k = 0.1 gives the 3.85 mm^2 printed in Table 3-1
    assert p.line_area_m2 == pytest.approx(38.4845e-6, rel=1e-5)
    assert p.restricted_orifice_area_m2 == pytest.approx(3.848e-6, rel=1e-3)
    # chamber volume 234 cm^3 exceeds the half-stroke swept volume 633e-6 * 0.3 = 190 cm^3
    assert p.chamber_volume_m3 == pytest.approx(234e-6)
    # 4.9 cm^3/rev * 4000 rpm = 19.6 L/min
    assert p.rated_pump_flow_lpm == pytest.approx(19.6, rel=1e-12)
    assert p.pump_flow_per_rad_m3 == pytest.approx(4.9e-6 / (2 * math.pi))
    # leaks of 0.77-1.63 L/min are 4-8 % of the rated flow
    assert 3.9 < 100 * 0.77 / p.rated_pump_flow_lpm < 100 * 1.63 / p.rated_pump_flow_lpm < 8.4


def test_field_order_matches_dataclass():
    assert tuple(f.name for f in dataclasses.fields(EHAParams)) == _FIELD_ORDER


def test_to_array_layout():
    p = EHAParams()
    arr = p.to_array(closed_loop=True)
    assert arr.shape == (N_PARAMS,)
    for i, name in enumerate(_FIELD_ORDER):
        assert arr[i] == getattr(p, name)
    k = 0.92 * math.sqrt(2 / 847.0)
    assert arr[P_KFREE] == pytest.approx(k * p.line_area_m2, rel=1e-12)
    assert arr[P_KRESTR] / arr[P_KFREE] == pytest.approx(0.1, rel=1e-12)
    assert arr[P_CLOSED] == 1.0 and p.to_array()[P_CLOSED] == 0.0


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        ({"mass_kg": 0.0}, ValueError, "mass_kg=0.0 must be a finite number > 0"),
        ({"bulk_modulus_pa": float("nan")}, ValueError, "bulk_modulus_pa=nan"),
        ({"preload_force_n": -1.0}, ValueError, "preload_force_n=-1.0 must be a finite number >= 0"),
        ({"orifice_area_ratio": 1.5}, ValueError, "orifice_area_ratio=1.5 must be in"),
        ({"chamber_volume_m3": 234e-9}, ValueError, "chamber_volume_m3=2.34e-07 must exceed"),
        ({"stroke_m": "long"}, TypeError, "stroke_m='long' must be a number"),
    ],
)
def test_validation_messages(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        EHAParams(**kwargs)


def test_zero_allowed_where_physical():
    p = EHAParams(preload_force_n=0, pump_internal_leakage_m3_per_s_pa=0)
    assert p.preload_force_n == 0.0 and isinstance(p.preload_force_n, float)


def test_from_toml_and_dict(tmp_path):
    f = tmp_path / "eha.toml"
    f.write_text("[eha]\nmass_kg = 15.0\nline_volume_m3 = 4e-5\n")
    p = EHAParams.from_toml(f)
    assert p.mass_kg == 15.0 and p.line_volume_m3 == 4e-5
    assert p.stroke_m == 0.6
    assert EHAParams.from_dict(p.to_dict()) == p
    bad = tmp_path / "bad.toml"
    bad.write_text("mass_kilograms = 3\n")
    with pytest.raises(ValueError, match=r"bad.toml: unknown EHAParams field\(s\) \['mass_kilograms'\]"):
        EHAParams.from_toml(bad)


def test_frozen_and_replace():
    p = EHAParams()
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'mass_kg'"):
        p.mass_kg = 1.0  # type: ignore[misc]
    q = dataclasses.replace(p, accumulator_pressure_pa=2e6)
    assert q.accumulator_pressure_pa == 2e6 and np.isfinite(q.to_array()).all()
