"""Simulator arguments a researcher can get wrong (a simulator audit, 2026-11-29): each is
refused naming the argument, before any work, instead of running another experiment than the
one asked for or failing inside the run."""

import re

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.sim import OperatingConditions
from leakdiag.sim.eha.drive import EHAConditions


@pytest.mark.parametrize("simulate", [ld.sim.simulate_vca, ld.sim.simulate_eha])
@pytest.mark.parametrize("kw,error,words", [
    (dict(onset=True, leak_lpm=0.1), ValueError, "onset=True must be a number of seconds, "
                                                 "not a bool"),
    (dict(sensors="no"), TypeError, "sensors='no' must be True or False"),
    (dict(sensors=0), TypeError, "sensors=0 must be True or False"),
    (dict(progress=1), TypeError, "progress=1 must be a callable progress(n_samples) or None"),
    (dict(calibration_rtol=5), ValueError, "calibration_rtol=5 must be below 1"),
    (dict(calibration_rtol=0), ValueError, "calibration_rtol"),
    (dict(sensor_params=1), TypeError, "sensor_params must be a SensorParams, got int"),
])
def test_arguments_are_refused_naming_them(simulate, kw, error, words):
    kw = {"duration": 2.0, "leak_lpm": None, **kw}
    with pytest.raises(error, match=re.escape(words)):
        simulate(**kw)


def test_the_tolerance_of_a_calibrated_leak_is_in_the_metadata():
    rec = ld.sim.simulate_vca(duration=20.0, leak_lpm=0.1, onset=8.0, calibration_rtol=0.05)
    assert rec.meta["calibration_rtol"] == 0.05
    assert abs(rec.meta["leak_lpm_achieved"] / 0.1 - 1) <= 0.05
    assert ld.sim.simulate_eha(duration=2.0, leak_lpm=None).meta["calibration_rtol"] == 0.02


def test_an_eha_command_beyond_its_limit_is_refused_not_clipped():
    """amplitude=100 ran at the 10-V limit with meta["amplitude"] 100 (the piston on its end
    stop); an input signal beyond it the same."""
    with pytest.raises(ValueError, match=r"amplitude=100 V, beyond the command limit of \+-10 V"):
        ld.sim.simulate_eha(duration=2.0, leak_lpm=None, amplitude=100.0)
    with pytest.raises(ValueError, match=r"input_signal reaches 12 V, beyond the command limit"):
        ld.sim.simulate_eha(duration=2.0, leak_lpm=None, input_signal=np.full(2000, 12.0))
    rec = ld.sim.simulate_eha(duration=2.0, leak_lpm=None, amplitude=10.0)
    assert rec.meta["amplitude"] == 10.0


def test_a_given_eha_coefficient_beyond_the_pump_flow_is_refused():
    with pytest.raises(ValueError, match=r"leak_coefficient=0.001 delivers a mean leak of "
                                         r"3.\d+ L/min, beyond 75% of the mean pump flow"):
        ld.sim.simulate_eha(duration=20.0, leak_lpm=1.0, onset=10.0, leak_coefficient=1e-3)


@pytest.mark.parametrize("cls", [OperatingConditions, EHAConditions])
def test_conditions_take_numbers_only(cls):
    with pytest.raises(TypeError, match=r"spring_change_time_s=True must be a number of "
                                        r"seconds or None, not a bool"):
        cls(spring_change_time_s=True)
    with pytest.raises(TypeError, match=r"temperature_rise_k='5' must be a number"):
        cls(temperature_rise_k="5")
    with pytest.raises(TypeError, match=r"temperature_rise_k=None must be a number"):
        cls(temperature_rise_k=None)
    with pytest.raises(ValueError, match=r"spring_change_time_s=-5 must be None or >= 0"):
        cls(spring_change_time_s=-5)
    assert cls(temperature_rise_k=np.float32(2.0)).temperature_rise_k == 2.0


def test_a_drive_above_nyquist_and_a_ripple_above_the_supply_are_refused():
    with pytest.raises(ValueError, match=r"frequency_rad_s=10000 must be below the Nyquist "
                                         r"frequency of sample_rate=1000 Hz"):
        ld.sim.simulate_eha(duration=2.0, leak_lpm=None, frequency_rad_s=1e4)
    with pytest.raises(ValueError, match=r"conditions.supply_ripple_pa=2e\+07 must be below the "
                                         r"supply pressure"):
        ld.sim.simulate_vca(duration=2.0, leak_lpm=None,
                            conditions=OperatingConditions(supply_ripple_pa=2e7))
