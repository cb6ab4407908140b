"""``leakdiag batch`` resumes only rows of the same code (cache audit 2026-11-27, finding 5):
after an edit of a part batch results depend on, or under other library versions, finished
recordings are computed again with a note, and their new rows replace the old ones (until
then the rerun said "0 run, 2 already done" and kept the former code's numbers)."""

import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

import leakdiag._fingerprint as fingerprint
import leakdiag.batch.runner as runner
from _batch_helpers import make_recording
from leakdiag.batch import read_results
from leakdiag.cli.main import cli
from leakdiag.io.parquet import write_parquet

#: The edit of the audit's repro: batch/runner.py's feature summary, value_mean x 10.
ORIGINAL = '"value_mean": float(finite.mean())'
EDITED = '"value_mean": 10.0 * float(finite.mean())'


@pytest.fixture()
def job(tmp_path, monkeypatch):
    """Two recordings, a one-analysis job, and a copy of the package's sources whose
    fingerprint the run uses (so that the test can edit them)."""
    (tmp_path / "recordings").mkdir()
    for i in range(2):
        write_parquet(make_recording(i), tmp_path / "recordings" / f"run{i}.parquet")
    (tmp_path / "job.toml").write_text('[[analysis]]\nmethod = "autocorrelation"\n'
                                       'channels = ["p1"]\nlag = 1\nwindow = 200\noverlap = 5\n')
    src = tmp_path / "src" / "leakdiag"
    shutil.copytree(fingerprint.PACKAGE_ROOT, src,
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    monkeypatch.setattr(fingerprint, "PACKAGE_ROOT", src)
    fingerprint.parts_fingerprint.cache_clear()
    yield tmp_path, src
    fingerprint.parts_fingerprint.cache_clear()


def _batch(tmp):
    return CliRunner().invoke(cli, ["batch", str(tmp / "recordings" / "*.parquet"), "--config",
                                    str(tmp / "job.toml"), "-o", str(tmp / "res.parquet"),
                                    "--scheduler", "serial", "--no-progress"])


def _value_means(tmp):
    df = read_results(tmp / "res.parquet")
    assert len(df) == 2 and df["path"].is_unique  # one current row per recording
    return df.sort_values("recording")["value_mean"].to_numpy()


def test_rows_of_other_code_are_computed_again_with_a_note(job, monkeypatch):
    tmp, src = job
    r = _batch(tmp)
    assert r.exit_code == 0, r.output
    before = _value_means(tmp)
    assert "2 recording(s): 2 run, 0 already done" in r.output
    assert "2 recording(s): 0 run, 2 already done" in _batch(tmp).output  # same code: reused

    # edit batch/runner.py (what runs and its source, as after a real edit)
    f = src / "batch" / "runner.py"
    assert f.read_text().count(ORIGINAL) == 1
    f.write_text(f.read_text().replace(ORIGINAL, EDITED))
    fingerprint.parts_fingerprint.cache_clear()
    real = runner._summary
    monkeypatch.setattr(runner, "_summary", lambda v: {**real(v), "value_mean": 10.0 * real(v)[
        "value_mean"]} if real(v)["value_mean"] is not None else real(v))
    r = _batch(tmp)
    assert r.exit_code == 0, r.output
    assert "2 recording(s): 2 run, 0 already done, 0 error(s) in this run; 2 current row(s)" \
        in r.output
    parts = ", ".join(runner.CODE_PARTS)
    assert (f"leakdiag: note: 2 finished recording(s) in {tmp / 'res.parquet'} computed again, "
            f"their rows replaced: 2 had rows of other leakdiag code (another fingerprint of "
            f"{parts})") in r.stderr
    np.testing.assert_allclose(_value_means(tmp), 10.0 * before, rtol=1e-12)
    df = read_results(tmp / "res.parquet")
    assert set(df["code_fingerprint"]) == {fingerprint.parts_fingerprint(runner.CODE_PARTS)}
    r = _batch(tmp)
    assert "2 recording(s): 0 run, 2 already done" in r.output and "note:" not in r.output


def test_rows_of_other_library_versions_are_computed_again_with_a_note(job, monkeypatch):
    tmp, _ = job
    assert _batch(tmp).exit_code == 0
    df = read_results(tmp / "res.parquet")
    assert json.loads(df["library_versions"].iloc[0]) == fingerprint.library_versions()
    newer = {**fingerprint.library_versions(), "numpy": "99.0.0"}
    monkeypatch.setattr(fingerprint, "library_versions", lambda: newer)
    r = _batch(tmp)
    assert "2 recording(s): 2 run, 0 already done" in r.output
    assert ("computed again, their rows replaced: 2 had rows of other library versions "
            "(Python, NumPy, SciPy, Numba, pandas, pyarrow)") in r.stderr
    assert {json.loads(v)["numpy"] for v in read_results(tmp / "res.parquet")[
        "library_versions"]} == {"99.0.0"}


def test_the_parts_exist_and_cover_what_a_batch_run_imports():
    """Every part is hashed (a typo would raise), and every leakdiag module a batch run of
    analyses and detector files imports lies in a part or in the documented exclusions."""
    import subprocess
    import sys

    assert len(fingerprint.parts_fingerprint(runner.CODE_PARTS)) == 16
    code = ("import sys, leakdiag.batch.runner, leakdiag.stream.detector_file, leakdiag.detect, "
            "leakdiag.literature; print(sorted({m.split('.')[1] for m in sys.modules "
            "if m.startswith('leakdiag.')}))")
    used = set(eval(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                   check=True).stdout))
    excluded = {"sim", "runtime", "_version", "_fingerprint", "_numba_cache", "bench"}
    parts = {p.removesuffix(".py") for p in runner.CODE_PARTS}
    assert used - excluded <= parts, used - excluded - parts
