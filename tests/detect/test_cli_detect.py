"""``leakdiag detect FILE --healthy ...`` on simulated VCA recordings written to Parquet."""

import pytest

from leakdiag.cli.detect import verdict_table
from leakdiag.cli.main import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from leakdiag.io import write_recording
    from leakdiag.sim import simulate_vca

    d = tmp_path_factory.mktemp("detect")
    healthy = []
    for s in range(3):
        rec = simulate_vca(duration=30.0, leak_lpm=None, seed=20 + s, reference_seed=120 + s)
        healthy.append(str(write_recording(rec, d / f"healthy{s}.parquet")))
    leak = simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=30, reference_seed=130)
    return healthy, str(write_recording(leak, d / "leak.parquet"))


def test_verdict_table_flags_leak_after_onset(files):
    healthy, leak = files
    # 3 healthy runs of 25 s monitored support false-alarm probabilities down to 1/4 per run
    # (conformal threshold = the largest healthy CUSUM maximum, k = 1): 40 per hour = 0.28 per run
    tab = verdict_table(leak, healthy, methods=["ccf-p1p2"], false_alarms_per_hour=40.0)
    row = tab.iloc[0]
    assert bool(row.leak) and row.alarm_time_s >= 15.0 and abs(row.onset_s - 15.0) < 3.0
    assert row.n_healthy == 3


def test_cli_prints_verdict_and_rejects_unknown_method(files, capsys):
    healthy, leak = files
    args = ["detect", leak, "--methods", "ccf-p1p2"]
    for h in healthy:
        args += ["--healthy", h]
    # the default 1 alarm per hour needs >= 143 healthy 25-s runs: refused, and it says so
    assert main(args) == 2
    assert "needs at least 143 maxima" in capsys.readouterr().err
    args += ["--false-alarms-per-hour", "40"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "ccf-p1p2" in out and "True" in out
    assert main(args[:2] + ["--methods", "nope"] + args[4:]) == 2
    assert "unknown method 'nope'" in capsys.readouterr().err
