"""Which column names are taken for a time column not named exactly ``time`` (refused without a
map, audit of users' recordings 2026-11-27, finding 3), and which are not: a review found
temperature columns (``T_oil``) refused, with the advice to make them the time axis."""

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.io import RecordingError
from leakdiag.io.checks import time_like_column


@pytest.mark.parametrize("name", ["Time", "TIME", "t", "time_s", "Time [s]", "time (ms)", "t_s",
                                  "t [s]", "t (ms)", "T_s"])
def test_time_like(name):
    assert time_like_column([name, "p1"]) == name


@pytest.mark.parametrize("name", ["T", "T_oil", "t_amb", "T [degC]", "T (C)", "timer", "Temp",
                                  "tank"])
def test_not_time_like(name):
    assert time_like_column([name, "p1"]) is None


def test_a_temperature_column_is_read_as_a_channel(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "notime.csv"
    pd.DataFrame({"p1": 5e6 + rng.standard_normal(100), "T_oil": 40 + rng.standard_normal(100)}) \
        .to_csv(path, index=False)
    rec = ld.io.read_recording(path, sample_rate=1000.0)
    assert rec.sample_rate == 1000.0 and "T_oil" in rec.channels
    path2 = tmp_path / "time.csv"
    pd.DataFrame({"Time": np.arange(100) / 500, "p1": np.ones(100)}).to_csv(path2, index=False)
    with pytest.raises(RecordingError, match="column 'Time' looks like a time column"):
        ld.io.read_recording(path2, sample_rate=1000.0)
