"""Batch on a real dask.distributed LocalCluster with two worker processes equals the serial run."""

import pickle

import pytest

from leakdiag.stream.detector_file import DetectorFileWarning

from _batch_helpers import SlowScorer, make_recording
from leakdiag.batch import config_from_dict, read_results, run_batch
from leakdiag.io.parquet import write_parquet


@pytest.mark.slow
def test_local_cluster_equals_serial(tmp_path):
    from dask.distributed import LocalCluster

    rec_dir = tmp_path / "recordings"
    rec_dir.mkdir()
    for i in range(4):
        write_parquet(make_recording(i), rec_dir / f"run{i}.parquet")
    (rec_dir / "bad.parquet").write_text("nope")
    det = tmp_path / "det.pkl"
    det.write_bytes(pickle.dumps(SlowScorer()))
    cfg = config_from_dict({
        "analysis": [{"method": "autocorrelation", "channels": ["p1"], "lag": [1, 2]},
                     {"method": "cross-correlation", "channels": ["p1", "p2"], "lag": 1,
                      "window": 100}],
        "detector": [{"name": "slow", "path": str(det)}]})
    pattern = [str(rec_dir / "*.parquet")]
    bare = "a bare pickled detector without a metadata record"  # said once per run
    with pytest.warns(DetectorFileWarning, match=bare):
        run_batch(pattern, cfg, tmp_path / "serial", progress=False)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:
        assert len(cluster.workers) == 2
        with pytest.warns(DetectorFileWarning, match=bare):
            s = run_batch(pattern, cfg, tmp_path / "dask", scheduler=cluster.scheduler_address,
                          progress=False)
    assert (s.n_run, s.n_errors) == (5, 1)
    a = read_results(tmp_path / "serial").drop(columns="elapsed_s")
    b = read_results(tmp_path / "dask").drop(columns="elapsed_s")
    assert len(a) == 4 * 4 + 1
    assert a.equals(b)
