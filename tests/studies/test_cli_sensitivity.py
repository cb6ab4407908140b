"""`leakdiag sensitivity` on one short VCA experiment: every VCA method measured, ranges printed."""

import pandas as pd
import pytest

import leakdiag.sim as sim
from leakdiag.cli.main import main
from leakdiag.studies.protocol import SENSITIVITY_METHODS


@pytest.mark.skipif(not hasattr(sim, "simulate_vca"), reason="no VCA simulator")
def test_sensitivity_cli_one_experiment(tmp_path, capsys):
    out = tmp_path / "s"
    out.mkdir()
    for name in ("sensitivity_eha.png", "sensitivity_other.png"):  # an earlier run's, the user's
        (out / name).write_bytes(b"old")
    code = main(["sensitivity", "vca", "--quick", "--leaks", "0.3", "--seeds", "3",
                 "--durations", "24", "--loads", "none", "--scheduler", "serial",
                 "--cache-dir", str(tmp_path / "cache"), "--out", str(out)])
    assert code == 0
    rows = pd.read_csv(out / "sensitivity.csv")
    assert len(rows) == len(SENSITIVITY_METHODS["vca"])
    assert set(rows.leak_lpm) == {0.3} and set(rows.duration) == {24.0}
    assert set(rows.load) == {"none"} and set(rows.seed) == {3}
    summ = pd.read_csv(out / "sensitivity_summary.csv")
    assert (summ.n_runs <= 1).all()
    assert (summ.min_pct.dropna() == summ.max_pct.dropna()).all()  # one run: min == max
    assert (out / "sensitivity_vca.png").stat().st_size > 1000
    text = capsys.readouterr().out
    assert "thesis_min_pct" in text
    # the EHA figure of an earlier run no longer sits beside tables without EHA rows (audit
    # 2026-11-27: it stayed, and the command said it wrote "sensitivity_*.png")
    assert sorted(p.name for p in out.iterdir()) == [
        "sensitivity.csv", "sensitivity_other.png", "sensitivity_summary.csv",
        "sensitivity_vca.png"]
    assert text.splitlines()[-2:] == [
        f"wrote {out}/: sensitivity.csv, sensitivity_summary.csv, sensitivity_vca.png",
        f"removed sensitivity_eha.png from {out}/ (an earlier run's figure of a system this run "
        "does not measure)"]


# ------------------------------------------ audit of the commands' options, 2026-11-27
@pytest.fixture
def no_run(monkeypatch):
    """Any option refused below is refused before the first experiment."""
    import leakdiag.studies.sensitivity as sens

    monkeypatch.setattr(sens, "run_sensitivity",
                        lambda *a, **k: pytest.fail("the experiments were started"))


@pytest.mark.parametrize("args, message", [
    (["vca", "--loads", ""],  # used to run the default loads
     "Error: Invalid value for '--loads': '' is an empty list; give e.g. spring,none"),
    (["vca", "--loads", "spring,foo"],
     "Error: Invalid value for '--loads': 'foo' in 'spring,foo': a load must be one of spring, "
     "none"),
    (["vca", "--leaks", ""],
     "Error: Invalid value for '--leaks': '' is an empty list; give e.g. 0.047,0.1,0.5"),
    (["vca", "--leaks", "0.1,-1"],
     "Error: Invalid value for '--leaks': -1.0 in '0.1,-1': a leak size must be a finite number "
     "of L/min >= 0 (0: no leak)"),
    (["vca", "--durations", "nan"],
     "Error: Invalid value for '--durations': nan: a run length must be a finite number of s > 0"),
    (["vca", "--seeds", "-1"], "Error: Invalid value for '--seeds': -1: a seed must be >= 0"),
    (["vca", "--seeds", "1.5"],
     "Error: Invalid value for '--seeds': cannot read '1.5' as a list of int"),
    (["eha", "--durations", "80"],  # used to run 40 s without a word
     "Error: --durations sets the VCA's run lengths only; the EHA's case-study-3 runs last 40 s "
     "with --quick: drop --durations for eha"),
    (["vca", "--workers", "0", "--scheduler", "local"],  # used to wait at 0 % until killed
     "Error: Invalid value for '--workers': 0 is not in the range x>=1."),
    (["vca", "--workers", "-1", "--scheduler", "local"],
     "Error: Invalid value for '--workers': -1 is not in the range x>=1."),
    (["vca", "--workers", "2", "--scheduler", "serial"],  # used to be ignored
     "Error: --workers 2 is for --scheduler local (serial runs every case in this process): "
     "drop --workers or give --scheduler local"),
])
def test_sensitivity_refuses_bad_options_before_the_experiments(no_run, capsys, args, message):
    code = main(["sensitivity", *args, "--quick", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.splitlines()[-1] == message


def test_sensitivity_eha_durations_without_quick(no_run, capsys):
    assert main(["sensitivity", "eha", "--durations", "80", "--scheduler", "serial"]) == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "Error: --durations sets the VCA's run lengths only; the EHA's case-study-3 runs last "
        "180 s: drop --durations for eha")


def test_sensitivity_out_that_cannot_be_made_is_said_before_the_experiments(no_run, tmp_path,
                                                                            capsys):
    (tmp_path / "afile").write_text("")
    bad = tmp_path / "afile" / "sens"
    assert main(["sensitivity", "vca", "--quick", "--scheduler", "serial", "--out",
                 str(bad)]) == 2
    assert capsys.readouterr().err == (f"leakdiag: error: --out {bad}: cannot create the "
                                       "folder: Not a directory\n")


def test_sensitivity_all_durations_set_the_vca_only(monkeypatch, capsys):
    seen = {}

    def fake(systems, cfg, **kw):
        seen.update(systems=systems, cfg=cfg, kw=kw)
        return pd.DataFrame(), pd.DataFrame({"system": []})

    import leakdiag.studies.sensitivity as sens

    monkeypatch.setattr(sens, "run_sensitivity", fake)
    assert main(["sensitivity", "all", "--quick", "--durations", "80", "--loads", "none",
                 "--scheduler", "local", "--workers", "2", "--no-progress"]) == 0
    cfg = seen["cfg"]
    assert seen["systems"] == ("vca", "eha") and seen["kw"]["n_workers"] == 2
    assert cfg.vca_sensitivity_durations_s == (80.0,) and cfg.eha_sensitivity_duration_s == 40.0
    assert cfg.loads == ("none",)


@pytest.mark.parametrize("args, message", [
    (["--durations", "1e9", "--scheduler", "serial"],
     "Error: Invalid value for '--durations': 1e+09: a 1e+09-s run is 1e+12 samples at 1000 Hz "
     "and needs about 182 TiB of memory (200 bytes per sample); one run may use 16 GiB (this "
     "machine's memory): give run lengths of at most 85899 s"),
    (["--durations", "60,1e6", "--scheduler", "local", "--workers", "2"],
     "Error: Invalid value for '--durations': 1e+06: a 1e+06-s run is 1e+09 samples at 1000 Hz "
     "and needs about 186 GiB of memory (200 bytes per sample); one run may use 8 GiB (16 GiB "
     "of memory / 2 local workers): give run lengths of at most 42949 s"),
])
def test_sensitivity_refuses_a_run_longer_than_memory_holds(no_run, monkeypatch, capsys, args,
                                                            message):
    """--durations 1e9 gave numpy's _ArrayMemoryError traceback ('Unable to allocate 7.28
    TiB'), exit 1, after the first simulation had started."""
    import leakdiag.cli.sensitivity as cli_sens

    monkeypatch.setattr(cli_sens, "memory_bytes", lambda: 16 * 2**30)
    code = main(["sensitivity", "vca", "--quick", "--leaks", "0.1", "--loads", "none", *args])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.splitlines()[-1] == message
