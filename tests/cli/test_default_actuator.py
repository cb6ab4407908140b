"""``detect`` and ``monitor`` with ``--store`` and no ``--actuator`` name the actuator after the
file's stem, unless that merges two actuators (store audit 2026-11-27, finding 2:
``rig1/run1.parquet`` with a leak and ``rig2/run1.parquet`` healthy became one actuator
``run1``, shown OK, the leak hidden)."""


def test_a_stem_of_another_folder_is_refused_and_stdin_needs_a_name(run_cli, tmp_path):
    import dataclasses

    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca
    from leakdiag.store import EventStore

    healthy = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=50 + s,
                                                reference_seed=150 + s),
                                   tmp_path / f"h{s}.parquet")) for s in range(3)]
    det = tmp_path / "d.joblib"
    code, _, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", h)], "-m", "acf-p1",
                            "--false-alarm-rate", "100", "-o", str(det)])
    assert code == 0, err
    rec = simulate_vca(duration=20.0, leak_lpm=None, seed=60, reference_seed=160)
    for rig in ("rig1", "rig2"):
        (tmp_path / rig).mkdir()
        write_recording(rec, tmp_path / rig / "run1.parquet")
    db = tmp_path / "ev.db"
    base = ["--detector", str(det), "--store", str(db)]
    code, out, err = run_cli(["detect", str(tmp_path / "rig1" / "run1.parquet"), *base,
                              "--no-progress"])
    assert code == 0 and "for run1 written to" in out, err
    code, out, err = run_cli(["detect", str(tmp_path / "rig1" / "run1.parquet"), *base,
                              "--no-progress"])
    assert code == 0, err  # the same file (folder) again: the same actuator
    # ... also through a symbolic link to its folder (a review found it refused the second time)
    (tmp_path / "link").symlink_to(tmp_path)
    for _ in range(2):
        code, out, err = run_cli(["detect", str(tmp_path / "link" / "rig1" / "run1.parquet"),
                                  *base, "--no-progress"])
        assert code == 0 and "for run1 written to" in out, err
    for cmd in (["detect", str(tmp_path / "rig2" / "run1.parquet"), *base, "--no-progress"],
                ["monitor", "--input", str(tmp_path / "rig2" / "run1.parquet"), *base]):
        code, out, err = run_cli(cmd)
        assert code == 2, (cmd, out, err)
        assert ("actuator 'run1' (the file's stem) already holds runs of "
                f"{tmp_path / 'rig1' / 'run1.parquet'}, a file in another folder" in err), err
        assert "--actuator rig2" in err
    code, out, err = run_cli(["detect", str(tmp_path / "rig2" / "run1.parquet"), *base,
                              "--no-progress", "--actuator", "rig2"])
    assert code == 0 and "for rig2 written to" in out, err
    st = EventStore(db)
    runs = st.runs_of("run1")
    assert set(runs["source"]) == {str(tmp_path / "rig1" / "run1.parquet")}  # absolute paths
    assert "rig2" in set(st.fleet()["name"])
    st.close()
    # standard input has no name: --store needs --actuator
    csv = tmp_path / "rec.csv"
    write_recording(dataclasses.replace(rec), csv)
    code, out, err = run_cli(["monitor", "--input", "-", *base], stdin=csv.read_text())
    assert code == 2 and "--store with standard input needs --actuator NAME" in err, err


def test_stdin_without_a_name_is_refused_before_the_detector_is_read(run_cli, tmp_path):
    # an audit (2026-11-30): the detector's own warnings came first, then the usage error; a
    # file that is no detector shows the order (its error was the one reported)
    db, bad = tmp_path / "events.db", tmp_path / "bad.joblib"
    bad.write_text("not a detector")
    code, out, err = run_cli(["monitor", "-", "--detector", str(bad), "--store", str(db)],
                             stdin="0,1,2\n")
    assert code == 2 and "--store with standard input needs --actuator NAME" in err, err
    assert "bad.joblib" not in err and not db.exists()
