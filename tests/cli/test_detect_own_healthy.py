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


def _export(src, dst, drop=(), add=None):
    """``src`` re-saved with other columns: ``drop`` left out, ``add`` (name -> values) added."""
    from leakdiag.io import Recording, read_recording, write_recording

    r = read_recording(src)
    ch = {k: v for k, v in r.channels.items() if k not in drop}
    ch.update(add or {})
    meta = {k: v for k, v in r.meta.items() if k not in ("source", "origin")}
    return str(write_recording(Recording(ch, r.sample_rate, start_time=r.start_time,
                                         units={k: u for k, u in r.units.items() if k in ch},
                                         meta=meta), dst))


def test_a_copy_with_other_columns_is_the_same_run(run_cli, tmp_path):
    # a CLI audit, 2026-11-29: the samples were compared over every column, so a healthy run
    # re-saved without the simulator's leak_flow (a CSV export) or with an extra temperature
    # was another run: counted twice in a fit, judged against its own threshold, and a
    # healthy CSV export without leak_flow was refused by detect --healthy
    import numpy as np

    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    files = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=70 + s,
                                              reference_seed=170 + s),
                                 tmp_path / f"h{s}.parquet")) for s in range(5)]
    suspect = str(write_recording(simulate_vca(duration=20.0, leak_lpm=0.5, onset=10.0,
                                               seed=79, reference_seed=179),
                                  tmp_path / "s.parquet"))
    n = 20000
    extra = _export(files[0], tmp_path / "h0x.parquet", add={"temp": 40 + np.arange(n) * 1e-5})
    bare = _export(files[0], tmp_path / "h0.csv", drop=("leak_flow", "x_ref"))
    fit = ["fit", "-m", "acf-p1", "--system", "vca", "--false-alarm-rate", "100"]
    for twin in (extra, bare):
        code, _, err = run_cli([*fit, "--healthy", files[0], "--healthy", twin, "--healthy",
                                files[1], "-o", str(tmp_path / "dup.joblib")])
        assert code == 2 and "holds the same samples as healthy recording 1" in err, err
    det = tmp_path / "d.joblib"
    code, _, err = run_cli([*fit, *[a for h in files[:3] for a in ("--healthy", h)], "-o",
                            str(det)])
    assert code == 0, err
    for twin in (extra, bare):
        code, out, err = run_cli(["detect", twin, "--detector", str(det), "--no-progress"])
        assert code == 2 and "holds the same samples as one of the 3 healthy" in err, (out, err)
    code, _, err = run_cli(["analyze", bare, "--healthy", files[0], "-m", "autocorrelation",
                            "-c", "p1", "--window", "100"])
    assert code == 2 and f"--healthy {files[0]}: holds the same samples as {bare}" in err, err
    # healthy exports without leak_flow judge a suspect that has it (the methods read p1)
    bares = [_export(f, tmp_path / f"b{i}.csv", drop=("leak_flow", "x_ref"))
             for i, f in enumerate(files[1:])]
    code, out, err = run_cli(["detect", suspect, *[a for b in bares for a in ("--healthy", b)],
                              "--methods", "acf-p1", "--false-alarm-rate", "0.4",
                              "--no-progress"])
    assert code == 0 and "Decision:" in out, err
