"""Web pages of leakdiag: a live page per monitored actuator, the fleet overview and histories.

``leakdiag monitor ... --dashboard [HOST:]PORT`` serves the live pages; ``leakdiag dashboard
--store URL`` the fleet overview of an event store (:mod:`leakdiag.store`). Starlette + uvicorn,
server-sent events (sse-starlette), Plotly.js from the installed ``plotly`` package (offline).
Imported only by those commands, so that ``import leakdiag`` stays fast.
"""

from leakdiag.dashboard.live import ActuatorLive, LiveBoard
from leakdiag.dashboard.server import Bind, DashboardServer, parse_bind

__all__ = ["LiveBoard", "ActuatorLive", "Bind", "parse_bind", "DashboardServer"]
