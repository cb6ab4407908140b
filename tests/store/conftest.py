"""A real PostgreSQL for the store tests: ``LEAKDIAG_TEST_PG_URL``, or a throwaway cluster.

With ``LEAKDIAG_TEST_PG_URL`` (an SQLAlchemy URL of a database the tests may create databases
with) that server is used. Otherwise, when PostgreSQL's ``initdb`` and ``pg_ctl`` are installed
(Debian: ``apt-get install postgresql``; ``.ci/run`` does it), a cluster is created in a
temporary folder, listening on a Unix socket only, and removed after the tests. Without either
(or without the ``psycopg`` driver) the PostgreSQL tests are skipped, and one line at the end of
the pytest run says why.
"""

import glob
import os
import shutil
import subprocess
import tempfile
import uuid

import pytest

import _skip_lines

PG_ENV = "LEAKDIAG_TEST_PG_URL"
_WHY: list[str] = []


def _pg_bindir() -> str | None:
    for d in sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True):
        if os.path.exists(os.path.join(d, "initdb")) and os.path.exists(os.path.join(d, "pg_ctl")):
            return d
    initdb = shutil.which("initdb")
    return os.path.dirname(initdb) if initdb and shutil.which("pg_ctl") else None


def _as_user(cmd: list[str]) -> list[str]:
    """PostgreSQL refuses to run as root: run its commands as the 'postgres' user then."""
    if os.geteuid() != 0:
        return cmd
    return ["runuser", "-u", "postgres", "--", *cmd]


def _skip(why: str):
    if not _WHY:  # said once at the end of the run (tests/conftest.py)
        _skip_lines.add(f"tests/store: PostgreSQL tests skipped: {why}")
    _WHY.append(why)
    pytest.skip(why)


@pytest.fixture(scope="session")
def pg_server():
    """SQLAlchemy URL of a PostgreSQL server (a database in which databases can be created)."""
    try:
        import psycopg  # noqa: F401
    except ImportError:
        _skip("the psycopg driver is not installed (pip install -e '.[dev]')")
    url = os.environ.get(PG_ENV)
    if url:
        yield url
        return
    bindir = _pg_bindir()
    if bindir is None:
        _skip(f"no PostgreSQL server: set {PG_ENV} or install initdb/pg_ctl "
              "(Debian: apt-get install postgresql; .ci/run does it)")
    if os.geteuid() == 0 and shutil.which("runuser") is None:
        _skip("running as root without runuser: PostgreSQL cannot be started")
    root = tempfile.mkdtemp(prefix="leakdiag-pg-")
    data = os.path.join(root, "data")
    if os.geteuid() == 0:
        import pwd

        pw = pwd.getpwnam("postgres")
        os.chown(root, pw.pw_uid, pw.pw_gid)
    try:
        subprocess.run(_as_user([os.path.join(bindir, "initdb"), "-D", data, "-U", "postgres",
                                 "-A", "trust", "-E", "UTF8", "--no-sync"]),
                       check=True, capture_output=True, text=True, timeout=120)
        opts = f"-c listen_addresses='' -c unix_socket_directories={root} -c fsync=off"
        subprocess.run(_as_user([os.path.join(bindir, "pg_ctl"), "-D", data, "-w", "-t", "60",
                                 "-l", os.path.join(root, "log"), "-o", opts, "start"]),
                       check=True, capture_output=True, text=True, timeout=120)
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired, KeyError) as exc:
        shutil.rmtree(root, ignore_errors=True)
        out = getattr(exc, "stderr", "") or ""
        _skip(f"could not start a throwaway PostgreSQL cluster: {exc} {out.strip()[-300:]}")
    try:
        yield f"postgresql+psycopg://postgres@/postgres?host={root}"
    finally:
        subprocess.run(_as_user([os.path.join(bindir, "pg_ctl"), "-D", data, "-m", "immediate",
                                 "stop"]), capture_output=True, timeout=60)
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def pg_url(pg_server):
    """A new, empty database on the PostgreSQL server (dropped after the test)."""
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    name = "leakdiag_test_" + uuid.uuid4().hex[:12]
    admin = create_engine(pg_server, isolation_level="AUTOCOMMIT")
    with admin.connect() as c:
        c.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        yield make_url(pg_server).set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as c:
            c.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()
