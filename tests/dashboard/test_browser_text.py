"""What the pages write, in a real headless Chromium (session 26 audit): numbers and times as
they are (the live page's ``fmt`` showed 100059.899 s as "10006 s" and 100000 as "1"), feature
labels as text (Plotly rendered ``<a href=...>`` in a legend as a link and ``<span
style="font-size:90px">`` as big text), the history page's alarm table in ms and its windows.

Skipped with the reason when Chromium or selenium is missing (conftest.browser).
"""

import time

import numpy as np
from types import SimpleNamespace

from leakdiag.dashboard import Bind, DashboardServer, LiveBoard
from leakdiag.dashboard.app import make_app

LINK = '<a href="http://example.invalid/">acf</a>'
BIG = '<span style="font-size:90px">BIG</span>'


def _wait(browser, script, timeout_s=60.0):
    t_end = time.monotonic() + timeout_s
    while True:
        got = browser.execute_script(script)
        if got:
            return got
        assert time.monotonic() < t_end, f"timed out waiting for: {script}"
        time.sleep(0.1)


def _markup(browser, plot_id):
    """Links and large fonts Plotly drew inside one plot's SVG, and its texts."""
    return browser.execute_script(
        "const p = document.getElementById(arguments[0]);"
        "const big = [...p.querySelectorAll('text, tspan')].filter((e) =>"
        "  parseFloat(getComputedStyle(e).fontSize) > 40 ||"
        "  /font-size:\\s*9\\dpx/.test(e.getAttribute('style') || ''));"
        "return {links: p.querySelectorAll('a').length, big: big.length,"
        "  text: [...p.querySelectorAll('.legendtext, .gtitle')].map((e) => e.textContent)};",
        plot_id)


def test_live_page_times_numbers_and_label(browser):
    board = LiveBoard()
    sc = SimpleNamespace(threshold_=100000.0)
    board.add("rig1", LINK + BIG, sc, window_s=0.199)
    t = np.array([100059.499, 100059.699, 100059.899])
    s = np.array([10.0, 120000.0, 120000.0])
    board.update("rig1", t, np.array([0.5, 0.6, 0.7]), s, s >= 100000.0, received_wall=1.0,
                 branches=(s, np.zeros(3)))
    board.finish("rig1")
    srv = DashboardServer(make_app(board), Bind("127.0.0.1", 0)).start()
    try:
        browser.get(srv.page_url("live/rig1"))
        _wait(browser, "return document.body.dataset.version;")
        assert browser.find_element("id", "alarm-time").text == "100059.699 s"  # was 100060 s
        assert browser.find_element("id", "last-time").text == "100059.899 s (input ended)"
        event = browser.execute_script("return document.querySelector('#events li').innerText;")
        assert event.startswith("ALARM at t=100059.699 s, score 120000, onset ")  # was 12
        assert _markup(browser, "feature-plot") == {"links": 0, "big": 0,
                                                    "text": [LINK + BIG]}
    finally:
        srv.stop()


def test_history_page_labels_alarm_times_and_windows(browser, tmp_path):
    from leakdiag.store import AlarmRecord, ChunkSummary, EventStore

    st = EventStore(tmp_path / "e.db")
    for label in (LINK, BIG):  # two features: each its own legend entry
        run = st.start_run("rig1", command="monitor", source="a.csv", feature=label,
                           threshold=20.0)
        for i in range(5):
            al = [AlarmRecord(57.859500000000004, 25.0, 20.0, onset_s=55.1000000001)] \
                if i == 3 and label == LINK else []
            st.add_chunk(run, ChunkSummary(i, i + 0.9, 5, 0, 0.5, 0.1, 0.9, 0.4, 2.0 * i, 1.0,
                                           i >= 3), al)
        st.end_run(run)
    st.end_run(st.start_run("rig1", command="detect", source="/d/b.parquet", feature="acf"))
    srv = DashboardServer(make_app(store=st), Bind("127.0.0.1", 0)).start()
    try:
        browser.get(srv.page_url("history/rig1"))
        _wait(browser, "return document.body.dataset.loaded === '1';")
        for plot in ("summary-plot", "score-plot"):
            got = _markup(browser, plot)
            assert (got["links"], got["big"]) == (0, 0), (plot, got)
            assert LINK in got["text"] and BIG in got["text"], got
        cells = browser.execute_script(
            "return [...document.querySelectorAll('#alarms tr td')].map((e) => e.innerText);")
        assert cells[1:3] == ["57.860 s", "55.100 s"]  # was 57.859500000000004 s
        windows = browser.execute_script(
            "return [...document.querySelectorAll('#runs tr.run')].map((r) =>"
            " [r.children[1].innerText, r.children[4].innerText]);")
        assert windows == [["detect", "–"], ["monitor", "25"], ["monitor", "25"]]  # was "0"
    finally:
        srv.stop()
        st.close()
