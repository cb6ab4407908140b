"""Wall-clock times on the pages are UTC whatever zone the database returned them in (store
audit of 2026-11-27, finding 4: a PostgreSQL session in Europe/Berlin showed local times under
"(UTC)" headers and Plotly dropped the offset). Without a database server: a store whose
reads return aware times in UTC+01:00."""

from datetime import datetime, timedelta, timezone

import pandas as pd

from leakdiag.dashboard.app import _clean, make_app

from .test_app import Client

BERLIN = timezone(timedelta(hours=1))


def test_clean_converts_aware_times_to_utc():
    t = datetime(2026, 11, 27, 16, 24, 47, tzinfo=BERLIN)
    assert _clean(t) == "2026-11-27T15:24:47+00:00"
    assert _clean(pd.Timestamp(t)) == "2026-11-27T15:24:47+00:00"
    assert _clean(datetime(2026, 11, 27, 15, 24, 47)) == "2026-11-27T15:24:47"  # SQLite: UTC


class _BerlinStore:
    """What psycopg returns from a session whose TimeZone is Europe/Berlin."""

    t = datetime(2026, 11, 27, 16, 24, 47, tzinfo=BERLIN)

    def fleet(self):
        return pd.DataFrame([{
            "name": "pgmon", "system": "vca", "state": "ALARM", "last_seen_at": self.t,
            "n_runs": 1, "last_alarm_at": self.t, "last_alarm_time_s": 34.4, "onset_s": 32.4,
            "onset_censored": False, "leak_lpm": None, "leak_lpm_low": None,
            "leak_lpm_high": None, "feature": "acf-p1", "source": "leak.parquet",
            "error": None}])

    def actuator_names(self):
        return ["pgmon"]

    def history(self, name):
        summ = pd.DataFrame({"recorded_at": [self.t], "t_start_s": [0.0], "t_end_s": [1.0],
                             "n_windows": [5], "n_degenerate": [0], "value_mean": [0.5],
                             "value_min": [0.1], "value_max": [0.9], "score_max": [1.0],
                             "alarm": [True], "source": ["leak.parquet"],
                             "feature": ["acf-p1"], "run_id": [1]})
        al = pd.DataFrame({"raised_at": [self.t], "alarm_time_s": [34.4], "run_id": [1]})
        return summ, al

    def runs_of(self, name):
        return pd.DataFrame({"id": [1], "started_at": [self.t], "ended_at": [self.t]})


def test_the_pages_show_utc():
    c = Client(make_app(store=_BerlinStore()))
    try:
        body = c.get("/").text
        assert "2026-11-27 15:24:47 (t=34.4 s)" in body and "16:24" not in body
        assert "<td>2026-11-27 15:24:47</td>" in body  # last seen
        h = c.get("/api/history/pgmon").json()
        assert h["summaries"]["recorded_at"] == ["2026-11-27T15:24:47+00:00"]
        assert h["alarms"][0]["raised_at"] == "2026-11-27T15:24:47+00:00"
        assert h["runs"][0]["started_at"] == "2026-11-27T15:24:47+00:00"
    finally:
        c.srv.stop()
