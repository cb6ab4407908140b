"""A running fleet page follows a store that another process upgraded (audit of 2026-11-27,
finding 5): "at or before" and "Why not judged" appear without a restart."""

from leakdiag.dashboard.app import make_app
from leakdiag.store import EventStore

from tests.store._rows import downgrade, upgrade_and_write

from .test_app import Client


def test_fleet_page_shows_the_new_columns_after_an_upgrade(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("rigA", command="detect", source="a.parquet", feature="fb")
    st.end_run(run)
    st.close()
    downgrade(db, 1)
    reader = EventStore(db, create=False)  # leakdiag dashboard --store e.db
    c = Client(make_app(store=reader))
    page = c.get("/").text
    assert "at or before" not in page
    upgrade_and_write(db, 1)  # detect and batch --store e.db, in another process
    page = c.get("/").text
    row_a = page.split('<tr data-actuator="rigA">')[1].split("</tr>")[0]
    row_b = page.split('<tr data-actuator="rigB">')[1].split("</tr>")[0]
    assert "<td>at or before 4.85 s</td>" in row_a
    assert "acf: b.csv: line 3, channel &#x27;p1&#x27;: &#x27;x&#x27; is not a number" in row_b
    c.srv.stop()
    reader.close()
