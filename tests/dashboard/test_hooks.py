"""MonitorHooks and its sidecar process: the page's board and the store equal a chunk-by-chunk
update, the sidecar's errors reach the monitor's thread, and the monitor's process does none of
the work (it runs in the sidecar process, at a lower priority)."""

import json
import os
import sqlite3
import threading
import time
import urllib.request

import pytest

from leakdiag.dashboard.hooks import MonitorHooks
from leakdiag.dashboard.live import LiveBoard
from leakdiag.dashboard.server import Bind
from leakdiag.dashboard.sidecar import NICE
from leakdiag.store import StoreError, summarize_windows
from leakdiag.stream import Monitor, recording_chunks


def _monitor(leak_case):
    det, rec = leak_case["detector"], leak_case["rec"]
    return Monitor(det.spec(), rec.sample_rate, 0.0, scorers=det), det.spec(), rec


def test_sidecar_equals_chunk_by_chunk(leak_case, tmp_path):
    mon, spec, rec = _monitor(leak_case)
    ref_mon, _, _ = _monitor(leak_case)
    ref = LiveBoard()
    ref.add("rig7", spec.label, ref_mon.scorers[0], (spec.window - 1) / rec.sample_rate)
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate,
                         store=str(tmp_path / "ev.db"), bind=Bind("127.0.0.1", 0),
                         say=lambda m: None)
    ref_rows = []
    for c in recording_chunks(rec, 1000, list(spec.channels)):
        hooks.push(mon.push(c))
        (t, v, s, a), = ref_mon.push_arrays(c)
        ref.update("rig7", t, v, s, a)
        if len(t):
            ref_rows.append(summarize_windows(t, v, s, a))
    hooks.flush()
    with urllib.request.urlopen(hooks.page_url("api/live/rig7")) as r:  # the sidecar's board
        got = json.loads(r.read())
    want = json.loads(json.dumps(ref.snapshot("rig7")))
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


def test_store_and_page_work_is_done_in_the_sidecar(leak_case, tmp_path, monkeypatch):
    """--store --dashboard: the monitor's process writes no row and starts no thread (no board
    worker, no server), and its push does not wait for a database that another process keeps
    locked; the sidecar stores every chunk."""
    from leakdiag.store import EventStore

    def no_sql_here(*args, **kw):
        raise AssertionError("EventStore.add_chunks called in the monitor's process")

    monkeypatch.setattr(EventStore, "add_chunks", no_sql_here)
    mon, spec, rec = _monitor(leak_case)
    db = tmp_path / "ev.db"
    n_threads = threading.active_count()
    hooks = MonitorHooks("rig7", spec, mon, "rig7.parquet", rec.sample_rate, store=str(db),
                         bind=Bind("127.0.0.1", 0), say=lambda m: None)
    assert hooks.sidecar.proc.pid != os.getpid() and threading.active_count() == n_threads
    # the sidecar runs at a lower priority than the monitor (once configured, i.e. by now)
    assert os.getpriority(os.PRIO_PROCESS, hooks.sidecar.proc.pid) == \
        min(19, os.getpriority(os.PRIO_PROCESS, 0) + NICE)
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


def test_push_of_events_other_than_the_last_push(tmp_path):
    """The hooks take the monitor's arrays only for the list its last push returned; other
    events (here those of the push before) are read from the events themselves."""
    import numpy as np

    from .conftest import abs_monitor_hooks

    mon, hooks = abs_monitor_hooks(tmp_path, "rig8", 100)
    x = np.random.default_rng(0).normal(size=600)
    first, second = mon.push({"p1": x[:300]}), mon.push({"p1": x[300:]})
    assert mon.last_events is second and len(first) == len(second) == 3
    hooks.push(first)
    hooks.push(second)
    hooks.close(True)
    con = sqlite3.connect(tmp_path / "ev.db")
    rows = con.execute("select t_start_s, t_end_s, n_windows from chunk_summaries "
                       "order by seq").fetchall()
    assert rows == [(0.099, 0.299, 3), (0.399, 0.599, 3)]
