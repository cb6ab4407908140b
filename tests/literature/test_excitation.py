import numpy as np
import pytest

from leakdiag.sim.excitation import PeriodicSteps, RepeatedChirp, structured_excitation


def test_periodic_steps_waveform():
    s = PeriodicSteps(amplitude=2.0, period_s=1.0, offset=1.0, duty=0.25)
    t = np.array([0.0, 0.2, 0.25, 0.9, 1.0, 1.24, 1.26])
    assert s.samples(t).tolist() == [3.0, 3.0, -1.0, -1.0, 3.0, 3.0, -1.0]


def test_periodic_steps_mean_and_period():
    s = structured_excitation("vca", "steps")
    t = np.arange(0, 10, 1e-3)
    x = s.samples(t)
    assert np.mean(x) == pytest.approx(0.0, abs=1e-12)
    assert set(np.round(x, 12)) == {0.01, -0.01}
    np.testing.assert_array_equal(x[:1000], x[1000:2000])  # period 1 s at 1 kHz
    assert np.count_nonzero(np.diff(x)) == 19  # two edges per period


def test_repeated_chirp_instantaneous_frequency_and_continuity():
    c = RepeatedChirp(amplitude=1.0, f0_hz=0.5, f1_hz=5.0, period_s=4.0)
    fs = 10000.0
    t = np.arange(0, 8, 1 / fs)
    x = c.samples(t)
    # zero crossings per second rise from ~2*f0 to ~2*f1 within a sweep
    zc = np.flatnonzero(np.diff(np.signbit(x)))
    first_s, last_s = np.sum(zc < fs), np.sum((zc >= 3 * fs) & (zc < 4 * fs))
    assert first_s in (1, 2, 3) and 9 <= last_s <= 11
    # the end phase is 22 pi: sweeps join without a jump
    assert abs(x[40000] - x[39999]) < 2 * np.pi * 5.0 / fs + 1e-9
    np.testing.assert_allclose(x[:40000], x[40000:80000], atol=1e-9)


def test_works_as_a_simulator_reference():
    from leakdiag.sim.vca.simulate import simulate_vca

    rec = simulate_vca(duration=3.0, leak_lpm=None, onset=1.0, seed=1, sensors=False,
                       reference=structured_excitation("vca"))
    np.testing.assert_allclose(rec["x_ref"], structured_excitation("vca").samples(rec.time))
    # the closed loop follows: position near +10 mm at the end of each high half-period
    i = int(0.45 * rec.sample_rate)
    assert rec["x"][1000 + i] == pytest.approx(0.01, abs=1e-3)


def test_errors():
    with pytest.raises(ValueError, match="duty=1.0 must be in"):
        PeriodicSteps(duty=1.0)
    with pytest.raises(ValueError, match="period_s=0"):
        RepeatedChirp(period_s=0)
    with pytest.raises(ValueError, match="system='x'"):
        structured_excitation("x")
    with pytest.raises(ValueError, match="kind='sine'"):
        structured_excitation("vca", "sine")
