"""The named protocols: the case studies as the thesis states them (Sec. 5.1, Sec. 6)."""

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

from leakdiag.sim.sensors import THESIS_EHA_SENSORS, THESIS_VCA_SENSORS
from leakdiag.studies.protocol import (
    FULL,
    QUICK,
    THESIS,
    V1,
    build_cases,
    protocol_config,
    simulate_case,
)


def test_thesis_protocol_states_the_case_studies_of_sec_5_1():
    assert FULL is THESIS and THESIS.vca_load == "none"  # "under a no-load condition"
    cases = build_cases(THESIS, ["vca"])
    tables = {c["case_study"]: c["sim"] for c in cases if c["kind"] == "tables"}
    assert tables[1]["reference"] == {"min_amplitude_m": 8e-3, "max_amplitude_m": 20e-3}
    assert tables[2]["reference"] == {"min_amplitude_m": 5e-3, "max_amplitude_m": 17e-3}
    assert tables[1]["load"] == tables[2]["load"] == "none"
    assert (tables[1]["duration"], tables[1]["onset"]) == (400.0, 200.0)
    assert (tables[1]["leak_lpm"], tables[2]["leak_lpm"]) == (0.10, 0.047)
    sens = [c["sim"] for c in cases if c["kind"] == "sensitivity"]
    assert {s["duration"] for s in sens} == {300.0, 400.0, 600.0}
    assert all(s["onset"] == s["duration"] / 2 for s in sens)  # "at about half"
    assert {s["load"] for s in sens} == {"spring", "none"}  # "under load and no-load"
    assert all(s["reference"] == {"min_amplitude_m": 2e-3, "max_amplitude_m": 20e-3}
               for s in sens)
    assert all(c["sim"]["sensor_chain"] == "thesis" for c in cases)


def test_thesis_protocol_states_the_eha_case_studies_of_sec_6():
    cases = build_cases(THESIS, ["eha"])
    tables = {c["case_study"]: c["sim"] for c in cases if c["kind"] == "tables"}
    # Sec. 6 list: "under a no-load condition", leak after 90 s of a 180 s run, 1.2 / 0.98 L/min
    assert {cs: (t["load"], t["duration"], t["onset"], t["leak_lpm"])
            for cs, t in tables.items()} == {1: ("none", 180.0, 90.0, 1.2),
                                             2: ("none", 180.0, 90.0, 0.98)}
    sens = [c["sim"] for c in cases if c["kind"] == "sensitivity"]
    # case study 3: 0.77-1.63 L/min "under load and no-load conditions", 180 s, leak at half
    assert {s["leak_lpm"] for s in sens} >= {0.77, 1.63}
    assert min(s["leak_lpm"] for s in sens) == 0.77 and max(s["leak_lpm"] for s in sens) == 1.63
    assert {s["load"] for s in sens} == {"spring", "none"}
    assert all((s["duration"], s["onset"]) == (180.0, 90.0) for s in sens)
    assert all("reference" not in s for s in sens)  # open loop: the simulator's 3 sin 4t
    assert all(c["sim"]["sensor_chain"] == "thesis" for c in cases)
    assert len(build_cases(THESIS)) == 98  # the committed run's count (docs/reproduction)


def test_v1_protocol_keeps_the_old_cases_bit_for_bit():
    cases = build_cases(V1, ["vca", "eha"])
    first = [c["sim"] for c in cases if c["kind"] == "tables"][0]
    assert first == {"duration": 400.0, "leak_lpm": 0.10, "onset": 200.0, "load": "spring",
                     "seed": 0}  # no reference, no sensor chain: the old cache keys
    assert protocol_config("v1") is V1 and protocol_config("thesis", quick=True) == QUICK
    with pytest.raises(ValueError, match="protocol='x' must be one of"):
        protocol_config("x")
    with pytest.raises(ValueError, match="sensor_chain='y' must be"):
        dataclasses.replace(THESIS, sensor_chain="y")


def test_simulate_case_applies_reference_and_chain(tmp_path):
    case = build_cases(dataclasses.replace(QUICK, cache_dir=str(tmp_path)), ["vca"])[0]
    case["sim"] = {**case["sim"], "duration": 6.0, "onset": 3.0, "leak_lpm": None}
    rec = simulate_case(case)
    ref = np.abs(rec["x_ref"])
    assert ref.min() >= 8e-3 - 1e-12 and ref.max() <= 20e-3 + 1e-12  # case study 1: 8-20 mm
    assert rec.meta["sensors"] == THESIS_VCA_SENSORS.to_dict() and rec.meta["load"] == "none"
    eha = [c for c in build_cases(QUICK, ["eha"]) if c["kind"] == "tables"][0]
    assert eha["sim"]["sensor_chain"] == "thesis" and THESIS_EHA_SENSORS.adc_input_span_v == 20


def test_cli_protocol_option(tmp_path, monkeypatch):
    import importlib

    rep_mod = importlib.import_module("leakdiag.studies.reproduce")
    from leakdiag.cli.main import cli

    seen = {}

    def fake_run(systems, cfg, **kw):
        seen["cfg"] = cfg
        raise ValueError("stop here")

    monkeypatch.setattr(rep_mod, "reproduce", fake_run)
    res = CliRunner().invoke(cli, ["reproduce", "vca", "--protocol", "v1", "--quick"])
    assert isinstance(res.exception, ValueError) and seen["cfg"].name == "v1-quick"
    assert seen["cfg"].vca_load == "spring" and seen["cfg"].sensor_chain == "default"
    CliRunner().invoke(cli, ["reproduce", "vca"])
    assert seen["cfg"].name == "thesis" and seen["cfg"].vca_duration_s == 400.0
    res = CliRunner().invoke(cli, ["reproduce", "vca", "--protocol", "v2"])
    assert res.exit_code == 2 and "'v2' is not one of 'thesis', 'v1'" in res.output


def test_report_compares_with_a_previous_run():
    from types import SimpleNamespace

    import pandas as pd

    from leakdiag.report.html import Report
    from leakdiag.report.reproduction import _changes_section
    from leakdiag.studies.thesis import load_tables

    th = load_tables()
    t = th[th.table.isin(["5-1", "6-9"])]
    new = pd.DataFrame({"system": t.system, "table": t.table, "method": t.method,
                        "signals": t.signals, "varied": t.varied,
                        "direction_agrees": True, "trend_ours": 1, "trend_thesis": 1,
                        "trend_agrees": True, "pct_change": t.pct_change_reported / 2,
                        "thesis_pct_change": t.pct_change_reported})
    old = new.assign(pct_change=new["thesis_pct_change"] / 10, direction_agrees=False)
    r = Report("x")
    _changes_section(SimpleNamespace(tables=new, previous=old), r)
    md = r.to_markdown()
    assert f"Direction agrees in 0 of {len(new)} rows before and {len(new)} of {len(new)} now" \
        in md
    assert "0.1 before, 0.5 now" in md


def test_cross_correlation_signals_in_the_named_order():
    """docs/studies.md "Signals" (decision, thesis audit 2026-11-29): the signal the thesis names
    first is Eq. 4.2's y (paired with the other's later samples); the order changes the value,
    so the study path must keep it. A signal that leads the other by the lag correlates fully
    in this order and not swapped."""
    from leakdiag.features.correlation import cross_correlation
    from leakdiag.features.spec import compute_feature
    from leakdiag.io import Recording
    from leakdiag.studies.protocol import _spec
    from leakdiag.studies.thesis import channels_of

    rng = np.random.default_rng(3)
    lead = rng.standard_normal(2000)
    u = lead[8:]                    # x = u delayed by 8 samples: x_{j+8} = u_j
    x = lead[:-8]
    rec = Recording({"u": u, "x": x, "p1": u, "p2": x}, 1000.0)
    for signals, (a, b) in (("U,X", (u, x)), ("P1,P2", (u, x))):
        assert channels_of(signals) == (("u", "x") if signals == "U,X" else ("p1", "p2"))
        spec = _spec("cross_correlation", ",".join(channels_of(signals)), 8, 200, 5.0)
        got = compute_feature(rec, spec).values
        want = cross_correlation(a, b, lag=8, window=200, overlap=5.0).values
        swapped = cross_correlation(b, a, lag=8, window=200, overlap=5.0).values
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        assert np.all(got > 0.9) and np.all(np.abs(swapped) < 0.5)  # (N - lag) / N at most
