"""Lines said once at the end of a pytest run: why a group of tests was skipped (no browser, no
PostgreSQL). ``make test`` runs the suite in two processes (pytest-xdist): a worker's lines
reach the controlling process, which prints them (``tests/conftest.py``)."""

#: The lines of this process, in the order they were added.
LINES: list[str] = []


def add(line: str) -> None:
    """Say ``line`` at the end of the run (once, however often it is added)."""
    if line not in LINES:
        LINES.append(line)
