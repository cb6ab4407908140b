"""The history plot keeps runs apart (store audit of 2026-11-27, finding 7): two monitors of
one actuator at once are two stretches of line, merged blocks never mix two runs, a gap of days
is not bridged, and each chunk is stamped with its hand-off time, not the sidecar's commit."""

from datetime import datetime, timedelta, timezone

import numpy as np
import pytest
from sqlalchemy import text

from leakdiag.dashboard.app import make_app
from leakdiag.store import ChunkSummary, EventStore

from .test_app import Client

T0 = datetime(2026, 11, 20, 8, 0, tzinfo=timezone.utc)


def _chunks(value, n):
    return [ChunkSummary(float(i), i + 0.9, 5, 0, value, value, value, value, value, value,
                         False) for i in range(n)]


def _history(st):
    c = Client(make_app(store=st))
    try:
        return c.get("/api/history/pump").json()["summaries"]
    finally:
        c.srv.stop()


def _stretches(s):
    """Stretches of line: consecutive points between null rows, as lists of values."""
    out, cur = [], []
    for k, v in zip(s["n_chunks"], s["value_mean"]):
        if k is None:
            out.append(cur) if cur else None
            cur = []
        else:
            cur.append(v)
    return out + ([cur] if cur else [])


def test_two_monitors_at_once_are_two_lines(tmp_path):
    st = EventStore(tmp_path / "e.db")
    a = st.start_run("pump", command="monitor", source="leak.parquet", feature="f", threshold=1.0)
    b = st.start_run("pump", command="monitor", source="ok.parquet", feature="f", threshold=1.0)
    for i in range(30):  # interleaved in wall time, as the audit's two replays were
        at = [T0 + timedelta(seconds=i)]
        st.add_chunks(a, [_chunks(0.6, 1)[0]], recorded_at=at)
        st.add_chunks(b, [_chunks(0.0, 1)[0]], recorded_at=at)
    s = _history(st)
    assert _stretches(s) == [[0.6] * 30, [0.0] * 30]  # was one line alternating 0.6, 0.0, ...
    st.close()


def test_merged_points_never_mix_runs_and_gaps_are_not_bridged(tmp_path):
    """1,501 chunks at 1.0 on Nov 20 and 1,500 at 0.0 on Nov 22: one merged point was 0.5,
    dated Nov 22, with t_start_s 1500 > t_end_s 0.9."""
    st = EventStore(tmp_path / "e.db")
    for value, n, day in ((1.0, 1501, 0), (0.0, 1500, 2)):
        run = st.start_run("pump", command="monitor", source=f"d{day}.csv", feature="f",
                           threshold=1.0)
        st.add_chunks(run, _chunks(value, n), recorded_at=[
            T0 + timedelta(days=day, seconds=i) for i in range(n)])
    # and a day's pause inside the second run
    st.add_chunks(run, _chunks(0.0, 10), recorded_at=[
        T0 + timedelta(days=3, seconds=i) for i in range(10)])
    s = _history(st)
    st.close()
    pts = [i for i, k in enumerate(s["n_chunks"]) if k is not None]
    assert {s["value_mean"][i] for i in pts} == {0.0, 1.0}
    assert all(s["t_start_s"][i] <= s["t_end_s"][i] for i in pts)
    lines = _stretches(s)
    assert [set(x) for x in lines] == [{1.0}, {0.0}, {0.0}]
    assert sum(s["n_chunks"][i] for i in pts) == 3011 and len(pts) <= 2000 + 2


def test_chunks_are_stamped_with_their_hand_off_time(tmp_path):
    """A sidecar that lags behind a fast replay took 60 chunks in 2 takes: all were stamped with
    the 2 commit times. The recorder now passes each chunk's hand-off wall time."""
    from leakdiag.dashboard.recorder import ChunkRecorder

    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("pump", command="monitor", source="x", feature="f")
    rec = ChunkRecorder(st, run, "pump", "f")
    handed = [1_790_000_000.0 + 0.05 * i for i in range(6)]
    chunks = [(np.array([i + 0.1, i + 0.5]), np.array([0.1, 0.2]), None, None, None, w)
              for i, w in enumerate(handed)]
    rec.apply(chunks[:3])
    rec.apply(chunks[3:])
    with st.engine.connect() as c:
        got = c.execute(text("select recorded_at from chunk_summaries order by seq")).scalars()
        got = [datetime.fromisoformat(str(g)).replace(tzinfo=timezone.utc).timestamp()
               for g in got]
    assert got == pytest.approx(handed, abs=1e-6)
    st.close()
