"""Resumed perf studies read back only whole files of their own settings and code (cache audit
2026-11-27, finding 4): ``perf/flow_balance_verdict_study.py`` and
``perf/flow_balance_size_band.py``, with the simulator and the detector replaced by fakes whose
answers are known (the real study takes 40 CPU-minutes)."""

import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from perf import flow_balance_size_band as band
from perf import flow_balance_verdict_study as study


class FakeFlowBalance:
    """Detects every leak at its onset and sizes it 1.1 x the truth, interval [0.9, 1.2] x."""

    def __init__(self, system=None, false_alarms_per_hour=None, alarm=None):
        self.n_fit = 0

    def fit(self, healthy):
        self.n_fit = len(healthy)
        return self

    def predict(self, rec):
        leak = rec.meta["leak_lpm_achieved"]
        return SimpleNamespace(leak=leak > 0, onset_s=rec.onset, onset_censored=False,
                               alarm_time_s=rec.onset + 1.0, leak_lpm=1.1 * leak,
                               leak_coefficient=None, leak_lpm_interval=(0.9 * leak, 1.2 * leak))


def _fake_vca(duration, leak_lpm, load, machine, seed, onset=0.0, **kw):
    return SimpleNamespace(meta={"leak_lpm_achieved": leak_lpm}, onset=onset)


@pytest.fixture()
def small_study(monkeypatch):
    """One unit and load, 2 fit runs, one run per coverage size, with the fakes."""
    fits = []

    class Counting(FakeFlowBalance):
        def fit(self, healthy):
            fits.append(len(healthy))
            return super().fit(healthy)

    monkeypatch.setattr(study, "ld", SimpleNamespace(
        sim=SimpleNamespace(simulate_vca=_fake_vca, OperatingConditions=dict),
        detect=SimpleNamespace(FlowBalanceDetector=Counting)))
    monkeypatch.setattr(study, "UNITS", (17,))
    monkeypatch.setattr(study, "LOADS", ("none",))
    monkeypatch.setattr(study, "N_FIT", 2)
    monkeypatch.setattr(study, "N_PER", 1)
    monkeypatch.setattr(study, "COVERAGE_SIZES", (0.05, 0.2))
    # a fitted detector pickles as the plain fake (Counting is local to the fixture)
    monkeypatch.setattr(Counting, "__reduce__", lambda self: (FakeFlowBalance, ()))
    return fits


def _coverage_line(text):
    (line,) = [x for x in text.splitlines() if x.startswith("none   coverage step")]
    return line


def _start_lines(text):
    return [x for x in text.splitlines() if x.startswith("none   start")]


def test_verdict_study_with_other_settings_computes_its_rows_again(tmp_path, capsys,
                                                                   small_study, monkeypatch):
    """More runs per size and another size: 9 coverage runs, not the former 2 read back."""
    study.main(str(tmp_path))
    text = capsys.readouterr().out
    assert "runs   2, detected 2, censored 0, sized 2, interval holds 2/2" in _coverage_line(text)
    assert small_study == [2]
    monkeypatch.setattr(study, "N_PER", 3)
    monkeypatch.setattr(study, "COVERAGE_SIZES", (0.01, 0.05, 0.2))
    study.main(str(tmp_path))
    text = capsys.readouterr().out
    assert "runs   9, detected 9, censored 0, sized 9, interval holds 9/9" in _coverage_line(text)
    assert small_study == [2]  # the detector's settings did not change: read back
    assert re.search(r"^reused .*det_17_none_[0-9a-f]{16}\.pkl$", text, re.M), text
    assert re.search(r"^computed .*rows_17_none_[0-9a-f]{16}\.csv \(45 rows\)$", text, re.M)
    monkeypatch.setattr(study, "N_FIT", 3)  # another fit: the detector is fitted again
    study.main(str(tmp_path))
    assert small_study == [2, 3]
    study.main(str(tmp_path))  # nothing changed: everything read back
    text = capsys.readouterr().out
    assert small_study == [2, 3]
    assert re.search(r"^reused .*rows_17_none_[0-9a-f]{16}\.csv \(45 rows\)$", text, re.M)


def test_verdict_study_write_cut_by_a_full_disk_is_not_read_back(tmp_path, capsys, small_study,
                                                                 monkeypatch):
    """The rows' CSV write fails half-way: the rerun computes all 38 rows (the cut file was
    read as valid: fewer runs, no start lines, its cut last row counted)."""
    real = pd.DataFrame.to_csv

    def half_then_full(self, path=None, **kw):
        text = real(self, None, **kw)
        Path(path).write_text(text[: len(text) // 2])
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as m:
        m.setattr(pd.DataFrame, "to_csv", half_then_full)
        with pytest.raises(OSError, match="No space left"):
            study.main(str(tmp_path))
    assert not list(tmp_path.glob("rows_*")) and not list(tmp_path.glob(".rows_*"))
    capsys.readouterr()
    study.main(str(tmp_path))
    text = capsys.readouterr().out
    assert "runs   2, detected 2" in _coverage_line(text)
    assert len(_start_lines(text)) == len(study.START_KINDS)
    assert all("runs   6, detected 6" in x for x in _start_lines(text))


def test_verdict_study_cut_detector_file_is_fitted_again_with_a_warning(tmp_path, capsys,
                                                                        small_study):
    """A cut pickle stopped every rerun with UnpicklingError until deleted by hand."""
    study.main(str(tmp_path))
    (det,) = tmp_path.glob("det_17_none*.pkl")
    det.write_bytes(det.read_bytes()[:10])
    for f in tmp_path.glob("rows_*.csv"):
        f.unlink()
    capsys.readouterr()
    with pytest.warns(UserWarning, match=rf"^{re.escape(str(det))}: damaged fitted detector "):
        study.main(str(tmp_path))
    assert small_study == [2, 2]
    assert "runs   2, detected 2" in _coverage_line(capsys.readouterr().out)


# ------------------------------------------------------------------ size band
@pytest.fixture()
def small_band(monkeypatch):
    """The size band's loop with a fake simulator and detector (the suites are real)."""
    import leakdiag.bench.registry as registry
    import leakdiag.bench.v5_common as common

    def fake_simulate(case):
        return SimpleNamespace(meta={"leak_lpm_achieved": case.leak_lpm * 0.98}, onset=0.0)

    made = []

    def fake_detector(method, system, alarm):
        made.append(alarm)
        det = FakeFlowBalance()
        det.predict = lambda rec: SimpleNamespace(
            leak=True, alarm_time_s=math.inf, leak_lpm=1.1 * rec.meta["leak_lpm_achieved"],
            leak_lpm_interval_statistical=(rec.meta["leak_lpm_achieved"],
                                           1.2 * rec.meta["leak_lpm_achieved"]))
        return det

    monkeypatch.setattr(common, "_simulate", fake_simulate)
    monkeypatch.setattr(registry, "make_detector", fake_detector)
    return made


def _band(tmp_path, *extra):
    band.main(["--per-size", "1", "--out", str(tmp_path), *extra])


def test_size_band_rows_of_other_settings_are_not_resumed(tmp_path, capsys, small_band,
                                                          monkeypatch):
    """Rows of another alarm confidence are computed again (the resume key was the seed)."""
    _band(tmp_path)
    first = pd.read_csv(tmp_path / "size_ratios.csv")
    n = len(first)
    assert n == len(small_band) > 4 and np.allclose(first["ratio"], 1.1)
    assert {a.confidence for a in small_band} == {0.95}
    capsys.readouterr()
    _band(tmp_path)  # same settings: nothing run again
    assert len(small_band) == n
    reused = capsys.readouterr().out
    monkeypatch.setattr(band, "CONFIDENCE", 0.99, raising=False)
    _band(tmp_path)
    assert len(small_band) == 2 * n
    assert {a.confidence for a in small_band[n:]} == {0.99}
    assert len(pd.read_csv(tmp_path / "size_ratios.csv")) == n
    assert re.search(rf"^reused {n} rows from .*rows-[0-9a-f]{{16}}\.csv$", reused, re.M)
    text = capsys.readouterr().out
    assert re.search(r"^not reused \(other settings or code\): rows-[0-9a-f]{16}\.csv$", text,
                     re.M), text


def test_size_band_write_cut_by_a_full_disk_is_not_read_back(tmp_path, capsys, small_band,
                                                             monkeypatch):
    """The CSV write fails half-way after the third row: the rerun has every row once and
    whole (a half row's seed counted as done)."""
    real, calls = pd.DataFrame.to_csv, []

    def cut_third(self, path=None, **kw):
        calls.append(1)
        if len(calls) < 3:
            return real(self, path, **kw)
        lines = real(self, None, **kw).splitlines(keepends=True)
        Path(path).write_text("".join(lines[:-1]) + lines[-1][: len(lines[-1]) // 2])
        raise OSError(28, "No space left on device")

    with monkeypatch.context() as m:
        m.setattr(pd.DataFrame, "to_csv", cut_third)
        with pytest.raises(OSError, match="No space left"):
            _band(tmp_path)
    n_made = len(small_band)
    _band(tmp_path)
    df = pd.read_csv(tmp_path / "size_ratios.csv")
    assert df["truth_lpm"].notna().all() and np.allclose(df["ratio"], 1.1)
    assert n_made == 3
    assert df["seed"].is_unique and len(df) == len(small_band) - 1  # 2 rows kept, 1 redone
