"""kill -9 of a monitor process that has chunks in its sidecar's ring: the sidecar stores every
chunk pushed (after wrapping around a small ring and waiting for room), and a chunk being
written at the kill instant is reported on stderr, not stored."""

import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from leakdiag.store import EventStore

from .conftest import abs_monitor_hooks, process_gone, src_env

#: The "monitor": a sidecar with a 4,096-byte ring, K chunks of 5 windows (152 bytes each with
#: scores) pushed as fast as it can, then (mode "torn") half a frame written, then kill -9.
_MONITOR = """
import os, signal, sys
import numpy as np
from leakdiag.dashboard.sidecar import Sidecar
url, run, mode, k = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
class Threshold:
    threshold_ = 0.5
sc = Sidecar("rig9", "f", Threshold(), 0.2, url, run, ring_bytes=4096)
print(sc.proc.pid, flush=True)
for i in range(k):
    t = i + np.arange(5) / 10.0
    sc.push(t, -t, t - i, t - i > 0.25, None, 0.0)
ring = sc.ring
print(ring.n_wraps, ring.n_waits, ring.idx[0] - ring.idx[16], flush=True)
if mode == "torn":
    p = ring._reserve(152)
    ring.mm[p:p + 40] = b"\\x07" * 40
os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("mode", ["complete", "torn"])
def test_killed_monitor_mid_ring(tmp_path, mode):
    db = tmp_path / "ev.db"
    st = EventStore(db)
    run = st.start_run("rig9", command="monitor", source="test", feature="f")
    url = st.url
    st.close()
    k = 400  # 60,800 bytes: about 15 laps of the ring
    p = subprocess.Popen([sys.executable, "-c", _MONITOR, url, str(run), mode, str(k)],
                         env=src_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    out, err = p.communicate(timeout=60)  # ends when the sidecar too has closed stderr
    assert p.returncode == -signal.SIGKILL, err
    sidecar, counts = out.splitlines()
    wraps, waits, held = map(int, counts.split())
    assert wraps >= 10 and waits >= 1 and held > 0  # chunks were in the ring at the kill
    t_end = time.monotonic() + 30
    while not process_gone(int(sidecar)) and time.monotonic() < t_end:
        time.sleep(0.05)
    assert process_gone(int(sidecar))
    con = sqlite3.connect(db)
    rows = con.execute("select seq, n_windows, t_start_s, t_end_s, alarm from chunk_summaries "
                       "order by seq").fetchall()
    con.close()
    assert rows == [(i, 5, float(i), i + 0.4, 1) for i in range(k)]
    if mode == "torn":
        assert "the monitor ended while writing a chunk: 152 bytes of a frame being " \
            "written; incomplete, not stored" in err
    else:
        assert "incomplete" not in err


def test_a_sidecar_killed_from_outside_is_noticed_by_the_next_pushes(tmp_path):
    """A real-time stream (one chunk every 50 ms) would fill the 4 MiB ring only after hours;
    push checks the sidecar at most once a second, so its death is raised within about 1 s."""
    import numpy as np

    from leakdiag.dashboard.sidecar import ALIVE_CHECK_S, Sidecar
    from leakdiag.store import StoreError

    st = EventStore(tmp_path / "ev.db")
    run = st.start_run("rig9", command="monitor", source="test", feature="f")
    url = st.url
    st.close()

    class Threshold:
        threshold_ = 0.5

    sc = Sidecar("rig9", "f", Threshold(), 0.2, url, run)
    try:
        t = np.arange(5) / 10.0
        sc.push(t, -t, t, t > 0.25, None, 0.0)
        sc.proc.kill()
        sc.proc.wait(timeout=10)
        killed = time.monotonic()
        with pytest.raises(StoreError, match="ended unexpectedly"):
            for i in range(1, 200):  # 10 s of chunks at most
                sc.push(t + i, -t, t, t > 0.25, None, 0.0)
                time.sleep(0.05)
        assert time.monotonic() - killed <= ALIVE_CHECK_S + 0.5
    finally:
        with pytest.raises(StoreError):
            sc.close()


def test_monitor_hooks_notice_a_killed_sidecar(tmp_path):
    """The same check on the monitor's path (MonitorHooks.push writes to the ring itself, not
    through Sidecar.push): a killed sidecar is raised within about ALIVE_CHECK_S."""
    import numpy as np

    from leakdiag.dashboard.sidecar import ALIVE_CHECK_S
    from leakdiag.store import StoreError

    mon, hooks = abs_monitor_hooks(tmp_path, "rig9", 10)
    x = np.random.default_rng(0).normal(size=50)
    hooks.push(mon.push({"p1": x}))
    hooks.sidecar.proc.kill()
    hooks.sidecar.proc.wait(timeout=10)
    killed = time.monotonic()
    with pytest.raises(StoreError, match="ended unexpectedly"):
        for _ in range(200):  # 10 s of 50-ms chunks at most
            hooks.push(mon.push({"p1": x}))
            time.sleep(0.05)
    assert time.monotonic() - killed <= ALIVE_CHECK_S + 0.5
    with pytest.raises(StoreError):
        hooks.close(True)
