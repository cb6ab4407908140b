"""Actuator names with ``.``/``..`` path segments (store audit of 2026-11-27, finding 3): refused
by every writer; a store that holds one from before links to the actuator's own page (the name
one ``%2F``-encoded path segment), in a real Chromium too; the live address the monitor prints
works; the token in a printed address is URL-encoded (finding 11)."""

import sqlite3
import subprocess
import time
import urllib.request

import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.dashboard import Bind, DashboardServer, LiveBoard
from leakdiag.dashboard.app import make_app
from leakdiag.dashboard.server import page_path
from leakdiag.store import AlarmRecord, ChunkSummary, EventStore

from .conftest import src_env

DOTTED = ["x/../rig 1", "a/./b", "../x", "x/..", " . /y"]


def _run(args):
    with CliRunner().isolation() as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


@pytest.mark.parametrize("name", DOTTED)
def test_dot_segments_are_refused_by_every_writer(leak_case, tmp_path, name):
    db = str(tmp_path / "e.db")
    for cmd in (["detect", str(leak_case["recording"]), "--detector",
                 str(leak_case["detector_path"]), "--no-progress"],
                ["monitor", str(leak_case["recording"]), "--dashboard", "0"]):
        code, out, err = _run([*cmd, "--store", db, "--actuator", name])
        assert code == 2 and "must not have a '.' or '..' segment between slashes" in err, err
        assert "Decision" not in out and "dashboard:" not in err
    st = EventStore(db)
    with pytest.raises(ValueError, match=r"^actuator name .*: must not have a '\.' or '\.\.' "
                                         r"segment between slashes \(it names the actuator's "
                                         r"page, /history/NAME"):
        st.start_run(name, command="monitor", source="a.csv", feature="f")
    assert st.count("actuators") == 0
    st.close()


def _legacy_store(db):
    """rig 1 in ALARM; 'x/../rig 1' (OK) and 'a/./b' stored before names were checked."""
    st = EventStore(db)
    for name, alarm in (("rig 1", True), ("x/TWO/rig 1", False), ("a/ONE/b", False)):
        run = st.start_run(name, command="monitor", source=f"{name}.csv", feature="ac p1",
                           threshold=20.0)
        st.add_chunk(run, ChunkSummary(0.0, 0.9, 5, 0, 0.5, 0.1, 0.9, 0.4, 30.0 * alarm, 1.0,
                                       alarm), [AlarmRecord(0.5, 30.0, 20.0)] if alarm else [])
        st.end_run(run)
    st.close()
    con = sqlite3.connect(db)  # as an older leakdiag accepted them
    con.execute("update actuators set name = replace(replace(name, 'TWO', '..'), 'ONE', '.')")
    con.commit()
    con.close()


def test_a_stored_dotted_name_links_to_its_own_page(tmp_path):
    db = tmp_path / "e.db"
    _legacy_store(db)
    st = EventStore(db, create=False)
    srv = DashboardServer(make_app(store=st), Bind("127.0.0.1", 0)).start()
    try:
        with urllib.request.urlopen(srv.url) as r:
            body = r.read().decode()
        assert 'href="/history/x%2F..%2Frig%201"' in body and 'href="/history/a%2F.%2Fb"' in body
        with urllib.request.urlopen(srv.page_url("api/history/x%2F..%2Frig%201")) as r:
            import json

            h = json.load(r)
        assert h["alarms"] == [] and [x["source"] for x in h["runs"]] == ["x/TWO/rig 1.csv"]
    finally:
        srv.stop()
        st.close()


def test_dotted_names_in_a_browser(browser, tmp_path):
    """Chromium resolved '/history/x/../rig 1' to '/history/rig 1': the page of another
    actuator, in ALARM, under the clicked name's link."""
    from .test_browser import LEAKDIAG, _stop, _url_from

    db = tmp_path / "e.db"
    _legacy_store(db)
    p = subprocess.Popen(LEAKDIAG + ["dashboard", "--store", str(db), "--bind", "127.0.0.1:0"],
                         env=src_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                         text=True)
    try:
        url = _url_from(p, "leakdiag dashboard:", p.stderr)
        for name in ("x/../rig 1", "a/./b", "rig 1"):
            browser.get(url)
            link = [r for r in browser.find_elements("css selector", "#fleet tr[data-actuator]")
                    if r.get_attribute("data-actuator") == name][0]
            link.find_element("tag name", "a").click()
            t_end = time.monotonic() + 60
            while browser.find_element("tag name", "body").get_attribute("data-loaded") != "1":
                assert time.monotonic() < t_end, "history page did not load its data"
                time.sleep(0.1)
            assert browser.find_element("id", "name").text == name
            n_alarms = len(browser.find_elements("css selector", "#alarms tr")) - 1
            assert n_alarms == (1 if name == "rig 1" else 0), name
    finally:
        _stop(p)


def test_the_printed_live_address_and_token_work():
    name = "site A/pump.1"
    board = LiveBoard()
    board.add(name, "feat")
    srv = DashboardServer(make_app(board, token="a&b c/d"),
                          Bind("127.0.0.1", 0, token="a&b c/d")).start()
    try:
        url = srv.page_url(page_path("live", name))
        assert url.endswith("/live/site%20A%2Fpump.1?token=a%26b%20c%2Fd")
        with urllib.request.urlopen(url) as r:
            assert r.status == 200 and '"name": "site A/pump.1"' in r.read().decode()
        with urllib.request.urlopen(srv.url) as r:  # the fleet page's address: 403 unencoded
            assert r.status == 200
    finally:
        srv.stop()
