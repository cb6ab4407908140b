"""A run restricted to some leak sizes (``--sizes``, session 28) judges the same runs as the
whole suite's groups of those sizes: the seeds follow a size's place in the whole suite, as a
load's do (tests/bench/test_v5_suite_loads.py), so a restricted run neither takes another
size's seeds nor misses the cached results of the same runs."""

from dataclasses import replace

import pytest

from leakdiag.bench.v5_suite import V5_QUICK_SUITES, V5_SUITES, build_v5_suite, restrict_sizes


def _leaks(suite):
    return {(c.load, c.leak_lpm, c.seed, c.onset_s, c.nuisance["machine"])
            for c in build_v5_suite({suite.system: suite}) if c.role == "test_leak"}


def test_a_size_keeps_its_seeds_when_the_suite_is_restricted_to_it():
    whole = replace(V5_SUITES["eha"], n_test_leak=3, first_test_index=2000)
    only = restrict_sizes(whole, [0.1, 0.02])
    assert only.leak_lpm == (0.02, 0.1) and only.size_indexes == (0, 2)
    got = _leaks(only)
    assert len(got) == 2 * 2 * 3  # loads x sizes x runs
    assert got == {x for x in _leaks(whole) if x[1] in (0.02, 0.1)}
    # enumerate's order would have given 0.1 the seeds of 0.05 (place 1): not so
    assert not {x[2] for x in got if x[1] == 0.1} & {x[2] for x in _leaks(whole)
                                                      if x[1] == 0.05}
    # healthy and calibration runs are untouched
    rest = {(c.role, c.seed) for c in build_v5_suite({"eha": only}) if c.role != "test_leak"}
    assert rest == {(c.role, c.seed) for c in build_v5_suite({"eha": whole})
                    if c.role != "test_leak"}


def test_the_quick_suite_restricted_to_its_size_is_the_quick_suite():
    quick = V5_QUICK_SUITES["vca"]
    assert _leaks(restrict_sizes(quick, [0.5])) == _leaks(quick)


def test_a_size_outside_the_suite_is_refused_with_the_suites_sizes():
    with pytest.raises(ValueError, match=r"leak size 0.003 L/min is not in the vca suite's "
                                         r"sizes \[0.002, 0.005, 0.01, 0.02"):
        restrict_sizes(V5_SUITES["vca"], [0.02, 0.003])
    with pytest.raises(ValueError, match="already restricted"):
        restrict_sizes(restrict_sizes(V5_SUITES["vca"], [0.02]), [0.02])
    with pytest.raises(ValueError, match="2 size indexes for 1 sizes"):
        build_v5_suite({"vca": replace(V5_SUITES["vca"], leak_lpm=(0.02,),
                                       size_indexes=(1, 3))})


def test_cli_sizes_refused_before_any_folder_is_made(tmp_path, run_cli):
    out, cache = tmp_path / "o", tmp_path / "c"
    args = ["benchmark", "-o", str(out), "--cache-dir", str(cache), "--methods", "flow-balance"]
    code, _, err = run_cli([*args, "--systems", "vca,eha", "--sizes", "0.005"])
    assert code == 2 and not out.exists() and not cache.exists()
    assert "leak size 0.005 L/min is not in the eha suite's sizes [0.02, 0.05" in err
    code, _, err = run_cli([*args, "--sizes", "0.02,small"])
    assert code == 2 and "--sizes '0.02,small': not a comma-separated list of leak sizes" in err
    code, _, err = run_cli([*args, "--sizes", " , "])
    assert code == 2 and "--sizes: no size given" in err
    code, _, err = run_cli([*args, "--suite", "v4", "--sizes", "0.02"])
    assert code == 2 and "--sizes is for --suite v5 only" in err
    assert not out.exists() and not cache.exists()
