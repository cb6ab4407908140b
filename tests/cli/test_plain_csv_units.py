"""A plain CSV states no units: every command takes its standard channels as SI (``p1`` in Pa),
so detect, monitor (file, stdin) and batch agree on the unit check against a detector fitted on
counts (audit of users' recordings, 2026-11-27, finding 8: detect refused the file, monitor and
batch judged it). Through the CLI entry point."""

import numpy as np
import pandas as pd
import pytest


REFUSED = "channel 'p1' is in 'Pa', but {det} was fitted on 'counts'"


def _csv(path, seed, level=5000.0, scale=50.0):
    rng = np.random.default_rng(seed)
    n = 3000
    pd.DataFrame({"time": np.round(np.arange(n) / 1000.0, 3),
                  "p1": np.round(level + rng.normal(0, scale, n), 1),
                  "p2": np.round(0.8 * level + rng.normal(0, scale, n), 1)}).to_csv(
        path, index=False)
    return str(path)


@pytest.fixture(scope="module")
def counts_detector(run_cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    healthy = [_csv(d / f"h{s}.csv", s) for s in range(8)]
    det = str(d / "counts.joblib")
    code, out, err = run_cli(["fit", *[a for h in healthy for a in ("--healthy", h)],
                              "--col", "p1=p1:counts", "--col", "p2=p2:counts", "-m", "acf-p1",
                              "--system", "vca", "--burn-in", "0", "--false-alarm-rate", "1000",
                              "-o", det])
    assert code == 0, err
    return d, det, _csv(d / "judged.csv", 99, level=1e7, scale=1e5)


def test_detect_monitor_and_batch_refuse_a_plain_csv_against_a_counts_detector(run_cli,
                                                                              counts_detector):
    d, det, judged = counts_detector
    message = REFUSED.format(det=det)
    code, out, err = run_cli(["detect", judged, "--detector", det, "--no-progress"])
    assert code != 0 and f"{judged}: {message}" in err, err
    code, out, err = run_cli(["monitor", judged, "--detector", det])
    assert code != 0 and f"{judged}: {message}" in err, err
    with open(judged) as fh:
        code, out, err = run_cli(["monitor", "-", "--detector", det], stdin=fh.read())
    assert code != 0 and f"<stdin>: {message}" in err, err
    # what to do, where the stream has no way to state its units (a workflow audit, 2026-11-30)
    assert ("stdin and --follow take SI values only, so to monitor a live stream fit the "
            "detector on recordings converted to SI") in err
    job = d / "job.toml"
    job.write_text(f'[[detector]]\npath = "{det}"\n')
    res = d / "res.parquet"
    code, out, err = run_cli(["batch", judged, "--config", str(job), "-o", str(res),
                              "--scheduler", "serial"])
    rows = pd.read_parquet(res)
    assert rows["status"].tolist() == ["error"], rows
    assert message in rows["error"].iloc[0], rows["error"].iloc[0]
    # with the map that says counts, every command judges it
    code, out, err = run_cli(["monitor", judged, "--detector", det, "--col", "p1=p1:counts",
                              "--col", "p2=p2:counts"])
    assert code == 0, err
