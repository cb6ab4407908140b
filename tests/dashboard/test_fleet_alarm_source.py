"""The fleet page names the recording of the alarm it shows (session-26 batch audit, finding 3:
a batch job's folder of many recordings, and the row never said which file alarmed)."""

from leakdiag.dashboard.app import make_app
from leakdiag.store import EventStore
from leakdiag.store.writers import record_batch

from tests.store._rows import JOB, frame, row
from .test_app import Client


def test_fleet_page_names_the_file_of_the_alarm_shown(tmp_path):
    st = EventStore(tmp_path / "e.db")
    record_batch(st, frame([row("/d/u7/rec012.parquet", alarm=True, alarm_time_s=40.0,
                                leak_lpm=0.2),
                            row("/d/u7/rec049.parquet", alarm=True, alarm_time_s=5.0),
                            row("/d/u7/rec050.parquet", alarm=False)]), JOB)
    c = Client(make_app(store=st))
    try:
        page = c.get("/").text
        row_ = page.split('<tr data-actuator="u7">')[1].split("</tr>")[0]
        assert '(t=40 s)<div class="note source" title="/d/u7/rec012.parquet">' \
            'in rec012.parquet</div></td>' in row_
        assert "rec049" not in row_
        (api,) = c.get("/api/fleet").json()
        assert (api["alarm_source"], api["leak_lpm"]) == ("/d/u7/rec012.parquet", 0.2)
    finally:
        c.srv.stop()
        st.close()


def test_no_alarm_no_file(tmp_path):
    st = EventStore(tmp_path / "e.db")
    record_batch(st, frame([row("/d/u7/rec050.parquet", alarm=False)]), JOB)
    c = Client(make_app(store=st))
    try:
        row_ = c.get("/").text.split('<tr data-actuator="u7">')[1].split("</tr>")[0]
        assert 'class="note source"' not in row_ and "<td>–</td>" in row_
    finally:
        c.srv.stop()
        st.close()
