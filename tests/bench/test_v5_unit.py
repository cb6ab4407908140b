"""Benchmark v5, per-unit mode: own runs' seeds."""

import pytest


def test_own_seeds_are_distinct_across_units_and_runs():
    """A statistics audit (2026-11-29): with ``10 * seed + k + 1``, own run 10 of one unit was
    own run 0 of the next at ``--unit-fit 11`` (106 of 1,170 own seeds repeated). The first ten
    keep their seeds (the committed results), later ones are apart from all of them."""
    from leakdiag.bench.v5_unit import own_seed

    seeds = [s for s in range(70_000_000, 70_000_000 + 120)]
    own = [own_seed(s, k) for s in seeds for k in range(25)]
    assert len(set(own)) == len(own) and not set(own) & set(seeds)
    assert [own_seed(70_000_003, k) for k in (0, 9)] == [700000031, 700000040]
    with pytest.raises(ValueError, match="must be in"):
        own_seed(70_000_000, 10_000)
