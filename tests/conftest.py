"""Shared test fixtures: the location of the team's shared folder (thesis, real data), and the
CLI run through its entry point."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


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
