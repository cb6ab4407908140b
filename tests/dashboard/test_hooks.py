"""MonitorHooks: the worker thread's board and store equal a chunk-by-chunk update, and its
errors reach the monitor's thread."""

import os
import sqlite3
import time

import pytest

from leakdiag.dashboard.hooks import MonitorHooks
from leakdiag.dashboard.live import LiveBoard
from leakdiag.store import StoreError, summarize_windows
from leakdiag.stream import Monitor, recording_chunks


def _monitor(leak_case):
    det, rec = leak_case["detector"], leak_case["rec"]
    return Monitor(det.spec(), rec.sample_rate, 0.0, scorers=det), det.spec(), rec


def test_worker_equals_chunk_by_chunk(leak_case, tmp_path):
    mon, spec, rec = _monitor(leak_case)
    ref_mon, _, _ = _monitor(leak_case)
    ref = LiveBoard()
    ref.add("rig7", spec.label, ref_mon.scorers[0], (spec.window - 1) / rec.sample_rate)
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate,
                         store=str(tmp_path / "ev.db"), say=lambda m: None, board=True)
    ref_rows = []
    for c in recording_chunks(rec, 1000, list(spec.channels)):
        hooks.push(mon.push(c))
        (t, v, s, a), = ref_mon.push_arrays(c)
        ref.update("rig7", t, v, s, a)
        if len(t):
            ref_rows.append(summarize_windows(t, v, s, a))
    hooks.flush()
    got, want = hooks.board.snapshot("rig7"), ref.snapshot("rig7")
    for k in ("state", "alarm_time_s", "onset_s", "n_windows", "time", "score", "events"):
        assert got[k] == want[k], k
    assert got["leak_lpm"] == pytest.approx(want["leak_lpm"], rel=1e-12)
    hooks.close(True)
    con = sqlite3.connect(tmp_path / "ev.db")
    rows = con.execute("select seq, t_start_s, t_end_s, n_windows, score_max, alarm "
                       "from chunk_summaries order by seq").fetchall()
    assert rows == [(i, r.t_start_s, r.t_end_s, r.n_windows, r.score_max, int(r.alarm))
                    for i, r in enumerate(ref_rows)]
    (alarm_time, onset, lpm), = con.execute("select alarm_time_s, onset_s, leak_lpm from alarms")
    v = leak_case["verdict"]
    assert (alarm_time, onset) == (v.alarm_time_s, pytest.approx(v.onset_s, abs=1e-12))
    assert lpm == pytest.approx(v.leak_lpm, rel=1e-9)
    assert con.execute("select status, n_chunks from runs").fetchall() == \
        [("finished", len(ref_rows))]


def test_worker_error_reaches_the_monitor(leak_case, tmp_path):
    mon, spec, rec = _monitor(leak_case)
    db = tmp_path / "ev.db"
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate, store=str(db),
                         say=lambda m: None)
    con = sqlite3.connect(db)
    con.execute("delete from runs")  # the run disappears under the writer
    con.commit()
    con.close()
    chunks = recording_chunks(rec, 5000, list(spec.channels))
    with pytest.raises(StoreError, match="no run with id"):
        for c in chunks:
            hooks.push(mon.push(c))
        hooks.flush()
    with pytest.raises(StoreError, match="no run with id"):
        hooks.close(True)
    hooks.close(False)  # the monitor's own error is the one reported: no second raise


def test_push_does_not_wait_for_a_slow_worker(leak_case):
    """Throttle the page, not the detector: the monitor's push only queues the chunk."""
    mon, spec, rec = _monitor(leak_case)
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate, say=lambda m: None,
                         board=True)
    update = hooks.board.update

    def slow_update(*args, **kw):  # a board (or store) that takes 0.3 s per update
        time.sleep(0.3)
        update(*args, **kw)

    hooks.board.update = slow_update
    t_push = 0.0
    chunks = list(recording_chunks(rec, 1000, list(spec.channels)))[:30]
    for c in chunks:
        evs = mon.push(c)
        t0 = time.perf_counter()
        hooks.push(evs)
        t_push += time.perf_counter() - t0
    # one update per chunk in the monitor's thread would take 30 x 0.3 s = 9 s
    assert t_push < 1.0, t_push
    hooks.flush()
    snap = hooks.board.snapshot("rig7")
    assert snap["n_windows"] == mon.features[0].n_windows > 100
    hooks.close(True)


def test_store_work_is_done_in_the_writer_process(leak_case, tmp_path, monkeypatch):
    """--store: the monitor's process writes no row itself, and its push does not wait for a
    database that another process keeps locked; the writer process stores every chunk."""
    from leakdiag.store import EventStore

    def no_sql_here(*args, **kw):
        raise AssertionError("EventStore.add_chunks called in the monitor's process")

    monkeypatch.setattr(EventStore, "add_chunks", no_sql_here)
    mon, spec, rec = _monitor(leak_case)
    db = tmp_path / "ev.db"
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate, store=str(db),
                         say=lambda m: None)
    assert hooks.writer.proc.pid != os.getpid() and not hooks._worker.is_alive()  # no thread
    lock = sqlite3.connect(db, isolation_level=None)
    lock.execute("begin immediate")  # the writer's transactions wait for this lock
    n_chunks = t_push = 0
    for c in recording_chunks(rec, 1000, list(spec.channels)):
        evs = mon.push(c)
        t0 = time.perf_counter()
        hooks.push(evs)
        t_push += time.perf_counter() - t0
        n_chunks += bool(evs)
    time.sleep(0.3)
    lock.execute("rollback")
    lock.close()
    assert t_push < 0.5, t_push
    hooks.flush()
    hooks.close(True)
    con = sqlite3.connect(db)
    assert con.execute("select count(*), sum(n_windows) from chunk_summaries").fetchone() == \
        (n_chunks, mon.features[0].n_windows)
    (alarm_time,), = con.execute("select alarm_time_s from alarms")
    assert alarm_time == leak_case["verdict"].alarm_time_s
    con.close()
