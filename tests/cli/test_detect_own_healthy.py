"""``leakdiag detect --detector FILE`` refuses to judge a recording the detector was fitted on
(a review, 2026-11-27: after ``fit --healthy suspect.csv ...``, ``detect suspect.csv
--detector`` read NO LEAK against a threshold the suspect set itself, getting around the
``--healthy`` refusal)."""

import shutil


def test_detect_refuses_a_file_its_detector_was_fitted_on(run_cli, tmp_path):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    files = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=90 + s,
                                              reference_seed=190 + s),
                                 tmp_path / f"h{s}.csv")) for s in range(4)]
    det = tmp_path / "d.joblib"
    code, _, err = run_cli(["fit", *[a for h in files[:3] for a in ("--healthy", h)], "-m",
                            "acf-p1", "--system", "vca", "--false-alarm-rate", "100", "-o",
                            str(det)])
    assert code == 0, err
    copy = tmp_path / "copy.csv"
    shutil.copy(files[0], copy)
    for judged in (files[0], str(copy)):  # the file itself, or a copy of it
        code, out, err = run_cli(["detect", judged, "--detector", str(det), "--no-progress"])
        assert code == 2, (out, err)
        assert "holds the same samples as one of the 3 healthy recordings this FeatureDetector " \
               "was fitted on" in err, err
    code, out, err = run_cli(["detect", files[3], "--detector", str(det), "--no-progress"])
    assert code == 0 and "Decision:" in out, err
