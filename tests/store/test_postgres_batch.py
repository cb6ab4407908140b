"""``batch --store`` on a real PostgreSQL (see conftest.py): two writers at once store each row
once (the actuator's row is locked; a writer that loses the race to create it retries) (audit
of 2026-11-27)."""

from sqlalchemy import create_engine, text

from leakdiag.store import EventStore

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
