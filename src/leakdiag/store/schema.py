"""Tables of the event store (SQLAlchemy Core) and its schema version.

Five tables: ``schema_version`` (one row), ``actuators`` (one per monitored actuator, by name),
``runs`` (one per ``monitor``/``batch``/``detect`` pass over one input), ``chunk_summaries``
(one per chunk of the stream that completed at least one window: the feature and detector score
summarised over that chunk) and ``alarms`` (raised, and cleared when the detector clears them).
Times in the stream are seconds (``*_s``); wall-clock times are UTC (``*_at``).
"""

from __future__ import annotations

from sqlalchemy import (Boolean, Column, DateTime, Float, ForeignKey, Index, Integer, MetaData,
                        String, Table, Text)

__all__ = ["SCHEMA_VERSION", "UPGRADES", "UPGRADE_NOTES", "metadata", "schema_version", "actuators", "runs",
           "chunk_summaries", "alarms"]

#: Version of the table layout below. 1: the first layout; 2: ``runs.error``, the reason a run
#: failed or was not judged; 3: ``alarms.onset_censored``, the onset is the first window judged
#: (the leak was there from the start, the onset is an upper bound); 4: the run status
#: ``inconclusive`` (the detector alarmed, but the alarm is no evidence of a leak: refused by
#: the detector or expected by chance in a run this long; stored ``unjudged`` before), no new
#: column, but a leakdiag reading version 3 would show such a run OK; 5:
#: ``alarms.leak_extrapolated`` (the feature shift lies outside the calibrated range: the
#: size is an extrapolation) and ``alarms.leak_interval`` (what the bracket of the size is, in
#: the detector's words: "90 % prediction interval", the flow balance's interval). An older
#: store is upgraded in place when a writer opens it (added columns, :data:`UPGRADES`); a store
#: of any other version is refused.
SCHEMA_VERSION = 5

#: The statements that take a store from version ``v`` to ``v + 1``.
UPGRADES = {1: ("ALTER TABLE runs ADD COLUMN error TEXT",),
            2: ("ALTER TABLE alarms ADD COLUMN onset_censored BOOLEAN",),
            3: (),
            4: ("ALTER TABLE alarms ADD COLUMN leak_extrapolated BOOLEAN",
                "ALTER TABLE alarms ADD COLUMN leak_interval TEXT")}

#: What each upgrade adds, in words (the writer's warning).
UPGRADE_NOTES = {1: "runs.error", 2: "alarms.onset_censored",
                 3: "the run status 'inconclusive'",
                 4: "alarms.leak_extrapolated, alarms.leak_interval"}

metadata = MetaData()

schema_version = Table(
    "schema_version", metadata,
    Column("version", Integer, primary_key=True, autoincrement=False),
    Column("created_at", DateTime(timezone=True), nullable=False),
)

actuators = Table(
    "actuators", metadata,
    Column("id", Integer, primary_key=True),
    Column("name", String(200), nullable=False, unique=True),
    Column("system", String(20)),
    Column("first_seen_at", DateTime(timezone=True), nullable=False),
    Column("last_seen_at", DateTime(timezone=True), nullable=False),
)

runs = Table(
    "runs", metadata,
    Column("id", Integer, primary_key=True),
    Column("actuator_id", Integer, ForeignKey("actuators.id"), nullable=False, index=True),
    Column("command", String(20), nullable=False),
    Column("invocation", String(40), nullable=False),
    Column("source", Text, nullable=False),
    Column("feature", String(200), nullable=False),
    Column("sample_rate_hz", Float),
    Column("threshold", Float),
    Column("started_at", DateTime(timezone=True), nullable=False),
    Column("ended_at", DateTime(timezone=True)),
    Column("status", String(20), nullable=False),
    Column("n_chunks", Integer, nullable=False, default=0),
    Column("n_windows", Integer, nullable=False, default=0),
    Column("config", Text),
    Column("leakdiag_version", String(40)),
    Column("error", Text),  # why a run failed, was not judged (schema version 2) or was
    # inconclusive (4)
)

chunk_summaries = Table(
    "chunk_summaries", metadata,
    Column("id", Integer, primary_key=True),
    Column("run_id", Integer, ForeignKey("runs.id"), nullable=False),
    Column("seq", Integer, nullable=False),
    Column("recorded_at", DateTime(timezone=True), nullable=False),
    Column("t_start_s", Float, nullable=False),
    Column("t_end_s", Float, nullable=False),
    Column("n_windows", Integer, nullable=False),
    Column("n_degenerate", Integer, nullable=False),
    Column("value_mean", Float),
    Column("value_min", Float),
    Column("value_max", Float),
    Column("value_last", Float),
    Column("score_max", Float),
    Column("score_last", Float),
    Column("alarm", Boolean),
    Index("ix_chunk_summaries_run_seq", "run_id", "seq", unique=True),
)

alarms = Table(
    "alarms", metadata,
    Column("id", Integer, primary_key=True),
    Column("run_id", Integer, ForeignKey("runs.id"), nullable=False, index=True),
    Column("raised_at", DateTime(timezone=True), nullable=False),
    Column("alarm_time_s", Float, nullable=False),
    Column("cleared_time_s", Float),  # the episode's end: its CUSUM excursion back at 0 (a dip
    # under the threshold is no clearing; stores before version 5 may hold a dip's time)
    Column("onset_s", Float),
    Column("onset_censored", Boolean),  # onset at the first window judged (schema version 3)
    Column("score", Float),
    Column("threshold", Float),
    Column("leak_lpm", Float),
    Column("leak_lpm_low", Float),
    Column("leak_lpm_high", Float),
    Column("detector", String(200)),
    Column("leak_extrapolated", Boolean),  # the size an extrapolation (schema version 5)
    Column("leak_interval", Text),  # what [leak_lpm_low, leak_lpm_high] is, in words (5)
)
