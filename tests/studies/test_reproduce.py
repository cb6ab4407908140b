"""The quick reproduction (CI version of `leakdiag reproduce all --quick`): outputs contract."""

import os
import pickle
import re
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import leakdiag.sim as sim
from leakdiag.cli.main import main
from leakdiag.report.html import check_html
from leakdiag.studies.reproduce import CONTRACT_COLUMNS, NAN_COLUMNS, assemble_tables
from leakdiag.studies.thesis import THESIS_DATA, load_tables

SYSTEMS = [s for s, fn in (("vca", "simulate_vca"), ("eha", "simulate_eha")) if hasattr(sim, fn)]
WHICH = "all" if len(SYSTEMS) == 2 else (SYSTEMS[0] if SYSTEMS else None)


REPO = Path(__file__).resolve().parents[2]
COMMITTED_TABLES = REPO / "docs" / "reproduction" / "tables.csv"


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    if WHICH is None:
        pytest.skip("no simulator available")
    out = tmp_path_factory.mktemp("repro")
    cache = tmp_path_factory.mktemp("cache")
    pkl = tmp_path_factory.mktemp("saved") / "not-yet" / "results.pkl"  # folder made up front
    code = main(["reproduce", WHICH, "--quick", "--out", str(out), "--scheduler", "serial",
                 "--cache-dir", str(cache), "--no-progress", "--save-results", str(pkl),
                 "--previous", str(COMMITTED_TABLES)])
    assert code == 0
    return out, cache, pkl


def test_tables_csv_has_every_thesis_row(quick_run, shared_dir):
    out, *_ = quick_run
    ours = pd.read_csv(out / "tables.csv", dtype={"table": str, "lag": str})
    # the shipped copy: the shared one with Table 5-5 at window 100 (docs/studies.md; the
    # differences are pinned by test_thesis_data.py)
    thesis = pd.read_csv(THESIS_DATA / "tables.csv", dtype={"table": str, "lag": str})
    assert len(thesis) == len(pd.read_csv(shared_dir / "thesis" / "tables.csv"))
    thesis = thesis[thesis.system.str.lower().isin(SYSTEMS)].reset_index(drop=True)
    assert list(ours.columns) == CONTRACT_COLUMNS
    assert len(ours) == len(thesis)
    for c in ("table", "system", "case_study", "method", "signals", "varied", "lag", "window",
              "overlap_pct"):
        assert ours[c].tolist() == thesis[c].tolist(), c
    np.testing.assert_allclose(ours.leak_lpm, thesis.leak_lpm)
    assert set(ours.direction_agrees.unique()) <= {True, False}
    assert ours["pct_change"].notna().all(), "every row must have a measure in --quick"
    signs = np.sign(ours.pct_change_signed).astype(int)
    thesis_signs = np.sign(thesis.mean_rms_after - thesis.mean_rms_before).astype(int)
    assert (ours.direction_agrees == (signs == thesis_signs)).all()
    np.testing.assert_allclose(ours["pct_change"], ours.pct_change_signed.abs())
    # undefined windows disclosed per row and side (thesis audit 2026-11-28, F1)
    for c in NAN_COLUMNS:
        assert ours[c].notna().all(), c
    assert (ours.n_nan_windows_before + ours.n_nan_windows_after <= ours.n_nan_windows).all()
    assert (ours.n_windows_before >= ours.n_chunks_before * ours.chunk).all()
    assert (ours.n_windows_after >= ours.n_chunks_after * ours.chunk).all()
    ux = ours[(ours.system == "VCA") & (ours.signals == "U,X")]
    assert (ux.n_nan_windows > 0).all()  # the encoder's position stands still between steps
    other = ours[ours.signals != "U,X"]
    assert (other.n_nan_windows == 0).all()
    no_nan = ours[ours.n_nan_windows == 0]
    np.testing.assert_allclose(no_nan.pct_change_signed_nan_as_0, no_nan.pct_change_signed)


def test_html_and_markdown_complete(quick_run):
    out, *_ = quick_run
    page = (out / "index.html").read_text()
    check_html(page)
    md = (out / "report.md").read_text()
    tables = pd.read_csv(out / "tables.csv", dtype={"table": str}).table.unique()
    for t in tables:
        assert f"Table {t}:" in page and f"Table {t}:" in md
    n_img = page.count('<img src="data:image/png;base64,')
    pngs = re.findall(r"\]\(figures/([\w.-]+\.png)\)", md)
    assert n_img == len(pngs) >= len(tables)
    assert all((out / "figures" / p).stat().st_size > 1000 for p in pngs)
    # issue 15: figures named after their table, wide enough to read
    import matplotlib.image as mpimg

    assert all(p.startswith(("table-", "stationarity-", "sec-")) for p in pngs), pngs
    for t in tables:
        assert f"table-{t}-series.png" in pngs
    # Table 5-17 is the VCA's sensitivity summary; the EHA's are Secs. 6.1.5-6.4.5 (an audit)
    assert "table-5-17-sensitivity-eha.png" not in pngs
    if "eha" in SYSTEMS:
        assert "sec-6-x-5-sensitivity-eha.png" in pngs
    assert min(mpimg.imread(out / "figures" / p).shape[1] for p in pngs) >= 900
    for section in ("Summary", "Main disagreements", "Preferred settings", "sensitivity",
                    "Stationarity"):
        assert section in page
    agree = pd.read_csv(out / "tables.csv").direction_agrees.sum()
    assert f"agrees with the thesis in {agree} of" in md
    # the undefined windows, pooled over the tables that have them (thesis audit, F1)
    t = pd.read_csv(out / "tables.csv", dtype={"table": str})
    nan_tabs = t.groupby("table", sort=False).filter(lambda g: (g.n_nan_windows > 0).any())
    if len(nan_tabs):
        share_b = 100 * nan_tabs.n_nan_windows_before.sum() / nan_tabs.n_windows_before.sum()
        share_a = 100 * nan_tabs.n_nan_windows_after.sum() / nan_tabs.n_windows_after.sum()
        assert (f"in {nan_tabs.table.nunique()} tables ({', '.join(nan_tabs.table.unique())}); "
                f"pooled over their rows {share_b:.1f} % of the windows before the onset and "
                f"{share_a:.1f} % after it") in md
        assert md.count("| NaN windows before | NaN windows after |") == nan_tabs.table.nunique()
    if "vca" in SYSTEMS:  # the thesis states the U-X range twice (F7); the load (F10)
        assert "Note on the thesis's range for VCA cross-correlation u,x: Table 5-17 says " \
               "20%-63%" in md
        assert "case-study-1 experiment (load: VCA 'none', EHA 'none')" in md
    # the code the numbers come from, so that a committed report can be checked against today's
    from leakdiag._fingerprint import parts_fingerprint
    from leakdiag.studies.reproduce import CODE_PARTS, code_fingerprints
    fp = code_fingerprints()
    assert fp["code"] == parts_fingerprint(CODE_PARTS)
    assert (f"Code: `{fp['code']}` (leakdiag's {', '.join(CODE_PARTS)}), thesis data "
            f"`{fp['thesis_data']}`, libraries {fp['libraries']} ") in md
    # how many simulations the run computed and how many it read from the cache (a fresh
    # cache: cases that share a simulation read it back)
    with open(quick_run[2], "rb") as fh:
        timing = pickle.load(fh)[0].timing
    n, hits = timing["n_cases"], timing["cache_hits"]
    assert n > hits
    assert (f"{n} simulated experiments: {n - hits} simulated in this run, {hits} read from the "
            "simulation cache" if hits else f"{n} simulated experiments, all simulated") in md


def test_second_run_is_all_cache_hits(quick_run, tmp_path):
    _, cache, _ = quick_run
    from leakdiag.studies.protocol import QUICK, build_cases, run_case
    import dataclasses

    cfg = dataclasses.replace(QUICK, cache_dir=str(cache))
    case = build_cases(cfg, SYSTEMS[:1])[0]
    assert run_case(case)["cache_hit"] is True


def test_assemble_tables_hand_case():
    thesis = load_tables()
    t = thesis[thesis.table == "5-3"]  # overlap 5, 25, 50, 75; thesis falls, trend falls
    rows = [{"row_id": rid, "mean_rms_before": 1.0, "mean_rms_after": a,
             "pct_change": abs(a - 1) * 100, "pct_change_signed": (a - 1) * 100,
             "n_windows": 100, "n_chunks_before": 5, "n_chunks_after": 5,
             "n_chunks_straddling": 0, "n_chunks_empty": 0, "n_nan_windows": 0,
             "n_windows_before": 50, "n_windows_after": 50, "n_nan_windows_before": 0,
             "n_nan_windows_after": 0, "pct_change_signed_nan_as_0": (a - 1) * 100,
             "chunk": 10}
            for rid, a in zip(t.row_id, [0.5, 0.6, 1.2, 0.8])]
    out = assemble_tables(t, rows)
    assert out.direction_agrees.tolist() == [True, True, False, True]
    # |% change| 50, 40, 20, 20 along overlap 5..75: falling, like the thesis's.
    assert out.trend_ours.tolist() == [-1] * 4 and out.trend_thesis.tolist() == [-1] * 4
    assert out.trend_agrees.all()
    assert out.thesis_pct_change_signed.iloc[0] == pytest.approx(-42.5222)


def test_saved_results_and_previous_comparison(quick_run):
    out, _, pkl = quick_run
    umask = os.umask(0)
    os.umask(umask)
    assert pkl.stat().st_mode & 0o777 == 0o666 & ~umask  # as open() makes it
    with open(pkl, "rb") as fh:
        rep, command = pickle.load(fh)
    assert command.startswith("leakdiag reproduce")
    assert len(rep.tables) == len(pd.read_csv(out / "tables.csv"))
    md = (out / "report.md").read_text()
    assert "What changed against the previous run" in md
    # the committed run is a full one: the quick run's report says the settings differ
    assert "**The previous run was made with other settings**, so these changes are not the " \
           "code's alone: protocol (VCA): thesis before, thesis-quick now;" in md
    assert not list(pkl.parent.glob(".leakdiag-*"))  # no temporary file left beside it


# ------------------------------------------ audit of the commands' options, 2026-11-27
@pytest.fixture
def no_run(monkeypatch):
    """Everything refused below is refused before the first experiment."""
    import importlib

    rp = importlib.import_module("leakdiag.studies.reproduce")
    monkeypatch.setattr(rp, "reproduce", lambda *a, **k: pytest.fail("the run was started"))


def _last_error(capsys, code):
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    return err.splitlines()[-1]


@pytest.mark.parametrize("args, message", [
    (["--workers", "0", "--scheduler", "local"],  # used to wait at 0 % until killed
     "Error: Invalid value for '--workers': 0 is not in the range x>=1."),
    (["--workers", "-1", "--scheduler", "local"],
     "Error: Invalid value for '--workers': -1 is not in the range x>=1."),
    (["--workers", "2", "--scheduler", "serial"],  # used to be ignored
     "Error: --workers 2 is for --scheduler local (serial runs every case in this process): "
     "drop --workers or give --scheduler local"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"],
     "Error: --workers 2 is for --scheduler local (the scheduler at tcp://127.0.0.1:8786 has "
     "the workers of its own cluster): drop --workers or give --scheduler local"),
    (["--scheduler", "fast"],
     "Error: Invalid value for '--scheduler': 'fast' must be 'serial', 'local' or the address "
     "of a Dask scheduler such as tcp://127.0.0.1:8786"),
])
def test_reproduce_workers_and_scheduler_refused_up_front(no_run, tmp_path, capsys, args,
                                                          message):
    code = main(["reproduce", "vca", "--quick", "--out", str(tmp_path / "rep"), *args])
    assert _last_error(capsys, code) == message
    assert not (tmp_path / "rep").exists()


def test_reproduce_output_paths_checked_before_the_run(no_run, tmp_path, capsys):
    """`--out /proc/x` and `--save-results /proc/x/r.pkl` failed after all the work."""
    (tmp_path / "afile").write_text("")
    bad = tmp_path / "afile" / "rep"
    code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out", str(bad)])
    assert _last_error(capsys, code) == (f"leakdiag: error: --out {bad}: cannot create the "
                                         "folder: Not a directory")
    pkl = tmp_path / "afile" / "r.pkl"
    code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out",
                 str(tmp_path / "rep"), "--save-results", str(pkl)])
    assert _last_error(capsys, code) == (f"leakdiag: error: --save-results {pkl}: "
                                         f"{pkl.parent} is a file, not a folder")
    if Path("/proc/self").is_dir():  # the audit's paths
        code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out", "/proc/x"])
        assert _last_error(capsys, code) == ("leakdiag: error: --out /proc/x: cannot create the "
                                             "folder: No such file or directory")
        code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out",
                     str(tmp_path / "rep2"), "--save-results", "/proc/x/r.pkl"])
        assert _last_error(capsys, code) == (
            "leakdiag: error: --save-results /proc/x/r.pkl: cannot create its folder /proc/x: "
            "No such file or directory")


def _committed():
    return pd.read_csv(COMMITTED_TABLES)


@pytest.mark.parametrize("name, table, message", [
    ("junk.csv", "a,b\n1,2\n",  # used to fail as "leakdiag: error: pct_change" after the run
     "no column system, table, method, signals, varied, direction_agrees, trend_ours, "
     "trend_thesis, trend_agrees, pct_change, thesis_pct_change: not a tables.csv written by "
     "leakdiag reproduce (its columns: a, b)"),
    ("empty.csv", "", "cannot read it as a CSV table (No columns to parse from file)"),
    ("header.csv", lambda: _committed().iloc[:0].to_csv(index=False),
     "no rows: nothing to compare with"),
    ("nopct.csv", lambda: _committed().drop(columns="pct_change").to_csv(index=False),
     "no column pct_change: not a tables.csv written by leakdiag reproduce (its columns: table, "
     "system, case_study, leak_lpm, method, signals, ...)"),
    ("textpct.csv", lambda: _committed().assign(pct_change="x").to_csv(index=False),
     "column pct_change must be numeric (empty for no measure)"),
    ("agree.csv", lambda: _committed().assign(direction_agrees="yes").to_csv(index=False),
     "column direction_agrees must hold True or False in every row"),
    ("eha.csv", lambda: _committed().query("system == 'EHA'").to_csv(index=False),
     "its rows are of EHA, this run is of VCA: nothing to compare"),
    ("trend.csv", lambda: _committed().assign(trend_agrees="maybe").to_csv(index=False),
     "cannot compare with it: Need to pass bool-like values"),
])
def test_reproduce_previous_checked_before_the_run(no_run, tmp_path, capsys, name, table,
                                                   message):
    prev = tmp_path / name
    prev.write_text(table() if callable(table) else table)
    code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out",
                 str(tmp_path / "rep"), "--previous", str(prev)])
    assert _last_error(capsys, code) == f"leakdiag: error: --previous {prev}: {message}"
    assert not (tmp_path / "rep").exists()  # nothing written either


@pytest.mark.skipif(WHICH != "all", reason="needs both simulators")
def test_vca_over_an_all_run_removes_the_eha_figures_only(quick_run, tmp_path, monkeypatch,
                                                          capsys):
    """`reproduce vca --out mix` over an `all` run kept 33 EHA figures beside the VCA report.
    Reproduce's own figures that the new run does not make are removed; other files stay."""
    import importlib

    out, _, pkl = quick_run
    mix = tmp_path / "mix"
    shutil.copytree(out, mix)
    (mix / "notes.txt").write_text("mine")
    (mix / "figures" / "mine.png").write_bytes(b"mine")
    (mix / "figures" / "table-notes.txt").write_text("mine")
    with open(pkl, "rb") as fh:
        rep, _ = pickle.load(fh)
    # the VCA half of the `all` run, as `reproduce vca` would compute it
    vca = rep.tables.system == "VCA"
    rep.systems = ("vca",)
    rep.series = {k: v for k, v in rep.series.items() if k in set(rep.tables.row_id[vca])}
    rep.tables = rep.tables[vca].reset_index(drop=True)
    rep.preferred = rep.preferred[rep.preferred.system == "VCA"].reset_index(drop=True)
    rep.ofat = [o for o in rep.ofat if o["system"] == "vca"]
    rep.sensitivity = rep.sensitivity[rep.sensitivity.system == "vca"].reset_index(drop=True)
    rep.stationarity = {"vca": rep.stationarity["vca"]}
    rep.previous = None
    monkeypatch.setattr(importlib.import_module("leakdiag.studies.reproduce"), "reproduce",
                        lambda *a, **k: rep)
    before = sorted(p.name for p in (mix / "figures").iterdir())
    eha = [n for n in before if "-eha" in n or n.startswith("table-6-")]
    assert len(eha) > 10
    code = main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out", str(mix),
                 "--no-progress"])
    assert code == 0
    lines = capsys.readouterr().out.splitlines()
    assert f"removed {len(eha)} figure(s) of an earlier run from {mix / 'figures'} (this run " \
           f"does not make them): {', '.join(eha[:3])}, ..." in lines
    after = sorted(p.name for p in (mix / "figures").iterdir())
    assert after == sorted(set(before) - set(eha))  # the VCA figures rewritten, the rest kept
    assert {"mine.png", "table-notes.txt"} <= set(after)
    assert (mix / "notes.txt").read_text() == "mine"
    md = (mix / "report.md").read_text()
    assert "Experiments: VCA leaks" in md and "EHA leaks" not in md  # no EHA run described
    assert sorted(re.findall(r"\]\(figures/([\w.-]+\.png)\)", md)) == \
        sorted(set(after) - {"mine.png", "table-notes.txt"})
    # a second run over its own output removes nothing and says nothing about it
    assert main(["reproduce", "vca", "--quick", "--scheduler", "serial", "--out", str(mix),
                 "--no-progress"]) == 0
    assert "removed" not in capsys.readouterr().out


def test_a_report_that_fails_to_build_leaves_the_earlier_files(quick_run, tmp_path,
                                                                monkeypatch):
    """The report is built before any file is written (the CSVs used to be written first)."""
    import leakdiag.report.reproduction as rr

    out, _, pkl = quick_run
    old = tmp_path / "old"
    shutil.copytree(out, old)
    with open(pkl, "rb") as fh:
        rep, _ = pickle.load(fh)
    rep.tables = rep.tables.assign(pct_change=0.0)  # would change tables.csv

    def broken(*a, **k):
        raise ValueError("broken report")

    monkeypatch.setattr(rr, "build_report", broken)
    with pytest.raises(ValueError, match="broken report"):
        rr.write_outputs(rep, old)
    for f in rr.OUTPUT_FILES:
        assert (old / f).read_bytes() == (out / f).read_bytes(), f
    assert sorted(p.name for p in (old / "figures").iterdir()) == \
        sorted(p.name for p in (out / "figures").iterdir())


def test_setting_differences_match_rows_by_table_and_setting():
    """A review (2026-11-27): rows were matched by position, so an EHA-only quick run against
    the committed full run (EHA rows at other positions) matched none and said nothing."""
    from leakdiag.studies.reproduce import setting_differences

    full = pd.read_csv(COMMITTED_TABLES, dtype={"table": str, "lag": str})
    eha = full[full.system == "EHA"].reset_index(drop=True)
    assert setting_differences(eha, full) == []
    quick = eha.assign(n_windows=eha.n_windows // 5)
    assert setting_differences(quick, full) == [
        "windows per experiment differ in 45 of 45 rows shared (tables 6-1, 6-2, 6-3, 6-4, ...)"
        ": other run lengths, e.g. a --quick run against a full one"]
    one_more = pd.concat([full.iloc[:1], full], ignore_index=True)  # positions shifted by one
    assert setting_differences(full, one_more) == []


def test_a_quick_report_says_its_runs_are_shorter_than_the_thesiss(quick_run):
    """An audit (2026-11-29): a --quick report read like the reproduction (60 s / 40 s runs
    against the thesis's 400 s / 180 s, without a word)."""
    out, *_ = quick_run
    md = (out / "report.md").read_text()
    assert md.splitlines()[0].endswith("thesis-quick, --quick: runs shorter than the thesis's)")
    short = {"vca": "VCA 60 s against the thesis's 400 s",
             "eha": "EHA 40 s against the thesis's 180 s"}
    assert (f"**A --quick run**: its case-study runs are shorter than the thesis's ("
            f"{'; '.join(short[s] for s in SYSTEMS)}), so each measure averages fewer RMS "
            "chunks") in md
    for s in SYSTEMS:
        assert f"## {s.upper()}: thesis tables reproduced (--quick: {short[s]})" in md
    assert md.count("s run (shorter than the thesis's") == (16 if "vca" in SYSTEMS else 0) + (
        16 if "eha" in SYSTEMS else 0)


def test_the_report_rebuilt_from_saved_results_is_the_runs(quick_run, tmp_path, capsys):
    """`leakdiag reproduce --from-results PKL --out DIR` writes the run's own report again,
    without simulating (an audit, 2026-11-29: no command read --save-results)."""
    out, _, pkl = quick_run
    again = tmp_path / "again"
    assert main(["reproduce", "--from-results", str(pkl), "--out", str(again)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("rebuilt the report of `leakdiag reproduce") and \
        lines[0].endswith(f"` from {pkl}")
    for f in ("tables.csv", "sensitivity.csv", "preferred.csv", "report.md"):
        assert (again / f).read_bytes() == (out / f).read_bytes(), f
    assert sorted(p.name for p in (again / "figures").iterdir()) == \
        sorted(p.name for p in (out / "figures").iterdir())
    code = main(["reproduce", "eha" if WHICH == "vca" else "vca", "--from-results", str(pkl),
                 "--out", str(again)])
    assert code == 2 and "give its system or none" in capsys.readouterr().err
