"""``leakdiag simulate`` command line."""

import numpy as np

import leakdiag as ld
from leakdiag.cli.main import main


def test_simulate_vca_writes_parquet_and_plot(tmp_path, capsys):
    out = tmp_path / "run.parquet"
    code = main(["simulate", "vca", "--duration", "6", "--onset", "3", "--leak", "0.1",
                 "--leak-model", "laminar", "--load", "spring", "--seed", "4",
                 "--out", str(out), "--plot"])
    assert code == 0
    rec = ld.io.read_recording(out)
    assert rec.channel_names == ["p1", "p2", "x", "u", "leak_flow", "x_ref"]
    assert rec.meta["leak_model"] == "laminar" and rec.meta["load"] == "spring"
    assert abs(rec.meta["leak_lpm_achieved"] - 0.1) <= 0.002
    # the file holds the same samples as the API gives for the same arguments
    api = ld.sim.simulate_vca(duration=6.0, onset=3.0, leak_lpm=0.1, leak_model="laminar",
                              load="spring", seed=4)
    assert np.array_equal(rec["p1"], api["p1"])
    assert (tmp_path / "run.png").stat().st_size > 10_000
    assert "achieved" in capsys.readouterr().out


def test_simulate_draws_a_virtual_machine_unit(tmp_path, capsys):
    out = tmp_path / "m17.parquet"
    assert main(["simulate", "vca", "--duration", "4", "--leak", "0", "--machine", "17",
                 "--load", "spring", "--no-progress", "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip().endswith(
        "(4000 samples at 1000 Hz, machine unit 17, load spring); no leak")
    rec = ld.io.read_recording(out)
    api = ld.sim.simulate_vca(duration=4.0, leak_lpm=0.0, load="spring", machine=17, seed=1)
    assert rec.meta["machine"]["unit"] == 17 and np.array_equal(rec["p1"], api["p1"])
    assert main(["simulate", "eha", "--duration", "4", "--machine", "-1", "--out",
                 str(tmp_path / "x.parquet")]) == 2
    assert "Invalid value for '--machine': -1 is not in the range x>=0" in \
        capsys.readouterr().err


def test_simulate_bad_onset_is_a_one_line_error(tmp_path, capsys):
    code = main(["simulate", "vca", "--duration", "2", "--onset", "5",
                 "--out", str(tmp_path / "x.parquet")])
    assert code == 2
    assert ("--onset 5 s must lie in [0, 1.999) s: before the run's last sample (2000 samples "
            "at 1000 Hz, --duration 2 s)") in capsys.readouterr().err


def test_simulate_eha_same_options_as_vca(tmp_path, capsys):
    """One signature: the EHA takes the VCA's options (--leak-kind, --ramp-duration, progress)."""
    out = tmp_path / "eha.parquet"
    code = main(["simulate", "eha", "--duration", "25", "--onset", "12", "--leak", "1.0",
                 "--leak-kind", "ramp", "--ramp-duration", "4", "--seed", "3", "--out", str(out)])
    assert code == 0
    rec = ld.io.read_recording(out)
    assert rec.meta["system"] == "eha" and rec.meta["leak_kind"] == "ramp"
    assert rec.meta["ramp_duration"] == 4.0 and rec.meta["onset"] == 12.0
    assert abs(rec.meta["leak_lpm_achieved"] / 1.0 - 1) <= 0.02
    api = ld.sim.simulate_eha(duration=25.0, onset=12.0, leak_lpm=1.0, leak_kind="ramp",
                              ramp_duration=4.0, seed=3)
    assert np.array_equal(rec["p1"], api["p1"])
    assert f"achieved {rec.meta['leak_lpm_achieved']:.4g} L/min" in capsys.readouterr().out


def test_simulate_eha_laminar_leak_is_a_one_line_error(tmp_path, capsys):
    """The EHA has Eq. 2-4 only: --leak-model laminar is refused, not ignored."""
    code = main(["simulate", "eha", "--duration", "25", "--onset", "12",
                 "--leak-model", "laminar", "--out", str(tmp_path / "x.parquet")])
    assert code == 2
    err = capsys.readouterr().err
    errors = [ln for ln in err.splitlines() if "error" in ln.lower()]
    assert "Traceback" not in err and len(errors) == 1
    assert errors[0] == ("Error: --leak-model laminar: the EHA's leak is the thesis's turbulent "
                         "needle-valve flow, Eq. 2-4, only")
    assert not (tmp_path / "x.parquet").exists()


def test_simulate_help_states_each_rigs_defaults(capsys):
    """The help's per-rig defaults are the simulators' own (one signature, no introspection)."""
    import inspect

    assert main(["simulate", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    for name, flag in (("duration", "Run length"), ("leak_lpm", "Target mean leak")):
        vca = inspect.signature(ld.sim.simulate_vca).parameters[name].default
        eha = inspect.signature(ld.sim.simulate_eha).parameters[name].default
        part = text[text.index(flag):]
        assert f"{vca:g} for vca, {eha:g} for eha" in part[:160], (name, part[:160])
    # the onset's default is half the run in the simulators themselves, as the help says
    for fn in (ld.sim.simulate_vca, ld.sim.simulate_eha):
        assert inspect.signature(fn).parameters["onset"].default is None
    dur = {s: inspect.signature(getattr(ld.sim, f"simulate_{s}")).parameters["duration"].default
           for s in ("vca", "eha")}
    part = text[text.index("Leak onset"):]
    assert (f"half of --duration, as in Secs. 4.5, 4.6: {dur['vca'] / 2:g} for vca, "
            f"{dur['eha'] / 2:g} for eha") in part[:200], part[:200]


def test_simulate_says_what_it_did_not_use_and_refuses_what_cannot_be(tmp_path, capsys):
    """Found by an audit session (2026-11-27): --ramp-duration without a ramp and --onset
    without a leak were silently ignored, a ramp longer than the run was not mentioned, and the
    EHA's laminar law failed with a bare choice list."""
    out = str(tmp_path / "r.parquet")
    assert main(["simulate", "vca", "--duration", "40", "--onset", "20", "--leak", "0.1",
                 "--leak-kind", "ramp", "--no-progress", "--out", out]) == 0
    said = capsys.readouterr().out
    rec = ld.io.read_recording(out)
    assert rec.meta["ramp_duration"] == 100.0  # the VCA's default, now in --help
    assert "the 100-s ramp from 20 s outlasts the run (40 s): the leak still rises" in said
    assert main(["simulate", "vca", "--duration", "4", "--onset", "2", "--leak", "0",
                 "--no-progress", "--out", out]) == 0
    assert capsys.readouterr().out.strip().endswith(
        "no leak (--onset 2 ignored: no leak to start)")
    assert main(["simulate", "vca", "--duration", "4", "--ramp-duration", "10",
                 "--no-progress", "--out", out]) == 2
    assert "--ramp-duration applies to ramp leaks: add --leak-kind ramp" in capsys.readouterr().err
    assert main(["simulate", "eha", "--duration", "4", "--leak-model", "laminar",
                 "--no-progress", "--out", out]) == 2
    assert "the EHA's leak is the thesis's turbulent needle-valve flow, Eq. 2-4, only" in \
        capsys.readouterr().err


def test_the_default_onset_is_half_the_run_in_the_library_as_in_the_cli():
    """A review (2026-11-27): the CLI's default onset followed --duration, the library's stayed
    200 / 90 s, so the same arguments leaked from different times."""
    rec = ld.sim.simulate_vca(duration=30.0, leak_lpm=0.5, seed=1)
    assert rec.meta["onset"] == 15.0
    rec = ld.sim.simulate_eha(duration=20.0, leak_lpm=1.2, seed=1)
    assert rec.meta["onset"] == 10.0
