"""Runs that judged nothing do not vote OK on the fleet page and do not clear a standing alarm
(store audit of 2026-11-27, finding 1), through the CLI entry point: a monitor without a
detector, a monitor whose every window lies in the burn-in, a monitor that went BLIND, a batch
job of analysis entries only, and a detect whose method could not judge the file."""

import numpy as np
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.store import EventStore


def _run(args):
    with CliRunner().isolation() as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


@pytest.fixture(scope="module")
def files(leak_case, tmp_path_factory):
    """rig7 (leak from 30 s), a 4-s cut of it (shorter than the 5-s burn-in plus a window) and
    a copy whose p1 sticks from 20 s on (before the leak: a stuck sensor, the monitor BLIND)."""
    from leakdiag.io import write_recording

    d = tmp_path_factory.mktemp("judged")
    rec = leak_case["rec"]
    short = d / "short.parquet"
    write_recording(rec.slice_time(0.0, 4.0), short)
    df = rec.to_pandas()
    stuck_at = df["time"] >= 20.0
    df.loc[stuck_at, "p1"] = df.loc[stuck_at, "p1"].iloc[0]
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = pq.read_table(leak_case["recording"])
    i = t.schema.get_field_index("p1")
    stuck = d / "stuck.parquet"
    pq.write_table(t.set_column(i, t.schema.field(i), pa.array(df["p1"].to_numpy())), stuck)
    return {"leak": str(leak_case["recording"]), "short": str(short), "stuck": str(stuck),
            "det": str(leak_case["detector_path"]), "dir": d}


def _row(db, name):
    st = EventStore(db, create=False)
    try:
        return st.fleet().set_index("name").loc[name].to_dict(), st.runs_of(name)
    finally:
        st.close()


def test_runs_that_judged_nothing_are_not_ok_and_clear_no_alarm(files, leak_case, tmp_path):
    db = str(tmp_path / "ev.db")
    code, out, err = _run(["detect", files["leak"], "--detector", files["det"], "--store", db,
                           "--actuator", "rigA", "--no-progress"])
    assert code == 0 and "Decision: LEAK" in out, err
    alarm_t = leak_case["verdict"].alarm_time_s
    row, _ = _row(db, "rigA")
    assert (row["state"], row["last_alarm_time_s"]) == ("ALARM", alarm_t)
    # each of these judged nothing: before the fix each of them turned rigA's row OK
    for args in (["monitor", files["leak"]],  # no detector
                 ["monitor", files["short"], "--detector", files["det"]],  # all in burn-in
                 ["monitor", files["stuck"], "--detector", files["det"]]):  # BLIND
        code, out, err = _run([*args, "--store", db, "--actuator", "rigA", "-q"])
        # a run all in the burn-in is refused, exit 2, as detect refuses it (finding 4 of the
        # streams audit, 2026-11-27); the store holds it as before
        assert code == (2 if args[1] == files["short"] else 0), err
        row, runs = _row(db, "rigA")
        assert (row["state"], row["last_alarm_time_s"]) == ("ALARM", alarm_t), args
    assert runs["status"].tolist() == ["unjudged", "unjudged", "finished", "finished"]


def test_each_kind_of_non_judgment_is_shown_with_its_reason(files, tmp_path):
    db = str(tmp_path / "ev.db")
    for name, args in (("nodet", ["monitor", files["leak"]]),
                       ("short", ["monitor", files["short"], "--detector", files["det"]]),
                       ("stuck", ["monitor", files["stuck"], "--detector", files["det"]])):
        code, out, err = _run([*args, "--store", db, "--actuator", name, "-q"])
        assert code == (2 if name == "short" else 0), err
    row, runs = _row(db, "nodet")
    assert row["state"] == "NO DETECTOR" and runs["status"].tolist() == ["finished"]
    assert row["error"] == ("autocorrelation p1 1 N=200 5%: no detector: monitor without "
                            "--detector computes the feature only, nothing was judged")
    row, runs = _row(db, "short")
    assert (row["state"], runs["status"].tolist()) == ("NOT JUDGED", ["unjudged"])
    assert row["error"].endswith(f"{files['short']}: no window was scored: all 21 windows lie "
                                 "in the detector's burn-in (the stream is shorter than the "
                                 "burn-in plus one window), nothing was judged")
    row, runs = _row(db, "stuck")
    assert (row["state"], runs["status"].tolist()) == ("NOT JUDGED", ["unjudged"])
    assert f": BLIND: {files['stuck']}: the feature " in row["error"]
    assert "no alarm there rules nothing out" in row["error"]
    # a healthy judgment afterwards is OK: the rule is about judging, not about the actuator
    code, out, err = _run(["monitor", files["leak"], "--detector", files["det"], "--store", db,
                           "--actuator", "nodet", "-q"])
    assert code == 0, err
    assert _row(db, "nodet")[0]["state"] == "ALARM"


def test_batch_analysis_only_is_no_detector_and_detect_cannot_judge_is_not_judged(files,
                                                                                 tmp_path):
    import shutil

    db = str(tmp_path / "ev.db")
    (tmp_path / "recs" / "rigB").mkdir(parents=True)
    shutil.copy(files["leak"], tmp_path / "recs" / "rigB" / "run1.parquet")
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    code, out, err = _run(["batch", str(tmp_path / "recs" / "**" / "*.parquet"), "--config",
                           str(job), "--out", str(tmp_path / "res"), "--scheduler", "serial",
                           "--no-progress", "--store", db])
    assert code == 0 and "1 run(s) written" in out, err
    row, _ = _row(db, "rigB")
    assert row["state"] == "NO DETECTOR"
    assert row["error"].endswith("no detector: a batch analysis entry computes the feature "
                                 "only, nothing was judged")
    # detect of a file its method cannot judge: NOT JUDGED as batch says it, not FAILED
    code, out, err = _run(["detect", files["short"], "--detector", files["det"], "--store", db,
                           "--actuator", "shortdet", "--no-progress"])
    assert code == 2
    row, runs = _row(db, "shortdet")
    assert (row["state"], runs["status"].tolist()) == ("NOT JUDGED", ["unjudged"])
    assert row["error"] and np.all(runs["error"].notna())
