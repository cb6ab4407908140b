"""The event store: actuators, runs, alarms and chunk summaries in a SQL database.

:class:`EventStore` opens any SQLAlchemy URL; a plain path means an SQLite file. For SQLite the
store sets WAL journaling (readers do not block the writer), ``synchronous=FULL`` (a committed
chunk survives a crash of the process or of the machine), a busy timeout, and opens every write
transaction with ``BEGIN IMMEDIATE`` so that two writing processes queue for the lock instead of
failing half-way; a write that still meets a locked database is retried. Each chunk is one
transaction, so a killed writer loses at most the chunk it was writing.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
import uuid
import warnings
from collections import Counter
from dataclasses import asdict, fields
from datetime import datetime, timezone
from typing import Any, Callable

from sqlalchemy import and_, case, create_engine, event, func, insert, select, update
from sqlalchemy.engine import Engine
from sqlalchemy.exc import DatabaseError, DataError, OperationalError

from leakdiag._version import __version__
from leakdiag.store import schema as S
from leakdiag.store.summary import AlarmRecord, ChunkSummary

__all__ = ["EventStore", "StoreError", "store_url"]

#: Seconds SQLite waits for a lock held by another process before a write attempt fails.
BUSY_TIMEOUT_S = 30.0
#: Attempts of a write transaction that meets a locked database (after the busy timeout).
WRITE_ATTEMPTS = 5
#: PostgreSQL advisory lock taken by a writer while it checks, creates or upgrades the schema
#: (any constant of this program's own; "leakdiag" in ASCII).
SCHEMA_LOCK_KEY = 0x6C65616B64696167


class StoreError(RuntimeError):
    """The store cannot be used: wrong schema version, unreachable database, unknown actuator."""


class ActuatorRigError(StoreError):
    """A run of another rig than its actuator's in the store: that actuator's rows are refused
    (``batch`` goes on with the others; any other :class:`StoreError` stops it)."""


def store_url(target: str | os.PathLike) -> str:
    """SQLAlchemy URL of ``--store``: a URL as given, a file path as an SQLite URL.

    Parameters
    ----------
    target : str or path-like
        ``events.db``, ``sqlite:///events.db``, ``postgresql+psycopg://user@host/db``...

    Returns
    -------
    str

    Raises
    ------
    ValueError
        If ``target`` is empty or blank (the message shows it as given), an in-memory SQLite
        database (``sqlite://``, ``sqlite:///``, ``sqlite:///:memory:``: it ends with the
        connection, so nothing would be kept and the store's reader would see another, empty
        one), or looks like a URL without ``//``
        (``sqlite:/x.db`` is not the file ``x.db``).

    Examples
    --------
    >>> store_url("postgresql+psycopg://u@h/leaks")
    'postgresql+psycopg://u@h/leaks'
    >>> store_url("/data/events.db")
    'sqlite:////data/events.db'
    >>> store_url("sqlite:///")
    Traceback (most recent call last):
    ...
    ValueError: --store sqlite:///: an in-memory SQLite database ends with the connection that made it: nothing would be kept, and every other connection (the page, another command) sees an empty one; give a file, e.g. --store events.db
    """
    t = os.fspath(target)
    if not t.strip():
        raise ValueError(f"--store needs a file path or a database URL, got {t!r}")
    if "://" in t:
        from sqlalchemy.engine import make_url

        try:
            url = make_url(t)
        except Exception:  # noqa: BLE001 - not parseable: create_engine will say why
            return t
        db = url.database or ""
        if url.get_backend_name() == "sqlite" and (
                db in ("", ":memory:") or db.startswith("file::memory:")
                or url.query.get("mode") == "memory"):
            raise ValueError(f"--store {t}: an in-memory SQLite database ends with "
                             "the connection that made it: nothing would be kept, and every "
                             "other connection (the page, another command) sees an empty one; "
                             "give a file, e.g. --store events.db")
        return t
    scheme = re.match(r"([A-Za-z][A-Za-z0-9+.\-]+):", t)
    if scheme:  # two letters at least: C:\\events.db is a Windows path
        shown = t if "@" not in t else f"{scheme.group(1)}:***"
        raise ValueError(f"--store {shown}: looks like a database URL, but a URL needs '//' "
                         f"after '{scheme.group(1)}:' (sqlite:///events.db is the file "
                         "events.db, sqlite:////data/events.db an absolute path); for a file "
                         f"of this name write ./{shown if shown == t else 'NAME'}")
    return f"sqlite:///{os.path.abspath(t)}"


#: Longest actuator name (and detector or feature name) the store's columns hold
#: (``String(200)``, :mod:`leakdiag.store.schema`).
MAX_NAME_CHARS = 200


def check_actuator_name(name: str) -> str:
    """Refuse an actuator name the store and its pages cannot hold.

    Parameters
    ----------
    name : str

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    ValueError
        If it is empty or blank, longer than :data:`MAX_NAME_CHARS` (the column's size: a
        PostgreSQL store refused a longer one with a traceback after the verdict was printed,
        a store audit, 2026-11-29), or has a ``.`` or ``..`` path segment (``.``, ``..``,
        ``site A/../pump 1``, ``a/./b``: its page is ``/history/NAME``, which a browser or an
        HTTP client resolves to another address, another actuator's page).

    Examples
    --------
    >>> check_actuator_name("Presse 3")
    'Presse 3'
    >>> check_actuator_name("x/../rig 1")
    Traceback (most recent call last):
    ...
    ValueError: actuator name 'x/../rig 1': must not have a '.' or '..' segment between slashes (it names the actuator's page, /history/NAME, which a browser would resolve to another address: another actuator's page); e.g. 'x/rig 1'
    """
    text = str(name)
    if not text.strip():
        raise ValueError("actuator name must not be empty")
    if len(text) > MAX_NAME_CHARS:
        raise ValueError(f"actuator name {text[:40]!r}...: {len(text)} characters, at most "
                         f"{MAX_NAME_CHARS} are stored (the store's actuator names)")
    segments = text.split("/")
    if any(seg.strip() in (".", "..") for seg in segments):
        fixed = "/".join(seg for seg in segments if seg.strip() not in (".", "..")) or "rig1"
        raise ValueError(f"actuator name {text!r}: must not have a '.' or '..' segment "
                         "between slashes (it names the actuator's page, /history/NAME, "
                         "which a browser would resolve to another address: another "
                         f"actuator's page); e.g. {fixed!r}")
    return text


def _shown_url(url: str) -> str:
    """``url`` with its password hidden, for messages.

    Examples
    --------
    >>> _shown_url("postgresql+psycopg://fleet:hunter2@db.example/leaks")
    'postgresql+psycopg://fleet:***@db.example/leaks'
    """
    try:
        from sqlalchemy.engine import make_url

        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001 - not parseable: create_engine will say why
        return url


def _sqlite_path(url: str) -> str:
    """The file of an SQLite URL ('' for none), also of a ``file:`` URI (``?uri=true``).

    Examples
    --------
    >>> _sqlite_path("sqlite:////data/e.db")
    '/data/e.db'
    >>> _sqlite_path("sqlite:///file:/d/e.db?mode=ro&uri=true")
    '/d/e.db'
    """
    from urllib.parse import unquote

    from sqlalchemy.engine import make_url

    try:
        db = make_url(url).database or ""
    except Exception:  # noqa: BLE001 - not parseable: create_engine will say why
        return ""
    if db.startswith("file:"):
        db = unquote(db[5:].split("?", 1)[0])
    return db


def _now() -> datetime:
    return datetime.now(timezone.utc)


def _locked(exc: OperationalError) -> bool:
    msg = str(exc.orig).lower()
    return "locked" in msg or "busy" in msg


class EventStore:
    """Read and write the event store.

    Parameters
    ----------
    target : str or path-like
        SQLite file or SQLAlchemy URL (see :func:`store_url`).
    create : bool, default True
        Create the tables if the database is empty.

    Raises
    ------
    StoreError
        If the database holds another schema version, or cannot be opened.

    Examples
    --------
    >>> import tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> st = EventStore(os.path.join(d, "events.db"))
    >>> run = st.start_run("rig1", command="monitor", source="x.parquet", feature="ac p1")
    >>> st.add_chunk(run, ChunkSummary(0.2, 0.4, 2, 0, 0.5, 0.4, 0.6, 0.6))
    (0, [])
    >>> st.fleet()["name"].tolist()
    ['rig1']
    >>> st.close()
    """

    def __init__(self, target: str | os.PathLike, create: bool = True):
        self.url = store_url(target)
        #: Schema version of the file: :data:`SCHEMA_VERSION`, or an older one that a reader
        #: (``create=False``) reads as it is.
        self.version = S.SCHEMA_VERSION
        #: The URL as messages show it: a password in it is hidden (``***``).
        self.shown_url = _shown_url(self.url)
        self.is_sqlite = self.url.startswith("sqlite")
        path = _sqlite_path(self.url) if self.is_sqlite else ""
        if not create and path and path != ":memory:" and not os.path.exists(path):
            raise StoreError(f"{path}: no such event store file")
        folder = os.path.dirname(os.path.abspath(path)) if path and path != ":memory:" else ""
        if create and folder and not os.path.isdir(folder):  # SQLite: "unable to open database"
            raise StoreError(f"{path}: cannot create the event store: the folder {folder} does "
                             "not exist (create it first; a store is one file, made in a folder "
                             "that is there)")
        try:
            self.engine: Engine = create_engine(self.url)
        except Exception as exc:  # bad URL, missing driver
            raise StoreError(f"--store {self.shown_url}: cannot open: "
                             f"{type(exc).__name__}: {exc}") from None
        self._read_engine: Engine = self.engine
        self._path = path
        if self.is_sqlite:
            event.listen(self.engine, "connect", _sqlite_connect)
            event.listen(self.engine, "begin", _sqlite_begin)
            self._read_engine = create_engine(self.url)  # readers: deferred BEGIN, no write lock
            event.listen(self._read_engine, "connect", _sqlite_connect_read)
            event.listen(self._read_engine, "begin", _sqlite_begin_read)
        elif self.engine.dialect.name == "postgresql":
            event.listen(self.engine, "connect", _pg_connect)
        try:
            if create:
                self._write(lambda c: self._check_schema(c, create), opening=True)
            else:  # a reader (the fleet page) opens without a write lock
                self._open_reader()
        except DatabaseError as exc:  # a file that is not a database
            self.close()
            raise StoreError(f"{self.shown_url}: cannot open the event store: "
                             f"{exc.orig}{self._read_only_hint()}") from None
        except BaseException:
            self.close()  # no pooled connection left open behind a refused store
            raise

    def _read_only_hint(self) -> str:
        """``; the file or its folder is read-only ...`` when that is why SQLite failed, else ''."""
        if not self._path or not os.path.exists(self._path):
            return ""
        folder = os.path.dirname(os.path.abspath(self._path))
        if os.access(self._path, os.W_OK) and os.access(folder, os.W_OK):
            return ""
        return (f" ({self._path} or its folder is read-only: a writing command needs write "
                "access to both, SQLite writes its -wal and -shm files beside the store)")

    def _open_reader(self) -> None:
        """Check the schema as a reader: a deferred transaction, no pragma that writes. A
        store that cannot be opened so (its folder read-only, where SQLite cannot create the
        shared-memory file of a WAL store) is opened read-only (``mode=ro``), else refused with
        the reason; never ``immutable`` (another process may be writing it)."""
        try:
            with self._read_engine.begin() as conn:
                self._check_schema(conn, False)
            return
        except OperationalError as exc:
            if not (self.is_sqlite and self._path):
                raise StoreError(f"{self.shown_url}: cannot open the event store: "
                                 f"{exc.orig}") from None
            first = exc
        from urllib.parse import quote

        self._read_engine.dispose()
        ro = f"sqlite:///file:{quote(os.path.abspath(self._path))}?mode=ro&uri=true"
        self._read_engine = create_engine(ro)
        event.listen(self._read_engine, "connect", _sqlite_connect_read)
        event.listen(self._read_engine, "begin", _sqlite_begin_read)
        try:
            with self._read_engine.begin() as conn:
                self._check_schema(conn, False)
        except OperationalError:
            why = f"{self.shown_url}: cannot open the event store: {first.orig}"
            if self._read_only_hint():
                why += (f"; {self._path} or its folder is read-only, and to read a WAL store "
                        f"SQLite must create {self._path}-shm beside it (it cannot open it "
                        "read-only while no writer has it open); give the page write access "
                        "to the folder, or serve a copy of the file from a writable folder")
            raise StoreError(why) from None

    # -- internals ------------------------------------------------------------------------
    def _check_schema(self, conn, create: bool) -> None:
        from sqlalchemy import inspect, text

        if create and conn.dialect.name == "postgresql":
            # writers opening a new or an older store at once take turns (SQLite: BEGIN
            # IMMEDIATE); the lock ends with the transaction, the version is read after it
            conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": SCHEMA_LOCK_KEY})
        have = set(inspect(conn).get_table_names())
        if "schema_version" in have:
            rows = conn.execute(select(S.schema_version.c.version)).scalars().all()
            if len(rows) == 1 and rows[0] in S.UPGRADES and rows[0] < S.SCHEMA_VERSION:
                if not create:  # a reader (the fleet page) leaves the file as it is
                    self.version = rows[0]
                    return
                old = rows[0]
                while rows[0] in S.UPGRADES and rows[0] < S.SCHEMA_VERSION:
                    rows = [self._upgrade(conn, rows[0])]
                added = ", ".join(S.UPGRADE_NOTES[v] for v in range(old, rows[0]))
                warnings.warn(f"{self.shown_url}: event store upgraded from schema version "
                              f"{old} to {rows[0]} ({added} added); leakdiag versions "
                              "before this one no longer open it", UserWarning, stacklevel=4)
            if rows and rows != [S.SCHEMA_VERSION]:
                raise StoreError(
                    f"{self.shown_url}: event store has schema version "
                    f"{', '.join(map(str, rows))}, this leakdiag "
                    f"({__version__}) reads version {S.SCHEMA_VERSION}; use a new store file or "
                    "the leakdiag version that wrote it")
        elif have and not create:
            raise StoreError(f"{self.shown_url}: not a leakdiag event store (no "
                             "schema_version table)")
        elif have:
            raise StoreError(f"{self.shown_url}: not a leakdiag event store: it has tables "
                             f"{sorted(have)} but no schema_version table")
        if not create and not have:
            raise StoreError(f"{self.shown_url}: empty database, no event store in it")
        if not create:
            return
        S.metadata.create_all(conn)
        if not conn.execute(select(S.schema_version.c.version)).first():
            conn.execute(insert(S.schema_version).values(version=S.SCHEMA_VERSION,
                                                          created_at=_now()))
        else:  # a no-op write: a store this process cannot write is refused now, not later
            conn.execute(update(S.schema_version).values(version=S.schema_version.c.version))

    @staticmethod
    def _upgrade(conn, version: int) -> int:
        """Take the store from ``version`` to the next one, in the open transaction."""
        from sqlalchemy import text

        for stmt in S.UPGRADES[version]:
            conn.execute(text(stmt))
        conn.execute(update(S.schema_version).values(version=version + 1))
        return version + 1

    def _write(self, fn: Callable[[Any], Any], opening: bool = False) -> Any:
        """Run ``fn(conn)`` in a write transaction; retried while the database is locked.

        Raises
        ------
        StoreError
            For any other database error (read-only, disk full, connection lost), or a lock
            that outlasted every attempt, naming the store and saying what went wrong.
        """
        for attempt in range(WRITE_ATTEMPTS):
            try:
                with self.engine.begin() as conn:
                    return fn(conn)
            except DataError as exc:  # a value the column cannot hold (PostgreSQL: too long)
                raise StoreError(f"{self.shown_url}: cannot write to the event store: a value "
                                 f"does not fit its column: {str(exc.orig).strip()}") from None
            except OperationalError as exc:
                if _locked(exc) and attempt < WRITE_ATTEMPTS - 1:
                    time.sleep(0.05 * 2 ** attempt)
                    continue
                what = "cannot open the event store" if opening else \
                    "cannot write to the event store"
                msg = str(exc.orig)
                if "readonly" in msg.replace("-", "").replace(" ", "").lower():
                    what += " (it is read-only)"
                elif _locked(exc):
                    what += f" (still locked after {WRITE_ATTEMPTS} attempts)"
                raise StoreError(f"{self.shown_url}: {what}: {msg}"
                                 f"{self._read_only_hint()}") from None
        raise AssertionError("unreachable")  # pragma: no cover

    def _actuator(self, conn, name: str, system: str | None, said_by: str) -> int:
        """The id of actuator ``name``, its row locked until the transaction ends; created if new.

        The row is read ``SELECT ... FOR UPDATE`` (SQLite: the transaction's ``BEGIN
        IMMEDIATE`` already holds the file), so a writer that changes the actuator at the same
        time (another command setting its rig) is waited for and its change read, not
        overwritten. A new actuator is inserted in a savepoint: when another writer inserted
        the same name first (PostgreSQL: a unique violation once it commits), its row is read
        and locked instead. The rig is checked against the store's and set only where the store
        has none (``WHERE system IS NULL``). ``last_seen_at`` is the caller's: a call that
        writes no run writes nothing here for a known actuator of a known rig.

        Parameters
        ----------
        conn : Connection
            In the write transaction.
        name : str
            Actuator name.
        system : str or None
            The rig the runs say (lower case), None if they do not know it.
        said_by : str
            Who says it, for the message (``this run``, a recording).

        Raises
        ------
        StoreError
            If the store has the actuator as another rig (nothing is written then).
        """
        from sqlalchemy.exc import IntegrityError

        a = S.actuators.c
        locked = select(a.id, a.system).where(a.name == name).with_for_update()
        row = conn.execute(locked).first()
        if row is None:
            now = _now()
            try:
                with conn.begin_nested():
                    return int(conn.execute(insert(S.actuators).values(
                        name=name, system=system, first_seen_at=now,
                        last_seen_at=now)).inserted_primary_key[0])
            except IntegrityError:  # another writer created it first: take its row
                row = conn.execute(locked).first()
                if row is None:
                    raise
        aid, have = int(row[0]), row[1]
        if system is not None and have is not None and have != system:
            article = "an" if str(have)[:1].lower() in "aeiou" else "a"  # an eha, a vca
            raise ActuatorRigError(f"{self.shown_url}: actuator {name!r} is {article} {have} in "
                                   f"the store, {said_by} says {system}: give it another name")
        if system is not None and have is None:  # the first run that knows it
            conn.execute(update(S.actuators).where((a.id == aid) & a.system.is_(None))
                         .values(system=system))
        return aid

    # -- writing --------------------------------------------------------------------------
    def start_run(self, actuator: str, *, command: str, source: str, feature: str,
                  sample_rate_hz: float | None = None, threshold: float | None = None,
                  system: str | None = None, config: dict | None = None,
                  invocation: str | None = None) -> int:
        """Register a run (one pass over one input) of an actuator; creates the actuator.

        The actuator is read with its row locked, as :meth:`add_finished_runs` reads it: a
        writer that sets its rig or creates it at the same time is waited for, and its rig
        checked against ``system``.

        Parameters
        ----------
        actuator : str
            Actuator name (unique in the store).
        command : str
            ``monitor``, ``batch`` or ``detect``.
        source : str
            Input file or ``<stdin>``.
        feature : str
            Feature or method label.
        sample_rate_hz : float, optional
            Sample rate in Hz.
        threshold : float, optional
            Detector alarm threshold.
        system : str, optional
            ``vca`` or ``eha``.
        config : dict, optional
            Settings stored as JSON.
        invocation : str, optional
            Id shared by the runs of one command invocation (e.g. ``detect`` with several
            methods); default: a new id. The fleet state looks at the latest invocation.

        Returns
        -------
        int
            Run id.

        Raises
        ------
        StoreError
            If the store has the actuator as another rig than ``system``.
        ValueError
            If ``actuator`` is empty.
        """
        check_actuator_name(actuator)
        rig = None if system is None else str(system).lower()

        def fn(conn):
            aid = self._actuator(conn, str(actuator), rig, "this run")
            now = _now()
            conn.execute(update(S.actuators).where(S.actuators.c.id == aid)
                         .values(last_seen_at=now))
            return int(conn.execute(insert(S.runs).values(
                actuator_id=aid, command=command, invocation=invocation or uuid.uuid4().hex,
                source=str(source), feature=feature,
                sample_rate_hz=sample_rate_hz, threshold=threshold, started_at=now,
                status="running", n_chunks=0, n_windows=0,
                config=None if config is None else json.dumps(config, default=str),
                leakdiag_version=__version__)).inserted_primary_key[0])

        return self._write(fn)

    def add_chunk(self, run_id: int, summary: ChunkSummary | None,
                  new_alarms: tuple[AlarmRecord, ...] | list[AlarmRecord] = (),
                  alarm_updates: dict[int, dict] | None = None) -> tuple[int | None, list[int]]:
        """Write one chunk in one transaction: its summary, new alarms, changed alarms.

        Parameters
        ----------
        run_id : int
            From :meth:`start_run`.
        summary : ChunkSummary or None
            The chunk's windows (None: only alarms).
        new_alarms : sequence of AlarmRecord
            Alarms raised in the chunk.
        alarm_updates : dict of int to dict, optional
            Alarm id -> columns to change (e.g. ``cleared_time_s``, ``leak_lpm``).

        Returns
        -------
        seq : int or None
            Chunk number in the run (None without a summary).
        alarm_ids : list of int
            Ids of the new alarms.
        """
        seqs, ids = self.add_chunks(run_id, [] if summary is None else [summary], new_alarms,
                                    alarm_updates)
        return (seqs[0] if seqs else None), ids

    def add_chunks(self, run_id: int, summaries: list[ChunkSummary] | tuple[ChunkSummary, ...],
                   new_alarms: tuple[AlarmRecord, ...] | list[AlarmRecord] = (),
                   alarm_updates: dict[int, dict] | None = None,
                   recorded_at: list[datetime] | None = None) -> tuple[list[int], list[int]]:
        """Write consecutive chunks in one transaction: their summaries, new and changed alarms.

        A group commit: all the rows are committed together or not at all, and the run's
        ``n_chunks`` and ``n_windows`` move with them. The summaries are inserted with one
        ``executemany``, so many small chunks cost about one commit.

        Parameters
        ----------
        run_id : int
            From :meth:`start_run`.
        summaries : sequence of ChunkSummary
            The chunks' windows, in stream order (may be empty: only alarms).
        new_alarms : sequence of AlarmRecord
            Alarms raised in these chunks.
        alarm_updates : dict of int to dict, optional
            Alarm id -> columns to change (e.g. ``cleared_time_s``, ``leak_lpm``).
        recorded_at : list of datetime, optional
            Wall-clock time (aware, UTC) of each summary's chunk: when the monitor handed it
            over. Default: the time of this transaction for all of them.

        Returns
        -------
        seqs : list of int
            Chunk numbers in the run, one per summary.
        alarm_ids : list of int
            Ids of the new alarms.

        Raises
        ------
        StoreError
            If the run is not in the store.
        ValueError
            If ``recorded_at`` is not one time per summary.
        """
        summaries = list(summaries)
        if recorded_at is not None and len(recorded_at) != len(summaries):
            raise ValueError(f"recorded_at has {len(recorded_at)} times for {len(summaries)} "
                             "summaries")

        def fn(conn):
            run = conn.execute(select(S.runs.c.actuator_id, S.runs.c.n_chunks)
                               .where(S.runs.c.id == run_id)).first()
            if run is None:
                raise StoreError(f"{self.shown_url}: no run with id {run_id}")
            now = _now()
            seq0 = int(run.n_chunks)
            if summaries:
                _insert_summaries(conn, run_id, seq0, now, summaries, recorded_at)
                conn.execute(update(S.runs).where(S.runs.c.id == run_id).values(
                    n_chunks=S.runs.c.n_chunks + len(summaries),
                    n_windows=S.runs.c.n_windows + sum(sm.n_windows for sm in summaries)))
            ids = [int(conn.execute(insert(S.alarms).values(
                run_id=run_id, raised_at=now, **asdict(a))).inserted_primary_key[0])
                for a in new_alarms]
            for aid, cols in (alarm_updates or {}).items():
                conn.execute(update(S.alarms).where(S.alarms.c.id == aid).values(**cols))
            conn.execute(update(S.actuators).where(S.actuators.c.id == run.actuator_id)
                         .values(last_seen_at=now))
            return list(range(seq0, seq0 + len(summaries))), ids

        return self._write(fn)

    def add_finished_runs(self, actuator: str, runs, invocation: str | None = None) -> list:
        """Write runs judged as a whole (batch rows, detect's methods) in one transaction.

        Each run goes in with its summary, its alarms and its end (status, ``ended_at``): all
        of them or none, so an interruption leaves no run ``running`` and loses no alarm of a
        run it stored. The actuator's row is locked first (``SELECT ... FOR UPDATE``; SQLite's
        ``BEGIN IMMEDIATE`` locks the file), so two writers of one actuator take turns, and a
        run whose :attr:`FinishedRun.key` the actuator already has is skipped *inside* the
        transaction: each batch result row is stored once whatever runs at the same time.

        Parameters
        ----------
        actuator : str
            Actuator name (created if new).
        runs : sequence of FinishedRun
            The runs, in order.
        invocation : str, optional
            Id shared by the runs (default: a new one).

        Returns
        -------
        list of int or None
            Run id of each run, None for a run skipped because its key is stored.

        Raises
        ------
        StoreError
            If the runs' rigs disagree with each other or with the actuator's rig in the store
            (the message names the recordings); nothing is written then.
        ValueError
            If ``actuator`` is empty.
        """
        check_actuator_name(actuator)
        runs = list(runs)
        if not runs:
            return []
        inv = invocation or uuid.uuid4().hex
        return self._write(lambda conn: self._add_finished(conn, str(actuator), runs, inv))

    def _add_finished(self, conn, name: str, runs: list, inv: str) -> list:
        said = {}  # rig -> first recording that says it
        for r in runs:
            if r.system is not None:
                said.setdefault(str(r.system).lower(), str(r.source))
        if len(said) > 1:
            words = ", ".join(f"{src} says {k}" for k, src in said.items())
            raise ActuatorRigError(f"{self.shown_url}: actuator {name!r}: its recordings disagree "
                                   f"on the rig ({words}): give them different actuator names")
        system, said_by = next(iter(said.items()), (None, ""))
        aid = self._actuator(conn, name, system, said_by)
        stored = set()  # rows of this actuator already in the store, read under its lock
        if any(r.key is not None for r in runs):
            for c in conn.execute(select(S.runs.c.config).where(
                    S.runs.c.actuator_id == aid)).scalars():
                key = _row_key(c)
                if key is not None:
                    stored.add(key)
        new, skip = [], []
        for r in runs:
            skip.append(r.key is not None and r.key in stored)
            if not skip[-1]:
                new.append(r)
                if r.key is not None:
                    stored.add(r.key)  # the same row twice in one call: once
        if not new:  # nothing to write: the lock was all (no write for a known actuator)
            return [None] * len(runs)
        now = _now()
        conn.execute(update(S.actuators).where(S.actuators.c.id == aid)
                     .values(last_seen_at=now))
        ids = iter([self._insert_finished(conn, aid, r, inv, now) for r in new])
        return [None if sk else next(ids) for sk in skip]

    @staticmethod
    def _insert_finished(conn, aid: int, r, inv: str, now) -> int:
        """One finished run with its summary and alarms, in the open transaction."""
        config = dict(r.config or {})
        if r.key is not None:
            config["row"] = r.key
        rid = int(conn.execute(insert(S.runs).values(
            actuator_id=aid, command=r.command, invocation=inv, source=str(r.source),
            feature=r.feature, sample_rate_hz=r.sample_rate_hz, threshold=r.threshold,
            started_at=now, ended_at=now, status=r.status,
            n_chunks=0 if r.summary is None else 1,
            n_windows=0 if r.summary is None else int(r.summary.n_windows),
            config=json.dumps(config, default=str) if config else None,
            leakdiag_version=__version__, error=r.error)).inserted_primary_key[0])
        if r.summary is not None:
            _insert_summaries(conn, rid, 0, now, [r.summary])
        for al in r.alarms:
            conn.execute(insert(S.alarms).values(run_id=rid, raised_at=now, **asdict(al)))
        return rid

    def end_run(self, run_id: int, status: str = "finished", error: str | None = None) -> None:
        """Mark a run as ended (``finished``, ``failed``, ``unjudged``, ``inconclusive`` or
        ``stopped``).

        Parameters
        ----------
        run_id : int
            From :meth:`start_run`.
        status : str, default "finished"
            Final status; ``stopped``: the user stopped a monitor before the end of its input
            (Ctrl-C, SIGTERM), what it judged until then is stored.
        error : str, optional
            Why the run failed, was not judged or was inconclusive (the message the user
            saw), or what stopped it ("stopped by SIGTERM after 1263 windows").
        """
        self._write(lambda c: c.execute(update(S.runs).where(S.runs.c.id == run_id)
                                        .values(ended_at=_now(), status=status, error=error)))

    def end_session(self, actuator: str, session_id: str) -> int:
        """Mark the stored runs of one ``monitor --segment`` session as ended.

        Each judged segment is stored as a finished run whose config carries the session
        (``{"session": {"id": ..., "interval_s": ..., "ended": false}}``); the monitor marks
        them ended when it stops in any way but a ``kill -9`` (or a crash of the machine), so
        the fleet page can tell a session that stopped sending segments from one that ended
        (:func:`_run_words`).

        Parameters
        ----------
        actuator : str
            Actuator name.
        session_id : str
            The session's id (its runs' ``config["session"]["id"]``).

        Returns
        -------
        int
            Runs marked.
        """
        def fn(conn):
            r_, a_ = S.runs.c, S.actuators.c
            rows = conn.execute(select(r_.id, r_.config).join(
                S.actuators, a_.id == r_.actuator_id).where(
                (a_.name == str(actuator)) & r_.config.contains(str(session_id)))).all()
            n = 0
            for rid, text in rows:
                cfg = _config(text)
                ses = cfg.get("session")
                if isinstance(ses, dict) and ses.get("id") == session_id and \
                        ses.get("ended") is not True:
                    cfg["session"] = {**ses, "ended": True}
                    conn.execute(update(S.runs).where(r_.id == rid).values(
                        config=json.dumps(cfg, default=str)))
                    n += 1
            return n

        return self._write(fn)

    def close(self) -> None:
        """Release the database connections."""
        self.engine.dispose()
        self._read_engine.dispose()

    # -- reading --------------------------------------------------------------------------
    def _frame(self, stmt):
        import pandas as pd

        with self._read_engine.connect() as conn:
            res = conn.execute(stmt)
            return pd.DataFrame(res.fetchall(), columns=list(res.keys()))

    def actuator_names(self) -> list[str]:
        """Names of every actuator in the store, sorted.

        Returns
        -------
        list of str
        """
        with self._read_engine.connect() as conn:
            return sorted(conn.execute(select(S.actuators.c.name)).scalars().all())

    def fleet(self):
        """One row per actuator: state, last alarm, leak estimate, last seen.

        The runs of one command invocation (``detect``'s methods, a ``batch`` job's rows) are
        judged together. An invocation's *activity* is the latest of its runs' start, end, last
        chunk and last alarm (wall clock); its verdict is ``ALARM`` when a run of it has an
        alarm that was not cleared, ``NO DATA`` while its runs are running (or were stopped)
        without a chunk or an alarm, ``FAILED`` when every run failed, ``INCONCLUSIVE`` when
        a run alarmed but its alarm is no evidence of a leak (``inconclusive``: the detector
        refused it, or a run this long expects it by chance; ``detect`` and ``batch`` print
        INCONCLUSIVE, ``monitor --segment`` such a segment), ``NOT JUDGED`` when one failed
        or was not judged, else ``OK`` (a monitor ``stopped`` by the user is judged by
        what it stored, like a ``finished`` one). Runs that cannot judge take no part
        (:func:`_judgment`: a ``monitor`` without a detector, a ``batch`` analysis row): an
        invocation of such runs only is ``NO DETECTOR``, which gives the state only while the
        actuator has no other invocation and never clears an alarm. A monitor with a
        detector that ended without scoring a window (every window in the burn-in) counts as
        not judged, one still running in its burn-in as without data.

        The state is ``ALARM`` while an invocation with that verdict stands: until an
        invocation that *started after* its last activity judged the actuator ``OK`` (a
        healthy run started before that alarm, or a failed or unjudged one, does not clear
        it). Otherwise the state is the verdict of the invocation with the latest activity.
        So a ``detect`` of a healthy file started while a long ``monitor`` runs does not hide
        the monitor's later alarm, and a live monitor's alarm stands while it keeps sending
        chunks in alarm.

        ``batch`` runs are judged by recording (:func:`_batch_current`): the current runs of
        every recording (its latest batch invocation's) are judged as one invocation, so the
        state does not depend on how a folder's files were split across batch runs (a re-run
        storing only an added file's runs cleared a leaking file's alarm).

        The alarm shown (time, onset, leak estimate) is the newest alarm by wall clock
        (``raised_at``; the standing ones when the state is ``ALARM``); of the alarms of its
        invocation on the same recording (``detect``'s methods, a batch job's detectors), the
        first in stream time, each run's latest episode; the leak estimate from the first of
        those that has one. Of the current batch runs' alarms (several recordings, one
        wall-clock time per batch run), the recording's with a leak size, then the earliest
        in its recording, then the first file name (:func:`_shown_alarm`).

        The row also says which run gave the state and how it stands (``run``,
        :func:`_run_words`): "monitor stopped after 57 windows", or for a monitor still marked
        running but silent for :data:`SILENT_S` and 20 of its mean chunk intervals (killed, or
        its input stalled) "monitor running, silent since ...": a dead monitor's last OK is
        told from a live one's (store audit 2026-11-27, finding 8). A ``monitor --segment``
        session's judged segments say "monitor --segment running, last segment judged ..."
        until the session ends (:meth:`end_session`), and "silent since ..." once its latest
        segment is 3 of its segment intervals (at least :data:`SILENT_S`) old.

        Returns
        -------
        pandas.DataFrame
            Columns ``name``, ``system``, ``state``, ``run``, ``last_seen_at``, ``n_runs``,
            ``last_alarm_at``, ``last_alarm_time_s``, ``onset_s``, ``onset_censored``,
            ``leak_lpm``, ``leak_lpm_low``, ``leak_lpm_high``, ``leak_extrapolated`` (the size
            an extrapolation), ``leak_interval`` (what the bracket is, in words),
            ``alarm_source`` (the recording of the alarm shown), ``feature``,
            ``source`` (of the alarm shown
            when the state is ``ALARM``, else of the latest run) and ``error`` (for ``FAILED``,
            ``INCONCLUSIVE``, ``NOT JUDGED`` and ``NO DETECTOR``: the feature and reason of the
            first such run of that invocation).
        """
        import pandas as pd

        self._refresh_version()
        r_, cs = S.runs.c, S.chunk_summaries.c
        act = self._frame(select(S.actuators))
        # whether a run scored a window: a chunk with a score (the run_id/seq index finds a
        # judging monitor's first scored chunk right after its burn-in)
        # ... asked only of monitor runs that had a detector (_judgment's only use of it): on
        # a monitor without one (start_run's config '"detector": false', json.dumps) it walks
        # all its chunks, none scored (a review, 2026-11-27: 20 such runs of 100,000 chunks
        # doubled the page's query time)
        with_detector = and_(r_.command == "monitor", r_.config.isnot(None),
                             ~r_.config.contains('"detector": false'))
        scored = case((with_detector | ((r_.command == "monitor") & r_.config.is_(None)),
                       select(cs.id).where((cs.run_id == r_.id) & cs.score_max.isnot(None))
                       .exists()), else_=False).label("scored")
        runs = self._frame(select(*self._run_columns(), scored))
        # each run's last chunk: its row with seq = n_chunks - 1 (the unique run/seq index)
        last_chunk = self._frame(select(cs.run_id, cs.recorded_at).join(
            S.runs, (r_.id == cs.run_id) & (cs.seq == r_.n_chunks - 1)))
        al = self._frame(select(*self._alarm_columns(), r_.invocation, r_.source)
                         .join(S.runs, r_.id == S.alarms.c.run_id))
        al["raised"] = _utc(al["raised_at"])
        runs["start"] = _utc(runs["started_at"])
        chunk_at = dict(zip(last_chunk["run_id"], _utc(last_chunk["recorded_at"])))
        alarm_at = al.groupby("run_id")["raised"].max().to_dict() if len(al) else {}
        runs["at"] = pd.DataFrame({
            "start": runs["start"], "end": _utc(runs["ended_at"]),
            "chunk": _utc(runs["id"].map(chunk_at)),
            "alarm": _utc(runs["id"].map(alarm_at))}).max(axis=1)
        # the latest sign of life of a running monitor: its last chunk or alarm, else its start
        runs["data_at"] = pd.DataFrame({
            "chunk": _utc(runs["id"].map(chunk_at)), "alarm": _utc(runs["id"].map(alarm_at))}
        ).max(axis=1).astype("datetime64[ns, UTC]").fillna(
            runs["start"].astype("datetime64[ns, UTC]"))
        now = pd.Timestamp(_now())
        alarms_of: dict = {}
        for a in al.to_dict("records"):
            alarms_of.setdefault(a["run_id"], []).append(a)
        invocations: dict = {}  # actuator id -> invocation -> its runs
        sessions: dict = {}  # (actuator id, monitor --segment session id) -> its runs
        for r in runs.sort_values("id").to_dict("records"):
            r.update(_judgment(r, bool(alarms_of.get(r["id"]))))
            invocations.setdefault(r["actuator_id"], {}).setdefault(r["invocation"], []) \
                .append(r)
            r["session"] = _session(r)
            if r["session"] is not None:
                sessions.setdefault((r["actuator_id"], r["session"]["id"]), []).append(r)
        for rs in sessions.values():  # a session's latest segment, and whether it ended
            latest = max(r["at"] for r in rs)
            ended = any(r["session"].get("ended") is True for r in rs)
            for r in rs:
                r["session_at"], r["session_ended"] = latest, ended
        rows = []
        for a in act.itertuples():
            invs = _batch_current(invocations.get(a.id, {}), alarms_of)
            # superseded batch runs (a later batch run judged their recording) take no part
            live = [i for i in invs if not i["superseded"]]
            # an invocation without a detector judged nothing: it gives the state only while
            # the actuator has nothing else (NO DETECTOR), and never clears an alarm
            judging = [i for i in live if i["judging"]] or live
            current = max(judging, key=lambda i: (i["at"], i["last_id"])) if live else None
            ok_start = max([i["start"] for i in live if i["verdict"] == "OK"]
                           + [i["ok_since"] for i in live if i.get("ok_since") is not None],
                           default=None)
            standing = [i for i in live if i["verdict"] == "ALARM"
                        and not (ok_start is not None and ok_start > i["at"])]
            state = "ALARM" if standing else "NO DATA" if current is None else \
                current["verdict"]
            if standing:
                pool = [x for i in standing for x in i["alarms"] if _missing(x["cleared_time_s"])]
            else:
                pool = [x for i in invs for x in i["alarms"]]  # superseded too
            la, size_row = _shown_alarm(pool)
            why, bad = None, []
            if state in ("FAILED", "INCONCLUSIVE", "NOT JUDGED", "NO DETECTOR"):
                # the runs that set the state: a run without a detector takes no part in a
                # verdict, so it gives the reason of NO DETECTOR only (a workflow audit,
                # 2026-11-30: a batch job's analysis entry, "no detector", was shown as the
                # reason of a FAILED actuator whose detectors refused the file's units)
                kinds = {"INCONCLUSIVE": ("inconclusive",),
                         "NO DETECTOR": ("no detector",)}.get(state, ("failed", "unjudged"))
                bad = [r for r in current["runs"] if r["effective"] in kinds
                       and not _missing(r["why"])]
                why = f"{bad[0]['feature']}: {bad[0]['why']}" if bad else None
            shown = None
            if state == "ALARM" and la is not None:
                shown = next(r for i in standing for r in i["runs"] if r["id"] == la["run_id"])
            elif bad:  # the run that set the state, whose reason is shown (an audit,
                # 2026-11-29: "detect finished" beside INCONCLUSIVE, the latest of its runs)
                shown = bad[0]
            elif current is not None:
                shown = max(current["runs"], key=lambda r: (r["at"], r["id"]))

            def g(k, row=None):
                row = la if row is None else row
                return None if row is None or _missing(row[k]) else row[k]

            rows.append({"name": a.name, "system": a.system, "state": state,
                         "run": None if shown is None else _run_words(shown, now),
                         "last_seen_at": a.last_seen_at,
                         "n_runs": sum(len(i["runs"]) for i in invs),
                         "last_alarm_at": g("raised_at"), "last_alarm_time_s": g("alarm_time_s"),
                         "onset_s": g("onset_s"), "onset_censored": g("onset_censored"),
                         "leak_lpm": g("leak_lpm", size_row),
                         "leak_lpm_low": g("leak_lpm_low", size_row),
                         "leak_lpm_high": g("leak_lpm_high", size_row),
                         "leak_extrapolated": g("leak_extrapolated", size_row),
                         "leak_interval": g("leak_interval", size_row),
                         "alarm_source": g("source"),
                         "feature": None if shown is None else shown["feature"],
                         "source": None if shown is None else shown["source"], "error": why})
        cols = ["name", "system", "state", "run", "last_seen_at", "n_runs", "last_alarm_at",
                "last_alarm_time_s", "onset_s", "onset_censored", "leak_lpm", "leak_lpm_low",
                "leak_lpm_high", "leak_extrapolated", "leak_interval", "alarm_source",
                "feature", "source", "error"]
        return pd.DataFrame(rows, columns=cols).sort_values("name", kind="stable") \
            .reset_index(drop=True)

    def history(self, actuator: str):
        """Chunk summaries and alarms of one actuator over all its runs.

        Parameters
        ----------
        actuator : str
            Actuator name.

        Returns
        -------
        summaries : pandas.DataFrame
            One row per chunk (columns of ``chunk_summaries`` plus ``feature`` and ``source``),
            by time of recording.
        alarms : pandas.DataFrame
            One row per alarm (columns of ``alarms`` plus ``feature``, ``source``).

        Raises
        ------
        StoreError
            If the actuator is not in the store.
        """
        self._refresh_version()
        aid = self._known_actuator(actuator)
        extra = (S.runs.c.feature, S.runs.c.source)
        summ = self._frame(select(S.chunk_summaries, *extra)
                           .join(S.runs, S.runs.c.id == S.chunk_summaries.c.run_id)
                           .where(S.runs.c.actuator_id == aid)
                           .order_by(S.chunk_summaries.c.recorded_at, S.chunk_summaries.c.id))
        al = self._frame(select(*self._alarm_columns(), *extra).join(
            S.runs, S.runs.c.id == S.alarms.c.run_id)
                         .where(S.runs.c.actuator_id == aid).order_by(S.alarms.c.id))
        return summ, al

    def _known_actuator(self, actuator: str) -> int:
        """The id of an actuator of the store (:class:`StoreError` for an unknown name)."""
        with self._read_engine.connect() as conn:
            aid = conn.execute(select(S.actuators.c.id)
                               .where(S.actuators.c.name == actuator)).scalar()
        if aid is None:
            raise StoreError(f"{self.shown_url}: no actuator named {actuator!r}")
        return int(aid)

    def runs_of(self, actuator: str):
        """Every run of one actuator, newest first: command, source, feature, status, error.

        Parameters
        ----------
        actuator : str
            Actuator name.

        Returns
        -------
        pandas.DataFrame
            Columns ``id``, ``command``, ``source``, ``feature``, ``started_at``,
            ``ended_at``, ``status``, ``n_chunks``, ``n_windows`` (None for a run judged as a
            whole, whose windows are not stored: ``detect``, a ``monitor --segment`` segment),
            ``threshold``, ``error``.

        Raises
        ------
        StoreError
            If the actuator is not in the store.
        """
        import pandas as pd

        self._refresh_version()
        aid = self._known_actuator(actuator)
        c = S.runs.c
        cols = {col.name: col for col in self._run_columns()}
        runs = self._frame(select(*(cols[k] for k in (
            "id", "command", "source", "feature", "started_at", "ended_at", "status",
            "n_chunks", "n_windows", "threshold", "error", "config")))
                           .where(c.actuator_id == aid).order_by(c.id.desc()))
        # a run judged as a whole without its windows stored (detect's methods, a monitor
        # --segment segment) has no window count: None, not 0 (as the fleet page says it)
        whole = [int(n) == 0 and (cmd == "detect" or _is_segment(cmd, _config(cfg)))
                 for cmd, n, cfg in zip(runs["command"], runs["n_chunks"], runs["config"])]
        runs["n_windows"] = runs["n_windows"].astype(object).where(
            ~pd.Series(whole, index=runs.index, dtype=bool), None)
        return runs.drop(columns="config")

    def _refresh_version(self) -> None:
        """Read the file's schema version again when it is older than this code's: another
        process (a writer) may have upgraded it in place since this store was opened, and
        its new columns (``runs.error``, ``alarms.onset_censored``) are read from then on.
        One single-row query per page while the file is old, none once it is current."""
        if self.version >= S.SCHEMA_VERSION:
            return
        with self._read_engine.connect() as conn:
            rows = conn.execute(select(S.schema_version.c.version)).scalars().all()
        if len(rows) == 1 and rows[0] > self.version:
            self.version = min(int(rows[0]), S.SCHEMA_VERSION)

    def _alarm_columns(self) -> list:
        """The columns of ``alarms`` this file has (an older file read as it is: the columns
        added since, ``onset_censored`` (3), ``leak_extrapolated`` and ``leak_interval`` (5),
        read as unknown)."""
        from sqlalchemy import null

        missing = {"leak_extrapolated", "leak_interval"} if self.version < 5 else set()
        if self.version < 3:
            missing.add("onset_censored")
        return [c for c in S.alarms.c if c.name not in missing] + \
            [null().label(name) for name in sorted(missing)]

    def _run_columns(self) -> list:
        """The columns of ``runs`` this file has (a version-1 file read as it is: no error)."""
        from sqlalchemy import null

        if self.version >= 2:
            return list(S.runs.c)
        return [c for c in S.runs.c if c.name != "error"] + [null().label("error")]

    def count(self, table: str) -> int:
        """Rows in one of the store's tables.

        Parameters
        ----------
        table : str
            Table name (``actuators``, ``runs``, ``chunk_summaries``, ``alarms``).

        Returns
        -------
        int

        Raises
        ------
        ValueError
            For an unknown table.
        """
        t = S.metadata.tables.get(table)
        if t is None:
            raise ValueError(f"table={table!r} must be one of {sorted(S.metadata.tables)}")
        with self._read_engine.connect() as conn:
            return int(conn.execute(select(func.count()).select_from(t)).scalar())


def _row_key(config: str | None) -> str | None:
    """The batch result row a stored run came from (``config["row"]``), None for other runs.

    Examples
    --------
    >>> _row_key('{"row": "job|a.parquet|sha|detector|det"}'), _row_key(None), _row_key("[1]")
    ('job|a.parquet|sha|detector|det', None, None)
    """
    try:
        row = json.loads(config).get("row") if config else None
    except (ValueError, AttributeError):
        row = None
    return str(row) if row else None


def _utc(values):
    """Wall-clock times as UTC pandas timestamps (SQLite returns them naive, PostgreSQL aware;
    both are UTC in the store); None becomes NaT."""
    import pandas as pd

    return pd.to_datetime(pd.Series(values, dtype=object), utc=True)


def _missing(v) -> bool:
    """A cell read from the store that holds nothing (None, NaN, NaT)."""
    import pandas as pd

    return v is None or bool(pd.isna(v))


#: Why a run without a detector judged nothing (the fleet page's "Why not judged").
NO_DETECTOR_WHY = {
    "monitor": "no detector: monitor without --detector computes the feature only, nothing "
               "was judged",
    "batch": "no detector: a batch analysis entry computes the feature only, nothing was "
             "judged"}
#: Why a monitor run with a detector that scored no window judged nothing.
NOT_SCORED_WHY = ("no window was scored: every window lay in the detector's burn-in (the "
                  "stream was shorter than the burn-in and one window), nothing was judged")


def _config(text) -> dict:
    """A run's stored ``config`` JSON as a dict ({} for none or a bad one)."""
    try:
        c = json.loads(text) if isinstance(text, str) and text else {}
    except ValueError:
        return {}
    return c if isinstance(c, dict) else {}


#: Seconds without a chunk after which a running monitor is said to be silent on the fleet
#: page (also at least 20 of its own mean chunk intervals; leakdiag choice: a live monitor at
#: 1 kHz in 1,000-sample chunks sends one a second).
SILENT_S = 60.0


def _is_segment(cmd: str, cfg: dict) -> bool:
    """Whether a stored run is a segment of ``monitor --segment``: stored as ``detect`` stores
    a verdict (:func:`leakdiag.store.writers.record_verdicts`: config ``{"method": ...}``, no
    chunks, no window settings), not a streamed monitor's run.

    Examples
    --------
    >>> _is_segment("monitor", {"method": "flow-balance"})
    True
    >>> _is_segment("monitor", {"method": "autocorrelation", "window": 200, "detector": True})
    False
    """
    return cmd == "monitor" and "method" in cfg and "window" not in cfg


def _session(run: dict) -> dict | None:
    """The ``monitor --segment`` session of a stored run (``config["session"]`` with an id),
    None for any other run (and for segments stored before sessions were).

    Examples
    --------
    >>> import json
    >>> cfg = {"method": "flow-balance", "session": {"id": "ab12", "ended": False}}
    >>> _session({"command": "monitor", "config": json.dumps(cfg)})["id"]
    'ab12'
    >>> _session({"command": "detect", "config": json.dumps(cfg)}) is None
    True
    """
    text = run.get("config")
    if str(run.get("command")) != "monitor" or not isinstance(text, str) or \
            '"session"' not in text:  # (the fleet asks it of every run: no JSON parse for most)
        return None
    cmd, cfg = "monitor", _config(text)
    ses = cfg.get("session")
    if not _is_segment(cmd, cfg) or not isinstance(ses, dict) or \
            not isinstance(ses.get("id"), str):
        return None
    return ses


def _run_words(run: dict, now) -> str:
    """How the run that gave an actuator's state stands, in words (:meth:`EventStore.fleet`).

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.Timestamp("2026-11-27 09:00:00", tz="UTC")
    >>> _run_words({"command": "monitor", "status": "stopped", "n_windows": 57,
    ...             "start": t, "at": t, "n_chunks": 3}, t)
    'monitor stopped after 57 windows'
    >>> _run_words({"command": "monitor", "status": "running", "n_windows": 78,
    ...             "start": t, "at": t + pd.Timedelta(seconds=10), "n_chunks": 10},
    ...            t + pd.Timedelta(minutes=5))
    'monitor running, silent since 2026-11-27 09:00:10 UTC (78 windows)'
    >>> _run_words({"command": "detect", "status": "finished", "n_windows": None,
    ...             "start": t, "at": t, "n_chunks": 0}, t)
    'detect finished'
    >>> seg = {"command": "monitor", "status": "finished", "at": t, "config": json.dumps(
    ...     {"method": "flow-balance", "session": {"id": "a1", "interval_s": 60.0,
    ...                                            "ended": False}})}
    >>> _run_words(seg, t + pd.Timedelta(minutes=2))   # 3 intervals: 3 minutes
    'monitor --segment running, last segment judged 2026-11-27 09:00:00 UTC'
    >>> _run_words({**seg, "session_at": t + pd.Timedelta(minutes=1)},
    ...            t + pd.Timedelta(minutes=5))   # the session's latest segment counts
    'monitor --segment running, silent since 2026-11-27 09:01:00 UTC'
    >>> _run_words({**seg, "session_ended": True}, t + pd.Timedelta(hours=1))
    'monitor finished'
    """
    cmd, status = str(run["command"]), str(run["status"])
    n = run.get("n_windows")
    n = None if _missing(n) else int(n)
    ses = run["session"] if "session" in run else _session(run)  # (the fleet's, or parsed)
    if ses is not None and not run.get("session_ended", ses.get("ended") is True):
        # a monitor --segment session that has not ended: its latest segment tells whether
        # it still sends them (a segment session killed with kill -9 read "monitor finished")
        at = run.get("session_at", run.get("at"))
        when = at.strftime("%Y-%m-%d %H:%M:%S")
        interval = ses.get("interval_s")
        interval = float(interval) if isinstance(interval, (int, float)) and \
            math.isfinite(interval) and interval > 0 else 0.0
        if (now - at).total_seconds() > max(SILENT_S, 3.0 * interval):
            return f"monitor --segment running, silent since {when} UTC"
        return f"monitor --segment running, last segment judged {when} UTC"
    if cmd != "monitor" or _is_segment(cmd, _config(run.get("config"))):
        return f"{cmd} {status}"  # (a segment's windows are not stored: no "0 windows")
    if status == "running":
        at, start = run.get("data_at", run.get("at")), run.get("start")
        chunks = int(run.get("n_chunks") or 0)
        if at is not None and not _missing(at) and start is not None and not _missing(start):
            interval = max((at - start).total_seconds(), 0.0) / max(chunks, 1)
            silent = (now - at).total_seconds()
            if silent > max(SILENT_S, 20.0 * interval):
                return (f"monitor running, silent since {at.strftime('%Y-%m-%d %H:%M:%S')} UTC"
                        + (f" ({n} windows)" if n is not None else ""))
        return "monitor running" + (f", {n} windows" if n is not None else "")
    if status == "stopped":
        return "monitor stopped" + (f" after {n} windows" if n is not None else "")
    return f"monitor {status}" + (f", {n} windows" if n is not None else "")


def _judgment(run: dict, has_alarm: bool) -> dict:
    """Whether a stored run judged the actuator, as :meth:`EventStore.fleet` counts it.

    Returns ``effective``: the run's status, ``no detector`` for a run that could not judge
    (``monitor`` without a detector: ``config["detector"]`` false, or for runs stored before
    that key no ``threshold``; a ``batch`` analysis row), ``unjudged`` for a streamed monitor
    with a
    detector that ended (finished, or stopped after a chunk) without scoring a window,
    ``waiting`` for one still running in its burn-in; and ``why``: the stored error or the
    reason for these. A run with an alarm judged, whatever else it says; a failed run is
    ``failed`` with or without a detector (its input could not be read: worth showing).

    Examples
    --------
    >>> _judgment({"command": "monitor", "status": "finished", "threshold": None,
    ...            "config": None, "error": None, "scored": 0, "n_chunks": 2},
    ...           False)["effective"]
    'no detector'
    >>> _judgment({"command": "monitor", "status": "finished", "threshold": 3.0,
    ...            "config": None, "error": None, "scored": 0, "n_chunks": 2},
    ...           False)["effective"]
    'unjudged'
    >>> _judgment({"command": "monitor", "status": "finished", "threshold": 4.1,
    ...            "config": '{"method": "flow-balance"}', "error": None, "scored": 0},
    ...           False)["effective"]  # a monitor --segment verdict
    'finished'
    >>> _judgment({"command": "batch", "status": "finished", "threshold": None,
    ...            "config": '{"kind": "detector"}', "error": None, "scored": 1},
    ...           False)["effective"]
    'finished'
    """
    status, why = run["status"], None if _missing(run.get("error")) else run.get("error")
    if has_alarm or status == "failed":  # an alarm judged; a failure is shown whatever ran
        return {"effective": status, "why": why}
    cmd, cfg = run["command"], _config(run.get("config"))
    # a segment of monitor --segment is stored as detect stores a verdict (writers.
    # record_verdicts: config {"method": ...}, no chunks, no window settings) and judged as
    # one: a review (2026-11-29) found a NO LEAK segment shown NOT JUDGED, "no window was
    # scored", and a segment that could not judge shown NO DETECTOR
    if cmd == "monitor" and not _is_segment(cmd, cfg):
        detector = bool(cfg["detector"]) if "detector" in cfg else \
            not _missing(run.get("threshold"))
        if not detector:
            return {"effective": "no detector", "why": why or NO_DETECTOR_WHY["monitor"]}
        if not bool(run.get("scored")) and status in ("finished", "stopped", "running"):
            if status == "running":
                return {"effective": "waiting", "why": why}
            if status == "stopped" and not int(run.get("n_chunks") or 0):
                return {"effective": status, "why": why}  # stopped before its first window
            return {"effective": "unjudged", "why": why or NOT_SCORED_WHY}
    elif cmd == "batch" and cfg.get("kind") == "analysis":
        return {"effective": "no detector", "why": why or NO_DETECTOR_WHY["batch"]}
    return {"effective": status, "why": why}


def _invocation(runs: list[dict], alarms: list[dict]) -> dict:
    """One invocation's runs and alarms, its start, activity and verdict (:meth:`fleet`).

    Runs without a detector (:func:`_judgment`) do not take part in the verdict; an
    invocation of such runs only is ``NO DETECTOR``. An alarm stands until its
    ``cleared_time_s``: a monitor writes it when the episode ends, its CUSUM excursion back at
    0 (:class:`leakdiag.dashboard.recorder.ChunkRecorder`), not when the score dips under the
    threshold, so a run that ends or is killed inside an episode stands in alarm, as
    ``leakdiag detect`` judges the recording (session 26 audit: such a dip was stored as a
    clearing and shown OK; alarm rows a monitor wrote before schema version 5 may still hold
    a dip's time, which cannot be told from an end).
    """
    tally = _tally(runs, alarms)
    verdict = _tally_verdict(tally)
    return {"runs": runs, "alarms": alarms, "start": min(r["start"] for r in runs),
            "at": max(r["at"] for r in runs), "last_id": max(int(r["id"]) for r in runs),
            "verdict": verdict, "judging": bool(tally["judging"] or alarms)}


def _tally(runs: list[dict], alarms: list[dict]) -> Counter:
    """The counts of runs and alarms that :func:`_tally_verdict` judges an invocation by.

    Counts add over disjoint sets of runs (with their alarms), so that a sequence of
    invocations can be judged with each run counted once (:func:`_batch_ok_since`).
    """
    c: Counter = Counter()
    for a in alarms:
        c["alarms"] += 1
        c["standing"] += _missing(a["cleared_time_s"])
    for r in runs:
        st = r["effective"]
        c["chunks"] += int(r["n_chunks"])
        c["not_running"] += r["status"] not in ("running", "stopped")
        if st == "no detector":
            continue
        c["judging"] += 1
        c["judged_chunks"] += int(r["n_chunks"]) if st != "waiting" else 0
        c["started"] += st not in ("running", "stopped", "waiting")
        c["failed"] += st == "failed"
        c["inconclusive"] += st == "inconclusive"
        c["unjudged"] += st in ("failed", "unjudged")
    return c


def _tally_verdict(c: Counter) -> str:
    """An invocation's verdict from its :func:`_tally` (:func:`_invocation`)."""
    if c["standing"]:
        return "ALARM"
    if not c["judging"]:  # features only: nothing was judged (NO DATA before its first chunk)
        return "NO DATA" if c["chunks"] == 0 and c["not_running"] == 0 else "NO DETECTOR"
    if c["judged_chunks"] == 0 and not c["alarms"] and c["started"] == 0:
        return "NO DATA"  # (a monitor stopped before its first window judged nothing)
    if c["failed"] == c["judging"]:
        return "FAILED"  # nothing of it could be read or judged
    if c["inconclusive"]:
        return "INCONCLUSIVE"  # an alarm that is no evidence: neither an ALARM nor an OK
    if c["unjudged"]:
        return "NOT JUDGED"  # no alarm, but a run of it was not judged: not an OK
    return "OK"


def _group(x: dict):
    """The alarms :func:`_shown_alarm` chooses among together: those of one invocation on one
    recording, or for ``batch`` those of its group (:func:`_batch_current`: every recording's
    current runs, or one superseded invocation), every recording."""
    return x["group"] if "group" in x else (x["invocation"], x["source"])


def _stream_time(x: dict) -> float:
    """An alarm's stream time, a missing one last."""
    return math.inf if _missing(x["alarm_time_s"]) else float(x["alarm_time_s"])


def _shown_alarm(pool: list[dict]):
    """The alarm a fleet row shows and the one whose leak estimate it shows (:meth:`fleet`).

    The newest of ``pool`` by wall clock (then by id: the order the runs were written in)
    gives the group (:func:`_group`). Of each recording's alarms in that group (each run's
    latest episode), the first in stream time, and the first of those with a leak size. Of
    several recordings (a batch job's folder, whose runs share one wall-clock time), the one
    with a leak size, then the earliest alarm in its recording, then the first file name: not
    the last row written (a session-26 audit: a feature detector's alarm without size on
    ``rec049`` was shown instead of the flow balance's leak with size on ``rec012``).

    Examples
    --------
    >>> t = 0
    >>> a = [{"id": 1, "run_id": 1, "raised": t, "group": "b", "source": "rec012",
    ...       "alarm_time_s": 40.0, "leak_lpm": 0.2},
    ...      {"id": 2, "run_id": 2, "raised": t, "group": "b", "source": "rec049",
    ...       "alarm_time_s": 5.0, "leak_lpm": None}]
    >>> [x["source"] for x in _shown_alarm(a)]
    ['rec012', 'rec012']
    """
    if not pool:
        return None, None
    newest = max(pool, key=lambda x: (x["raised"], x["id"]))
    latest: dict = {}  # run -> its latest episode
    for x in pool:
        if _group(x) == _group(newest):
            if x["run_id"] not in latest or x["id"] > latest[x["run_id"]]["id"]:
                latest[x["run_id"]] = x
    per_source: dict = {}
    for x in latest.values():
        per_source.setdefault(str(x["source"]), []).append(x)
    picks = []
    for xs in per_source.values():
        group = sorted(xs, key=lambda x: (_stream_time(x), x["id"]))
        sized = [x for x in group if not _missing(x["leak_lpm"])]
        picks.append((group[0], sized[0] if sized else group[0]))
    return min(picks, key=lambda p: (_missing(p[1]["leak_lpm"]), _stream_time(p[0]),
                                     str(p[0]["source"])))


def _batch_current(invocations: dict, alarms_of: dict) -> list[dict]:
    """One actuator's invocations as :meth:`EventStore.fleet` judges them (:func:`_invocation`),
    ``batch`` runs regrouped by recording.

    A batch invocation stores only the result rows the store lacks, so a re-run after a file
    was added or edited holds that file's runs alone: judged by itself it read as an ``OK`` of
    the actuator and cleared a leaking file's standing alarm (a session-26 audit). So every
    recording's *current* batch runs (those of the latest batch invocation that judged it,
    by run id) are judged together, as one invocation: its verdict follows every recording's
    current verdict, its activity is theirs, its start that of the latest such invocation (as
    if the whole folder had been judged then). The superseded runs stay, marked
    ``superseded``, for the alarm shown of an actuator not in alarm only.

    Parameters
    ----------
    invocations : dict
        Invocation id to its runs (dicts with ``command``, ``source``, ``invocation``,
        ``id``, ``start``, ``at``, ``effective``...).
    alarms_of : dict
        Run id to its alarms (dicts; given a ``group`` here, :func:`_group`).

    Returns
    -------
    list of dict
        :func:`_invocation` of each, with ``superseded``.
    """
    latest: dict = {}  # recording -> invocation of its latest batch run
    for inv, rs in invocations.items():
        for r in rs:
            if r["command"] == "batch":
                src = str(r["source"])
                if src not in latest or r["id"] > latest[src][1]:
                    latest[src] = (inv, r["id"])
    out, current, starts, batch = [], [], [], []
    for inv, rs in invocations.items():
        if not any(r["command"] == "batch" for r in rs):
            out.append({**_invocation(rs, [x for r in rs for x in alarms_of.get(r["id"], [])]),
                        "superseded": False})
            continue
        batch.append(rs)
        mine = [r for r in rs if latest[str(r["source"])][0] == inv]
        old = [r for r in rs if latest[str(r["source"])][0] != inv]
        if mine:
            current += mine
            starts.append(min(r["start"] for r in rs))
        if old:
            for r in old:
                for x in alarms_of.get(r["id"], []):
                    x["group"] = ("batch", inv)
            out.append({**_invocation(old, [x for r in old for x in alarms_of.get(r["id"], [])]),
                        "superseded": True})
    if current:
        current.sort(key=lambda r: r["id"])
        for r in current:
            for x in alarms_of.get(r["id"], []):
                x["group"] = ("batch",)
        merged = _invocation(current, [x for r in current for x in alarms_of.get(r["id"], [])])
        out.append({**merged, "start": max(starts), "superseded": False,
                    "ok_since": _batch_ok_since(batch, alarms_of) if any(
                        i["verdict"] == "ALARM" for i in out if not i["superseded"]) else None})
    return out


def _batch_ok_since(batch: list[list[dict]], alarms_of: dict):
    """The start of the latest batch invocation after which every recording's current verdict
    was OK (:func:`_batch_current`), or None: an OK of the whole folder then, which cleared an
    alarm of another command active before it, as a batch of the whole folder at that time
    would have (a later failed re-run of one file does not undo that)."""
    cur: dict = {}  # recording -> the tally of its runs as of the invocation
    total: Counter = Counter()  # the sum of cur's tallies, kept as recordings are re-judged
    since = None
    for rs in sorted(batch, key=lambda rs: min(r["id"] for r in rs)):
        mine: dict = {}
        for r in rs:
            mine.setdefault(str(r["source"]), []).append(r)
        for src, runs in mine.items():
            if src in cur:
                total.subtract(cur[src])
            cur[src] = _tally(runs, [x for r in runs for x in alarms_of.get(r["id"], [])])
            total.update(cur[src])
        if _tally_verdict(total) == "OK":
            since = min(r["start"] for r in rs)
    return since


_SUMMARY_FIELDS = tuple(f.name for f in fields(ChunkSummary))
_SUMMARY_COLUMNS = ("run_id", "seq", "recorded_at", *_SUMMARY_FIELDS)
_COMPILED: dict = {}  # dialect name -> compiled INSERT of chunk_summaries


def _insert_summaries(conn, run_id: int, seq0: int, now: datetime,
                      summaries: list[ChunkSummary], times: list | None = None) -> None:
    """One ``executemany`` of the summary rows, past SQLAlchemy's per-row parameter handling.

    The statement is compiled by SQLAlchemy for the connection's dialect (its paramstyle and
    quoting); the bind processors of the columns that have one (the timestamp, the boolean)
    are applied column by column. SQLAlchemy's own ``execute(insert(t), rows)`` spends about
    20 us per row in Python, as long as the monitor's work on a 1,000-sample chunk.
    """
    dialect = conn.dialect
    comp = _COMPILED.get(dialect.name)
    if comp is None or comp.dialect is not dialect:
        comp = _COMPILED[dialect.name] = insert(S.chunk_summaries).compile(
            dialect=dialect, column_keys=list(_SUMMARY_COLUMNS))
    n = len(summaries)
    cols = {"run_id": [run_id] * n, "seq": list(range(seq0, seq0 + n)),
            "recorded_at": [now] * n if times is None else list(times)}
    for f in _SUMMARY_FIELDS:
        cols[f] = [getattr(sm, f) for sm in summaries]
    for c in _SUMMARY_COLUMNS:
        proc = S.chunk_summaries.c[c].type._cached_bind_processor(dialect)
        if proc is not None:
            if c == "recorded_at" and times is None:  # the same value in every row
                cols[c] = [proc(now)] * n
            else:
                cols[c] = [None if v is None else proc(v) for v in cols[c]]
    if comp.positional:
        order = [comp.binds[name].key for name in comp.positiontup]
        rows = list(zip(*(cols[k] for k in order)))
        if dialect.name == "sqlite":  # a few multi-row statements, not one step per row
            _insert_multirow(conn, order, rows)
            return
    else:
        names = [(name, comp.binds[name].key) for name in comp.binds]
        rows = [dict(zip([nm for nm, _ in names], r))
                for r in zip(*(cols[k] for _, k in names))]
    conn.exec_driver_sql(comp.string, rows)


#: Rows per multi-row INSERT on SQLite: 64 x 14 columns stays under the 999 bound variables of
#: SQLite builds before 3.32 (SQLITE_MAX_VARIABLE_NUMBER).
SQLITE_ROWS_PER_INSERT = 64


def _insert_multirow(conn, order: list[str], rows: list[tuple]) -> None:
    """``INSERT ... VALUES (...), (...), ...`` in blocks of :data:`SQLITE_ROWS_PER_INSERT`.

    The sqlite3 module releases the GIL around every step of a statement; an ``executemany``
    of 360 rows is 360 steps, and each one hands the GIL back and forth with the monitor's
    thread. One statement per 64 rows makes that 6.
    """
    prep = conn.dialect.identifier_preparer
    head = (f"INSERT INTO {prep.format_table(S.chunk_summaries)} "
            f"({', '.join(prep.quote(c) for c in order)}) VALUES ")
    one = "(" + ", ".join("?" * len(order)) + ")"
    for i in range(0, len(rows), SQLITE_ROWS_PER_INSERT):
        block = rows[i:i + SQLITE_ROWS_PER_INSERT]
        conn.exec_driver_sql(head + ", ".join([one] * len(block)),
                             tuple(v for r in block for v in r))


def _sqlite_connect(dbapi_conn, _record) -> None:
    dbapi_conn.isolation_level = None  # transactions are begun by _sqlite_begin
    cur = dbapi_conn.cursor()
    cur.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
    cur.execute("PRAGMA journal_mode = WAL")
    cur.execute("PRAGMA synchronous = FULL")
    cur.execute("PRAGMA foreign_keys = ON")
    cur.close()


def _sqlite_connect_read(dbapi_conn, _record) -> None:
    """A reader's connection: the busy timeout, no pragma that writes (journal mode)."""
    dbapi_conn.isolation_level = None
    cur = dbapi_conn.cursor()
    cur.execute(f"PRAGMA busy_timeout = {int(BUSY_TIMEOUT_S * 1000)}")
    cur.close()


def _pg_connect(dbapi_conn, _record) -> None:
    """Every PostgreSQL session in UTC: ``timestamptz`` values come back in UTC whatever the
    server's ``TimeZone`` (a German host's cluster: Europe/Berlin)."""
    autocommit = dbapi_conn.autocommit
    dbapi_conn.autocommit = True
    try:
        cur = dbapi_conn.cursor()
        cur.execute("SET TIME ZONE 'UTC'")
        cur.close()
    finally:
        dbapi_conn.autocommit = autocommit


def _sqlite_begin(conn) -> None:
    conn.exec_driver_sql("BEGIN IMMEDIATE")


def _sqlite_begin_read(conn) -> None:
    conn.exec_driver_sql("BEGIN")
