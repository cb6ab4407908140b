"""FlowBalanceDetector's sensor-consistency refusals (found by a sensor-fault audit, 2026-11-27).

A healthy actuator with one faulty sensor was judged LEAK with a size: a pressure transducer
reading +100 kPa (11 of 12 healthy VCA spring runs), a pressure dropping out to 0 for 0.1-1 s,
a single +10 V sample of the command, a frozen EHA position (0.51 L/min on a healthy run).
The leak-free sum of the two chamber balances (the leak and the piston flow cancel) catches
the transducer faults; single samples and holds are checked against the healthy recordings.
"""

import dataclasses
import re

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect._flow_balance_checks import (
    SPIKE_FACTOR,
    SUM_GATE_FACTOR,
    SumGate,
    learn_sum_gate,
    spike_sizes,
)
from leakdiag.detect.flow_balance import HOLD_FACTORS
from leakdiag.io.recording import RecordingError

SRC = "leakdiag.sim.simulate_vca"


def _vca(seed, duration=20.0, **kw):
    kw.setdefault("leak_lpm", 0.0)
    return ld.sim.simulate_vca(duration=duration, load="spring", machine=17, seed=seed, **kw)


def _eha(seed, duration=20.0, load="none", **kw):
    kw.setdefault("leak_lpm", 0.0)
    return ld.sim.simulate_eha(duration=duration, load=load, machine=17, seed=seed, **kw)


def _with(rec, channel, values):
    return dataclasses.replace(rec, channels={**rec.channels, channel: values})


@pytest.fixture(scope="module")
def healthy():
    return [_vca(s) for s in range(4)]


@pytest.fixture(scope="module")
def det(healthy):
    return FlowBalanceDetector(system="vca").fit(healthy)


@pytest.fixture(scope="module")
def eha():
    return FlowBalanceDetector(system="eha").fit([_eha(s) for s in range(4)])


# ------------------------------------------------------------------ 1. the sum equation
def test_the_gate_is_learned_on_the_healthy_recordings(det, healthy):
    """The limit is SUM_GATE_FACTOR times the largest |z| of the healthy windows, with the
    spread s^2 = c0 + c1 F^2 fitted on the same windows (recomputed here from the terms)."""
    gate = det.sum_gate_
    assert isinstance(gate, SumGate) and SUM_GATE_FACTOR == 4.0
    terms = [det._terms(r) for r in healthy]
    again = learn_sum_gate([t["balance"] for t in terms], [t["flow"] for t in terms])
    assert again == gate
    z = np.concatenate([gate.z(t["balance"], t["flow"]) for t in terms])
    assert gate.healthy_max_z == pytest.approx(float(np.abs(z).max()), rel=1e-12)
    assert gate.limit == pytest.approx(4.0 * gate.healthy_max_z, rel=1e-12)
    assert gate.flow_max_m3 == max(float(np.abs(t["flow"]).max()) for t in terms)
    assert 2.0 < gate.healthy_max_z < 6.0


def test_the_sum_equation_does_not_see_a_leak(det):
    """The leak leaves chamber 1 and enters chamber 2: the sum equation's window residuals of
    a run leaking 2 L/min stay within the limit where the valve volume is within the healthy
    windows' (the servo feeds a large leak with larger volumes, which the gate does not
    judge), and the run is judged LEAK with a size (the rated leak of the VCA)."""
    # (30 s with the leak from 15 s: an onset after the first 10 windows judged, sized; from
    # 10 s in 20 s, it is "at or before" with 9 windows after it, no size since session 22)
    rec = _vca(60, 30.0, leak_lpm=2.0, onset=15.0)
    t = det._terms(rec)
    gate = det.sum_gate_
    inside = gate.judged(t["flow"])
    assert inside.sum() > 5 and (~inside).sum() > 0  # windows on both sides of the range
    assert np.abs(gate.z(t["balance"], t["flow"]))[inside].max() < gate.limit
    v = det.predict(rec)
    assert v.leak and v.alarm_time_s >= 10.0 and v.leak_lpm > 1.0


@pytest.mark.parametrize("fault", ["offset", "gain"])
def test_a_pressure_transducer_error_is_refused_as_an_inconsistency(det, fault):
    """p1 reading +100 kPa or +1 % (against the fit runs) made healthy spring runs LEAK
    (11 and 8 of 12 with 120-s runs); now the recording is refused, naming the time span."""
    rec = _vca(61)
    assert not det.predict(rec).leak
    p1 = rec["p1"] + 1e5 if fault == "offset" else rec["p1"] * 1.01
    bad = _with(rec, "p1", p1)
    with pytest.raises(RecordingError, match=(
            rf"^predict: {re.escape(SRC)}: sensor or model inconsistency from [0-9.]+ to "
            r"[0-9.]+ s \(\d+ window\(s\)\): the leak-free sum of the chamber balances .* is "
            r"off by up to [0-9.]+ healthy spreads .* a transducer offset/gain, a command delay "
            r"or sign, or operation the fit did not see; no verdict on a leak$")):
        det.predict(bad)


def test_a_detector_saved_before_the_gate_skips_it(det):
    import pickle

    old = pickle.loads(pickle.dumps(det))
    del old.__dict__["sum_gate_"]  # as unpickled from a file written before the gate
    bad = _with(_vca(61), "p1", _vca(61)["p1"] + 1e5)
    try:  # judged without the gate (since 2026-11-28 its alarm here, whose interval since
        old.predict(bad)  # the onset reaches zero, is refused by another check)
    except RecordingError as exc:
        assert "sensor or model inconsistency" not in str(exc)
    with pytest.raises(RecordingError, match="sensor or model inconsistency"):
        det.predict(bad)


def test_the_eha_has_no_sum_gate(eha):
    """The EHA's sum equation holds neither the pump flow nor the position (both cancel), so
    it cannot check the speed and position the audit's EHA faults were in: no gate."""
    assert eha.sum_gate_ is None


# ------------------------------------------------------------------ 2. EHA position holds
def test_the_eha_position_is_held_to_six_times_its_longest_healthy_hold(eha):
    assert HOLD_FACTORS == {("eha", "x"): 6.0}
    assert eha.hold_limits_s_["x"] == pytest.approx(6.0 * eha.longest_hold_s_["x"], rel=1e-12)
    assert 0.01 < eha.longest_hold_s_["x"] < 0.05
    rec = _eha(70)
    x = rec["x"].copy()
    x[9000:9300] = x[9000]  # 0.3 s frozen part-way (a false LEAK in 32 of 40 places at 1 s)
    with pytest.raises(RecordingError, match=re.escape(
            "predict: leakdiag.sim.simulate_eha: channel 'x' holds one value")):
        eha.predict(_with(rec, "x", x))


def test_a_rated_eha_leak_without_load_is_not_taken_for_a_frozen_position(eha):
    """Under a 1.63 L/min leak without load the piston creeps: holds of up to 2.9x the
    healthy ones (docs 8.4), inside the 6x limit."""
    v = eha.predict(_eha(71, leak_lpm=1.63, onset=8.0))
    assert v.leak and v.leak_lpm > 1.0


# ------------------------------------------------------------------ 3. dropouts and outliers
def test_a_dropout_to_a_value_the_healthy_recordings_never_reached_is_not_a_rail(det):
    """p2 at 0 for 0.1 s: 0 is the recording's smallest value, which the hold check skipped
    as a rail; the healthy recordings never read 0, so it is a hold like any other."""
    rec = _vca(62)
    p2 = rec["p2"].copy()
    p2[9000:9100] = 0.0
    assert det.operation_["extremes"]["p2"][0] > 0.0
    with pytest.raises(RecordingError, match=re.escape(
            f"predict: {SRC}: channel 'p2' holds one value (0) for 0.1 s, rows 9000 to 9099")):
        det.predict(_with(rec, "p2", p2))


def test_a_sample_far_outside_the_healthy_full_range_is_refused_by_row(det):
    """One sample is under 1 % of a run, which the percentile range check ignores."""
    rec = _vca(63)
    lo, hi = det.operation_["extremes"]["p1"]
    p1 = rec["p1"].copy()
    p1[12345] = hi + 1.5 * (hi - lo)
    with pytest.raises(RecordingError, match=re.escape(
            f"predict: {SRC}: channel 'p1' reads {p1[12345]:.6g} at row 12345 (1 such rows "
            "after the burn-in), far outside the healthy recordings' full range")):
        det.predict(_with(rec, "p1", p1))
    p1[12345] = hi + 0.9 * (hi - lo)  # within the margin (OPERATION_MARGIN = 1 span)
    det._check_operation(_with(rec, "p1", p1), "predict")


def test_spike_sizes_by_hand():
    # 3 is above 1 and 2 (by 2 and 1), -4 below 2 and 0 (by 6 and 4)
    assert spike_sizes([1.0, 3.0, 2.0, 2.0, -4.0, 0.0]).tolist() == [1.0, 0.0, 0.0, 4.0]
    assert spike_sizes([0.0, 10.0, 10.0, 10.0]).tolist() == [0.0, 0.0]  # a step is no spike


def test_a_single_command_sample_is_refused_beyond_the_spike_limit(det, healthy):
    """A single +10 V sample of u made 11 of 12 healthy VCA runs LEAK."""
    assert SPIKE_FACTOR == 4.0
    largest = max(float(spike_sizes(r["u"][2000:]).max()) for r in healthy)
    assert det.largest_spike_["u"] == largest and det.spike_limits_ == {"u": 4.0 * largest}
    rec = _vca(64)
    u = rec["u"].copy()
    u[10300] = u[10299] + 10.0
    u[10301] = u[10299]
    with pytest.raises(RecordingError, match=re.escape(
            f"predict: {SRC}: channel 'u' has a one-sample outlier at row 10300")):
        det.predict(_with(rec, "u", u))


def test_the_eha_speed_is_checked_for_spikes(eha):
    assert set(eha.spike_limits_) == {"speed"}
    rec = _eha(72)
    w = rec["speed"].copy()
    w[7000] += 20.0 * eha.largest_spike_["speed"]
    with pytest.raises(RecordingError, match="channel 'speed' has a one-sample outlier at row"):
        eha.predict(_with(rec, "speed", w))


# ------------------------------------------------------------------ 3b. the command's sign
def test_piston_valve_ratio_by_hand():
    """1 - sum(r G) / sum(G^2) from window j on; None without valve volumes or flow."""
    from leakdiag.detect.flow_balance import _piston_valve_ratio

    t = {"valve_volume": np.array([9.0, 1.0, 2.0]), "residual": np.array([4.0, 0.5, 1.0])}
    assert _piston_valve_ratio(t, 1) == pytest.approx(1.0 - (0.5 + 2.0) / (1.0 + 4.0))
    assert _piston_valve_ratio(t, 0) == pytest.approx(1.0 - (36.0 + 2.5) / 86.0)
    assert _piston_valve_ratio({"residual": t["residual"]}, 0) is None  # the EHA
    assert _piston_valve_ratio({"valve_volume": np.zeros(2), "residual": np.ones(2)}, 0) is None


@pytest.mark.parametrize("channel", ["u", "x"])
def test_a_reversed_command_or_position_sign_is_no_leak_verdict(det, channel):
    """A sensor-fault audit (2026-11-27): the command's sign reversed from 50 s of 120-s runs
    of unit 17 read LEAK in 5 of 12 healthy spring runs and 12 of 12 without load. The piston
    then moves against the valve model's flow (ratio about -0.75; a leak only takes part of
    the valve's flow, 0 to 1), which is refused; a large leak is still LEAK (ratio ~0.04)."""
    from leakdiag.detect.flow_balance import MIN_PISTON_VALVE_RATIO, _piston_valve_ratio

    rec = _vca(71)
    flipped = rec[channel].copy()
    half = len(flipped) // 2
    if channel == "x":  # the position flipped at a non-zero value jumps: refused as a
        # discontinuity before the test (_check_steps, 2026-11-28) ...
        jumped = flipped.copy()
        jumped[half:] *= -1.0
        with pytest.raises(RecordingError, match=r"channel 'x' steps by [0-9.e-]+ between rows "
                                                 r"9999 and 10000 \(at 10 s"):
            det.predict(_with(rec, channel, jumped))
        # ... flipped where it crosses zero (no jump) it is refused as well (here, 2026-11-28,
        # by the coefficient's sign check: its alarm's leak is not positive)
        half += int(np.argmin(np.abs(flipped[half:half + 5000])))
        flipped[half:] *= -1.0
        with pytest.raises(RecordingError, match=r"; no verdict on a leak$"):
            det.predict(_with(rec, channel, flipped))
        return
    flipped[half:] *= -1.0
    with pytest.raises(RecordingError, match=(
            rf"^predict: {re.escape(SRC)}: the test alarmed at [0-9.]+ s, but after the onset "
            r"\([0-9.]+ s\) the piston moved against the valve's flow: the piston's volume is "
            r"-[0-9]\.[0-9]+ times the valve model's \(1 on a healthy recording; a leak takes part of "
            r"the valve's flow, between 0 and 1; below -0\.25 no leak explains it\): the "
            r"command's or the position's sign is reversed against the fit runs; no verdict on "
            r"a leak$")):
        det.predict(_with(rec, channel, flipped))
    assert MIN_PISTON_VALVE_RATIO == -0.25
    big = _vca(72, leak_lpm=2.0, onset=10.0)
    v = det.predict(big)
    t = det._terms(big)
    j = int(np.flatnonzero(t["start"] >= v.onset_s)[0])
    assert v.leak and 0.0 - 0.1 < _piston_valve_ratio(t, j) < 0.5


# ------------------------------------------------------------------ 4. an alarm without a leak
def test_an_alarm_whose_coefficient_since_the_onset_is_not_positive_is_no_leak_verdict(det,
                                                                                      monkeypatch):
    """Until 2026-11-27 this was LEAK without a size; it is now refused (INCONCLUSIVE). Since
    session 22 an onset in the first windows judged (a leak present from the start, fitted into
    the null offset) or an alarm less than 10 s before the end (too few data) is refused with
    its own words, not "does not describe this recording" (an audit, 2026-11-29)."""
    from leakdiag.detect.flow_balance import AlarmAtStart, AlarmNotConfirmed

    rec = _vca(65, 40.0, leak_lpm=0.5, onset=20.0)
    early = _vca(65, leak_lpm=0.5, onset=8.0)
    late = _vca(65, 25.0, leak_lpm=0.5, onset=20.0)
    assert det.predict(rec).leak and det.predict(early).leak and det.predict(late).leak
    monkeypatch.setattr(type(det), "_estimate", lambda self, t, j, sigma=None: (-2e-13, 1e-13))
    with pytest.raises(AlarmAtStart, match=r"with its onset within the first 10 windows judged"):
        det.predict(early)
    with pytest.raises(AlarmNotConfirmed, match=r"s of data after the alarm, too few to confirm"):
        det.predict(late)
    from leakdiag.detect.flow_balance import RefusedAlarm

    # a refused alarm like the others (an audit, 2026-11-29: a plain RecordingError, which a
    # count of refused alarms by RefusedAlarm missed)
    with pytest.raises(RefusedAlarm, match=(
            rf"^predict: {re.escape(SRC)}: the test alarmed at [0-9.]+ s \(score [0-9.]+, level "
            r"[0-9.]+\), but the leak coefficient estimated from the onset \([0-9.]+ s\) to the "
            r"end is not positive \(-2e-13 \+- 1e-13\): the flow balance does not describe "
            r"this recording well .*; no verdict on a leak$")):
        det.predict(rec)


def test_an_eha_recording_that_ends_soon_after_the_onset_gets_no_size(eha):
    """A flow-balance audit (2026-11-28, finding 6) cut EHA runs 2.5-5 s after a 1 L/min leak
    began: 0.48 L/min [0.44, 0.49] from 1-2 windows (the transducers' offset, profiled on the
    leak's windows, took half the leak). Fewer than 10 windows after the onset: no size."""
    from leakdiag.detect.flow_balance import OFFSET_MIN_WINDOWS

    full = _eha(81, 32.0, leak_lpm=1.0, onset=18.0)
    for cut, sized in ((22.5, False), (32.0, True)):
        n = int(cut * 1000)
        rec = full.__class__({c: v[:n] for c, v in full.channels.items()}, full.sample_rate,
                             full.start_time, dict(full.units), dict(full.meta))
        v = eha.predict(rec)
        assert v.leak and abs(v.onset_s - 18.0) <= 1.0
        if sized:
            assert v.leak_lpm == pytest.approx(1.0, rel=0.05)
        else:
            assert v.leak_lpm is None and v.leak_coefficient is None
            assert v.leak_lpm_interval_holds.startswith(
                "no size: only 3 window(s) follow the onset window before the recording ends, "
                "and the size profiles the chamber transducers' differential offset on the "
                f"leak's own windows, which takes at least {OFFSET_MIN_WINDOWS}")


def test_a_range_refusal_of_a_longer_run_names_the_drift_of_a_long_run(eha):
    """A flow-balance audit (2026-11-28, finding 5): 30-min healthy EHA runs were refused as
    "another unit ..., another rig" while the open-loop position had drifted; a run much longer
    than the fit runs is now told that too."""
    rec = _eha(83, 35.0)
    x = rec["x"] + 3.0 * (rec["x"].max() - rec["x"].min())  # beyond the healthy range
    with pytest.raises(RecordingError, match=r"channel 'x' spans .* or operation the detector "
                                             r"was not fitted for, or a slow drift \(an open-loop "
                                             r"position, a temperature\) that goes further in a "
                                             r"recording 1.75x as long as the longest healthy "
                                             r"one: judge parts as long as the healthy"):
        eha.predict(_with(rec, "x", x))
    short = _eha(84)
    with pytest.raises(RecordingError, match="or operation the detector was not fitted for$"):
        eha.predict(_with(short, "x", short["x"] + 3.0 * (x.max() - x.min())))  # not longer


def test_a_refused_alarm_near_its_level_names_a_chance_crossing_first():
    """A CLI audit (2026-11-28, finding 7): a healthy unit's chance alarm at 25 per hour was
    refused with only sensor faults and units named as causes."""
    from leakdiag.detect.flow_balance import CHANCE_SCORE_FACTOR, _chance_words

    assert CHANCE_SCORE_FACTOR == 2.0
    assert _chance_words(3.1, 2.9).startswith("a false alarm: the score is within 2x the level")
    assert _chance_words(5.8, 2.9) != "" and _chance_words(5.81, 2.9) == ""
    assert _chance_words(299.0, 3.75) == ""  # a leak-sized score is no chance crossing
