"""What a Recording refuses at its boundary (an API audit, 2026-11-29: each was accepted, or
failed with numpy's words naming no argument)."""

import numpy as np
import pandas as pd
import pytest

from leakdiag.io import Recording, RecordingError


def test_a_time_column_is_not_overridden_by_a_given_rate():
    df = pd.DataFrame({"time": np.arange(10) / 500.0, "p1": np.arange(10.0)})
    with pytest.raises(RecordingError, match=r"sample_rate=1000 Hz was given, but the 'time' "
                                             r"column says 500 Hz"):
        Recording.from_pandas(df, sample_rate=1000.0)  # every duration was halved
    assert Recording.from_pandas(df, sample_rate=500.2).sample_rate == 500.0  # within 0.1 %
    assert Recording.from_pandas(df).sample_rate == 500.0


@pytest.mark.parametrize("kw, words", [
    ({"units": {"p1": "bar"}}, "channel 'p1' is labelled 'bar', but a Recording holds standard "
                               "channels in SI units ('Pa', or 'counts')"),
    ({"start_time": float("nan")}, "start_time=nan must be a finite number of seconds"),
    ({"start_time": float("inf")}, "start_time=inf must be a finite number of seconds"),
])
def test_labels_and_start_times_it_cannot_hold(kw, words):
    with pytest.raises(RecordingError, match=f"^<recording>: {words}".replace("(", r"\(")
                       .replace(")", r"\)")):
        Recording({"p1": np.zeros(3)}, 1.0, **kw)


def test_counts_and_other_channels_keep_their_labels():
    rec = Recording({"p1": np.zeros(3), "temp": np.ones(3)}, 1.0,
                    units={"p1": "counts", "temp": "degC"})
    assert rec.units == {"p1": "counts", "temp": "degC"}


@pytest.mark.parametrize("values, words", [
    (np.array([1 + 1j, 2.0]), "holds complex values"),
    (["a", "b"], "holds values that are not numbers"),
])
def test_samples_that_are_not_real_numbers(values, words):
    with pytest.raises(RecordingError, match=f"channel 'p1' {words}"):
        Recording({"p1": values}, 1.0)


@pytest.mark.parametrize("t0, t1", [(float("nan"), 1.0), (0.0, float("inf"))])
def test_slice_time_bounds_are_finite(t0, t1):
    with pytest.raises(ValueError, match="must be a finite time in s, or None"):
        Recording({"p1": np.zeros(3)}, 1.0).slice_time(t0, t1)
