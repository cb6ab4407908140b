"""The web app: read-only routes, escaping, token, bind safety, offline Plotly, SSE stream."""

import json
import threading
import urllib.error
import urllib.parse
import urllib.request

import numpy as np
import pytest

from leakdiag.dashboard import Bind, DashboardServer, LiveBoard, parse_bind
from leakdiag.dashboard.app import make_app, plotly_js_path
from leakdiag.store import AlarmRecord, ChunkSummary, EventStore

EVIL = "<script>alert(1)</script>"


class _Resp:
    def __init__(self, status, headers, content):
        self.status_code, self.headers, self.content = status, headers, content
        self.text = content.decode("utf-8", "replace")

    def json(self):
        return json.loads(self.content)


class Client:
    """The app on a real uvicorn server at 127.0.0.1:<free port>, queried with urllib."""

    def __init__(self, app):
        self.srv = DashboardServer(app, Bind("127.0.0.1", 0)).start()

    def request(self, method, path, headers=None):
        url = f"http://127.0.0.1:{self.srv.port}{path}"
        req = urllib.request.Request(url, method=method, headers=headers or {})
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                return _Resp(r.status, r.headers, r.read())
        except urllib.error.HTTPError as e:
            return _Resp(e.code, e.headers, e.read())

    def get(self, path, headers=None):
        return self.request("GET", path, headers)

    def post(self, path):
        return self.request("POST", path)

    def delete(self, path):
        return self.request("DELETE", path)


@pytest.fixture
def client():
    made = []

    def make(app):
        made.append(Client(app))
        return made[-1]

    yield make
    for c in made:
        c.srv.stop()


@pytest.fixture
def store(tmp_path):
    st = EventStore(tmp_path / "e.db")
    r = st.start_run("rig-a", command="monitor", source="a.parquet", feature="ac p1",
                     threshold=20.0)
    st.add_chunk(r, ChunkSummary(0.2, 9.8, 50, 0, 0.4, 0.1, 0.9, 0.3, 1.0, 1.0, False))
    r = st.start_run("rig-b", command="monitor", source="b.parquet", feature="ac p1",
                     threshold=20.0)
    st.add_chunk(r, ChunkSummary(0.2, 9.8, 50, 0, 0.1, -0.1, 0.3, 0.0, 30.0, 30.0, True),
                 [AlarmRecord(6.5, 21.0, 20.0, onset_s=4.25, leak_lpm=0.2, leak_lpm_low=0.1,
                              leak_lpm_high=0.3)])
    st.start_run(EVIL, command="monitor", source="x", feature="f")
    yield st
    st.close()


def test_fleet_page_lists_actuators_and_escapes(store, client):
    c = client(make_app(store=store))
    r = c.get("/")
    assert r.status_code == 200
    body = r.text
    assert body.count("<tr data-actuator=") == 3
    assert 'href="/history/rig-b"' in body and "0.2 L/min [0.1, 0.3]" in body
    assert "t=6.5 s" in body and "4.25 s" in body
    assert EVIL not in body and "&lt;script&gt;alert(1)&lt;/script&gt;" in body
    assert r.headers["content-security-policy"].startswith("default-src 'self'")
    fleet = c.get("/api/fleet").json()
    assert [(f["name"], f["state"]) for f in fleet] == [
        (EVIL, "NO DATA"), ("rig-a", "OK"), ("rig-b", "ALARM")]
    # last seen: the store's time of the actuator's last write (UTC), in its row of the page
    seen = {n: store.fleet().set_index("name").loc[n, "last_seen_at"] for n in ("rig-a", "rig-b")}
    assert seen["rig-a"] < seen["rig-b"]
    row_b = body.split('<tr data-actuator="rig-b">')[1].split("</tr>")[0]
    assert f'<td>{seen["rig-b"].isoformat()[:19].replace("T", " ")}</td>' in row_b
    assert [f["last_seen_at"] for f in fleet[1:]] == [seen[n].isoformat() for n in seen]
    # the state's badge holds the state alone; the run behind it is a line under the badge
    # (it was inside the coloured cell, grey on red or green: docs/images/dashboard-fleet.png)
    assert '<td><span class="state ALARM">ALARM</span><div class="note run">monitor running' \
        in row_b


def test_history_api_and_404(store, client):
    c = client(make_app(store=store))
    h = c.get("/api/history/rig-b").json()
    assert h["summaries"]["value_mean"] == [0.1] and h["summaries"]["score_max"] == [30.0]
    assert h["alarms"][0]["onset_s"] == 4.25 and h["alarms"][0]["leak_lpm_high"] == 0.3
    assert c.get("/history/rig-b").status_code == 200
    assert c.get("/api/history/nope").status_code == 404
    assert c.get("/history/nope").status_code == 404  # was an empty page with 200
    assert c.get("/live/rig-b").status_code == 404  # no live board in `leakdiag dashboard`
    page = c.get("/history/" + urllib.parse.quote(EVIL))
    assert EVIL not in page.text
    # a name with '/' (EVIL has one) reaches its data: the routes take the rest of the path
    # (before 2026-11-26 such a name was stored but its pages gave 404)
    assert c.get("/api/history/" + urllib.parse.quote(EVIL)).status_code == 200
    assert c.get("/api/history/" + urllib.parse.quote(EVIL, safe="")).status_code == 200
    assert page.status_code == 200


def test_only_get(store, client):
    c = client(make_app(store=store))
    for path in ("/", "/api/fleet", "/history/rig-a"):
        assert c.post(path).status_code == 405
        assert c.delete(path).status_code == 405


def test_token_required(store, client):
    c = client(make_app(store=store, token="s3cret"))
    assert c.get("/").status_code == 403
    assert c.get("/?token=wrong").status_code == 403
    assert c.get("/static/live.js").status_code == 403
    r = c.get("/?token=s3cret")
    assert r.status_code == 200 and 'href="/history/rig-a?token=s3cret"' in r.text
    assert c.get("/api/fleet", headers={"Authorization": "Bearer s3cret"}).status_code == 200


def test_plotly_served_from_the_package(store, client):
    c = client(make_app(store=store))
    r = c.get("/static/plotly.min.js")
    assert r.status_code == 200 and r.content == plotly_js_path().read_bytes()
    assert len(r.content) > 1_000_000  # the full bundle, no CDN
    page = c.get("/history/rig-a").text
    assert 'src="/static/plotly.min.js"' in page and "http" not in page.split("<body>")[1]
    assert c.get("/static/app.py").status_code == 404


@pytest.mark.parametrize("text,host,port", [("8050", "127.0.0.1", 8050),
                                            ("localhost:0", "localhost", 0),
                                            ("[::1]:9000", "::1", 9000)])
def test_parse_bind_loopback(text, host, port):
    b = parse_bind(text)
    assert (b.host, b.port, b.token, b.is_loopback) == (host, port, None, True)


def test_parse_bind_remote_needs_flag_and_token():
    with pytest.raises(ValueError, match="--allow-remote and a --token"):
        parse_bind("0.0.0.0:8050")
    with pytest.raises(ValueError, match="can reach; add a --token$"):  # only what is missing
        parse_bind("0.0.0.0:8050", allow_remote=True)
    with pytest.raises(ValueError, match="can reach; add --allow-remote$"):
        parse_bind("192.168.1.5:8050", token="t")
    b = parse_bind("0.0.0.0:8050", allow_remote=True, token="auto")
    assert not b.is_loopback and len(b.token) >= 20
    with pytest.raises(ValueError, match="PORT in 0..65535"):
        parse_bind("host:http")


def test_live_api_and_sse_stream_on_a_real_server():
    board = LiveBoard()
    board.add("rig1", "feat")
    stop = threading.Event()
    srv = DashboardServer(make_app(board, refresh_hz=20.0, stop=stop),
                          Bind("127.0.0.1", 0), stop).start()
    try:
        assert srv.port > 0
        board.update("rig1", np.array([0.5, 1.0]), np.array([0.25, np.nan]), received_wall=7.0)
        with urllib.request.urlopen(srv.page_url("api/live/rig1")) as r:
            snap = json.load(r)
        assert snap["time"] == [0.5, 1.0] and snap["value"] == [0.25, None]
        assert snap["received_wall"] == 7.0 and snap["state"] == "NO DETECTOR"
        with urllib.request.urlopen(srv.page_url("stream/rig1"), timeout=10) as r:
            assert r.headers["content-type"].startswith("text/event-stream")
            line = b""
            while not line.startswith(b"data:"):
                line = r.readline()
            first = json.loads(line[5:])
            assert first["version"] == snap["version"] and first["n_windows"] == 2
        with pytest.raises(urllib.error.HTTPError, match="404"):
            urllib.request.urlopen(srv.page_url("stream/nope"))
    finally:
        srv.stop()
    assert not srv.thread.is_alive()


@pytest.mark.parametrize("refresh_hz, speed, lo, hi", [(2.0, 100.0, 5, 8), (10.0, 100.0, 5, 8),
                                                      (10.0, 1.0, 20, 32)],
                         ids=["2Hz-replay", "10Hz-replay", "10Hz-realtime"])
def test_sse_stream_is_throttled_to_refresh_hz(refresh_hz, speed, lo, hi):
    """The board changes 100 times a second; a page gets at most refresh_hz snapshots a second,
    and at most REPLAY_HZ (2) while the stream time runs faster than the wall clock (a replay
    at 100 s per s; at 1 s per s, real time, refresh_hz holds)."""
    import time

    board = LiveBoard()
    board.add("rig1", "feat")
    stop, done = threading.Event(), threading.Event()

    def feed():
        t0 = time.monotonic()
        while not done.is_set():
            t = (time.monotonic() - t0) * speed
            board.update("rig1", np.array([t]), np.array([0.5]))
            time.sleep(0.01)

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    srv = DashboardServer(make_app(board, refresh_hz=refresh_hz, stop=stop),
                          Bind("127.0.0.1", 0), stop).start()
    try:
        times, versions = [], []
        with urllib.request.urlopen(srv.page_url("stream/rig1"), timeout=10) as r:
            while not times or times[-1] - times[0] < 3.0:
                line = r.readline()
                if line.startswith(b"data:"):
                    times.append(time.monotonic())
                    versions.append(json.loads(line[5:])["version"])
    finally:
        done.set()
        srv.stop()
        feeder.join()
    # 3 s at 2 Hz: 7 snapshots (the first at once); at 10 Hz 31 (fewer on a loaded machine),
    # each newer than the one before
    assert lo <= len(times) <= hi, times
    assert versions == sorted(set(versions)) and versions[-1] - versions[0] > 50


def _points(s):
    """The history's points without the rows that break its line (no chunk in them), and how
    many of those there were."""
    keep = [i for i, k in enumerate(s["n_chunks"]) if k is not None]
    return {c: [v[i] for i in keep] for c, v in s.items()}, len(s["n_chunks"]) - len(keep)


def test_history_of_days_is_merged_to_at_most_history_points(tmp_path, client):
    """Two days of 1-s chunks would be 172,800 rows; 5,000 here, sent as blocks of 3 chunks."""
    from leakdiag.dashboard.app import HISTORY_POINTS

    st = EventStore(tmp_path / "e.db")
    run = st.start_run("rig-a", command="monitor", source="a.parquet", feature="ac p1")
    n = 5000
    rows = [ChunkSummary(float(i), i + 0.9, 5, i % 5, float(i), i - 1.0, i + 1.0, float(i),
                         float(i % 7), 0.0, i == 4001) for i in range(n)]
    st.add_chunks(run, rows, [AlarmRecord(4001.5, 6.0, 5.0)])
    c = client(make_app(store=st))
    h = c.get("/api/history/rig-a").json()
    s, breaks = _points(h["summaries"])
    assert breaks == 0  # one run: one stretch of line
    assert HISTORY_POINTS == 2000 and (h["n_chunks"], h["chunks_per_point"]) == (5000, 3)
    assert len(s["recorded_at"]) == 1667 and sum(s["n_chunks"]) == n
    # block 0 = chunks 0, 1, 2 with 5, 4, 3 finite windows: mean (0*5 + 1*4 + 2*3) / 12
    assert (s["t_start_s"][0], s["t_end_s"][0], s["value_min"][0], s["value_max"][0]) == \
        (0.0, 2.9, -1.0, 3.0)
    assert s["value_mean"][0] == pytest.approx(10 / 12, rel=1e-15)
    assert s["score_max"][0] == 2.0 and s["alarm"][0] is False
    assert [i for i, a in enumerate(s["alarm"]) if a] == [4001 // 3]  # the alarm's block
    assert s["n_chunks"][-1] == 2 and s["t_end_s"][-1] == 4999.9
    assert len(h["alarms"]) == 1 and h["alarms"][0]["alarm_time_s"] == 4001.5
    st.close()


def test_loopback_server_refuses_other_host_names(store, client):
    """DNS rebinding: a page of evil.example that resolves to 127.0.0.1 is refused."""
    c = client(make_app(store=store))
    port = c.srv.port
    for host in (f"127.0.0.1:{port}", f"localhost:{port}", "localhost"):
        assert c.get("/api/fleet", headers={"Host": host}).status_code == 200, host
    for host in (f"evil.example:{port}", "127.0.0.1.evil.example", "[::2]:80"):
        r = c.get("/api/fleet", headers={"Host": host})
        assert r.status_code == 400 and "rig-a" not in r.text, host


def test_history_keeps_features_apart(tmp_path, client):
    """Found by a real-data audit (2026-11-27): after a batch with several analyses the history
    drew every feature's value as one 'mean' line; now each feature is its own series, merged
    on its own (no point mixes two features) within the same total of points."""
    from leakdiag.dashboard.app import HISTORY_POINTS

    st = EventStore(tmp_path / "e.db")
    a = st.start_run("rig-a", command="monitor", source="a.parquet", feature="ac p1")
    st.add_chunks(a, [ChunkSummary(float(i), i + 0.9, 5, 0, 0.8, 0.7, 0.9, 0.8, None, None,
                                   None) for i in range(3000)])
    b = st.start_run("rig-a", command="batch", source="b.csv", feature="metric-length")
    st.add_chunk(b, ChunkSummary(0.0, 30.0, 31, 2, -0.3, -0.5, 0.1, None, 4.0, None, False))
    h = client(make_app(store=st)).get("/api/history/rig-a").json()
    s, breaks = _points(h["summaries"])
    assert breaks == 0  # one run per feature, each feature its own trace
    assert h["features"] == ["ac p1", "metric-length"] and h["n_chunks"] == 3001
    ac = [i for i, f in enumerate(s["feature"]) if f == "ac p1"]
    ml = [i for i, f in enumerate(s["feature"]) if f == "metric-length"]
    assert len(ac) == 1000 == HISTORY_POINTS // 2 and sum(s["n_chunks"][i] for i in ac) == 3000
    assert {s["value_mean"][i] for i in ac} == {0.8} and h["chunks_per_point"] == 3
    assert [(s["value_mean"][i], s["score_max"][i], s["n_chunks"][i]) for i in ml] == \
        [(-0.3, 4.0, 1)]
    st.close()
