"""MATLAB .mat (v5 via SciPy, v7.3 via h5py) and generic HDF5 files, read through column maps."""

import numpy as np
import pytest
import scipy.io

from leakdiag.io import RecordingError, read_recording
from leakdiag.io.matlab import read_mat

N = 20
T = np.arange(N) / 100.0
P1 = 1e6 + 1e4 * np.sin(T * 9)
X = 0.01 * T


def _savemat(tmp_path, data, name="log.mat"):
    path = tmp_path / name
    scipy.io.savemat(path, data)
    return path


def test_separate_variables_standard_names_need_no_map(tmp_path):
    path = _savemat(tmp_path, {"time": T, "p1": P1, "x": X.reshape(1, -1)})  # x a row vector
    rec = read_recording(path)
    assert rec.sample_rate == 100.0
    np.testing.assert_array_equal(rec["p1"], P1)
    np.testing.assert_array_equal(rec["x"], X)


def test_matrix_columns_are_one_based(tmp_path):
    data = np.column_stack([T, P1 / 1e5, X * 1e3])  # time, bar, mm
    path = _savemat(tmp_path, {"data": data, "Ts": 0.01})
    assert read_mat(path).names == ["data(:,1)", "data(:,2)", "data(:,3)"]  # scalar Ts skipped
    rec = read_recording(path, {"file": {"time_column": "data(:,1)"},
                                "channels": {"p1": "data(:,2):bar", "x": "data(:,3):mm"}})
    np.testing.assert_allclose(rec["p1"], P1, rtol=1e-15)
    np.testing.assert_allclose(rec["x"], X, rtol=1e-12)
    assert rec.units == {"p1": "Pa", "x": "m"}


def test_simulink_structure_with_time(tmp_path):
    scope = {"time": T, "signals": {"values": np.column_stack([P1, X]),
                                    "dimensions": 2, "label": "p1,x", "blockName": "m/Scope"},
             "blockName": "m/Scope"}
    path = _savemat(tmp_path, {"ScopeData": scope})
    table = read_mat(path)
    assert table.names == ["ScopeData.time", "ScopeData.signals.values(:,1)",
                           "ScopeData.signals.values(:,2)"]
    rec = read_recording(path, {"file": {"time_column": "ScopeData.time"},
                                "channels": {"p1": "ScopeData.signals.values(:,1)",
                                             "x": "ScopeData.signals.values(:,2)"}})
    np.testing.assert_array_equal(rec["x"], X)


def test_struct_array_elements(tmp_path):
    sig = np.array([(P1,), (X,)], dtype=[("values", object)])
    path = _savemat(tmp_path, {"t": T, "signals": sig})
    assert read_mat(path).names == ["t", "signals(1).values", "signals(2).values"]


def test_channels_of_different_length(tmp_path):
    path = _savemat(tmp_path, {"t": T, "a": P1, "b": X[:-3]})
    with pytest.raises(RecordingError, match=r"log.mat: channels have different lengths "
                                             r"\(time column 't'=20, p1=20, x=17\)"):
        read_recording(path, {"file": {"time_column": "t"}, "channels": {"p1": "a", "x": "b"}})


def test_no_numeric_variables(tmp_path):
    path = _savemat(tmp_path, {"name": "run 1", "k": 3.0})
    with pytest.raises(RecordingError, match=r"holds no numeric vectors \(no channels\); "
                                             r"variables: \['k', 'name'\]"):
        read_recording(path)


def _write_v73(path, variables):
    """A MATLAB v7.3-style file: HDF5 with a 512-byte user block, column-major (transposed)
    datasets carrying MATLAB_class, a struct as a group, text as uint16 'char'."""
    import h5py

    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            if isinstance(value, dict):
                g = f.create_group(name)
                g.attrs["MATLAB_class"] = np.bytes_("struct")
                for k, v in value.items():
                    ds = g.create_dataset(k, data=np.atleast_2d(v).T)
                    ds.attrs["MATLAB_class"] = np.bytes_("double")
            elif isinstance(value, str):
                ds = f.create_dataset(name, data=np.array([[ord(c)] for c in value], np.uint16))
                ds.attrs["MATLAB_class"] = np.bytes_("char")
            else:
                arr = np.asarray(value, dtype=np.float64)
                arr = arr.reshape(-1, 1) if arr.ndim == 1 else arr
                ds = f.create_dataset(name, data=arr.T)  # MATLAB n x k is stored k x n
                ds.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sat Nov 21 2026 HDF5 schema")


def test_v73_file_is_read_with_h5py_and_transposed(tmp_path):
    path = tmp_path / "log73.mat"
    _write_v73(path, {"data": np.column_stack([T, P1, X]), "label": "run",
                      "S": {"time": T, "p": P1}})
    table = read_mat(path)
    assert table.names == ["S.p", "S.time", "data(:,1)", "data(:,2)", "data(:,3)"]
    rec = read_recording(path, {"file": {"time_column": "data(:,1)"},
                                "channels": {"p1": "data(:,2)", "x": "data(:,3)", "p2": "S.p"}})
    assert rec.sample_rate == 100.0
    np.testing.assert_array_equal(rec["p1"], P1)
    np.testing.assert_array_equal(rec["x"], X)
    np.testing.assert_array_equal(rec["p2"], P1)


def test_generic_hdf5_groups_join_with_slash(tmp_path):
    import h5py

    path = tmp_path / "daq.h5"
    with h5py.File(path, "w") as f:
        f["daq/time"] = T * 1e3  # ms
        f["daq/pressures"] = np.column_stack([P1 / 1e6, P1 / 2e6])  # MPa
        f["note"] = np.bytes_("text is skipped")
    rec = read_recording(path, {"file": {"time_column": "daq/time", "time_unit": "ms"},
                                "channels": {"p1": "daq/pressures(:,1):MPa",
                                             "p2": "daq/pressures(:,2):MPa"}})
    assert rec.sample_rate == pytest.approx(100.0)
    np.testing.assert_allclose(rec["p2"], P1 / 2, rtol=1e-15)


def test_generic_parquet_with_nulls_and_text(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = tmp_path / "ext.parquet"
    pq.write_table(pa.table({"t_ms": pa.array([0, 10, 20], pa.int64()),
                             "P": pa.array([1.0, None, 3.0]),
                             "tag": pa.array(["a", "b", "c"])}), path)
    cmap = {"file": {"time_column": "t_ms", "time_unit": "ms"}, "channels": {"p1": "P:bar"}}
    with pytest.raises(RecordingError, match=r"ext.parquet: channel 'p1' \(column 'P'\) has 1 non-finite "
                                             r"value\(s\); first NaN at row 1"):
        read_recording(path, cmap)
    with pytest.raises(RecordingError, match=r"channel 'p1' \(column 'tag'\) holds text"):
        read_recording(path, {"file": cmap["file"], "channels": {"p1": "tag"}})


def test_empty_parquet(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = tmp_path / "empty.parquet"
    pq.write_table(pa.table({"time": pa.array([], pa.float64())}), path)
    with pytest.raises(RecordingError, match=r"empty.parquet: has columns \(time\) but no rows"):
        read_recording(path)


def test_generic_parquet_with_standard_names_needs_no_map(tmp_path):
    import pandas as pd

    path = tmp_path / "pandas.parquet"
    pd.DataFrame({"time": T, "p1": P1, "x": X}).to_parquet(path)
    rec = read_recording(path)
    assert rec.sample_rate == 100.0
    assert rec.channel_names == ["p1", "x"]
    np.testing.assert_array_equal(rec["p1"], P1)
    assert rec.meta == {"source": str(path)}


@pytest.mark.parametrize("dtype", ["int16", "uint16", "int32", "float32", "float64"])
def test_integer_and_single_precision_columns(tmp_path, dtype):
    import pyarrow as pa
    import pyarrow.parquet as pq

    counts = np.array([0, 8191, 16383, 42], dtype=dtype)
    path = tmp_path / f"{dtype}.parquet"
    pq.write_table(pa.table({"PG_1": counts}), path)
    rec = read_recording(path, {"p1": "PG_1:counts"}, sample_rate=1000)
    assert rec["p1"].dtype == np.float64
    assert rec["p1"].tolist() == [0.0, 8191.0, 16383.0, 42.0]
    assert rec.units == {"p1": "counts"}
