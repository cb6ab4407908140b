"""A no-load VCA recording cut a few seconds after the alarm: the onset is not placed at the start.

An API audit (2026-11-29) found no-load runs of machine 7, a leak from 30 s, cut at 38-45 s
(what ``monitor --segment`` judges), read LEAK "at or before 2.2 s: present from the first
window judged" with no size, while the same run cut at 40 or 60 s had its onset at 30.8 s. The
windows after the alarm pulled the leak coefficient of every candidate onset below zero (every
:math:`Z_j` of the change-point profile negative), and the argmax of negative values is the
first window. Now such a recording is said not to locate its onset: LEAK with an onset at or
before the alarm (censored, with why) and no size; located onsets are unchanged (grid of 324
cut no-load runs: 26 false "at or before" bounds before, 2 after; 286 located onsets, median
error 1.16 s, as before; spring runs identical).
"""

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect import FlowBalanceDetector


@pytest.fixture(scope="module")
def unit7():
    healthy = [ld.sim.simulate_vca(duration=60.0, leak_lpm=0, seed=s, machine=7)
               for s in (11, 12, 13, 14, 15, 16)]
    return FlowBalanceDetector(system="vca").fit(healthy)


def test_a_run_cut_after_the_alarm_says_its_onset_is_before_the_alarm(unit7):
    run = ld.sim.simulate_vca(duration=60.0, leak_lpm=0.3, onset=30.0, seed=33, machine=7)
    cut = run.slice_time(0.0, 45.0)
    t, _, _, g, arg = unit7._scan(cut, "predict")
    i = int(np.flatnonzero(g >= unit7.threshold_)[0])
    z = unit7._onset_profile(t, i, int(arg[i]))[1]
    assert not np.any(z > 0)  # the case: no positive step fits the whole recording
    v = unit7.predict(cut)
    assert v.leak and v.onset_censored
    assert v.onset_s == pytest.approx(v.alarm_time_s) and v.onset_s >= 30.0  # an upper bound
    assert "does not locate the onset" in v.onset_why
    assert v.leak_lpm is None and "does not locate the onset" in v.leak_lpm_interval_holds
    # the whole run and a shorter cut locate it, as before
    for rec in (run, run.slice_time(0.0, 40.0)):
        w = unit7.predict(rec)
        assert not w.onset_censored and w.onset_s == pytest.approx(30.757, abs=1e-3)
    assert unit7.predict(run).leak_lpm is not None
    # cut at 40 s, 9 windows follow the onset: no size (a flow-balance audit, 2026-11-29:
    # from so few a no-load size missed the truth up to 21x, VCA_SIZE_MIN_WINDOWS)
    w = unit7.predict(run.slice_time(0.0, 40.0))
    assert w.leak_lpm is None and "a VCA size needs 10" in w.leak_lpm_interval_holds
