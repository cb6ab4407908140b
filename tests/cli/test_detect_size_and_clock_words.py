"""What detect prints for a calibrated detector that gives no size, and times on a clock's axis.

A user audit (2026-11-29): a calibrated detector whose onset was censored (the leak there from
the first window judged) was said to be "not calibrated on known leaks"; and a recording timed
in Unix seconds printed its alarm and onset as ``1.796e+09 s``, so that an onset 6 s before
its alarm could not be seen (``leakdiag._format.seconds``).
"""

import dataclasses

import pytest

from leakdiag._format import seconds
from leakdiag.detect.base import Alarm
from leakdiag.detect.leaksize import fit_leak_calibration
from leakdiag.detect.methods import thesis_detector
from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca
from leakdiag.stream.detector_file import DetectorMeta, save_detector

CLOCK_S = 1795960000.0  # a Unix time, 2026-11-29


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("sizewords")
    healthy = [simulate_vca(duration=120.0, leak_lpm=None, seed=s) for s in (10, 11)]
    det = thesis_detector("vca", "autocorrelation",
                          alarm=Alarm(onset_method="cusum", burn_in_s=5.0,
                                      false_alarms_per_hour=12.0)).fit(healthy)
    meta = DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"},
                        false_alarms_per_hour=12.0, n_healthy=2)
    save_detector(det, meta, d / "plain.joblib")
    det.calibration_ = fit_leak_calibration([-3.0, -2.0, -1.0, 0.0, 1.0],
                                            [0.4, 0.3, 0.22, 0.1, 0.05])
    save_detector(det, meta, d / "calibrated.joblib")
    leak = simulate_vca(duration=120.0, leak_lpm=1.0, onset=60.0, seed=13)
    write_recording(leak.slice_time(55.0, None), d / "late.parquet")   # leaking from 5 s on
    write_recording(leak, d / "whole.parquet")
    write_recording(dataclasses.replace(leak, start_time=CLOCK_S), d / "clock.parquet")
    return d


def test_a_calibrated_detector_says_why_a_censored_onset_gives_no_size(files, run_cli):
    code, out, err = run_cli(["detect", str(files / "late.parquet"), "--detector",
                              str(files / "calibrated.joblib")])
    assert code == 0 and "Decision: LEAK" in out, (out, err)
    assert "onset at or before" in out
    assert ("leak size (acf-p1): not estimated: the change was there from the first window "
            "judged") in out
    assert "no detector here is calibrated" not in out


def test_an_uncalibrated_detector_still_says_so(files, run_cli):
    code, out, err = run_cli(["detect", str(files / "late.parquet"), "--detector",
                              str(files / "plain.joblib")])
    assert code == 0 and "leak size: not estimated (no detector here is calibrated" in out


def test_times_on_a_clock_axis_keep_the_tenth_of_a_second(files, run_cli):
    code, out, err = run_cli(["detect", str(files / "whole.parquet"), "--detector",
                              str(files / "calibrated.joblib")])
    assert code == 0 and "Decision: LEAK" in out, (out, err)
    code, clock, err = run_cli(["detect", str(files / "clock.parquet"), "--detector",
                                str(files / "calibrated.joblib")])
    assert code == 0 and "Decision: LEAK" in clock, (clock, err)
    assert "e+09" not in clock
    line = next(s for s in out.splitlines() if s.startswith("  onset "))
    # "  onset 57.86 s, first alarm 63.28 s (acf-p1)": the same instants CLOCK_S later, to the
    # tenth of a second (not "1.796e+09 s" for both)
    words = line.replace(",", " ").split()
    onset, alarm = float(words[1]), float(words[5])
    want = (f"  onset {CLOCK_S + onset:.1f} s, first alarm {CLOCK_S + alarm:.1f} s "
            "(acf-p1)")
    got = next(s for s in clock.splitlines() if s.startswith("  onset "))
    assert abs(float(got.split()[1]) - CLOCK_S - onset) < 0.06, (line, got)
    assert abs(float(got.split()[5]) - CLOCK_S - alarm) < 0.06, (line, got)
    assert len(got) == len(want), (got, want)


@pytest.mark.parametrize("t, digits, text", [
    (64.039, 4, "64.04"), (64.039, 6, "64.039"), (999.94, 4, "999.9"), (1234.56, 4, "1234.6"),
    (123456.789, 6, "123456.8"), (1795960057.8595, 6, "1795960057.9"), (-2.5e7, 4, "-25000000.0"),
    (float("inf"), 4, "inf")])
def test_seconds_by_hand(t, digits, text):
    assert seconds(t, digits) == text
