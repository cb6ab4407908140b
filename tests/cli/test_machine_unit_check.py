"""A detector fitted on one machine's healthy recordings refuses a recording of another
machine, whatever its method (a CLI audit, 2026-11-29, session 28: feature detectors judged
healthy runs of other units LEAK "false-alarm rate at most 0.2" in 3 of 7 pairs, while the
flow balance refused them; units differ more than a leak changes the features)."""

import pytest

from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca
from leakdiag.stream.detector_file import DetectorMeta, check_detector_fits, common_machine


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    out = {}
    for name, machine, seed in (("a1", 3, 1), ("a2", 3, 2), ("a3", 3, 3), ("a_test", 3, 4),
                                ("b", 4, 5), ("nominal", None, 6)):
        out[name] = d / f"{name}.parquet"
        write_recording(simulate_vca(duration=30.0, leak_lpm=0.0, machine=machine, seed=seed),
                        out[name])
    return out


def _fit(files, names, det, run_cli):
    """``leakdiag fit`` of a ccf-p1p2 detector on the named healthy files: (code, out, err)."""
    return run_cli(["fit", *[a for k in names for a in ("--healthy", str(files[k]))],
                    "--method", "ccf-p1p2", "--false-alarm-rate", "40", "-o", str(det),
                    "--no-progress"])


def test_a_feature_detector_file_refuses_another_machine(files, tmp_path, run_cli):
    det = tmp_path / "ccf.joblib"
    code, _, err = _fit(files, ("a1", "a2", "a3"), det, run_cli)
    assert code == 0, err
    for other, unit in (("b", "4"), ("nominal", "'nominal'")):
        code, out, err = run_cli(["detect", str(files[other]), "--detector", str(det),
                                  "--no-progress"])
        assert code == 2 and "Decision" not in out
        assert (f"{files[other]}: machine unit {unit}, but {det} was fitted on healthy "
                "recordings of machine unit 3: machines differ more than a leak changes what a "
                "detector measures; fit one on healthy recordings of this machine") in err
    code, out, err = run_cli(["detect", str(files["a_test"]), "--detector", str(det),
                              "--no-progress"])
    assert code == 0 and "Decision:" in out  # its own machine: judged


def test_healthy_recordings_of_another_machine_are_refused_by_detect(files, run_cli):
    code, out, err = run_cli(["detect", str(files["b"]), *[a for k in ("a1", "a2", "a3") for a
                                                          in ("--healthy", str(files[k]))],
                              "--methods", "ccf-p1p2", "--false-alarm-rate", "0.3",
                              "--no-progress"])
    assert code == 2 and (f"{files['b']}: machine unit 4, but the --healthy recordings are all "
                          "of machine unit 3") in err


def test_a_fleet_or_unstated_fit_checks_no_machine():
    m = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"}, machine=3)
    with pytest.raises(ValueError, match="machine unit 4, but d.joblib was fitted on healthy "
                                         "recordings of machine unit 3"):
        check_detector_fits(m, sample_rate=1000.0, source="r.csv", path="d.joblib", machine=4)
    check_detector_fits(m, sample_rate=1000.0, source="r.csv", path="d.joblib", machine=3)
    check_detector_fits(m, sample_rate=1000.0, source="r.csv", path="d.joblib")  # unstated
    fleet = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"})  # machine None
    check_detector_fits(fleet, sample_rate=1000.0, source="r.csv", path="d.joblib", machine=4)
    assert common_machine([{"machine": {"unit": 3}}, {"machine": {"unit": 4}}]) is None


def test_fit_says_a_fleet_fit_of_several_units(files, tmp_path, run_cli):
    """A CLI audit (2026-11-29, session 28): fit took healthy runs of three units with only the
    generic "another machine's among them goes unnoticed"; a fleet fit is allowed (the
    benchmark's fleet mode), and now said as one, and its file checks no unit."""
    det = tmp_path / "fleet.joblib"
    code, out, err = _fit(files, ("a1", "b", "nominal"), det, run_cli)
    assert code == 0, err
    assert ("the healthy recordings name 3 machine units (3, 4, nominal): a fleet fit, so the "
            "recordings judged are not checked against a unit") in " ".join(out.split())
    from leakdiag.stream.detector_file import load_detector_file

    assert load_detector_file(det)[1].machine is None
    for other in ("a_test", "a2"):  # judged by the fleet fit (its file names no unit)
        code, out, err = run_cli(["detect", str(files[other]), "--detector", str(det),
                                  "--no-progress"])
        assert code == 0 and "Decision:" in out, err
