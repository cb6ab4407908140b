"""Shared test fixtures: the location of the team's shared folder (thesis, real data), and the
CLI run through its entry point."""

from pathlib import Path

import pytest

import _skip_lines

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
_WORKER_KEY = "leakdiag_skip_lines"


def pytest_sessionfinish(session):
    """In a pytest-xdist worker, hand this process's skip lines to the controlling process."""
    out = getattr(session.config, "workeroutput", None)
    if out is not None:
        out[_WORKER_KEY] = list(_skip_lines.LINES)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """pytest-xdist, in the controlling process: a worker's skip lines."""
    for line in getattr(node, "workeroutput", {}).get(_WORKER_KEY, ()):
        _skip_lines.add(line)


def pytest_terminal_summary(terminalreporter):
    """Why a group of tests was skipped, one line each (no browser, no PostgreSQL)."""
    for line in _skip_lines.LINES:
        terminalreporter.write_line(line)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """``<repo>/../shared`` (thesis tables, real recordings); skip if absent."""
    if not SHARED.is_dir():
        pytest.skip(f"shared folder not found at {SHARED}")
    return SHARED


def _run_cli(args, stdin=None):
    """Exit code, stdout and stderr of ``leakdiag ARGS`` through the entry point (``stdin``:
    text on standard input)."""
    from click.testing import CliRunner

    from leakdiag.cli.main import main

    with CliRunner().isolation(input=stdin) as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


@pytest.fixture(scope="session")
def run_cli():
    """``run_cli(args, stdin=None) -> (code, stdout, stderr)`` of ``leakdiag ARGS``."""
    return _run_cli
