"""Two writers of one actuator at once, on SQLite and PostgreSQL (review of 2026-11-27, items 3
and 4): ``start_run`` (``monitor --store``) and ``add_finished_runs`` (``batch``/``detect
--store``) share one locked "get or create the actuator, check its rig" step.

Another writer's transaction is held open by hand (``Holder``) while the store's call runs in a
thread; on PostgreSQL the holder commits once that call is seen waiting for a lock
(``pg_stat_activity``), so the call is known to have met the open transaction.
"""

import sqlite3
import threading
import time

import pytest
from sqlalchemy import create_engine, text

from leakdiag.store import EventStore, FinishedRun, StoreError


@pytest.fixture(params=["sqlite", "postgresql"])
def url(request, tmp_path):
    """An empty event store: an SQLite file, or a database on the test PostgreSQL server."""
    if request.param == "sqlite":
        return str(tmp_path / "e.db")
    return request.getfixturevalue("pg_url")


class Holder:
    """Another writer's transaction, open until :meth:`commit` (SQLite: ``BEGIN IMMEDIATE``
    holds the file; PostgreSQL: the rows it wrote or locked)."""

    def __init__(self, url):
        self.url = url
        self.sqlite = "://" not in url
        if self.sqlite:
            self.conn = sqlite3.connect(url, isolation_level=None, timeout=30)
            self.conn.execute("BEGIN IMMEDIATE")
        else:
            self.engine = create_engine(url)
            self.conn = self.engine.connect()
            self.tx = self.conn.begin()

    def execute(self, sql):
        if self.sqlite:
            self.conn.execute(sql.replace("now()", "'2026-11-27 10:00:00.000000'"))
        else:
            self.conn.execute(text(sql))

    def commit_when_waited_for(self):
        """Commit once another connection waits for this one (PostgreSQL: seen in
        ``pg_stat_activity``; SQLite, where the busy wait cannot be seen, after 0.3 s)."""
        if self.sqlite:
            time.sleep(0.3)
            self.conn.execute("COMMIT")
            self.conn.close()
            return
        t_end = time.monotonic() + 20
        while time.monotonic() < t_end:
            with self.engine.connect() as c:  # a new snapshot of pg_stat_activity each time
                if c.execute(text("select count(*) from pg_stat_activity where "
                                  "wait_event_type = 'Lock' and datname = current_database()")
                             ).scalar():
                    break
            time.sleep(0.01)
        else:
            raise AssertionError("the store's call never waited for the open transaction")
        self.tx.commit()
        self.conn.close()
        self.engine.dispose()


def _in_thread(fn):
    """Start ``fn`` in a thread; the returned function joins it and gives (result, error)."""
    out = {}

    def run():
        try:
            out["result"] = fn()
        except Exception as exc:  # noqa: BLE001 - handed to the test
            out["error"] = exc

    t = threading.Thread(target=run)
    t.start()

    def join():
        t.join(60)
        assert not t.is_alive()
        return out.get("result"), out.get("error")

    return join


def _start(st, name, system):
    return st.start_run(name, command="monitor", source="live.csv", feature="acf-p1",
                        system=system)


def _finished(st, name, system):
    return st.add_finished_runs(name, [FinishedRun("batch", f"/d/{name}/v.parquet", "acf",
                                                   system=system)])


def _actuators(url):
    st = EventStore(url, create=False)
    try:
        return st.fleet()[["name", "system", "n_runs"]].values.tolist()
    finally:
        st.close()


@pytest.mark.parametrize("write", [_start, _finished], ids=["start_run", "add_finished_runs"])
def test_a_rig_another_writer_is_setting_is_read_not_overwritten(url, write):
    """Item 3: a batch transaction had locked rigX and set its rig to eha; start_run("rigX",
    system="vca") read the row without waiting (rig unknown) and then set vca over it: on
    PostgreSQL the EHA actuator became a VCA without an error."""
    st = EventStore(url)
    st.end_run(st.start_run("rigX", command="monitor", source="a.csv", feature="f"))
    other = Holder(url)
    if not other.sqlite:
        other.execute("select id from actuators where name = 'rigX' for update")
    other.execute("update actuators set system = 'eha' where name = 'rigX'")
    join = _in_thread(lambda: write(st, "rigX", "vca"))
    other.commit_when_waited_for()
    result, error = join()
    st.close()
    assert isinstance(error, StoreError), (result, error)
    assert "actuator 'rigX' is an eha in the store" in str(error)
    assert _actuators(url) == [["rigX", "eha", 1]]


@pytest.mark.parametrize("write", [_start, _finished], ids=["start_run", "add_finished_runs"])
def test_an_actuator_another_writer_is_creating_is_taken_not_an_error(url, write):
    """Item 4: two writers creating one new actuator at once: start_run raised an uncaught
    IntegrityError (UniqueViolation actuators_name_key) on PostgreSQL and the monitor died.
    Now the second writer takes the first one's row, and the rig it says is set on it."""
    st = EventStore(url)
    other = Holder(url)
    other.execute("insert into actuators (name, system, first_seen_at, last_seen_at) "
                  "values ('rigY', null, now(), now())")
    join = _in_thread(lambda: write(st, "rigY", "vca"))
    other.commit_when_waited_for()
    result, error = join()
    st.close()
    assert error is None, error
    assert result is not None
    assert _actuators(url) == [["rigY", "vca", 1]]


def test_an_actuator_another_writer_created_as_another_rig_is_refused(url):
    """The same race, the other writer's actuator an EHA: the monitor's run is refused (as for
    an actuator already in the store), not stored under it."""
    st = EventStore(url)
    other = Holder(url)
    other.execute("insert into actuators (name, system, first_seen_at, last_seen_at) "
                  "values ('rigY', 'eha', now(), now())")
    join = _in_thread(lambda: _start(st, "rigY", "VCA"))
    other.commit_when_waited_for()
    _, error = join()
    st.close()
    assert isinstance(error, StoreError)
    assert str(error).endswith("actuator 'rigY' is an eha in the store, this run says vca: give "
                               "it another name")
    assert _actuators(url) == [["rigY", "eha", 0]]
