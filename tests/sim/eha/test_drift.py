"""EHA drift under the spring load of Sec. 4.6 and its stop under a leak (Fig. 4-10).

Mechanism (docs/models.md, "EHA drift"): under the spring the mean chamber pressure difference
balances the spring, ``A mean(P_A - P_B) = k_s mean(x)``; without a leak only the pump's
internal paths relieve it, so the mean position creeps towards the spring's neutral point; a
bypass leak drains the mean pressure difference and the creep ends at the neutral point.
"""

import numpy as np
import pytest

from leakdiag.sim import simulate_eha
from leakdiag.sim.eha.params import EHAParams


@pytest.fixture(scope="module")
def runs():
    out = {}
    for leak in (None, 1.2):
        out[leak] = simulate_eha(duration=40.0, leak_lpm=leak, onset=10.0, seed=1,
                                 load="spring", sensors=False)
    return out


def _blocks(v, n=5000):
    return np.array([v[i:i + n].mean() for i in range(0, v.size - n + 1, n)])


def test_mean_load_pressure_balances_the_spring(runs):
    p = EHAParams()
    rec = runs[None]
    x = _blocks(rec["x"])
    dp = _blocks(rec["p1"] - rec["p2"])
    # force balance over whole cycles (5 s = 3.2 periods of 4 rad/s; friction and inertia
    # average out): A mean(dp) = k_s mean(x)
    assert dp == pytest.approx(p.spring_stiffness_n_per_m * x / p.piston_area_m2, rel=0.05,
                               abs=20e3)


def test_drift_creeps_without_leak_and_stops_at_neutral_under_leak(runs):
    x0 = _blocks(runs[None]["x"]) * 1e3  # mm
    x1 = _blocks(runs[1.2]["x"]) * 1e3
    # no leak: the mean position falls block after block over the first 25 s, still > 10 mm
    assert np.all(np.diff(x0[:6]) < 0) and x0[-1] > 10.0
    # same run up to the onset (10 s), then the leak drains the load pressure: within 10 s
    # the mean position sits at the spring's neutral point and stays there
    assert x1[:2] == pytest.approx(x0[:2], abs=1e-9)
    assert np.all(np.abs(x1[4:]) < 2.5)
    dp1 = _blocks(runs[1.2]["p1"] - runs[1.2]["p2"])
    assert np.all(np.abs(dp1[4:]) < 0.2 * _blocks(runs[None]["p1"] - runs[None]["p2"])[4:])
