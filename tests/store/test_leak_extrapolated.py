"""A leak size's extrapolation flag and what its bracket is, kept by the store (schema version 5)
and shown by the pages (session 26 audit, finding 2: detect and the live page said
"(extrapolated)", the fleet and history pages did not, the store had no column for it)."""

import sqlite3
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from leakdiag.store import AlarmRecord, EventStore
from leakdiag.store.writers import record_verdicts

from ._rows import downgrade


def test_a_version_4_store_is_upgraded_to_5_and_keeps_its_alarms(tmp_path):
    db = tmp_path / "e.db"
    st = EventStore(db)
    run = st.start_run("rig1", command="detect", source="a.parquet", feature="acf")
    st.add_chunk(run, None, [AlarmRecord(9.8, onset_s=5.2, leak_lpm=0.3, leak_lpm_low=0.2,
                                         leak_lpm_high=0.4, detector="acf")])
    st.end_run(run)
    st.close()
    downgrade(db, 4)
    reader = EventStore(db, create=False)  # the fleet page reads it as it is: not known
    assert reader.version == 4
    assert reader.fleet()[["leak_lpm", "leak_extrapolated", "leak_interval"]].values.tolist() \
        == [[0.3, None, None]]
    with pytest.warns(UserWarning, match=r"from schema version 4 to 5 \(alarms.leak_extrapolated"
                                         r", alarms.leak_interval added\); leakdiag versions "
                                         r"before this one no longer open it"):
        st = EventStore(db)
    con = sqlite3.connect(db)
    assert con.execute("select version from schema_version").fetchall() == [(5,)]
    assert con.execute("select alarm_time_s, leak_lpm, leak_extrapolated, leak_interval "
                       "from alarms").fetchall() == [(9.8, 0.3, None, None)]
    con.close()
    run = st.start_run("rig1", command="detect", source="b.parquet", feature="acf")
    st.add_chunk(run, None, [AlarmRecord(7.1, leak_lpm=2.5, leak_lpm_low=1.9, leak_lpm_high=3.1,
                                         leak_extrapolated=True,
                                         leak_interval="prediction interval")])
    st.end_run(run)
    st.close()
    # the running page follows the upgrade (it reads the version again)
    row = reader.fleet().iloc[0]
    assert (row["leak_lpm"], row["leak_extrapolated"], row["leak_interval"]) == \
        (2.5, True, "prediction interval")
    assert reader.history("rig1")[1]["leak_extrapolated"].tolist() == [None, True]
    reader.close()


def _table(**cols):
    base = {"method": "acf-p1", "leak": True, "decision": "leak", "alarm_time_s": 64.0,
            "onset_s": 60.0, "score_max": 30.0, "threshold": 22.8, "leak_lpm": 2.5,
            "leak_lpm_low": 1.9, "leak_lpm_high": 3.1, "leak_lpm_in_range": False,
            "error": None}
    t = pd.DataFrame([{**base, **cols}])
    t.attrs["system"] = "vca"
    return t


@pytest.mark.parametrize("cols, want", [
    ({}, (True, "prediction interval")),
    ({"leak_lpm_in_range": True}, (False, "prediction interval")),
    ({"method": "flow-balance", "leak_lpm_in_range": None,
      "leak_lpm_interval_holds": "offsets within +-0.2 bar"},
     (None, "interval: offsets within +-0.2 bar")),
    ({"leak_lpm": None, "leak_lpm_low": None, "leak_lpm_high": None}, (None, None)),
])
def test_detect_stores_the_flag_and_the_interval_it_prints(tmp_path, cols, want):
    st = EventStore(tmp_path / "e.db")
    record_verdicts(st, "rig1", "/d/x.parquet", _table(**cols))
    al = st.history("rig1")[1]
    assert (al.loc[0, "leak_extrapolated"], al.loc[0, "leak_interval"]) == want
    row = st.fleet().iloc[0]
    assert (row["leak_extrapolated"], row["leak_interval"]) == want
    st.close()


class _Cal:
    """A calibration whose estimate lies outside its range (an extrapolation)."""

    level = 0.9

    def estimate(self, shift):
        return 2.5, (1.9, 3.1), False


def test_the_monitor_stores_the_flag_and_its_interval(tmp_path):
    from leakdiag.dashboard.recorder import ChunkRecorder

    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig", command="monitor", source="x.csv", feature="f", threshold=2.0)
    sc = SimpleNamespace(threshold_=2.0, mean_=0.0, std_=1.0,
                         detector=SimpleNamespace(calibration_=_Cal()))
    rec = ChunkRecorder(st, run, "rig", "f", sc, 1.0)
    up = np.array([0.0, 1.0, 2.5, 3.0])
    t = np.arange(1.0, 5.0)
    rec.apply([(t, up, up, up >= 2.0, (up, np.zeros(4)), 1.0)])
    al = st.history("rig")[1]
    assert al[["leak_lpm", "leak_extrapolated", "leak_interval"]].values.tolist() == \
        [[2.5, True, "90 % prediction interval"]]
    assert rec.board.snapshot("rig")["leak_interval"] == "90 % prediction interval"
    st.close()
