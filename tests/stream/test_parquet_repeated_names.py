"""A Parquet file with a column name twice (p1, p1, p2, x, u): monitor and batch read the second
p1 as p2, and every later column one place off (ccf-p1p2 alarmed at 6.6 s for a leak at 67 s;
an audit of the streamed readers, 2026-11-27), while detect refused the file. The streamed
reader now refuses a repeated column it reads, naming it, as it does in a CSV; a repeated
column it does not read is harmless."""

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from leakdiag.io import RecordingError
from leakdiag.stream.files import open_recording


def _write(path, names):
    n = 500
    cols = [pa.array(np.arange(n) / 1000.0)] + [pa.array(np.full(n, float(i)))
                                                 for i in range(len(names))]
    pq.write_table(pa.Table.from_arrays(cols, names=["time", *names]), path)


def test_a_repeated_channel_that_is_read_is_refused(tmp_path):
    p = tmp_path / "twice.parquet"
    _write(p, ["p1", "p1", "p2"])
    with pytest.raises(RecordingError, match="column 'p1' .* appears 2 times"):
        open_recording(str(p), ["p1", "p2"], 100)


def test_a_repeated_column_that_is_not_read_is_harmless(tmp_path):
    p = tmp_path / "junk.parquet"
    _write(p, ["p1", "junk", "junk", "p2"])
    src, _ = open_recording(str(p), ["p1", "p2"], 100)
    chunk = next(iter(src))
    assert chunk["p1"][0] == 0.0 and chunk["p2"][0] == 3.0  # not shifted
