"""What leakdiag reports on the real rotary-actuator recordings (shared/realdata).

The protocol is the one of docs/realdata.md: read every file through the generic reader with the
example column map; split by stroke direction (P1 above P2 or not: the strokes alternate and the
features differ by direction); for each file, fit the detector on the *healthy* files of the same
direction from *other* units (leave one unit out), then predict the file. The numbers pinned
here are the ones printed in docs/realdata.md. Caveat (README of the data): one unit per
condition, defect units recorded on another day -- this is not evidence about leak detection.
"""

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from sklearn.base import clone

from leakdiag.bench.run import per_run_target_per_hour
from leakdiag.detect import Alarm, FeatureDetector
from leakdiag.detect.threshold import InsufficientHealthyDataWarning

REPO = Path(__file__).resolve().parents[2]
MAP = REPO / "docs" / "examples" / "rotary_actuator_map.toml"
CONDITION = {"Act_1": "healthy", "Act_2": "healthy", "Act_3 (Gear Damage)": "gear damage",
             "Act_4 (Seal Defect)": "seal defect", "Act_5": "healthy"}
DETECTORS = {
    "acf-p1": FeatureDetector("autocorrelation", ("p1",), lag=1, window=200, overlap=5),
    "ccf-p1p2": FeatureDetector("cross-correlation", ("p1", "p2"), lag=1, window=100, overlap=5),
    "mlr-p1": FeatureDetector("metric-length", ("p1",), lag_ratio="83:3", window=500, overlap=5),
}


def analyse(data_dir: Path, on_insufficient: str = "raise") -> pd.DataFrame:
    """One row per (method, file): verdict, CUSUM maximum, threshold, or the fitting error.

    ``on_insufficient="warn"`` fits anyway at the largest healthy maximum (an *unsupported*
    threshold basis: its false-alarm level is 1/(n+1) per file, not 1 %)."""
    from leakdiag.io import read_recording

    recs = []
    for f in sorted(data_dir.glob("*/*.txt")):
        r = read_recording(f, MAP)
        recs.append((f.parent.name, f.name, r, "p1>p2" if r["p1"].mean() > r["p2"].mean() else "p2>p1"))
    # 1 % false alarms per 3-s file, the 1 kHz sample rate being an assumption of the map
    alarm = Alarm(false_alarms_per_hour=per_run_target_per_hour(0.01, 3.0, 0.0), burn_in_s=0.0,
                  on_insufficient=on_insufficient)
    rows = []
    for name, proto in DETECTORS.items():
        for unit, fname, rec, direction in recs:
            train = [x[2] for x in recs
                     if CONDITION[x[0]] == "healthy" and x[0] != unit and x[3] == direction]
            row = {"method": name, "unit": unit, "condition": CONDITION[unit],
                   "direction": direction, "file": fname.split("_")[2], "n_fit": len(train)}
            det = clone(proto).set_params(alarm=alarm)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", InsufficientHealthyDataWarning)
                    det.fit(train)
            except ValueError as exc:
                rows.append({**row, "error": str(exc).split(":")[0]})
                continue
            v = det.predict(rec)
            rows.append({**row, "leak": v.leak, "score_max": v.score_max,
                         "threshold": v.threshold, "threshold_method": det.alarm_threshold_.method,
                         "level_per_file": det.threshold_basis_.bound_per_segment,
                         "mean_z": float(np.nanmean(det.standardize(rec).values))})
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def data(shared_dir):
    data = shared_dir / "realdata" / "rotary-actuators" / "Data"
    if not data.is_dir():
        pytest.skip("real recordings not available")
    return data


@pytest.fixture(scope="module")
def refused(data):
    return analyse(data)


@pytest.fixture(scope="module")
def table(data):
    return analyse(data, on_insufficient="warn")


def test_reader_with_column_map_gives_raw_count_channels(shared_dir):
    from leakdiag.io import read_recording

    f = next((shared_dir / "realdata" / "rotary-actuators" / "Data" / "Act_4 (Seal Defect)").glob("*.txt"))
    rec = read_recording(f, MAP)
    assert rec.n_samples == 3000 and rec.sample_rate == 1000.0
    assert rec.units["p1"] == "counts" and set(rec.channel_names) >= {"p1", "p2", "angle"}
    assert 0 <= rec["p1"].min() and rec["p1"].max() <= 16383  # 14-bit ADC counts


def test_fourteen_files_five_units(table):
    per = table[table.method == "acf-p1"].groupby("condition").size().to_dict()
    assert per == {"healthy": 8, "gear damage": 2, "seal defect": 4}


def test_too_little_healthy_data_is_an_error_not_a_default(refused):
    # 2-4 healthy 3-s files per direction and unit left out: a conformal threshold at 1 % per
    # file needs 99 healthy maxima; leakdiag refuses every file instead of extrapolating
    assert len(refused) == 42 and refused.error.notna().all()
    assert refused.error.str.contains("needs at least 99 maxima").all()
    assert set(refused.n_fit) == {2, 3, 4}


def test_what_leakdiag_reports(table):
    # fitted anyway at the largest healthy maximum of the other units: an unsupported basis
    # whose level is 1/(n+1) per file (0.2-0.33), not 1 %
    assert (table.threshold_method == "conformal-unsupported").all()
    assert np.allclose(table.level_per_file, 1.0 / (table.n_fit + 1))
    flagged = table[table.leak.astype(bool)]
    # no seal-defect or gear file exceeds the healthy maxima of the other units; four healthy
    # files do: the healthy units differ among themselves as much as the defect unit differs
    # from them (the data README's caveat, measured)
    assert sorted(zip(flagged.method, flagged.unit, flagged.file)) == [
        ("acf-p1", "Act_1", "61"), ("acf-p1", "Act_2", "31"), ("ccf-p1p2", "Act_5", "31"),
        ("mlr-p1", "Act_2", "31")]
    seal = table[table.condition == "seal defect"]
    healthy = table[table.condition == "healthy"]
    assert seal.score_max.max() < healthy.score_max.max()


def test_the_command_line_gives_the_tables_row(shared_dir, run_cli, tmp_path):
    """docs/realdata.md's commands (fit on the other units' P1-high healthy files, detect Act_4
    file 10) give the table's row: score 2.53 against 6.66, NO LEAK at 0.2 per file."""
    data = shared_dir / "realdata" / "rotary-actuators" / "Data"
    healthy = [next((data / u).glob(f"Base_000_{i}_*.txt"))
               for u, i in (("Act_1", 11), ("Act_1", 61), ("Act_2", 30), ("Act_5", 30))]
    det = tmp_path / "p1high.joblib"
    common = ["--map", str(MAP)]
    code, out, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", str(h))],
                              "-m", "acf-p1", "--system", "vca", *common, "--burn-in", "0",
                              "--false-alarm-rate", "200", "--no-progress", "-o", str(det)])
    assert code == 2 and "needs at least 5 maxima" in err
    code, out, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", str(h))],
                              "-m", "acf-p1", "--system", "vca", *common, "--burn-in", "0",
                              "--false-alarm-rate", "240", "--no-progress", "-o", str(det)])
    assert code == 0, err
    suspect = next((data / "Act_4 (Seal Defect)").glob("Leak_000_10_*.txt"))
    code, out, err = run_cli(["detect", str(suspect), "--detector", str(det), *common])
    assert code == 0, err
    assert "acf-p1 False" in out and "2.532205  6.664946" in out
    assert "Decision: NO LEAK -- no method alarmed; false-alarm rate for this run at most 0.2" \
        in out
    assert "states no rig in its metadata" in err
