"""Shared by the CLI tests: ``leakdiag ARGS`` through the entry point."""

import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main


def _run(args, stdin=None):
    """Exit code, stdout and stderr of ``leakdiag ARGS`` (``stdin``: text on standard input)."""
    with CliRunner().isolation(input=stdin) as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


@pytest.fixture(scope="session")
def run_cli():
    """:func:`_run`: ``run_cli(args, stdin=None) -> (code, stdout, stderr)``."""
    return _run
