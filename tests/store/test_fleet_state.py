"""The fleet row: its state follows the latest activity, a standing alarm is not hidden by a run
started before it, and the alarm shown is the newest (audit of 2026-11-27, findings 1, 5, 6)."""

import time

import pytest

from leakdiag.store import AlarmRecord, EventStore
from leakdiag.store.writers import record_batch

from ._rows import JOB, WHY_FAILED, downgrade, frame, row, summary, upgrade_and_write


def _state(st, name="rigA"):
    return st.fleet().set_index("name").loc[name]


def _tick():
    time.sleep(0.002)  # wall-clock order of the writes below (microsecond timestamps)


def test_a_detect_started_during_a_monitor_does_not_hide_its_later_alarm(tmp_path):
    """Finding 1: ``detect --store`` of a healthy file started while a long ``monitor
    --store`` runs; the monitor raises its alarm after the detect ended. The row showed OK
    beside "Last alarm 09:44:19" (the state came from the newest-started run)."""
    st = EventStore(tmp_path / "e.db")
    m = st.start_run("rigA", command="monitor", source="live.csv", feature="acf-p1",
                     threshold=33.22)
    st.add_chunk(m, summary(0, False))
    _tick()
    d = st.start_run("rigA", command="detect", source="healthy.parquet", feature="acf-p1")
    st.end_run(d)
    _tick()
    assert _state(st)["state"] == "OK"
    _, (aid,) = st.add_chunk(m, summary(1, True),
                             [AlarmRecord(64.229, 33.24, 33.22, onset_s=60.1)])
    row_ = _state(st)
    assert row_["state"] == "ALARM"
    assert (row_["last_alarm_time_s"], row_["onset_s"]) == (64.229, 60.1)
    assert (row_["feature"], row_["source"]) == ("acf-p1", "live.csv")
    # a failed run started after the alarm judges nothing: the alarm stands
    _tick()
    f = st.start_run("rigA", command="batch", source="broken.parquet", feature="acf-p1")
    st.end_run(f, "failed", "unreadable as Parquet")
    assert _state(st)["state"] == "ALARM"
    # a healthy judgment started after the monitor's last activity clears it...
    _tick()
    d2 = st.start_run("rigA", command="detect", source="healthy2.parquet", feature="acf-p1")
    st.end_run(d2)
    row_ = _state(st)
    assert row_["state"] == "OK" and row_["last_alarm_time_s"] == 64.229
    assert row_["source"] == "healthy2.parquet"
    # ... until the live monitor sends another chunk in alarm: newer than that judgment
    _tick()
    st.add_chunk(m, summary(2, True))
    assert _state(st)["state"] == "ALARM"
    # the monitor clears its alarm: OK, the newest activity is its healthy chunk
    _tick()
    st.add_chunk(m, summary(3, False), alarm_updates={aid: {"cleared_time_s": 3.4}})
    row_ = _state(st)
    assert row_["state"] == "OK" and row_["source"] == "live.csv"
    st.close()


def test_two_monitors_at_once_the_alarm_of_one_is_not_hidden_by_the_other(tmp_path):
    st = EventStore(tmp_path / "e.db")
    a = st.start_run("rigA", command="monitor", source="p1.csv", feature="acf-p1",
                     threshold=3.0)
    b = st.start_run("rigA", command="monitor", source="p2.csv", feature="ccf-p1p2",
                     threshold=3.0)
    assert _state(st)["state"] == "NO DATA"
    st.add_chunk(a, summary(0, True), [AlarmRecord(5.0, onset_s=4.0)])
    for i in range(3):  # the healthy monitor keeps writing after the other's alarm
        _tick()
        st.add_chunk(b, summary(i, False))
        assert _state(st)["state"] == "ALARM"
    assert _state(st)["source"] == "p1.csv"
    st.close()


def test_the_alarm_shown_is_the_newest_and_its_size_from_the_same_recording(tmp_path):
    """Finding 6: one batch job over a folder of two recordings that both alarm. The row
    showed the alarm with the earliest stream time whatever its recording (run1's 12.0 s) and
    its leak size beside the newest run (run2). Then: run2's alarm (the last written), without
    size; since the session-26 batch audit: run1's, the recording whose alarm has a size, and
    its size, its recording named in the row."""
    st = EventStore(tmp_path / "e.db")
    res = frame([row("/d/rigA/run1.parquet", alarm=True, alarm_time_s=12.0, onset_s=10.0,
                     leak_lpm=0.3),
                 row("/d/rigA/run2.parquet", alarm=True, alarm_time_s=70.879, onset_s=68.5)])
    record_batch(st, res, JOB)
    r = _state(st)
    assert r["state"] == "ALARM"
    assert (r["last_alarm_time_s"], r["onset_s"], r["leak_lpm"]) == (12.0, 10.0, 0.3)
    assert r["source"] == r["alarm_source"] == "/d/rigA/run1.parquet"
    # a later detect on run1 alone: its alarm is the newest now, with its size
    _tick()
    d = st.start_run("rigA", command="detect", source="/d/rigA/run1.parquet", feature="fb")
    st.add_chunk(d, None, [AlarmRecord(13.5, onset_s=11.0, leak_lpm=0.25, leak_lpm_low=0.2,
                                       leak_lpm_high=0.3, detector="fb")])
    st.end_run(d)
    r = _state(st)
    assert (r["last_alarm_time_s"], r["leak_lpm"], r["leak_lpm_low"]) == (13.5, 0.25, 0.2)
    assert (r["feature"], r["source"]) == ("fb", "/d/rigA/run1.parquet")
    st.close()


def test_the_last_alarm_of_an_ok_actuator_is_its_newest_episode(tmp_path):
    st = EventStore(tmp_path / "e.db")
    m = st.start_run("rigA", command="monitor", source="live.csv", feature="acf-p1",
                     threshold=33.22)
    _, (a1,) = st.add_chunk(m, summary(0, True), [AlarmRecord(64.2, onset_s=60.0)])
    st.add_chunk(m, summary(1, False), alarm_updates={a1: {"cleared_time_s": 64.9}})
    _, (a2,) = st.add_chunk(m, summary(2, True), [AlarmRecord(65.9, onset_s=60.0)])
    st.add_chunk(m, summary(3, False), alarm_updates={a2: {"cleared_time_s": 66.8}})
    st.end_run(m)
    r = _state(st)
    assert r["state"] == "OK" and r["last_alarm_time_s"] == 65.9
    st.close()


@pytest.mark.parametrize("version", [1, 2])
def test_a_reader_sees_the_columns_of_a_store_another_process_upgraded(tmp_path, version):
    """Finding 5: ``leakdiag dashboard --store`` opened an old store and kept reading it as
    that version after a writer upgraded it: no "at or before" and no "Why not judged" until
    restarted."""
    db = tmp_path / "e.db"
    EventStore(db).close()
    downgrade(db, version)
    reader = EventStore(db, create=False)
    assert reader.version == version
    upgrade_and_write(db, version)
    fl = reader.fleet().set_index("name")
    assert reader.version == 5
    assert fl.loc["rigA", "onset_censored"] is True or fl.loc["rigA", "onset_censored"] == 1
    assert fl.loc["rigB", "error"] == f"acf: {WHY_FAILED}"
    assert reader.history("rigA")[1]["onset_censored"].tolist() == [True]
    assert reader.runs_of("rigB")["error"].tolist() == [WHY_FAILED]
    reader.close()
