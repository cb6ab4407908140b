"""``leakdiag monitor`` refuses a NO LEAK as ``detect`` does when more than half of the judged
windows are undefined, also where no undefined span reaches the 10-s limit (audit of users'
recordings, 2026-11-27, finding 2: the monitor counted only spans)."""

import dataclasses
import re

import numpy as np
import pytest


@pytest.fixture(scope="module")
def det(run_cli, tmp_path_factory):
    """acf-p1 fitted on 3 healthy 20-s runs (its healthy recordings: no undefined window)."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    d = tmp_path_factory.mktemp("blind")
    healthy = [str(write_recording(simulate_vca(duration=20.0, leak_lpm=None, seed=70 + s,
                                                reference_seed=170 + s),
                                   d / f"h{s}.parquet")) for s in range(3)]
    det = d / "d.joblib"
    code, _, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", h)], "-m", "acf-p1",
                            "--false-alarm-rate", "100", "-o", str(det)])
    assert code == 0, err
    return det


def test_monitor_and_detect_refuse_no_leak_on_mostly_undefined_windows(run_cli, det, tmp_path):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    rec = simulate_vca(duration=16.0, leak_lpm=None, seed=80, reference_seed=180)
    p1 = np.array(rec["p1"])
    p1[7000:] = p1[7000]  # stuck 7-16 s: 9 s, under the 10-s span limit; most windows after
    path = write_recording(dataclasses.replace(rec, channels={**rec.channels, "p1": p1}),
                           tmp_path / "stuck.parquet")  # the 5-s burn-in undefined
    code, out, err = run_cli(["detect", str(path), "--detector", str(det), "--no-progress"])
    assert code == 2 and "windows judged (more than 50%" in err, (out, err)
    span = re.search(r"the longest span \d+ windows from \S+ to \S+ s", err).group(0)
    code, out, err = run_cli(["monitor", "--input", str(path), "--detector", str(det)])
    assert code == 0, err
    warn = [ln for ln in err.splitlines() if ln.startswith("leakdiag: warning:")]
    assert len(warn) == 1 and "windows judged (more than half; the longest span" in warn[0] \
        and "the absence of an alarm rules nothing out" in warn[0], err
    # the same span as detect's, from its first window's first sample (an audit, 2026-11-29:
    # monitor said "from 1.339" where detect said "from 1.14", the first window's last sample)
    assert span in warn[0], (span, warn[0])
    assert "BLIND   t=" not in err  # no span beyond the limit: no BLIND line while it ran
    # the same file without the stuck sensor: no warning
    clean = write_recording(rec, tmp_path / "clean.parquet")
    code, out, err = run_cli(["monitor", "--input", str(clean), "--detector", str(det)])
    assert code == 0 and "warning" not in err, err


def test_a_monitor_that_alarmed_before_going_blind_is_stored_as_judged(run_cli, det, tmp_path):
    """A review (2026-11-27): a run that raised an alarm and then went blind was stored
    'unjudged' with "the absence of an alarm rules nothing out", while detect stored the same
    file as a finished LEAK. An alarm on the windows looked at judged the run."""
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca
    from leakdiag.store import EventStore

    rec = simulate_vca(duration=16.0, leak_lpm=1.0, onset=6.0, seed=82, reference_seed=182)
    p1 = np.array(rec["p1"])
    p1[9000:] = p1[9000]  # stuck from 9 s, after the alarm
    path = write_recording(dataclasses.replace(rec, channels={**rec.channels, "p1": p1}),
                           tmp_path / "ba.parquet")
    db = tmp_path / "ev.db"
    code, out, err = run_cli(["detect", str(path), "--detector", str(det), "--no-progress",
                              "--store", str(db), "--actuator", "viaDetect"])
    assert code == 0 and "Decision: LEAK" in out, err
    code, out, err = run_cli(["monitor", "--input", str(path), "--detector", str(det), "--store",
                              str(db), "--actuator", "viaMonitor"])
    assert code == 0 and "ALARM   t=" in out, (out, err)
    st = EventStore(db)
    for name in ("viaDetect", "viaMonitor"):
        runs = st.runs_of(name)
        assert list(runs["status"]) == ["finished"], (name, runs[["status", "error"]])
    assert set(st.fleet().set_index("name").loc[["viaDetect", "viaMonitor"], "state"]) == \
        {"ALARM"}
    st.close()
