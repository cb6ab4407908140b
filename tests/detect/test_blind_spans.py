"""A stuck channel makes a feature undefined (NaN windows) and the CUSUM holds its value across
them: NO LEAK is refused over an undefined span longer than the healthy recordings allow."""

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.bench.registry import make_detector
from leakdiag.detect.base import Alarm, longest_nan_run
from leakdiag.detect.blind_rules import blind_limit_s
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
    assert acf.nan_span_healthy_s_ == 0.0 and blind_limit_s(0.0) == 10.0


def test_a_stuck_pressure_sensor_is_not_judged_no_leak(acf):
    """Found by an audit (2026-11-27): a 1 L/min leak with p1 stuck from 58 s read NO LEAK
    (p = 0.33) with 52 % of the windows undefined."""
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20)
    assert not acf.predict(rec).leak  # the same run, sensor working: judged
    stuck = _freeze(rec, "p1", 20.0)
    n, i, span = longest_nan_run(acf._trace(stuck).time, acf._trace(stuck).z)
    assert 19.0 < span < 20.0 and n == round(span / 0.19)  # 190-sample steps at 1 kHz
    with pytest.raises(RecordingError, match=rf"predict: p1 frozen: the feature 'autocorrelation "
                                             rf"p1 .*' is undefined in {n} consecutive windows "
                                             r"from 20\.\d+ to 39\.\d+ s \(a channel it reads "
                                             r"is constant there, or holds one value longer than "
                                             r"in the healthy recordings: a stuck sensor\?\); the "
                                             r"healthy recordings had undefined "
                                             r"spans of at most 0 s \(limit 10 s\), so no leak "
                                             r"can be ruled out over that span"):
        acf.predict(stuck)


def test_a_leak_hidden_by_a_span_that_ends_too_late_to_show_it_is_refused(acf):
    """A review (2026-11-27) of a first version that refused only spans at the end: a 1 L/min
    leak from 20 s with p1 stuck 15-38 s (2 s of defined data after it) read NO LEAK."""
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=1.0, onset=20.0, seed=21)
    assert acf.predict(rec).leak
    with pytest.raises(RecordingError, match=r"undefined in \d+ consecutive windows from 15\."):
        acf.predict(_freeze(rec, "p1", 15.0, 38.0))


def test_a_short_undefined_span_is_judged(acf):
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20)
    short = _freeze(rec, "p1", 30.0, 38.0)  # 8 s: under the 10-s floor
    assert 6.0 < longest_nan_run(acf._trace(short).time, acf._trace(short).z)[2] < 10.0
    assert not acf.predict(short).leak


def test_an_alarm_before_the_blind_span_still_reads_leak(acf):
    rec = ld.sim.simulate_vca(duration=40, leak_lpm=1.0, onset=10.0, seed=21)
    v = acf.predict(_freeze(rec, "p1", 25.0))
    assert v.leak and v.alarm_time_s < 25.0  # evidence from the windows that were looked at


def test_detectors_fitted_before_the_check_skip_it(acf):
    from sklearn.base import clone

    old = clone(acf).fit([ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=s)
                          for s in range(4)])
    del old.nan_span_healthy_s_
    stuck = _freeze(ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=20), "p1", 20.0)
    v = old.predict(stuck)  # as before: judged, without the check
    assert not v.leak and np.isfinite(v.score_max)


def _series(acf, z_values, burn_windows):
    """The detector's feature over windows whose standardised values are ``z_values``, after
    ``burn_windows`` windows at the healthy mean (the burn-in), 190-sample steps at 1 kHz."""
    from leakdiag.features.series import FeatureSeries

    spec = acf.spec()
    z = np.r_[np.zeros(burn_windows), z_values]
    step = 190
    time = (np.arange(len(z)) * step + spec.window - 1) / 1000.0
    return FeatureSeries(time, acf.mean_ + acf.std_ * z, spec.label, window=spec.window,
                         overlap=spec.overlap, step=step, channels=spec.channels,
                         sample_rate=1000.0, start_time=0.0)


def test_an_onset_across_a_blind_span_is_at_or_before_its_end(acf):
    """A streaming audit (2026-11-27): a healthy fluctuation raised the CUSUM before p1 stuck
    for 40 s, the CUSUM held across the undefined windows, and the leak's windows after them
    continued the same excursion: onset 29.2 s reported as a plain value, the leak began at
    60 s. The onset is now the first window after the span, 'at or before', with the reason;
    the same excursion without the span keeps its own onset."""
    burn = int(np.ceil(acf.alarm.burn_in_s / 0.19)) + 5
    h = acf.threshold_
    rise = np.full(10, -(h / 20.0 + acf.alarm.drift))  # S- grows by h/20 a window: 0.5 h
    stuck = np.full(80, np.nan)  # 80 windows of 0.19 s: 15.2 s > the 10-s limit
    leak = np.full(40, -(h / 20.0 + acf.alarm.drift))  # the same level: one change, before
    series = _series(acf, np.r_[rise, stuck, leak], burn)
    v = acf.predict_series(series, duration_s=float(series.time[-1]) + 0.01)
    after = burn + 10 + 80  # the first window after the span
    first_after = (series.time[after] + series.time[after] - 0.199) / 2.0
    assert v.leak and v.alarm_time_s > series.time[after - 1]
    assert v.onset_censored and v.onset_s == pytest.approx(first_after)
    span0 = series.time[burn + 10] - 0.199  # the first undefined window's first sample
    assert v.onset_why.startswith(f"the feature was undefined from {span0:.6g} to "
                                  f"{series.time[after - 1]:.6g} s, longer than the healthy")
    assert "at or before" in str(v)
    # a span within the limit (40 windows: 7.6 s) is looked through: the excursion's own onset
    short = _series(acf, np.r_[rise, np.full(40, np.nan), leak], burn)
    w = acf.predict_series(short, duration_s=float(short.time[-1]) + 0.01)
    assert w.leak and not w.onset_censored and w.onset_s < short.time[burn + 10]


def test_a_short_run_mostly_undefined_is_not_judged_no_leak(acf):
    """Audit of users' recordings (2026-11-27, finding 2): a 3-s file with p1 stuck from 0.2 s
    had 13 of its 15 windows undefined and read NO LEAK: no span of a 3-s file can exceed the
    10-s floor. More than half of the judged windows undefined now refuses NO LEAK."""
    from leakdiag.detect.blind_rules import MAX_UNDEFINED_FRACTION, blind_rule

    burn = int(np.ceil(acf.alarm.burn_in_s / 0.19))  # the windows before it: burn-in
    z = np.r_[0.1, -0.2, np.full(13, np.nan)]  # 15 judged windows: 2.85 s, under 10 s
    series = _series(acf, z, burn)
    assert blind_rule(acf.nan_span_healthy_s_, 15, 13, 13 * 0.19) == "fraction"
    with pytest.raises(RecordingError, match=r"predict: <series>: the feature 'autocorrelation "
                                             r"p1 .*' is undefined in 13 of the 15 windows "
                                             r"judged \(more than 50%; the longest span 13 "
                                             r"windows from .*so no NO LEAK can rest on the 2 "
                                             r"defined window\(s\)"):
        acf.predict_series(series, duration_s=float(series.time[-1]) + 0.01)
    # half of them undefined: judged, and the verdict says on how many windows
    half = _series(acf, np.r_[np.zeros(8), np.full(7, np.nan)], burn)
    v = acf.predict_series(half, duration_s=float(half.time[-1]) + 0.01)
    assert MAX_UNDEFINED_FRACTION == 0.5 and not v.leak
    assert (v.n_windows, v.n_undefined) == (15, 7)
    assert v.as_dict()["windows_undefined"] == "7 of 15 windows undefined"
    assert str(v).endswith("; 7 of 15 windows undefined")
    # none undefined: nothing said
    full = acf.predict_series(_series(acf, np.zeros(15), burn), duration_s=float(half.time[-1]))
    assert full.n_undefined == 0 and full.undefined_words == "" and "undefined" not in str(full)


def test_the_fraction_rule_is_relative_to_the_healthy_recordings(acf):
    """A review (2026-11-27): with a fixed half, a feature undefined in most healthy windows
    (ccf u,x while an encoder holds its count) refused the detector's own healthy recordings.
    The limit is ``max(1/2, (1 + healthy share) / 2)``: at least half as many defined windows
    as the healthy recordings had."""
    import copy

    from leakdiag.detect.blind_rules import undefined_limit

    assert acf.nan_fraction_healthy_ == 0.0  # pressure features: never undefined when healthy
    assert undefined_limit(0.0) == 0.5 and undefined_limit(0.64) == pytest.approx(0.82)
    often = copy.deepcopy(acf)
    often.nan_fraction_healthy_ = 0.64
    burn = int(np.ceil(acf.alarm.burn_in_s / 0.19))
    # undefined in short spans, about as often as in the healthy recordings: judged
    z = np.array([0.1, np.nan, np.nan, 0.0, np.nan, np.nan, 0.2, np.nan, np.nan, 0.0, np.nan,
                  np.nan, -0.1, np.nan, np.nan])  # 10 of 15 undefined: 67 % < 82 %
    series = _series(acf, z, burn)
    v = often.predict_series(series, duration_s=float(series.time[-1]) + 0.01)
    assert not v.leak and (v.n_windows, v.n_undefined) == (15, 10)
    with pytest.raises(RecordingError, match=r"undefined in 10 of the 15 windows judged \(more "
                                             r"than 50%;"):
        acf.predict_series(series, duration_s=float(series.time[-1]) + 0.01)
    # 13 of 15 (87 %): refused under either
    z13 = np.r_[0.1, 0.2, np.full(13, np.nan)]
    s13 = _series(acf, z13, burn)
    with pytest.raises(RecordingError, match=r"undefined in 13 of the 15 windows judged \(more "
                                             r"than 82%, the healthy recordings had at most "
                                             r"64%;"):
        often.predict_series(s13, duration_s=float(s13.time[-1]) + 0.01)


def test_fit_refuses_a_healthy_recording_whose_feature_is_never_defined():
    """A statistics audit (2026-11-30): a healthy run with p1 stuck throughout was accepted by
    fit, counted as segment maxima of 0 (understating the bound) and lifted the blind-span
    limits to its whole length, so that a judged run 73 % undefined read NO LEAK."""
    healthy = [ld.sim.simulate_vca(duration=40, leak_lpm=0.0, seed=s) for s in range(4)]
    stuck = _freeze(healthy[3], "p1", 0.0)
    det = make_detector("acf-p1", "vca", Alarm(false_alarms_per_hour=30.0))
    with pytest.raises(ValueError, match=r"fit: healthy recording p1 frozen: no finite feature "
                                         r"value in its \d+ window\(s\) after the 5-s burn-in "
                                         r"\(zero variance: a constant or stuck channel\?\)"):
        det.fit(healthy[:3] + [stuck])
    # stuck for part of it only: accepted, its undefined span sets the blind-span limit
    part = _freeze(healthy[3], "p1", 20.0)
    assert 19.0 < det.fit(healthy[:3] + [part]).nan_span_healthy_s_ < 20.0
