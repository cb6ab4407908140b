"""One consistent command line (issue 15, sec. 4): help on every option, an example at the end of
every --help, -o meaning --out, --onset in seconds, --scheduler serial|local|ADDRESS."""

import importlib

import click
import pytest
from click.testing import CliRunner

from leakdiag.cli.main import COMMANDS, cli

MINE = sorted(COMMANDS)  # every command (benchmark and reproduce included since issue 15's audit)


def _command(name) -> click.Command:
    mod, attr = COMMANDS[name].split(":")
    return getattr(importlib.import_module(mod), attr)


@pytest.mark.parametrize("name", MINE)
def test_every_option_has_help(name):
    cmd = _command(name)
    missing = [p.opts[0] for p in cmd.params if isinstance(p, click.Option) and not p.help]
    assert missing == []


@pytest.mark.parametrize("name", MINE)
def test_help_ends_with_an_example(name):
    r = CliRunner().invoke(cli, [name, "--help"])
    assert r.exit_code == 0
    last = r.output.strip().splitlines()[-1].strip()
    assert last.startswith("leakdiag ") or "Example: leakdiag " in r.output.strip().split(
        "\n\n")[-1], r.output[-400:]


@pytest.mark.parametrize("name", MINE)
def test_dash_o_means_out(name):
    cmd = _command(name)
    for p in cmd.params:
        if isinstance(p, click.Option) and ("-o" in p.opts or "--out" in p.opts):
            assert {"-o", "--out"} <= set(p.opts), (name, p.opts)  # both or neither


@pytest.mark.parametrize("name", MINE)
def test_onset_is_seconds(name):
    for p in _command(name).params:
        if isinstance(p, click.Option) and "--onset" in p.opts:
            assert p.type is click.FLOAT or isinstance(p.type, click.types.FloatParamType)
            assert "(s)" in p.help or " s " in p.help or "seconds" in p.help.lower()


def test_scheduler_is_one_option_wherever_dask_runs():
    """reproduce, sensitivity, benchmark and batch: the same --scheduler serial|local|ADDRESS."""
    opts = {n: [p for p in _command(n).params if "--scheduler" in getattr(p, "opts", [])]
            for n in MINE}
    have = sorted(n for n, o in opts.items() if o)
    assert have == ["batch", "benchmark", "reproduce", "sensitivity"]
    for n in have:
        (opt,) = opts[n]
        assert (opt.metavar, opt.help) == (opts["batch"][0].metavar, opts["batch"][0].help), n
        assert "serial" in opt.help and "local" in opt.help and "address" in opt.help


def test_benchmark_onset_estimator_is_onset_method():
    r = CliRunner().invoke(cli, ["benchmark", "--onset", "pelt", "--list-methods"])
    assert r.exit_code == 2 and "No such option '--onset'" in r.output
    opts = {o for p in _command("benchmark").params for o in getattr(p, "opts", [])}
    assert "--onset-method" in opts


def test_batch_serial_flag_is_gone_for_scheduler_serial():
    r = CliRunner().invoke(cli, ["batch", "x", "--config", __file__, "-o", "y", "--serial"])
    assert r.exit_code == 2 and "No such option '--serial'" in r.output


@pytest.mark.parametrize("name", ["analyze", "detect", "fit", "monitor", "sweep"])
def test_recording_options_everywhere(name):
    opts = {o for p in _command(name).params for o in getattr(p, "opts", [])}
    assert {"--map", "--col", "--sample-rate", "--time-unit"} <= opts


def test_first_run_says_the_kernels_compile_once(tmp_path, monkeypatch, capsys):
    from leakdiag.cli.main import main

    import leakdiag.cli.main as m

    monkeypatch.setattr(m, "_stderr_is_terminal", lambda: True)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "empty-cache"))
    main(["analyze", str(tmp_path / "nope.csv")])
    assert "first run: compiling the feature kernels" in capsys.readouterr().err
    from leakdiag._numba_cache import kernel_cache_dir

    # an index of another code's kernels (or of the simulators only) is no cache of these
    other = tmp_path / "empty-cache" / "leakdiag-0123456789abcdef" / "features_00"
    other.mkdir(parents=True)
    (other / "k.nbi").write_bytes(b"")
    (kernel_cache_dir() / "sim_00").mkdir(parents=True)
    (kernel_cache_dir() / "sim_00" / "k.nbi").write_bytes(b"")
    main(["analyze", str(tmp_path / "nope.csv")])
    assert "first run: compiling the feature kernels" in capsys.readouterr().err
    mine = kernel_cache_dir() / "features_00"
    assert mine.parent.parent == tmp_path / "empty-cache"
    mine.mkdir()
    (mine / "k.nbi").write_bytes(b"")
    main(["analyze", str(tmp_path / "nope.csv")])
    assert "first run" not in capsys.readouterr().err
    main(["analyze", "--help"])


def test_monitor_error_advises_no_option_monitor_lacks(tmp_path, capsys):
    import numpy as np

    from leakdiag.cli.main import main

    t = np.arange(3000) / 1000.0
    t[1000:] += 0.0004  # one irregular interval
    path = tmp_path / "nonuni.csv"
    path.write_text("time,p1\n" + "".join(f"{a},{np.sin(a * 50)}\n" for a in t))
    assert main(["monitor", "-i", str(path), "-c", "p1", "-q"]) == 2
    err = capsys.readouterr().err
    # the resampling it can be given (a user-data audit, 2026-11-29: "leakdiag analyze
    # --resample RATE_HZ reads it" wrote no file to monitor)
    assert "not uniformly sampled" in err and \
        "leakdiag.io.write_recording(leakdiag.io.read_recording(FILE, resample=RATE_HZ)" in err
    assert "(--resample RATE_HZ)" not in err
    # detect has --resample, so it may advise it
    opts = {o for p in _command("detect").params for o in getattr(p, "opts", [])}
    assert "--resample" in opts


def test_sweep_figures_are_readable_and_name_the_users_file(tmp_path, capsys):
    import matplotlib.image as mpimg
    import numpy as np

    import leakdiag as ld
    from leakdiag.cli.main import main

    rng = np.random.default_rng(3)
    p1 = np.convolve(rng.standard_normal(12_000), np.ones(5) / 5, mode="same")
    p1[6000:] = rng.standard_normal(6000)
    path = tmp_path / "myrig.csv"
    ld.Recording({"p1": 1e6 + 1e3 * p1}, 1000.0).to_pandas().to_csv(path, index=False)
    assert main(["sweep", str(path), "-c", "p1", "--lags", "1,2", "--windows", "100,200",
                 "--overlaps", "5", "--onset", "6", "--chunk", "2", "-o", str(tmp_path / "sw")]) == 0
    img = mpimg.imread(tmp_path / "sw" / "pct_vs_window.png")
    assert img.shape[1] >= 900  # pixels wide
    from leakdiag.report.study_plots import plot_pct_vs_parameter

    fig = plot_pct_vs_parameter([100, 200], [10.0, 20.0], xlabel="window N (samples)",
                                label="myrig.csv")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "window N (samples)" and ax.get_ylabel() == "% change of mean RMS"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["myrig.csv"]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_no_progress_wherever_there_is_progress():
    """Commands that print progress (bars or per-step lines on stderr) can be silenced."""
    for name in ["batch", "benchmark", "detect", "fit", "reproduce", "sensitivity", "simulate"]:
        opts = {o for p in _command(name).params for o in getattr(p, "opts", [])}
        assert "--no-progress" in opts, name


def test_batch_draws_no_bar_into_a_log(tmp_path):
    """Not at a terminal (a log, CI), batch prints its summary line once and no progress bar."""
    import numpy as np

    import leakdiag as ld

    d = tmp_path / "recs"
    d.mkdir()
    for i in range(3):
        ld.io.write_recording(ld.Recording({"p1": np.sin(np.arange(2000.0) * (1 + i))}, 1000.0),
                              d / f"r{i}.parquet")
    job = tmp_path / "job.toml"
    job.write_text('[[analysis]]\nmethod = "autocorrelation"\nchannels = ["p1"]\n')
    r = CliRunner().invoke(cli, ["batch", str(d / "*.parquet"), "--config", str(job), "-o",
                                 str(tmp_path / "res"), "--scheduler", "serial"])
    assert r.exit_code == 0, r.output
    assert r.output.count("3 recording(s): 3 run") == 1
    assert "rec/s" not in r.output and "%|" not in r.output


def test_reproduce_says_it_writes_the_report_after_the_bar(tmp_path, monkeypatch):
    """The report takes tens of seconds after the progress bar's 100 %: said before it starts."""
    import types

    import pandas as pd

    rp = importlib.import_module("leakdiag.studies.reproduce")  # the package's reproduce()
    said = []                                                 # shadows the module's name
    rep = types.SimpleNamespace(tables=pd.DataFrame({"direction_agrees": [True]}),
                                timing={"n_cases": 1, "cache_hits": 0, "wall_s": 1.0})
    monkeypatch.setattr(rp, "reproduce", lambda *a, **k: rep)

    def write_outputs(rep_, out, command):
        said.append(capture.getvalue())
        return {"html": out}

    monkeypatch.setattr(importlib.import_module("leakdiag.report.reproduction"), "write_outputs",
                        write_outputs)
    import contextlib
    import io

    from leakdiag.cli.main import main

    capture = io.StringIO()
    with contextlib.redirect_stderr(capture):
        assert main(["reproduce", "vca", "--quick", "-o", str(tmp_path), "--scheduler",
                     "serial"]) == 0
    assert said and "writing the report (tables, figures, HTML and Markdown)" in said[0]


def test_one_false_alarm_option_name():
    """Every command that takes a false-alarm target calls it --false-alarm-rate."""
    for name in MINE:
        for p in _command(name).params:
            for o in getattr(p, "opts", []):
                if "alarm" in o:
                    assert o == "--false-alarm-rate", (name, o)


def test_every_false_alarm_rate_shows_its_range_in_help():
    """detect's --false-alarm-rate showed only its default while analyze, fit and benchmark
    showed the values they take (docs audit 2026-11-29): each is a range, open at 0."""
    for name in MINE:
        for p in _command(name).params:
            if "--false-alarm-rate" in getattr(p, "opts", []):
                assert isinstance(p.type, click.FloatRange), name
                assert (p.type.min, p.type.min_open) == (0, True), name
    out = CliRunner().invoke(cli, ["detect", "--help"], terminal_width=200).output
    assert "[default: 0.01; 0<x<1]" in out


@pytest.mark.parametrize("rate", ["1", "0", "-0.1", "1.5"])
def test_detect_refuses_a_false_alarm_rate_out_of_its_range(run_cli, tmp_path, rate):
    x, h = tmp_path / "x.parquet", tmp_path / "h.parquet"
    x.touch()
    h.touch()
    code, out, err = run_cli(["detect", str(x), "--healthy", str(h), "--false-alarm-rate", rate])
    assert code == 2 and f"'--false-alarm-rate': {float(rate)} is not in the range 0<x<1" in err
