"""``leakdiag benchmark --quick`` end to end, with sanity checks on its numbers."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.bench.scoring import RESULT_COLUMNS
from leakdiag.cli.main import main


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    cache = tmp_path_factory.mktemp("cache")
    code = main(["benchmark", "--quick", "--out", str(out), "--cache-dir", str(cache),
                 "--no-progress"])
    assert code == 0
    return out


def test_outputs_follow_the_contract(quick):
    for name in ("index.html", "results.csv", "summary.csv", "runs.csv", "settings.json"):
        assert (quick / name).is_file(), name
    res = pd.read_csv(quick / "results.csv")
    assert list(res.columns[: len(RESULT_COLUMNS)]) == RESULT_COLUMNS
    assert not res.duplicated(["method", "system", "leak_lpm"]).any()
    summ = pd.read_csv(quick / "summary.csv")
    assert set(summ.method) == set(res.method)
    assert "<img" in (quick / "index.html").read_text()


THESIS = ["acf-p1", "acf-p2", "ccf-p1p2", "ccf-ux", "mlr-p1", "combined"]


def test_large_leak_is_separated_on_the_vca(quick):
    res = pd.read_csv(quick / "results.csv")
    vca = res[(res.system == "vca") & (res.leak_lpm == 0.5) & res.method.isin(THESIS)]
    # 0.5 L/min (1.2 % of rated flow) is separated by the pressure-correlation methods
    assert vca.auc.max() == 1.0
    assert (vca.set_index("method").loc[["acf-p1", "ccf-p1p2"], "auc"] >= 0.9).all()


def test_false_alarm_rate_near_its_target(quick):
    runs = pd.read_csv(quick / "runs.csv")
    healthy = runs[(runs.role == "test_healthy") & runs.method.isin(THESIS)]
    assert len(healthy) == 2 * 6 * 8
    # 1 % per run targeted with thresholds extrapolated from 8 x 25 s of healthy data; under
    # the target, more than 7 alarms in 96 runs has probability < 1e-5. The quick suite's
    # measured rate is a few per cent (docs/detect.md): near, not at, the target.
    assert healthy.alarm.mean() <= 0.08


def test_onset_found_near_planted_onset(quick):
    runs = pd.read_csv(quick / "runs.csv")
    det = runs[(runs.role == "test_leak") & runs.alarm & (runs.alarm_time_s >= runs.onset_true_s)
               & runs.method.isin(THESIS)]
    assert len(det) >= 9
    err = (det.onset_est_s - det.onset_true_s).abs()
    assert err.median() < 3.0  # runs are 30 s, onsets 14-16 s


def test_cpu_time_per_hour_of_signal_is_measured(quick):
    res = pd.read_csv(quick / "results.csv")
    runs = pd.read_csv(quick / "runs.csv")
    assert (res.cpu_s_per_hour > 0).all()
    test = runs[runs.role.isin(["test_healthy", "test_leak"])]
    med = test.groupby(["method", "system"]).cpu_s_per_hour.median()
    got = res.groupby(["method", "system"]).cpu_s_per_hour.first()
    assert np.allclose(got.loc[med.index], med)
    # the thesis features run far faster than real time (3600 CPU s per hour of signal)
    assert (res[res.method.isin(THESIS)].cpu_s_per_hour < 360).all()
    assert "cpu_s_per_hour" in pd.read_csv(quick / "summary.csv").columns
    assert "cpu_s_per_hour" in (quick / "index.html").read_text()
