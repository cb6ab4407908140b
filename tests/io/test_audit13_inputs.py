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


def test_implausible_si_names_file_channel_range_and_likely_unit():
    """Finding 1: x in mm and p in bar read as SI without a word (flow balance: 330 L/min for a
    0.3 L/min leak). implausible_si says so; physics detectors can refuse through it."""
    from leakdiag.io.checks import implausible_si

    rec = ld.Recording({"p1": np.array([8.0e6, 8.6e6]), "p2": np.array([85.0, 86.0]),
                        "x": np.array([-0.016, 0.02]), "x_ref": np.array([-16.0, 20.0]),
                        "u": np.array([-5.0, 5.0])}, 1000.0,
                       units={"p1": "Pa", "p2": "Pa", "x": "m", "x_ref": "m", "u": "V"},
                       meta={"source": "rig.csv"})
    assert implausible_si(rec) == [
        "rig.csv: channel 'p2' in Pa spans 85 to 86 Pa, below 1e+04 Pa for a hydraulic "
        "actuator: is it in bar, MPa, kPa or psi (give its unit, e.g. --col p2=p2:bar)?",
        "rig.csv: channel 'x_ref' in m spans -16 to 20 m, beyond 1 m for a hydraulic actuator: "
        "is it in mm (give its unit, e.g. --col x_ref=x_ref:mm)?"]
    big = ld.Recording({"p1": np.array([0.0, 5e9])}, 1000.0, units={"p1": "Pa"})
    assert implausible_si(big)[0].endswith("above 1e+09 Pa for a hydraulic actuator: is it in "
                                           "another unit, or counts whose gain is missing?")
    counts = ld.Recording({"p1": np.array([5.0, 6.0])}, 1000.0, units={"p1": "counts"})
    assert implausible_si(counts) == []
