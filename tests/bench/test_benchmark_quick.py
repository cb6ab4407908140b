"""``leakdiag benchmark --quick`` (suite v5) end to end, with checks on its numbers."""

import json
import time

import numpy as np
import pandas as pd
import pytest

from leakdiag.cli.main import main

THESIS = ["acf-p1", "acf-p2", "ccf-p1p2", "ccf-ux", "mlr-p1", "combined"]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    cache = tmp_path_factory.mktemp("cache")
    args = ["benchmark", "--quick", "-o", str(out), "--cache-dir", str(cache), "--no-progress"]
    assert main(args) == 0
    first = pd.read_csv(out / "runs.csv.gz")
    t0 = time.perf_counter()
    assert main(args) == 0  # resumed: fits and shards read back
    return out, first, time.perf_counter() - t0


def test_outputs_and_resume(quick):
    out, first, _ = quick
    for name in ("report.md", "summary.csv", "detection.csv", "false_alarms.csv", "fits.csv",
                 "runs.csv.gz", "settings.json", "figures/detection_vca_none_operating.png"):
        assert (out / name).is_file(), name
    again = pd.read_csv(out / "runs.csv.gz")
    pd.testing.assert_frame_equal(first, again)  # the resumed run reads the same results
    settings = json.loads((out / "settings.json").read_text())
    assert settings["suite_version"] == "5.0" and settings["false_alarm_per_run"] == 0.05
    assert f"leakdiag benchmark --out {out} --quick" in (out / "report.md").read_text()


def test_thresholds_are_conformal_with_their_bound(quick):
    fits = pd.read_csv(quick[0] / "fits.csv")
    assert set(fits.method) == set(THESIS) and fits.error.isna().all()
    # 20 calibration runs, 5 % per run: k = floor(0.05 * 21) = 1, bound 1/21
    assert (fits.n == 20).all() and (fits.k == 1).all()
    assert np.allclose(fits.bound_per_segment, 1 / 21) and (fits.segment_s == 25.0).all()


def test_every_rate_has_its_interval(quick):
    out = quick[0]
    far = pd.read_csv(out / "false_alarms.csv")
    assert (far.n_healthy == 20).all()
    assert ((far.far_low <= far.false_alarm_rate) & (far.false_alarm_rate <= far.far_high)).all()
    det = pd.read_csv(out / "detection.csv")
    for d in ("5s", "10s", "30s"):
        r = det[f"detection_rate_{d}"]
        assert ((det[f"det_low_{d}"] <= r) & (r <= det[f"det_high_{d}"])).all()
    # more time, more detections
    assert (det.detection_rate_5s <= det.detection_rate_10s).all()
    assert (det.detection_rate_10s <= det.detection_rate_30s).all()


def test_false_alarms_pooled_over_methods_not_above_target(quick):
    far = pd.read_csv(quick[0] / "false_alarms.csv")
    k, n = int(far.false_alarms.sum()), int(far.n_healthy.sum())
    from leakdiag.detect.rates import clopper_pearson

    lo, _ = clopper_pearson(k, n)
    assert lo <= 1 / 21  # not significantly above the 1/21 bound (runs shared by methods)


def test_large_vca_leak_found_within_ten_seconds_near_its_onset(quick):
    det = pd.read_csv(quick[0] / "detection.csv")
    row = det[(det.system == "vca") & (det.method == "ccf-p1p2")].iloc[0]
    assert row.leak_lpm == 0.5 and row.detection_rate_10s >= 0.75
    assert row.onset_error_median_s < 3.0


def test_per_unit_mode_pools_reference_maxima(tmp_path):
    from leakdiag.bench.v5_report import run_benchmark_v5

    res = run_benchmark_v5(tmp_path / "out", quick=True, systems=["vca"],
                           methods=["acf-p1", "combined"], unit_fit=2,
                           cache_dir=str(tmp_path / "cache"), progress=False)
    fits, runs = res["fits"], res["runs"]
    # 20 training units, each fitted on its 2 own runs: 20 out-of-sample reference maxima
    assert (fits.n_reference == 20).all() and fits.error.isna().all()
    ok = runs[runs.role != "error"]
    assert set(ok.method) == {"acf-p1", "combined"} and len(ok) == 2 * (20 + 4)
    # each held-out unit: 2 own (leave-one-run-out) maxima + 20 reference, k = floor(0.05 * 23)
    assert (ok.threshold_n == 22).all() and (ok.threshold_k == 1).all()
    assert (ok.threshold_method == "conformal").all()
    assert res["settings"]["unit_fit"] == 2
    # the report says on which basis the held-out runs were judged (a fallback would show)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| vca | none | acf-p1 | conformal | 1 | 22 | 24 |" in report


def test_full_budget_lifts_the_reduced_budget_through_the_cli(tmp_path, monkeypatch):
    """A method in REDUCED_BUDGET is fitted and judged on fewer runs unless --full-budget."""
    import leakdiag.bench.v5_run as v5_run

    monkeypatch.setattr(v5_run, "REDUCED_BUDGET", {"acf-p1": (19, 5, 1)})
    cache = tmp_path / "cache"
    common = ["benchmark", "--quick", "--systems", "vca", "--methods", "acf-p1",
              "--cache-dir", str(cache), "--no-progress"]
    assert main([*common, "-o", str(tmp_path / "reduced"), "--work-dir", str(tmp_path / "w1")]) == 0
    assert main([*common, "-o", str(tmp_path / "full"), "--work-dir", str(tmp_path / "w2"),
                 "--full-budget"]) == 0
    reduced = pd.read_csv(tmp_path / "reduced" / "runs.csv.gz")
    full = pd.read_csv(tmp_path / "full" / "runs.csv.gz")
    # quick VCA suite: 20 calibration, 20 healthy and 4 leaking runs (one size)
    assert (reduced.role == "test_healthy").sum() == 5 and (reduced.role == "test_leak").sum() == 1
    assert (full.role == "test_healthy").sum() == 20 and (full.role == "test_leak").sum() == 4
    fits_r = pd.read_csv(tmp_path / "reduced" / "fits.csv")
    fits_f = pd.read_csv(tmp_path / "full" / "fits.csv")
    assert fits_r.n.tolist() == [19] and fits_f.n.tolist() == [20]
    s_r = json.loads((tmp_path / "reduced" / "settings.json").read_text())
    s_f = json.loads((tmp_path / "full" / "settings.json").read_text())
    assert s_r["reduced_budget"] == {"acf-p1": [19, 5, 1]} and s_f["reduced_budget"] == {}


def test_every_fit_failing_is_an_error_with_a_report_of_the_fits(tmp_path, monkeypatch):
    """10 calibration runs cannot support 5 % per run (k < 1): the fit fails, and the run ends
    with an error naming it, after writing the fits table that lists it (it crashed with 'No
    objects to concatenate', then ended with exit 0 and a report of files it had not written)."""
    import leakdiag.bench.v5_run as v5_run
    from leakdiag.bench.outputs import NothingJudgedError
    from leakdiag.bench.v5_report import run_benchmark_v5

    monkeypatch.setattr(v5_run, "REDUCED_BUDGET", {"acf-p1": (10, 5, 1)})
    with pytest.raises(NothingJudgedError) as err:
        run_benchmark_v5(tmp_path / "out", quick=True, systems=["vca"], methods=["acf-p1"],
                         cache_dir=str(tmp_path / "cache"), progress=False)
    msg = str(err.value)
    assert msg.startswith(f"no held-out run was judged: 1 of 1 fits failed (listed in "
                          f"{tmp_path / 'out' / 'fits.csv'}); first: acf-p1 on vca none "
                          "operating: InsufficientHealthyDataError: 10 healthy maxima")
    assert msg.endswith(". The thresholds rest on 10 calibration runs per group: give "
                        "--full-budget with --n-cal 19 or more (acf-p1 is fitted on at most 10 "
                        "calibration runs without it), or a larger --false-alarm-rate (now "
                        "0.05)")
    fits = pd.read_csv(tmp_path / "out" / "fits.csv")
    assert fits.error.str.contains("InsufficientHealthyDataError").all()


def test_confidence_sets_calibration_conditional_levels_through_the_cli(tmp_path):
    """``--confidence``: 20 calibration runs at 5 % per run give k = 1 at 60 % confidence
    (P(Bin(20, .05) = 0) = 0.358 <= 0.4) and no level at 70 % (needs 24 maxima)."""
    cache = tmp_path / "cache"
    common = ["benchmark", "--quick", "--systems", "vca", "--methods", "acf-p1",
              "--cache-dir", str(cache), "--no-progress"]
    assert main([*common, "-o", str(tmp_path / "c60"), "--work-dir", str(tmp_path / "w1"),
                 "--confidence", "0.6"]) == 0
    fits = pd.read_csv(tmp_path / "c60" / "fits.csv")
    assert fits.k.tolist() == [1] and fits.confidence.tolist() == [0.6]
    settings = json.loads((tmp_path / "c60" / "settings.json").read_text())
    assert settings["threshold_confidence"] == 0.6
    assert "with probability 60 % over its healthy data" in (tmp_path / "c60" / "report.md").read_text()
    assert main([*common, "-o", str(tmp_path / "c70"), "--work-dir", str(tmp_path / "w2"),
                 "--confidence", "0.7"]) == 2  # no level at 70 %: nothing judged, an error
    fits = pd.read_csv(tmp_path / "c70" / "fits.csv")
    assert fits.error.str.contains("at 70 % confidence needs at least 24 maxima").all()
    assert main(["benchmark", "--suite", "v4", "-o", str(tmp_path / "v4"),
                 "--confidence", "0.9"]) == 2  # a usage error: v5 only
