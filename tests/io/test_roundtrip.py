"""Writing and reading back: Parquet and HDF5 exactly (samples, rate, start, units, meta but
its ``source``, which names the file read); CSV samples."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from leakdiag.io import Recording, RecordingError, read_recording, write_recording


def _rec(n=50, rng_seed=0, **meta):
    rng = np.random.default_rng(rng_seed)
    chans = {"p1": 1e7 + 1e5 * rng.standard_normal(n), "p2": 5e6 + rng.standard_normal(n),
             "x": rng.uniform(-0.05, 0.05, n), "u": np.sin(np.arange(n) / 7.0),
             "leak_flow": np.full(n, 1.6e-6)}
    return Recording(chans, 1000.0, start_time=0.25, units={"u": "V"},
                     meta={"onset": 0.3, "leak_lpm": 0.1, "source": "simulate_vca", **meta})


def _assert_same(a: Recording, b: Recording, path):
    """``b`` read from ``path`` is ``a``; its meta names the file (``source``) and keeps the
    source ``a`` named as ``origin`` (since 2026-11-27)."""
    assert list(a.channels) == list(b.channels)
    for k in a.channels:
        np.testing.assert_array_equal(a[k], b[k])
        assert a[k].tobytes() == b[k].tobytes()
    assert a.sample_rate == b.sample_rate
    assert a.start_time == b.start_time
    assert a.units == b.units
    meta = dict(a.meta)
    if meta.get("source", str(path)) != str(path):
        meta["origin"] = meta["source"]
    meta["source"] = str(path)
    assert b.meta == meta


@pytest.mark.parametrize("ext", [".parquet", ".h5", ".hdf5", ".pq"])
def test_exact_round_trip(tmp_path, ext):
    rec = _rec(params={"piston_area_m2": 1.2e-3, "nested": {"a": [1, 2.5, None]}},
               seed_value=7, flag=True, label="run 1 (µ)")
    path = write_recording(rec, tmp_path / f"run{ext}")
    assert path == tmp_path / f"run{ext}"
    _assert_same(rec, read_recording(path), path)


@pytest.mark.parametrize("ext", [".parquet", ".h5"])
def test_numpy_metadata_becomes_plain_python(tmp_path, ext):
    rec = _rec(seed=np.int64(3), gain=np.float32(0.5), arr=np.arange(3), tup=(1, 2))
    back = read_recording(write_recording(rec, tmp_path / f"r{ext}"))
    assert back.meta["seed"] == 3 and type(back.meta["seed"]) is int
    assert back.meta["gain"] == 0.5
    assert back.meta["arr"] == [0, 1, 2]
    assert back.meta["tup"] == [1, 2]  # documented: tuples come back as lists


@pytest.mark.parametrize("ext", [".parquet", ".h5"])
def test_non_finite_metadata_survives(tmp_path, ext):
    back = read_recording(write_recording(_rec(achieved=float("nan"), bound=float("-inf")),
                                          tmp_path / f"r{ext}"))
    assert np.isnan(back.meta["achieved"]) and back.meta["bound"] == -np.inf


@pytest.mark.parametrize("ext", [".parquet", ".h5"])
def test_metadata_that_json_cannot_hold(tmp_path, ext):
    rec = _rec(callback=object())
    with pytest.raises(RecordingError, match=rf"r{ext}: metadata cannot be stored \(key\(s\) "
                                             r"\['callback'\]\): object"):
        write_recording(rec, tmp_path / f"r{ext}")
    assert not list(tmp_path.iterdir())  # no partial file left behind


def test_csv_round_trip_samples_exact_units_si(tmp_path):
    rec = _rec()
    path = write_recording(rec, tmp_path / "sub dir (1)" / "run.csv")
    back = read_recording(path)
    for k in rec.channels:
        assert back[k].tobytes() == rec[k].tobytes()
    assert back.sample_rate == 1000.0
    assert back.start_time == 0.25
    assert back.units == {"p1": "Pa", "p2": "Pa", "x": "m", "u": "V", "leak_flow": "m^3/s"}
    assert back.meta == {"source": str(path)}  # CSV holds no metadata (documented)


def test_other_tools_can_read_our_parquet(tmp_path):
    import pandas as pd

    rec = _rec(n=5)
    df = pd.read_parquet(write_recording(rec, tmp_path / "r.parquet"))
    assert list(df.columns) == ["time", "p1", "p2", "x", "u", "leak_flow"]
    np.testing.assert_allclose(df["time"], 0.25 + np.arange(5) / 1000.0, rtol=0, atol=1e-15)


def test_hdf5_layout(tmp_path):
    import h5py

    path = write_recording(_rec(n=4), tmp_path / "r.h5")
    with h5py.File(path) as f:
        assert f.attrs["sample_rate"] == 1000.0
        assert f.attrs["start_time"] == 0.25
        assert f["channels/p1"].attrs["unit"] == "Pa"
        assert f["channels/p1"].shape == (4,)
        assert '"onset": 0.3' in f.attrs["meta"]


def test_overwrite_replaces(tmp_path):
    path = tmp_path / "r.parquet"
    write_recording(_rec(n=10), path)
    write_recording(_rec(n=20), path)
    assert read_recording(path).n_samples == 20
    assert [p.name for p in tmp_path.iterdir()] == ["r.parquet"]


def test_write_errors(tmp_path):
    with pytest.raises(RecordingError, match=r"cannot write files with extension '.xlsx'; "
                                             r"known: .csv, .parquet"):
        write_recording(_rec(), tmp_path / "r.xlsx")
    rec = Recording({"time": np.zeros(3)}, 10.0)
    with pytest.raises(RecordingError, match="a channel named 'time' collides"):
        write_recording(rec, tmp_path / "r.parquet")
    with pytest.raises(RecordingError, match="cannot be HDF5 dataset names"):
        write_recording(Recording({"a/b": np.zeros(3)}, 10.0), tmp_path / "r.h5")
    with pytest.raises(TypeError, match="rec must be a Recording"):
        write_recording({"p1": [1.0]}, tmp_path / "r.csv")


def test_sample_rate_argument_must_agree_with_stored(tmp_path):
    path = write_recording(_rec(), tmp_path / "r.parquet")
    assert read_recording(path, sample_rate=1000.0).sample_rate == 1000.0
    with pytest.raises(RecordingError, match=r"a sample rate of 500 Hz was given "
                                             r"\(--sample-rate, or sample_rate_hz in a column "
                                             r"map\), but the file's header says 1000 Hz"):
        read_recording(path, sample_rate=500.0)


def test_map_on_a_leakdiag_file_goes_through_the_generic_path(tmp_path):
    path = write_recording(_rec(n=10), tmp_path / "r.parquet")
    back = read_recording(path, {"p1": "p1:Pa", "pressure_kpa": "p2:kPa"})
    assert list(back.channels) == ["p1", "pressure_kpa"]
    np.testing.assert_allclose(back["pressure_kpa"], _rec(n=10)["p2"] * 1e3)
    assert back.meta["onset"] == 0.3  # stored metadata kept
    assert back.sample_rate == 1000.0


finite = st.floats(-1e12, 1e12, allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(values=st.lists(finite, min_size=2, max_size=30),
       rate=st.floats(0.1, 1e6, allow_nan=False),
       start=st.floats(-1e3, 1e3, allow_nan=False),
       ext=st.sampled_from([".parquet", ".h5"]),
       meta=st.dictionaries(st.text(min_size=1, max_size=5),
                            st.one_of(st.integers(-10**6, 10**6), finite, st.text(max_size=5),
                                      st.booleans(), st.none()), max_size=4))
def test_round_trip_property(tmp_path, values, rate, start, ext, meta):
    rec = Recording({"p1": np.array(values), "x": -np.array(values)}, rate, start,
                    {"p1": "counts"}, meta)
    path = write_recording(rec, tmp_path / f"h{ext}")
    _assert_same(rec, read_recording(path), path)


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(values=st.lists(finite, min_size=2, max_size=30))
def test_csv_samples_round_trip_property(tmp_path, values):
    rec = Recording({"p1": np.array(values)}, 1000.0)
    back = read_recording(write_recording(rec, tmp_path / "h.csv"))
    np.testing.assert_array_equal(back["p1"], rec["p1"])  # -0.0 may come back as 0.0


def test_a_leakdiag_file_whose_rows_were_cut_is_refused(tmp_path):
    """The header places the samples by its rate; a file with rows removed afterwards (its
    header kept) was read as continuous data and an EHA run with a 0.2-s gap was judged LEAK
    (found by an audit, 2026-11-27). The stored time column is now checked."""
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    from leakdiag.io import RecordingError, read_recording, write_recording
    from leakdiag.io.recording import Recording

    rec = Recording({"p1": np.arange(1000.0), "p2": np.arange(1000.0)}, 100.0)
    path = write_recording(rec, tmp_path / "r.parquet")
    assert read_recording(path).n_samples == 1000
    table = pq.read_table(path)
    keep = np.r_[0:500, 520:1000]
    pq.write_table(table.take(pa.array(keep)), tmp_path / "cut.parquet")
    with pytest.raises(RecordingError, match=r"cut.parquet: column 'time' is not uniformly "
                                             r"sampled: interval before row 500 is 0.21 s.*; "
                                             r"this file was written by leakdiag at 100 Hz \(its "
                                             r"header\), so rows were removed or added after "
                                             r"writing: write the recording again$") as err:
        read_recording(tmp_path / "cut.parquet")
    assert "--resample" not in str(err.value)  # resampling would interpolate over the gap
    every_other = table.take(pa.array(np.arange(0, 1000, 2)))
    pq.write_table(every_other, tmp_path / "half.parquet")
    with pytest.raises(RecordingError, match=r"half.parquet: the header says 100 Hz, but the "
                                             r"file's time column is sampled at 50 Hz"):
        read_recording(tmp_path / "half.parquet")


def test_a_leakdiag_hdf5_file_whose_time_dataset_was_cut_is_refused(tmp_path):
    """HDF5 keeps each column as its own dataset: a leakdiag file whose /time was cut short (or
    a channel) was read by its header's rate without a word, while `monitor` refuses the same
    file (an audit, 2026-11-27). The lengths are now compared, in io's words."""
    import h5py
    import numpy as np

    from leakdiag.io import RecordingError, read_recording, write_recording
    from leakdiag.io.recording import Recording

    rec = Recording({"p1": np.arange(1000.0), "p2": np.arange(1000.0)}, 100.0)
    path = write_recording(rec, tmp_path / "r.h5")
    assert read_recording(path).n_samples == 1000
    with h5py.File(path, "a") as f:
        t = f["time"][()]
        del f["time"]
        f["time"] = t[:10]
    with pytest.raises(RecordingError, match=r"r.h5: channels have different lengths \(time "
                                             r"column 'time'=10, p1=1000, p2=1000\)$"):
        read_recording(path)
