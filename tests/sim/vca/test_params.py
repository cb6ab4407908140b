"""VCAParams: Table 2-1 in SI, derived values, validation, TOML loading, array layout."""

import dataclasses
import math

import numpy as np
import pytest

from leakdiag.sim import VCAParams
from leakdiag.sim.vca.params import P_INDEX


def test_table_2_1_in_si():
    p = VCAParams()
    assert p.supply_pressure_pa == 17.2e6
    assert p.mass_kg == 12.3
    assert p.viscous_damping_n_s_per_m == 250.0
    assert p.stroke_m == 0.6
    assert p.piston_area_m2 == pytest.approx(633e-6)
    # annulus of a 38.1 mm bore with 25.4 mm rods (Sec. 2.2) is 633 mm^2
    assert p.piston_area_m2 == pytest.approx(math.pi / 4 * (38.1e-3**2 - 25.4e-3**2), rel=1e-3)
    assert p.chamber_volume_m3 == pytest.approx(234e-6)
    assert p.orifice_area_gradient_m == pytest.approx(20.75e-3)
    assert p.spool_gain_m_per_v == pytest.approx(4.06e-5)
    assert p.valve_flow_gain_m1_5_per_kg0_5 == 0.0292
    assert p.valve_natural_frequency_hz == 150.0
    assert p.valve_damping_ratio == 0.7
    assert p.bulk_modulus_pa == 689e6


def test_derived_values_by_hand():
    p = VCAParams()
    # omega_h = sqrt(2 * 689e6 * 633e-6^2 / (12.3 * 234e-6)) = 437.99 rad/s (69.7 Hz)
    assert p.hydraulic_natural_frequency_rad_s == pytest.approx(437.99, abs=0.01)
    # rated: 0.0292 * 20.75e-3 * 0.406e-3 * sqrt(8.6e6) m^3/s = 7.215e-4 m^3/s = 43.29 L/min
    assert p.rated_flow_lpm == pytest.approx(43.29, abs=0.01)
    assert p.max_spool_m == pytest.approx(0.406e-3)


def test_to_array_layout():
    p = VCAParams()
    a = p.to_array("laminar", "spring")
    assert a.shape == (len(P_INDEX),)
    assert a[P_INDEX["omega_v"]] == pytest.approx(2 * np.pi * 150)
    assert a[P_INDEX["half_stroke"]] == 0.3
    assert a[P_INDEX["leak_model"]] == 1.0
    assert a[P_INDEX["k_spring"]] == p.spring_stiffness_n_per_m
    assert p.to_array("turbulent", "none")[P_INDEX["k_spring"]] == 0.0


@pytest.mark.parametrize(
    "change, exc, match",
    [
        ({"mass_kg": 0.0}, ValueError, "mass_kg=0.0 must be a finite number > 0"),
        ({"bulk_modulus_pa": float("inf")}, ValueError, "bulk_modulus_pa=inf must be"),
        ({"coulomb_friction_n": -1.0}, ValueError, "coulomb_friction_n=-1.0 must be"),
        ({"tank_pressure_pa": 20e6}, ValueError, "tank_pressure_pa=20000000.0 must be below"),
        ({"chamber_volume_m3": 100e-6}, ValueError, "chamber_volume_m3=0.0001 must exceed"),
        ({"mass_kg": "heavy"}, TypeError, "mass_kg='heavy' must be a number"),
    ],
)
def test_validation(change, exc, match):
    with pytest.raises(exc, match=match):
        dataclasses.replace(VCAParams(), **change)


def test_bad_leak_model_or_load():
    with pytest.raises(ValueError, match="leak_model='x' must be one of"):
        VCAParams().to_array("x")
    with pytest.raises(ValueError, match="load='x' must be one of"):
        VCAParams().to_array("turbulent", "x")


def test_from_toml(tmp_path):
    f = tmp_path / "rig.toml"
    f.write_text("[vca]\nmass_kg = 24.6\nsupply_pressure_pa = 10e6\n")
    p = VCAParams.from_toml(f)
    assert p.mass_kg == 24.6 and p.supply_pressure_pa == 10e6
    assert p.bulk_modulus_pa == 689e6  # default kept
    assert p.hydraulic_natural_frequency_rad_s == pytest.approx(437.99 / math.sqrt(2), abs=0.01)
    g = tmp_path / "flat.toml"
    g.write_text("mass_kg = 5\n")
    assert VCAParams.from_toml(g).mass_kg == 5.0


def test_from_toml_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("mass = 3\n")
    with pytest.raises(ValueError, match=r"bad.toml: unknown VCA parameter\(s\) \['mass'\]"):
        VCAParams.from_toml(bad)
    neg = tmp_path / "neg.toml"
    neg.write_text("mass_kg = -3\n")
    with pytest.raises(ValueError, match="neg.toml: mass_kg=-3"):
        VCAParams.from_toml(neg)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        VCAParams.from_toml(tmp_path / "missing.toml")


def test_frozen_and_dict_roundtrip():
    p = VCAParams()
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'mass_kg'"):
        p.mass_kg = 1.0
    assert VCAParams(**p.to_dict()) == p
