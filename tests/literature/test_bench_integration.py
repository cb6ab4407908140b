"""The literature methods and the structured excitation inside the benchmark (issue 6)."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.bench.registry import DEFAULT_METHODS, METHODS, make_detector
from leakdiag.bench.run import simulator_kwargs
from leakdiag.bench.scoring import minimum_detectable, summarise
from leakdiag.bench.suite import EXCITATIONS, SUITES, build_suite
from leakdiag.detect.base import Alarm
from leakdiag.bench.comparison import comparison_suite
from leakdiag.literature.registry import LITERATURE_METHODS
from leakdiag.sim.excitation import PeriodicSteps


def test_literature_methods_registered_and_default():
    for name, target in LITERATURE_METHODS.items():
        assert METHODS[name] == target and name in DEFAULT_METHODS
        det = make_detector(name, "vca", Alarm())
        assert det.alarm == Alarm()


def test_full_suite_has_both_excitations_with_disjoint_seeds():
    assert EXCITATIONS == ("operating", "structured")
    cases = build_suite(SUITES, ("vca",))
    by_exc = {e: {c.seed for c in cases if c.excitation == e} for e in EXCITATIONS}
    assert all(by_exc.values()) and not (by_exc["operating"] & by_exc["structured"])


def test_structured_case_gets_the_periodic_step_reference():
    cases = build_suite(comparison_suite(), ("vca",))
    op = next(c for c in cases if c.excitation == "operating")
    st = next(c for c in cases if c.excitation == "structured")
    assert "reference" not in simulator_kwargs(op)
    ref = simulator_kwargs(st)["reference"]
    assert isinstance(ref, PeriodicSteps) and ref.period_s == 1.0 and ref.amplitude == 0.01


def test_scoring_keeps_excitations_apart():
    rows = []
    for exc, leak_score in (("operating", 1.5), ("structured", 9.0)):
        rows += [{"method": "m", "system": "vca", "excitation": exc, "role": "test_healthy",
                  "leak_lpm": 0.0, "score_max": s, "alarm": False, "alarm_time_s": np.nan,
                  "onset_true_s": np.nan, "onset_est_s": np.nan, "duration_s": 100.0}
                 for s in (1.0, 2.0)]
        rows += [{"method": "m", "system": "vca", "excitation": exc, "role": "test_leak",
                  "leak_lpm": 0.1, "score_max": leak_score, "alarm": leak_score > 5,
                  "alarm_time_s": 51.0 if leak_score > 5 else np.nan, "onset_true_s": 50.0,
                  "onset_est_s": 50.5 if leak_score > 5 else np.nan, "duration_s": 100.0}]
    res = summarise(pd.DataFrame(rows)).set_index("excitation")
    assert res.loc["operating", "auc"] == pytest.approx(0.5)
    assert res.loc["structured", "auc"] == 1.0
    assert res.loc["structured", "detection_rate"] == 1.0
    mdl = minimum_detectable(res.reset_index()).set_index("excitation").min_detectable_lpm
    assert np.isnan(mdl["operating"]) and mdl["structured"] == 0.1


def test_ekf_refuses_eha_recordings():
    from leakdiag.io.recording import Recording
    from leakdiag.literature.ekf import run_vca_ekf

    z = np.zeros(10)
    rec = Recording({"u": z, "x": z, "p1": z, "p2": z}, 1000.0, meta={"system": "eha"})
    with pytest.raises(ValueError, match="system='eha'; the EKF implements the VCA model only"):
        run_vca_ekf(rec)
