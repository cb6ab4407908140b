"""Detector files (``leakdiag.stream.save_detector`` / ``load_detector_file``): what they refuse,
what they warn about, and what they keep (audit of 2026-11-27: bare tracebacks, records without
the file's name, silent loads of files fitted by other code, flipped bits, edited records)."""

import hashlib
import os
import pickle
import re

import joblib
import numpy as np
import pytest

from leakdiag.detect.base import Alarm
from leakdiag.detect.methods import thesis_detector
from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca
from leakdiag.stream import (DetectorFileWarning, DetectorMeta, load_detector_file,
                             save_detector)
from leakdiag.stream.detector_file import (DETECTOR_FINGERPRINT_PARTS, _meta_sha256,
                                           detector_code_fingerprint)

META = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"}, n_healthy=2)


@pytest.fixture(scope="module")
def fitted():
    det = thesis_detector("vca", "autocorrelation",
                          alarm=Alarm(false_alarms_per_hour=100.0, burn_in_s=1.0))
    return det.fit([simulate_vca(duration=20.0, leak_lpm=None, seed=s) for s in (1, 2)])


@pytest.fixture
def saved(fitted, tmp_path):
    p = tmp_path / "det.joblib"
    save_detector(fitted, META, p)
    return p


def _rewrite(src, dst, rehash=False, **changes):
    """The record of ``src`` with ``changes`` (``meta`` entries merged), written to ``dst``;
    ``rehash``: with the record's SHA-256 made anew (as a leakdiag that wrote it would)."""
    rec = joblib.load(src)
    meta = {**rec["meta"], **changes.pop("meta", {})}
    if rehash:
        changes["meta_sha256"] = _meta_sha256(meta)
    joblib.dump({**rec, "meta": meta, **changes}, dst)
    return dst


def _payload(raw: bytes) -> dict:
    return {"detector_pickle": raw, "payload_sha256": hashlib.sha256(raw).hexdigest()}


def test_round_trip_keeps_threshold_and_records_code_fingerprint_and_sha(fitted, saved):
    det, meta = load_detector_file(saved)  # no warning: filterwarnings = error
    assert det.threshold_ == fitted.threshold_
    assert meta.code_fingerprint == detector_code_fingerprint()
    assert re.fullmatch(r"[0-9a-f]{16}", meta.code_fingerprint)
    assert (meta.method, meta.system, meta.channels) == ("acf-p1", "vca", ("p1",))
    rec = joblib.load(saved)
    assert rec["format"] == "leakdiag-detector/2"
    assert rec["payload_sha256"] == hashlib.sha256(rec["detector_pickle"]).hexdigest()
    assert re.fullmatch(r"[0-9a-f]{64}", rec["meta_sha256"])
    assert DETECTOR_FINGERPRINT_PARTS == ("detect", "features", "literature", "stream", "io")


@pytest.mark.parametrize("obj,shown", [
    (np.arange(3.0), "numpy.ndarray"), ([1, 2], "list"), ("det", "str"), (None, "None"),
])
def test_a_bare_non_detector_is_refused_naming_what_it_holds(tmp_path, obj, shown):
    p = tmp_path / "x.joblib"
    joblib.dump(obj, p)
    with pytest.raises(ValueError) as e:
        load_detector_file(p)
    assert str(e.value) == f"{p}: not a leakdiag detector (holds {shown})"


def test_a_record_whose_detector_is_a_dict_is_refused(saved, tmp_path):
    raw = pickle.dumps({"threshold_": 1.0})
    p = _rewrite(saved, tmp_path / "d.joblib", **_payload(raw))
    with pytest.raises(ValueError, match=re.escape(f"{p}: not a leakdiag detector (holds dict)")):
        load_detector_file(p)


@pytest.mark.parametrize("change,message", [
    ({"meta": {"new_field": 1}}, "its record has field(s) new_field that this leakdiag (0.1.0) "
                                 "does not know: written by a newer leakdiag"),
    ({"meta": None}, "no 'meta' record, not a table of what the detector was fitted on"),
    ({"meta": {"sample_rate_hz": "1000"}}, "its record's sample_rate_hz is '1000' (str), not a "
                                           "number > 0: the file is damaged or was edited"),
    ({"meta": {"channels": "p1"}}, "its record's channels is 'p1' (str), not a list of strings"),
])
def test_record_problems_name_the_file_and_the_field(saved, tmp_path, change, message):
    rec = joblib.load(saved)
    if change["meta"] is None:
        del rec["meta"]
    else:
        rec["meta"] = {**rec["meta"], **change["meta"]}
    p = tmp_path / "bad.joblib"
    joblib.dump(rec, p)
    with pytest.raises(ValueError) as e:
        load_detector_file(p)
    assert str(e.value).startswith(f"{p}: {message}"), str(e.value)


def test_a_record_missing_required_fields_says_which(saved, tmp_path):
    rec = joblib.load(saved)
    rec["meta"] = {k: v for k, v in rec["meta"].items() if k not in ("method", "sample_rate_hz")}
    p = tmp_path / "m.joblib"
    joblib.dump(rec, p)
    with pytest.raises(ValueError, match=re.escape(f"{p}: its record lacks method, "
                                                   "sample_rate_hz: the file is damaged")):
        load_detector_file(p)


def test_wrong_file_types_are_named_before_anything_is_unpickled(tmp_path):
    pq = write_recording(simulate_vca(duration=1.0, leak_lpm=None, seed=1), tmp_path / "r.parquet")
    (tmp_path / "r.csv").write_text("time,p1\n0.0,1.0\n0.001,2.0\n")
    (tmp_path / "r.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100))
    (tmp_path / "rnd.bin").write_bytes(bytes([191, 7, 250, 3]) + bytes(range(256)) * 2)
    (tmp_path / "empty.joblib").write_bytes(b"")
    expected = {
        pq: "a Parquet file (a recording?), not a detector file from leakdiag fit",
        tmp_path / "r.csv": "cannot load as a detector file: a text file (a CSV recording?), "
                            "not a detector file from leakdiag fit",
        tmp_path / "r.h5": "an HDF5 file (a recording?), not a detector file from leakdiag fit",
        tmp_path / "rnd.bin": "neither a joblib file nor a pickle (it starts with bytes "
                              "bf 07 fa 03), not a detector file from leakdiag fit",
        tmp_path / "empty.joblib": "empty (0 bytes): not a detector file from leakdiag fit",
    }
    for path, msg in expected.items():
        with pytest.raises(ValueError) as e:
            load_detector_file(path)
        assert str(e.value) == f"{path}: {msg}"


def test_a_truncated_file_says_so(saved, tmp_path):
    p = tmp_path / "cut.joblib"
    p.write_bytes(saved.read_bytes()[:200])
    with pytest.raises(ValueError, match=re.escape(f"{p}: truncated or not a detector file from "
                                                   "leakdiag fit (")):
        load_detector_file(p)


def test_other_code_warns_with_both_fingerprints(saved, tmp_path):
    p = _rewrite(saved, tmp_path / "old.joblib", rehash=True,
                 meta={"code_fingerprint": "0123456789abcdef"})
    mine = detector_code_fingerprint()
    with pytest.warns(DetectorFileWarning) as w:
        det, meta = load_detector_file(p)
    assert len(w) == 1
    assert str(w[0].message) == (
        f"{p}: fitted by leakdiag code 0123456789abcdef (version 0.1.0), this is code {mine} "
        "(version 0.1.0); it may be scored differently than when it was fitted: re-fit it with "
        "leakdiag fit")
    assert meta.code_fingerprint == "0123456789abcdef"


def test_a_file_of_format_1_loads_with_a_warning_that_its_code_is_unknown(fitted, saved,
                                                                           tmp_path):
    """Files written before 2026-11-27: the detector pickled inside the record, no fingerprint
    and no SHA-256."""
    meta = {k: v for k, v in joblib.load(saved)["meta"].items() if k != "code_fingerprint"}
    p = tmp_path / "v1.joblib"
    joblib.dump({"format": "leakdiag-detector/1", "meta": meta, "detector": fitted}, p)
    with pytest.warns(DetectorFileWarning, match=re.escape(
            f"{p}: the code that fitted it is unknown (leakdiag 0.1.0, written before detector "
            "files recorded it)")):
        det, m = load_detector_file(p)
    assert det.threshold_ == fitted.threshold_ and m.code_fingerprint is None


@pytest.mark.parametrize("old,new,why", [
    (b"FeatureDetector", b"FeatureDetectoX",
     "Can't get attribute 'FeatureDetectoX' in module leakdiag.detect.methods"),
    (b"leakdiag.detect.methods", b"leakdiag.detect.methodz",
     "No module named 'leakdiag.detect.methodz'"),
])
def test_classes_this_version_lacks_mean_another_version(fitted, saved, tmp_path, old, new, why):
    raw = pickle.dumps(fitted, protocol=pickle.HIGHEST_PROTOCOL).replace(old, new)
    p = _rewrite(saved, tmp_path / "moved.joblib", **_payload(raw))
    with pytest.raises(ValueError) as e:
        load_detector_file(p)
    assert str(e.value) == (f"{p}: written by another leakdiag version whose classes this one "
                            f"does not have ({why}): re-fit it with leakdiag fit")


def test_a_flipped_bit_in_the_detector_is_caught(saved, tmp_path):
    rec = joblib.load(saved)
    raw = bytearray(rec["detector_pickle"])
    raw[len(raw) // 2] ^= 1
    p = _rewrite(saved, tmp_path / "flip.joblib", detector_pickle=bytes(raw))
    with pytest.raises(ValueError, match=re.escape(f"{p}: damaged: the detector's SHA-256 is ")):
        load_detector_file(p)


@pytest.mark.parametrize("meta", [{"method": "ccf-p1p2"}, {"system": "eha"},
                                  {"false_alarms_per_hour": 0.01}])
def test_an_edited_record_is_refused(saved, tmp_path, meta):
    """An edited method made an acf-p1 detector report 'alarm from ccf-p1p2'."""
    p = _rewrite(saved, tmp_path / "edited.joblib", meta=meta)
    m = joblib.load(p)["meta"]
    with pytest.raises(ValueError) as e:
        load_detector_file(p)
    assert str(e.value) == (f"{p}: its record (method {m['method']}, system {m['system']}, ...) "
                            "does not match the SHA-256 leakdiag fit stored with it: the record "
                            "was edited or the file is damaged; re-fit it with leakdiag fit")


@pytest.mark.parametrize("meta,diff", [
    ({"system": "eha"}, "its record says acf-p1 with system 'eha', but the detector was fitted "
                        "on 'vca' recordings"),
    ({"channels": ["p2"]}, "its record says acf-p1 with channels p2, but the detector reads p1"),
])
def test_a_record_that_does_not_describe_its_detector_is_refused(fitted, saved, tmp_path, meta,
                                                                 diff):
    """Also in files of format 1 (no SHA-256): the detector's own attributes are compared."""
    raw = {k: v for k, v in joblib.load(saved)["meta"].items() if k != "code_fingerprint"}
    p = tmp_path / "v1.joblib"
    joblib.dump({"format": "leakdiag-detector/1", "meta": {**raw, **meta}, "detector": fitted}, p)
    with pytest.raises(ValueError) as e:
        load_detector_file(p)
    assert str(e.value) == (f"{p}: {diff}: the record was edited or the file is damaged; re-fit "
                            "it with leakdiag fit")


def test_save_refuses_non_detectors_unfitted_ones_and_wrong_records(fitted, tmp_path):
    p = tmp_path / "d.joblib"
    with pytest.raises(TypeError, match=re.escape(f"{p}: not written: not a leakdiag detector "
                                                  "(a dict: no fit, predict or score_windows)")):
        save_detector({"toy": 1}, META, p)
    unfitted = thesis_detector("vca", "autocorrelation")
    with pytest.raises(ValueError, match=re.escape(f"{p}: not written: FeatureDetector is not "
                                                   "fitted; call fit(healthy_recordings) first")):
        save_detector(unfitted, META, p)
    with pytest.raises(ValueError, match=re.escape(f"{p}: not written: its record says ccf-p1p2 "
                                                   "with channels p1,p2, but the detector reads "
                                                   "p1")):
        save_detector(fitted, DetectorMeta("ccf-p1p2", "vca", 1000.0, ("p1", "p2")), p)
    assert os.listdir(tmp_path) == []


class _Unpicklable:
    threshold_ = 1.0

    def score_windows(self, values, time):
        return values

    def __reduce__(self):
        raise RuntimeError("cannot pickle this scorer")


def test_a_failed_write_leaves_the_old_file_and_no_half_file(saved):
    before = saved.read_bytes()
    with pytest.raises(RuntimeError, match="cannot pickle this scorer"):
        save_detector(_Unpicklable(), META, saved)
    assert saved.read_bytes() == before
    assert sorted(os.listdir(saved.parent)) == ["det.joblib"]


def test_written_file_gets_the_mode_of_a_new_file(saved):
    mask = os.umask(0)
    os.umask(mask)
    assert saved.stat().st_mode & 0o777 == 0o666 & ~mask
