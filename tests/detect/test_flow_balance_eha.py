"""FlowBalanceDetector (EHA): pump-side balance, identification, planted leak, missing speed."""

import dataclasses

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect._flow_balance_eha import EHAPumpModel, terms
from leakdiag.io.recording import Recording, RecordingError
from leakdiag.sim.eha.params import EHAParams

P = EHAParams()
#: Off-nominal unit: pump displacement +3 %, cross-port leakage x1.5.
UNIT = dataclasses.replace(P, pump_displacement_m3_per_rev=P.pump_displacement_m3_per_rev * 1.03,
                           pump_internal_leakage_m3_per_s_pa=P.pump_internal_leakage_m3_per_s_pa * 1.5)


@pytest.fixture(scope="module")
def fitted():
    healthy = [ld.sim.simulate_eha(duration=30, leak_lpm=0.0, params=UNIT, seed=s) for s in range(4)]
    return FlowBalanceDetector(system="eha", false_alarms_per_hour=1.0).fit(healthy)


def test_residual_small_on_noise_free_leak_free_run():
    rec = ld.sim.simulate_eha(duration=8, leak_lpm=0.0, seed=2, sensors=False)
    # the nominal pump: cross-port leakage plus half the case drain (lumped, see the module)
    c = P.pump_internal_leakage_m3_per_s_pa + P.pump_external_leakage_m3_per_s_pa / 2
    t = terms(rec, P, EHAPumpModel(1.0, c, P.bulk_modulus_pa), 1000, laminar=False)
    r, flow = t["residual"][2:], t["flow"][2:]
    assert flow.min() > 4e-5  # ~50 mL through the pump per window
    # what remains is the accumulator make-up flow of the check valves, which the lumped
    # laminar term approximates: below 0.2 % of the pump volume (0.1 mL of 50 mL)
    assert np.all(np.abs(r) <= 2e-3 * flow)


def test_identification_recovers_displacement(fitted):
    assert fitted.model_.displacement_factor == pytest.approx(1.03, abs=2e-3)
    c_true = (UNIT.pump_internal_leakage_m3_per_s_pa + UNIT.pump_external_leakage_m3_per_s_pa / 2)
    assert fitted.model_.pump_leakage_m3_per_s_pa == pytest.approx(c_true, rel=0.3)


def test_planted_leak_found_and_sized(fitted):
    rec = ld.sim.simulate_eha(duration=40, leak_lpm=0.1, onset=20, params=UNIT, seed=11)
    v = fitted.predict(rec)
    assert v.leak and 20.0 <= v.alarm_time_s <= 30.0 and abs(v.onset_s - 20.0) <= 3.0
    assert abs(v.leak_coefficient - rec.meta["leak_coefficient"]) <= 3.0 * v.leak_coefficient_se
    lo, hi = v.leak_lpm_interval
    assert lo <= rec.meta["leak_lpm_achieved"] <= hi
    healthy = ld.sim.simulate_eha(duration=40, leak_lpm=0.0, params=UNIT, seed=12)
    assert not fitted.predict(healthy).leak


@pytest.mark.parametrize("where", ["fit", "predict"])
def test_missing_speed_is_named(fitted, where):
    rec = ld.sim.simulate_eha(duration=3, leak_lpm=0.0, seed=1)
    ch = {k: v for k, v in rec.channels.items() if k != "speed"}
    bad = Recording(ch, rec.sample_rate, 0.0, {}, {"source": "eha_rig.parquet", "system": "eha"})
    with pytest.raises(RecordingError, match=r"eha_rig\.parquet.*needs channel\(s\) \['speed'\]"):
        if where == "fit":
            FlowBalanceDetector(system="eha").fit([bad])
        else:
            fitted.predict(bad)


def test_no_load_size_profiles_the_transducers_differential_offset():
    # unit 17's chamber transducers are 32.7 kPa apart at zero (p1 +5.2, p2 +37.9 kPa); without
    # load |P1 - P2| is tens of kPa, so the leak law on the measured difference sized a
    # 0.1 L/min leak 21 % low with an interval that excluded the truth. The leak's own windows
    # identify the offset (the residual does not depend on it, the leak law's shape does)
    healthy = [ld.sim.simulate_eha(duration=60, leak_lpm=0.0, machine=17, seed=s)
               for s in range(4)]
    det = FlowBalanceDetector(system="eha").fit(healthy)
    rec = ld.sim.simulate_eha(duration=60, leak_lpm=0.1, onset=30, machine=17, seed=99)
    m = rec.meta["machine"]
    true_offset = m["p1_offset_pa"] - m["p2_offset_pa"]
    assert true_offset == pytest.approx(-32_687.0, abs=1.0)
    v = det.predict(rec)
    achieved = rec.meta["leak_lpm_achieved"]
    assert v.leak and abs(v.leak_lpm / achieved - 1) <= 0.03
    lo, hi = v.leak_lpm_interval
    assert lo <= achieved <= hi
    # found within the transducers' gain errors (0.2 %) of the offset
    assert v.pressure_offset_pa == pytest.approx(true_offset, abs=4e3)
    assert v.as_dict()["pressure_offset_pa"] == v.pressure_offset_pa
    lo_d, hi_d = v.leak_lpm_interval_holds.rsplit("(the data allow ", 1)[1].split(" kPa)")[0] \
        .split(" to ")
    slo, shi = v.leak_lpm_interval_statistical
    assert (f"{v.pressure_offset_pa / 1e3:+.3g} kPa (the data allow {lo_d} to {hi_d} kPa) (that "
            f"part alone: {slo:.3g}-{shi:.3g} L/min), and the model error measured on ") \
        in v.leak_lpm_interval_holds
    assert float(lo_d) * 1e3 <= v.pressure_offset_pa <= float(hi_d) * 1e3
    assert "beyond the +-200 kPa" not in v.leak_lpm_interval_holds  # a plausible offset


def test_an_offset_beyond_what_two_transducers_can_differ_by_is_flagged():
    from leakdiag.detect._flow_balance_eha import size_interval_holds

    text = size_interval_holds(-3.65e5, (-4e5, 1e4))
    assert text == ("the coefficient's statistical error and an effective P1-P2 offset (the "
                    "transducers' zero error and whatever else shifts P1 - P2 at the working "
                    "pressure) found on the leak's windows, -365 kPa (the data allow -400 to +10 kPa); "
                    "beyond the +-200 kPa two calibrated transducers can differ by: the offset "
                    "is poorly determined here (large |P1-P2|, e.g. under load) or the "
                    "transducers' zero needs checking")


def test_offset_profile_by_hand():
    from leakdiag.detect._flow_balance_offset import profile_offset

    # k(d) peaks at d = -40 kPa; se 2 % of k; mean |g| 0.5 everywhere
    def ev(d):
        return 1.0 - ((d + 4e4) / 1e5) ** 2, 0.02, 0.5

    p = profile_offset(ev, 0.95)
    assert p.offset_pa == pytest.approx(-4e4, abs=50.0)
    assert p.size == pytest.approx(0.5, rel=1e-6)
    # the offsets whose (k / se)^2 is within 3.84 of the best: k >= sqrt(1 - 3.84 * 4e-4)
    # = 0.99923, |d + 40 kPa| <= 2.77 kPa: on the 10 kPa grid only the best point, so the
    # interval is the coefficient's own: (1 -+ 1.96 * 0.02) * 0.5
    assert p.size_interval == pytest.approx((0.5 * (1 - 1.96 * 0.02), 0.5 * (1 + 1.96 * 0.02)),
                                            rel=1e-3)
    # an offset beyond the range: the range doubles until the best is inside (here 2x)
    far = profile_offset(lambda d: (1.0 - ((d - 3e5) / 1e5) ** 2, 0.02, 0.5), 0.95)
    assert far.offset_pa == pytest.approx(3e5, abs=100.0)
    # a reverse "leak" (k < 0) never wins over the offsets that fit a leak
    q = profile_offset(lambda d: (-5.0 if d > 1e5 else 1.0, 0.02, 0.5), 0.95)
    assert q.offset_pa <= 1e5
    for bad, match in [(dict(level=1.0), "level"), (dict(level=0.9, half_range_pa=0.0),
                                                    "half_range_pa"),
                       (dict(level=0.9, grid_points=2), "grid_points")]:
        with pytest.raises(ValueError, match=match):
            profile_offset(ev, **bad)
    # no offset with a usable standard error: a clear error, not an empty interval
    with pytest.raises(ValueError, match="no offset gave a finite leak coefficient"):
        profile_offset(lambda d: (1.0, 0.0, 0.5), 0.95)
    with pytest.raises(ValueError, match="no offset gave a finite leak coefficient"):
        profile_offset(lambda d: (float("nan"), 0.02, 0.5), 0.95)


def test_spring_load_false_alarm_is_not_confirmed_by_a_free_pressure_offset(tmp_path, run_cli):
    """An audit (2026-11-29, session 28): unit 5 under the spring, a detector fitted at 25 false
    alarms per hour on 4 healthy runs, healthy runs alarmed at that rate (as promised) but read
    LEAK 0.0026 L/min with an interval above zero, because the size profiled the transducers'
    differential offset and found -800 kPa (the search's edge; the true -85 kPa): the free
    offset turned the unit's model error into a "lasting" leak. Under the spring an alarm is
    now confirmed on the measured pressures (the size still profiles the offset): such an alarm
    is refused as not lasting; a real leak is still sized."""
    from leakdiag.detect._flow_balance_eha import (confirms_with_offset_profile,
                                                   size_profiles_pressure_offset)

    assert size_profiles_pressure_offset("spring") and not confirms_with_offset_profile("spring")
    assert confirms_with_offset_profile("none") and confirms_with_offset_profile(None)

    def sim(name, seed, *extra):
        path = tmp_path / f"{name}.parquet"
        code, _, err = run_cli(["simulate", "eha", "--duration", "120", "--seed", str(seed),
                                "--machine", "5", "--load", "spring", *extra, "--out",
                                str(path), "--no-progress"])
        assert code == 0, err
        return str(path)

    fits = [sim(f"h{s}", s, "--leak", "0") for s in (101, 102, 103, 104)]
    det = tmp_path / "fb.joblib"
    code, _, err = run_cli(["fit", *[a for f in fits for a in ("--healthy", f)], "--method",
                            "flow-balance", "--false-alarm-rate", "25", "-o", str(det),
                            "--no-progress"])
    assert code == 0, err
    # since the high-side balance (2026-11-30) healthy runs 110-116 of this unit stay under
    # the level (with the two-side sum seeds 110-129 crossed it and were refused); none may
    # read LEAK, and none may quote the search's edge
    for seed in (110, 112):
        code, out, _ = run_cli(["detect", sim(f"healthy{seed}", seed, "--leak", "0"),
                                "--detector", str(det), "--no-progress"])
        assert code == 0 and "Decision: LEAK" not in out and "-800 kPa" not in out
    code, out, _ = run_cli(["detect", sim("leak", 111, "--leak", "0.3", "--onset", "60"),
                            "--detector", str(det), "--no-progress"])
    assert code == 0 and "Decision: LEAK" in out
    size = float(out.split("leak size (flow-balance): ")[1].split(" L/min")[0])
    offset_kpa = float(out.split("found on the leak's windows, ")[1].split(" kPa")[0])
    # the unit's differential zero error is -85 kPa; the effective offset also holds what else
    # shifts P1 - P2 at the working pressure (measured: -9x kPa two-sided, -93 high-side)
    assert 0.27 < size < 0.33 and -130 <= offset_kpa <= -60


def _channels(rec, **swap):
    ch = {k: v.copy() for k, v in rec.channels.items()}
    ch.update(swap)
    return Recording(ch, rec.sample_rate, rec.start_time, dict(rec.units), dict(rec.meta))


def test_a_reversed_position_sign_is_refused_not_read_as_a_leak():
    # an API audit (2026-11-30): a healthy spring run with x's sign reversed (its position
    # range is symmetric, so the range check passes it) read LEAK 0.8 L/min at p = 8e-5; the
    # piston now moves against the pump model's volume (ratio -0.97, healthy 1)
    from leakdiag.detect.flow_balance import _piston_valve_ratio

    det = FlowBalanceDetector(system="eha", false_alarms_per_hour=1.0).fit(
        [ld.sim.simulate_eha(duration=30, leak_lpm=0.0, load="spring", machine=17, seed=s)
         for s in range(3)])
    rec = ld.sim.simulate_eha(duration=30, leak_lpm=0.0, load="spring", machine=17, seed=40)
    assert not det.predict(rec).leak
    assert _piston_valve_ratio(det._terms(rec), 0) == pytest.approx(1.0, abs=0.01)
    flipped = _channels(rec, x=-rec["x"])
    assert _piston_valve_ratio(det._terms(flipped), 0) < -0.9
    with pytest.raises(RecordingError, match=r"the piston moved against the pump's flow: the "
                                             r"piston's volume is -0\.9\d times the pump "
                                             r"model's .* the motor speed's or the position's "
                                             r"sign is reversed"):
        det.predict(flipped)


def test_swapped_line_pressures_are_refused_at_fit_and_predict(fitted):
    # the same audit: pa and pb swapped read a healthy run LEAK 0.07 L/min (the pump-leakage
    # term changes sign); each line pressure is nearer its own chamber (Eqs. 3-7 to 3-12)
    from leakdiag.detect._flow_balance_eha import wiring_problem

    rec = ld.sim.simulate_eha(duration=30, leak_lpm=0.0, params=UNIT, seed=41)
    p1, p2, pa, pb = (rec[c][2000:] for c in ("p1", "p2", "pa", "pb"))
    own = np.mean(np.abs(pa - p1)) + np.mean(np.abs(pb - p2))
    cross = np.mean(np.abs(pa - p2)) + np.mean(np.abs(pb - p1))
    assert cross > 1.3 * own and wiring_problem(rec, 2000) is None
    swapped = _channels(rec, pa=rec["pb"], pb=rec["pa"])
    msg = (rf"the line pressures are nearer the other chamber than their own \(mean \|pa - p1\| "
           rf"\+ \|pb - p2\| = {cross / 1e3:.4g} kPa against \|pa - p2\| \+ \|pb - p1\| = "
           rf"{own / 1e3:.4g} kPa after the burn-in\)")
    assert wiring_problem(swapped, 2000).startswith(msg.replace("\\", ""))
    with pytest.raises(RecordingError, match="predict: .*" + msg):
        fitted.predict(swapped)
    healthy = [ld.sim.simulate_eha(duration=30, leak_lpm=0.0, params=UNIT, seed=s)
               for s in range(3)]
    with pytest.raises(RecordingError, match=r"fit: healthy recording 3 \(.*\): the line "
                                             r"pressures are nearer the other chamber"):
        FlowBalanceDetector(system="eha").fit(
            healthy[:2] + [_channels(healthy[2], pa=healthy[2]["pb"], pb=healthy[2]["pa"])])


def _high_side_reference(p1, p2, x, pa, pb, start, window, area, volume, line_volume, delta):
    """Plain-Python ``eha_high_side_sums`` of one window (sample units)."""
    ext = sg = l2 = ch = gg = 0.0
    for k in range(start + 1, start + window):
        d = ((pa[k] - pb[k]) + (pa[k - 1] - pb[k - 1])) / 2
        xm = (x[k] + x[k - 1]) / 2
        va, vb = volume + area * xm, volume - area * xm
        if abs(d) > delta:
            s = 1.0 if d > 0 else -1.0
            ps, pc, v = (pa, p1, va) if s > 0 else (pb, p2, vb)
            ext += s * (ps[k] + ps[k - 1]) / 2
            sg += s
            gg += 1.0
            ch += 2 * s * (line_volume * (ps[k] - ps[k - 1]) + v * (pc[k] - pc[k - 1]))
        else:
            l2 += d
            ch += (line_volume * ((pa[k] - pa[k - 1]) - (pb[k] - pb[k - 1]))
                   + va * (p1[k] - p1[k - 1]) - vb * (p2[k] - p2[k - 1]))
    return [ext, sg, l2, ch, gg]


def test_high_side_kernel_matches_plain_python():
    from leakdiag.detect._flow_balance_kernel import eha_high_side_sums

    rng = np.random.default_rng(4)
    n = 301
    pa = 1.4e6 + 4e5 * np.sin(np.linspace(0, 9, n)) + 2e4 * rng.standard_normal(n)
    pb = 1.4e6 - 4e5 * np.sin(np.linspace(0, 9, n)) + 2e4 * rng.standard_normal(n)
    p1, p2 = pa - 3e4 * rng.random(n), pb + 3e4 * rng.random(n)
    x = 0.01 * np.cos(np.linspace(0, 9, n))
    starts = np.array([0, 100, 200], dtype=np.int64)
    out = np.empty((3, 5))
    eha_high_side_sums(p1, p2, x, pa, pb, starts, 101, 1e-3, 2e-4, 5e-5, 2e5, out)
    for i, s in enumerate(starts):
        ref = _high_side_reference(p1, p2, x, pa, pb, s, 101, 1e-3, 2e-4, 5e-5, 2e5)
        np.testing.assert_allclose(out[i], ref, rtol=1e-12, atol=1e-9)
    assert 0 < out[:, 4].sum() < 300  # both kinds of interval occur


@pytest.mark.parametrize("rate", [1000.0, 4000.0])
def test_high_side_balance_drops_the_make_up_flow(rate):
    """Under the spring the low line sits at the charge pressure with its check valve open; the
    two-side sum keeps half the make-up flow, the high line's continuity does not (Eqs. 3-16
    to 3-19 with the valve shut). On a noise-free run with the true pump, what the high side
    leaves on windows wholly on one side is the trapezoidal rule's error: it falls with the
    sampling interval; the two-side sum's make-up flow does not."""
    from leakdiag.detect._flow_balance_eha import HIGH_SIDE_DELTA_PA, raw_sums

    rec = ld.sim.simulate_eha(duration=8, leak_lpm=0.0, seed=2, sensors=False, load="spring",
                              sample_rate=rate)
    ci, ce = P.pump_internal_leakage_m3_per_s_pa, P.pump_external_leakage_m3_per_s_pa
    high = EHAPumpModel(1.0, ci, P.bulk_modulus_pa, high_side_delta_pa=HIGH_SIDE_DELTA_PA,
                        case_drain_m3_per_s_pa=ce,
                        charge_flow_m3_per_s=ce * P.accumulator_pressure_pa)
    two = EHAPumpModel(1.0, ci + ce / 2, P.bulk_modulus_pa)
    w = int(rate / 10)  # 0.1-s windows: about half lie wholly on one side
    raw = raw_sums(rec, P, w, False, HIGH_SIDE_DELTA_PA)
    one_side = raw[:, 17] >= raw[:, 8] - 1e-12
    one_side[:2] = False  # the start-up transient
    assert one_side.sum() >= 40
    r_high = terms(rec, P, high, w, laminar=False)["residual"][one_side]
    r_two = terms(rec, P, two, w, laminar=False)["residual"][one_side]
    # measured: 1.8e-9 m^3 at 1 kHz, 3.2e-10 at 4 kHz; the two-side sum 1.1e-7 at both
    assert np.abs(r_two).max() > 8e-8
    assert np.abs(r_high).max() < (2.5e-9 if rate == 1000.0 else 5e-10)


def test_identification_takes_the_high_side_under_load_only():
    from leakdiag.detect._flow_balance_eha import HIGH_SIDE_DELTA_PA

    spring = [ld.sim.simulate_eha(duration=30, leak_lpm=0.0, params=UNIT, seed=s, load="spring")
              for s in range(4)]
    det = FlowBalanceDetector(system="eha", false_alarms_per_hour=1.0).fit(spring)
    assert det.model_.high_side_delta_pa == HIGH_SIDE_DELTA_PA
    # the high side separates the cross-port leakage from the case drain (1.5 x nominal)
    assert det.model_.pump_leakage_m3_per_s_pa == pytest.approx(
        UNIT.pump_internal_leakage_m3_per_s_pa, rel=0.05)
    assert det.model_.displacement_factor == pytest.approx(1.03, abs=2e-3)
    rec = ld.sim.simulate_eha(duration=40, leak_lpm=0.02, onset=20, params=UNIT, seed=11,
                              load="spring")
    v = det.predict(rec)
    assert v.leak and 20.0 <= v.alarm_time_s <= 25.0
    lo, hi = v.leak_lpm_interval
    assert lo <= rec.meta["leak_lpm_achieved"] <= hi


def test_no_load_fit_keeps_the_two_side_sum(fitted):
    assert fitted.model_.high_side_delta_pa is None
    assert fitted.model_.case_drain_m3_per_s_pa == 0.0 == fitted.model_.constant_flow_m3_per_s


@pytest.fixture(scope="module")
def unit313():
    """Unit 313 fitted on 8 nominal healthy 120-s runs under the spring (3-V drive)."""
    fit = [ld.sim.simulate_eha(duration=120, leak_lpm=0.0, load="spring", machine=313,
                               seed=1000 + i) for i in range(8)]
    return FlowBalanceDetector(system="eha", false_alarms_per_hour=1.0).fit(fit)


def test_spring_change_is_no_alarm_under_the_high_side_balance(unit313):
    """An audit (2026-11-30, session 29): under the spring the two-side sum's make-up flow is a
    leak-shaped model error that depends on the operating point; unit 313 fitted on 8 nominal
    runs alarmed on a healthy run whose spring softened to 0.7x at 60 s (score 1.5 against a
    level of 1.22, refused as not lasting; 17 of 40 such runs crossed). The high side has no
    make-up flow: the same run stays under the level, a 0.005 L/min leak does not."""
    det = unit313
    soft = ld.sim.EHAConditions(spring_change_time_s=60, spring_change_factor=0.7)
    rec = ld.sim.simulate_eha(duration=120, leak_lpm=0.0, load="spring", machine=313, seed=7,
                              conditions=soft)
    v = det.predict(rec)
    assert not v.leak and v.score_max < 0.6 * det.threshold_
    rec = ld.sim.simulate_eha(duration=120, leak_lpm=0.005, onset=60, load="spring",
                              machine=313, seed=7)
    v = det.predict(rec)
    assert v.leak and 60.0 <= v.alarm_time_s <= 70.0
    assert v.leak_lpm == pytest.approx(rec.meta["leak_lpm_achieved"], rel=0.2)


def test_a_pump_model_saved_before_the_high_side_keeps_the_two_side_sum():
    # a model pickled before the fields existed unpickles without them in its __dict__
    old = EHAPumpModel.__new__(EHAPumpModel)
    old.__dict__.update(displacement_factor=1.0, pump_leakage_m3_per_s_pa=7e-13,
                        bulk_modulus_pa=P.bulk_modulus_pa, baseline_leak_coefficient=0.0)
    rec = ld.sim.simulate_eha(duration=4, leak_lpm=0.0, seed=3, load="spring")
    t_old = terms(rec, P, old, 500, laminar=False)
    t_two = terms(rec, P, EHAPumpModel(1.0, 7e-13, P.bulk_modulus_pa), 500, laminar=False)
    np.testing.assert_array_equal(t_old["residual"], t_two["residual"])


def _line_offset(rec, pa_pa):
    ch = {k: v.copy() for k, v in rec.channels.items()}
    ch["pa"] = ch["pa"] + pa_pa
    return Recording(ch, rec.sample_rate, rec.start_time, dict(rec.units), dict(rec.meta))


@pytest.fixture(scope="module")
def spring_runs():
    return [ld.sim.simulate_eha(duration=40, leak_lpm=0.0, machine=313, seed=s, load="spring")
            for s in range(4)]


def test_a_line_transducer_zero_error_is_a_constant_flow_not_a_leak(spring_runs):
    """An audit (2026-11-30): pa reading 100 kPa low in the fit and the judged runs gave 19 of
    100 healthy spring runs of unit 313 a false alarm under the high-side balance (17 LEAK),
    3 of 100 under the two-side sum: the offset moves the leakage term by C (pa - pb) and the
    case drain of side A only, neither of which the balance had a term for. The constant flow
    takes it: the identified constant moves by about the leakage times the offset (0 without
    the term), and the size does not move. The false-alarm rate itself needs the audit's 100
    runs per case (/tmp/audit30a/repro_offset.py: 0 of 100 with the term), too slow here; on
    these 40-s runs the sizes held without the term as well."""
    dets = {o: FlowBalanceDetector(system="eha", false_alarms_per_hour=1.0).fit(
        [_line_offset(r, o) for r in spring_runs]) for o in (0.0, -1e5)}
    m0, m1 = dets[0.0].model_, dets[-1e5].model_
    shift = m1.constant_flow_m3_per_s - m0.constant_flow_m3_per_s
    leakage = m0.pump_leakage_m3_per_s_pa + m0.case_drain_m3_per_s_pa
    assert 0.5 * leakage * 1e5 < shift < 3.0 * leakage * 1e5  # measured 2.0x
    rec = ld.sim.simulate_eha(duration=40, leak_lpm=0.02, onset=20, machine=313, seed=11,
                              load="spring")
    sizes = []
    for o, det in dets.items():
        v = det.predict(_line_offset(rec, o))
        lo, hi = v.leak_lpm_interval
        assert v.leak and lo <= rec.meta["leak_lpm_achieved"] <= hi
        sizes.append(v.leak_lpm)
    assert sizes[1] == pytest.approx(sizes[0], rel=0.05)


def test_cross_fit_halves_take_the_whole_fit_s_balance():
    from leakdiag.detect._flow_balance_eha import HIGH_SIDE_DELTA_PA, identify

    recs = [ld.sim.simulate_eha(duration=20, leak_lpm=0.0, seed=s) for s in range(2)]
    args = (recs, P, [500, 500], False, [4, 4], False, False)
    assert identify(*args)[0].high_side_delta_pa is None  # no load: the two-side sum
    high = EHAPumpModel(1.0, 6e-13, P.bulk_modulus_pa, high_side_delta_pa=HIGH_SIDE_DELTA_PA)
    assert identify(*args, like=high)[0].high_side_delta_pa == HIGH_SIDE_DELTA_PA
    two = identify(*args, like=EHAPumpModel(1.0, 6e-13, P.bulk_modulus_pa))[0]
    assert two.high_side_delta_pa is None


def test_a_run_at_a_lower_drive_than_the_fit_is_refused_or_not_sized(unit313):
    """Audit F2 (2026-11-30): fitted at 3 V, a run at 1.5 V read a leak of about -0.006 L/min
    on its healthy windows (z about -14), so a 0.02 L/min leak was sized 0.72-0.74x with every
    interval missing the truth, and at 0.5 V 5 of 20 healthy runs read LEAK (scores within 2x
    the level). Now a healthy run there is refused (no verdict), naming what it read; a leak's
    strong alarm stands, without a size or coefficient."""
    from leakdiag.detect._flow_balance_eha import NEGATIVE_LEAK_Z

    rec = ld.sim.simulate_eha(duration=120, leak_lpm=0.0, load="spring", machine=313, seed=11,
                              amplitude=1.5)
    with pytest.raises(RecordingError, match="reads a leak of -0.00") as info:
        unit313.predict(rec)
    msg = str(info.value)
    z = float(msg.split(" standard errors")[0].rsplit("(", 1)[1])
    assert z < NEGATIVE_LEAK_Z == -5.0
    assert "does not describe this recording's operation" in msg
    assert "of the whole recording (no alarm)" in msg and "NO LEAK would not mean" in msg
    rec = ld.sim.simulate_eha(duration=120, leak_lpm=0.02, onset=60, load="spring",
                              machine=313, seed=11, amplitude=1.5)
    v = unit313.predict(rec)
    assert v.leak and 60.0 <= v.alarm_time_s <= 70.0 and v.score_max > 2 * v.threshold
    assert v.leak_lpm is None and v.leak_lpm_interval is None and v.leak_coefficient is None
    assert v.leak_lpm_interval_holds.startswith("no size: the flow balance reads a leak of -0.0")
    assert "before the onset of the test's alarm" in v.leak_lpm_interval_holds
    # the fit's own operation is judged: a healthy run at 3 V reads near zero
    ok = ld.sim.simulate_eha(duration=120, leak_lpm=0.0, load="spring", machine=313, seed=11)
    assert not unit313.predict(ok).leak
