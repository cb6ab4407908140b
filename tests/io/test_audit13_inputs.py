"""Users' own recordings (audit of 2026-11-27, /tmp/audit13-real): one column read as two
channels, time axes of real exports, implausible SI values."""

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.cli.main import main
from leakdiag.io import RecordingError


@pytest.fixture()
def counts_file(tmp_path):
    rng = np.random.default_rng(0)
    n = 3000
    df = pd.DataFrame({"Time": np.arange(1, n + 1), "PG_1": 5000 + rng.integers(0, 50, n),
                       "PG_2": 6000 + rng.integers(0, 50, n)})
    path = tmp_path / "log.csv"
    df.to_csv(path, index=False)
    return path


def test_two_standard_channels_from_one_column_are_refused(counts_file, capsys):
    """Finding 5: --col p1=PG_2 over a map whose p2 is PG_2 read P2's autocorrelation as the
    P1-P2 cross-correlation and said NO LEAK."""
    with pytest.raises(RecordingError, match=r"log\.csv: channels 'p1' and 'p2' are both read "
                                             r"from column 'PG_2' \(same offset and gain\)"):
        ld.io.read_recording(counts_file, ld.io.build_column_map(
            ["p1=PG_2:counts", "p2=PG_2:counts", "time=Time:samples"]), sample_rate=1000.0)
    code = main(["analyze", str(counts_file), "--col", "p1=PG_1:counts", "--col",
                 "p2=PG_1:counts", "--col", "time=Time:samples", "--sample-rate", "1000",
                 "-m", "cross-correlation", "-c", "p1,p2"])
    assert code == 2
    assert ("channels 'p1' and 'p2' are both read from column 'PG_1' (same offset and gain)"
            in capsys.readouterr().err)
    # the same column with another gain is a different signal (e.g. two calibrations): read
    rec = ld.io.read_recording(counts_file, ld.io.build_column_map(
        ["p1=PG_1:counts", "p2=PG_1:counts*2", "time=Time:samples"]), sample_rate=1000.0)
    assert np.array_equal(rec["p2"], 2 * rec["p1"])


def test_two_other_channels_from_one_column_are_warned_about(counts_file):
    with pytest.warns(UserWarning, match="channels 'a' and 'b' are both read from column 'PG_1'"):
        ld.io.read_recording(counts_file, ld.io.build_column_map(
            ["p1=PG_2:counts", "a=PG_1:counts", "b=PG_1:counts", "time=Time:samples"]),
            sample_rate=1000.0)


def _k3(path, drop=None):
    t = np.round(np.arange(3000) / 3000.0, 6)  # uniform 3 kHz, timestamps to the microsecond
    p1 = 1e6 + np.sin(np.arange(3000.0))
    keep = np.ones(3000, bool)
    if drop is not None:
        keep[drop] = False
    pd.DataFrame({"time": t[keep], "p1": p1[keep]}).to_csv(path, index=False, float_format="%.6f")
    return path


def test_a_uniform_3khz_file_with_microsecond_timestamps_is_accepted(tmp_path, capsys):
    """Finding 7: intervals of 333 and 334 us (0.3 % apart) were refused as not uniformly
    sampled, in analyze and in monitor (file and stdin)."""
    path = _k3(tmp_path / "k3.csv")
    assert ld.io.read_recording(path).sample_rate == pytest.approx(3000.0, rel=1e-6)
    assert main(["monitor", str(path), "-c", "p1", "-w", "200"]) == 0
    assert "3000 samples at 3000 Hz" in capsys.readouterr().out
    # a missing row is still a gap, whole or streamed
    gap = _k3(tmp_path / "gap.csv", drop=1500)
    with pytest.raises(RecordingError, match="not uniformly sampled: interval before row 1500"):
        ld.io.read_recording(gap)
    assert main(["monitor", str(gap), "-c", "p1", "-w", "200"]) == 2
    assert "not uniformly sampled: interval before row 1500" in capsys.readouterr().err


def test_time_axis_allows_the_print_resolution_of_a_line_stream():
    from leakdiag.stream.chunks import TimeAxis

    ax = TimeAxis(3000.0, "<stdin>", resolution=1e-6)
    for i, t in enumerate(np.round(np.arange(10) / 3000.0, 6)):
        ax.check(float(t), i + 2)
    with pytest.raises(RecordingError, match="line 12: time 0.003667 s after 0.003 s is a gap"):
        ax.check(0.003667, 12)
    blocks = TimeAxis(3000.0, "k3.csv")  # a file's chunks: the resolution found per block
    t = np.round(np.arange(6000) / 3000.0, 6)
    blocks.check_block(t[:4096], 0)
    blocks.check_block(t[4096:5000], 4096)
    with pytest.raises(RecordingError, match="row 5000: time 1.667 s after 1.666333 s is a gap"):
        blocks.check_block(t[5001:], 5000)
