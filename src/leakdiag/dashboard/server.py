"""Run the dashboard: where to bind (safe by default) and a uvicorn server in a thread."""

from __future__ import annotations

import ipaddress
import secrets
import threading
import time
from dataclasses import dataclass
from urllib.parse import quote

__all__ = ["Bind", "parse_bind", "DashboardServer", "LOCALHOST", "stop_on_sigterm", "url_segment",
           "page_path", "check_can_listen"]

LOCALHOST = "127.0.0.1"


@dataclass(frozen=True)
class Bind:
    """Where the dashboard listens and the token it requires.

    Attributes
    ----------
    host : str
        Address to bind.
    port : int
        TCP port (0: any free port).
    token : str or None
        Required in every request (always set for a non-loopback host).
    """

    host: str
    port: int
    token: str | None = None

    @property
    def is_loopback(self) -> bool:
        """Whether the host is a loopback address (only this machine can connect)."""
        if self.host == "localhost":
            return True
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return False


def parse_bind(text: str, allow_remote: bool = False, token: str | None = None) -> Bind:
    """Parse ``[HOST:]PORT``; refuse a non-loopback host without ``allow_remote`` and a token.

    Parameters
    ----------
    text : str
        ``8050``, ``127.0.0.1:8050``, ``0.0.0.0:8050``, ``[::1]:8050``.
    allow_remote : bool, default False
        Allow binding an address other machines can reach.
    token : str, optional
        Token required in requests; ``"auto"`` makes a random one. Needed with a remote host.

    Returns
    -------
    Bind

    Raises
    ------
    ValueError
        For a bad port, a remote host without ``allow_remote``, or without a token.

    Examples
    --------
    >>> parse_bind("8050")
    Bind(host='127.0.0.1', port=8050, token=None)
    >>> parse_bind("0.0.0.0:8050")
    Traceback (most recent call last):
    ...
    ValueError: --dashboard 0.0.0.0:8050 binds an address other machines can reach; add --allow-remote and a --token
    """
    t = text.strip()
    host, sep, port_s = t.rpartition(":")
    if not sep:
        host = LOCALHOST
    host = host.strip("[]") or LOCALHOST
    try:
        port = int(port_s)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise ValueError(f"--dashboard {text!r}: expected [HOST:]PORT with PORT in 0..65535")
    if token == "auto":
        token = secrets.token_urlsafe(16)
    b = Bind(host, port, token or None)
    if not b.is_loopback:
        if not allow_remote or not b.token:
            need = " and ".join(x for x, ok in (("--allow-remote", allow_remote),
                                                ("a --token", b.token)) if not ok)
            raise ValueError(f"--dashboard {text} binds an address other machines can reach; "
                             f"add {need}")
    return b


def check_can_listen(bind: Bind) -> None:
    """Refuse an address the dashboard could not listen on (a port in use), before any work.

    Binds (and closes at once) a socket to every address of ``bind.host`` as uvicorn's
    server does (``SO_REUSEADDR``, IPv6 sockets IPv6-only), so that ``leakdiag monitor
    --dashboard`` stops before its run is registered in the store: a port taken by another
    program said nothing about the actuator, yet the run was stored as failed. Port 0 (any
    free port) is not checked. Another program can still take the port between this check and
    the server's start (the sidecar then fails as before).

    Parameters
    ----------
    bind : Bind
        The ``--dashboard`` address.

    Raises
    ------
    OSError
        Naming the address and the system's reason (e.g. ``Address already in use``).

    Examples
    --------
    >>> import socket
    >>> s = socket.socket()
    >>> s.bind(("127.0.0.1", 0)); s.listen()
    >>> port = s.getsockname()[1]
    >>> try:
    ...     check_can_listen(Bind("127.0.0.1", port))
    ... except OSError as exc:
    ...     print(str(exc).replace(str(port), "PORT").split(" (")[0])
    --dashboard 127.0.0.1:PORT: the page cannot listen there
    >>> s.close()
    """
    import socket

    if bind.port == 0:
        return
    where = f"[{bind.host}]:{bind.port}" if ":" in bind.host else f"{bind.host}:{bind.port}"
    try:
        infos = socket.getaddrinfo(bind.host, bind.port, socket.AF_UNSPEC, socket.SOCK_STREAM,
                                   0, socket.AI_PASSIVE)
        for family, kind, proto, _, addr in infos:
            with socket.socket(family, kind, proto) as s:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                if family == socket.AF_INET6 and hasattr(socket, "IPPROTO_IPV6"):
                    s.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
                s.bind(addr)
    except OSError as exc:
        why = exc.strerror or str(exc)
        raise OSError(f"--dashboard {where}: the page cannot listen there ({why}: another "
                      "program, e.g. a dashboard or monitor still running, may use the port); "
                      "nothing was run or stored: choose another port (0: any free one)") from None


def url_segment(name: str) -> str:
    """An actuator name as one URL path segment: every ``/`` percent-encoded (``%2F``), so that
    a browser never resolves a ``.``/``..`` segment inside it to another actuator's page (the
    server decodes the path before the routes read the name; a name that is ``.`` or ``..``
    itself is refused by :func:`leakdiag.store.database.check_actuator_name`).

    Parameters
    ----------
    name : str
        Actuator name.

    Returns
    -------
    str

    Examples
    --------
    >>> url_segment("x/../rig 1")
    'x%2F..%2Frig%201'
    """
    return quote(name, safe="")


def page_path(kind: str, name: str) -> str:
    """Path of an actuator's page, e.g. ``live/NAME`` (the name one encoded segment).

    Parameters
    ----------
    kind : str
        ``live``, ``history``, ``api/live``...
    name : str
        Actuator name.

    Returns
    -------
    str

    Examples
    --------
    >>> page_path("live", "site A/pump 1")
    'live/site%20A%2Fpump%201'
    """
    return f"{kind}/{url_segment(name)}"


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def stop_on_sigterm() -> None:
    """Make SIGTERM stop a serving command like Ctrl-C (clean shutdown), from the main thread.

    A process started in the background has SIGINT ignored, so ``kill PID`` (SIGTERM) is the
    way to stop it; this turns that into the same clean stop as Ctrl-C.
    """
    import signal

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _interrupt)


class DashboardServer:
    """A uvicorn server for the dashboard app in a background thread.

    On a loopback address, requests must name a loopback host (``127.0.0.1``, ``localhost``,
    ``[::1]`` or the bound address) in their ``Host`` header, else they get 400: a web page of
    another site cannot read the dashboard through a DNS name that points to 127.0.0.1.

    Parameters
    ----------
    app : ASGI application
        From :func:`leakdiag.dashboard.app.make_app`.
    bind : Bind
        Host, port, token.
    stop : threading.Event, optional
        The event the app's live streams watch; set on :meth:`stop`.

    Examples
    --------
    >>> from leakdiag.dashboard.live import LiveBoard
    >>> from leakdiag.dashboard.app import make_app
    >>> import threading, urllib.request
    >>> ev = threading.Event()
    >>> srv = DashboardServer(make_app(LiveBoard(), stop=ev), Bind("127.0.0.1", 0), ev).start()
    >>> urllib.request.urlopen(srv.url).status
    200
    >>> srv.stop()
    """

    def __init__(self, app, bind: Bind, stop: threading.Event | None = None):
        import uvicorn

        if bind.is_loopback:
            # a page of another site must not reach this server by a name that resolves to
            # 127.0.0.1 (DNS rebinding): only loopback names in the Host header
            from starlette.middleware.trustedhost import TrustedHostMiddleware

            host = f"[{bind.host}]" if ":" in bind.host else bind.host
            app = TrustedHostMiddleware(app, allowed_hosts=sorted(
                {"127.0.0.1", "localhost", "[::1]", host}))
        self.bind = bind
        self._stop = stop or threading.Event()
        cfg = uvicorn.Config(app, host=bind.host, port=bind.port, log_level="warning",
                             access_log=False, timeout_graceful_shutdown=2, lifespan="off")
        self.server = uvicorn.Server(cfg)
        self.thread = threading.Thread(target=self.server.run, name="leakdiag-dashboard",
                                       daemon=True)
        self.port = bind.port

    def start(self, timeout_s: float = 20.0) -> "DashboardServer":
        """Start serving and wait until the socket listens.

        Parameters
        ----------
        timeout_s : float, default 20.0
            Seconds to wait.

        Returns
        -------
        DashboardServer
            ``self``.

        Raises
        ------
        OSError
            If the server did not start (e.g. the port is taken).
        """
        self.thread.start()
        t_end = time.monotonic() + timeout_s
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > t_end:
                raise OSError(f"dashboard could not listen on {self.bind.host}:{self.bind.port}")
            time.sleep(0.01)
        self.port = self.server.servers[0].sockets[0].getsockname()[1]
        return self

    @property
    def url(self) -> str:
        """Base URL of the dashboard (with the token, if any)."""
        return self.page_url("")

    def page_url(self, path: str) -> str:
        """URL of a page of the dashboard (with the token, if any).

        Parameters
        ----------
        path : str
            Path without the leading slash, e.g. ``live/rig1``.

        Returns
        -------
        str
        """
        host = f"[{self.bind.host}]" if ":" in self.bind.host else self.bind.host
        q = f"?token={quote(self.bind.token, safe='')}" if self.bind.token else ""
        return f"http://{host}:{self.port}/{path}{q}"

    def stop(self) -> None:
        """End the live streams and stop the server."""
        self._stop.set()
        self.server.should_exit = True
        self.thread.join(timeout=10)
