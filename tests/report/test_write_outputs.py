"""Output paths of ``leakdiag reproduce`` checked before the run, and written all or nothing.

An audit (2026-11-29): with a file named ``OUT/figures``, the run failed only after every
simulation, with a bare ``[Errno 17] File exists``, and left the new CSVs beside the earlier
run's report.
"""

import importlib
import os
from types import SimpleNamespace

import pandas as pd
import pytest

import leakdiag.report.reproduction as rr
from leakdiag.cli.main import main
from leakdiag.report.html import Report


def _report(*a, **k):
    """A small report with one figure (what build_report would return, quickly)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = Report("new")
    r.paragraph("new run")
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    r.figure(fig, "a figure", name="table-5-1-series")
    return r


def _rep():
    t = pd.DataFrame({"row_id": [1], "table": ["5-1"], "value": ["new"]})
    return SimpleNamespace(tables=t, sensitivity=pd.DataFrame({"value": ["new"]}),
                           preferred=pd.DataFrame({"value": ["new"]}))


@pytest.fixture
def earlier(tmp_path):
    """An output folder holding an earlier run's files (each says "old")."""
    out = tmp_path / "rep"
    (out / "figures").mkdir(parents=True)
    for f in rr.OUTPUT_FILES:
        (out / f).write_text("old")
    (out / "figures" / "table-5-1-series.png").write_text("old")
    return out


def _contents(out):
    return {str(p.relative_to(out)): p.read_text() for p in sorted(out.rglob("*"))
            if p.is_file()}


def test_outputs_replace_the_earlier_ones_through_a_staging_folder(earlier, monkeypatch):
    monkeypatch.setattr(rr, "build_report", _report)
    paths = rr.write_outputs(_rep(), earlier)
    assert sorted(p.name for p in earlier.iterdir()) == sorted([*rr.OUTPUT_FILES, "figures"])
    assert (earlier / "tables.csv").read_text() == "table,value\n5-1,new\n"
    assert "new run" in (earlier / "report.md").read_text()
    png = (earlier / "figures" / "table-5-1-series.png").read_bytes()
    assert png.startswith(b"\x89PNG")
    assert paths["tables"] == earlier / "tables.csv" and paths["removed"] == []


@pytest.mark.parametrize("fail_at", [1, 4, 6])
def test_a_failed_move_puts_the_earlier_files_back(earlier, monkeypatch, fail_at):
    """The third file moved in fails: the two moved before it are the earlier ones again."""
    monkeypatch.setattr(rr, "build_report", _report)
    before = _contents(earlier)
    real, calls = os.replace, []

    def replace(src, dst):
        if str(src).startswith(str(earlier / ".leakdiag-staging-")) and ".earlier" not in \
                str(src) and ".earlier" not in str(dst):
            calls.append(dst)
            if len(calls) == fail_at:
                raise OSError(28, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="No space left on device"):
        rr.write_outputs(_rep(), earlier)
    assert len(calls) == fail_at
    assert _contents(earlier) == before  # no mix of old and new, no staging folder left
    assert sorted(p.name for p in earlier.iterdir()) == sorted([*rr.OUTPUT_FILES, "figures"])


def test_a_report_that_fails_to_write_leaves_the_earlier_files(earlier, monkeypatch):
    """The CSVs used to be written before the report: a failing report left new CSVs beside
    the earlier report."""
    monkeypatch.setattr(rr, "build_report", _report)
    before = _contents(earlier)

    def broken(self, *a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Report, "write", broken)
    with pytest.raises(OSError, match="No space left"):
        rr.write_outputs(_rep(), earlier)
    assert _contents(earlier) == before
    assert sorted(p.name for p in earlier.iterdir()) == sorted([*rr.OUTPUT_FILES, "figures"])


@pytest.mark.parametrize("make, message", [
    (lambda out: (out / "figures").write_text(""), "{out}/figures exists and is not a folder"),
    (lambda out: (out / "index.html").mkdir(), "{out}/index.html exists and is a folder, not "
                                               "a file"),
    (lambda out: (out / "tables.csv").mkdir(), "{out}/tables.csv exists and is a folder, not "
                                               "a file"),
])
def test_output_paths_named_before_the_run(tmp_path, monkeypatch, capsys, make, message):
    rp = importlib.import_module("leakdiag.studies.reproduce")
    monkeypatch.setattr(rp, "reproduce", lambda *a, **k: pytest.fail("the run was started"))
    out = tmp_path / "rep"
    out.mkdir()
    make(out)
    code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.splitlines() == [f"leakdiag: error: --out {out}: " + message.format(out=out)]


def test_a_figures_file_is_named_by_write_outputs_before_the_report_is_built(tmp_path,
                                                                           monkeypatch):
    monkeypatch.setattr(rr, "build_report", lambda *a, **k: pytest.fail("built the report"))
    (tmp_path / "figures").write_text("")
    with pytest.raises(OSError, match=f"^out_dir {tmp_path}: {tmp_path}/figures exists and is "
                                      "not a folder$"):
        rr.write_outputs(_rep(), tmp_path)


def test_report_write_names_a_figure_folder_that_is_a_file(tmp_path):
    (tmp_path / "figures").write_text("")
    with pytest.raises(OSError, match=f"^{tmp_path}/figures exists and is not a folder$"):
        _report().write(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figures"]  # nothing written
