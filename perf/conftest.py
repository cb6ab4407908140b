"""The ratio table of ``make bench``: a ``record_ratio`` fixture and the end-of-session summary.

Any benchmark can call ``record_ratio(name, fast_seconds, reference_seconds, extra="...",
n_samples=..., goal_ratio=..., goal_samples_per_s=..., fast_median_seconds=...)``;
``best_time`` (fixture, or import from ``perf.harness``) times a callable. All records are
printed in one table at the end.
"""

from __future__ import annotations

import pytest

from perf.harness import RatioRecord, best_time, format_table

_RECORDS = pytest.StashKey[list]()


def pytest_configure(config):
    config.stash[_RECORDS] = []


@pytest.fixture
def record_ratio(request):
    """Record one fast-vs-reference case for the end-of-session table; returns the record."""
    records = request.config.stash[_RECORDS]

    def _record(name, fast_seconds, reference_seconds, extra="", n_samples=None,
                goal_ratio=None, goal_samples_per_s=None, fast_median_seconds=None):
        median = None if fast_median_seconds is None else float(fast_median_seconds)
        rec = RatioRecord(name, float(fast_seconds), float(reference_seconds), n_samples, extra,
                          goal_ratio, goal_samples_per_s, median)
        records.append(rec)
        return rec

    return _record


@pytest.fixture(name="best_time")
def best_time_fixture():
    """:func:`perf.harness.best_time`."""
    return best_time


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    records = config.stash.get(_RECORDS, [])
    if not records:
        return
    terminalreporter.section("fast vs reference ratios")
    for line in format_table(records):
        terminalreporter.write_line(line)
