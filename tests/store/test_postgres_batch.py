"""``batch --store`` on a real PostgreSQL (see conftest.py): two writers at once store each row
once (the actuator's row is locked; a writer that loses the race to create it takes the
other's row), and the fleet state reads PostgreSQL's time-zone-aware timestamps (audit of
2026-11-27)."""

import time

from sqlalchemy import create_engine, text

from leakdiag.store import AlarmRecord, EventStore

from ._rows import summary
from .test_batch_rows import _race


def test_two_batch_writers_at_once_store_each_row_once_on_postgresql(pg_url, tmp_path):
    EventStore(pg_url).close()
    written = _race(pg_url, tmp_path)
    assert sum(written) == 24
    eng = create_engine(pg_url)
    with eng.connect() as c:
        assert c.execute(text("select count(*), count(distinct config) from runs")).one() == \
            (24, 24)
        assert c.execute(text("select count(*) from alarms")).scalar() == 4
        assert c.execute(text("select count(*) from runs where status = 'running'")) \
            .scalar() == 0
    eng.dispose()


def test_fleet_state_on_postgresql(pg_url):
    st = EventStore(pg_url)
    m = st.start_run("rigA", command="monitor", source="live.csv", feature="acf-p1",
                     threshold=33.22)
    st.add_chunk(m, summary(0, False))
    d = st.start_run("rigA", command="detect", source="healthy.parquet", feature="acf-p1")
    st.end_run(d)
    time.sleep(0.002)
    st.add_chunk(m, summary(1, True), [AlarmRecord(64.229, onset_s=60.1)])
    row = st.fleet().iloc[0]
    assert (row["state"], row["last_alarm_time_s"], row["source"]) == ("ALARM", 64.229,
                                                                        "live.csv")
    st.close()
