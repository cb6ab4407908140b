"""analyze_recording and MethodSpec: the pipeline equals the direct feature + measure calls."""

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.detect.analysis import analyze_recording
from leakdiag.features.spec import MethodSpec, compute_feature, parse_lag_ratio, thesis_defaults


@pytest.fixture(scope="module")
def rec():
    rng = np.random.default_rng(0)
    n, fs = 20_000, 1000.0
    t = np.arange(n) / fs
    leak = t >= 10.0
    # AR(1) noise whose correlation drops after the "leak": a planted change in every feature
    e = rng.standard_normal((n, 2))
    p1 = np.empty(n)
    p1[0] = 0.0
    for i in range(1, n):
        p1[i] = (0.3 if leak[i] else 0.9) * p1[i - 1] + e[i, 0]
    p2 = -0.8 * p1 + 0.5 * e[:, 1]
    x = np.cumsum(e[:, 1]) * 1e-5
    u = np.roll(x, -3) * 100 + 0.01 * rng.standard_normal(n)
    return ld.Recording({"p1": 8.6e6 + 1e4 * p1, "p2": 4e6 + 1e4 * p2, "x": x, "u": u}, fs,
                        meta={"onset": 10.0, "source": "synthetic"})


def test_table_equals_direct_calls(rec):
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    res = analyze_recording(rec, [spec])
    fs = ld.features.autocorrelation(rec["p1"], lag=1, window=200, overlap=5, sample_rate=1000.0)
    direct = ld.detect.rms_change(fs, onset=10.0, chunk=10)
    row = res.table.iloc[0]
    assert row["mean_rms_before"] == pytest.approx(direct.mean_rms_before, rel=1e-12)
    assert row["mean_rms_after"] == pytest.approx(direct.mean_rms_after, rel=1e-12)
    assert row["n_windows"] == len(fs)
    # planted: AR coefficient 0.9 -> 0.3, so the lag-1 autocorrelation falls a lot
    assert row["pct_change_signed"] < -50


def test_all_four_methods_and_moments_rows(rec):
    specs = list(thesis_defaults("vca")) + [MethodSpec("moments", ("p1",), window=400, overlap=50)]
    res = analyze_recording(rec, specs)
    assert res.table["method"].tolist() == [
        "autocorrelation", "cross-correlation", "cross-correlation", "metric-length",
        "moments:mean", "moments:variance", "moments:skewness", "moments:kurtosis"]
    assert res.table["channels"].tolist()[:4] == ["p1", "p1,p2", "u,x", "p1"]
    assert res.table["setting"].tolist()[:4] == ["1", "1", "1", "83:3"]
    # the mean of p1 does not change (AR noise about 8.6e6): moments:mean changes by < 0.1 %
    assert abs(res.table.set_index("method").loc["moments:mean", "pct_change_signed"]) < 0.1
    frame = res.features_frame()
    assert len(frame) == sum(len(s) for s in res.series)


def test_no_onset_gives_table_without_measure(rec):
    r = ld.Recording(dict(rec.channels), rec.sample_rate)
    res = analyze_recording(r, thesis_defaults("vca", "autocorrelation"))
    assert res.onset is None and res.table["mean_rms_before"].isna().all()


def test_missing_channel_error_names_it(rec):
    r = ld.Recording({"p1": rec["p1"]}, rec.sample_rate, meta={"source": "rig.csv"})
    with pytest.raises(ld.io.RecordingError, match=r"rig.csv: missing channel\(s\) \['p2'\]"):
        analyze_recording(r, [MethodSpec("cross-correlation", ("p1", "p2"))], onset=5.0)


def test_too_short_for_window_error():
    r = ld.Recording({"p1": np.arange(50.0)}, 100.0, meta={"source": "short.csv"})
    with pytest.raises(ld.io.RecordingError, match=r"short.csv: recording has 50 samples \(0.5 s\), shorter than one window \(window=200\)"):
        compute_feature(r, MethodSpec("autocorrelation", ("p1",), window=200))


def test_degenerate_warning_names_source_and_method():
    r = ld.Recording({"p1": np.r_[np.ones(400), np.arange(400.0) % 7]}, 1.0, meta={"source": "f.csv"})
    with pytest.warns(RuntimeWarning, match=r"f.csv: autocorrelation p1 1 N=100 0%: 4 of 8 windows"):
        compute_feature(r, MethodSpec("autocorrelation", ("p1",), window=100, overlap=0))


@pytest.mark.parametrize("kw,match", [
    (dict(method="nope"), "unknown method 'nope'"),
    (dict(method="autocorrelation", channels=("p1", "p2")), "takes one channel"),
    (dict(method="cross-correlation", channels=("p1",)), "takes two channels"),
    (dict(method="autocorrelation", lag=200, window=200), "lag=200 must be in"),
    (dict(method="metric-length", lag_ratio="3:83"), "needs l > k >= 1"),
    (dict(method="metric-length", lag_ratio="83:3", window=80), "must be < window=80"),
    (dict(method="metric-length", lag=2), "takes no lag"),
])
def test_method_spec_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        MethodSpec(**kw)


def test_parse_lag_ratio_forms():
    assert parse_lag_ratio("83:3") == parse_lag_ratio((83, 3)) == parse_lag_ratio(" 83 : 3 ") == (83, 3)
    with pytest.raises(ValueError, match="'l:k'"):
        parse_lag_ratio("83-3")


def test_thesis_defaults_match_case_study_2_tables(shared_dir):
    """THESIS_PREFERRED is the setting of each case-study-2 table in tables.csv."""
    t = pd.read_csv(shared_dir / "thesis" / "tables.csv")
    cs2 = t[(t.case_study == 2)].drop_duplicates(["system", "method", "signals"])
    for _, row in cs2.iterrows():
        system = row.system.lower()
        chans = tuple(c.strip().lower() for c in row.signals.split(","))
        specs = [s for s in thesis_defaults(system, row.method)
                 if len(chans) == 1 or s.channels == chans]
        assert specs, (system, row.method, chans)
        s = specs[0]
        assert (s.setting, s.window, s.overlap) == (str(row.lag), int(row.window), float(row.overlap_pct))


def test_overall_decision_judges_both_directions_at_the_split_level():
    """A per-method LEAK at p = 0.006 does not make the overall LEAK with 4 methods (level
    0.0025); an opposite change at p = 0.006 no longer makes it INCONCLUSIVE either (it did)."""
    import pandas as pd

    from leakdiag.detect.analysis import overall_decision

    def table(decision, p, p_opp):
        return pd.DataFrame({"method": ["a", "b", "c", "d"],
                             "decision": [decision, "no-leak", "no-leak", "no-leak"],
                             "p_value": [p, 0.5, 0.5, 0.5],
                             "p_value_opposite": [p_opp, float("nan"), float("nan"),
                                                  float("nan")]})

    dec, why = overall_decision(table("leak", 0.006, float("nan")), 0.01)
    assert dec == "no-leak" and "(a below 0.01 alone, not below the split level)" in why
    dec, why = overall_decision(table("inconclusive", 0.99, 0.006), 0.01)
    assert dec == "no-leak" and ("(a: a change opposite to a leak's below 0.01 alone, not "
                                 "below the split level)") in why
    assert overall_decision(table("inconclusive", 0.99, 0.001), 0.01)[0] == "inconclusive"
    # not tested (too few chunks to reach the level): inconclusive
    assert overall_decision(table("inconclusive", float("nan"), float("nan")), 0.01)[0] == \
        "inconclusive"
    assert overall_decision(table("leak", 0.001, float("nan")), 0.01)[0] == "leak"
    # a table written before the column existed keeps its inconclusive rows
    old = table("inconclusive", 0.99, 0.006).drop(columns="p_value_opposite")
    assert overall_decision(old, 0.01)[0] == "inconclusive"


@pytest.mark.filterwarnings("ignore:.*have zero variance")
def test_opposite_change_reaches_the_overall_decision_through_analyze_recording():
    """End to end (found by an audit session, 2026-11-27): Decision.as_dict and the verdict
    table's columns dropped p_value_opposite, so a healthy run whose metric length fell at
    p = 0.0062 (opposite to a leak, not below the split level 0.0025) was INCONCLUSIVE overall
    instead of NO LEAK; the table-level test above did not see it."""
    from leakdiag.detect.analysis import analyze_recording, overall_decision
    from leakdiag.features.spec import thesis_defaults

    recs = [ld.sim.simulate_vca(duration=120, leak_lpm=0.0, seed=s) for s in (105, 106, 107)]
    a = analyze_recording(recs[0], thesis_defaults("vca"), healthy=recs[1:],
                          false_alarm_rate=0.01)
    row = a.table.set_index("method").loc["metric-length"]
    assert row["decision"] == "inconclusive"
    assert 0.0025 <= row["p_value_opposite"] < 0.01
    assert f"(p={row['p_value_opposite']:.3g})" in row["reason"]
    dec, why = overall_decision(a.table, 0.01)
    assert dec == "no-leak" and "metric-length: a change opposite to a leak's" in why


# ------------------------- too few chunks: INCONCLUSIVE with the counts, for one method as many
def _noise(n, seed, rate=1000.0, source=None):
    rng = np.random.default_rng(seed)
    meta = {"source": source} if source else {}
    return ld.Recording({"p1": 1e6 + 1e3 * rng.standard_normal(n)}, rate, meta=meta)


def test_one_method_too_short_for_the_measure_is_inconclusive_not_an_error():
    """It raised for a single method and was INCONCLUSIVE among several (found by an audit,
    2026-11-27). 3000 samples, N=200, 5 %: 15 windows; onset 1.5 s: one whole chunk of 10,
    straddling the onset."""
    from leakdiag.detect.measure import TooFewChunksError

    rec = _noise(3000, 1)
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    fs = compute_feature(rec, spec)
    with pytest.raises(TooFewChunksError) as info:
        ld.detect.rms_change(fs, onset=1.5, chunk=10)
    for specs in ([spec], [spec, MethodSpec("autocorrelation", ("p1",), lag=2)]):
        row = analyze_recording(rec, specs, onset=1.5).table.iloc[0]
        assert (row["decision"], row["basis"]) == ("inconclusive", "before-after")
        assert row["reason"] == str(info.value)
        assert "got 0 before and 0 after (15 windows, 1 whole chunk of 10: 1 straddling " \
               "the onset, 5 windows left over)" in row["reason"]
        p = info.value.partial  # the row's counts are rms_change's
        assert (row["n_windows"], row["n_chunks_before"], row["n_chunks_after"],
                row["n_chunks_straddling"], row["n_chunks_empty"]) == (
            p.n_windows, p.n_chunks_before, p.n_chunks_after, p.n_chunks_straddling,
            p.n_chunks_empty) == (15, 0, 0, 1, 0)
        assert np.isnan(row["pct_change"]) and np.isnan(row["p_value"])


def test_healthy_reference_too_short_says_windows_and_chunk_in_the_reason():
    """It said 'too few chunks (0 reference, 0 tested): the smallest p-value the test can give,
    1' after two bare numpy warnings (warnings are errors in this suite). N=500, 5 %: step 475,
    3000 samples give 6 windows, fewer than one chunk of 10."""
    spec = MethodSpec("metric-length", ("p1",), lag_ratio="83:3", window=500, overlap=5)
    rec = _noise(3000, 2)
    refs = [_noise(3000, 3, source="/data/h1.txt")]
    row = analyze_recording(rec, [spec], healthy=refs).table.iloc[0]
    assert (row["decision"], row["basis"], row["n_reference"], row["n_test"]) == (
        "inconclusive", "healthy", 0, 0)
    assert row["reason"] == (
        "too few chunks to test (0 reference, 0 tested): the file has 6 windows, fewer than one "
        "chunk of 10; the healthy reference h1.txt has 6 windows, fewer than one chunk of 10; "
        "use a smaller chunk (--chunk), or more windows (a smaller --window or a larger "
        "--overlap)")
    # a longer file: (20000 - 500) // 475 + 1 = 42 windows, 4 whole chunks, 2 left over
    row = analyze_recording(_noise(20_000, 8), [spec], healthy=refs).table.iloc[0]
    assert (row["n_reference"], row["n_test"]) == (0, 4)
    assert row["reason"].startswith(
        "too few chunks to test (0 reference, 4 tested): the file has 42 windows, 4 whole "
        "chunks of 10: 2 windows left over; the healthy reference h1.txt has 6 windows, fewer "
        "than one chunk of 10; ")
    refs = [_noise(3000, s) for s in (3, 4)]
    row = analyze_recording(rec, [spec], onset=1.5, healthy=refs).table.iloc[0]
    assert row["reason"] == (
        "too few chunks to test (0 reference, 0 tested): the file has 0 whole chunks of 10 "
        "after the onset (1.5 s; 6 windows, fewer than one chunk of 10); the 2 healthy "
        "references make 0 whole chunks of 10 from 12 windows (at most 6 per file); use a "
        "smaller chunk (--chunk), or more windows (a smaller --window or a larger --overlap)")


def test_healthy_references_judge_the_chunks_after_an_onset_with_none_before():
    """With healthy references the decision needs no chunk before the onset: an onset 0.3 s
    into the file still gets its test (it was INCONCLUSIVE, or an error for one method)."""
    from leakdiag.detect.measure import chunk_rms, decide_change

    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=100, overlap=0)
    rec = _noise(20_000, 5)
    refs = [_noise(20_000, s) for s in (6, 7)]
    row = analyze_recording(rec, [spec], onset=0.3, healthy=refs).table.iloc[0]
    fs = compute_feature(rec, spec)
    ref = np.concatenate([chunk_rms(compute_feature(r, spec).values, 10)[0] for r in refs])
    # windows of 100 samples from 0: the first after 0.3 s is window 3; chunk 0 straddles
    want = decide_change(ref, chunk_rms(fs.values, 10)[0][1:], direction="down",
                         basis="healthy")
    assert (row["n_chunks_before"], row["n_chunks_after"], row["n_chunks_straddling"]) == (
        0, 19, 1)
    assert (row["decision"], row["basis"], row["n_reference"], row["n_test"]) == (
        want.decision, "healthy", 40, 19)
    assert row["p_value"] == want.p_value and np.isnan(row["pct_change"])


def test_a_row_without_a_measure_has_no_result_to_draw():
    """Analysis.results stays None for such a row (a figure would draw 'mean RMS before nan')."""
    rec = _noise(3000, 1)
    specs = [MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5),
             MethodSpec("autocorrelation", ("p1",), lag=1, window=100, overlap=50)]
    a = analyze_recording(rec, specs, onset=1.5)
    assert a.results[0] is None and a.table.loc[0, "n_chunks_straddling"] == 1
    fs = compute_feature(rec, specs[1])
    want = ld.detect.rms_change(fs, onset=1.5, chunk=10)
    assert a.results[1].mean_rms_before == want.mean_rms_before
    assert a.table.loc[1, "pct_change_signed"] == want.pct_change_signed


def _ccf_rises(system):
    """P1 and P2 sharing more of one slow signal after 100 s: their cross-correlation's RMS
    rises, as in the thesis's EHA tables (Table 6-8: 0.470 -> 0.515)."""
    from scipy.signal import lfilter

    from leakdiag.io import Recording

    rng = np.random.default_rng(3)
    n = 20000
    z = lfilter([1.0], [1.0, -0.99], rng.normal(size=n))
    z /= z.std()
    w = np.where(np.arange(n) < n // 2, 0.6, 1.2)
    p1 = w * z + rng.normal(size=n)
    p2 = w * z + rng.normal(size=n)
    meta = {} if system is None else {"system": system}
    return Recording({"p1": p1, "p2": p2}, 100.0, meta=meta)


@pytest.mark.parametrize("system, expected", [("vca", "inconclusive"), (None, "inconclusive"),
                                              ("eha", "leak")])
def test_the_decision_direction_follows_the_rig(system, expected):
    """The VCA's tables (Ch. 5) have the cross-correlation fall after a leak; the EHA's
    (Ch. 6) have it rise in 22 of 23 rows, and this package's EHA simulator has it fall: an
    EHA's features are tested two-sided, the VCA's (and an unknown rig's) one-sided, where a
    rise reads 'inconclusive' (an audit: a Table 6-8-like rise was 'inconclusive' on the EHA)."""
    spec = MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=200, overlap=0)
    rec = _ccf_rises(system)
    row = analyze_recording(rec, spec, onset=100.0).table.iloc[0]
    assert row["pct_change_signed"] > 10
    assert row["decision"] == expected
    # the rig given to the call wins over the recording's word
    assert analyze_recording(rec, spec, onset=100.0, system="eha").table.iloc[0]["decision"] \
        == "leak"


def test_no_leak_needs_a_method_that_could_reach_the_split_level():
    """A statistics audit: three methods, each with 8 reference and 2 tested chunks, all at the
    smallest p the test can give (1/C(10, 2) = 0.0222, 'leak' at 0.05 alone); the split level
    0.05/3 = 0.0167 cannot be reached, yet the overall decision read NO LEAK."""
    from leakdiag.detect.analysis import overall_decision
    from leakdiag.detect.measure import decide_change

    ref, low = np.linspace(1.0, 1.2, 8), np.array([0.1, 0.2])
    rows = [{"method": m, **decide_change(ref, low, false_alarm_rate=0.05,
                                          direction="down").as_dict()}
            for m in ("acf-p1", "ccf-p1p2", "mlr-p1")]
    dec, why = overall_decision(pd.DataFrame(rows), 0.05)
    assert dec == "inconclusive"
    assert why.startswith("too few chunks for the split level: the smallest p-value acf-p1, "
                          "ccf-p1p2, mlr-p1 can give (0.0222 at best) is not below 0.0167")
    # one method with enough chunks that saw nothing: its NO LEAK stands
    ref2 = np.linspace(1.0, 1.2, 30)
    rows[0] = {"method": "acf-p1", **decide_change(ref2, ref2[::3] + 0.001,
                                                   false_alarm_rate=0.05,
                                                   direction="down").as_dict()}
    assert overall_decision(pd.DataFrame(rows), 0.05)[0] == "no-leak"


def test_an_inconclusive_overall_names_a_method_that_reads_leak_alone():
    """A CLI audit (2026-11-28, finding 3): a method line read LEAK at the full rate while the
    overall line said INCONCLUSIVE at the split level with no word of it."""
    import pandas as pd

    from leakdiag.detect.analysis import overall_decision

    t = pd.DataFrame({"method": ["a", "b"], "decision": ["leak", "inconclusive"],
                      "p_value": [0.008, float("nan")],
                      "p_value_opposite": [float("nan"), float("nan")]})
    assert overall_decision(t, 0.01) == (
        "inconclusive", "inconclusive: b (a below 0.01 alone, not below the split level); 2 "
        "method(s), each at 0.005 so that the overall false-alarm rate per run is 0.01")


@pytest.mark.filterwarnings("ignore::leakdiag.features._degenerate.DegenerateWindowWarning")
def test_a_no_leak_resting_on_few_defined_windows_is_inconclusive():
    """A user-data audit (2026-11-29): ``analyze`` read NO LEAK on a file whose pressure sensor
    was stuck (constant) over 9 of its 15 windows, where ``detect`` refused the NO LEAK; the
    same rule now refuses it here, per row and overall (the rule of
    :func:`leakdiag.detect.blind_rules.blind_rule`)."""
    from leakdiag.detect.analysis import analyze_recording, overall_decision
    from leakdiag.io import Recording

    rng = np.random.default_rng(5)
    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=0)
    healthy = [Recording({"p1": rng.standard_normal(20000)}, 1000.0) for _ in range(3)]
    p1 = rng.standard_normal(20000)
    a = analyze_recording(Recording({"p1": p1}, 1000.0), spec, healthy=healthy)
    assert a.table.loc[0, "decision"] == "no-leak" and a.table.loc[0, "blind"] is None
    stuck = p1.copy()
    stuck[4000:15000] = 3.0  # 55 of the 100 windows constant (11 s: longer than the 10-s floor)
    a = analyze_recording(Recording({"p1": stuck}, 1000.0), spec, healthy=healthy)
    row = a.table.loc[0]
    assert row["n_nan_windows"] == 55 and row["decision"] == "inconclusive"
    assert "undefined for 11 s in a row" in row["reason"] and "stuck sensor" in row["reason"]
    assert overall_decision(a.table)[0] == "inconclusive"
    # 4 s stuck: 20 of 100 windows, a span under the floor: judged as before
    short = p1.copy()
    short[4000:8000] = 3.0
    a = analyze_recording(Recording({"p1": short}, 1000.0), spec, healthy=healthy)
    assert a.table.loc[0, "decision"] == "no-leak"
    # without healthy references the file's own windows, before and after the onset
    stuck = p1.copy()
    stuck[2000:14000] = 3.0  # 60 of 100 windows, from before to after the onset
    a = analyze_recording(Recording({"p1": stuck}, 1000.0), spec, onset=10.0, chunk=2)
    assert a.table.loc[0, "decision"] == "inconclusive", a.table.loc[0, "reason"]
    assert overall_decision(a.table)[0] == "inconclusive"
