"""The web application (Starlette): live pages, fleet overview, history; read-only.

Routes (all ``GET``; any other method gets 405):

* ``/`` fleet overview: the store's actuators (state, last alarm, leak estimate, last seen,
  link to the history) and the actuators monitored live by this process.
* ``/live/{name}`` live page; its data come from ``/stream/{name}`` (server-sent events, at most
  ``refresh_hz`` per second, :data:`REPLAY_HZ` while a replay runs faster than real time, only
  when something changed) or ``/api/live/{name}`` (one JSON).
* ``/history/{name}`` feature summaries over all runs, alarms marked (data: ``/api/history``,
  at most :data:`HISTORY_POINTS` points and line breaks: longer histories merged in blocks of
  chunks, and of whole runs when runs outnumber the points; :mod:`leakdiag.dashboard.history`).
* ``/api/fleet`` the overview as JSON; ``/static/...`` the page scripts and Plotly's
  ``plotly.min.js`` served from the installed ``plotly`` package (no CDN, works offline).

With a token every request must carry it (``?token=`` or ``Authorization: Bearer``). Names in
the URL are only looked up, never executed; pages put data into the DOM as text.
"""

from __future__ import annotations

import hmac
import html
import importlib.util
import json
import math
import threading
import time
from datetime import timezone
from pathlib import Path
from typing import Any
from urllib.parse import quote

import anyio
from sse_starlette import EventSourceResponse
from starlette.applications import Starlette
from starlette.datastructures import MutableHeaders
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import (
    FileResponse,
    HTMLResponse,
    JSONResponse,
    PlainTextResponse,
    Response,
)
from starlette.routing import Route

from leakdiag._format import seconds
from leakdiag.dashboard.history import history_points
from leakdiag.dashboard.live import LiveBoard
from leakdiag.dashboard.server import url_segment as _seg
from leakdiag.store import StoreError

__all__ = ["make_app", "plotly_js_path"]

STATIC = Path(__file__).with_name("static")
#: Most rows of a history plot, points and line breaks together: longer histories are merged
#: in blocks of consecutive chunks (:func:`leakdiag.dashboard.history.history_points`; a day of
#: 1-s chunks is 86,400 rows).
HISTORY_POINTS = 2000
#: Runs listed on a history page (newest first; the API says how many there are in all).
HISTORY_RUNS = 200
#: Largest live-page update rate while the stream runs faster than real time (its stream time
#: advanced more than :data:`REPLAY_SPEEDUP` times the wall time since the last update): each
#: update costs the browser a redraw of up to 3,000 points per trace on the cores that the
#: monitor uses; at 2 Hz an update still reaches the page 0.5 s after the one before.
REPLAY_HZ = 2.0
#: Stream time over wall time above which the live stream is treated as a fast replay.
REPLAY_SPEEDUP = 1.5
#: Content security policy: scripts and data only from this server.
CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
       "img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'")


def plotly_js_path() -> Path:
    """Path of ``plotly.min.js`` inside the installed ``plotly`` Python package.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    FileNotFoundError
        If plotly is not installed or does not ship the file.
    """
    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("the dashboard needs the 'plotly' package (pip install plotly)")
    p = Path(list(spec.submodule_search_locations)[0]) / "package_data" / "plotly.min.js"
    if not p.is_file():
        raise FileNotFoundError(f"plotly.min.js not found at {p}")
    return p


def _clean(v: Any) -> Any:
    import pandas as pd

    if v is None or (not isinstance(v, (list, tuple, dict, str)) and pd.isna(v)):
        return None
    if hasattr(v, "isoformat"):  # a wall-clock time: shown in UTC whatever its zone
        if getattr(v, "tzinfo", None) is not None:
            v = v.astimezone(timezone.utc)
        return v.isoformat()
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if hasattr(v, "item"):
        return _clean(v.item())
    return v


def _page(title: str, body: str, scripts: list[str], tok: str, refresh: int | None = None) -> str:
    meta = f'<meta http-equiv="refresh" content="{refresh}">' if refresh else ""
    src = "".join(f'<script src="/static/{s}{tok}"></script>' for s in scripts)
    return (f'<!doctype html><html lang="en"><head><meta charset="utf-8">{meta}'
            f'<title>{html.escape(title)}</title>'
            f'<link rel="stylesheet" href="/static/dashboard.css{tok}"></head>'
            f'<body>{body}{src}</body></html>')


def _cfg(d: dict) -> str:
    text = json.dumps(d).replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f'<script type="application/json" id="cfg">{text}</script>'


class _Guard:
    """ASGI middleware: token check (when set) and security headers on every response."""

    def __init__(self, app, token: str | None):
        self.app, self.token = app, token

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        if self.token is not None:
            request = Request(scope)
            given = request.query_params.get("token", "")
            auth = request.headers.get("authorization", "")
            if auth.lower().startswith("bearer "):
                given = auth[7:]
            if not hmac.compare_digest(given.encode(), self.token.encode()):
                await PlainTextResponse("403: a valid token is required",
                                        status_code=403)(scope, receive, send)
                return

        async def send_headers(message):
            if message["type"] == "http.response.start":
                h = MutableHeaders(scope=message)
                h["Content-Security-Policy"] = CSP
                h["X-Content-Type-Options"] = "nosniff"
                h["Cache-Control"] = "no-store"
            await send(message)

        await self.app(scope, receive, send_headers)


def make_app(board: LiveBoard | None = None, store: Any = None, token: str | None = None,
             refresh_hz: float = 5.0, stop: threading.Event | None = None) -> Starlette:
    """Build the read-only web application.

    Parameters
    ----------
    board : LiveBoard, optional
        Live states (``leakdiag monitor --dashboard``).
    store : leakdiag.store.EventStore, optional
        Event store for the fleet overview and histories.
    token : str, optional
        Required in every request when given.
    refresh_hz : float, default 5.0
        Largest rate of live updates sent per page (:data:`REPLAY_HZ` at most while the stream
        runs faster than real time).
    stop : threading.Event, optional
        Set to end the open live streams (server shutdown).

    Returns
    -------
    starlette.applications.Starlette

    Raises
    ------
    ValueError
        If ``refresh_hz`` is not positive, or there is neither a board nor a store.
    """
    if not refresh_hz > 0:
        raise ValueError(f"refresh_hz={refresh_hz!r} must be > 0")
    if board is None and store is None:
        raise ValueError("the dashboard needs a live board or a store")
    stop = stop or threading.Event()
    period = 1.0 / refresh_hz
    cache: dict[str, tuple[int, str]] = {}

    def tok_q(request: Request) -> str:
        t = request.query_params.get("token")
        return f"?token={quote(t, safe='')}" if token is not None and t else ""

    def live_json(name: str) -> tuple[int, str] | None:
        if board is None:
            return None
        ver = board.version
        hit = cache.get(name)
        if hit and hit[0] == ver:
            return hit
        snap = board.snapshot(name)
        if snap is None:
            return None
        hit = (snap["version"], json.dumps(snap, allow_nan=False))
        cache[name] = hit
        return hit

    async def index(request: Request):
        tq = tok_q(request)
        parts = ["<h1>leakdiag fleet</h1>"]
        if board is not None:
            names = board.names()
            items = "".join(
                f'<li><a href="/live/{_seg(n)}{tq}">{html.escape(n)}</a> '
                f'<span class="state" data-actuator="{html.escape(n)}">'
                f'{html.escape(board.snapshot(n)["state"])}</span></li>' for n in names)
            parts.append(f'<h2>Live</h2><ul id="live-list">{items or "<li>none</li>"}</ul>')
        if store is not None:
            fl = await anyio.to_thread.run_sync(store.fleet)
            rows = []
            for r in fl.to_dict("records"):
                r = {k: _clean(v) for k, v in r.items()}
                n = r["name"]
                leak = "–"
                if r["leak_lpm"] is not None:
                    leak = f'{r["leak_lpm"]:.3g} L/min'
                    if r["leak_lpm_low"] is not None:
                        leak += f' [{r["leak_lpm_low"]:.3g}, {r["leak_lpm_high"]:.3g}]'
                        if r.get("leak_interval"):  # what the bracket is (detect's words)
                            leak += f' ({r["leak_interval"]})'
                    if r.get("leak_extrapolated"):
                        leak += " (extrapolated: outside the calibrated range)"
                last = "–" if r["last_alarm_at"] is None else (
                    f'{r["last_alarm_at"][:19].replace("T", " ")} '
                    f'(t={seconds(r["last_alarm_time_s"], 6)} s)')
                # the recording of the alarm shown: a batch job's folder holds many
                src = r.get("alarm_source")
                where = "" if src is None or r["last_alarm_at"] is None else (
                    f'<div class="note source" title="{html.escape(str(src))}">'
                    f'in {html.escape(Path(str(src)).name)}</div>')
                onset = "–" if r["onset_s"] is None else (
                    ("at or before " if r.get("onset_censored") else "")
                    + f'{seconds(r["onset_s"], 6)} s')
                why = r.get("error") or ""
                note = (f'<td class="note" title="{html.escape(why)}">'
                        f'{html.escape(why if len(why) <= 160 else why[:157] + "...")}</td>')
                rows.append(
                    f'<tr data-actuator="{html.escape(n)}"><td><a href="/history/{_seg(n)}{tq}">'
                    f'{html.escape(n)}</a></td><td><span class="state '
                    f'{html.escape(r["state"])}">{html.escape(r["state"])}</span>'
                    # the run that gave the state under the badge, not inside its colour
                    + (f'<div class="note run">{html.escape(r["run"])}</div>'
                       if r.get("run") else "") + f'</td><td>{html.escape(last)}{where}</td>'
                    f'<td>{html.escape(onset)}</td><td>{html.escape(leak)}</td>'
                    f'<td>{html.escape(str(r["last_seen_at"])[:19].replace("T", " "))}</td>'
                    f'<td>{html.escape(str(r["feature"]))}</td>{note}</tr>')
            head = ("<tr><th>Actuator</th><th>State</th><th>Last alarm (UTC)</th><th>Onset</th>"
                    "<th>Leak estimate</th><th>Last seen (UTC)</th><th>Feature</th>"
                    "<th>Why not judged / inconclusive</th></tr>")
            parts.append(f'<h2>Event store</h2><table id="fleet">{head}{"".join(rows)}</table>'
                         f'<p class="note">{len(rows)} actuator(s); refreshed every 10 s.</p>')
        return HTMLResponse(_page("leakdiag fleet", "".join(parts), [], tq, refresh=10))

    async def live_page(request: Request):
        name = request.path_params["name"]
        if board is None or board.snapshot(name) is None:
            return PlainTextResponse(f"404: no live actuator named {name!r}", status_code=404)
        tq = tok_q(request)
        body = (_cfg({"name": name, "stream": f"/stream/{_seg(name)}{tq}"}) +
                '<h1>leakdiag live: <span id="name"></span></h1>'
                '<div id="status"><div id="state" class="state WAITING">WAITING</div>'
                '<dl><dt>Feature</dt><dd id="feature">–</dd>'
                '<dt>Alarm time</dt><dd id="alarm-time">–</dd>'
                '<dt>Onset estimate</dt><dd id="onset">–</dd>'
                '<dt>Leak size</dt><dd id="leak">–</dd>'
                '<dt>Last window</dt><dd id="last-time">–</dd>'
                '<dt>Page delay</dt><dd id="latency">–</dd></dl></div>'
                '<div id="feature-plot" class="plot"></div><div id="score-plot" class="plot"></div>'
                '<h2>Recent events</h2><ul id="events"></ul>'
                f'<p><a href="/{tq}">fleet</a></p>')
        return HTMLResponse(_page(f"leakdiag live {name}", body,
                                  ["plotly.min.js", "format.js", "live.js"], tq))

    async def live_api(request: Request):
        hit = live_json(request.path_params["name"])
        if hit is None:
            return PlainTextResponse("404: no such live actuator", status_code=404)
        return HTMLResponse(hit[1], media_type="application/json")

    async def live_stream(request: Request):
        name = request.path_params["name"]
        if live_json(name) is None:
            return PlainTextResponse("404: no such live actuator", status_code=404)

        async def events():
            sent = -1
            last = (time.monotonic(), None)  # wall and stream time of the last update sent
            wait = period
            while not stop.is_set():
                hit = live_json(name)
                if hit is not None and hit[0] != sent:
                    sent = hit[0]
                    yield {"data": hit[1]}
                    now, t = time.monotonic(), board.last_time(name)
                    fast = t is not None and last[1] is not None and \
                        t - last[1] > REPLAY_SPEEDUP * (now - last[0])
                    wait = max(period, 1.0 / REPLAY_HZ) if fast else period
                    last = (now, t)
                await anyio.sleep(wait)

        return EventSourceResponse(events(), ping=15)

    async def history_page(request: Request):
        name = request.path_params["name"]
        if store is None:
            return PlainTextResponse("404: no event store", status_code=404)
        if name not in await anyio.to_thread.run_sync(store.actuator_names):
            return PlainTextResponse(f"404: no actuator named {name!r} in the store",
                                     status_code=404)
        tq = tok_q(request)
        body = (_cfg({"name": name, "api": f"/api/history/{_seg(name)}{tq}"}) +
                '<h1>leakdiag history: <span id="name"></span></h1>'
                '<div id="summary-plot" class="plot"></div><div id="score-plot" class="plot"></div>'
                '<h2>Alarms</h2><table id="alarms"><tr><th>Raised (UTC)</th><th>Alarm time</th>'
                '<th>Onset</th><th>Leak estimate</th><th>Cleared</th><th>Source</th></tr></table>'
                '<h2>Runs</h2><table id="runs"><tr><th>Started (UTC)</th><th>Command</th>'
                '<th>Feature</th><th>Status</th><th>Windows</th><th>Source</th><th>Error</th>'
                '</tr></table>'
                f'<p><a href="/{tq}">fleet</a></p>')
        return HTMLResponse(_page(f"leakdiag history {name}", body,
                                  ["plotly.min.js", "format.js", "history.js"], tq))

    async def history_api(request: Request):
        if store is None:
            return PlainTextResponse("404: no event store", status_code=404)
        try:
            summ, al = await anyio.to_thread.run_sync(store.history, request.path_params["name"])
            runs = await anyio.to_thread.run_sync(store.runs_of, request.path_params["name"])
        except StoreError as exc:
            return PlainTextResponse(f"404: {exc}", status_code=404)

        n_rows = len(summ)
        # one series per feature (the runs of an actuator may monitor several: batch analyses,
        # detect's methods), merged run by run so that no point mixes two features or two
        # runs; each run is its own stretch of line: a null row ends it, and one breaks it
        # across a gap (history_points); with more runs than that fits in HISTORY_POINTS,
        # whole runs are merged and drawn as one line (runs_joined, runs_per_point)
        summ, feats = await anyio.to_thread.run_sync(history_points, summ, HISTORY_POINTS)
        cols = ["recorded_at", "t_start_s", "t_end_s", "n_chunks", "value_mean", "value_min",
                "value_max", "score_max", "alarm", "source", "feature"]
        pts = summ["n_chunks"].notna().to_numpy()
        rid, ft = summ["run_id"].to_numpy(), summ["feature"].to_numpy()
        per_run = int(summ["n_runs"].max()) if pts.any() else 1
        out = {"summaries": {c: [_clean(v) for v in summ[c].tolist()] for c in cols},
               "features": feats, "n_chunks": n_rows,
               "chunks_per_point": int(summ["n_chunks"].max()) if len(summ) and n_rows else 1,
               # two runs' points one after the other without a null row between them
               "runs_joined": per_run > 1 or bool((pts[1:] & pts[:-1] & (rid[1:] != rid[:-1])
                                                   & (ft[1:] == ft[:-1])).any()),
               "runs_per_point": per_run,
               "alarms": [{k: _clean(v) for k, v in r.items()} for r in al.to_dict("records")],
               "runs": [{k: _clean(v) for k, v in r.items()}
                        for r in runs.head(HISTORY_RUNS).to_dict("records")],
               "n_runs": len(runs)}
        return JSONResponse(out)

    async def fleet_api(request: Request):
        if store is None:
            return JSONResponse([])
        fl = await anyio.to_thread.run_sync(store.fleet)
        return JSONResponse([{k: _clean(v) for k, v in r.items()} for r in fl.to_dict("records")])

    files = {"live.js": STATIC / "live.js", "history.js": STATIC / "history.js",
             "format.js": STATIC / "format.js", "dashboard.css": STATIC / "dashboard.css"}

    async def static(request: Request):
        fname = request.path_params["fname"]
        if fname == "plotly.min.js":
            return FileResponse(plotly_js_path(), media_type="text/javascript")
        if fname not in files:
            return PlainTextResponse("404", status_code=404)
        media = "text/css" if fname.endswith(".css") else "text/javascript"
        return FileResponse(files[fname], media_type=media)

    async def favicon(request: Request):
        return Response(status_code=204)

    routes = [Route("/", index, methods=["GET"]),
              Route("/favicon.ico", favicon, methods=["GET"]),
              Route("/live/{name:path}", live_page, methods=["GET"]),
              Route("/api/live/{name:path}", live_api, methods=["GET"]),
              Route("/stream/{name:path}", live_stream, methods=["GET"]),
              Route("/history/{name:path}", history_page, methods=["GET"]),
              Route("/api/history/{name:path}", history_api, methods=["GET"]),
              Route("/api/fleet", fleet_api, methods=["GET"]),
              Route("/static/{fname}", static, methods=["GET"])]
    return Starlette(routes=routes, middleware=[Middleware(_Guard, token=token)])
