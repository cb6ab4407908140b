"""A running fleet page follows a store that another process upgraded (audit of 2026-11-27,
finding 5): "at or before" and "Why not judged" appear without a restart."""

import pytest

from leakdiag.dashboard.app import make_app
from leakdiag.store import AlarmRecord, EventStore

from tests.store.test_fleet_state import _downgrade

from .test_app import Client


def test_fleet_page_shows_the_new_columns_after_an_upgrade(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("rigA", command="detect", source="a.parquet", feature="fb")
    st.end_run(run)
    st.close()
    _downgrade(db, 1)
    reader = EventStore(db, create=False)  # leakdiag dashboard --store e.db
    c = Client(make_app(store=reader))
    page = c.get("/").text
    assert "at or before" not in page
    with pytest.warns(UserWarning, match="upgraded from schema version 1 to 3"):
        writer = EventStore(db)  # detect --store e.db, in another process
    run = writer.start_run("rigA", command="detect", source="b.parquet", feature="fb")
    writer.add_chunk(run, None, [AlarmRecord(7.1, onset_s=4.85, onset_censored=True)])
    writer.end_run(run)
    bad = writer.start_run("rigB", command="batch", source="c.csv", feature="acf")
    writer.end_run(bad, "failed", "c.csv: line 3, channel 'p1': 'x' is not a number")
    writer.close()
    page = c.get("/").text
    row_a = page.split('<tr data-actuator="rigA">')[1].split("</tr>")[0]
    row_b = page.split('<tr data-actuator="rigB">')[1].split("</tr>")[0]
    assert "<td>at or before 4.85 s</td>" in row_a
    assert "acf: c.csv: line 3, channel &#x27;p1&#x27;: &#x27;x&#x27; is not a number" in row_b
    c.srv.stop()
    reader.close()
