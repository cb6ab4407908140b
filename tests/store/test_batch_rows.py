"""``batch --store``: each result row stored once whatever runs at the same time, with its
summary, alarm and end in one transaction, and an actuator of two rigs refused whole, naming
the recordings (audit of 2026-11-27, findings 2, 3, 4)."""

import json
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from leakdiag.store import AlarmRecord, ChunkSummary, EventStore
from leakdiag.store.writers import record_batch

from ._rows import JOB, child_env, fleet_rows, frame, row

CHILD = Path(__file__).with_name("_batch_writer.py")


def _counts(st):
    return st.count("runs"), st.count("alarms"), st.count("chunk_summaries")


def _race(url, tmp_path, n_folders=4, per_folder=3):
    """Two processes store the same job's rows at once (released by one start file)."""
    go = tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, str(CHILD), url, str(go), str(n_folders),
                               str(per_folder)], env=child_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    for p in procs:  # both have opened the store and built their rows
        assert p.stdout.readline().strip() == "ready", p.stderr.read()
    go.write_text("")
    written = []
    for p in procs:
        out, err = p.communicate(timeout=240)
        assert p.returncode == 0, err
        written.append(int(out.split()[-1]))
    return written


def test_two_batch_writers_at_once_store_each_row_once(tmp_path):
    """Finding 2: two ``batch --store`` of one job at once gave 22 runs instead of 13 (the keys
    were read once before the writes). 4 folders of 3 recordings, an analysis and a detector
    row each: 24 runs, 4 alarms, 24 summaries, whoever writes them."""
    db = str(tmp_path / "e.db")
    EventStore(db).close()
    written = _race(db, tmp_path)
    st = EventStore(db)
    assert _counts(st) == (24, 4, 24)
    assert sum(written) == 24  # between them, each row once (each actuator by one of them)
    con = sqlite3.connect(db)
    keys = [json.loads(c)["row"] for (c,) in con.execute("select config from runs")]
    assert len(set(keys)) == 24
    assert con.execute("pragma integrity_check").fetchone()[0] == "ok"
    con.close()
    st.close()


def test_an_interrupted_batch_write_leaves_no_running_run_and_loses_no_alarm(tmp_path,
                                                                            monkeypatch):
    """Finding 4: start_run committed the row's key before its summary and alarm; a Ctrl-C in
    between left the run 'running' forever, and the re-run skipped it: its alarm was lost."""
    import leakdiag.store.database as D

    st = EventStore(tmp_path / "e.db")
    real, calls = D._insert_summaries, []

    def interrupted(*args, **kw):  # Ctrl-C while storing rig0's alarm row (its 6th row)
        calls.append(1)
        if len(calls) == 6:
            raise KeyboardInterrupt
        return real(*args, **kw)

    monkeypatch.setattr(D, "_insert_summaries", interrupted)
    with pytest.raises(KeyboardInterrupt):
        record_batch(st, fleet_rows(), JOB)
    monkeypatch.setattr(D, "_insert_summaries", real)
    con = sqlite3.connect(tmp_path / "e.db")
    assert con.execute("select count(*) from runs where status = 'running'").fetchone() == (0,)
    assert _counts(st) == (0, 0, 0)  # rig0's rows went in together or not at all
    w = record_batch(st, fleet_rows(), JOB)
    assert (w.n_runs, w.n_stored, w.refused) == (24, 0, ())
    assert _counts(st) == (24, 4, 24)
    assert con.execute("select count(*) from runs where status != 'finished' or ended_at is "
                       "null").fetchone() == (0,)
    assert con.execute("select count(*) from runs r where r.n_chunks != (select count(*) from "
                       "chunk_summaries c where c.run_id = r.id)").fetchone() == (0,)
    con.close()
    st.close()


#: Runs in the store when the writer below is killed: in the middle of an actuator's rows when
#: they were written one by one (each actuator has 4).
KILL_AT_RUNS = 42


def _kill_mid_write(db, tmp_path, n_folders):
    """Start a process storing ``n_folders`` actuators' batch rows (2 recordings, 4 runs each)
    into ``db`` and ``kill -9`` it once :data:`KILL_AT_RUNS` runs are in. Returns False when it
    finished them all first (a fast machine, a slow poll): nothing was killed then."""
    EventStore(db).close()
    go = tmp_path / "go"
    go.write_text("")
    p = subprocess.Popen([sys.executable, str(CHILD), db, str(go), str(n_folders), "2"],
                         env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    try:
        assert p.stdout.readline().strip() == "ready", p.stderr.read()
        con = sqlite3.connect(db, timeout=30)
        try:
            t_end = time.monotonic() + 120
            while con.execute("select count(*) from runs").fetchone()[0] < KILL_AT_RUNS:
                if p.poll() is not None or time.monotonic() > t_end:
                    break
                time.sleep(0.005)
        finally:
            con.close()
        p.send_signal(signal.SIGKILL)  # nothing if it has ended (no ProcessLookupError)
        p.wait(timeout=30)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
        err = p.stderr.read()
        p.stdout.close()
        p.stderr.close()
    if p.returncode == 0:
        return False
    assert p.returncode == -signal.SIGKILL, f"the writer failed ({p.returncode}): {err}"
    return True


def test_the_kill_helper_says_when_the_writer_finished_first(tmp_path):
    """Review item 11: a writer that stored all its rows before the poll saw 42 of them made
    the kill test fail with ProcessLookupError (kill of a process already reaped). 5
    actuators are 20 runs, fewer than 42: it always finishes first, and that is said."""
    db = str(tmp_path / "e.db")
    assert _kill_mid_write(db, tmp_path, 5) is False
    st = EventStore(db)
    assert _counts(st) == (20, 5, 20)
    st.close()


def test_a_killed_batch_write_keeps_whole_actuators_and_the_rerun_completes(tmp_path):
    """kill -9 of a process storing 150 actuators' rows (once 42 runs are in: in the middle of
    an actuator's rows when they were written one by one): every actuator it stored is whole
    (2 runs per recording, none 'running'), the file is consistent, and storing again adds
    exactly what is missing. A writer that finished before it was killed is started again
    with four times the actuators, twice at most."""
    for n_folders in (150, 600, 2400):
        db = str(tmp_path / f"e{n_folders}.db")
        if _kill_mid_write(db, tmp_path, n_folders):
            break
    else:
        pytest.fail(f"the writer stored all {4 * n_folders} runs before the test saw "
                    f"{KILL_AT_RUNS} of them, three times (each with 4 times the runs): the "
                    "polling loop did not run; nothing was killed, so nothing was tested")
    n_runs = 4 * n_folders
    con = sqlite3.connect(db, timeout=30)
    assert con.execute("pragma integrity_check").fetchone()[0] == "ok"
    assert con.execute("select count(*) from runs where status = 'running'").fetchone() == (0,)
    per = con.execute("select a.name, count(*) from runs r join actuators a on "
                      "a.id = r.actuator_id group by a.name").fetchall()
    assert KILL_AT_RUNS <= sum(n for _, n in per) < n_runs and {n for _, n in per} == {4}
    st = EventStore(db)
    w = record_batch(st, fleet_rows(n_folders, 2), JOB)
    assert w.n_stored == sum(n for _, n in per) and w.n_runs == n_runs - w.n_stored
    assert _counts(st) == (n_runs, n_folders, n_runs)
    con.close()
    st.close()


def test_an_actuator_of_two_rigs_is_refused_whole_naming_its_recordings(tmp_path):
    """Finding 3: rigM's recordings say vca and eha: the store wrote rigM's vca rows, then
    stopped at the eha one with "actuator 'rigM' is a vca in the store, this run says eha"
    (no file named), without rigN's rows; every re-run failed alike."""
    st = EventStore(tmp_path / "e.db")
    res = frame([row("/d/rigM/a_vca.parquet", alarm=False, system="vca"),
                 row("/d/rigM/b_eha.parquet", alarm=False, system="eha"),
                 row("/d/rigN/c_vca.parquet", alarm=True, alarm_time_s=64.2, system="vca")])
    w = record_batch(st, res, JOB)
    assert (w.n_runs, w.n_stored) == (1, 0)
    assert w.refused == ("actuator 'rigM': its recordings disagree on the rig "
                         "(/d/rigM/a_vca.parquet says vca, /d/rigM/b_eha.parquet says eha): "
                         "give them different actuator names",)
    assert st.actuator_names() == ["rigN"] and _counts(st) == (1, 1, 1)
    # rigM already a vca in the store (a monitor): the eha recording is named
    m = st.start_run("rigM", command="monitor", source="live.csv", feature="f", system="vca")
    st.end_run(m)
    w = record_batch(st, res[res["path"] != "/d/rigM/a_vca.parquet"], JOB)
    assert (w.n_runs, w.n_stored) == (0, 1)
    assert w.refused == ("actuator 'rigM' is a vca in the store, /d/rigM/b_eha.parquet says "
                         "eha: give it another name",)
    assert _counts(st) == (2, 1, 1)
    st.close()


def test_add_finished_runs_is_one_transaction(tmp_path):
    from leakdiag.store import FinishedRun

    st = EventStore(tmp_path / "e.db")
    runs = [FinishedRun("detect", "x.parquet", "acf-p1",
                        summary=ChunkSummary(0.0, 60.0, 300, 0, 0.5, 0.1, 0.9, None, 40.0),
                        alarms=(AlarmRecord(31.2, 40.0, 33.2, onset_s=30.1),), system="VCA"),
            FinishedRun("detect", "x.parquet", "ekf", "unjudged", "too short to judge: 3 s")]
    ids = st.add_finished_runs("rig1", runs, invocation="inv1")
    assert len(ids) == 2 and None not in ids
    con = sqlite3.connect(tmp_path / "e.db")
    assert con.execute("select feature, status, error, n_chunks, n_windows, invocation, "
                       "ended_at is not null from runs order by id").fetchall() == [
        ("acf-p1", "finished", None, 1, 300, "inv1", 1),
        ("ekf", "unjudged", "too short to judge: 3 s", 0, 0, "inv1", 1)]
    assert con.execute("select system from actuators").fetchall() == [("vca",)]
    with pytest.raises(TypeError, match="asdict"):  # nothing of a failing call is kept
        st.add_finished_runs("rig2", [FinishedRun("detect", "y.parquet", "f", alarms=(
            AlarmRecord(1.0, onset_s=2.0), "not an alarm"))])
    assert st.actuator_names() == ["rig1"] and st.count("runs") == 2
    con.close()
    st.close()


def test_other_store_trouble_stops_the_batch_write_instead_of_reading_as_refused(tmp_path,
                                                                                 monkeypatch):
    """Only an actuator of another rig is "refused" (the others are written); any other
    StoreError met while writing (a store that became read-only during the job) stops the
    write, where every actuator was listed as "refused" and the command went on (store audit
    2026-11-27)."""
    from leakdiag.store import StoreError

    st = EventStore(tmp_path / "e.db")
    res = frame([row("/d/rigN/c_vca.parquet", alarm=False, system="vca")])

    def read_only(*args, **kwargs):
        raise StoreError(f"{st.shown_url}: cannot write to the event store (it is read-only)")

    monkeypatch.setattr(st, "add_finished_runs", read_only)
    with pytest.raises(StoreError, match="it is read-only"):
        record_batch(st, res, JOB)
    st.close()
