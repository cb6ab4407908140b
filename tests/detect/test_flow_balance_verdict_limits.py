"""What a flow-balance verdict says beyond LEAK / NO LEAK where its size was never measured to
hold: leaks present from the start, the VCA without load, growing leaks (audit 2026-11-27,
docs/detect.md 8.5, "What the verdict says beyond LEAK / NO LEAK")."""

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect.flow_balance import CENSOR_WINDOWS


def _vca(load, seed, duration=30.0, **kw):
    kw.setdefault("leak_lpm", 0.0)
    return ld.sim.simulate_vca(duration=duration, load=load, machine=17, seed=seed, **kw)


@pytest.fixture(scope="module")
def no_load():
    return FlowBalanceDetector(system="vca").fit([_vca("none", s) for s in range(3)])


@pytest.fixture(scope="module")
def spring():
    return FlowBalanceDetector(system="vca").fit([_vca("spring", s, 40.0) for s in range(3)])


def test_no_load_vca_gives_no_coefficient_nor_reference_flow_and_says_why(no_load):
    """Without load the VCA's coefficient and reference flow were 0.13-1.05x the truth with a
    standard error hundreds of times too small (F3), 0.41-1.24x with the transducers' offset
    profiled and no band for it: withheld, the size kept."""
    rec = _vca("none", 2, leak_lpm=0.2, onset=15.0)
    v = no_load.predict(rec)
    assert v.leak and not v.onset_censored and v.leak_lpm is not None
    assert v.leak_coefficient is None and v.leak_coefficient_se is None
    assert v.leak_lpm_at_reference is None
    assert "no leak coefficient nor flow at the reference pressure difference: on the VCA " \
        "without load the coefficient was measured 0.41-1.24x the truth on 68 virtual " \
        "machines" in v.leak_lpm_interval_holds
    d = v.as_dict()
    assert d["leak_coefficient"] is None and d["leak_lpm_at_reference"] is None


def test_unknown_load_is_taken_as_one_where_the_coefficient_was_not_measured(spring):
    import copy

    det = copy.deepcopy(spring)
    det.operation_ = {**det.operation_, "load": None}
    rec = _vca("spring", 5, 40.0, leak_lpm=0.05, onset=20.0)
    rec = rec.__class__(rec.channels, rec.sample_rate, rec.start_time, dict(rec.units),
                        {k: v for k, v in rec.meta.items() if k != "load"})
    v = det.predict(rec)
    assert v.leak and v.leak_coefficient is None
    assert "on the VCA under an unknown load" in v.leak_lpm_interval_holds
    w = spring.predict(_vca("spring", 5, 40.0, leak_lpm=0.05, onset=20.0))
    assert w.leak_coefficient > 0 and w.leak_lpm_at_reference > 0  # measured to hold there


def test_a_leak_there_from_the_start_is_censored_and_unsized_without_load(no_load):
    """A leak from 0 s was placed at 2.9-7.1 s without "at or before" (40 of 72 no-load runs)
    and sized up to 2.8x with the interval missing 15 of 72 (F2)."""
    for seed in (1, 2):
        v = no_load.predict(_vca("none", seed, leak_lpm=0.2, onset=0.0))
        assert v.leak and v.onset_censored
        first_judged = 2.0  # the burn-in
        assert v.onset_s < first_judged + CENSOR_WINDOWS * 1.5  # quiet windows: <= 1.5 s
        assert v.leak_lpm is None and v.leak_lpm_interval is None
        assert v.leak_coefficient is None
        assert v.leak_lpm_interval_holds.startswith("no size: the onset lies within the first 10 "
                                                    "windows judged, where a leak present from")
        assert "onset at or before" in str(v) and "\n  size: no size" in str(v)
    late = no_load.predict(_vca("none", 2, leak_lpm=0.2, onset=15.0))
    assert not late.onset_censored and late.leak_lpm is not None


def test_a_leak_there_from_the_start_under_the_spring_is_censored_and_sized(spring):
    rec = _vca("spring", 7, 40.0, leak_lpm=0.05, onset=0.0)
    v = spring.predict(rec)
    assert v.leak and v.onset_censored and v.leak_lpm is not None
    lo, hi = v.leak_lpm_interval
    assert lo <= rec.meta["leak_lpm_achieved"] <= hi


def test_size_weights_leave_out_the_valve_flow_feeding_the_leak(spring):
    """The error model's end-point term reads the valve flow, which with a leak includes what
    the servo delivers to feed it: the size's weights are taken at the leak-free end-point
    flows (F1). On a 0.2 L/min ramp the late windows' sigma was 4.5-4.9x the same run's
    without the leak, and the ramp was sized 0.32-0.51x its mean since the onset (seeds
    11-13); with the feed removed, sigma is within 1.5x of the leak-free run's (the flow-gain
    term still sees the feed) and the size of seed 11 within 10 %."""
    seed = 11
    ramp = _vca("spring", seed, 40.0, leak_lpm=0.2, onset=10.0, leak_kind="ramp",
                ramp_duration=25.0)
    dry = _vca("spring", seed, 40.0)
    t, t0 = spring._terms(ramp), spring._terms(dry)
    v = spring.predict(ramp)
    j = int(np.searchsorted(t["start"], v.onset_s - 1e-9))
    late = t["start"] >= 30.0  # the ramp at its top
    s_old, s_new, s_dry = spring._sigma(t), spring._size_sigma(t, j + 1), spring._sigma(t0)
    assert np.median(s_old[late] / s_dry[late]) > 3.0
    assert np.median(s_new[late] / s_dry[late]) < 1.5
    truth = ramp.meta["leak_lpm_achieved"]
    mean_phi = t["phi_abs"][j:].sum() / t["duration"][j:].sum()
    old = spring._estimate(t, j + 1)[0] * mean_phi * 6e4  # the healthy weights, as before
    assert old / truth < 0.6
    assert v.leak_lpm / truth == pytest.approx(1.0, abs=0.1)
    # without load (or an unknown load) the healthy weights, with which the band was measured
    for load in ("none", None):
        np.testing.assert_array_equal(spring._size_sigma(t, j + 1, load), s_old)


def test_a_growing_leak_is_said_to_grow_with_its_recent_flow(spring):
    """A ramp under the spring was sized as a step, with the step-leak band's promise and
    nothing said of the growth (F1). The coefficient on the second half of the time since the
    onset against the first (step leaks 0.98-1.03x, ramps 1.99-3.35x in the audit's runs) flags
    it; the verdict then gives the flow of the last 10 windows and withdraws the promise."""
    ramp = _vca("spring", 12, 40.0, leak_lpm=0.2, onset=10.0, leak_kind="ramp",
                ramp_duration=25.0)
    v = spring.predict(ramp)
    recent_truth = float(np.abs(ramp["leak_flow"][-10_000:]).mean()) * 6e4  # ~0.38 L/min
    assert v.leak and v.recent_leak_lpm == pytest.approx(recent_truth, rel=0.15)
    assert v.recent_leak_lpm > 1.5 * ramp.meta["leak_lpm_achieved"]  # the mean since onset
    assert "the leak is growing" in v.leak_lpm_interval_holds
    assert "for a growing leak it is no promise" in v.leak_lpm_interval_holds
    assert v.as_dict()["recent_leak_lpm"] == v.recent_leak_lpm
    step = spring.predict(_vca("spring", 12, 40.0, leak_lpm=0.2, onset=10.0))
    assert step.leak and step.recent_leak_lpm is None
    assert "growing" not in step.leak_lpm_interval_holds


def test_a_no_leak_states_the_smallest_step_leak_it_would_have_seen(spring):
    """A NO LEAK said nothing of what the test could see (decisions audit 2026-11-27, finding
    4). The stated size, simulated on the same run from the stated time, is seen at 3x and
    missed at a fifth of it (on 8 units, 38 of 38 alarmed at 1x: perf/flow_balance_detectable)."""
    v = spring.predict(_vca("spring", 12, 40.0))
    assert not v.leak and v.detectable_lpm is not None
    # the last 30 s (max_span_s) of the 38 judged 1-s windows: from the 9th (burn-in 2 s)
    assert v.detectable_from_s == pytest.approx(9.0, abs=0.1)
    assert 1e-4 < v.detectable_lpm < 1e-2  # ~1e-3 L/min: Fig. 4-6's smallest leak is 0.005
    assert v.as_dict()["detectable_lpm"] == v.detectable_lpm
    assert "sensitivity: a step leak of " in str(v) and "38 of 38 such leaks" in str(v)
    for factor, leak in ((3.0, True), (0.2, False)):
        w = spring.predict(_vca("spring", 12, 40.0, leak_lpm=factor * v.detectable_lpm,
                                onset=v.detectable_from_s))
        assert w.leak is leak, (factor, w.score_max, w.threshold)


def test_without_load_the_smallest_leak_is_three_times_the_error_model_s(no_load):
    """Without load the model's own size alarmed in 21 of 38 VCA runs on 8 units (the leak term
    the test sees is a fraction of the true one): 3x it is stated (38 of 38), and holds here."""
    from leakdiag.detect.flow_balance import DETECTABLE_FACTOR

    v = no_load.predict(_vca("none", 12))
    assert not v.leak and v.detectable_lpm is not None
    assert DETECTABLE_FACTOR[("vca", "none")] == 3.0
    assert "3 times its error model's size (on the VCA without load the model's own size " \
        "alarmed in as few as 21 of 38 runs); on 8 virtual machines 38 of 38" in v.detectable_why
    for factor, leak in ((1.0, True), (0.2, False)):
        w = no_load.predict(_vca("none", 12, leak_lpm=factor * v.detectable_lpm,
                                 onset=v.detectable_from_s))
        assert w.leak is leak, (factor, w.score_max, w.threshold)
    # an unknown load (a CSV without metadata) takes the larger factor
    import copy

    det = copy.deepcopy(no_load)
    det.operation_ = {**det.operation_, "load": None}
    rec = _vca("none", 12)
    rec = rec.__class__(rec.channels, rec.sample_rate, rec.start_time, dict(rec.units),
                        {k: val for k, val in rec.meta.items() if k != "load"})
    u = det.predict(rec)
    assert u.detectable_lpm == pytest.approx(v.detectable_lpm, rel=1e-12)
    assert "on the VCA under an unknown load" in u.detectable_why


def test_two_runs_spliced_into_one_file_are_refused_at_the_seam(spring):
    """A flow-balance audit (2026-11-28, finding 2) put two healthy runs end to end on one time
    axis: no VCA splice read NO LEAK, 5 of 12 read LEAK with a size (the position's jump at the
    seam entered the balance as piston volume). The step is refused, naming the rows."""
    from leakdiag.io import RecordingError

    a, b = _vca("spring", 21, 40.0), _vca("spring", 22, 40.0)
    half = 20000
    rec = a.__class__({c: np.concatenate([a[c][:half], b[c][half:]]) for c in a.channels},
                      a.sample_rate, a.start_time, dict(a.units), dict(a.meta))
    jump = abs(float(b["x"][half] - a["x"][half - 1]))
    assert jump > 2 * spring.largest_step_["x"]  # the seam's step, this pair of runs
    with pytest.raises(RecordingError, match=r"channel 'x' steps by [0-9.e-]+ between rows 19999 "
                                             r"and 20000 \(at 20 s; 1 such step\(s\) after the "
                                             r"burn-in\): more than the [0-9.e-]+ allowed, 2x the "
                                             r"largest step of the healthy recordings .*a stop and "
                                             r"restart spliced into one file"):
        spring.predict(rec)
    assert not spring.predict(a).leak  # each part alone is judged
    assert 1.6e-3 < spring.largest_step_["x"] < 1.8e-3  # the valve's saturated piston speed


def test_an_alarm_whose_leak_since_the_onset_is_not_above_zero_is_no_verdict(spring):
    """An audit (2026-11-28): a healthy file spliced where the positions matched (the step
    check cannot see it) read LEAK with an interval reaching below zero. An alarm whose leak
    since the onset is not significantly above zero now gives no verdict. (Of 8 such splices
    of these runs: 4 refused as a coefficient not positive, 1 by this rule, 1 a spike, 1 NO
    LEAK, 2 still LEAK: docs/detect.md 8.4, "Discontinuities".)"""
    from leakdiag.io import RecordingError

    a, b = _vca("spring", 36, 40.0), _vca("spring", 136, 40.0)
    k = int(np.argmin(np.abs(b["x"][15000:25000] - a["x"][19999]))) + 15000
    n = min(len(a["x"]) - 20000, len(b["x"]) - k)
    rec = a.__class__({c: np.concatenate([a[c][:20000], b[c][k:k + n]]) for c in a.channels},
                      a.sample_rate, a.start_time, dict(a.units), dict(a.meta))
    with pytest.raises(RecordingError, match=r"but the leak estimated from the onset \([0-9.]+ "
                                             r"s\) to the end is not significantly above zero "
                                             r"\(its interval -[0-9.e-]+ to [0-9.e-]+ L/min "
                                             r"reaches zero\)"):
        spring.predict(rec)


def test_a_leak_there_from_the_start_of_a_short_run_gets_no_size(spring):
    """A CLI audit (2026-11-29): ``monitor --segment 11.5`` and ``20`` sized a continuing
    0.05 L/min spring leak at 0.0055-0.07 L/min per segment, 9 of 10 intervals excluding the
    truth. A leak present from the start (a censored onset) is sized only with at least
    ``CENSORED_SIZE_MIN_WINDOWS`` windows after its onset window, as on the 40-s runs above."""
    from leakdiag.detect.flow_balance import CENSORED_SIZE_MIN_WINDOWS

    assert CENSORED_SIZE_MIN_WINDOWS == 25
    rec = _vca("spring", 7, 20.0, leak_lpm=0.05, onset=0.0)
    v = spring.predict(rec)
    assert v.leak and v.onset_censored
    assert v.leak_lpm is None and v.leak_lpm_interval is None and v.leak_coefficient is None
    assert v.leak_lpm_interval_holds.startswith(
        "no size: the onset lies within the first 10 windows judged") and \
        f"sized within its band with {CENSORED_SIZE_MIN_WINDOWS} or more" in \
        v.leak_lpm_interval_holds


def test_eha_under_an_unknown_load_gives_the_coefficient_measured_under_both():
    """The EHA's coefficient held 0.967-1.015x the truth with and without load
    (COEFFICIENT_MEASURED), so a recording and fit that state no load keep it (withheld before
    2026-11-29, session 28, as if the rig had a load where it failed); the VCA's stays
    withheld under an unknown load, sized as without load."""
    import copy

    def eha(seed, **kw):
        kw.setdefault("leak_lpm", 0.0)
        rec = ld.sim.simulate_eha(duration=40.0, load="none", machine=17, seed=seed, **kw)
        return rec.__class__(rec.channels, rec.sample_rate, rec.start_time, dict(rec.units),
                             {k: v for k, v in rec.meta.items() if k != "load"})

    det = FlowBalanceDetector(system="eha").fit([eha(s) for s in range(3)])
    assert det.operation_["load"] is None
    rec = eha(7, leak_lpm=0.2, onset=15.0)
    v = det.predict(rec)
    assert v.leak and v.leak_lpm is not None and "any load" in v.leak_lpm_interval_holds
    truth = rec.meta["leak_lpm_at_reference_dp"]
    assert v.leak_coefficient > 0 and 0.9 < v.leak_lpm_at_reference / truth < 1.1
    assert "no leak coefficient" not in v.leak_lpm_interval_holds
    vca = copy.deepcopy(FlowBalanceDetector(system="vca").fit([_vca("none", s) for s in range(3)]))
    vca.operation_ = {**vca.operation_, "load": None}
    leak = _vca("none", 2, leak_lpm=0.2, onset=15.0)
    w = vca.predict(leak.__class__(leak.channels, leak.sample_rate, leak.start_time,
                                   dict(leak.units),
                                   {k: x for k, x in leak.meta.items() if k != "load"}))
    assert w.leak and w.leak_coefficient is None and w.leak_lpm_at_reference is None
    assert "on the VCA under an unknown load (sized as without load) the coefficient was " \
        "measured 0.41-1.24x the truth" in w.leak_lpm_interval_holds
