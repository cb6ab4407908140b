"""`leakdiag simulate`: a run too short to calibrate its leak is told in the command's options.

The simulator's own advice names Python arguments (``leak_coefficient=``, ``leak_lpm``) that the
command line does not have; the command says which options to change and by how much.
"""

from leakdiag.cli.main import main


def test_too_short_run_names_cli_options(tmp_path, capsys):
    out = tmp_path / "r.parquet"
    code = main(["simulate", "vca", "--duration", "3", "--onset", "1.5", "--leak", "0.3",
                 "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("leakdiag: error: the run is too short to calibrate a 0.3 L/min leak")
    assert "leak_coefficient" not in err and "leak_lpm" not in err
    assert ("Give a longer --duration or an earlier --onset: at least 10 s must follow the "
            "onset (now --duration 3 with the onset at 1.5 s leaves 1.5 s), e.g. --duration "
            "11.5; or --leak 0 for a run without a leak.") in err
    assert not out.exists()


def test_default_onset_is_named_as_half_the_run(tmp_path, capsys):
    code = main(["simulate", "vca", "--duration", "3", "--leak", "0.3", "--no-progress",
                 "-o", str(tmp_path / "r.parquet")])
    err = capsys.readouterr().err
    assert code == 2
    assert "now --duration 3 with the onset at 1.5 s leaves 1.5 s), e.g. --duration 11.5" in err
