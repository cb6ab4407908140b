"""Tests of the on-disk simulation cache: a changed parameter misses, an unchanged one hits."""

import dataclasses

import numpy as np
import pytest

from leakdiag.io.recording import Recording
from leakdiag.runtime import cache as C

CALLS = []


@dataclasses.dataclass(frozen=True)
class Params:
    area_m2: float = 1e-3
    gain: float = 2.0


def fake_sim(duration, leak_lpm, seed, params=Params()):
    CALLS.append((duration, leak_lpm, seed))
    rng = np.random.default_rng(seed)
    n = int(duration * 10)
    return Recording({"p1": rng.normal(size=n) * params.gain + leak_lpm,
                      "x": np.arange(n, dtype=float)}, 10.0,
                     meta={"onset": duration / 2, "leak_lpm": leak_lpm, "source": "fake"})


def run(tmp_path, **kw):
    args = {"duration": 4.0, "leak_lpm": 0.1, "seed": 1, **kw}
    return C.cached_simulation("fake", simulator=fake_sim, cache_dir=tmp_path, **args)


def test_unchanged_hits_changed_misses(tmp_path):
    CALLS.clear()
    a = run(tmp_path)
    b = run(tmp_path)
    assert (a.meta["cache_hit"], b.meta["cache_hit"]) == (False, True)
    assert len(CALLS) == 1
    np.testing.assert_array_equal(a["p1"], b["p1"])
    assert b.sample_rate == 10.0 and b.meta["onset"] == 2.0 and b.units["p1"] == "Pa"
    for change in ({"seed": 2}, {"leak_lpm": 0.2}, {"duration": 5.0},
                   {"params": Params(gain=2.5)}):
        r = run(tmp_path, **change)
        assert r.meta["cache_hit"] is False, change
        assert r.meta["cache_key"] != a.meta["cache_key"]
    assert len(CALLS) == 5
    assert run(tmp_path, params=Params(gain=2.5)).meta["cache_hit"] is True


def test_version_is_part_of_the_key():
    k = C.cache_key("vca", {"seed": 1})
    assert k != C.cache_key("vca", {"seed": 1}, version="999.0")
    assert k != C.cache_key("eha", {"seed": 1})
    assert len(k) == 64


def test_key_is_canonical():
    a = C.cache_key("vca", {"x": np.float64(0.1), "t": (1, 2), "p": Params()})
    b = C.cache_key("vca", {"p": Params(), "t": [1, 2], "x": 0.1})
    assert a == b
    assert C.cache_key("vca", {"x": 0.1}) != C.cache_key("vca", {"x": 0.1 + 1e-15})


def test_uncacheable_value_is_named():
    with pytest.raises(TypeError, match="type function"):
        C.cache_key("vca", {"f": lambda: 1})


def test_cache_dir_resolution(tmp_path, monkeypatch):
    monkeypatch.setenv(C.CACHE_ENV, str(tmp_path / "env"))
    assert C.resolve_cache_dir() == tmp_path / "env"
    assert C.resolve_cache_dir(tmp_path / "arg") == tmp_path / "arg"
    monkeypatch.delenv(C.CACHE_ENV)
    assert C.resolve_cache_dir().parts[-2:] == (".cache", "leakdiag")


def test_env_cache_used(tmp_path, monkeypatch):
    monkeypatch.setenv(C.CACHE_ENV, str(tmp_path))
    C.cached_simulation("fake", simulator=fake_sim, duration=1.0, leak_lpm=0.0, seed=3)
    assert len(list(tmp_path.glob("*.parquet"))) == 1
    assert C.clear_cache() == 1
    assert list(tmp_path.glob("*")) == []


def test_damaged_entry_is_a_miss(tmp_path):
    a = run(tmp_path)
    (tmp_path / f"{a.meta['cache_key']}.parquet").write_bytes(b"garbage")
    b = run(tmp_path)
    assert b.meta["cache_hit"] is False
    np.testing.assert_array_equal(a["p1"], b["p1"])


def test_unknown_system():
    with pytest.raises(ValueError, match="unknown system 'abc'"):
        C.cached_simulation("abc", seed=1)


def test_code_change_misses(tmp_path, monkeypatch):
    a = run(tmp_path)
    monkeypatch.setattr(C, "code_fingerprint", lambda fn: "edited")
    b = run(tmp_path)
    assert b.meta["cache_hit"] is False and b.meta["cache_key"] != a.meta["cache_key"]


def test_a_sidecar_without_a_field_or_a_channel_is_a_miss(tmp_path):
    import json

    a = run(tmp_path)
    js = tmp_path / f"{a.meta['cache_key']}.json"
    side = json.loads(js.read_text())
    js.write_text(json.dumps({**side, "channels": ["p1", "nope"]}))  # not in the Parquet file
    b = run(tmp_path)
    assert b.meta["cache_hit"] is False
    del side["channels"]
    js.write_text(json.dumps(side))
    assert run(tmp_path).meta["cache_hit"] is False
    assert run(tmp_path).meta["cache_hit"] is True  # rewritten whole


def test_clear_cache_removes_the_leftovers_of_cut_writes_once_stale(tmp_path):
    import os
    import time

    run(tmp_path)
    key = "a" * 64
    stale = tmp_path / f".{key}.x1y2.parquet"
    fresh = tmp_path / f".{key}.z3w4.json"
    other = tmp_path / ".not-ours.json"
    for p in (stale, fresh, other):
        p.write_bytes(b"")
    t = time.time() - C.STALE_TEMP_S - 1
    os.utime(stale, (t, t))
    os.utime(other, (t, t))
    assert C.clear_cache(tmp_path) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([fresh.name, other.name])


def test_code_fingerprint_hashes_the_package_or_the_folder_of_a_function(tmp_path, monkeypatch):
    import importlib
    import sys

    from leakdiag._fingerprint import parts_fingerprint
    from leakdiag.sim import simulate_vca

    assert C.code_fingerprint(simulate_vca) == parts_fingerprint(("sim",))
    # a simulator of the user's: its folder, every .py in it, an edit of a sibling counts
    pkg = tmp_path / "mysims"
    pkg.mkdir()
    (pkg / "mysim.py").write_text("def sim(seed):\n    return seed\n")
    (pkg / "helper.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(pkg))
    fn = importlib.import_module("mysim").sim
    a = C.code_fingerprint(fn)
    (pkg / "helper.py").write_text("X = 2\n")
    parts_fingerprint.cache_clear()
    assert C.code_fingerprint(fn) != a and len(a) == 16
    sys.modules.pop("mysim", None)
