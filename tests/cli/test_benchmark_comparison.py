"""``leakdiag benchmark --suite comparison`` (formerly ``python -m leakdiag.bench.comparison``),
through the entry point: the unsupported target refused before any folder, the options that do
not apply refused, and the files and table of a fixed result, byte for byte what the former
command wrote for it."""

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import leakdiag.bench.benchmark as benchmark  # imported before any patch: it binds run_suite
import leakdiag.bench.comparison as comparison
import leakdiag.bench.run as run
from leakdiag.cli.main import cli


def _invoke(args):
    return CliRunner().invoke(cli, ["benchmark", *args])


@pytest.fixture
def no_work(monkeypatch):
    """The comparison's work fails the test if it starts."""
    def fail(*a, **k):
        raise AssertionError("the comparison started")

    # (bench.benchmark binds run_suite when imported: a first import while run.run_suite was
    # patched kept the failing stand-in for the rest of the session, and a v4 benchmark test
    # run after this one failed with "the comparison started", depending on the test order)
    monkeypatch.setattr(run, "run_suite", fail)
    monkeypatch.setattr(benchmark, "run_suite", fail)
    monkeypatch.setattr(comparison, "run_comparison", fail)


def _fixed_result():
    runs = pd.DataFrame({"method": ["a", "a", "b"], "system": "vca", "excitation": "operating",
                         "role": ["test_healthy", "test_leak", "error"],
                         "leak_lpm": [0.0, 1.0, np.nan], "score_max": [0.25, 3.5, np.nan],
                         "alarm": [False, True, None], "error": ["", "", "ValueError: x"]})
    res = pd.DataFrame({"method": ["a"] * 3 + ["b"] * 3, "excitation": "operating",
                        "leak_lpm": [0.05, 0.2, 1.0] * 2, "auc": [0.6, 0.8, 1.0, 0.5, 0.5, 0.7],
                        "detection_rate": [0.0, 0.4, 1.0, 0.0, 0.0, 0.2],
                        "onset_error_median_s": [np.nan, 2.0, 0.5, np.nan, np.nan, 4.0],
                        "detection_delay_median_s": [np.nan, 8.0, 1.5, np.nan, np.nan, 30.0],
                        "n_runs": 5, "detections": [0, 2, 5, 0, 0, 1]})
    summ = pd.DataFrame({"method": ["a", "b"], "excitation": "operating",
                         "min_detectable_lpm": [1.0, np.nan], "false_alarms": [0, 2],
                         "n_test_healthy": [10, 10], "cpu_s_per_hour": [0.03, 38.5]})
    return comparison.ComparisonResult(runs, res, summ, {})


#: What ``python -m leakdiag.bench.comparison OUT`` wrote and printed for :func:`_fixed_result`
#: (captured from the former command before it was removed; the detection counts and the
#: 95 % intervals beside the rates since 2026-11-30, a statistics audit).
EXPECTED_FILES = {
    "runs.csv": "method,system,excitation,role,leak_lpm,score_max,alarm,error\n"
                "a,vca,operating,test_healthy,0.0,0.25,False,\n"
                "a,vca,operating,test_leak,1.0,3.5,True,\n"
                "b,vca,operating,error,,,,ValueError: x\n",
    "results.csv": "method,excitation,leak_lpm,auc,detection_rate,onset_error_median_s,"
                   "detection_delay_median_s,n_runs,detections\n"
                   "a,operating,0.05,0.6,0.0,,,5,0\n"
                   "a,operating,0.2,0.8,0.4,2.0,8.0,5,2\n"
                   "a,operating,1.0,1.0,1.0,0.5,1.5,5,5\n"
                   "b,operating,0.05,0.5,0.0,,,5,0\n"
                   "b,operating,0.2,0.5,0.0,,,5,0\n"
                   "b,operating,1.0,0.7,0.2,4.0,30.0,5,1\n",
    "summary.csv": "method,excitation,min_detectable_lpm,false_alarms,n_test_healthy,"
                   "cpu_s_per_hour\n"
                   "a,operating,1.0,0,10,0.03\n"
                   "b,operating,,2,10,38.5\n",
    "table.md": "| method | excitation | MDL L/min | AUC 0.05 | AUC 0.2 | AUC 1.0 | "
                "det 0.2 [95 % CI] | det 1.0 [95 % CI] | onset err 1.0 (s) | delay 1.0 (s) | "
                "false alarms [95 % CI] | CPU s / h |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|\n"
                "| a | operating | 1 | 0.6 | 0.8 | 1 | 2/5 = 0.4 [0.0527, 0.853] | "
                "5/5 = 1 [0.478, 1] | 0.5 | 1.5 | 0/10 = 0 [0, 0.308] | 0.03 |\n"
                "| b | operating |  | 0.5 | 0.5 | 0.7 | 0/5 = 0 [0, 0.522] | "
                "1/5 = 0.2 [0.00505, 0.716] | 4 | 30 | 2/10 = 0.2 [0.0252, 0.556] | 38.5 |\n"}
EXPECTED_STDOUT = (
    "method excitation  MDL L/min  AUC 0.05  AUC 0.2  AUC 1.0         det 0.2 [95 % CI]          "
    "det 1.0 [95 % CI]  onset err 1.0 (s)  delay 1.0 (s)     false alarms [95 % CI]  CPU s / h\n"
    "     a  operating        1.0       0.6      0.8      1.0 2/5 = 0.4 [0.0527, 0.853]         "
    "5/5 = 1 [0.478, 1]                0.5            1.5        0/10 = 0 [0, 0.308]       0.03\n"
    "     b  operating        NaN       0.5      0.5      0.7        0/5 = 0 [0, 0.522] 1/5 = "
    "0.2 [0.00505, 0.716]                4.0           30.0 2/10 = 0.2 [0.0252, 0.556]      "
    "38.50\n")


def test_comparison_command_refuses_an_unsupported_target_before_any_output(tmp_path, no_work):
    out, cache = tmp_path / "cmp", tmp_path / "cache"
    r = _invoke(["--suite", "comparison", "-o", str(out), "--n-fit", "5",
                 "--false-alarm-rate", "0.01", "--cache-dir", str(cache)])
    assert r.exit_code == 2 and not out.exists() and not cache.exists()
    assert r.stderr.splitlines()[-1] == (
        "Error: the comparison fits acf-p1's threshold on n_fit=5 healthy runs per excitation "
        "(vca), one CUSUM maximum each: they support a false-alarm target of at least 0.167 "
        "per run, and false_alarm_per_run=0.01 needs n_fit=99; give n_fit=99 or "
        "false_alarm_per_run >= 0.17")


def test_comparison_default_target_needs_its_default_fitting_runs(tmp_path, no_work):
    # 18 fitting runs support at least 1/19 = 0.0526 per run: the default 5 % is refused
    out, cache = tmp_path / "cmp", tmp_path / "cache"
    r = _invoke(["--suite", "comparison", "-o", str(out), "--n-fit", "18", "--cache-dir",
                 str(cache)])
    assert r.exit_code == 2 and not out.exists() and not cache.exists()
    assert "false_alarm_per_run=0.05 needs n_fit=19" in r.stderr


@pytest.mark.parametrize("args, flags", [
    (["--quick"], "--quick does"),
    (["--methods", "acf-p1"], "--methods does"),
    (["--systems", "vca"], "--systems does"),
    (["--loads", "none"], "--loads does"),
    (["--sizes", "0.02"], "--sizes does"),
    (["--excitations", "operating"], "--excitations does"),
    (["--n-cal", "30"], "--n-cal does"),
    (["--n-healthy", "3"], "--n-healthy does"),
    (["--n-leak", "3"], "--n-leak does"),
    (["--unit-fit", "0"], "--unit-fit does"),  # given is refused, even at its default
    (["--full-budget"], "--full-budget does"),
    (["--max-test-runs", "4"], "--max-test-runs does"),
    (["--confidence", "0.9"], "--confidence does"),
    (["--onset-method", "binseg"], "--onset-method does"),
    (["--work-dir", "w"], "--work-dir does"),
    (["--quick", "--methods", "acf-p1"], "--quick, --methods do")])
def test_options_that_do_not_apply_are_refused_with_comparison(tmp_path, no_work, args, flags):
    out = tmp_path / "o"
    r = _invoke(["--suite", "comparison", *args, "-o", str(out)])
    assert r.exit_code == 2 and not out.exists()
    assert r.stderr.splitlines()[-1] == f"Error: {flags} not apply to --suite comparison"


@pytest.mark.parametrize("suite", ["v5", "v4"])
def test_n_fit_is_refused_with_the_other_suites(tmp_path, suite):
    out = tmp_path / "o"
    r = _invoke(["--suite", suite, "--quick", "--n-fit", "19", "-o", str(out)])
    assert r.exit_code == 2 and not out.exists()
    assert r.stderr.splitlines()[-1] == "Error: --n-fit is for --suite comparison only"


def test_comparison_needs_out(no_work):
    r = _invoke(["--suite", "comparison"])
    assert r.exit_code == 2 and r.stderr.splitlines()[-1] == "Error: --out DIR is required"


def test_comparison_refuses_an_out_it_cannot_create_before_work(tmp_path, no_work):
    (tmp_path / "f").write_text("")
    out = tmp_path / "f" / "sub"
    r = _invoke(["--suite", "comparison", "-o", str(out), "--cache-dir", str(tmp_path / "c")])
    assert r.exit_code == 2
    assert r.stderr.splitlines()[-1].startswith(f"Error: --out {out}: cannot create the folder")


@pytest.mark.parametrize("args, settings", [
    (["--scheduler", "local", "--workers", "2", "--no-progress"],
     {"false_alarm_per_run": 0.05, "n_fit": 19, "scheduler": "local", "n_workers": 2,
      "progress": False}),
    (["--n-fit", "39", "--false-alarm-rate", "0.03"],
     {"false_alarm_per_run": 0.03, "n_fit": 39, "scheduler": "serial", "n_workers": None,
      "progress": True})])
def test_comparison_writes_the_former_commands_files_and_prints_its_table(tmp_path, monkeypatch,
                                                                          args, settings):
    calls = []

    def fixed(**kwargs):
        calls.append(kwargs)
        return _fixed_result()

    monkeypatch.setattr(comparison, "run_comparison", fixed)
    out, cache = tmp_path / "a" / "cmp", tmp_path / "cache"
    (tmp_path / "a").mkdir()
    r = _invoke(["--suite", "comparison", "-o", str(out), "--cache-dir", str(cache), *args])
    assert r.exit_code == 0, r.output
    assert calls == [{**settings, "cache_dir": str(cache)}]
    assert sorted(p.name for p in out.iterdir()) == sorted(EXPECTED_FILES)
    for name, text in EXPECTED_FILES.items():
        assert (out / name).read_text(encoding="utf-8") == text, name
    assert r.stdout == EXPECTED_STDOUT
    assert cache.is_dir()  # made before the work, as for the other suites


def test_comparison_defaults_are_the_ones_the_help_states():
    r = _invoke(["--help"])
    assert r.exit_code == 0
    text = " ".join(r.output.split())
    assert f"--suite comparison: {comparison.COMPARISON_FAR:g}, what its " \
           f"{comparison.COMPARISON_N_FIT} fitting runs per excitation support" in text
    assert f"(default {comparison.COMPARISON_N_FIT}, the fewest that support its " \
           f"{comparison.COMPARISON_FAR:.0%} target)".replace("%", " %") in text
    assert "[v5|v4|comparison]" in text


def test_the_command_docs_literature_md_shows_runs_the_comparison(tmp_path, monkeypatch):
    from pathlib import Path

    doc = (Path(__file__).parents[2] / "docs" / "literature.md").read_text(encoding="utf-8")
    (line,) = [x for x in doc.splitlines() if x.startswith("leakdiag benchmark --suite compar")]
    calls = []
    monkeypatch.setattr(comparison, "run_comparison",
                        lambda **kwargs: calls.append(kwargs) or _fixed_result())
    args = line.replace("OUT", str(tmp_path / "out")).replace("CACHE", str(tmp_path / "c"))
    r = CliRunner().invoke(cli, args.split()[1:])
    assert r.exit_code == 0, r.output
    # what the former `python -m leakdiag.bench.comparison OUT --workers 2 --cache-dir CACHE` ran
    assert calls == [{"false_alarm_per_run": 0.05, "n_fit": 19, "scheduler": "local",
                      "n_workers": 2, "cache_dir": str(tmp_path / "c"), "progress": True}]
