"""``leakdiag batch`` with whole-recording detectors (the flow balance): each file read whole and
judged by ``predict``, its row what ``leakdiag detect --detector`` says of the file.

Until 2026-11-28 batch refused them ("judges whole recordings and cannot be streamed"), so the
project's physics-based detector could not judge a fleet's recordings in one job.
"""

import pytest

import leakdiag as ld
from leakdiag.batch import config_from_dict, read_results, run_batch, run_case
from leakdiag.cli.main import main
from leakdiag.io import write_recording


def _vca(seed, **kw):
    kw.setdefault("leak_lpm", 0.0)
    return ld.sim.simulate_vca(duration=40.0, load="spring", machine=17, seed=seed, **kw)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    from leakdiag.stream.detector_file import load_detector_file

    d = tmp_path_factory.mktemp("whole")
    healthy = [_vca(s) for s in range(3)]
    hfiles = [str(write_recording(r, d / f"h{i}.parquet")) for i, r in enumerate(healthy)]
    path = d / "fb.joblib"
    assert main(["fit", *[a for h in hfiles for a in ("--healthy", h)], "-m", "flow-balance",
                 "--no-progress", "-o", str(path)]) == 0
    det, _ = load_detector_file(path)
    recs = d / "recs"
    recs.mkdir()
    files = {"leak": write_recording(_vca(7, leak_lpm=0.05, onset=20.0), recs / "leak.parquet"),
             "ok": write_recording(_vca(8), recs / "ok.parquet"),
             "own": write_recording(healthy[0], recs / "own.parquet"),
             "eha": write_recording(ld.sim.simulate_eha(duration=20.0, leak_lpm=0.0, seed=1),
                                    recs / "eha.parquet")}
    return det, path, files


def _job(path, analyses=()):
    return config_from_dict({"detector": [{"path": str(path), "name": "fb"}],
                             "analysis": list(analyses)})


def test_a_flow_balance_row_is_its_predict_on_the_whole_file(fleet):
    det, path, files = fleet
    for name in ("leak", "ok"):
        (row,) = run_case(str(files[name]), _job(path))
        v = det.predict(ld.io.read_recording(files[name]))
        assert row["status"] == "ok" and row["kind"] == "detector" and row["name"] == "fb"
        assert row["method"] == "flow-balance" and row["channels"] == "p1,p2,x,u"
        assert row["alarm"] is v.leak and row["score_max"] == v.score_max
        assert row["p_value"] == v.confidence and row["threshold"] == det.threshold_
        assert row["verdict"] == str(v)
        # the decision detect makes with this detector alone (20-s runs: one segment)
        assert row["decision"] == ("leak" if v.leak else "no-leak")
        assert 0 < row["false_alarms_expected"] < 1 and row["run_level"] is None
        if v.leak:
            assert row["alarm_time_s"] == v.alarm_time_s and row["alarm_onset_s"] == v.onset_s
            assert row["leak_lpm"] == v.leak_lpm and \
                (row["leak_lpm_low"], row["leak_lpm_high"]) == v.leak_lpm_interval
            assert 19.0 <= v.onset_s <= 21.0 and row["detectable_lpm"] is None
            # what its interval holds, in its words (the store's alarm says it)
            assert row["leak_lpm_interval_holds"] == v.leak_lpm_interval_holds != ""
        else:  # a NO LEAK row states what it would have seen
            assert row["detectable_lpm"] == v.detectable_lpm > 0
            assert "sensitivity: a step leak of" in row["verdict"]
    assert name == "ok"


def test_rows_the_flow_balance_cannot_judge_say_why(fleet):
    det, path, files = fleet
    (own,) = run_case(str(files["own"]), _job(path))  # one of its healthy recordings
    assert own["status"] == "ok" and own["alarm"] is None
    assert own["error"].startswith("detector not judged: batch: ") and \
        "holds the same samples as one of the 3 healthy recordings" in own["error"]
    (eha,) = run_case(str(files["eha"]), _job(path))  # another rig: refused by name
    assert eha["status"] == "error" and "eha" in eha["error"] and "vca" in eha["error"]


def test_an_analysis_and_a_whole_recording_detector_in_one_job(fleet, tmp_path):
    _, path, files = fleet
    ana = {"method": "autocorrelation", "channels": ["p1"], "lag": 1, "window": 200,
           "overlap": 5}
    run_batch([str(files["leak"]), str(files["ok"])], _job(path, [ana]), tmp_path / "res",
              scheduler="serial")
    res = read_results(tmp_path / "res")
    assert sorted(zip(res["recording"], res["kind"])) == [
        ("leak.parquet", "analysis"), ("leak.parquet", "detector"),
        ("ok.parquet", "analysis"), ("ok.parquet", "detector")]
    det_rows = res[res["kind"] == "detector"].set_index("recording")
    assert bool(det_rows.loc["leak.parquet", "alarm"]) and \
        not bool(det_rows.loc["ok.parquet", "alarm"])
    assert det_rows.loc["ok.parquet", "detectable_lpm"] > 0


def test_the_cli_takes_a_flow_balance_file(fleet, tmp_path, capsys):
    _, path, files = fleet
    job = tmp_path / "job.toml"
    job.write_text("[job]\n")
    code = main(["batch", str(files["leak"]), str(files["ok"]), "--config", str(job),
                 "--detector", str(path), "-o", str(tmp_path / "res"), "--scheduler", "serial",
                 "--no-progress"])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "2 recording(s): 2 run, 0 already done, 0 error(s)" in out.out + out.err
    res = read_results(tmp_path / "res")
    assert res.set_index("recording")["alarm"].to_dict() == {"leak.parquet": True,
                                                             "ok.parquet": False}
    # the decisions' basis: the false LEAKs chance alone would give (a batch audit, 2026-11-29)
    expected = res["false_alarms_expected"].sum()
    assert 0 < expected < 2
    assert (f"  basis: were every recording healthy, chance alone would give about "
            f"{expected:.3g} LEAK(s) from fb (the sum of each run's false_alarms_expected") \
        in out.out


def test_the_store_says_what_the_flow_balance_interval_holds(fleet, tmp_path, run_cli):
    # a batch audit (2026-11-29): batch --store called it a "prediction interval", where
    # detect --store stored the flow balance's own words (its model error)
    from leakdiag.store import EventStore

    _, path, files = fleet
    db = tmp_path / "ev.db"
    code, out, err = run_cli(["batch", str(files["leak"]), "--detector", str(path), "-o",
                              str(tmp_path / "res"), "--scheduler", "serial", "--no-progress",
                              "--store", str(db)])
    assert code == 0, err
    code, out, err = run_cli(["detect", str(files["leak"]), "--detector", str(path), "--store",
                              str(tmp_path / "det.db"), "--actuator", "recs"])
    assert code == 0, err
    st, sd = EventStore(db), EventStore(tmp_path / "det.db")
    try:
        (batch,), (det,) = st.fleet().to_dict("records"), sd.fleet().to_dict("records")
    finally:
        st.close()
        sd.close()
    assert batch["leak_interval"].startswith("interval: ")
    assert batch["leak_interval"] == det["leak_interval"]


def test_a_refused_judgement_at_the_run_level_keeps_that_level_as_threshold(tmp_path,
                                                                             monkeypatch):
    """An audit (2026-11-29): a run longer than a healthy segment is judged at its run level,
    and when the detector then refused its alarm ("... level 3.53 ..."), the row (and
    ``--store``) kept the fitted threshold (3.28). Four 20-s no-load runs of machine 31 fitted
    for 36 per hour (14-s segments); the first 30 s of a 0.5 L/min leak from 25 s alarm at
    28.07 s with too little data after it. Refused as it was before the VCA's no-load size
    profiled the transducers' zero error (it reads LEAK since, without a size:
    tests/stream/test_monitor_segments.py); it stands for the refusals that remain."""
    import re

    import leakdiag.detect._flow_balance_vca as vca_backend

    monkeypatch.setattr(vca_backend, "OFFSET_PROFILED_LOADS", ())

    from leakdiag.detect.decision import raised_level
    from leakdiag.stream.detector_file import load_detector_file

    files = [str(write_recording(ld.sim.simulate_vca(duration=20.0, leak_lpm=0.0, load="none",
                                                     machine=31, seed=s),
                                 tmp_path / f"h{s}.parquet")) for s in range(100, 104)]
    path = tmp_path / "fb.joblib"
    assert main(["fit", *[a for f in files for a in ("--healthy", f)], "-m", "flow-balance",
                 "--false-alarm-rate", "36", "--no-progress", "-o", str(path)]) == 0
    det, _ = load_detector_file(path)
    import dataclasses

    full = ld.sim.simulate_vca(duration=50.0, leak_lpm=0.5, onset=25.0, load="none",
                               machine=31, seed=2000)
    rec = dataclasses.replace(full, channels={c: v[:30000] for c, v in full.channels.items()})
    part = write_recording(rec, tmp_path / "part.parquet")
    job = config_from_dict({"detector": [{"path": str(path), "name": "fb"}], "analysis": []})
    (row,) = run_case(str(part), job)
    assert row["alarm"] is None and "too few to confirm" in row["error"]
    # the detector alarmed and refused its alarm: judged, inconclusive (session 23: batch
    # printed "not judged" and exited 1, and the store said NOT JUDGED, where detect said
    # INCONCLUSIVE)
    assert row["alarm_refused"] is True and row["decision"] == "inconclusive"
    assert row["error"].startswith("alarm refused: predict: ")
    level, _ = raised_level(det, rec.n_samples, rec.sample_rate)
    assert level > det.threshold_
    assert row["threshold"] == pytest.approx(level)
    named = float(re.search(r"level (\d+\.\d+)\)", row["error"]).group(1))
    assert row["threshold"] == pytest.approx(named, abs=0.005)
    # detect reads the same file INCONCLUSIVE, as batch does (a CLI audit, 2026-11-29: it
    # exited 2, "no method could judge it")
    from click.testing import CliRunner

    from leakdiag.cli.main import cli

    db = tmp_path / "e.db"
    r = CliRunner().invoke(cli, ["detect", str(part), "--detector", str(path), "--store",
                                 str(db), "--actuator", "unit31"])
    assert r.exit_code == 0, r.output
    assert "Decision: INCONCLUSIVE -- flow-balance alarmed but refused its alarm: predict: " \
           in r.output and "too few to confirm a leak that began there" in r.output
    # beside a method that judged, the refused alarm is said under the decision line (a
    # consistency audit, 2026-11-29: the line named only the other method)
    acf = tmp_path / "acf.joblib"
    assert main(["fit", *[a for f in files for a in ("--healthy", f)], "-m", "acf-p1",
                 "--false-alarm-rate", "60", "--no-progress", "-o", str(acf)]) == 0
    r = CliRunner().invoke(cli, ["detect", str(part), "--detector", str(path), "--detector",
                                 str(acf)])
    assert r.exit_code == 0, r.output
    assert "\n  flow-balance alarmed but refused its alarm (no evidence of a leak): predict: " \
        in r.output
    r = CliRunner().invoke(cli, ["batch", str(part), "--detector", str(path), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial",
                                 "--no-progress", "--store", str(db)])
    assert r.exit_code == 0, r.output  # judged: no "not judged" row
    assert "1 current row(s) for job" in r.output and "0 of them not judged" in r.output
    assert "detector decisions: 0 LEAK, 0 NO LEAK, 1 INCONCLUSIVE" in r.output
    assert "  inconclusive: part.parquet: " in r.output and "not judged:" not in r.output
    from leakdiag.store import EventStore

    st = EventStore(db, create=False)
    fl = st.fleet().set_index("name")
    assert fl.loc["unit31", "state"] == "INCONCLUSIVE"  # detect's run
    assert "too few to confirm" in fl.loc["unit31", "error"]
    runs = st.runs_of(tmp_path.name)  # batch's actuator: the file's folder
    assert runs["status"].tolist() == ["inconclusive"]
    st.close()


def test_two_actuator_folders_of_one_name_are_refused_before_the_work(fleet, tmp_path, run_cli):
    # a batch audit (2026-11-29): refused only after every recording was judged, so nothing
    # was stored and the decisions were never printed
    import shutil

    _, path, files = fleet
    for site in ("siteA", "siteB"):
        (tmp_path / site / "pump").mkdir(parents=True)
        shutil.copy(files["ok"], tmp_path / site / "pump" / "run.parquet")
    code, out, err = run_cli(["batch", str(tmp_path / "site*" / "pump" / "*.parquet"),
                              "--detector", str(path), "-o", str(tmp_path / "res"),
                              "--scheduler", "serial", "--no-progress", "--store",
                              str(tmp_path / "ev.db")])
    assert code == 2 and "have the same folder name 'pump'" in err, (out, err)
    assert "recording(s)" not in out and not (tmp_path / "res").exists()


def test_one_unchecked_note_per_file_with_streamed_and_whole_detectors(fleet, tmp_path,
                                                                        run_cli):
    # a batch audit (2026-11-29): a CSV file stating no rig and no load got one note from the
    # streamed detectors and another from the flow balance, and batch printed both
    import pandas as pd

    _, path, files = fleet
    healthy = sorted(str(p) for p in path.parent.glob("h*.parquet"))
    acf = tmp_path / "acf.joblib"
    code, out, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", h)], "-m",
                              "acf-p1", "--false-alarm-rate", "30", "-o", str(acf)])
    assert code == 0, err
    rec = ld.io.read_recording(files["ok"])
    frame = pd.DataFrame({"time": rec.time, **rec.channels})
    csv = tmp_path / "bare.csv"   # no metadata: no rig, no load, no machine
    frame.to_csv(csv, index=False)
    code, out, err = run_cli(["batch", str(csv), "--detector", str(acf), "--detector",
                              str(path), "-o", str(tmp_path / "res"), "--scheduler", "serial",
                              "--no-progress"])
    assert code in (0, 1), err
    notes = read_results(tmp_path / "res")["unchecked"].dropna().unique()
    assert len(notes) == 1 and "bare.csv" in notes[0], notes
    assert (out + err).count(notes[0]) == 1
