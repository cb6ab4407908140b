"""``leakdiag detect`` says when a verdict rests on fewer windows than it judged (undefined
feature windows: a constant or stuck channel; audit of users' recordings, 2026-11-27)."""

import numpy as np


def test_detect_names_the_undefined_windows_a_verdict_did_without(run_cli, tmp_path):
    import dataclasses

    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    healthy = [str(write_recording(simulate_vca(duration=40, leak_lpm=0.0, seed=s),
                                   tmp_path / f"h{s}.parquet")) for s in range(4)]
    det = tmp_path / "acf.joblib"
    code, out, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", h)], "-m",
                              "acf-p1", "--false-alarm-rate", "30", "-o", str(det)])
    assert code == 0, err
    rec = simulate_vca(duration=40, leak_lpm=0.0, seed=20)
    p1 = np.array(rec["p1"])
    p1[30000:38000] = p1[30000]  # stuck for 8 s: under the 10-s span limit, judged
    stuck = write_recording(dataclasses.replace(rec, channels={**rec.channels, "p1": p1}),
                            tmp_path / "stuck.parquet")
    code, out, err = run_cli(["detect", str(stuck), "--detector", str(det), "--no-progress"])
    assert code == 0, err
    assert "Decision: NO LEAK" in out, out
    line = [ln for ln in out.splitlines() if "windows undefined" in ln]
    assert len(line) == 1 and line[0].startswith("  acf-p1: ") and line[0].endswith(
        "(a feature undefined there: a constant or stuck channel?); its verdict rests on the "
        "others"), out
    n, m = (int(v) for v in line[0].split(": ")[1].split(" windows")[0].split(" of "))
    assert 35 <= n <= 45 and m > 2 * n  # about 8 s of 0.19-s windows, under half of them
    # the same file, sensor working: nothing said
    clean = write_recording(rec, tmp_path / "clean.parquet")
    code, out, _ = run_cli(["detect", str(clean), "--detector", str(det), "--no-progress"])
    assert code == 0 and "windows undefined" not in out
