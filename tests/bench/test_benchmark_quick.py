"""``leakdiag benchmark --quick`` end to end, with sanity checks on its numbers."""

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


def test_large_leak_is_separated_by_thesis_methods(quick):
    res = pd.read_csv(quick / "results.csv")
    big = res[res.leak_lpm == res.groupby("system").leak_lpm.transform("max")]
    # the pressure-correlation methods separate the largest leak on the quick suite
    best = big.groupby("system").auc.max()
    assert (best >= 0.9).all(), big[["method", "system", "auc"]]


def test_false_alarm_rate_near_its_target(quick):
    runs = pd.read_csv(quick / "runs.csv")
    healthy = runs[runs.role == "test_healthy"]
    # 1 % per run targeted; pooled over methods (~24 healthy evaluations) expect ~0.24 alarms.
    # More than 4 (P < 1e-4 under the target) means a broken calibration.
    assert healthy.alarm.sum() <= 4


def test_onset_found_near_planted_onset(quick):
    runs = pd.read_csv(quick / "runs.csv")
    det = runs[(runs.role == "test_leak") & runs.alarm & (runs.alarm_time_s >= runs.onset_true_s)]
    assert len(det) >= 3
    err = (det.onset_est_s - det.onset_true_s).abs()
    assert err.median() < 3.0  # runs are 30 s, onsets 14-16 s
