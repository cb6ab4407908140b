"""The print-resolution allowance of a time column applies only where printing rounds: at
200 or 250 Hz with ms timestamps the intervals are whole numbers of ms, and allowing 1 ms there
passed 4/6-ms jitter (20 % of an interval) and a sample 1 ms late as uniform (a review,
2026-11-27, of the allowance added for 3-kHz files with us timestamps)."""

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import main
from leakdiag.io import RecordingError
from leakdiag.io.checks import infer_sample_rate, rounds


def _run(args, stdin=None):
    with CliRunner().isolation(input=stdin) as (out, err, _):
        code = main(args)
        return code, out.getvalue().decode(), err.getvalue().decode()


def test_the_allowance_only_where_printing_rounds():
    assert infer_sample_rate(np.round(np.arange(3000) / 3000, 6)) == pytest.approx(3000, 1e-6)
    assert infer_sample_rate(np.round(np.arange(1000) / 200, 3)) == 200.0
    assert rounds(1 / 3000, 1e-6) and not rounds(0.005, 1e-3)
    with pytest.raises(RecordingError, match="not uniformly sampled: interval before row 2 is "
                                             "0.004 s"):
        infer_sample_rate(np.round(np.cumsum(np.tile([0.004, 0.006], 500)), 3))
    late = np.round(np.arange(1000) / 250, 3)
    late[500:] += 0.001
    with pytest.raises(RecordingError, match="interval before row 500 is 0.005 s"):
        infer_sample_rate(late)


@pytest.mark.parametrize("how", ["file", "stdin"])
def test_monitor_refuses_ms_jitter_at_200_hz_and_reads_us_times_at_3_khz(tmp_path, how):
    rng = np.random.default_rng(1)
    jit = pd.DataFrame({"time": np.round(np.cumsum(np.tile([0.004, 0.006], 500)), 3),
                        "p1": 5e6 + 1e4 * rng.standard_normal(1000)})
    ok = pd.DataFrame({"time": np.round(np.arange(3000) / 3000, 6),
                       "p1": 5e6 + 1e4 * rng.standard_normal(3000)})
    for name, df, good in (("jit", jit, False), ("ok", ok, True)):
        path = tmp_path / f"{name}.csv"
        df.to_csv(path, index=False)
        args = ["monitor", "--input", str(path) if how == "file" else "-", "--channels", "p1",
                "--window", "100", "-q"]
        code, out, err = _run(args, stdin=path.read_text() if how == "stdin" else None)
        assert (code == 0) == good, (name, code, err)
        if not good:
            assert "jitter" in err or "not uniformly sampled" in err, err
