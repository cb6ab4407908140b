"""Sensor models (Sec. 2.2) and position references used by the VCA simulator."""

import numpy as np
import pytest

from leakdiag.sim import (
    ChirpReference,
    PseudoRandomSteps,
    SampledReference,
    SensorParams,
    SineReference,
    as_reference,
)
from leakdiag.sim.sensors import PSI_PA, adc_reading, measure_pressure, measure_position, quantize


def test_sensor_defaults_from_sec_2_2():
    s = SensorParams()
    assert s.pressure_full_scale_pa == pytest.approx(3000 * 6894.757, rel=1e-6)  # 20.68 MPa
    assert s.pressure_quantum_pa == pytest.approx(3000 * PSI_PA / 4096)
    assert s.position_resolution_m == 0.03e-3


def test_quantize_and_adc_hand_values():
    assert quantize(0.07, 0.03) == pytest.approx(0.06)
    assert quantize(-0.05, 0.03) == pytest.approx(-0.06)
    assert adc_reading(3.2, 0.0, 10.0, 1.0) == 3.0
    assert adc_reading(3.2, 0.4, 10.0, 1.0) == 4.0  # noise before the converter
    assert adc_reading(25.0, 0.0, 10.0, 1.0) == 9.0  # top code
    assert adc_reading(-2.0, 0.0, 10.0, 1.0) == 0.0  # gauge transducer cannot go below 0


def test_measure_pressure_noise_statistics():
    s = SensorParams()
    rng = np.random.default_rng(0)
    p = np.full(20_000, 8.6e6)
    m = measure_pressure(p, s, rng)
    # noise std 10 kPa plus uniform quantisation (q^2/12)
    expected = np.sqrt(s.pressure_noise_std_pa**2 + s.pressure_quantum_pa**2 / 12)
    assert np.std(m) == pytest.approx(expected, rel=0.02)  # 20000 samples: std error 0.5 %
    assert abs(np.mean(m) - 8.6e6) < 4 * expected / np.sqrt(m.size)  # 4 standard errors


def test_measure_position_strided_and_readonly():
    x = np.arange(10.0)[::2] * 1e-5
    x.flags.writeable = False
    out = measure_position(x, SensorParams())
    assert out.tolist() == pytest.approx([0.0, 3e-5, 3e-5, 6e-5, 9e-5])


def test_sensor_validation():
    with pytest.raises(ValueError, match="pressure_noise_std_pa=-1 must be >= 0"):
        SensorParams(pressure_noise_std_pa=-1)
    with pytest.raises(ValueError, match="pressure_adc_bits=0 must be in"):
        SensorParams(pressure_adc_bits=0)


def test_pseudorandom_steps_ranges_and_holds():
    ref = PseudoRandomSteps(min_amplitude_m=2e-3, max_amplitude_m=20e-3, min_hold_s=1.0,
                            max_hold_s=5.0)
    t = np.arange(0, 400, 0.001)
    x = ref.samples(t, np.random.default_rng(3))
    assert np.all((np.abs(x) >= 2e-3) & (np.abs(x) <= 20e-3))
    edges = np.flatnonzero(np.diff(x)) + 1
    holds = np.diff(edges) / 1000.0
    assert holds.min() >= 1.0 - 1e-9 and holds.max() <= 5.0 + 1e-9
    assert 400 / 5 <= len(edges) + 1 <= 400 / 1 + 1
    assert (x > 0).mean() == pytest.approx(0.5, abs=0.15)  # bipolar
    same = ref.samples(t, np.random.default_rng(3))
    assert np.array_equal(x, same)


def test_sine_chirp_sampled_hand_values():
    t = np.array([0.0, 0.5, 1.0])
    assert SineReference(2.0, 0.5, 1.0).samples(t, None) == pytest.approx([1.0, 3.0, 1.0])
    # linear chirp 0 -> 2 Hz over 1 s: phase 2 pi (t^2) -> sin(2 pi * 0.25) at t = 0.5
    assert ChirpReference(1.0, 0.0, 2.0, 1.0).samples(np.array([0.5]), None)[0] == \
        pytest.approx(1.0)
    assert SampledReference(np.array([1.0, 2.0, 3.0])).samples(np.zeros(2), None).tolist() == \
        [1.0, 2.0]


def test_as_reference_from_files(tmp_path):
    import pandas as pd

    np.save(tmp_path / "r.npy", np.array([1e-3, 2e-3]))
    assert as_reference(tmp_path / "r.npy").samples(np.zeros(3), None).tolist() == \
        [1e-3, 2e-3, 2e-3]
    pd.DataFrame({"x_ref": [0.5e-3, 1e-3]}).to_csv(tmp_path / "r.csv", index=False)
    assert as_reference(str(tmp_path / "r.csv")).samples(np.zeros(2), None).tolist() == \
        [0.5e-3, 1e-3]
    pd.DataFrame({"y": [1.0]}).to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(ValueError, match="no 'x_ref' column"):
        as_reference(tmp_path / "bad.csv")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        as_reference(tmp_path / "nope.npy")


def test_reference_validation():
    with pytest.raises(ValueError, match="max_amplitude_m=0.001 must be >= min_amplitude_m"):
        PseudoRandomSteps(min_amplitude_m=2e-3, max_amplitude_m=1e-3)
    with pytest.raises(ValueError, match="reference holds 1 non-finite"):
        SampledReference(np.array([np.nan])).samples(np.zeros(2), None)


def test_transducer_error_defaults_are_ideal_and_bit_identical():
    s = SensorParams()
    assert (s.p1_offset_pa, s.p2_offset_pa, s.p1_gain, s.p2_gain) == (0.0, 0.0, 1.0, 1.0)
    assert s.antialias_cutoff_hz is None and not s.has_transducer_error
    p = np.linspace(-1e5, 2.2e7, 5001)
    a = measure_pressure(p, s, np.random.default_rng(4))
    b = measure_pressure(p, s, np.random.default_rng(4), channel="p2", sample_rate=1000.0)
    assert np.array_equal(a, b)  # defaults: the channel and rate change nothing


def test_transducer_gain_and_offset_applied_before_quantisation():
    s = SensorParams(pressure_noise_std_pa=0.0, p1_gain=1.02, p1_offset_pa=7.4e3,
                     p2_gain=0.99, p2_offset_pa=-3e3)
    q = s.pressure_quantum_pa
    p = np.array([1e6, 8.6e6])
    m1 = measure_pressure(p, s, np.random.default_rng(0), channel="p1")
    m2 = measure_pressure(p, s, np.random.default_rng(0), channel="p2")
    assert m1.tolist() == (np.round((1.02 * p + 7.4e3) / q) * q).tolist()
    assert m2.tolist() == (np.round((0.99 * p - 3e3) / q) * q).tolist()
    assert s.transducer_error("p1") == (1.02, 7.4e3)
    with pytest.raises(ValueError, match="channel must be 'p1' or 'p2'"):
        measure_pressure(p, s, np.random.default_rng(0))
    with pytest.raises(ValueError, match="channel='x' must be 'p1' or 'p2'"):
        s.transducer_error("x")


def test_transducer_error_validation():
    with pytest.raises(ValueError, match="p1_gain=0 must be a finite number > 0"):
        SensorParams(p1_gain=0)
    with pytest.raises(ValueError, match="p2_offset_pa=nan must be a finite number"):
        SensorParams(p2_offset_pa=float("nan"))
    with pytest.raises(ValueError, match="antialias_cutoff_hz=-5 must be a finite number > 0"):
        SensorParams(antialias_cutoff_hz=-5)


def test_antialias_filter_minus_3db_at_cutoff_and_dc_gain_1():
    from scipy.signal import sosfreqz

    from leakdiag.sim.sensor_chain import antialias_sos
    sos = antialias_sos(150.0, 1000.0)
    _, h = sosfreqz(sos, worN=[0.0, 150.0], fs=1000.0)
    assert abs(h[0]) == pytest.approx(1.0, abs=1e-12)
    assert 20 * np.log10(abs(h[1])) == pytest.approx(-3.0103, abs=1e-3)
    with pytest.raises(ValueError, match="below the Nyquist frequency 500 Hz"):
        antialias_sos(500.0, 1000.0)
    s = SensorParams(pressure_noise_std_pa=0.0, antialias_cutoff_hz=150.0)
    with pytest.raises(ValueError, match="sample_rate is required"):
        measure_pressure([1e6], s, np.random.default_rng(0))
    # a constant passes unchanged (the filter starts at rest on the first value)
    m = measure_pressure(np.full(100, 8.6e6), s, np.random.default_rng(0), sample_rate=1000.0)
    assert np.all(m == np.round(8.6e6 / s.pressure_quantum_pa) * s.pressure_quantum_pa)
    # a 150 Hz sine leaves with amplitude 1/sqrt(2) in the steady state
    t = np.arange(4000) / 1000.0
    sf = SensorParams(pressure_noise_std_pa=0.0, antialias_cutoff_hz=150.0, pressure_adc_bits=32)
    m = measure_pressure(8e6 + 1e6 * np.sin(2 * np.pi * 150 * t), sf, np.random.default_rng(0),
                         sample_rate=1000.0)
    amp = np.sqrt(2) * np.std(m[2000:])
    assert amp == pytest.approx(1e6 / np.sqrt(2), rel=2e-3)


def test_thesis_chains_quantum_from_the_voltage_chain():
    from leakdiag.sim.sensors import THESIS_EHA_SENSORS, THESIS_VCA_SENSORS
    fs_pa = 3000 * PSI_PA
    # DAS16F, 12 bit over the transducer's 0-5 V: full scale / 2**12
    assert THESIS_VCA_SENSORS.pressure_quantum_pa == pytest.approx(fs_pa / 4096, rel=1e-15)
    # Q8: 14 bit over +-10 V with a 0-5 V transducer: (20 V / 5 V) * full scale / 2**14
    assert THESIS_EHA_SENSORS.pressure_quantum_pa == pytest.approx(4 * fs_pa / 2**14, rel=1e-15)
    assert SensorParams(pressure_adc_bits=14).pressure_quantum_pa == fs_pa / 2**14
    # 10-90 % rise of 1 ms -> ln(9) / (2 pi 1 ms) = 349.7 Hz
    assert THESIS_VCA_SENSORS.transducer_bandwidth_hz == pytest.approx(349.69, abs=0.01)
    with pytest.raises(ValueError, match="adc_input_span_v=2.0 must cover"):
        SensorParams(adc_input_span_v=2.0)


def test_transducer_filter_step_response_and_pole():
    from leakdiag.sim.sensor_chain import pressure_chain, transducer_ba
    b, a = transducer_ba(100.0, 1000.0)
    pole = np.exp(-2 * np.pi * 100.0 / 1000.0)
    assert a[1] == pytest.approx(-pole) and b[0] == pytest.approx(1 - pole)
    s = SensorParams(pressure_noise_std_pa=0.0, pressure_adc_bits=32,
                     transducer_bandwidth_hz=100.0)
    p = np.r_[0.0, np.full(9, 1e6)]
    m = pressure_chain(p, np.zeros(10), s, sample_rate=1000.0)
    k = np.arange(9)
    # first-order lag: 1 - pole**(k + 1) of the step after the first sample
    assert m[1:] == pytest.approx(1e6 * (1 - pole ** (k + 1)), abs=s.pressure_quantum_pa)
    with pytest.raises(ValueError, match="sample_rate is required when the sensor chain filters"):
        pressure_chain(p, np.zeros(10), s)


def test_pressure_chain_defaults_equal_the_in_loop_adc():
    from leakdiag.sim.sensor_chain import pressure_chain
    s = SensorParams()
    rng = np.random.default_rng(7)
    p = rng.uniform(-1e5, 2.2e7, 3000)
    e = s.pressure_noise_std_pa * rng.standard_normal(3000)
    ref = [adc_reading(pi, ei, s.pressure_full_scale_pa, s.pressure_quantum_pa)
           for pi, ei in zip(p, e)]
    assert np.array_equal(pressure_chain(p, e, s), np.array(ref))
    with pytest.raises(ValueError, match="noise has 2 samples, pressure 3000"):
        pressure_chain(p, e[:2], s)


def test_simulators_record_pressures_through_the_chain():
    from leakdiag.sim import simulate_eha, simulate_vca
    from leakdiag.sim.sensors import THESIS_EHA_SENSORS
    from leakdiag.sim.vca.control import position_only_controller
    # The loop reads the pressures through the transducers (machine.py: the load-pressure feedback
    # sees offsets and gains); a controller without pressure feedback makes the loop independent
    # of the pressure readings, so the runs differ only by the chain.
    ctrl = position_only_controller(6.0)
    s = SensorParams(transducer_bandwidth_hz=200.0, p1_offset_pa=3e3, p2_gain=1.01)
    a = simulate_vca(duration=2.0, leak_lpm=None, seed=3, sensor_params=s, controller=ctrl)
    b = simulate_vca(duration=2.0, leak_lpm=None, seed=3, sensor_params=SensorParams(),
                     controller=ctrl)
    assert np.array_equal(a["x"], b["x"]) and np.array_equal(a["u"], b["u"])
    assert 2e3 < np.mean(a["p1"] - b["p1"]) < 4e3  # the 3 kPa offset, within noise
    # an offset of exactly 10 quanta moves every (unclipped) reading by exactly 10 codes
    q = SensorParams().pressure_quantum_pa
    c = simulate_vca(duration=2.0, leak_lpm=None, seed=3, controller=ctrl,
                     sensor_params=SensorParams(p1_offset_pa=10 * q))
    assert np.abs(c["p1"] - b["p1"] - 10 * q).max() < 1e-6  # Pa: float rounding only
    assert np.array_equal(c["p2"], b["p2"])
    # with the default load-pressure feedback the loop sees the offset: the position moves by
    # micrometres only (measured 0.06 mm at most over 2 s with this chain)
    d = simulate_vca(duration=2.0, leak_lpm=None, seed=3, sensor_params=s)
    e0 = simulate_vca(duration=2.0, leak_lpm=None, seed=3, sensor_params=SensorParams())
    assert 0 < np.abs(d["x"] - e0["x"]).max() < 2e-4
    e = simulate_eha(duration=2.0, leak_lpm=None, seed=3, sensor_params=THESIS_EHA_SENSORS)
    steps = np.unique(np.round(np.diff(np.unique(e["p1"])) / THESIS_EHA_SENSORS
                               .pressure_quantum_pa, 6))
    assert steps.min() == 1.0  # readings sit on the 2**12-code grid of the Q8 chain


def test_position_only_controller_loop_shape():
    """QFT structure's feedback path (position only): margins of the linearised loop."""
    from leakdiag.sim.vca.control import loop_margins, position_only_controller
    from leakdiag.sim.vca.params import VCAParams
    c = position_only_controller(6.0)
    assert c.integral_gain_v_per_m_s == 0 and c.pressure_gain_v_per_pa == 0
    m = loop_margins(c.position_gain_v_per_m)
    assert m["gain_margin_db"] == pytest.approx(6.0, abs=0.01)
    wh = VCAParams().hydraulic_natural_frequency_rad_s
    assert 0.9 * wh < m["phase_crossover_rad_s"] < wh  # phase -180 just below omega_h
    # far below the resonance the loop is K k_v K_q / (A s): crossover at K * 0.114 m/s/V
    assert m["crossover_rad_s"] == pytest.approx(c.position_gain_v_per_m * 0.11397, rel=0.03)
    assert m["phase_margin_deg"] > 80


def test_position_only_controller_tracks_a_step_without_steady_error():
    from leakdiag.sim import SampledReference, simulate_vca
    from leakdiag.sim.vca.control import position_only_controller
    x_ref = np.r_[np.zeros(100), np.full(1900, 10e-3)]
    rec = simulate_vca(duration=2.0, leak_lpm=None, seed=1, sensors=False,
                       reference=SampledReference(x_ref), controller=position_only_controller())
    # type-1 loop (the actuator integrates): no steady error on a step; friction leaves a
    # dead band of a few micrometres at most
    assert abs(rec["x"][-1] - 10e-3) < 0.05e-3
    k = position_only_controller().position_gain_v_per_m
    t63 = (np.argmax(rec["x"] > 0.632 * 10e-3) - 100) / 1000.0
    assert t63 == pytest.approx(1.0 / (k * 0.11397), rel=0.25)  # first-order loop, tau = 1/wc
