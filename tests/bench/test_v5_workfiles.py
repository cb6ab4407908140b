"""The v5 work folder (audit 2026-11-27, findings 6 and 7): files written by several runs at
once are complete, a damaged file is recomputed with a warning naming it, and a work folder
reached by another path spelling reuses everything."""

import os
import re
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from leakdiag.bench.v5_common import shard_rows, write_shard
from leakdiag.bench.v5_run import load_fit, save_fit
from leakdiag.cli.main import main

#: The smallest v5 run (as tests/bench/test_benchmark_audit.py): one fit, one shard of 6 runs.
SMALL = ["benchmark", "--quick", "--systems", "vca", "--methods", "acf-p1", "--n-healthy", "4",
         "--n-leak", "2", "--no-progress"]
#: Columns that differ between two computations of one result (CPU time).
CPU_COLUMNS = ["cpu_s", "sim_cpu_s"]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    """One simulation cache for the module (the calibration runs are simulated once)."""
    return str(tmp_path_factory.mktemp("cache"))


def _hammer(write_and_read, n_threads=3, n_each=60):
    """Run ``write_and_read(i)`` from several threads at once; the errors they raised."""
    errors, start = [], threading.Barrier(n_threads)

    def work():
        start.wait()
        for i in range(n_each):
            try:
                write_and_read(i)
            except Exception as exc:  # noqa: BLE001 -- collected and asserted empty
                errors.append(f"{type(exc).__name__}: {exc}")

    threads = [threading.Thread(target=work) for _ in range(n_threads)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return errors


def test_concurrent_shard_writers_leave_only_complete_files(tmp_path):
    """Writers of one shard at once: every read gives all 2,000 rows, no temporary file stays
    (with one fixed ``.tmp`` name: FileNotFoundError on the rename and 0-byte shards)."""
    path = tmp_path / "shards" / "s.parquet"
    rows = [{"method": "m", "seed": i, "score_max": float(i), "pad": "y" * 50}
            for i in range(2000)]

    def write_and_read(i):
        assert write_shard(rows, path) == 2000
        assert shard_rows(path) == 2000

    assert _hammer(write_and_read) == []
    assert sorted(os.listdir(path.parent)) == ["s.parquet"]
    df = pd.read_parquet(path)
    assert df["seed"].tolist() == list(range(2000))
    assert df["score_max"].sum() == sum(range(2000))


def test_concurrent_fit_writers_leave_only_complete_files(tmp_path):
    path = tmp_path / "fits" / "f.joblib"
    arr = np.arange(20_000)

    def write_and_read(i):
        save_fit(path, {"a": arr}, None, 1.5)
        got = load_fit(path)
        assert got["cpu_s"] == 1.5 and np.array_equal(got["detector"]["a"], arr)

    assert _hammer(write_and_read) == []
    assert sorted(os.listdir(path.parent)) == ["f.joblib"]


def test_a_failed_write_leaves_no_temporary_file_and_no_target(tmp_path):
    from leakdiag.bench._workfiles import write_atomic

    path = tmp_path / "shards" / "s.parquet"

    def half_then_fail(tmp):
        tmp.write_bytes(b"PAR1 half a file")
        raise OSError("No space left on device")

    with pytest.raises(OSError, match="No space left"):
        write_atomic(path, half_then_fail)
    assert os.listdir(path.parent) == []


def _cut(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _runs(out):
    df = pd.read_csv(out / "runs.csv.gz")
    return df.drop(columns=[c for c in CPU_COLUMNS if c in df]).sort_values(
        ["method", "seed"]).reset_index(drop=True)


@pytest.mark.parametrize("cut", [("fit", "shard"), ("shard",)])
def test_a_cut_fit_or_shard_is_recomputed_naming_it(tmp_path, cache, capsys, cut):
    """A reused fit or shard cut in half is removed and computed again with a warning naming
    it, and the results equal the first run's (it stopped every rerun: an UnpicklingError
    traceback for a fit, a usage error "Error: ... magic bytes not found" without the file's
    name for a shard)."""
    work = tmp_path / "work"
    args = [*SMALL, "--work-dir", str(work), "--cache-dir", cache]
    assert main([*args, "-o", str(tmp_path / "out1")]) == 0
    capsys.readouterr()
    files = {"fit": next((work / "fits").iterdir()), "shard": next((work / "shards").iterdir())}
    for what in cut:
        _cut(files[what])
    with pytest.warns(UserWarning) as record:
        code = main([*args, "-o", str(tmp_path / "out2")])
    text = capsys.readouterr().out
    assert code == 0, text
    damaged = sorted(str(w.message) for w in record if "damaged" in str(w.message))
    names = {"fit": "fit", "shard": "result shard"}
    assert len(damaged) == len(cut), damaged
    for msg, what in zip(damaged, cut):
        assert msg.startswith(f"{files[what]}: damaged {names[what]} file ("), msg
        assert msg.endswith("; removed, computed again"), msg
    lines = text.splitlines()
    n_fit = "fit" in cut
    fit_line = (rf"fits: 0 reused from {work}, 1 computed now \([0-9.e-]+ CPU s\)" if n_fit else
                rf"fits: 1 reused from {work} \(computed earlier, [0-9.e-]+ CPU s\), "
                r"0 computed now")
    assert re.fullmatch(fit_line, lines[1]), lines[1]
    assert re.fullmatch(rf"result shards: 0 reused from {work}, 1 computed now \(6 verdicts, "
                        r"[0-9.e-]+ CPU s\)", lines[2]), lines[2]
    pd.testing.assert_frame_equal(_runs(tmp_path / "out2"), _runs(tmp_path / "out1"))
    assert sorted(p.name for p in work.rglob("*")) == sorted(
        ["fits", "shards", files["fit"].name, files["shard"].name])  # whole, no temp file
    assert shard_rows(files["shard"]) == 6


def test_the_work_folder_by_another_path_reuses_every_shard(tmp_path, cache, capsys,
                                                            monkeypatch):
    """The same work folder through a relative path and through a symlink: fits and shards
    all reused, no new file (the shard key hashed the fits' absolute paths: 0 shards reused,
    one more shard file per spelling; finding 7)."""
    work = tmp_path / "work"
    args = [*SMALL, "--cache-dir", cache]
    assert main([*args, "--work-dir", str(work), "-o", str(tmp_path / "out1")]) == 0
    capsys.readouterr()
    (tmp_path / "link").symlink_to(work, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    for spelling in ("work", "link", "link/../work"):
        assert main([*args, "--work-dir", spelling, "-o", str(tmp_path / "out2")]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert re.fullmatch(rf"fits: 1 reused from {re.escape(spelling)} \(computed earlier, [0-9.e-]+ "
                            r"CPU s\), 0 computed now", lines[1]), lines[1]
        assert re.fullmatch(rf"result shards: 1 reused from {re.escape(spelling)} \(computed "
                            r"earlier, 6 verdicts, [0-9.e-]+ CPU s\), 0 computed now",
                            lines[2]), lines[2]
        pd.testing.assert_frame_equal(_runs(tmp_path / "out2"), _runs(tmp_path / "out1"))
    assert len(list((work / "shards").iterdir())) == 1
    assert len(list((work / "fits").iterdir())) == 1


def test_settings_and_report_record_the_library_versions(tmp_path, cache, capsys):
    """settings.json and report.md record leakdiag's and the libraries' versions beside the
    code fingerprint (the fingerprint alone before; cache audit 2026-11-27, finding 8)."""
    import json

    from leakdiag._fingerprint import library_versions

    out = tmp_path / "out"
    assert main([*SMALL, "--work-dir", str(tmp_path / "work"), "--cache-dir", cache,
                 "-o", str(out)]) == 0
    settings = json.loads((out / "settings.json").read_text())
    assert settings["library_versions"] == library_versions()
    assert settings["leakdiag_version"] == "0.1.0"
    libs = ", ".join(f"{k} {v}" for k, v in sorted(library_versions().items()))
    assert (f"Code: fingerprint `{settings['code_fingerprint']}` (part of every fit, reference "
            f"and shard key), leakdiag 0.1.0; libraries {libs} (recorded, not part of the "
            "keys).") in (out / "report.md").read_text()


def test_temporary_files_of_killed_writers_are_removed_after_an_hour(tmp_path, cache, capsys):
    """A writer killed between its temporary file and the rename leaves ``.<name>.<random>.tmp``;
    a run removes those older than an hour and keeps a fresh one (another run's, at work)."""
    work = tmp_path / "work"
    (work / "shards").mkdir(parents=True)
    (work / "fits").mkdir()
    old = work / "shards" / ".0f71a1705b4b7ccb93c22b6b.parquet.k3j2x9.tmp"
    fresh = work / "fits" / ".acf-p1-ad58aaa84db9a3e177ff7685.joblib.p0q1r2.tmp"
    for f in (old, fresh):
        f.write_bytes(b"PAR1 half a file")
    hours_ago = os.stat(old).st_mtime - 7200.0
    os.utime(old, (hours_ago, hours_ago))
    assert main([*SMALL, "--work-dir", str(work), "--cache-dir", cache,
                 "-o", str(tmp_path / "out")]) == 0
    assert not old.exists() and fresh.read_bytes() == b"PAR1 half a file"
    assert sorted(p.name for p in (work / "shards").iterdir() if p.name.startswith(".")) == []
