"""The judged file (or a byte copy) given as its own healthy reference is refused, naming both
files (audit of users' recordings, 2026-11-27, finding 4: LEAK became NO LEAK)."""

import shutil

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.cli.main import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("self")
    paths = []
    for seed in range(3):
        rng = np.random.default_rng(seed)
        p1 = np.convolve(rng.standard_normal(4000), np.ones(5) / 5, mode="same")
        rec = ld.Recording({"p1": 1e6 + 1e3 * p1, "p2": 1e6 - 1e3 * p1}, 1000.0)
        path = d / f"run{seed}.csv"
        rec.to_pandas().to_csv(path, index=False)
        paths.append(path)
    copy = d / "copy.csv"
    shutil.copy(paths[0], copy)
    return paths, copy


@pytest.mark.parametrize("same", ["itself", "copy"])
def test_analyze_refuses_the_suspect_as_its_own_reference(files, same, capsys):
    (a, b, c), copy = files
    ref = a if same == "itself" else copy
    args = ["analyze", str(a), "-m", "autocorrelation", "-c", "p1", "-w", "200",
            "--healthy", str(b), "--healthy", str(c)]
    assert main(args) == 0
    capsys.readouterr()
    assert main(args + ["--healthy", str(ref)]) == 2
    err = capsys.readouterr().err
    assert (f"--healthy {ref}: holds the same samples as {a}, the recording judged: a "
            "recording cannot be its own healthy reference") in err


def test_detect_refuses_the_suspect_as_its_own_reference(files, capsys):
    (a, b, c), copy = files
    code = main(["detect", str(a), "--healthy", str(b), "--healthy", str(c), "--healthy",
                 str(copy), "--methods", "acf-p1", "--system", "vca", "--burn-in", "0",
                 "--no-progress"])
    assert code == 2
    assert (f"--healthy {copy}: holds the same samples as {a}, the recording judged"
            in capsys.readouterr().err)
