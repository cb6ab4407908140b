"""``recording_units``: the units a file's leakdiag header states, read without its samples, with
the header decoding of ``read_recording`` (review of 2026-11-27, item 7: it lived in
``leakdiag.batch.runner``, parsed the Parquet header itself, and read any HDF5 file's top-level
``units`` attribute without checking that leakdiag wrote the file)."""

import json

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from leakdiag.io import Recording, RecordingError, read_recording, recording_units, write_recording

COUNTS = {"p1": "counts", "p2": "counts"}


def _counts():
    t = np.arange(100) / 1000.0
    return Recording({"p1": 2000.0 + np.sin(t), "p2": 1000.0 + np.cos(t)}, 1000.0,
                     units=COUNTS, meta={"system": "vca"})


@pytest.mark.parametrize("suffix", [".parquet", ".pq", ".h5", ".hdf5"])
def test_the_units_of_a_leakdiag_file_are_those_read_recording_gives(tmp_path, suffix):
    path = write_recording(_counts(), tmp_path / f"run{suffix}")
    assert recording_units(path) == COUNTS == read_recording(path).units


def test_a_plain_csv_states_no_units(tmp_path):
    assert recording_units(write_recording(_counts(), tmp_path / "run.csv")) is None


def _foreign_hdf5(path, **attrs):
    """An HDF5 file another program wrote: channels at the root, a ``units`` attribute."""
    with h5py.File(path, "w") as f:
        f["time"] = np.arange(100) / 1000.0
        f["p1"] = np.full(100, 1.0e7)
        f["p2"] = np.full(100, 5.0e6)
        for k, v in attrs.items():
            f.attrs[k] = v
    return path


def test_another_programs_hdf5_units_attribute_is_not_a_leakdiag_header(tmp_path):
    """It was read as one: a file whose DAQ software wrote ``units = {"p1": "counts"}`` was
    judged in counts by batch and monitor, in Pa (SI, no leakdiag header) by detect."""
    path = _foreign_hdf5(tmp_path / "daq.h5", units=json.dumps(COUNTS))
    assert recording_units(path) is None
    assert read_recording(path).units["p1"] == "Pa"


def test_another_programs_parquet_states_no_units(tmp_path):
    path = tmp_path / "daq.parquet"
    pq.write_table(pa.table({"time": np.arange(3) / 1000.0, "p1": np.ones(3)}), path)
    assert recording_units(path) is None


def test_a_leakdiag_header_of_a_newer_version_is_refused_as_read_recording_refuses_it(tmp_path):
    path = write_recording(_counts(), tmp_path / "run.h5")
    with h5py.File(path, "r+") as f:
        f.attrs["version"] = 99
    with pytest.raises(RecordingError) as new:
        recording_units(path)
    with pytest.raises(RecordingError) as old:
        read_recording(path)
    assert str(new.value) == str(old.value) == \
        f"{path}: leakdiag header version 99 is newer than this leakdiag understands (1); " \
        "upgrade leakdiag"


def test_a_missing_file_is_said(tmp_path):
    with pytest.raises(RecordingError, match="no.parquet: file not found"):
        recording_units(tmp_path / "no.parquet")
