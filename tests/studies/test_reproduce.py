"""The quick reproduction (CI version of `leakdiag reproduce all --quick`): outputs contract."""

import re

import numpy as np
import pandas as pd
import pytest

import leakdiag.sim as sim
from leakdiag.cli.main import main
from leakdiag.report.html import check_html
from leakdiag.studies.reproduce import CONTRACT_COLUMNS, assemble_tables
from leakdiag.studies.thesis import load_tables

SYSTEMS = [s for s, fn in (("vca", "simulate_vca"), ("eha", "simulate_eha")) if hasattr(sim, fn)]
WHICH = "all" if len(SYSTEMS) == 2 else (SYSTEMS[0] if SYSTEMS else None)


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    if WHICH is None:
        pytest.skip("no simulator available")
    out = tmp_path_factory.mktemp("repro")
    cache = tmp_path_factory.mktemp("cache")
    code = main(["reproduce", WHICH, "--quick", "--out", str(out), "--scheduler", "serial",
                 "--cache-dir", str(cache), "--no-progress"])
    assert code == 0
    return out, cache


def test_tables_csv_has_every_thesis_row(quick_run, shared_dir):
    out, _ = quick_run
    ours = pd.read_csv(out / "tables.csv", dtype={"table": str, "lag": str})
    thesis = pd.read_csv(shared_dir / "thesis" / "tables.csv", dtype={"table": str, "lag": str})
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


def test_html_and_markdown_complete(quick_run):
    out, _ = quick_run
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

    assert all(p.startswith(("table-", "stationarity-")) for p in pngs), pngs
    for t in tables:
        assert f"table-{t}-series.png" in pngs
    assert min(mpimg.imread(out / "figures" / p).shape[1] for p in pngs) >= 900
    for section in ("Summary", "Main disagreements", "Preferred settings", "sensitivity",
                    "Stationarity"):
        assert section in page
    agree = pd.read_csv(out / "tables.csv").direction_agrees.sum()
    assert f"agrees with the thesis in {agree} of" in md
    # the code the numbers come from, so that a committed report can be checked against today's
    from leakdiag.runtime.cache import code_fingerprint
    from leakdiag.studies.reproduce import code_fingerprints
    fp = code_fingerprints()
    assert fp["sim"] == code_fingerprint(sim.simulate_eha) != fp["features"]
    assert f"Code: simulators `{fp['sim']}`, features `{fp['features']}`" in md


def test_second_run_is_all_cache_hits(quick_run, tmp_path):
    _, cache = quick_run
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
             "n_chunks_straddling": 0, "chunk": 10}
            for rid, a in zip(t.row_id, [0.5, 0.6, 1.2, 0.8])]
    out = assemble_tables(t, rows)
    assert out.direction_agrees.tolist() == [True, True, False, True]
    # |% change| 50, 40, 20, 20 along overlap 5..75: falling, like the thesis's.
    assert out.trend_ours.tolist() == [-1] * 4 and out.trend_thesis.tolist() == [-1] * 4
    assert out.trend_agrees.all()
    assert out.thesis_pct_change_signed.iloc[0] == pytest.approx(-42.5222)
