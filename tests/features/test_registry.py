"""The feature registry: one record per feature, read by specs, grids, streaming and the CLI.

The toy feature of ``toy_feature.py`` (one kernel, one record) is registered here and must be
seen, with hand-checked numbers, by ``leakdiag analyze``, ``leakdiag sweep`` and
``leakdiag monitor`` (issue 16's acceptance test).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import leakdiag as ld
from leakdiag.cli.main import main
from leakdiag.features import (
    FeatureRecord,
    MethodSpec,
    compute_feature,
    feature_names,
    feature_record,
    register_feature,
    unregister_feature,
)
from leakdiag.features.registry import compute, normalize_method, values_at
from leakdiag.stream import StreamingFeature
from leakdiag.studies.grid import grid

from .toy_feature import RECORD


def mai_reference(x, lag, window, starts):
    """The toy feature by its definition, window by window."""
    return np.array([np.abs(x[s + lag:s + window] - x[s:s + window - lag]).mean() for s in starts])


@pytest.fixture
def toy():
    register_feature(RECORD)
    yield RECORD
    unregister_feature(RECORD.name)


@pytest.fixture(scope="module")
def toy_file(tmp_path_factory):
    # increments of size 1 before t = 1 s, of size 3 after: the toy feature triples there
    n, rate = 2000, 1000.0
    steps = np.where(np.arange(n) < 1000, 1.0, 3.0) * np.where(np.arange(n) % 2, 1.0, -1.0)
    p1 = 1e6 + np.cumsum(steps)
    rec = ld.Recording({"p1": p1, "p2": p1[::-1].copy()}, rate)
    path = tmp_path_factory.mktemp("toy") / "toy.csv"
    rec.to_pandas().to_csv(path, index=False)
    return path, ld.io.read_recording(path)


def test_builtin_records_and_spellings():
    assert feature_names() == ("autocorrelation", "cross-correlation", "metric-length", "moments")
    assert feature_names(streamable=True) == feature_names(single=True) == feature_names()[:3]
    for spelling, name in [("ACF", "autocorrelation"), ("cross_correlation", "cross-correlation"),
                           ("ccf", "cross-correlation"), ("ratio_of_metric_lengths", "metric-length"),
                           ("metric_length_ratio", "metric-length"), ("moments", "moments")]:
        assert normalize_method(spelling) == name
    rec = feature_record("metric_length")
    assert (rec.setting, rec.default_setting, rec.direction, rec.n_channels) == \
        ("lag_ratio", (83, 3), "up", None)
    assert feature_record("moments").outputs == ("mean", "variance", "skewness", "kurtosis")
    assert ld.detect.measure.EXPECTED_DIRECTION == {
        "autocorrelation": "down", "cross-correlation": "down", "metric-length": "up"}
    with pytest.raises(ValueError, match="unknown method 'wavelet'"):
        feature_record("wavelet")


def test_record_checks_settings_and_channels():
    acf = feature_record("autocorrelation")
    assert acf.check_setting(None) == 1 and acf.check_setting("4", window=10) == 4
    with pytest.raises(ValueError, match=r"lag=10 must be in \[1, 10\)"):
        acf.check_setting(10, window=10)
    with pytest.raises(ValueError, match="is a lag ratio"):
        acf.check_setting("83:3")
    ml = feature_record("metric-length")
    assert ml.check_setting(" 43 : 3 ", window=400) == (43, 3)
    with pytest.raises(ValueError, match="l=83 must be < window=50"):
        ml.check_setting(None, window=50)
    with pytest.raises(ValueError, match="takes no lag or lag ratio"):
        feature_record("moments").check_setting(3)
    assert feature_record("ccf").check_channels("u, x") == ("u", "x")
    with pytest.raises(ValueError, match=r"takes two channels \(y, x\), got \('p1',\)"):
        feature_record("ccf").check_channels(["p1"])
    with pytest.raises(ValueError, match="takes no lag"):
        MethodSpec("moments", lag=2)


def test_registration_refuses_taken_names_and_bad_records(toy):
    with pytest.raises(ValueError, match=r"already registered: \{'mai': 'mean-abs-increment'\}"):
        register_feature(FeatureRecord("other", RECORD.kernel, aliases=("mai",)))
    with pytest.raises(ValueError, match="spelling"):
        register_feature(RECORD)
    register_feature(RECORD, replace=True)  # replacing is explicit
    with pytest.raises(TypeError, match="must be a FeatureRecord"):
        register_feature({"name": "x"})
    with pytest.raises(ValueError, match="cannot be streamable"):
        FeatureRecord("two", RECORD.kernel, outputs=("a", "b"))
    with pytest.raises(ValueError, match="do not match n_channels=2"):
        FeatureRecord("two", RECORD.kernel, channels=("p1",), n_channels=2)


def test_toy_batch_and_at_are_derived_from_the_kernel(toy):
    rng = np.random.default_rng(0)
    x = rng.normal(size=503)
    fs = compute(toy, [x], 3, window=50, overlap=10, sample_rate=100.0, start_time=2.0,
                 channels=("p1",))
    starts = np.arange(0, 503 - 50 + 1, 45)  # step = 50 - round(5.0) = 45
    np.testing.assert_allclose(fs.values, mai_reference(x, 3, 50, starts), rtol=1e-12)
    np.testing.assert_allclose(fs.time, 2.0 + (starts + 49) / 100.0)
    assert (fs.name, dict(fs.settings), fs.window, fs.step, fs.channels) == \
        ("mean-abs-increment", {"lag": 3}, 50, 45, ("p1",))
    any_order = np.array([400, 0, 7, 400])
    np.testing.assert_allclose(values_at(toy, [x], 3, any_order, 50),
                               mai_reference(x, 3, 50, any_order), rtol=1e-12)
    with pytest.raises(ValueError, match=r"starts\[0\]=500 must be in \[0, 453\]"):
        values_at(toy, [x], 3, [500], 50)
    with pytest.raises(ValueError, match="lag=50 must be in"):
        compute(toy, [x], 50, window=50, overlap=0)


def test_toy_in_spec_and_streaming(toy, toy_file):
    _, rec = toy_file
    spec = MethodSpec("mai", lag=1, window=100, overlap=0)
    assert (spec.method, spec.channels, spec.label) == \
        ("mean-abs-increment", ("p1",), "mean-abs-increment p1 1 N=100 0%")
    fs = compute_feature(rec, spec)
    # |x[j+1] - x[j]| is the step size: 1 in the ten windows before sample 1000, 3 after
    np.testing.assert_allclose(fs.values, [1.0] * 10 + [3.0] * 10, rtol=1e-12)
    sf = StreamingFeature(spec, sample_rate=rec.sample_rate)
    pieces = [sf.push({"p1": rec["p1"][i:i + 77]}) for i in range(0, rec.n_samples, 77)]
    np.testing.assert_allclose(np.concatenate([p.values for p in pieces]), fs.values, rtol=1e-12)
    np.testing.assert_allclose(np.concatenate([p.time for p in pieces]), fs.time)
    # the pushed series carry the same typed geometry and settings as the batch one
    for p in pieces:
        assert p.geometry() == fs.geometry() and dict(p.settings) == dict(fs.settings) == {"lag": 1}
        assert p.name == fs.name and isinstance(p.settings, type(fs.settings))


def test_toy_seen_by_analyze_sweep_and_monitor(toy, toy_file, tmp_path, capsys):
    path, rec = toy_file
    x = rec["p1"]
    # analyze: the feature values and the Sec. 5.2 measure of the toy
    out = tmp_path / "a"
    assert main(["analyze", str(path), "--method", "mean-abs-increment", "--lag", "1",
                 "--window", "100", "--overlap", "0", "--onset", "1.0", "--chunk", "2",
                 "-o", str(out)]) == 0
    text = capsys.readouterr().out
    feats = pd.read_parquet(out / "features.parquet")
    np.testing.assert_allclose(feats["value"], mai_reference(x, 1, 100, np.arange(0, 1901, 100)))
    assert set(feats["value"].round(12)) == {1.0, 3.0}  # |increments| 1 before, 3 after
    verdict = pd.read_csv(out / "verdict.csv")
    assert verdict.loc[0, "method"] == "mean-abs-increment"
    assert verdict.loc[0, "pct_change_signed"] == pytest.approx(200.0)
    assert "mean-abs-increment" in text
    # sweep: the grid over lag and window, each row the measure of its setting
    out = tmp_path / "s"
    assert main(["sweep", str(path), "-m", "mai", "-c", "p1", "--lags", "1,3",
                 "--windows", "50,100", "--overlaps", "0", "--mode", "grid", "--onset", "1.0",
                 "--chunk", "2", "-o", str(out), "--no-figures"]) == 0
    t = pd.read_csv(out / "sweep.csv")
    assert list(t["method"].unique()) == ["mean-abs-increment"]
    assert sorted(zip(t["lag"], t["window"])) == [(1, 50), (1, 100), (3, 50), (3, 100)]
    # |x[j+3] - x[j]| is one step: 1 before, 3 after, so +200 % at every setting
    np.testing.assert_allclose(t["pct_change_signed"], 200.0)
    # monitor: the streamed values, one JSON line per window, equal the batch ones
    events = tmp_path / "events.jsonl"
    assert main(["monitor", "-i", str(path), "-m", "mai", "--lag", "1", "--window", "100",
                 "--overlap", "0", "--chunk", "333", "--events", str(events), "-q"]) == 0
    lines = [json.loads(ln) for ln in events.read_text().splitlines()]
    values = [ln["value"] for ln in lines if "value" in ln]
    np.testing.assert_allclose(values, feats["value"])


def test_unregistered_toy_is_refused_by_the_cli(toy_file, capsys):
    path, _ = toy_file
    assert "mean-abs-increment" not in feature_names()
    assert main(["analyze", str(path), "--method", "mean-abs-increment"]) == 2
    assert "'mean-abs-increment' is not one of 'autocorrelation'" in capsys.readouterr().err


def test_moments_cannot_be_monitored_or_swept(toy_file, capsys):
    path, _ = toy_file
    assert main(["monitor", "-i", str(path), "-m", "moments", "-q"]) == 2
    assert "'moments' is not one of" in capsys.readouterr().err
    with pytest.raises(ValueError, match="a grid sweeps single-valued features"):
        grid(ld.io.read_recording(path), "moments", "p1", [1], [100], [0],
                             onset=1.0)
