"""Event store: schema, round trip, fleet state, concurrent writers, killed writer, versions."""

import os
import re
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from leakdiag.store import (SCHEMA_VERSION, AlarmRecord, ChunkSummary, EventStore, StoreError,
                            store_url, summarize_chunks, summarize_windows)

from ._rows import child_env, drop_version_5_columns, summary

WRITER = Path(__file__).with_name("_writer.py")


def test_schema_tables_and_version(tmp_path):
    db = tmp_path / "e.db"
    EventStore(db).close()
    con = sqlite3.connect(db)
    tables = {r[0] for r in con.execute("select name from sqlite_master where type='table'")}
    assert tables == {"schema_version", "actuators", "runs", "chunk_summaries", "alarms"}
    assert con.execute("select version from schema_version").fetchall() == [(SCHEMA_VERSION,)]
    assert con.execute("pragma journal_mode").fetchone()[0] == "wal"
    cols = [r[1] for r in con.execute("pragma table_info(chunk_summaries)")]
    assert cols[:5] == ["id", "run_id", "seq", "recorded_at", "t_start_s"]
    con.close()


def test_round_trip(tmp_path):
    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig1", command="monitor", source="a.parquet", feature="ac p1",
                       sample_rate_hz=1000.0, threshold=12.5, system="vca", config={"window": 200})
    assert st.add_chunk(run, summary(0)) == (0, [])
    seq, ids = st.add_chunk(run, summary(1, True), [AlarmRecord(1.4, 13.0, 12.5, onset_s=0.9,
                                                                 leak_lpm=0.1, leak_lpm_low=0.05,
                                                                 leak_lpm_high=0.15)])
    assert seq == 1 and len(ids) == 1
    st.add_chunk(run, summary(2, False), alarm_updates={ids[0]: {"cleared_time_s": 2.3}})
    st.end_run(run)
    st.close()
    st = EventStore(tmp_path / "e.db", create=False)
    summ, al = st.history("rig1")
    assert summ["seq"].tolist() == [0, 1, 2]
    assert summ["t_start_s"].tolist() == [0.0, 1.0, 2.0]
    assert summ["value_mean"].tolist() == pytest.approx([0.0, 0.1, 0.2], abs=0)
    assert summ["score_max"].tolist() == [0.0, 2.0, 4.0]
    assert summ["alarm"].tolist()[1:] == [True, False]
    assert summ["feature"].unique().tolist() == ["ac p1"]
    a = al.iloc[0]
    assert (a.alarm_time_s, a.onset_s, a.leak_lpm, a.leak_lpm_low, a.leak_lpm_high,
            a.cleared_time_s) == (1.4, 0.9, 0.1, 0.05, 0.15, 2.3)
    assert st.count("runs") == 1 and st.count("chunk_summaries") == 3
    fl = st.fleet()
    assert fl.loc[0, "state"] == "OK" and fl.loc[0, "leak_lpm"] == 0.1
    with pytest.raises(StoreError, match="no actuator named 'nope'"):
        st.history("nope")


def test_fleet_state_alarm_ok_nodata(tmp_path):
    st = EventStore(tmp_path / "e.db")
    r1 = st.start_run("b-rig", command="monitor", source="b", feature="f", threshold=12.0)
    st.add_chunk(r1, summary(0, True), [AlarmRecord(0.5, 20.0, 12.0)])
    r2 = st.start_run("a-rig", command="monitor", source="a", feature="f", threshold=12.0)
    st.add_chunk(r2, summary(0, False))
    st.start_run("c-rig", command="monitor", source="c", feature="f", threshold=12.0)
    fl = st.fleet()
    assert fl["name"].tolist() == ["a-rig", "b-rig", "c-rig"]
    assert fl["state"].tolist() == ["OK", "ALARM", "NO DATA"]
    assert fl.loc[1, "last_alarm_time_s"] == 0.5
    # a new run without alarm on b-rig: OK again, its last alarm is still listed
    r3 = st.start_run("b-rig", command="monitor", source="b2", feature="f", threshold=12.0)
    st.add_chunk(r3, summary(0, False))
    fl = st.fleet()
    assert fl.loc[1, "state"] == "OK" and fl.loc[1, "last_alarm_time_s"] == 0.5
    assert fl.loc[1, "n_runs"] == 2


def test_schema_version_mismatch(tmp_path):
    db = tmp_path / "e.db"
    EventStore(db).close()
    con = sqlite3.connect(db)
    con.execute("update schema_version set version = 99")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match=r"schema version 99, this leakdiag .*reads version 5"):
        EventStore(db)


def test_foreign_database_refused(tmp_path):
    db = tmp_path / "other.db"
    con = sqlite3.connect(db)
    con.execute("create table things (x int)")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match=r"not a leakdiag event store.*\['things'\]"):
        EventStore(db)
    with pytest.raises(StoreError, match="new.db: no such event store file"):
        EventStore(tmp_path / "new.db", create=False)
    assert not (tmp_path / "new.db").exists()
    (tmp_path / "empty.db").write_bytes(b"")
    with pytest.raises(StoreError, match="empty database"):
        EventStore(tmp_path / "empty.db", create=False)


def test_store_url():
    assert store_url("sqlite:///x.db") == "sqlite:///x.db"
    assert store_url("rel.db") == "sqlite:///" + os.path.abspath("rel.db")
    with pytest.raises(ValueError, match="--store needs"):
        store_url(" ")
    with pytest.raises(StoreError, match="cannot open"):
        EventStore("nosuchdialect://x/y")


def test_summarize_windows_hand_values():
    s = summarize_windows([0.2, 0.4, 0.6, 0.8], [1.0, 3.0, np.nan, 2.0],
                          [np.nan, np.nan, 1.0, 5.0], [False, False, False, True])
    assert (s.t_start_s, s.t_end_s, s.n_windows, s.n_degenerate) == (0.2, 0.8, 4, 1)
    assert (s.value_mean, s.value_min, s.value_max, s.value_last) == (2.0, 1.0, 3.0, 2.0)
    assert (s.score_max, s.score_last, s.alarm) == (5.0, 5.0, True)
    assert summarize_windows([], []) is None
    with pytest.raises(ValueError, match="scores has shape"):
        summarize_windows([1.0], [1.0], [1.0, 2.0])


def test_two_processes_write_the_same_file(tmp_path):
    db = str(tmp_path / "e.db")
    EventStore(db).close()
    n = 150
    procs = [subprocess.Popen([sys.executable, str(WRITER), db, name, str(n)],
                              env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
             for name in ("w1", "w2")]
    for p in procs:
        out, err = p.communicate(timeout=240)
        assert p.returncode == 0, err
        assert out.split() == [str(i) for i in range(n)]
    st = EventStore(db)
    assert st.count("chunk_summaries") == 2 * n
    for name in ("w1", "w2"):
        summ, _ = st.history(name)
        assert summ["seq"].tolist() == list(range(n))
        assert summ["value_mean"].tolist() == [float(i) for i in range(n)]
    con = sqlite3.connect(db)
    assert con.execute("pragma integrity_check").fetchone()[0] == "ok"
    assert con.execute("select n_chunks, status from runs order by id").fetchall() == \
        [(n, "finished"), (n, "finished")]


def test_killed_writer_leaves_a_consistent_file(tmp_path):
    db = str(tmp_path / "e.db")
    with subprocess.Popen([sys.executable, str(WRITER), db, "victim", "-1"],
                          env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          text=True) as p:
        try:
            for _ in range(40):  # wait for 40 committed chunks, then kill -9 mid-stream
                line = p.stdout.readline()
                assert line, p.stderr.read()
            os.kill(p.pid, signal.SIGKILL)
            p.wait(timeout=30)
        finally:
            if p.poll() is None:
                p.kill()
    assert p.returncode == -signal.SIGKILL
    con = sqlite3.connect(db)
    assert con.execute("pragma integrity_check").fetchone()[0] == "ok"
    (n_chunks, status), = con.execute("select n_chunks, status from runs").fetchall()
    n_rows = con.execute("select count(*) from chunk_summaries").fetchone()[0]
    seqs = [r[0] for r in con.execute("select seq from chunk_summaries order by seq")]
    con.close()
    # every committed chunk is there, the run's counter agrees with the rows: no half chunk
    assert n_chunks == n_rows >= 40 and seqs == list(range(n_rows)) and status == "running"
    st = EventStore(db)  # the store is still writable after the crash
    run = st.start_run("victim", command="monitor", source="again", feature="ac p1")
    assert st.add_chunk(run, summary(0)) == (0, [])
    assert st.count("chunk_summaries") == n_rows + 1


def test_summarize_chunks_equals_summarize_windows_per_chunk():
    rng = np.random.default_rng(3)
    counts = [3, 0, 1, 5, 2, 0, 4]
    n = sum(counts)
    t = np.arange(n) * 0.19 + 0.199
    v = rng.normal(size=n)
    v[[1, 4, 5]] = np.nan  # degenerate windows, one chunk of only NaN values below
    v[9:11] = np.nan
    s = np.abs(rng.normal(size=n)) * 3
    s[:2] = np.nan  # burn-in
    a = s >= 2.0
    ref, i = [], 0
    for c in counts:
        if c:
            ref.append(summarize_windows(t[i:i + c], v[i:i + c], s[i:i + c], a[i:i + c]))
        i += c
    got = summarize_chunks(t, v, s, a, counts)
    assert len(got) == len(ref) == 5
    for g, r in zip(got, ref):
        for k, want in r.__dict__.items():  # the mean is summed in another order
            have = getattr(g, k)
            assert have == want if want is None or k != "value_mean" else \
                have == pytest.approx(want, rel=1e-14), (k, have, want)
    assert got[3] == ref[3] and got[3].value_mean is None and got[3].value_last is None
    assert [g.n_windows for g in summarize_chunks(t, v, counts=counts)] == [3, 1, 5, 2, 4]
    assert summarize_chunks(t, v, counts=counts)[0].score_max is None
    assert summarize_chunks([], [], counts=[0, 0]) == []
    with pytest.raises(ValueError, match="sum to 15 windows, got sum 14"):
        summarize_chunks(t, v, counts=[14])
    with pytest.raises(ValueError, match="must be >= 0"):
        summarize_chunks(t, v, counts=[16, -1])


def test_add_chunks_is_one_group_equal_to_single_chunks(tmp_path):
    one, group = EventStore(tmp_path / "one.db"), EventStore(tmp_path / "group.db")
    r1 = one.start_run("rig1", command="monitor", source="a", feature="f")
    r2 = group.start_run("rig1", command="monitor", source="a", feature="f")
    sums = [summary(i, i >= 3) for i in range(6)]
    for sm in sums[:3]:
        one.add_chunk(r1, sm)
    _, (aid,) = one.add_chunk(r1, sums[3], [AlarmRecord(3.2, 7.0, 6.0, onset_s=2.5)])
    for sm in sums[4:]:
        one.add_chunk(r1, sm)
    assert group.add_chunks(r2, sums[:1]) == ([0], [])
    seqs, ids = group.add_chunks(r2, sums[1:], [AlarmRecord(3.2, 7.0, 6.0, onset_s=2.5)])
    assert seqs == [1, 2, 3, 4, 5] and len(ids) == 1
    assert group.add_chunks(r2, [], alarm_updates={ids[0]: {"cleared_time_s": 9.0}}) == ([], [])
    one.add_chunk(r1, None, alarm_updates={aid: {"cleared_time_s": 9.0}})
    cols = ["seq", "t_start_s", "t_end_s", "n_windows", "n_degenerate", "value_mean",
            "value_min", "value_max", "value_last", "score_max", "score_last", "alarm"]
    (s1, a1), (s2, a2) = one.history("rig1"), group.history("rig1")
    assert s1[cols].equals(s2[cols]) and len(s2) == 6
    assert a1[["alarm_time_s", "onset_s", "cleared_time_s"]].equals(
        a2[["alarm_time_s", "onset_s", "cleared_time_s"]])
    con = sqlite3.connect(tmp_path / "group.db")
    assert con.execute("select n_chunks, n_windows from runs").fetchall() == [(6, 18)]
    with pytest.raises(StoreError, match="no run with id 99"):
        group.add_chunks(99, sums)
    assert con.execute("select count(*) from chunk_summaries").fetchone() == (6,)  # rolled back
    con.close()


def test_merge_summaries_equals_blocks_by_hand(tmp_path):
    from leakdiag.store import merge_summaries

    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig1", command="monitor", source="a", feature="f")
    rng = np.random.default_rng(5)
    sums = []
    for i in range(11):
        deg = int(rng.integers(0, 4))
        mean = None if deg == 3 else float(rng.normal())
        sums.append(ChunkSummary(float(i), i + 0.5, 3, deg, mean, None if mean is None else
                                 mean - 1, None if mean is None else mean + 1, mean,
                                 None if i < 2 else float(rng.normal()), None,
                                 None if i < 2 else bool(i in (5, 9))))
    st.add_chunks(run, sums)
    summ, _ = st.history("rig1")
    m = merge_summaries(summ, 4)  # blocks of 3: [0-2], [3-5], [6-8], [9-10]
    assert m["n_chunks"].tolist() == [3, 3, 3, 2] and m["n_windows"].tolist() == [9, 9, 9, 6]
    for b, blk in enumerate([sums[0:3], sums[3:6], sums[6:9], sums[9:11]]):
        w = [s.n_windows - s.n_degenerate for s in blk if s.value_mean is not None]
        v = [s.value_mean for s in blk if s.value_mean is not None]
        want = sum(x * y for x, y in zip(v, w)) / sum(w) if sum(w) else None
        got = m.loc[b, "value_mean"]
        assert (np.isnan(got) if want is None else got == pytest.approx(want, rel=1e-14))
        mins = [s.value_min for s in blk if s.value_min is not None]
        assert m.loc[b, "value_min"] == min(mins) if mins else np.isnan(m.loc[b, "value_min"])
        scores = [s.score_max for s in blk if s.score_max is not None]
        assert m.loc[b, "score_max"] == max(scores) if scores else \
            np.isnan(m.loc[b, "score_max"])
        flags = [s.alarm for s in blk if s.alarm is not None]
        assert m.loc[b, "alarm"] == (any(flags) if flags else None)
        assert (m.loc[b, "t_start_s"], m.loc[b, "t_end_s"]) == (blk[0].t_start_s,
                                                                blk[-1].t_end_s)
    same = merge_summaries(summ, 11)
    assert same["n_chunks"].tolist() == [1] * 11
    np.testing.assert_array_equal(same["value_mean"].to_numpy(float),
                                  summ["value_mean"].to_numpy(float))
    assert len(merge_summaries(summ.iloc[:0], 5)) == 0
    with pytest.raises(ValueError, match="max_points=0 must be >= 1"):
        merge_summaries(summ, 0)
    st.close()


@pytest.mark.parametrize("order", [("acf", "fb"), ("fb", "acf")])
def test_fleet_shows_the_first_standing_alarm_and_a_size_whatever_the_method_order(tmp_path,
                                                                                   order):
    """`detect --detector A --detector B --store`: the fleet row showed the alarm and size of
    whichever method came last (found by a store audit, 2026-11-26)."""
    alarms = {"acf": AlarmRecord(14.829, onset_s=13.0, detector="acf"),
              "fb": AlarmRecord(32.117, onset_s=31.128, leak_lpm=0.118, leak_lpm_low=0.0713,
                                leak_lpm_high=0.938, detector="fb")}
    st = EventStore(tmp_path / "e.db")
    for m in order:
        run = st.start_run("rig", command="detect", source="s.parquet", feature=m,
                           invocation="one")
        st.add_chunk(run, None, [alarms[m]])
        st.end_run(run)
    row = st.fleet().iloc[0]
    assert row["state"] == "ALARM"
    assert (row["last_alarm_time_s"], row["onset_s"]) == (14.829, 13.0)
    assert (row["leak_lpm"], row["leak_lpm_low"], row["leak_lpm_high"]) == (0.118, 0.0713, 0.938)
    st.close()


def _as_version_1(db):
    """Make a store file the version-1 layout: ``runs`` without ``error``, ``alarms`` without
    ``onset_censored``, version 1."""
    con = sqlite3.connect(db)
    drop_version_5_columns(con)
    con.execute("alter table runs drop column error")
    con.execute("alter table alarms drop column onset_censored")
    con.execute("update schema_version set version = 1")
    con.commit()
    con.close()


def test_a_version_1_store_is_upgraded_in_place(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("rig1", command="monitor", source="a.parquet", feature="ac p1",
                       threshold=3.0)
    st.add_chunk(run, summary(0))
    st.end_run(run)
    st.close()
    _as_version_1(db)
    st = EventStore(db, create=False)  # a reader (the fleet page) reads it as it is
    assert st.version == 1 and st.fleet()[["state", "error"]].values.tolist() == [["OK", None]]
    assert st.runs_of("rig1")["error"].tolist() == [None]
    st.close()
    con = sqlite3.connect(db)
    assert con.execute("select version from schema_version").fetchall() == [(1,)]
    con.close()
    with pytest.warns(UserWarning, match=r"e.db: event store upgraded from schema version 1 to "
                                         r"5 \(runs.error, alarms.onset_censored, the run "
                                         r"status 'inconclusive', alarms.leak_extrapolated, "
                                         r"alarms.leak_interval added\); "
                                         r"leakdiag versions before"):
        st = EventStore(db)  # a writer upgrades it
    con = sqlite3.connect(db)
    assert con.execute("select version from schema_version").fetchall() == [(5,)]
    assert "onset_censored" in [r[1] for r in con.execute("pragma table_info(alarms)")]
    assert "error" in [r[1] for r in con.execute("pragma table_info(runs)")]
    assert con.execute("select status, error from runs").fetchall() == [("finished", None)]
    con.close()
    assert st.fleet()["state"].tolist() == ["OK"] and st.count("chunk_summaries") == 1
    run = st.start_run("rig1", command="batch", source="b.csv", feature="acf")
    st.end_run(run, "failed", "b.csv: line 3, channel 'p1': 'x' is not a number")
    assert st.fleet()["error"].tolist() == ["acf: b.csv: line 3, channel 'p1': 'x' is not a "
                                            "number"]
    st.close()
    EventStore(db).close()  # opening a current store changes nothing
    assert sqlite3.connect(db).execute("select version from schema_version").fetchall() == \
        [(5,)]


def test_a_version_2_store_keeps_its_alarms_and_is_upgraded_to_5(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("rig1", command="detect", source="a.parquet", feature="fb")
    st.add_chunk(run, None, [AlarmRecord(9.8, onset_s=5.2, detector="fb")])
    st.end_run(run)
    st.close()
    con = sqlite3.connect(db)
    drop_version_5_columns(con)
    con.execute("alter table alarms drop column onset_censored")
    con.execute("update schema_version set version = 2")
    con.commit()
    con.close()
    st = EventStore(db, create=False)  # the fleet page reads it as it is: not known
    assert st.version == 2
    fl = st.fleet()
    assert fl["onset_s"].tolist() == [5.2] and fl["onset_censored"].tolist() == [None]
    assert st.history("rig1")[1]["onset_censored"].tolist() == [None]
    st.close()
    with pytest.warns(UserWarning, match=r"from schema version 2 to 5 \(alarms.onset_censored, "
                                         r"the run status 'inconclusive', "
                                         r"alarms.leak_extrapolated, alarms.leak_interval "
                                         r"added\)"):
        st = EventStore(db)
    run = st.start_run("rig1", command="detect", source="b.parquet", feature="fb")
    st.add_chunk(run, None, [AlarmRecord(7.1, onset_s=4.85, detector="fb", onset_censored=True)])
    st.end_run(run)
    assert st.fleet()[["onset_s", "onset_censored"]].values.tolist() == [[4.85, True]]
    al = st.history("rig1")[1]
    assert al["onset_censored"].tolist() == [None, True]
    st.close()


def test_failed_and_unjudged_runs_keep_their_reason(tmp_path):
    st = EventStore(tmp_path / "e.db")
    inv = "i1"
    a = st.start_run("rig1", command="detect", source="x.csv", feature="acf-p1", invocation=inv)
    b = st.start_run("rig1", command="detect", source="x.csv", feature="ekf", invocation=inv)
    st.end_run(a, "finished")
    st.end_run(b, "unjudged", "too short to judge: 3 s")
    fl = st.fleet()
    assert fl["state"].tolist() == ["NOT JUDGED"]
    assert fl["error"].tolist() == ["ekf: too short to judge: 3 s"]
    runs = st.runs_of("rig1")
    assert runs["feature"].tolist() == ["ekf", "acf-p1"]  # newest first
    assert runs["error"].tolist()[0] == "too short to judge: 3 s"
    assert runs["error"].isna().tolist() == [False, True]
    c = st.start_run("rig1", command="detect", source="y.csv", feature="acf-p1")
    st.end_run(c, "finished")
    assert st.fleet()[["state", "error"]].values.tolist() == [["OK", None]]
    with pytest.raises(StoreError, match="no actuator named 'rig9'"):
        st.runs_of("rig9")
    st.close()


def test_the_system_of_an_actuator_is_filled_once_and_never_overridden(tmp_path):
    st = EventStore(tmp_path / "e.db")
    st.end_run(st.start_run("rig1", command="batch", source="a.csv", feature="f"))
    assert st.fleet()["system"].tolist() == [None]
    st.end_run(st.start_run("rig1", command="detect", source="b.csv", feature="f",
                            system="VCA"))
    assert st.fleet()["system"].tolist() == ["vca"]
    st.end_run(st.start_run("rig1", command="batch", source="c.csv", feature="f"))
    assert st.fleet()["system"].tolist() == ["vca"]
    with pytest.raises(StoreError, match="actuator 'rig1' is a vca in the store, this run says "
                                         "eha: give it another name"):
        st.start_run("rig1", command="detect", source="d.csv", feature="f", system="eha")
    assert st.count("runs") == 3 and st.fleet()["system"].tolist() == ["vca"]
    st.close()


def test_an_inconclusive_run_is_neither_ok_nor_alarm_nor_unjudged(tmp_path):
    """Session 23: detect, batch and monitor --segment print INCONCLUSIVE for an alarm that is
    no evidence (the detector refused it, or the run expects it by chance); the store kept such
    a run ``unjudged`` and the fleet page said NOT JUDGED. It is stored ``inconclusive`` now
    (schema version 4): INCONCLUSIVE, with why, above NOT JUDGED and below ALARM, and it clears
    no alarm."""
    st = EventStore(tmp_path / "e.db")

    def invocation(inv, *runs):
        for feature, status, why in runs:
            st.end_run(st.start_run("rig1", command="detect", source=f"{inv}.csv",
                                    feature=feature, invocation=inv), status, why)
        return st.fleet().iloc[0]

    r = invocation("i1", ("flow-balance", "inconclusive", "alarmed but refused its alarm"),
                   ("acf-p1", "finished", None))
    assert (r["state"], r["error"]) == ("INCONCLUSIVE",
                                        "flow-balance: alarmed but refused its alarm")
    # the run beside the state is the one that set it, not the invocation's latest run
    assert (r["run"], r["feature"]) == ("detect inconclusive", "flow-balance")
    r = invocation("i2", ("ekf", "unjudged", "too short"),
                   ("flow-balance", "inconclusive", "refused"))
    assert (r["state"], r["error"]) == ("INCONCLUSIVE", "flow-balance: refused")
    r = invocation("i3", ("acf-p1", "finished", None), ("ekf", "unjudged", "too short"))
    assert (r["state"], r["error"]) == ("NOT JUDGED", "ekf: too short")
    run = st.start_run("rig1", command="detect", source="a.csv", feature="acf-p1",
                       invocation="i4")
    st.add_chunk(run, None, [AlarmRecord(9.8, detector="acf-p1")])
    st.end_run(run)
    assert st.fleet()["state"].tolist() == ["ALARM"]
    r = invocation("i5", ("flow-balance", "inconclusive", "refused"))
    assert r["state"] == "ALARM"  # only an OK started later clears it
    st.close()


def test_a_version_3_store_is_upgraded_to_5(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    st.end_run(st.start_run("rig1", command="detect", source="a.csv", feature="fb"))
    st.close()
    con = sqlite3.connect(db)
    drop_version_5_columns(con)
    con.execute("update schema_version set version = 3")
    con.commit()
    con.close()
    st = EventStore(db, create=False)  # a reader leaves it at 3
    assert st.version == 3 and st.fleet()["state"].tolist() == ["OK"]
    st.close()
    with pytest.warns(UserWarning, match=r"from schema version 3 to 5 \(the run status "
                                         r"'inconclusive', alarms.leak_extrapolated, "
                                         r"alarms.leak_interval added\); leakdiag versions "
                                         r"before"):
        st = EventStore(db)
    st.close()
    assert sqlite3.connect(db).execute("select version from schema_version").fetchall() == \
        [(5,)]


def test_a_store_in_a_folder_that_does_not_exist_says_so(tmp_path, run_cli):
    """A CLI audit (2026-11-29, session 28): ``--store nodir/x.db`` said only "unable to open
    database file"."""
    path = tmp_path / "nodir" / "x.db"
    with pytest.raises(StoreError, match=re.escape(
            f"{path}: cannot create the event store: the folder {tmp_path / 'nodir'} does not "
            "exist (create it first")):
        EventStore(path)
    assert not (tmp_path / "nodir").exists()  # nothing made
    csv = tmp_path / "r.csv"
    csv.write_text("time,p1\n" + "".join(f"{i / 100},{i % 7}\n" for i in range(300)))
    code, _, err = run_cli(["monitor", str(csv), "-c", "p1", "--window", "50", "--store",
                            str(path)])
    assert code == 2 and f"the folder {tmp_path / 'nodir'} does not exist" in err
    EventStore(tmp_path / "x.db").close()  # an existing folder: made
