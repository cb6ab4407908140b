"""The fleet row says which run gave the state and how it stands: a stopped or silent (killed)
monitor's last OK is told from a live one's (store audit 2026-11-27, finding 8: both showed a
plain OK, only "Last seen" differed)."""

from datetime import datetime, timedelta, timezone

from leakdiag.store import EventStore

from ._rows import summary


def _row(st, name):
    return st.fleet().set_index("name").loc[name]


def test_the_row_names_the_run_behind_its_state(tmp_path):
    st = EventStore(tmp_path / "e.db")
    # a monitor stopped by the user after 2 chunks of 3 windows
    m = st.start_run("stopped", command="monitor", source="/r/a.csv", feature="acf-p1",
                     threshold=3.0)
    st.add_chunks(m, [summary(0), summary(1)])
    st.end_run(m, "stopped")
    assert _row(st, "stopped")["run"] == "monitor stopped after 6 windows"
    assert _row(st, "stopped")["state"] == "OK"
    # a live monitor: its chunks arrive, so it is running
    live = st.start_run("live", command="monitor", source="/r/b.csv", feature="acf-p1",
                        threshold=3.0)
    st.add_chunks(live, [summary(0)])
    assert _row(st, "live")["run"] == "monitor running, 3 windows"
    # a monitor killed 10 minutes ago (still marked running): its last chunks are old
    dead = st.start_run("dead", command="monitor", source="/r/c.csv", feature="acf-p1",
                        threshold=3.0)
    old = datetime.now(timezone.utc) - timedelta(minutes=10)
    st.add_chunks(dead, [summary(0), summary(1)], recorded_at=[old, old])
    words = _row(st, "dead")["run"]
    assert words.startswith(f"monitor running, silent since {old:%Y-%m-%d %H:%M}"), words
    assert words.endswith(" UTC (6 windows)") and _row(st, "dead")["state"] == "OK"
    # detect: the command and its end
    d = st.start_run("det", command="detect", source="/r/d.parquet", feature="acf-p1",
                     threshold=3.0)
    st.end_run(d)
    assert _row(st, "det")["run"] == "detect finished"
    st.close()
