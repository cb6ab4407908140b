"""``--previous`` notices a run made with other settings (an audit, 2026-11-29: only the RMS
chunk and the window counts were compared, so a run of another protocol, load, run length,
onset, seed or sensor chain was compared without a word)."""

import dataclasses
import importlib
from pathlib import Path
from types import SimpleNamespace

import pandas as pd

from leakdiag.cli.main import main
from leakdiag.report.html import Report
from leakdiag.report.reproduction import _changes_section
from leakdiag.studies.protocol import QUICK, THESIS, V1
from leakdiag.studies.reproduce import (CONTRACT_COLUMNS, SETTING_COLUMNS, assemble_tables,
                                        experiment_settings, setting_differences,
                                        unrecorded_settings)
from leakdiag.studies.thesis import load_tables

COMMITTED = Path(__file__).resolve().parents[2] / "docs" / "reproduction" / "tables.csv"


def _committed():
    """The committed full run's tables.csv without the setting columns (as an older run's)."""
    return pd.read_csv(COMMITTED, dtype={"table": str, "lag": str}).drop(
        columns=SETTING_COLUMNS, errors="ignore")


def _with(t, cfg):
    """``t`` with the setting columns of a run of ``cfg``."""
    rows = [experiment_settings(cfg, s) for s in t["system"]]
    return t.assign(**{c: [r[c] for r in rows] for c in SETTING_COLUMNS})


def test_tables_record_the_settings_of_each_systems_experiment():
    thesis = load_tables()
    t = thesis[thesis.table.isin(["5-4", "6-4"])]
    rows = [{"row_id": rid, "mean_rms_before": 1.0, "mean_rms_after": 0.5, "pct_change": 50.0,
             "pct_change_signed": -50.0, "n_windows": 100, "n_chunks_before": 5,
             "n_chunks_after": 5, "n_chunks_straddling": 0, "n_chunks_empty": 0,
             "n_nan_windows": 0, "n_windows_before": 50, "n_windows_after": 50,
             "n_nan_windows_before": 0, "n_nan_windows_after": 0,
             "pct_change_signed_nan_as_0": -50.0, "chunk": 10} for rid in t.row_id]
    out = assemble_tables(t, rows, dataclasses.replace(QUICK, table_seed=3))
    assert list(out.columns) == ["row_id"] + CONTRACT_COLUMNS
    assert out[["system"] + SETTING_COLUMNS].drop_duplicates().values.tolist() == [
        ["VCA", "thesis-quick", "none", 60.0, 30.0, 3, "thesis"],
        ["EHA", "thesis-quick", "none", 40.0, 20.0, 3, "thesis"]]
    assert assemble_tables(t, rows)[SETTING_COLUMNS].isna().all().all()


def test_each_setting_that_differs_is_named_per_system():
    full = _with(_committed(), THESIS)
    assert setting_differences(full, full) == []
    assert unrecorded_settings(full) == []
    other = _with(_committed(), dataclasses.replace(V1, table_seed=2, eha_load="spring"))
    assert setting_differences(other, full) == [
        "protocol (VCA): thesis before, v1 now", "protocol (EHA): thesis before, v1 now",
        "load (VCA): none before, spring now", "load (EHA): none before, spring now",
        "seed (VCA): 0 before, 2 now", "seed (EHA): 0 before, 2 now",
        "sensor chain (VCA): thesis before, default now",
        "sensor chain (EHA): thesis before, default now"]
    moved = _with(_committed(), dataclasses.replace(THESIS, vca_duration_s=300.0,
                                                    vca_onset_s=150.0))
    assert setting_differences(moved, full) == ["run length (s) (VCA): 400 before, 300 now",
                                                 "leak onset (s) (VCA): 200 before, 150 now"]


def test_the_report_says_when_the_settings_could_not_be_compared():
    new = _with(_committed(), THESIS)
    r = Report("t")
    _changes_section(SimpleNamespace(tables=new, previous=_committed()), r)
    md = r.to_markdown()
    assert ("**Settings not compared**: the previous run's tables.csv has no protocol, load, "
            "duration_s, onset_s, seed, sensors (written before leakdiag recorded them)") in md
    assert "other settings" not in md
    r = Report("t")
    _changes_section(SimpleNamespace(tables=_with(_committed(), V1), previous=new), r)
    md = r.to_markdown()
    assert "**The previous run was made with other settings**, so these changes are not the " \
           "code's alone: protocol (VCA): thesis before, v1 now;" in md
    assert "Settings not compared" not in md


def _stop(*a, **k):
    raise ValueError("stopped where the run would start")


def test_the_command_warns_before_the_run(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(importlib.import_module("leakdiag.studies.reproduce"), "reproduce",
                        _stop)
    prev = tmp_path / "tables.csv"
    _with(_committed(), dataclasses.replace(THESIS, vca_load="spring")).to_csv(prev,
                                                                              index=False)
    args = ["reproduce", "vca", "--quick", "--scheduler", "serial", "--out",
            str(tmp_path / "rep"), "--previous", str(prev)]
    assert main(args) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "leakdiag: warning: the --previous run was made with other settings, so the comparison "
        "is not of the code alone: protocol (VCA): thesis before, thesis-quick now; load (VCA): "
        "spring before, none now; run length (s) (VCA): 400 before, 60 now; leak onset (s) "
        "(VCA): 200 before, 30 now",
        "leakdiag: error: stopped where the run would start"]
    _committed().to_csv(prev, index=False)  # an older run: no setting columns
    assert main(args) == 2
    assert capsys.readouterr().err.splitlines()[0] == (
        "leakdiag: warning: the --previous tables.csv has no protocol, load, duration_s, "
        "onset_s, seed, sensors (an older run): its settings could not be compared with this "
        "run's")
