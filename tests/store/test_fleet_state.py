"""A reader of the store (the fleet page) follows a store that another process upgraded
(audit of 2026-11-27, finding 5)."""

import sqlite3

import pytest

from leakdiag.store import AlarmRecord, EventStore


def _downgrade(db, version):
    con = sqlite3.connect(db)
    if version < 3:
        con.execute("alter table alarms drop column onset_censored")
    if version < 2:
        con.execute("alter table runs drop column error")
    con.execute(f"update schema_version set version = {version}")
    con.commit()
    con.close()


@pytest.mark.parametrize("version", [1, 2])
def test_a_reader_sees_the_columns_of_a_store_another_process_upgraded(tmp_path, version):
    """Finding 5: ``leakdiag dashboard --store`` opened an old store and kept reading it as
    that version after a writer upgraded it: no "at or before" and no "Why not judged" until
    restarted."""
    db = tmp_path / "e.db"
    EventStore(db).close()
    _downgrade(db, version)
    reader = EventStore(db, create=False)
    assert reader.version == version
    with pytest.warns(UserWarning, match=f"upgraded from schema version {version} to 3"):
        writer = EventStore(db)
    run = writer.start_run("rigA", command="detect", source="a.parquet", feature="fb")
    writer.add_chunk(run, None, [AlarmRecord(7.1, onset_s=4.85, onset_censored=True)])
    writer.end_run(run)
    bad = writer.start_run("rigB", command="batch", source="b.csv", feature="acf")
    writer.end_run(bad, "failed", "b.csv: line 3, channel 'p1': 'x' is not a number")
    writer.close()
    fl = reader.fleet().set_index("name")
    assert reader.version == 3
    assert fl.loc["rigA", "onset_censored"] is True or fl.loc["rigA", "onset_censored"] == 1
    assert fl.loc["rigB", "error"] == "acf: b.csv: line 3, channel 'p1': 'x' is not a number"
    assert reader.history("rigA")[1]["onset_censored"].tolist() == [True]
    assert reader.runs_of("rigB")["error"].tolist() == [
        "b.csv: line 3, channel 'p1': 'x' is not a number"]
    reader.close()
