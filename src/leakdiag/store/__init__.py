"""Event store: actuators, runs, alarms and per-chunk feature summaries in a SQL database.

An SQLite file by default (``--store events.db``), any SQLAlchemy URL otherwise (e.g.
PostgreSQL). ``leakdiag monitor``, ``batch`` and ``detect`` write to it with ``--store``;
``leakdiag dashboard --store`` shows it. See ``docs/operations.md``.
"""

from leakdiag.store.schema import SCHEMA_VERSION
from leakdiag.store.summary import (AlarmRecord, ChunkSummary, FinishedRun, merge_blocks,
                                   merge_summaries, summarize_chunks, summarize_windows)
from leakdiag.store.database import EventStore, StoreError, store_url

__all__ = ["SCHEMA_VERSION", "EventStore", "StoreError", "store_url", "ChunkSummary",
           "AlarmRecord", "FinishedRun", "summarize_windows", "summarize_chunks", "merge_summaries",
           "merge_blocks"]
