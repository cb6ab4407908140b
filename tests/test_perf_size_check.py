"""``perf/flow_balance_size_check.py``: the held-out check's rows and summary, with the judging
replaced by a fake whose intervals hold or miss by construction (the suites are real)."""

from __future__ import annotations

import re
import math
from types import SimpleNamespace

import pandas as pd
import pytest

from perf import flow_balance_size_check as check


@pytest.fixture()
def fake_judge(monkeypatch):
    """The real ``_judge`` with a fake simulator and detector: sizes 1.1x the truth; the
    reported interval 1.0-1.2x except at the largest EHA size (1.15-1.2x: missed); the
    statistical part 1.05-1.15x (missed everywhere); the 0.05 L/min runs' alarms refused, the
    0.1 L/min runs refused (a plain RecordingError, as the EHA's negative leak)."""
    import leakdiag.bench.registry as registry
    import leakdiag.bench.v5_common as common
    from leakdiag.detect.flow_balance import AlarmNotConfirmed
    from leakdiag.io.recording import RecordingError

    judged = []

    def predict(rec):
        t = rec.meta["leak_lpm_achieved"]
        judged.append(t)
        if t == 0.05:
            raise AlarmNotConfirmed("predict: not confirmed", 30.0, 25.0)
        if t == 0.1:
            raise RecordingError("predict: the flow balance reads a leak of -0.004 L/min")
        lo = 1.15 * t if t == 1.63 else 1.0 * t
        return SimpleNamespace(leak=True, alarm_time_s=math.inf, leak_lpm=1.1 * t,
                               leak_lpm_interval=(lo, 1.2 * t),
                               leak_lpm_interval_statistical=(1.05 * t, 1.15 * t))

    def fake_detector(method, system, alarm):
        return SimpleNamespace(fit=lambda healthy: None, predict=predict)

    monkeypatch.setattr(common, "_simulate",
                        lambda c: SimpleNamespace(meta={"leak_lpm_achieved": c.leak_lpm}))
    monkeypatch.setattr(registry, "make_detector", fake_detector)
    return judged


def test_size_check_counts_held_intervals_and_refusals(tmp_path, capsys, fake_judge):
    check.main(["--systems", "eha", "--per-size", "2", "--first", "3000", "--out",
                str(tmp_path)])
    df = pd.read_csv(tmp_path / "size_check.csv")
    # the EHA suite: 7 sizes x 2 loads x 2 runs, indexes 3000 and 3001
    assert len(df) == 28 and set(df["index"]) == {3000, 3001}
    assert (df.refused == "AlarmNotConfirmed").sum() == 4
    assert (df.refused == "RecordingError").sum() == 4 and (~df.sized).sum() == 8
    sized = df[df.sized]
    assert not sized.stat_held.astype(bool).any()
    assert (~sized.held.astype(bool)).sum() == 4  # 1.63 L/min, both loads, both runs
    out = capsys.readouterr().out
    # 5 sized sizes x 2 runs = 10 per load, 8 held; Clopper-Pearson of 8/10
    assert re.search(r"^eha spring: intervals held 8/10 \[44\.4, 97\.5 %\] \(statistical part "
                     r"alone 0/10\)$", out, re.M), out
    assert "  0.1 L/min:" not in out
    assert "  1.63 L/min: 0/2, median width 0.045 of the size" in out
    assert "  0.02 L/min: 2/2, median width 0.182 of the size" in out
    n = len(fake_judge)
    check.main(["--systems", "eha", "--per-size", "2", "--first", "3000", "--out",
                str(tmp_path)])
    assert len(fake_judge) == n  # resumed: nothing judged again


def test_size_check_refuses_the_band_s_and_the_benchmark_s_indexes(tmp_path, capsys):
    with pytest.raises(SystemExit):
        check.main(["--first", "10", "--out", str(tmp_path)])
    assert "indexes 0-49 are the benchmark's and the size band's" in capsys.readouterr().err
