"""Suite, registry and scoring of the benchmark: hand-computed values and invariants."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.bench.registry import METHODS, make_detector
from leakdiag.bench.run import per_run_target_per_hour, simulator_kwargs
from leakdiag.bench.scoring import minimum_detectable, roc_auc, roc_curve, summarise
from leakdiag.bench.suite import QUICK_SUITES, SUITES, Nuisance, build_suite
from leakdiag.detect.base import Alarm


def test_suite_is_fixed_disjoint_and_reproducible():
    a, b = build_suite(), build_suite()
    assert [c.seed for c in a] == [c.seed for c in b]
    assert [c.nuisance for c in a] == [c.nuisance for c in b]
    seeds = [c.seed for c in a]
    assert len(seeds) == len(set(seeds))  # every run its own seed: roles are disjoint
    vca = [c for c in a if c.system == "vca"]
    assert min(c.leak_lpm for c in vca if c.leak_lpm > 0) == 0.01
    assert max(c.leak_lpm for c in vca) == 0.5
    eha = [c for c in a if c.system == "eha"]
    assert {c.leak_lpm for c in eha if c.leak_lpm > 0} == {0.1, 0.2, 0.5, 1.0, 1.63}
    assert {(c.load, c.noise_level) for c in vca} == {("none", "low"), ("none", "high"),
                                                       ("spring", "low"), ("spring", "high")}


def test_nuisance_draws_inside_ranges_for_healthy_and_leaking_alike():
    n = Nuisance()
    for c in build_suite(SUITES, ("vca",)):
        nz = c.nuisance
        assert n.supply_ripple_pa[0] <= nz["supply_ripple_pa"] <= n.supply_ripple_pa[1]
        assert n.temperature_rise_k[0] <= nz["temperature_rise_k"] <= n.temperature_rise_k[1]
        if c.leak_lpm > 0:
            lo, hi = SUITES["vca"].onset_range_s
            assert lo <= c.onset_s <= hi
    temps = lambda role: [c.nuisance["temperature_rise_k"] for c in build_suite() if c.role == role]  # noqa: E731
    # same distribution for healthy and leaking runs: means within 2 K of each other
    assert abs(np.mean(temps("test_healthy")) - np.mean(temps("test_leak"))) < 2.0


def test_simulator_kwargs_switch_spring_change_with_load():
    cases = build_suite(SUITES, ("vca",))
    none = next(c for c in cases if c.load == "none")
    spring = next(c for c in cases if c.load == "spring")
    assert simulator_kwargs(none)["conditions"].spring_change_time_s is None
    assert simulator_kwargs(spring)["conditions"].spring_change_factor == spring.nuisance[
        "spring_change_factor"]
    assert simulator_kwargs(spring)["sensor_params"].pressure_noise_std_pa == spring.noise_std_pa


def test_per_run_target_conversion():
    # 1 % per run of 1 h monitored: -ln(0.99) alarms per hour
    # linear: one segment per run, as the fit turns the rate back (Poisson -ln(0.99) until a
    # statistics audit, 2026-11-29, fitted 0.09 per run for 0.0943)
    assert per_run_target_per_hour(0.01, 3600.0 + 5.0, 5.0) == pytest.approx(0.01, rel=1e-12)
    assert per_run_target_per_hour(0.09, 65.0, 5.0) * 60.0 / 3600.0 == pytest.approx(0.09)
    with pytest.raises(ValueError, match="per_run"):
        per_run_target_per_hour(1.0, 100.0, 5.0)
    # nothing monitored: refused (a statistics audit, 2026-11-30: ZeroDivisionError, and -36
    # per hour at 4 s with a 5-s burn-in)
    for duration in (5.0, 4.0):
        with pytest.raises(ValueError, match=rf"duration_s={duration!r} leaves nothing "
                                             r"monitored after burn_in_s=5\.0"):
            per_run_target_per_hour(0.01, duration, 5.0)


def test_registry_builds_unfitted_detectors():
    for name in METHODS:
        det = make_detector(name, "vca", Alarm())
        assert not hasattr(det, "threshold_")
    with pytest.raises(ValueError, match="unknown method 'nope'"):
        make_detector("nope", "vca", Alarm())


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 5), min_size=1, max_size=12),
       st.lists(st.integers(0, 5), min_size=1, max_size=12))
def test_auc_equals_area_under_roc_curve(null, alt):
    fpr, tpr = roc_curve(null, alt)
    area = float(np.sum(np.diff(fpr) * (tpr[1:] + tpr[:-1]) / 2))  # trapezoid handles ties
    assert roc_auc(null, alt) == pytest.approx(area)


def test_summarise_counts_alarm_before_onset_as_not_detected():
    runs = pd.DataFrame({
        "method": "m", "system": "vca", "role": ["test_healthy"] * 4 + ["test_leak"] * 4,
        "leak_lpm": [0.0] * 4 + [0.2] * 4, "score_max": [1, 2, 3, 4, 5, 6, 7, 8],
        "alarm": [False, False, False, True, True, True, True, False],
        "alarm_time_s": [None, None, None, 3.0, 9.0, 11.0, 13.0, None],
        "onset_true_s": [None] * 4 + [10.0] * 4, "onset_est_s": [None] * 4 + [8.0, 10.5, 11.0, None],
        "duration_s": 100.0})
    r = summarise(runs, {"vca": 40.0}).iloc[0]
    assert r.auc == 1.0 and r.false_alarm_rate == 0.25
    assert r.detection_rate == 0.5  # the alarm at 9 s precedes the onset at 10 s
    assert r.onset_error_median_s == pytest.approx(0.75) and r.detection_delay_median_s == 2.0
    assert r.leak_pct_rated == pytest.approx(0.5)
    # per hour of the monitored 95 s (100 s minus the 5-s burn-in), as targets are set
    assert r.false_alarms_per_hour == pytest.approx(0.25 * 3600 / 95)


def test_minimum_detectable_requires_all_larger_sizes():
    res = pd.DataFrame({"method": "m", "system": "vca", "leak_lpm": [0.01, 0.05, 0.1],
                        "detection_rate": [0.9, 1.0, 0.85], "false_alarm_rate": 0.0,
                        "n_test_healthy": 10})
    assert math.isnan(minimum_detectable(res).min_detectable_lpm.iloc[0])
    res.loc[2, "detection_rate"] = 0.95
    out = minimum_detectable(res, {"vca": 50.0}).iloc[0]
    assert out.min_detectable_lpm == 0.01 and out.min_detectable_pct_rated == pytest.approx(0.02)


def test_quick_suite_is_small():
    assert len(build_suite(QUICK_SUITES)) <= 40


def test_seeds_do_not_depend_on_selected_excitations():
    from dataclasses import replace

    full = [c for c in build_suite(SUITES, ("vca",)) if c.excitation == "operating"]
    only = build_suite({"vca": replace(SUITES["vca"], excitations=("operating",))})
    assert [c.seed for c in full] == [c.seed for c in only]
    assert [c.nuisance for c in full] == [c.nuisance for c in only]


def test_summarise_scores_leak_size_estimates_of_detected_runs():
    runs = pd.DataFrame({
        "method": "m", "system": "vca", "role": ["test_healthy"] + ["test_leak"] * 3,
        "leak_lpm": [0.0, 0.2, 0.2, 0.2], "score_max": [1.0, 5.0, 6.0, 7.0],
        "alarm": [False, True, True, False], "alarm_time_s": [None, 12.0, 13.0, None],
        "onset_true_s": [None, 10.0, 10.0, 10.0], "onset_est_s": [None, 10.0, 10.0, None],
        "duration_s": 100.0, "leak_lpm_est": [None, 0.15, 0.3, 0.2],
        "leak_lpm_low": [None, 0.1, 0.25, 0.1], "leak_lpm_high": [None, 0.25, 0.35, 0.3]})
    r = summarise(runs).iloc[0]
    # the undetected run's estimate is not used; one of two intervals holds 0.2
    assert r.n_size_estimates == 2 and r.leak_lpm_est_median == pytest.approx(0.225)
    assert r.leak_interval_coverage == 0.5


def test_cli_lists_methods_and_requires_out(capsys):
    from leakdiag.cli.main import main

    assert main(["benchmark", "--list-methods"]) == 0
    assert "ccf-ux" in capsys.readouterr().out.split()
    assert main(["benchmark", "--quick"]) == 2
    assert "--out DIR is required" in capsys.readouterr().err


def test_eha_structured_runs_use_the_step_input_without_input_variation():
    from leakdiag.sim.excitation import structured_excitation

    cases = [c for c in build_suite(SUITES, ("eha",)) if c.role == "fit"]
    assert {c.excitation for c in cases} == {"operating", "structured"}
    st_kw = simulator_kwargs(next(c for c in cases if c.excitation == "structured"))
    op_kw = simulator_kwargs(next(c for c in cases if c.excitation == "operating"))
    assert st_kw["input_signal"] == structured_excitation("eha")
    assert st_kw["conditions"].amplitude_variation == 0.0
    assert "input_signal" not in op_kw and op_kw["conditions"].amplitude_variation == 0.05


def test_summarise_reports_median_cpu_per_hour_of_all_held_out_runs():
    runs = pd.DataFrame({
        "method": "m", "system": "vca", "role": ["test_healthy"] * 2 + ["test_leak"] * 3,
        "leak_lpm": [0.0, 0.0, 0.2, 0.2, 0.5], "score_max": [1, 2, 5, 6, 7],
        "alarm": False, "alarm_time_s": None, "onset_true_s": [None, None, 10.0, 10.0, 10.0],
        "onset_est_s": None, "duration_s": 100.0, "cpu_s_per_hour": [1.0, 9.0, 2.0, 3.0, 4.0]})
    res = summarise(runs)
    assert res.cpu_s_per_hour.tolist() == [3.0, 3.0]  # median of 1, 9, 2, 3, 4
    summ = minimum_detectable(res)
    assert summ.cpu_s_per_hour.iloc[0] == 3.0 and summ.auc_max_leak.iloc[0] == 1.0


# ---------------------------------------------------------------- benchmark v5
def test_v5_suite_meets_the_issue_sizes_and_separates_units():
    from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite

    for system, lo, hi in (("vca", 0.002, 0.5), ("eha", 0.02, 1.63)):
        s = V5_SUITES[system]
        assert s.leak_lpm[0] == lo and s.leak_lpm[-1] == hi
        ratios = np.diff(np.log10(s.leak_lpm))
        assert (ratios > 0.2).all() and (ratios < 0.45).all()  # log-spaced (1-2-5 series)
        assert s.n_cal >= 300 and s.n_test_healthy >= 1000 and s.n_test_leak >= 50
        assert s.loads == ("none", "spring")
    cases = build_v5_suite(V5_SUITES)
    assert len({c.seed for c in cases}) == len(cases)
    train = {(c.system, c.nuisance["machine"]) for c in cases if c.role == "cal"}
    test = {(c.system, c.nuisance["machine"]) for c in cases if c.role != "cal"}
    assert not train & test  # test units never seen in fitting
    n_vca = 2 * (300 + 1000 + 8 * 50)
    assert sum(c.system == "vca" for c in cases) == n_vca
    leak = [c for c in cases if c.role == "test_leak"]
    assert all(20.0 <= c.onset_s <= 28.0 and c.duration_s - c.onset_s >= 30.0 for c in leak)


def _leak_runs(times, onset=20.0, size=0.1, load="none"):
    return pd.DataFrame({"method": "m", "system": "vca", "load": load, "excitation": "operating",
                         "role": "test_leak", "leak_lpm": size, "onset_true_s": onset,
                         "alarm": [t is not None for t in times], "alarm_time_s": times,
                         "onset_est_s": [None if t is None else onset + 1.0 for t in times]})


def test_v5_early_alarm_is_a_false_alarm_not_a_detection():
    from leakdiag.bench.v5_scoring import detection_table

    # onset 20 s: alarms at 19.9 (early), 20.0, 25, 29.99 (within 10 s), 35 (within 30 s only)
    det = detection_table(_leak_runs([19.9, 20.0, 25.0, 29.99, 35.0, None])).iloc[0]
    assert det.early_alarms == 1 and det.early_alarm_rate == pytest.approx(1 / 6)
    assert det.detected_5s == 2 and det.detected_10s == 3 and det.detected_30s == 4
    assert det.onset_error_median_s == pytest.approx(1.0)
    assert det.delay_median_s == pytest.approx(5.0)
    from leakdiag.detect.rates import clopper_pearson
    assert (det.det_low_10s, det.det_high_10s) == pytest.approx(clopper_pearson(3, 6))


def test_v5_minimum_detectable_per_load_every_larger_size_too():
    from leakdiag.bench.v5_scoring import detection_table, minimum_detectable_v5

    def runs(load, rates):
        parts = []
        for q, r in rates.items():
            hits = int(round(10 * r))
            parts.append(_leak_runs([21.0] * hits + [None] * (10 - hits), size=q, load=load))
        return pd.concat(parts)

    # no load: 0.01 at 90 % but 0.02 at 80 % -> MDL 0.05; spring: 0.02 and above -> 0.02
    r = pd.concat([runs("none", {0.01: 0.9, 0.02: 0.8, 0.05: 0.9, 0.1: 1.0}),
                   runs("spring", {0.01: 0.5, 0.02: 0.9, 0.05: 1.0, 0.1: 1.0})])
    mdl = minimum_detectable_v5(detection_table(r)).set_index("load")
    assert mdl.loc["none", "min_detectable_lpm"] == 0.05
    assert mdl.loc["spring", "min_detectable_lpm"] == 0.02  # never pooled with "none"
    assert mdl.loc["none", "mdl_det_low"] == pytest.approx(clopper_pearson_low(9, 10))
    none_never = runs("none", {0.01: 1.0, 0.1: 0.8})
    assert np.isnan(minimum_detectable_v5(detection_table(none_never)).min_detectable_lpm[0])


def clopper_pearson_low(k, n):
    from leakdiag.detect.rates import clopper_pearson

    return clopper_pearson(k, n)[0]


def test_v5_false_alarm_table_counts_healthy_runs_with_interval():
    from leakdiag.bench.v5_scoring import false_alarm_table

    runs = pd.DataFrame({"method": "m", "system": "eha", "load": "spring",
                         "excitation": "operating", "role": ["test_healthy"] * 300 + ["test_leak"],
                         "alarm": [True] * 3 + [False] * 297 + [True]})
    r = false_alarm_table(runs).iloc[0]
    assert (r.n_healthy, r.false_alarms) == (300, 3) and r.false_alarm_rate == 0.01
    assert r.far_high == pytest.approx(0.02894, abs=1e-4)  # 95 % CP upper bound of 3/300


def test_v5_a_refused_leaking_run_is_not_a_detection_and_a_refused_healthy_run_not_counted():
    """A method that refuses a held-out run (a sensor-consistency or blind-span refusal) gives
    the user no LEAK: for a leaking run that is a miss, not a run left out of the rate."""
    from leakdiag.bench.v5_common import error_row
    from leakdiag.bench.v5_scoring import detection_table, false_alarm_table

    class Case:
        system, load, excitation, seed, leak_lpm, onset_s = "vca", "none", "operating", 7, 0.1, 20.0
        role = "test_leak"

    err = pd.DataFrame([error_row(Case, "m", ValueError("refused"))])
    det = detection_table(pd.concat([_leak_runs([21.0, 22.0, 23.0]), err])).iloc[0]
    assert (det.n_leak, det.n_refused, det.detected_10s) == (4, 1, 3)
    assert det.detection_rate_10s == pytest.approx(0.75)
    Case.role, Case.leak_lpm, Case.onset_s = "test_healthy", 0.0, None
    healthy = pd.DataFrame({"method": "m", "system": "vca", "load": "none",
                            "excitation": "operating", "role": "test_healthy",
                            "alarm": [True, False, False]})
    err = pd.DataFrame([error_row(Case, "m", ValueError("refused"))])
    far = false_alarm_table(pd.concat([healthy, err])).iloc[0]
    assert (far.n_healthy, far.false_alarms, far.n_refused) == (3, 1, 1)


def test_v5_size_table_counts_only_runs_detected_in_time_and_their_coverage():
    from leakdiag.bench.v5_scoring import size_table
    from leakdiag.detect.rates import clopper_pearson

    # five runs of 0.1 L/min from 20 s: detected at 21, 25 and 29 s (sized), 35 s (too late),
    # 15 s (early); one healthy run with a size that must not count
    runs = pd.DataFrame({
        "method": "m", "system": "vca", "load": "spring", "excitation": "operating",
        "role": ["test_leak"] * 5 + ["test_healthy"], "leak_lpm": [0.1] * 5 + [0.0],
        "leak_lpm_achieved": [0.1, 0.08, 0.1, 0.1, 0.1, 0.0],
        "onset_true_s": [20.0] * 5 + [None], "alarm": [True] * 6,
        "alarm_time_s": [21.0, 25.0, 29.0, 35.0, 15.0, 30.0],
        "leak_lpm_est": [0.11, 0.08, 0.2, 0.1, 0.1, 0.05],
        "leak_lpm_low": [0.105, 0.07, 0.15, 0.09, 0.09, 0.04],
        "leak_lpm_high": [0.115, 0.09, 0.25, 0.11, 0.11, 0.06]})
    tab = size_table(runs)
    assert len(tab) == 1
    r = tab.iloc[0]
    ratio = np.array([1.1, 1.0, 2.0])  # 0.11/0.1, 0.08/0.08, 0.2/0.1
    assert r.n_sized == 3 and r.covered == 1  # only the 0.08 run's interval holds its truth
    assert r.ratio_median == pytest.approx(np.median(ratio))
    assert r.ratio_p90 == pytest.approx(np.quantile(ratio, 0.9))
    lo, hi = clopper_pearson(1, 3)
    assert (r.coverage, r.coverage_low, r.coverage_high) == pytest.approx((1 / 3, lo, hi))
    assert size_table(runs.drop(columns="leak_lpm_low")).empty  # no size columns: no table


def test_v5_alarm_maps_per_run_target_exactly():
    from leakdiag.bench.v5_run import v5_alarm

    a = v5_alarm(0.01, 60.0)
    assert a.segment_s == 55.0
    assert a.false_alarms_per_hour * a.segment_s / 3600.0 == pytest.approx(0.01, rel=1e-14)


def test_v5_shared_fit_only_for_detectors_with_the_base_fit():
    from leakdiag.bench.v5_run import shares_fit

    a = Alarm()
    assert shares_fit(make_detector("acf-p1", "vca", a))
    assert not shares_fit(make_detector("combined", "vca", a))  # covariance pass of its own
    # the EKF learns its hold limits and pressure noise from the runs it is fitted on
    assert not shares_fit(make_detector("ekf", "vca", a))
    if "flow-balance" in METHODS:
        assert not shares_fit(make_detector("flow-balance", "vca", a))  # its own fit


def test_v5_per_unit_reference_maxima_for_every_fit_that_pools_them():
    from leakdiag.bench.v5_unit import takes_reference

    a = Alarm(segment_s=55.0, burn_in_s=5.0, false_alarms_per_hour=0.01 * 3600 / 55.0)
    assert takes_reference(make_detector("acf-p1", "vca", a))
    assert takes_reference(make_detector("combined", "vca", a))
    fb = make_detector("flow-balance", "vca", a)
    assert takes_reference(fb)  # GLR maxima pooled since its fit takes reference_maxima
    # the suite's target and burn-in reach the flow balance (its segment = monitored span)
    assert fb.burn_in_s == 5.0 and fb.false_alarms_per_hour == pytest.approx(36 / 55)
    # and its segment: per run 1 % of 55 s, not of its 54 complete windows (k = 0 of 100)
    assert fb.segment_s == 55.0


def test_rate_figure_gives_twelve_methods_distinct_colours_and_markers():
    """Issue 15: more than ten methods stay distinguishable (colour and marker) in one figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    from leakdiag.bench.report import _rate_figure

    rows = [{"system": "vca", "method": f"m{i}", "leak_lpm": q, "detection_rate": 0.1 * i}
            for i in range(12) for q in (0.1, 0.5)]
    fig = _rate_figure(pd.DataFrame(rows), "vca", {})
    lines = fig.axes[0].get_lines()[:12]
    styles = {(tuple(ln.get_color()), ln.get_marker()) for ln in lines}
    colours = {tuple(ln.get_color()) for ln in lines}
    plt.close(fig)
    assert len(styles) == 12 and len(colours) == 12


def test_minimum_detectable_table_says_not_reached():
    import numpy as np
    import pandas as pd

    from leakdiag.bench.report import not_reached

    t = pd.DataFrame({"method": ["a", "b"], "min_detectable_lpm": [0.2, np.nan],
                      "min_detectable_pct_rated": [0.5, np.nan]})
    shown = not_reached(t)
    assert list(shown.min_detectable_lpm) == [0.2, "not reached"]
    assert list(shown.min_detectable_pct_rated) == [0.5, "not reached"]
    assert np.isnan(t.min_detectable_lpm[1])  # the data itself is untouched


def test_target_check_covers_every_method_with_the_common_threshold():
    """The EKF fits its own features (noise, hold limits) since 2026-11-27, but its threshold
    is still one CUSUM maximum per healthy run: an unsupported target is refused before any
    simulation for it too (the check had selected methods by a shared feature fit)."""
    from leakdiag.bench.benchmark import check_target_supported
    from leakdiag.bench.suite import QUICK_SUITES

    check_target_supported(QUICK_SUITES, ["ekf"], 0.12)
    for methods in (["ekf"], ["acf-p1"], ["combined"]):
        with pytest.raises(ValueError, match=r"^suite v4 fits each threshold on 8 healthy "
                                             r"fitting runs per group \(vca\)"):
            check_target_supported(QUICK_SUITES, methods, 0.05)
    if "flow-balance" in METHODS:  # its own fit and threshold: not checked here
        check_target_supported(QUICK_SUITES, ["flow-balance"], 0.05)


def test_v4_summary_gives_every_rate_its_count_and_interval():
    # a statistics audit (2026-11-30): the v4 results gave the detection rate, the per-hour
    # false-alarm rate and the size coverage bare
    from leakdiag.detect.rates import clopper_pearson

    healthy = pd.DataFrame({"role": "test_healthy", "leak_lpm": 0.0,
                            "score_max": np.arange(20.0),
                            "alarm": [True] * 2 + [False] * 18, "alarm_time_s": None,
                            "onset_true_s": None, "onset_est_s": None})
    hit = [True] * 7 + [False] * 3
    leak = pd.DataFrame({"role": "test_leak", "leak_lpm": 0.2, "score_max": 50.0 + np.arange(10),
                         "alarm": hit, "alarm_time_s": [12.0 if h else None for h in hit],
                         "onset_true_s": 10.0, "onset_est_s": [10.5 if h else None for h in hit],
                         "leak_lpm_est": 0.2, "leak_lpm_low": [0.1] * 5 + [0.3] * 5,
                         "leak_lpm_high": 0.5})
    runs = pd.concat([healthy, leak]).assign(method="m", system="vca", duration_s=65.0)
    r = summarise(runs).iloc[0]
    assert (r.detections, r.n_runs) == (7, 10)
    assert (r.detection_low, r.detection_high) == pytest.approx(clopper_pearson(7, 10))
    hours = (65.0 - 5.0) / 3600.0
    lo, hi = clopper_pearson(2, 20)
    assert r.false_alarms_per_hour == pytest.approx(0.1 / hours)
    assert (r.far_per_hour_low, r.far_per_hour_high) == pytest.approx((lo / hours, hi / hours))
    assert (r.n_size_estimates, r.n_covered) == (7, 5)  # lows of 0.3 miss the true 0.2
    assert r.leak_interval_coverage == pytest.approx(5 / 7)
    assert (r.coverage_low, r.coverage_high) == pytest.approx(clopper_pearson(5, 7))
