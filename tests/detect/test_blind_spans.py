"""A stuck channel makes a feature undefined (NaN windows) and the CUSUM holds its value across
them: NO LEAK is refused over a blind span longer than the healthy recordings had."""

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.bench.registry import make_detector
from leakdiag.detect.base import NAN_RUN_FACTOR, Alarm, longest_nan_run
from leakdiag.io import RecordingError
from leakdiag.io.recording import Recording


def _freeze(rec, channel, t0, t1=None):
    ch = dict(rec.channels)
    v = ch[channel].copy()
    i0 = int(t0 * rec.sample_rate)
    i1 = len(v) if t1 is None else int(t1 * rec.sample_rate)
    v[i0:i1] = v[i0]
    ch[channel] = v
    return Recording(ch, rec.sample_rate, rec.start_time, dict(rec.units),
                     {**rec.meta, "source": f"{channel} frozen"})


@pytest.fixture(scope="module")
def acf():
    healthy = [ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=s) for s in range(4)]
    return make_detector("acf-p1", "vca", Alarm(false_alarms_per_hour=30.0)).fit(healthy)


def test_healthy_runs_of_pressure_features_have_no_undefined_window(acf):
    assert acf.nan_run_healthy_ == 0


def test_a_stuck_pressure_sensor_is_not_judged_no_leak(acf):
    """Found by an audit (2026-11-27): a 1 L/min leak with p1 stuck from 58 s read NO LEAK
    (p = 0.33) with 52 % of the windows undefined."""
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20)
    assert not acf.predict(rec).leak  # the same run, sensor working: judged
    stuck = _freeze(rec, "p1", 20.0)
    n = longest_nan_run(acf._trace(stuck).z)
    assert n > NAN_RUN_FACTOR  # the whole frozen part
    with pytest.raises(RecordingError, match=rf"predict: p1 frozen: the feature 'autocorrelation "
                                             rf"p1 .*' is undefined in {n} consecutive windows "
                                             r"from 2\d\.\d+ to 39\.\d+ s \(zero variance: a "
                                             r"channel it reads is constant there, a stuck "
                                             r"sensor\?\); the healthy recordings had at most 0 "
                                             r"such windows in a row \(limit 3\)"):
        acf.predict(stuck)


def test_a_short_freeze_within_the_limit_is_judged(acf):
    rec = _freeze(ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20), "p1", 20.0, 20.6)
    assert 1 <= longest_nan_run(acf._trace(rec).z) <= NAN_RUN_FACTOR
    assert not acf.predict(rec).leak


def test_an_alarm_before_the_blind_span_still_reads_leak(acf):
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=1.0, onset=10.0, seed=21)
    v = acf.predict(_freeze(rec, "p1", 30.0))
    assert v.leak and v.alarm_time_s < 30.0  # evidence from the windows that were looked at


def test_detectors_fitted_before_the_check_skip_it(acf):
    from sklearn.base import clone

    old = clone(acf).fit([ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=s)
                          for s in range(4)])
    del old.nan_run_healthy_
    stuck = _freeze(ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20), "p1", 20.0)
    assert not old.predict(stuck).leak  # as before: no check without the fitted attribute
    assert np.isfinite(old.predict(stuck).score_max)
