"""Stopping ``leakdiag monitor --follow`` with a signal (its normal end), with and without
``--store`` and ``--dashboard``, through the entry point in a child process: the run ends as
``stopped`` with every window printed, the summary names the signal, the exit code is
128 + its number, and the sidecar says nothing when the monitor ends or is killed."""

import json
import os
import re
import signal
import sqlite3
import subprocess
import sys
import time

import pytest

from leakdiag.store import EventStore

from .conftest import process_gone, src_env
from .test_cli_store import _children

# SIGINT as at a terminal: a child of a background job would inherit it ignored
LEAKDIAG = [sys.executable, "-c", "import signal, sys; signal.signal(signal.SIGINT, "
            "signal.default_int_handler); from leakdiag.cli.main import main; sys.exit(main())"]
STEP = 190  # N = 200 at 5 % overlap: window k ends at sample 199 + 190 k


def _windows(n_samples: int) -> int:
    return (n_samples - 200) // STEP + 1


def _followed_csv(leak_case, tmp_path, seconds: float):
    """The first ``seconds`` of the leak case (0.2 L/min from 30 s) as a complete CSV file."""
    n = int(seconds * 1000)
    path = tmp_path / "rig7.csv"
    leak_case["rec"].to_pandas()[["time", "p1", "p2"]].iloc[:n].to_csv(path, index=False)
    return path, n


def _start(args, tmp_path):
    return subprocess.Popen(LEAKDIAG + ["monitor", *args], env=src_env(), cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for_lines(path, n: int, p, limit_s: float = 120.0) -> None:
    """Wait until ``path`` holds ``n`` lines (the monitor has read the whole file and waits)."""
    t_end = time.monotonic() + limit_s
    while time.monotonic() < t_end:
        if p.poll() is not None:
            raise AssertionError(f"the monitor ended: {p.communicate()}")
        if path.exists() and path.read_text().count("\n") >= n:
            return
        time.sleep(0.05)
    p.kill()
    raise AssertionError(f"{path} did not reach {n} lines: {p.communicate()}")


def _stop(p, sig):
    p.send_signal(sig)
    try:
        out, err = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
        raise AssertionError(f"the monitor did not end after {sig.name}: {err}")
    return out, err


def _run_and_stop(leak_case, tmp_path, seconds, sig, extra):
    """Follow the first ``seconds`` of the leak case, wait for all its windows, send ``sig``."""
    path, n = _followed_csv(leak_case, tmp_path, seconds)
    ev = tmp_path / "ev.jsonl"
    p = _start([path.name, "--follow", "--detector", str(leak_case["detector_path"]),
                "--events", str(ev), *extra], tmp_path)
    _wait_for_lines(ev, _windows(n), p)
    out, err = _stop(p, sig)  # the summary goes to stdout (the events to a file), errors to stderr
    return p.returncode, out, err, n, [json.loads(x) for x in ev.read_text().splitlines()]


@pytest.mark.parametrize("sig, extra", [
    (signal.SIGTERM, ["--store", "ev.db"]),
    (signal.SIGTERM, ["--store", "ev.db", "--dashboard", "127.0.0.1:0"]),
    (signal.SIGINT, ["--store", "ev.db", "--dashboard", "127.0.0.1:0"]),
    (signal.SIGINT, []),
], ids=["term-store", "term-store-page", "int-store-page", "int-alone"])
def test_a_stopped_healthy_monitor_ends_its_run_as_stopped(leak_case, tmp_path, sig, extra):
    """A healthy stream (the first 25 s; the leak starts at 30 s): before, SIGTERM left the run
    ``running`` without a summary (store only) or made it ``failed`` "interrupted (Ctrl-C)"
    with "Aborted." (with a page), and the fleet showed the actuator FAILED."""
    code, out, err, n, events = _run_and_stop(leak_case, tmp_path, 25.0, sig, extra)
    n_win = _windows(n)
    assert code == 128 + sig.value, err
    assert "Traceback" not in err and "Aborted" not in err, err
    summary = [ln for ln in out.splitlines() if ln.startswith("rig7.csv: ")]
    assert len(summary) == 1, (out, err)
    # the loop's time, then the hooks' close told apart (not counted in the throughput)
    hooks = " and ".join(n for n, opt in (("page", "--dashboard"), ("store", "--store"))
                         if opt in extra)
    closing = rf" \(then [0-9.e+-]+ s to close the {hooks}\)" if hooks else ""
    m = re.fullmatch(rf"rig7\.csv: (\d+) samples at 1000 Hz, {n_win} windows \(autocorrelation "
                     rf"p1 1 N=200 5%\), 0 alarm raising\(s\) in 0 episode\(s\), 0 "
                     rf"degenerate, in [0-9.e+]+ s{closing}; stopped by {sig.name}", summary[0])
    # the signal is sent once every window is out: the samples after the last window's end may
    # not all be read yet (24,918 of 25,000 once in make test)
    assert m and (n_win - 1) * STEP + 200 <= int(m.group(1)) <= n, summary[0]
    assert len(events) == n_win and not any(e["alarm"] for e in events)
    if "--store" not in extra:
        return
    con = sqlite3.connect(tmp_path / "ev.db")
    (status, error, n_windows, n_chunks, ended), = con.execute(
        "select status, error, n_windows, n_chunks, ended_at from runs")
    assert (status, error) == ("stopped", f"stopped by {sig.name} after {n_win} windows")
    assert n_windows == n_win and ended is not None  # every window printed is stored
    assert con.execute("select count(*), sum(n_windows) from chunk_summaries").fetchone() == \
        (n_chunks, n_win)
    con.close()
    fl = EventStore(tmp_path / "ev.db").fleet()
    assert fl[["name", "state", "error"]].values.tolist() == [["rig7", "OK", None]]


def test_a_monitor_stopped_in_alarm_stays_alarm_on_the_fleet(leak_case, tmp_path):
    """The whole leak case: in alarm at its end. Stopped, the run is ``stopped`` and the
    uncleared alarm keeps the actuator ALARM (a stop is not a clearing)."""
    code, out, err, n, events = _run_and_stop(leak_case, tmp_path, 60.0, signal.SIGTERM,
                                         ["--store", "ev.db", "--dashboard", "127.0.0.1:0"])
    assert code == 143 and "Traceback" not in err, err
    assert events[-1]["alarm"] is True
    assert f"{_windows(n)} windows" in out and "; stopped by SIGTERM" in out, out
    st = EventStore(tmp_path / "ev.db")
    runs = st.runs_of("rig7")
    assert runs[["status", "error"]].values.tolist() == [
        ["stopped", f"stopped by SIGTERM after {_windows(n)} windows"]]
    fl = st.fleet()
    assert fl["state"].tolist() == ["ALARM"]
    assert fl["last_alarm_time_s"].iloc[0] == pytest.approx(leak_case["verdict"].alarm_time_s,
                                                            abs=1e-9)
    st.close()


def test_the_sidecar_says_nothing_when_the_monitor_is_killed(leak_case, tmp_path):
    """kill -9 of a monitor with --store: the sidecar stores what it was given and ends
    without a BrokenPipeError traceback (it wrote "done" to the dead monitor's pipe)."""
    path, n = _followed_csv(leak_case, tmp_path, 10.0)
    ev = tmp_path / "ev.jsonl"
    p = _start([str(path), "--follow", "-c", "p1", "--events", str(ev), "--store", "ev.db",
                "-q"], tmp_path)
    _wait_for_lines(ev, _windows(n), p)
    sidecars = _children(p.pid)
    os.kill(p.pid, signal.SIGKILL)
    p.wait(timeout=30)
    t_end = time.monotonic() + 60
    while sidecars and not process_gone(sidecars[0]) and time.monotonic() < t_end:
        time.sleep(0.05)
    assert len(sidecars) == 1 and process_gone(sidecars[0])
    err = p.stderr.read()  # the sidecar's stderr is the monitor's
    p.stdout.close()
    p.stderr.close()
    assert err == "", err
    con = sqlite3.connect(tmp_path / "ev.db")
    assert con.execute("select status, n_windows from runs").fetchall() == \
        [("running", _windows(n))]  # killed: as documented, the run stays running
    con.close()


def test_the_fleet_judges_a_stopped_run_by_what_it_stored(tmp_path):
    """A run ``stopped`` before its first chunk judged nothing (NO DATA, not OK); with a
    healthy chunk it is OK; its stop is not a failure (no error shown)."""
    from leakdiag.store import ChunkSummary

    st = EventStore(tmp_path / "ev.db")
    empty = st.start_run("a", command="monitor", source="a.csv", feature="f")
    st.end_run(empty, "stopped", "stopped by SIGINT before the first chunk")
    run = st.start_run("b", command="monitor", source="b.csv", feature="f", threshold=3.0)
    st.add_chunk(run, ChunkSummary(t_start_s=0.2, t_end_s=1.0, n_windows=5, n_degenerate=0,
                                   value_mean=0.5, value_min=0.1, value_max=0.9, value_last=0.4,
                                   score_max=1.0, score_last=0.5, alarm=False))
    st.end_run(run, "stopped", "stopped by SIGTERM after 5 windows")
    fl = st.fleet()
    assert fl[["name", "state", "error"]].values.tolist() == [["a", "NO DATA", None],
                                                              ["b", "OK", None]]
    st.close()
