"""``leakdiag detect --store``: the decision is printed before the verdicts are stored, so a
store that refuses the run (an actuator of another rig) cannot swallow it (store audit
2026-11-27, finding 10: the table was printed, then the error, and no Decision line)."""


def test_a_store_that_refuses_the_run_keeps_the_decision(run_cli, tmp_path):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca
    from leakdiag.store import EventStore

    healthy = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=80 + s,
                                                reference_seed=180 + s),
                                   tmp_path / f"h{s}.parquet")) for s in range(3)]
    leak = str(write_recording(simulate_vca(duration=20.0, leak_lpm=0.5, onset=10.0, seed=90,
                                            reference_seed=190), tmp_path / "leak.parquet"))
    db = tmp_path / "ev.db"
    st = EventStore(db)  # the name is an EHA's in the store
    st.end_run(st.start_run("rig1", command="monitor", source="pump.csv", feature="acf p1",
                            sample_rate_hz=1000.0, system="eha"), "finished")
    st.close()
    args = ["detect", leak, *[a for h in healthy for a in ("--healthy", h)], "--methods",
            "ccf-p1p2", "--false-alarm-rate", "0.5", "--no-progress", "--store", str(db),
            "--actuator", "rig1"]
    code, out, err = run_cli(args)
    assert code == 2
    assert "actuator 'rig1' is a" in err and "give it another name" in err, err
    assert "Decision: LEAK" in out, out  # printed before the store refused the run
    # under another name the same run is stored after the same decision
    code, out, err = run_cli(args[:-1] + ["rig2"])
    assert code == 0, err
    assert out.index("Decision: LEAK") < out.index("alarm(s) for rig2 written to")
