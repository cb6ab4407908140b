"""The fleet row of a batch-judged actuator follows every recording's current verdict, however
the folder's files were split across batch runs, and shows a meaningful alarm (session-26 batch
audit, findings 1 and 3: a healthy file added to a leaking folder and batched again turned the
actuator's ALARM into OK; the alarm shown was the last file by name, without its size)."""

import time

from hypothesis import given, settings
from hypothesis import strategies as st

from leakdiag.store import AlarmRecord, EventStore
from leakdiag.store.writers import record_batch

from ._rows import JOB, frame, row

LEAK = dict(alarm=True, alarm_time_s=61.096, onset_s=55.0, leak_lpm=0.2)
SHOWN = ["state", "last_alarm_time_s", "onset_s", "leak_lpm", "leak_lpm_low", "alarm_source",
         "feature", "source"]


def _row(st, name="u101"):
    return st.fleet().set_index("name").loc[name]


def _tick():
    time.sleep(0.002)  # wall-clock order of the writes below (microsecond timestamps)


def test_a_healthy_file_added_to_a_leaking_folder_does_not_clear_its_alarm(tmp_path):
    a = row("/d/u101/a_leak.parquet", **LEAK)
    b = row("/d/u101/b_ok.parquet", alarm=False)
    c = row("/d/u101/c_ok.parquet", alarm=False, sha="sha-c")
    split = EventStore(tmp_path / "split.db")
    assert record_batch(split, frame([a, b]), JOB).n_runs == 2
    assert _row(split)["state"] == "ALARM"
    _tick()
    w = record_batch(split, frame([a, b, c]), JOB)  # "1 run, 2 already done"
    assert (w.n_runs, w.n_stored) == (1, 2)
    got = _row(split)
    assert got["state"] == "ALARM"  # it was OK: the re-run's one healthy run judged alone
    assert (got["leak_lpm"], got["alarm_source"]) == (0.2, "/d/u101/a_leak.parquet")
    # the same files in one go: the same row
    whole = EventStore(tmp_path / "whole.db")
    record_batch(whole, frame([a, b, c]), JOB)
    assert list(_row(whole)[SHOWN]) == list(got[SHOWN])
    assert _row(whole)["n_runs"] == got["n_runs"] == 3
    # an edited file (healthy again) is judged anew: its current verdict, OK, replaces the
    # LEAK, and the old alarm stays the last alarm of the OK actuator
    _tick()
    record_batch(split, frame([row("/d/u101/a_leak.parquet", alarm=False, sha="sha-2"),
                               b, c]), JOB)
    got = _row(split)
    assert got["state"] == "OK" and got["n_runs"] == 4
    assert (got["last_alarm_time_s"], got["alarm_source"]) == (61.096, "/d/u101/a_leak.parquet")
    split.close()
    whole.close()


def test_other_commands_keep_their_rules_beside_the_batch_runs(tmp_path):
    st = EventStore(tmp_path / "e.db")
    record_batch(st, frame([row("/d/u101/a_leak.parquet", **LEAK),
                            row("/d/u101/b_ok.parquet", alarm=False)]), JOB)
    # a healthy detect started after the batch's alarm clears it, as before
    _tick()
    d = st.start_run("u101", command="detect", source="/d/u101/a_leak.parquet", feature="fb")
    st.end_run(d)
    assert _row(st)["state"] == "OK"
    # a monitor's alarm after that stands beside a batch re-run whose files are all OK now
    _tick()
    m = st.start_run("u101", command="monitor", source="live.csv", feature="acf-p1",
                     threshold=33.22)
    st.add_chunk(m, None, [AlarmRecord(5.0, onset_s=4.0)])
    st.end_run(m)
    assert _row(st)["state"] == "ALARM" and _row(st)["source"] == "live.csv"
    # a later batch judging every current recording OK clears it (started after it)
    _tick()
    record_batch(st, frame([row("/d/u101/a_leak.parquet", alarm=False, sha="sha-2")]), JOB)
    assert _row(st)["state"] == "OK"
    # a failed re-run of one file is that file's current verdict: NOT JUDGED, not OK
    _tick()
    record_batch(st, frame([row("/d/u101/b_ok.parquet", status="error", sha="sha-3",
                                error="b_ok.parquet: unreadable")]), JOB)
    got = _row(st)
    assert got["state"] == "NOT JUDGED" and "unreadable" in got["error"]
    st.close()


def test_the_alarm_shown_prefers_a_size_then_the_earliest_not_the_last_file(tmp_path):
    """Finding 3: a folder of 60 recordings, a feature detector's false alarm without size on
    rec049 and the flow balance's leak with its size on rec012, all written at one wall-clock
    time: the row showed rec049's alarm, the last written."""
    rows = []
    for k in range(60):
        p = f"/d/u7/rec{k:03d}.parquet"
        rows.append(row(p, name="fb", sha=f"s{k}", alarm=k == 12,
                        alarm_time_s=40.0 if k == 12 else None, onset_s=35.0 if k == 12 else None,
                        leak_lpm=0.2 if k == 12 else None))
        rows.append(row(p, name="acf", sha=f"s{k}", alarm=k == 49,
                        alarm_time_s=5.0 if k == 49 else None))
    st = EventStore(tmp_path / "e.db")
    record_batch(st, frame(rows), JOB)
    got = _row(st, "u7")
    assert got["state"] == "ALARM"
    assert (got["last_alarm_time_s"], got["onset_s"], got["leak_lpm"], got["leak_lpm_low"]) \
        == (40.0, 35.0, 0.2, 0.1)
    assert (got["alarm_source"], got["source"], got["feature"]) == (
        "/d/u7/rec012.parquet", "/d/u7/rec012.parquet", "fb")
    # of two sized alarms, the earliest in its recording, whatever the names or the order
    st2 = EventStore(tmp_path / "e2.db")
    record_batch(st2, frame([row("/d/u7/z.parquet", alarm=True, alarm_time_s=20.0,
                                 leak_lpm=0.5),
                             row("/d/u7/a.parquet", alarm=True, alarm_time_s=30.0,
                                 leak_lpm=0.1)]), JOB)
    assert (_row(st2, "u7")["alarm_source"], _row(st2, "u7")["leak_lpm"]) == (
        "/d/u7/z.parquet", 0.5)
    st.close()
    st2.close()



def test_a_failed_actuator_shows_its_detectors_reason_not_the_analysis_entrys(tmp_path):
    # a workflow audit (2026-11-30): a job with an [[analysis]] entry stored its "no detector"
    # note first, and the fleet row of a FAILED actuator (its detector refused the file's
    # units) showed that note as the reason, and that run as the one that set the state
    st = EventStore(tmp_path / "e.db")
    why = "counts.parquet: channel 'p1' is in 'counts', but det.joblib was fitted on 'Pa'"
    record_batch(st, frame([row("/d/u101/counts.parquet", kind="analysis", name="acf"),
                            row("/d/u101/counts.parquet", status="error", error=why)]), JOB)
    got = _row(st)
    assert got["state"] == "FAILED"
    assert got["error"].endswith(why) and "no detector" not in got["error"]
    assert got["run"].startswith("batch failed")
    st.close()

# -- _batch_ok_since counts each run once: against the plain re-judging of every prefix --------

_EFFECTIVE = ("ok", "failed", "inconclusive", "unjudged", "waiting", "no detector", "running",
              "stopped")


def _verdict_reference(runs, alarms):
    """An invocation's verdict as :func:`leakdiag.store.database._invocation` states it, in
    plain comprehensions over its runs and alarms."""
    judging = [r for r in runs if r["effective"] != "no detector"]
    status = [r["effective"] for r in judging]
    if any(a["cleared_time_s"] is None for a in alarms):
        return "ALARM"
    if not judging:
        return "NO DATA" if sum(r["n_chunks"] for r in runs) == 0 and \
            all(r["status"] in ("running", "stopped") for r in runs) else "NO DETECTOR"
    if sum(r["n_chunks"] for r in judging if r["effective"] != "waiting") == 0 \
            and not alarms and all(st in ("running", "stopped", "waiting") for st in status):
        return "NO DATA"
    if all(st == "failed" for st in status):
        return "FAILED"
    if any(st == "inconclusive" for st in status):
        return "INCONCLUSIVE"
    if any(st in ("failed", "unjudged") for st in status):
        return "NOT JUDGED"
    return "OK"


def _ok_since_reference(batch, alarms_of):
    """The definition: after each invocation, every recording's current runs judged together
    (quadratic in the number of invocations)."""
    cur, since = {}, None
    for rs in sorted(batch, key=lambda rs: min(r["id"] for r in rs)):
        mine = {}
        for r in rs:
            mine.setdefault(str(r["source"]), []).append(r)
        cur.update(mine)
        runs = [r for v in cur.values() for r in v]
        if _verdict_reference(runs, [x for r in runs for x in alarms_of.get(r["id"], [])]
                              ) == "OK":
            since = min(r["start"] for r in rs)
    return since


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(st.tuples(st.integers(0, 3), st.sampled_from(_EFFECTIVE),
                                   st.integers(0, 2), st.sampled_from((None, 0, 1)),
                                   st.sampled_from(("done", "running", "stopped", "failed"))),
                         min_size=1, max_size=4), min_size=1, max_size=8))
def test_batch_ok_since_equals_rejudging_every_prefix(invocations):
    from leakdiag.store.database import _batch_ok_since, _invocation

    batch, alarms_of, rid = [], {}, 0
    for k, inv in enumerate(invocations):
        rs = []
        for src, eff, n_chunks, alarm, status in inv:
            rid += 1
            rs.append({"id": rid, "source": f"f{src}", "effective": eff, "n_chunks": n_chunks,
                       "status": status, "start": k, "at": k})
            if alarm is not None:  # an alarm, standing (None) or cleared (at 30 s)
                alarms_of[rid] = [{"cleared_time_s": None if alarm == 0 else 30.0}]
        batch.append(rs)
        mine = [x for r in rs for x in alarms_of.get(r["id"], [])]
        assert _invocation(rs, mine)["verdict"] == _verdict_reference(rs, mine)
    assert _batch_ok_since(batch, alarms_of) == _ok_since_reference(batch, alarms_of)
