"""``leakdiag dashboard``: the fleet overview of an event store; options shared with ``monitor``."""

from __future__ import annotations

import os

import click

__all__ = ["dashboard", "live_options", "open_monitor_hooks", "actuator_option"]


def actuator_option(ctx, param, value):
    """Click callback of ``--actuator``: a name the store and its pages can hold, or None.

    Parameters
    ----------
    ctx, param : click.Context, click.Parameter
        Click's callback arguments (unused).
    value : str or None
        The option's value.

    Returns
    -------
    str or None
        ``value``.

    Raises
    ------
    click.BadParameter
        For an empty name, ``.`` or ``..`` (:func:`leakdiag.store.database.check_actuator_name`).
    """
    if value is None:
        return None
    from leakdiag.store.database import check_actuator_name

    try:
        return check_actuator_name(value)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None


def live_options(f):
    """Add ``--store``, ``--actuator``, ``--dashboard``, ``--allow-remote``, ``--token``,
    ``--refresh-hz`` and ``--linger`` to a click command (``leakdiag monitor``).

    Parameters
    ----------
    f : callable
        The command function; it receives the options in ``**kwargs``.

    Returns
    -------
    callable
    """
    opts = [
        click.option("--store", "store", default=None,
                     help="Event store: SQLite file or SQLAlchemy URL (chunk summaries, alarms)."),
        click.option("--actuator", default=None, callback=actuator_option,
                     help="Actuator name in the store and on the page (default: input file stem)."),
        click.option("--dashboard", "dashboard_bind", default=None, metavar="[HOST:]PORT",
                     help="Serve a live page (127.0.0.1 unless HOST is given; PORT 0: any)."),
        click.option("--allow-remote", is_flag=True,
                     help="Allow --dashboard on an address other machines can reach."),
        click.option("--token", default=None,
                     help="Token required by the page ('auto': random); needed with a remote host."),
        click.option("--refresh-hz", type=float, default=5.0, show_default=True,
                     help="Largest page update rate; at most 2 a second while a replay "
                          "runs faster than real time (the detector is never throttled)."),
        click.option("--linger", type=float, default=0.0, show_default=True,
                     help="Seconds to keep the page up after the input ends (inf: until Ctrl-C)."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def monitor_actuator(store: str | None, source: str, given: str | None = None) -> str:
    """The actuator name a ``monitor`` run is stored and shown under.

    Parameters
    ----------
    store : str or None
        ``--store`` target.
    source : str
        The input's name (``<stdin>`` or ``-`` for standard input).
    given : str, optional
        ``--actuator``.

    Returns
    -------
    str
        ``given``, else a stem that merges no two actuators of the store
        (:func:`leakdiag.store.writers.default_actuator`), else ``stdin`` or the file's stem.

    Raises
    ------
    click.UsageError
        When the store's names make the default ambiguous.
    """
    name = given
    if name is None and store is not None:  # a stem that merges no two actuators
        from leakdiag.store import EventStore, StoreError
        from leakdiag.store.writers import default_actuator

        st = EventStore(store)
        try:
            name = default_actuator(st, source)
        except StoreError as exc:
            raise click.UsageError(str(exc)) from None
        finally:
            st.close()
    if name is None:
        name = ("stdin" if source in ("<stdin>", "-")
                else os.path.splitext(os.path.basename(source))[0])
    return name


def open_monitor_hooks(live: dict, spec, monitor, source, say):
    """The :class:`~leakdiag.dashboard.hooks.MonitorHooks` of a monitor run, or None.

    Parameters
    ----------
    live : dict
        The options of :func:`live_options`.
    spec : MethodSpec
        Monitored feature.
    monitor : leakdiag.stream.Monitor
        The monitor.
    source : ChunkSource
        The input.
    say : callable
        Prints a message.

    Returns
    -------
    MonitorHooks or None
        None without ``--store`` and ``--dashboard``.

    Raises
    ------
    click.BadParameter
        For a bad ``--dashboard`` address or a remote one without ``--allow-remote``/``--token``.
    """
    if live.get("store") is None and live.get("dashboard_bind") is None:
        return None
    from leakdiag.dashboard.hooks import MonitorHooks
    from leakdiag.dashboard.server import parse_bind

    bind = None
    if live.get("dashboard_bind") is not None:
        try:
            bind = parse_bind(live["dashboard_bind"], live.get("allow_remote", False),
                              live.get("token"))
        except ValueError as exc:
            raise click.BadParameter(str(exc)) from None
    src = str(source.source)
    stdin = src in ("<stdin>", "-")
    name = monitor_actuator(live.get("store"), src, live.get("actuator"))
    return MonitorHooks(name, spec, monitor, src if stdin else os.path.realpath(src),
                        source.sample_rate, live.get("store"), bind,
                        live.get("refresh_hz", 5.0), say, system=live.get("system"))


@click.command("dashboard", epilog="Example: leakdiag dashboard --store events.db --bind 8050")
@click.option("--store", "store", required=True, help="Event store: SQLite file or SQLAlchemy URL.")
@click.option("--bind", "bind_", default="127.0.0.1:8050", show_default=True,
              metavar="[HOST:]PORT", help="Address to serve on.")
@click.option("--allow-remote", is_flag=True,
              help="Allow an address other machines can reach (needs --token).")
@click.option("--token", default=None, help="Token required in every request ('auto': random).")
def dashboard(store, bind_, allow_remote, token):
    """Serve the fleet overview of an event store: state, last alarm, leak estimate, history.

    Read-only: GET pages and JSON only. Stop with Ctrl-C or SIGTERM.
    """
    import threading

    from leakdiag.dashboard.app import make_app
    from leakdiag.dashboard.server import DashboardServer, parse_bind, stop_on_sigterm
    from leakdiag.store import EventStore

    try:
        bind = parse_bind(bind_, allow_remote, token)
    except ValueError as exc:
        raise click.BadParameter(str(exc).replace("--dashboard", "--bind")) from None
    st = EventStore(store, create=False)
    stop = threading.Event()
    srv = DashboardServer(make_app(None, st, bind.token, stop=stop), bind, stop).start()
    click.echo(f"leakdiag dashboard: {st.shown_url} on {srv.url} (Ctrl-C stops)", err=True)
    stop_on_sigterm()
    try:
        while srv.thread.is_alive():
            srv.thread.join(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        srv.stop()
        st.close()
