"""Monitor: events per window, detector protocol (stateful scorer independent of chunking), JSON."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _stream_ref import ac_ref, mlr_ref
from leakdiag.features.spec import MethodSpec
from leakdiag.stream import Monitor, WindowEvent, check_scorer


class Cusum:
    """Test double of a fitted detector: one-sided CUSUM of the drop of a feature below a baseline.

    Stateful; its scores depend only on the sequence of values, not on how it is split.
    """

    def __init__(self, baseline, slack, threshold):
        self.baseline, self.slack, self.threshold_ = baseline, slack, threshold
        self._s = 0.0

    def score_windows(self, values, time):
        out = np.empty(len(values))
        for i, v in enumerate(values):
            self._s = max(0.0, self._s + (self.baseline - v) - self.slack)
            out[i] = self._s
        return out


def cusum_ref(values, baseline, slack):
    s, out = 0.0, []
    for v in values:
        s = max(0.0, s + (baseline - v) - slack)
        out.append(s)
    return np.array(out)


def _signal(n=6000, seed=0):
    rng = np.random.default_rng(seed)
    x = np.sin(np.arange(n) / 4.0) + 0.05 * rng.normal(size=n)
    x[n // 2:] = rng.normal(size=n - n // 2)  # white noise after the "leak": ac drops to ~0
    return x


@settings(max_examples=25, deadline=None)
@given(cuts=st.lists(st.integers(1, 5999), max_size=15))
def test_scores_and_alarms_independent_of_chunking(cuts):
    x = _signal()
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    mon = Monitor(spec, sample_rate=1000.0, scorers=Cusum(0.9, 0.05, 2.0))
    bounds = [0, *sorted(set(cuts)), len(x)]
    events = [e for a, b in zip(bounds[:-1], bounds[1:]) for e in mon.push({"p1": x[a:b]})]
    ac = ac_ref(x, 1, 200, 5)
    expected = cusum_ref(ac, 0.9, 0.05)
    np.testing.assert_allclose([e.value for e in events], ac, rtol=1e-9)
    np.testing.assert_allclose([e.score for e in events], expected, rtol=1e-9, atol=1e-12)
    assert [e.alarm for e in events] == (expected >= 2.0).tolist()
    assert [e.window for e in events] == list(range(len(ac)))
    # planted truth: alarm only after the change at sample 3000 (t = 3.0 s)
    first_alarm = next(e.time for e in events if e.alarm)
    assert 3.0 < first_alarm < 3.0 + 5 * 0.2


def test_two_features_events_in_time_order():
    x = _signal(3000)
    specs = [MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5),
             MethodSpec("metric-length", ("p1",), lag_ratio="83:3", window=500, overlap=5)]
    mon = Monitor(specs, sample_rate=100.0)
    events = list(mon.run({"p1": x[i:i + 700]} for i in range(0, 3000, 700)))
    assert [e.time for e in events] == sorted(e.time for e in events)
    mlr = [e.value for e in events if e.method == "metric-length"]
    np.testing.assert_allclose(mlr, mlr_ref(x, 83, 3, 500, 5), rtol=1e-9)
    assert all(e.score is None and e.alarm is None for e in events)
    assert mon.n_samples_seen == 3000


def test_alarm_windows_hook_overrides_threshold():
    class Band:
        def score_windows(self, values, time):
            return np.abs(values)

        def alarm_windows(self, scores):
            return scores < 0.5

    x = _signal(2000)
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=0)
    events = Monitor(spec, 1000.0, scorers=[Band()]).push({"p1": x})
    assert [e.alarm for e in events] == (np.abs(ac_ref(x, 1, 200, 0)) < 0.5).tolist()


def test_event_json_line():
    e = WindowEvent(0.199, 0, "autocorrelation", ("p1",), 0.5, 1.5, True)
    assert json.loads(e.to_json()) == {"time": 0.199, "window": 0, "method": "autocorrelation",
                                       "channels": ["p1"], "value": 0.5, "score": 1.5,
                                       "alarm": True}
    nan = json.loads(WindowEvent(1.0, 3, "autocorrelation", ("p1",), float("nan")).to_json())
    assert nan["value"] is None and "score" not in nan


def test_scorer_protocol_errors():
    class NoScore:
        threshold_ = 1.0

    class NoThreshold:
        def score_windows(self, values, time):
            return values

    with pytest.raises(TypeError, match=r"NoScore has no score_windows\(values, time\)"):
        check_scorer(NoScore())
    with pytest.raises(TypeError, match="needs alarm_windows\\(scores\\) or a numeric threshold_"):
        check_scorer(NoThreshold())
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=10, overlap=0)
    with pytest.raises(ValueError, match="got 2 scorer\\(s\\) for 1 feature spec"):
        Monitor(spec, 10.0, scorers=[None, None])

    class Bad:
        threshold_ = 0.0

        def score_windows(self, values, time):
            return values[:-1]

    mon = Monitor(spec, 10.0, scorers=Bad())
    with pytest.raises(ValueError, match=r"score_windows returned shape \(0,\) for \(1,\)"):
        mon.push({"p1": np.arange(10.0)})

    class BadAlarms:  # one alarm per chunk, whatever its windows: the events would be wrong
        def score_windows(self, values, time):
            return values

        def alarm_windows(self, scores):
            return [True]

    mon = Monitor(spec, 10.0, scorers=BadAlarms())
    assert [e.alarm for e in mon.push({"p1": np.arange(10.0)})] == [True]
    with pytest.raises(ValueError, match=r"alarm_windows returned shape \(1,\) for \(2,\)"):
        mon.push({"p1": np.arange(20.0)})
