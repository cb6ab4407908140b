"""leakdiag._holds.holds: runs of one exact value, against a plain loop."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from leakdiag._holds import holds


def _runs_by_loop(v):
    starts, lengths = [], []
    for i, x in enumerate(v):
        if i and x == v[i - 1]:  # NaN == NaN is False: a NaN starts a run of its own
            lengths[-1] += 1
        else:
            starts.append(i)
            lengths.append(1)
    return starts, lengths


@given(st.lists(st.sampled_from([0.0, -0.0, 1.0, 2.5, np.nan, np.inf]), max_size=60))
def test_holds_equal_a_plain_loop(values):
    starts, lengths = holds(values)
    ref_starts, ref_lengths = _runs_by_loop(values)
    assert starts.tolist() == ref_starts and lengths.tolist() == ref_lengths
    assert int(lengths.sum()) == len(values)


def test_holds_is_the_one_run_finder_of_the_hold_checks():
    """The frozen-window, EMD-split and longest-hold checks agree with holds() on one signal
    (each with its own policy on top)."""
    from leakdiag.detect._flow_balance_checks import longest_hold
    from leakdiag.literature._windowed import frozen_windows

    x = np.array([1.0, 2.0, 2.0, 2.0, 2.0, 2.0, 3.0, 4.0, 4.0, 5.0, 6.0, 7.0])
    starts, lengths = holds(x)
    assert (starts.tolist(), lengths.tolist()) == ([0, 1, 6, 7, 9, 10, 11], [1, 5, 1, 2, 1, 1, 1])
    assert longest_hold(x) == (5, 1)  # the run of five 2.0 (the extremes 1.0 and 7.0 are rails)
    # window 4 at 50 % overlap: windows start at 0, 2, 4, 6, 8; the hold covers samples 1-5
    assert frozen_windows(x, 4, 50).tolist() == [True, True, True, False, False]
