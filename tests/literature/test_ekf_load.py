"""load="auto" reads the recording's load as every other part of leakdiag compares it
(stripped, lower-cased; None or empty: not stated) and refuses a load the filter's model has
no case for, naming the recording. Before, " spring", "Spring" or a None load raised
"load=' spring' must be one of ['none', 'spring']" without naming the recording."""

import numpy as np
import pytest

from leakdiag.io.recording import Recording, RecordingError
from leakdiag.literature.detectors import EKFDetector
from leakdiag.literature.registry import ekf


def _rec(load, source="rig4/run7.parquet", absent=False):
    n = 100
    meta = {"system": "vca", "source": source}
    if not absent:
        meta["load"] = load
    return Recording({c: np.zeros(n) for c in ("u", "x", "p1", "p2")}, 1000.0, meta=meta)


@pytest.mark.parametrize("stated,used", [("spring", "spring"), ("Spring", "spring"),
                                         (" spring ", "spring"), ("SPRING\n", "spring"),
                                         ("none", "none"), (" None", "none"), (None, "none"),
                                         ("", "none"), ("  ", "none")])
def test_auto_load_normalised_like_the_rest_of_leakdiag(stated, used):
    assert ekf("vca", None).ekf_params(_rec(stated)).load == used


def test_auto_load_not_stated_or_no_recording_is_none():
    det = EKFDetector(load="auto")
    assert det.ekf_params(_rec(None, absent=True)).load == "none"
    assert det.ekf_params().load == "none"


@pytest.mark.parametrize("stated", ["spring 5 kN/m", "no load", "mass 20 kg"])
def test_auto_load_without_a_model_case_is_refused_naming_recording_and_load(stated):
    with pytest.raises(RecordingError, match=(
            rf"rig4/run7\.parquet: load {stated!r}: the EKF's model has a case for the loads "
            r"\['none', 'spring'\] only .*load='auto' cannot filter this recording: correct "
            r"its meta\['load'\], or give EKFDetector the load it should assume")):
        ekf("vca", None).ekf_params(_rec(stated))


def test_explicit_load_normalised_too():
    assert EKFDetector(load=" Spring").ekf_params(_rec("none")).load == "spring"
    with pytest.raises(ValueError, match=r"load='heavy' must be one of \['none', 'spring'\]"):
        EKFDetector(load="heavy").ekf_params()
