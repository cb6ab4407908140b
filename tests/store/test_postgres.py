"""The event store on a real PostgreSQL server: schema, round trip, group writes, two writer
processes, a schema-version mismatch (see conftest.py for where the server comes from)."""

import subprocess
import sys

import pytest
from sqlalchemy import create_engine, inspect, text

from leakdiag.store import SCHEMA_VERSION, AlarmRecord, EventStore, StoreError

from tests.store._rows import child_env, summary
from tests.store.test_store import WRITER


def test_schema_and_round_trip(pg_url):
    st = EventStore(pg_url)
    eng = create_engine(pg_url)
    assert set(inspect(eng).get_table_names()) == {"schema_version", "actuators", "runs",
                                                   "chunk_summaries", "alarms"}
    with eng.connect() as c:
        assert c.execute(text("select version from schema_version")).all() == \
            [(SCHEMA_VERSION,)]
    run = st.start_run("rig1", command="monitor", source="a.parquet", feature="ac p1",
                       sample_rate_hz=1000.0, threshold=12.5, system="vca")
    assert st.add_chunk(run, summary(0)) == (0, [])
    seqs, ids = st.add_chunks(run, [summary(1, True), summary(2, True)],
                              [AlarmRecord(1.4, 13.0, 12.5, onset_s=0.9, leak_lpm=0.1,
                                           leak_lpm_low=0.05, leak_lpm_high=0.15)])
    assert seqs == [1, 2] and len(ids) == 1
    st.add_chunks(run, [summary(3, False)], alarm_updates={ids[0]: {"cleared_time_s": 3.3}})
    st.end_run(run)
    summ, al = st.history("rig1")
    assert summ["seq"].tolist() == [0, 1, 2, 3]
    assert summ["value_mean"].tolist() == pytest.approx([0.0, 0.1, 0.2, 0.3], abs=1e-15)
    assert summ["alarm"].tolist()[1:] == [True, True, False] and summ["alarm"].isna()[0]
    assert summ["recorded_at"].dt.tz is not None  # stored with its time zone (UTC)
    a = al.iloc[0]
    assert (a.alarm_time_s, a.onset_s, a.leak_lpm, a.cleared_time_s) == (1.4, 0.9, 0.1, 3.3)
    with eng.connect() as c:
        assert c.execute(text("select n_chunks, n_windows, status from runs")).all() == \
            [(4, 12, "finished")]
    assert st.fleet().loc[0, "state"] == "OK"
    st.close()
    eng.dispose()


def test_two_processes_write_the_same_database(pg_url):
    EventStore(pg_url).close()
    n = 60
    procs = [subprocess.Popen([sys.executable, str(WRITER), pg_url, name, str(n)],
                              env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
             for name in ("w1", "w2")]
    for p in procs:
        out, err = p.communicate(timeout=240)
        assert p.returncode == 0, err
        assert out.split() == [str(i) for i in range(n)]
    st = EventStore(pg_url)
    assert st.count("chunk_summaries") == 2 * n
    for name in ("w1", "w2"):
        summ, _ = st.history(name)
        assert summ["seq"].tolist() == list(range(n))
        assert summ["value_mean"].tolist() == [float(i) for i in range(n)]
    st.close()


def test_schema_version_mismatch(pg_url):
    EventStore(pg_url).close()
    eng = create_engine(pg_url)
    with eng.begin() as c:
        c.execute(text("update schema_version set version = 99"))
    eng.dispose()
    with pytest.raises(StoreError, match=r"schema version 99, this leakdiag .*reads version 5"):
        EventStore(pg_url)


def test_monitor_store_on_postgres(healthy_rec, pg_url):
    """The monitor's worker writes groups of chunks through the non-SQLite insert path."""
    from leakdiag.dashboard.hooks import MonitorHooks
    from leakdiag.features.spec import MethodSpec
    from leakdiag.stream import Monitor, recording_chunks

    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    rec = healthy_rec
    mon = Monitor(spec, rec.sample_rate)
    hooks = MonitorHooks("rig9", spec, mon, "x.parquet", rec.sample_rate, store=pg_url,
                         say=lambda m: None)
    n_chunks = 0
    for c in recording_chunks(rec, 1000, ["p1"]):
        evs = mon.push(c)
        hooks.push(evs)
        n_chunks += bool(evs)
    hooks.close(True)
    st = EventStore(pg_url)
    summ, _ = st.history("rig9")
    assert len(summ) == n_chunks and summ["seq"].tolist() == list(range(n_chunks))
    assert int(summ["n_windows"].sum()) == mon.features[0].n_windows
    assert summ["score_max"].isna().all() and summ["alarm"].isna().all()  # no detector
    st.close()


@pytest.fixture
def healthy_rec():
    from leakdiag.sim import simulate_vca

    return simulate_vca(duration=20.0, leak_lpm=None, seed=4)



def test_a_version_1_store_is_upgraded_in_place(pg_url):
    st = EventStore(pg_url)
    st.end_run(st.start_run("rig1", command="monitor", source="a.parquet", feature="ac p1"))
    st.close()
    eng = create_engine(pg_url)
    with eng.begin() as c:
        c.execute(text("alter table runs drop column error"))
        c.execute(text("alter table alarms drop column onset_censored"))
        c.execute(text("alter table alarms drop column leak_extrapolated"))
        c.execute(text("alter table alarms drop column leak_interval"))
        c.execute(text("update schema_version set version = 1"))
    with pytest.warns(UserWarning, match="upgraded from schema version 1 to 5"):
        st = EventStore(pg_url)
    with eng.connect() as c:
        assert c.execute(text("select version from schema_version")).all() == [(5,)]
        assert c.execute(text("select status, error from runs")).all() == [("finished", None)]
    eng.dispose()
    run = st.start_run("rig1", command="batch", source="b.csv", feature="acf")
    st.end_run(run, "failed", "b.csv: unreadable")
    assert st.fleet()["error"].tolist() == ["acf: b.csv: unreadable"]
    st.close()


def test_times_are_utc_whatever_the_servers_time_zone(pg_url):
    """Store audit of 2026-11-27, finding 4: with the database's TimeZone Europe/Berlin the
    fleet page showed wall-clock times one hour off under "(UTC)"."""
    from datetime import datetime, timedelta, timezone

    eng = create_engine(pg_url, isolation_level="AUTOCOMMIT")
    with eng.connect() as c:
        name = c.execute(text("select current_database()")).scalar()
        c.execute(text(f"ALTER DATABASE \"{name}\" SET timezone TO 'Europe/Berlin'"))
    eng.dispose()
    before = datetime.now(timezone.utc)
    st = EventStore(pg_url)
    with st.engine.connect() as c:
        assert c.execute(text("show timezone")).scalar() == "UTC"
    run = st.start_run("rig1", command="monitor", source="a.parquet", feature="ac p1",
                       threshold=1.0)
    st.add_chunk(run, summary(0, True), [AlarmRecord(0.5, 2.0, 1.0)])
    row = st.fleet().iloc[0]
    for t in (row["last_seen_at"], row["last_alarm_at"], st.history("rig1")[0].loc[0,
                                                                                   "recorded_at"]):
        assert t.utcoffset() == timedelta(0)
        assert before - timedelta(seconds=1) <= t <= datetime.now(timezone.utc)
    st.close()



@pytest.mark.parametrize("version", [None, 1], ids=["new", "version-1"])
def test_a_writer_waits_for_another_creating_or_upgrading_the_schema(pg_url, version):
    """Store audit of 2026-11-27, finding 6: writers opening a new database at one instant
    failed with a duplicate pg_type row (concurrent CREATE TABLE), writers opening a version-1
    store with 'column "error" of relation "runs" already exists' (each read the version
    before the other's upgrade committed). Here the test's connection is the other writer, held
    in the middle of its transaction: it took the schema lock and created (or upgraded) the
    tables, not yet committed; the store opened meanwhile must wait and then find them."""
    import threading
    import time
    import warnings

    from leakdiag.store import schema as S
    from leakdiag.store.database import SCHEMA_LOCK_KEY

    eng = create_engine(pg_url)
    if version == 1:
        EventStore(pg_url).close()
        with eng.begin() as c:
            c.execute(text("alter table runs drop column error"))
            c.execute(text("alter table alarms drop column onset_censored"))
            c.execute(text("alter table alarms drop column leak_extrapolated"))
            c.execute(text("alter table alarms drop column leak_interval"))
            c.execute(text("update schema_version set version = 1"))
    out = []

    def open_store():
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # (the upgrade's warning, if it upgraded)
                st = EventStore(pg_url)
            st.start_run("rigX", command="detect", source="x", feature="f")
            out.append((st.version, st.count("schema_version"), st.count("runs")))
            st.close()
        except BaseException as exc:  # noqa: BLE001 - reported below
            out.append(f"{type(exc).__name__}: {exc}")

    with eng.connect() as c:
        tx = c.begin()
        c.execute(text("SELECT pg_advisory_xact_lock(:k)"), {"k": SCHEMA_LOCK_KEY})
        if version == 1:
            for v in range(1, S.SCHEMA_VERSION):
                for stmt in S.UPGRADES[v]:
                    c.execute(text(stmt))
            c.execute(text(f"update schema_version set version = {S.SCHEMA_VERSION}"))
        else:
            S.metadata.create_all(c)
            c.execute(S.schema_version.insert().values(version=S.SCHEMA_VERSION,
                                                       created_at=_utc_now()))
        t = threading.Thread(target=open_store)
        t.start()
        time.sleep(1.0)  # the other writer is now at its first statement
        assert t.is_alive() and not out  # it waits for the lock (old code: for a table lock)
        tx.commit()
    t.join(timeout=60)
    eng.dispose()
    assert out == [(SCHEMA_VERSION, 1, 1)]  # the schema as the other writer left it


def _utc_now():
    from datetime import datetime, timezone

    return datetime.now(timezone.utc)
