"""The fleet and history pages say what a leak size's bracket is and whether the size is an
extrapolation (session 26 audit, finding 2: they dropped "(extrapolated)")."""

from leakdiag.dashboard.app import make_app
from leakdiag.store import AlarmRecord, EventStore

from .test_app import Client


def test_fleet_and_history_show_the_interval_and_the_extrapolation(tmp_path):
    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig1", command="detect", source="a.parquet", feature="acf")
    st.add_chunk(run, None, [AlarmRecord(64.0, leak_lpm=2.5, leak_lpm_low=1.9,
                                         leak_lpm_high=3.1, leak_extrapolated=True,
                                         leak_interval="prediction interval")])
    st.end_run(run)
    c = Client(make_app(store=st))
    try:
        page = c.get("/").text
        row = page.split('<tr data-actuator="rig1">')[1].split("</tr>")[0]
        assert ("<td>2.5 L/min [1.9, 3.1] (prediction interval) (extrapolated: outside the "
                "calibrated range)</td>") in row
        (al,) = c.get("/api/history/rig1").json()["alarms"]
        assert (al["leak_extrapolated"], al["leak_interval"]) == (True, "prediction interval")
    finally:
        c.srv.stop()
        st.close()


def test_fleet_page_times_on_a_clock_axis_keep_the_tenth_of_a_second(tmp_path):
    # a recording timed in Unix seconds: ".6g" printed both instants as 1.79596e+09 s
    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig1", command="detect", source="a.parquet", feature="acf")
    st.add_chunk(run, None, [AlarmRecord(1795960063.279, onset_s=1795960057.8595)])
    st.end_run(run)
    c = Client(make_app(store=st))
    try:
        row = c.get("/").text.split('<tr data-actuator="rig1">')[1].split("</tr>")[0]
        assert "(t=1795960063.3 s)" in row and "1795960057.9 s" in row and "e+09" not in row
    finally:
        c.srv.stop()
        st.close()
