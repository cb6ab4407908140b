"""What a reproduction report says of its numbers' origin (cache audit 2026-11-27, finding 8):
how many simulations were computed in the run and how many read from the cache, and
fingerprints of every part of the code and data the numbers depend on."""

import importlib
import shutil
import subprocess
import sys
from types import SimpleNamespace

import pytest

import leakdiag._fingerprint as fingerprint
from leakdiag.report import reproduction as report
from leakdiag.report.html import Report
from leakdiag.studies.protocol import QUICK
from leakdiag.studies.thesis import load_tables

#: The module (``leakdiag.studies.reproduce`` the attribute is the function of that name).
reproduce = importlib.import_module("leakdiag.studies.reproduce")


def _summary(n_cases, cache_hits):
    """The report's summary paragraph for a hand-made run of table 5-3 (no simulation)."""
    t = load_tables()
    t = t[t.table == "5-3"]
    rows = [{"row_id": rid, "mean_rms_before": 1.0, "mean_rms_after": a,
             "pct_change": abs(a - 1) * 100, "pct_change_signed": (a - 1) * 100,
             "n_windows": 100, "n_chunks_before": 5, "n_chunks_after": 5,
             "n_chunks_straddling": 0, "n_chunks_empty": 0, "n_nan_windows": 0,
             "n_windows_before": 50, "n_windows_after": 50, "n_nan_windows_before": 0,
             "n_nan_windows_after": 0, "pct_change_signed_nan_as_0": (a - 1) * 100,
             "chunk": 10}
            for rid, a in zip(t.row_id, [0.5, 0.6, 1.2, 0.8])]
    tables = reproduce.assemble_tables(t, rows)
    rep = SimpleNamespace(tables=tables, config=QUICK, previous=None,
                          preferred=reproduce.preferred_settings(tables),
                          timing={"n_cases": n_cases, "cache_hits": cache_hits, "wall_s": 3.0,
                                  "command": "leakdiag reproduce vca --quick",
                                  "code": reproduce.code_fingerprints()})
    r = Report("x")
    report._summary(rep, r)
    return r.to_markdown().split("\n\n")[2]


def test_a_run_read_from_the_cache_does_not_say_it_computed_its_simulations():
    text = _summary(7, 7)
    assert "Every number below was computed in this run" not in text
    assert ("(protocol 'thesis-quick', 7 simulated experiments: none simulated in this run, all "
            "7 read from the simulation cache (recordings written to it earlier, by this run or "
            "an earlier one; the cache key holds the fingerprint of the simulators' code and the "
            "library versions); ") in text
    assert ("Every feature, measure, table and comparison below was computed in this run from "
            "these recordings") in text
    assert "98 simulated experiments: 96 simulated in this run, 2 read from the simulation " \
           "cache (recordings" in _summary(98, 2)
    fresh = _summary(98, 0)
    assert "98 simulated experiments, all simulated in this run; simulations" in fresh
    assert "cache" not in fresh.split("; simulations")[0]


@pytest.fixture()
def package_copy(tmp_path, monkeypatch):
    """A copy of leakdiag's sources whose fingerprints the functions read (editable)."""
    src = tmp_path / "leakdiag"
    shutil.copytree(fingerprint.PACKAGE_ROOT, src,
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    monkeypatch.setattr(fingerprint, "PACKAGE_ROOT", src)
    monkeypatch.setattr(reproduce, "THESIS_DATA", src / "studies" / "thesis_data",
                        raising=False)
    fingerprint.parts_fingerprint.cache_clear()
    yield src
    fingerprint.parts_fingerprint.cache_clear()


@pytest.mark.parametrize("edited", ["detect/measure.py", "studies/protocol.py",
                                    "_validation.py", "io/recording.py", "runtime/cache.py",
                                    "sim/vca/model.py", "features/spec.py",
                                    "studies/thesis_data/tables.csv"])
def test_the_code_line_changes_with_every_part_the_numbers_depend_on(package_copy, edited):
    """An edit of the Sec. 5.2 measure, the protocol, the checks or the thesis's tables left
    the report's "Code:" line unchanged (it hashed sim and features only)."""
    before = reproduce.code_fingerprints()
    f = package_copy / edited
    f.write_bytes(f.read_bytes() + (b"\n# edited\n" if f.suffix == ".py" else b"\n"))
    fingerprint.parts_fingerprint.cache_clear()
    after = reproduce.code_fingerprints()
    assert after != before
    key = "thesis_data" if f.suffix == ".csv" else "code"
    assert after[key] != before[key] and len(after[key]) == 16
    assert {k: v for k, v in after.items() if k != key} == \
        {k: v for k, v in before.items() if k != key}


def test_the_parts_cover_every_module_a_reproduction_imports():
    code = ("import sys, leakdiag.studies.reproduce, leakdiag.studies.protocol, "
            "leakdiag.report.reproduction; print(sorted({m.split('.')[1] for m in sys.modules "
            "if m.startswith('leakdiag.')}))")
    used = set(eval(subprocess.run([sys.executable, "-c", code], capture_output=True,
                                   text=True, check=True).stdout))
    # _format writes instants as text (words, like report), no number a result holds
    excluded = {"report", "_version", "_fingerprint", "_numba_cache", "_format"}
    parts = {p.removesuffix(".py") for p in reproduce.CODE_PARTS}
    assert used - excluded <= parts, used - excluded - parts
    assert len(fingerprint.parts_fingerprint(reproduce.CODE_PARTS)) == 16
