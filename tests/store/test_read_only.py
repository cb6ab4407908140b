"""A store the process cannot write (store audit of 2026-11-27, finding 5): a writer refuses it
when it opens it (StoreError naming it read-only, exit code 2 before any work), a write that
fails later for another reason than a lock is a StoreError too, and the read-only page opens a
store on a read-only file system (or says why it cannot)."""

import os
import shutil
import sqlite3
import subprocess
import sys

import pytest
from sqlalchemy.exc import OperationalError

from leakdiag.store import EventStore, StoreError

from ._rows import child_env, summary

READ_ONLY = r"cannot open the event store \(it is read-only\): attempt to write a readonly " \
            r"database"


def _store(db):
    st = EventStore(db)
    st.end_run(st.start_run("rig1", command="detect", source="a.parquet", feature="f"))
    st.close()


def _ro_url(db):
    return f"sqlite:///file:{db}?mode=ro&uri=true"


def test_a_writer_refuses_a_read_only_store_at_open(tmp_path):
    """``mode=ro``: SQLite opens the file read-only, for root as for anyone. Before the fix the
    store opened, and the first write raised a bare OperationalError (a traceback, exit 1)."""
    db = tmp_path / "e.db"
    _store(db)
    with pytest.raises(StoreError, match=READ_ONLY):
        EventStore(_ro_url(db))
    st = EventStore(_ro_url(db), create=False)  # a reader reads it
    assert st.fleet()["name"].tolist() == ["rig1"]
    st.close()


def test_detect_and_monitor_stop_before_any_work(tmp_path):
    db = tmp_path / "e.db"
    _store(db)
    rec = tmp_path / "r.csv"
    rec.write_text("time,p1\n" + "".join(f"{i / 1000},{i % 7}\n" for i in range(3000)))
    for cmd in (["detect", str(rec), "--healthy", str(rec)],
                ["monitor", str(rec), "--channels", "p1"]):
        p = subprocess.run([sys.executable, "-c", "import sys; from leakdiag.cli.main import "
                            "main; sys.exit(main())", *cmd, "--store", _ro_url(db)],
                           capture_output=True, text=True, env=child_env(), timeout=120)
        assert p.returncode == 2, p.stderr
        assert "(it is read-only): attempt to write a readonly database" in p.stderr
        assert "Traceback" not in p.stderr and p.stdout == ""


def test_a_later_write_error_is_a_store_error(tmp_path, monkeypatch):
    """The file became read-only (or the disk full) after the store was opened: the
    writer's error names the store and the problem, no bare OperationalError."""
    import leakdiag.store.database as D

    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig1", command="monitor", source="a.csv", feature="f", threshold=1.0)

    def fail(*a, **k):
        raise OperationalError("INSERT ...", {}, sqlite3.OperationalError(
            "attempt to write a readonly database"))

    monkeypatch.setattr(D, "_insert_summaries", fail)
    with pytest.raises(StoreError, match=r"e\.db: cannot write to the event store \(it is "
                                         r"read-only\): attempt to write a readonly database$"):
        st.add_chunk(run, summary(0))
    monkeypatch.undo()
    assert st.add_chunk(run, summary(0)) == (0, [])  # nothing half-written
    st.close()


@pytest.mark.skipif(os.geteuid() == 0, reason="running as root: chmod 444 does not stop "
                    "root's writes (the read-only cases are tested with mode=ro and, where it "
                    "can mount, a read-only bind mount)")
def test_a_chmod_444_store_is_refused_by_a_writer_and_read_by_the_page(tmp_path):
    db = tmp_path / "e.db"
    _store(db)
    os.chmod(db, 0o444)
    with pytest.raises(StoreError, match="read-only"):
        EventStore(db)
    st = EventStore(db, create=False)
    assert st.fleet()["name"].tolist() == ["rig1"]
    st.close()


@pytest.fixture
def ro_mount(tmp_path):
    """A read-only bind mount of a folder holding a closed store (root and mount needed)."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("a read-only bind mount needs root and mount(8)")
    src, mnt = tmp_path / "src", tmp_path / "ro"
    src.mkdir()
    mnt.mkdir()
    _store(src / "e.db")
    if subprocess.run(["mount", "--bind", str(src), str(mnt)], capture_output=True).returncode:
        pytest.skip("mount --bind is not permitted here")
    try:
        if subprocess.run(["mount", "-o", "remount,ro,bind", str(mnt)],
                          capture_output=True).returncode:
            pytest.skip("remount read-only is not permitted here")
        yield src, mnt
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def test_a_store_on_a_read_only_file_system(ro_mount):
    src, mnt = ro_mount
    with pytest.raises(StoreError, match=r"cannot open the event store: unable to open database"
                                         r" file \(.*e\.db or its folder is read-only"):
        EventStore(mnt / "e.db")
    # the page: no writer has it open, so SQLite cannot read the WAL store: it says why
    with pytest.raises(StoreError, match=r"e\.db or its folder is read-only, and to read a WAL "
                                         r"store SQLite must create .*e\.db-shm"):
        EventStore(mnt / "e.db", create=False)
    # while a writer has it open (its -shm exists), the page reads it; the writer is refused
    writer = EventStore(src / "e.db")
    writer.start_run("rig2", command="detect", source="b.parquet", feature="f")
    try:
        st = EventStore(mnt / "e.db", create=False)
        assert st.fleet()["name"].tolist() == ["rig1", "rig2"]
        st.close()
        with pytest.raises(StoreError, match=READ_ONLY):
            EventStore(mnt / "e.db")
    finally:
        writer.close()
