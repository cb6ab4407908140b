"""Detector protocol: sklearn conventions, threshold calibration, planted onsets, verdicts."""

import math
from dataclasses import replace

import numpy as np
import pytest
from sklearn.base import clone

from leakdiag.detect.base import Alarm, Verdict
from leakdiag.detect.cusum import cusum

from _detect_helpers import RATE, WINDOW, WindowMeanDetector, synthetic

SIGMA = 1.0 / np.sqrt(WINDOW)  # std of a window mean of unit white noise


@pytest.fixture(scope="module")
def fitted():
    healthy = [synthetic(600.0, seed) for seed in range(6)]
    return WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=1.0, burn_in_s=0.0)).fit(healthy)


def test_clone_and_params_roundtrip():
    det = WindowMeanDetector(window=20, alarm=Alarm(drift=0.7))
    c = clone(det)
    assert c.get_params() == det.get_params()
    assert c is not det and not hasattr(c, "threshold_")
    c.set_params(window=30)
    assert c.window == 30 and det.window == 20


def test_parameters_changed_after_fit_are_refused_until_refit(fitted):
    # an API audit (2026-11-30): set_params(lag=5) on a fitted feature detector read healthy
    # runs LEAK at 150x the threshold, labelled with the new lag; a new target kept the old
    # threshold without a word
    import copy
    import pickle

    rec = synthetic(120.0, 99)
    want = fitted.predict(rec)
    det = copy.deepcopy(fitted).set_params(window=20)
    with pytest.raises(ValueError, match=r"WindowMeanDetector: parameters changed since fit "
                                         r"\(window: fitted with 50, now 20\): the fitted model, "
                                         r"threshold and healthy statistics belong to the "
                                         r"settings it was fitted with; fit it again, or set "
                                         r"them back"):
        det.predict(rec)
    with pytest.raises(ValueError, match=r"alarm: fitted with Alarm\(false_alarms_per_hour=1\.0"):
        copy.deepcopy(fitted).set_params(
            alarm=Alarm(false_alarms_per_hour=5.0, burn_in_s=0.0)).score(rec)
    assert det.set_params(window=WINDOW).predict(rec) == want  # set back
    refit = clone(fitted).set_params(window=20).fit([synthetic(600.0, s) for s in range(6)])
    assert refit.fitted_params_["window"] == 20 and refit.predict(rec).n_windows == 120 * 100 // 20
    old = pickle.loads(pickle.dumps(fitted))  # a detector saved before the check
    del old.fitted_params_
    assert old.set_params(window=20).predict(rec).n_windows > 0  # not held: nothing to hold to


def test_fit_learns_healthy_distribution(fitted):
    # the window mean of unit white noise: mean 0, std 1/sqrt(50)
    assert abs(fitted.mean_) < 4 * SIGMA / np.sqrt(6 * 1200)
    assert fitted.std_ == pytest.approx(SIGMA, rel=0.05)
    assert fitted.n_healthy_ == 6
    assert fitted.healthy_hours_ == pytest.approx(1.0)


def test_predict_before_fit_raises():
    with pytest.raises(ValueError, match="not fitted"):
        WindowMeanDetector().predict(synthetic(10.0, 0))


def test_zero_variance_feature_rejected():
    from leakdiag.io.recording import Recording

    rec = Recording({"p1": np.ones(5000)}, RATE)
    with pytest.raises(ValueError, match="zero variance"):
        WindowMeanDetector(alarm=Alarm(burn_in_s=0.0)).fit([rec])


@pytest.mark.parametrize("bad,match", [({"drift": -1.0}, "drift"), ({"direction": "left"}, "direction"),
                                       ({"onset_method": "magic"}, "onset_method"),
                                       ({"false_alarms_per_hour": 0}, "false_alarms_per_hour"),
                                       ({"confidence": 1.0}, "confidence"),
                                       ({"confidence": 0.0}, "confidence"),
                                       # an API audit, 2026-11-29: numpy's words, or taken
                                       ({"drift": "a"}, "drift='a' must be a number$"),
                                       ({"burn_in_s": None}, "burn_in_s=None must be a number$"),
                                       ({"false_alarms_per_hour": True},
                                        "false_alarms_per_hour=True must be a number, not a "
                                        "bool")])
def test_alarm_validation(bad, match):
    with pytest.raises((ValueError, TypeError), match=match):
        Alarm(**bad)


def test_threshold_is_the_conformal_order_statistic(fitted):
    # 6 runs of 600 s, 1 alarm/h -> alpha = 1/6 per 600-s segment, k = floor(7/6) = 1: the
    # threshold is the largest healthy CUSUM maximum, bound 1/7 per segment (6/7 per hour)
    b = fitted.threshold_basis_
    assert b.method == "conformal" and fitted.alarm_threshold_ is b
    assert (b.n, b.k, b.segment_s) == (6, 1, 600.0)
    assert b.bound_per_segment == pytest.approx(1 / 7) and b.bound_per_hour == pytest.approx(6 / 7)
    assert fitted.threshold_ == fitted.healthy_maxima_.max()
    # the maxima are those of the CUSUM of each healthy run standardised with the mean and std
    # of the OTHER runs (leave one run out: out-of-sample maxima), recomputed by hand
    wm = [synthetic(600.0, s)["p1"].reshape(-1, WINDOW).mean(axis=1) for s in range(6)]
    others = np.concatenate([w for i, w in enumerate(wm) if i != 3])
    z = (wm[3] - others.mean()) / others.std(ddof=1)
    assert fitted.healthy_maxima_[3] == pytest.approx(np.maximum(*cusum(z, 0.5, "both")).max())


def test_false_alarm_rate_on_held_out_healthy_runs_inside_interval():
    from scipy.stats import beta

    from leakdiag.detect.rates import clopper_pearson

    # 99 healthy runs of 60 s, 5 % per run (3 per hour): k = 5, bound 5/100. The achieved rate
    # on 1500 fresh runs must be compatible with this calibration's Beta(5, 95) rate: its
    # Clopper-Pearson interval overlaps [2.5 %, 97.5 %] quantiles of that distribution.
    alarm = Alarm(false_alarms_per_hour=3.0, burn_in_s=0.0)
    det = WindowMeanDetector(alarm=alarm).fit([synthetic(60.0, 1000 + s) for s in range(99)])
    b = det.threshold_basis_
    assert (b.n, b.k) == (99, 5) and b.bound_per_segment == pytest.approx(0.05)
    alarms = sum(det.predict(synthetic(60.0, 5000 + s)).leak for s in range(1500))
    lo, hi = clopper_pearson(alarms, 1500)
    assert lo <= beta.ppf(0.975, 5, 95) and hi >= beta.ppf(0.025, 5, 95)
    assert lo <= b.conditional_upper_95


def test_too_little_healthy_data_is_refused_or_flagged():
    from leakdiag.detect.threshold import (InsufficientHealthyDataError,
                                           InsufficientHealthyDataWarning)

    healthy = [synthetic(600.0, s) for s in range(6)]
    # 0.1 alarm/h over 600 s segments = 1/60 per segment: needs 59 maxima, 6 given
    with pytest.raises(InsufficientHealthyDataError, match="needs at least 59 maxima"):
        WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=0.1, burn_in_s=0.0)).fit(healthy)
    with pytest.warns(InsufficientHealthyDataWarning):
        det = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=0.1, burn_in_s=0.0,
                                             on_insufficient="warn")).fit(healthy)
    assert not det.threshold_basis_.supported
    assert det.threshold_basis_.method == "conformal-unsupported"
    # shorter segments give more maxima: 60 s segments -> 60 maxima, 1/600 per segment still
    # needs 599
    with pytest.raises(InsufficientHealthyDataError, match="599"):
        WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=0.1, burn_in_s=0.0,
                                       segment_s=60.0)).fit(healthy)


def test_reference_maxima_from_other_units_are_pooled():
    from leakdiag.detect.threshold import ReferenceMaxima

    alarm = Alarm(false_alarms_per_hour=0.5, burn_in_s=0.0, segment_s=60.0)
    # 30 "reference units": each fitted on its own run, maxima out of sample on 4 others
    maxima = []
    for u in range(30):
        d = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=30.0, burn_in_s=0.0,
                                           segment_s=60.0)).fit([synthetic(600.0, 7000 + u)])
        maxima.append(d.segment_maxima([synthetic(60.0, 8000 + 10 * u + j) for j in range(4)]))
    ref = ReferenceMaxima(np.concatenate(maxima), 60.0, 0.5, "both", 0.0, "test units", 30)
    own = [synthetic(600.0, 9000)]  # 10 own maxima: alone they support 1/11 per segment at best
    with pytest.raises(ValueError, match="needs at least"):
        WindowMeanDetector(alarm=alarm).fit(own)
    det = WindowMeanDetector(alarm=alarm).fit(own, reference_maxima=ref)
    b = det.threshold_basis_
    assert (b.n_own, b.n_reference, b.n) == (10, 120, 130)
    assert b.k == math.floor(0.5 / 60 * 131) == 1
    with pytest.raises(ValueError, match="burn_in_s"):
        WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=0.5, burn_in_s=1.0, segment_s=60.0)
                           ).fit(own, reference_maxima=ref)
    # calibration-conditional: 1/120 per segment at 60 % needs (119/120)^n <= 0.4, n >= 110;
    # with 130 maxima k = 1 (P(Bin(130, 1/120) <= 1) = 0.70 > 0.4), the largest pooled maximum
    cond = WindowMeanDetector(alarm=replace(alarm, confidence=0.6)).fit(own, reference_maxima=ref)
    assert cond.threshold_basis_.k == 1 and cond.threshold_basis_.confidence == 0.6
    assert cond.threshold_ == max(ref.maxima.max(), det.healthy_maxima_.max())
    with pytest.raises(ValueError, match="at 90 % confidence needs at least 276 maxima"):
        WindowMeanDetector(alarm=replace(alarm, confidence=0.9)).fit(own, reference_maxima=ref)


def test_planted_step_found_by_all_onset_methods(fitted):
    rec = synthetic(300.0, 99, onset=150.0, step=0.5)  # 0.5 = 3.5 healthy std of the feature
    for method in ("binseg", "pelt", "cusum"):
        det = clone(fitted).set_params(alarm=Alarm(onset_method=method, burn_in_s=0.0))
        det.fit([synthetic(600.0, s) for s in range(6)])
        v = det.predict(rec)
        assert isinstance(v, Verdict) and v.leak
        assert abs(v.onset_s - 150.0) <= 1.5, (method, v.onset_s)  # within 3 windows
        assert 150.0 <= v.alarm_time_s <= 155.0  # the CUSUM needs a few windows after the onset
        assert v.confidence == pytest.approx(1 / 7)  # p-value floor 1/(n+1), n = 6
        assert v.shift == pytest.approx(0.5 / fitted.std_, rel=0.2)


def test_healthy_recording_gives_no_leak_and_low_confidence(fitted):
    v = fitted.predict(synthetic(300.0, 77))
    assert not v.leak and v.onset_s is None and v.alarm_time_s is None
    assert v.score_max <= v.threshold
    # p-value: (1 + #{healthy maxima >= score}) / 7, at least 2/7 without an alarm
    ge = int((fitted.healthy_maxima_ >= v.score_max).sum())
    assert v.confidence == pytest.approx((1 + ge) / 7) and v.confidence >= 2 / 7


def test_a_recording_with_no_window_after_the_burn_in_is_not_judged(fitted):
    """Nothing tested is no verdict, not NO LEAK (it was leak=False, p = 1 before)."""
    from leakdiag.detect.base import TooShortToJudge

    det = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=1.0, burn_in_s=5.0)).fit(
        [synthetic(600.0, seed) for seed in range(6)])
    short = synthetic(4.5, 9, onset=0.5, step=5.0)
    # a RecordingError of its own type (monitor --segment tells a short last segment by it)
    with pytest.raises(TooShortToJudge, match=r"predict: syn9: too short to judge: 4\.5 s leaves "
                       r"no complete window of the feature after the 5-s burn-in"):
        det.predict(short)
    assert det.predict(synthetic(30.0, 9)).leak is False  # long enough: judged


def test_score_is_cusum_of_standardised_feature(fitted):
    rec = synthetic(60.0, 5, onset=30.0, step=0.3)
    fs = fitted.score(rec)
    z = fitted.standardize(rec).values
    up, down = cusum(z, 0.5, "both")
    np.testing.assert_allclose(fs.values, np.maximum(up, down))
    # hand check of the standardisation on the first window
    assert z[0] == pytest.approx((rec["p1"][:WINDOW].mean() - fitted.mean_) / fitted.std_)


def test_leak_size_calibration_recovers_linear_truth(fitted):
    det = clone(fitted).fit([synthetic(600.0, s) for s in range(6)])
    cal_runs = [synthetic(200.0, 100 + i, onset=100.0, step=q) for i, q in
                enumerate([0.05, 0.1, 0.2, 0.3, 0.4, 0.5] * 2)]
    det.calibrate(cal_runs, validity={"rig": "synthetic"})
    v = det.predict(synthetic(200.0, 500, onset=100.0, step=0.25))
    assert v.leak and v.leak_lpm == pytest.approx(0.25, abs=0.05)
    lo, hi = v.leak_lpm_interval
    assert lo < 0.25 < hi and v.leak_lpm_in_range
    assert det.calibration_.validity == {"rig": "synthetic"}


def test_calibration_reads_the_shift_predict_reports_on_the_runs_it_alarms_on(fitted):
    """A statistics audit (2026-11-29): the map was fitted on the shift at the true onset of
    every run, while predict reads it at its estimated onset of an alarmed run, so near the
    detection limit the interval held the truth in 45-82 % of detected runs for 90 %. Now the
    calibration takes predict's own shift, and a run it does not alarm on is left out."""
    from leakdiag.detect.leaksize import fit_leak_calibration

    det = clone(fitted).fit([synthetic(600.0, s) for s in range(6)])
    runs = [synthetic(200.0, 100 + i, onset=100.0, step=q) for i, q in
            enumerate([0.0, 0.02, 0.04, 0.1, 0.2, 0.3, 0.4, 0.5])]
    verdicts = [det.predict(r) for r in runs]
    alarmed = [(v.shift, r.meta["leak_lpm"]) for v, r in zip(verdicts, runs) if v.leak]
    quiet = [r for v, r in zip(verdicts, runs) if not v.leak]
    assert quiet and len(alarmed) >= 3
    det.calibrate(runs)
    want = fit_leak_calibration(*zip(*alarmed))
    assert det.calibration_.n_runs == len(alarmed)
    assert det.calibration_.slope_lpm == pytest.approx(want.slope_lpm, rel=1e-12)
    assert det.calibration_.intercept_lpm == pytest.approx(want.intercept_lpm, rel=1e-12)
    with pytest.raises(ValueError, match=r"^calibrate: the detector alarms on 0 of the 1 "
                                         r"calibration recordings \(not on syn"):
        det.calibrate(quiet[:1])


def test_calibrate_refuses_a_run_given_twice_and_another_load(fitted):
    # a CLI audit, 2026-11-29: three calibration runs given twice passed the slope test that
    # the three alone failed, and their interval missed the truth; spring runs calibrated a
    # no-load detector (a 0.5 L/min no-load leak sized 3.6 L/min)
    det = clone(fitted).fit([_with(synthetic(600.0, s), meta={"load": "none"})
                             for s in range(6)])
    assert det.healthy_load_ == "none"
    runs = [synthetic(200.0, 100 + i, onset=100.0, step=q) for i, q in
            enumerate([0.05, 0.1, 0.2, 0.3])]
    with pytest.raises(ValueError, match=r"^calibrate: recording 5 \(syn100\) holds the same "
                                         r"samples as recording 1 \(syn100\): a recording "
                                         r"given twice would count as two known leaks"):
        det.calibrate([*runs, _with(runs[0])])
    spring = [_with(r, meta={"load": "Spring"}) for r in runs]
    with pytest.raises(ValueError, match=r"^calibrate: syn100 states load 'spring', but the "
                                         r"healthy recordings of fit state 'none'"):
        det.calibrate(spring)
    det.calibrate([_with(r, meta={"load": "none"}) for r in runs])  # the same load: fitted
    assert det.calibration_ is not None
    # a load unstated on either side is not checked (a plain CSV export)
    clone(fitted).fit([synthetic(600.0, s) for s in range(6)]).calibrate(spring)


def test_not_fitted_is_sklearns_not_fitted_error():
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError, match="WindowMeanDetector is not fitted; call fit"):
        WindowMeanDetector().score(synthetic(10.0, 0))


def _with(rec, **changes):
    from leakdiag.io.recording import Recording

    meta = {**rec.meta, **changes.pop("meta", {})}
    return Recording(dict(rec.channels), changes.get("sample_rate", rec.sample_rate),
                     meta=meta)


def test_fit_refuses_a_leaking_run_a_repeated_run_and_mixed_rates_or_rigs():
    """Found by an API audit (2026-11-27): all four were accepted; a leaking 'healthy' run
    lowers the threshold's reference and repeated runs are not independent."""
    h = [synthetic(60.0, s) for s in range(3)]
    det = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=30.0, burn_in_s=0.0))
    from leakdiag.io import RecordingError

    leak = synthetic(60.0, 9, onset=30.0, step=0.5)
    with pytest.raises(RecordingError, match=r"fit: healthy recording 4 \(syn9\) leaks by its "
                                             r"metadata \(leak_lpm=0.5 L/min from 30 s\): fit "
                                             r"on healthy recordings only$"):
        det.fit(h + [leak])
    with pytest.raises(ValueError, match=r"fit: healthy recording 3 \(syn0\) holds the same "
                                         r"samples as healthy recording 1 \(syn0\)"):
        det.fit([h[0], h[1], h[0]])
    with pytest.raises(ValueError, match=r"different sample rates \(100, 200 Hz\)"):
        det.fit([h[0], _with(h[1], sample_rate=2 * RATE)])
    with pytest.raises(ValueError, match=r"different rigs \(\['eha', 'vca'\]\); fit one "):
        det.fit([_with(h[0], meta={"system": "VCA"}), _with(h[1], meta={"system": "eha"})])
    det.fit([_with(r, meta={"system": "vca"}) for r in h[:2]] + [h[2]])  # one unknown: fine
    assert (det.sample_rate_, det.system_) == (RATE, "vca")


def test_fit_refuses_healthy_runs_of_different_loads():
    """Found by an audit (2026-11-27): no-load and spring runs were pooled without a word;
    the spring run set a flow-balance threshold of 102 (2.4 without it) and a 0.02 L/min leak
    was judged NO LEAK."""
    h = [synthetic(60.0, s) for s in range(3)]
    det = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=30.0, burn_in_s=0.0))
    with pytest.raises(ValueError, match=r"fit: the healthy recordings state different loads "
                                         r"\('none' in healthy recording 1 \(syn0\), 'spring' "
                                         r"in healthy recording 3 \(syn2\)\); fit one detector "
                                         r"per load"):
        det.fit([_with(h[0], meta={"load": "none"}), _with(h[1], meta={"load": "None"}),
                 _with(h[2], meta={"load": "spring"})])
    det.fit([_with(h[0], meta={"load": "spring"}), h[1], _with(h[2], meta={"load": "spring"})])


def test_predict_refuses_another_rate_or_rig_than_the_healthy_runs():
    """Found by an API audit (2026-11-27): a VCA detector judged a healthy EHA run LEAK
    (score 985 against 54), a run at another rate likewise (windows are in samples)."""
    from leakdiag.io import RecordingError

    h = [_with(synthetic(60.0, s), meta={"system": "vca"}) for s in range(3)]
    det = WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=30.0, burn_in_s=0.0)).fit(h)
    other = synthetic(60.0, 7)
    with pytest.raises(RecordingError, match=r"syn7: sampled at 200 Hz, but WindowMeanDetector "
                                             r"was fitted on healthy recordings at 100 Hz"):
        det.predict(_with(other, sample_rate=2 * RATE))
    with pytest.raises(RecordingError, match=r"syn7: a 'eha' recording, but WindowMeanDetector "
                                             r"was fitted on 'vca' recordings"):
        det.score(_with(other, meta={"system": "EHA"}))
    assert det.predict(other).leak in (True, False)  # no rig said: judged
    del det.sample_rate_, det.system_  # a detector saved before these existed: not checked
    det.predict(_with(other, meta={"system": "eha"}))


def test_what_is_not_a_recording_is_refused_with_what_was_given(fitted):
    # an API audit (2026-11-30): a DataFrame given to fit failed deep inside with "'str'
    # object has no attribute 'sample_rate'" (its column names taken for recordings)
    rec = synthetic(60.0, 7)
    df = rec.to_pandas()
    with pytest.raises(TypeError, match=r"^fit expects leakdiag Recording objects, got "
                                        r"DataFrame \(a pandas DataFrame: leakdiag\.io\."
                                        r"Recording\.from_pandas\(df\) makes one\)$"):
        clone(fitted).fit(df)
    with pytest.raises(TypeError, match=r"^fit expects .* got dict \(a mapping"):
        clone(fitted).fit([dict(rec.channels)])
    with pytest.raises(TypeError, match=r"^predict expects .* got str \(a file name: "
                                        r"leakdiag\.io\.read_recording\(path\) reads one\)$"):
        fitted.predict("run.parquet")
    with pytest.raises(TypeError, match=r"^predict expects .* got NoneType"):
        fitted.score(None)


def test_the_lazily_loaded_names_are_listed_by_dir():
    # an API audit (2026-11-30): dir(ld.detect), tab completion and help() listed no detector
    import leakdiag.detect as d

    assert set(d.__all__) <= set(dir(d))
    assert {"FeatureDetector", "CombinedDetector", "FlowBalanceDetector", "judge_run"} <= set(
        dir(d))
    assert d.judge_run is __import__("leakdiag.detect.decision", fromlist=["x"]).judge_run
