"""`--cache-dir` of reproduce and sensitivity is checked before the run (audit, 2026-11-27).

`leakdiag reproduce vca --quick --cache-dir /proc/nope -o rD` made rD, ran the first simulation,
then said "[Errno 2] No such file or directory: '/proc/nope'" without naming the option.
"""

import pytest

from leakdiag.cli.main import main


@pytest.fixture
def no_run(monkeypatch):
    """Fail the test if an experiment starts."""
    import importlib

    rep = importlib.import_module("leakdiag.studies.reproduce")  # the package exports a function
    sens = importlib.import_module("leakdiag.studies.sensitivity")  # of the module's name

    def started(*args, **kwargs):
        pytest.fail("the experiments were started")

    monkeypatch.setattr(rep, "reproduce", started)
    monkeypatch.setattr(sens, "run_sensitivity", started)


@pytest.mark.parametrize("command", ["reproduce", "sensitivity"])
def test_a_cache_dir_that_cannot_be_made_is_said_before_the_run(no_run, tmp_path, capsys,
                                                                command):
    (tmp_path / "afile").write_text("")
    bad, out = tmp_path / "afile" / "cache", tmp_path / "out"
    code = main([command, "vca", "--quick", "--scheduler", "serial", "--no-progress",
                 "--cache-dir", str(bad), "-o", str(out)])
    assert code == 2
    assert capsys.readouterr().err == (f"leakdiag: error: --cache-dir {bad}: cannot create the "
                                       "folder: Not a directory\n")
    assert not out.exists()  # checked before the output folder is made


def test_the_cache_folder_of_the_environment_is_named(no_run, tmp_path, monkeypatch, capsys):
    (tmp_path / "afile").write_text("")
    bad = tmp_path / "afile" / "cache"
    monkeypatch.setenv("LEAKDIAG_CACHE", str(bad))
    assert main(["sensitivity", "eha", "--quick", "--scheduler", "serial"]) == 2
    assert capsys.readouterr().err == (f"leakdiag: error: $LEAKDIAG_CACHE {bad}: cannot create "
                                       "the folder: Not a directory\n")
