"""A run restricted to some loads judges the same runs as the full suite's groups of those
loads (an audit, 2026-11-27: ``--loads spring`` took load none's seeds, so a work folder that
held a ``--loads none`` run served its results, load none's, as spring's)."""

from dataclasses import replace

from leakdiag.bench.v5_suite import V5_SUITES, build_v5_suite


def test_a_load_keeps_its_seeds_when_the_suite_is_restricted_to_it():
    full = {(c.load, c.role, c.seed) for c in build_v5_suite(V5_SUITES) if c.system == "vca"}
    only = build_v5_suite({"vca": replace(V5_SUITES["vca"], loads=("spring",))})
    assert {c.load for c in only} == {"spring"}
    assert {(c.load, c.role, c.seed) for c in only} <= full
    none = build_v5_suite({"vca": replace(V5_SUITES["vca"], loads=("none",))})
    assert not {c.seed for c in only} & {c.seed for c in none}


def test_a_load_outside_the_suite_is_refused_not_given_another_loads_seeds():
    import pytest

    with pytest.raises(ValueError, match="load 'rigid' is not in the v5 suite's loads"):
        build_v5_suite({"vca": replace(V5_SUITES["vca"], loads=("rigid",))})
