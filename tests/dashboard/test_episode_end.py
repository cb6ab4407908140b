"""An alarm episode ends when its CUSUM excursion is back at 0, not when the score dips under the
threshold (session 26 audit, finding 1): a monitor run that ended, or was killed, in such a dip
was stored as cleared, and the fleet page showed OK where ``leakdiag detect`` said LEAK for the
same file and detector."""

import re
import sqlite3
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.dashboard.recorder import ChunkRecorder
from leakdiag.store import EventStore



@pytest.fixture(scope="module")
def det7(leak_case, tmp_path_factory):
    """The leak case's detector with its threshold at 7 (as test_monitor_episodes', with its
    threshold basis kept: ``detect`` reads its segment length)."""
    import copy

    from leakdiag.stream.detector_file import load_detector_file, save_detector

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        det, meta = load_detector_file(leak_case["detector_path"])
    det = copy.deepcopy(det)
    det.threshold_ = 7.0
    path = tmp_path_factory.mktemp("det7") / "det7.joblib"
    save_detector(det, meta, path)
    return path


def _run(args):
    with CliRunner().isolation() as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


# S+ by hand, threshold 2: raised at t=2, under the threshold at t=3 and t=4 (S+ 1.5, 0.5:
# the excursion goes on), raised again at t=5 (the same episode), back at 0 at t=7
UP = np.array([1.0, 2.5, 1.5, 0.5, 2.2, 1.0, 0.0, 0.0, 1.0])
T = np.arange(1.0, 10.0)


def _recorded(tmp_path, ends: int, cuts):
    """The alarm rows after the first ``ends`` windows, handed over in takes split at
    ``cuts``."""
    st = EventStore(tmp_path / f"e{ends}_{len(cuts)}.db")
    run = st.start_run("rig", command="monitor", source="x.csv", feature="f", threshold=2.0)
    rec = ChunkRecorder(st, run, "rig", "f", SimpleNamespace(threshold_=2.0), 1.0)
    up, t = UP[:ends], T[:ends]
    a = up >= 2.0
    for take in np.split(np.arange(ends), [c for c in cuts if c < ends]):
        if len(take):
            chunks = [(t[[i]], up[[i]], up[[i]], a[[i]], (up[[i]], np.zeros(1)), 1.0)
                      for i in take]
            rec.apply(chunks)
    rows = st.history("rig")[1][["alarm_time_s", "cleared_time_s"]].to_numpy().tolist()
    state = st.fleet().loc[0, "state"]
    st.close()
    return rows, state


@pytest.mark.parametrize("cuts", [[], [1, 2, 3, 4, 5, 6, 7, 8], [3], [2, 6]])
def test_an_episode_ends_when_its_excursion_is_back_at_zero(tmp_path, cuts):
    # the run ends in the dip (S+ 0.5 at t=4): one alarm, not cleared, the actuator in ALARM
    rows, state = _recorded(tmp_path, 4, cuts)
    assert (rows, state) == ([[2.0, None]], "ALARM")  # before: cleared at 3.0, OK
    # raised again at t=5 in the same excursion: still one alarm
    rows, state = _recorded(tmp_path, 6, cuts)
    assert (rows, state) == ([[2.0, None]], "ALARM")
    # S+ back at 0 at t=7: the episode ended there
    rows, state = _recorded(tmp_path, 9, cuts)
    assert (rows, state) == ([[2.0, 7.0]], "OK")


def test_a_run_cut_in_a_dip_is_alarm_as_detect_says_leak(leak_case, det7, tmp_path):
    """The leak case at threshold 7: raised at 15.399 s, under the threshold, raised again at
    17.869 s in the same excursion. Cut between the two, ``detect`` says LEAK and the fleet
    showed ``monitor`` OK."""
    from leakdiag.io import read_recording, write_recording

    code, out, err = _run(["monitor", str(leak_case["recording"]), "--detector",
                           str(det7)])
    assert code == 0, err
    cleared = float(re.search(r"^cleared t=(\S+) s", out, re.M).group(1))
    assert 15.399 < cleared < 17.869 - 0.15
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = read_recording(leak_case["recording"])
    cut = tmp_path / "cut.parquet"
    write_recording(rec.slice_time(0.0, cleared + 0.1), cut)
    db = str(tmp_path / "e.db")
    code, out, err = _run(["detect", str(cut), "--detector", str(det7),
                           "--store", db, "--actuator", "cutdet", "--no-progress"])
    assert "LEAK" in out and "NO LEAK" not in out, out
    code, out, err = _run(["monitor", str(cut), "--detector", str(det7),
                           "--store", db, "--actuator", "cutmon"])
    assert code == 0, err
    assert re.search(r"^cleared t=", out, re.M) and out.count("ALARM ") == 1  # ends in the dip
    st = EventStore(db, create=False)
    fl = st.fleet().set_index("name")
    st.close()
    assert fl.loc["cutdet", "state"] == "ALARM"
    assert fl.loc["cutmon", "state"] == "ALARM"  # was OK
    con = sqlite3.connect(db)
    (t_alarm, t_cleared), = con.execute(
        "select alarm_time_s, cleared_time_s from alarms a join runs r on r.id = a.run_id "
        "where r.command = 'monitor'").fetchall()
    con.close()
    assert (t_alarm, t_cleared) == (15.399, None)
