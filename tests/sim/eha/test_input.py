"""simulate_eha's input hook (issue 6): the structured test input drives the EHA."""

import numpy as np
import pytest

from leakdiag.sim.eha.simulate import EHA_SENSORS, simulate_eha
from leakdiag.sim.eha.drive import EHAConditions
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.excitation import PeriodicSteps, structured_excitation

STEPS = structured_excitation("eha")


def test_structured_eha_input_is_the_documented_step_waveform():
    rec = simulate_eha(duration=3.0, leak_lpm=None, sensors=False, input_signal=STEPS)
    u = rec["u"]
    # docs/literature.md: -3 V for the first quarter period, then +3 V / -3 V every half period
    assert np.all(u[:250] == -3.0)
    assert np.all(u[250:750] == 3.0)
    assert np.all(u[750:1250] == -3.0)
    assert np.all(u[1250:1750] == 3.0)
    assert rec.meta["input_signal"] == repr(STEPS)


def test_measured_command_is_the_input_within_half_a_dac_step():
    rec = simulate_eha(duration=2.0, leak_lpm=None, input_signal=STEPS)
    p = EHAParams()
    half_step = p.command_limit_v / 2.0**EHA_SENSORS.control_dac_bits
    assert np.max(np.abs(rec["u"] - STEPS.samples(rec.time))) <= half_step + 1e-12


def test_piston_swings_about_mid_stroke_by_the_pump_flow():
    rec = simulate_eha(duration=4.0, leak_lpm=None, sensors=False, input_signal=STEPS)
    p = EHAParams()
    x = rec["x"][1000:]  # after the first period
    # a flow source at full 3 V speed for a whole half period would move the piston
    # q w T/2 / A; the motor needs time to reverse, so the swing is somewhat less, never more
    w = min(3.0 * p.speed_command_gain_rad_per_s_per_v, p.max_pump_speed_rad_per_s)
    ideal = p.pump_flow_per_rad_m3 * w * 0.5 / p.piston_area_m2
    assert 0.8 * ideal < np.ptp(x) <= ideal
    assert abs(0.5 * (x.max() + x.min())) < 0.15 * ideal  # about mid-stroke


@pytest.mark.parametrize("target", [0.2, 1.2])
def test_leak_calibrates_to_target_within_2_percent_under_steps(target):
    rec = simulate_eha(duration=12.0, onset=6.0, leak_lpm=target, sensors=False,
                       input_signal=STEPS)
    achieved = np.mean(np.abs(rec["leak_flow"][6000:])) * 60_000
    assert achieved == pytest.approx(rec.meta["leak_lpm_achieved"], rel=1e-12)
    assert abs(achieved - target) <= 0.02 * target


def test_array_input_equals_the_object_input():
    a = simulate_eha(duration=2.0, leak_lpm=None, seed=4, input_signal=STEPS)
    b = simulate_eha(duration=2.0, leak_lpm=None, seed=4,
                     input_signal=STEPS.samples(np.arange(2000) / 1000.0))
    for name in a.channel_names:
        np.testing.assert_array_equal(a[name], b[name])


def test_closed_loop_input_is_the_position_reference():
    ref = PeriodicSteps(0.01, period_s=2.0)
    rec = simulate_eha(duration=2.0, leak_lpm=None, mode="closed-loop", sensors=False,
                       input_signal=ref)
    np.testing.assert_array_equal(rec["x_ref"], ref.samples(rec.time))


def test_input_signal_errors_name_the_problem():
    with pytest.raises(ValueError, match=r"input_signal has shape \(5,\); expected \(2000,\)"):
        simulate_eha(duration=2.0, leak_lpm=None, input_signal=np.zeros(5))
    with pytest.raises(ValueError, match="non-finite"):
        simulate_eha(duration=2.0, leak_lpm=None, input_signal=np.full(2000, np.nan))
    with pytest.raises(ValueError, match="cannot be combined"):
        simulate_eha(duration=2.0, leak_lpm=None, input_signal=STEPS,
                     conditions=EHAConditions(amplitude_variation=0.05))
