"""VCA flow balance: window boundaries at quiet valve flow, and the valve timing term."""

import dataclasses
import math

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect._flow_balance_bounds import fixed_bounds, quiet_bounds
from leakdiag.detect._flow_balance_vca import (
    _QA, _QB, _TR1, _TR2, VCAValveModel, identify, recording_bounds, vca_raw_sums, vca_terms,
)
from leakdiag.sim.vca.params import VCAParams

P = VCAParams()
#: A unit whose valve is faster than Table 2-1: to first order a lead of
#: 2 zeta (1/omega_150 - 1/omega_175) = 0.212 ms (docs/detect.md, section 8.4).
FAST = dataclasses.replace(P, valve_natural_frequency_hz=175.0)
LEAD_S = 2 * P.valve_damping_ratio * (1 / (2 * math.pi * 150.0) - 1 / (2 * math.pi * 175.0))


def _arrays(rec):
    return tuple(np.ascontiguousarray(rec[c]) for c in ("p1", "p2", "x", "u"))


def _steps(rec):
    return np.flatnonzero(np.diff(rec["x_ref"]) != 0) + 1


def test_quiet_bounds_moves_only_a_boundary_inside_a_busy_stretch():
    xv = np.zeros(5001)
    xv[1990:] = 1.0  # spool step 10 ms before the boundary at 2000: busy 1969..2009
    xv[3600:] = 2.0  # far from any boundary
    b = quiet_bounds(xv, 1000, 1000.0)
    assert b.tolist() == [0, 1000, 2010, 3000, 4000, 5000]
    assert fixed_bounds(5001, 1000).tolist() == [0, 1000, 2000, 3000, 4000, 5000]
    with pytest.raises(ValueError, match="search_fraction"):
        quiet_bounds(xv, 1000, 1000.0, search_fraction=0.5)


def test_boundaries_land_away_from_command_steps():
    rec = ld.sim.simulate_vca(duration=120, leak_lpm=0.0, load="spring", seed=5)
    b = recording_bounds(_arrays(rec), rec.sample_rate, P, 1000, quiet=True)
    nominal = np.arange(len(b)) * 1000
    assert np.all(np.diff(b) > 0) and np.abs(b - nominal).max() <= 250
    d = b[None, 1:-1] - _steps(rec)[:, None]  # boundary minus step (samples = ms)
    assert d[d >= 0].min() >= 100  # the transient after a step stays inside one window
    assert -d[d < 0].max() >= 20   # and the step itself does not sit on the boundary
    fixed = fixed_bounds(len(rec["u"]), 1000)[1:-1]
    df = fixed[None, :] - _steps(rec)[:, None]
    assert np.any((df >= 0) & (df < 100))  # a real test: fixed windows do cut transients


def test_adjacent_windows_add_up_exactly_with_moved_boundaries():
    rec = ld.sim.simulate_vca(duration=20, leak_lpm=0.05, onset=5, load="spring", seed=4)
    a = _arrays(rec)
    b = recording_bounds(a, rec.sample_rate, P, 1000, quiet=True)
    merged = b[::2] if len(b) % 2 else b[:-1][::2]
    fine = vca_raw_sums(a, rec.sample_rate, P, 0.01, P.supply_pressure_pa, 150.0, b, False)
    coarse = vca_raw_sums(a, rec.sample_rate, P, 0.01, P.supply_pressure_pa, 150.0, merged,
                          False)
    n = len(coarse)
    additive = [0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 12, 13, 14, _TR1, _TR2]
    pairs = fine[:2 * n, additive].reshape(n, 2, -1).sum(axis=1)
    scale = np.abs(coarse[:, additive]).max(axis=0)
    assert np.all(scale > 0)
    np.testing.assert_allclose(pairs / scale, coarse[:, additive] / scale, rtol=0, atol=1e-12)
    m = VCAValveModel.nominal(P)
    rf = vca_terms(fine, P, m)["residual"][:2 * n].reshape(n, 2).sum(axis=1)
    np.testing.assert_allclose(rf, vca_terms(coarse, P, m)["residual"], rtol=1e-9, atol=1e-15)


def test_planted_bandwidth_error_splits_at_a_boundary_in_a_transient_only():
    rec = ld.sim.simulate_vca(duration=30, leak_lpm=0.0, load="spring", params=FAST, seed=3,
                              sensors=False)
    a, fs = _arrays(rec), rec.sample_rate
    s = _steps(rec)[_steps(rec) > 3000][0]
    planted = np.array([0, 2000, s + 10, s + 1000, s + 2000])  # a boundary 10 ms after a step
    raw = vca_raw_sums(a, fs, P, 0.0, P.supply_pressure_pa, 150.0, planted, False)
    r = vca_terms(raw, P, VCAValveModel.nominal(P))["residual"]
    predicted = -LEAD_S * (raw[:, _QB] - raw[:, _QA])  # the model lags: it misses delta [Q]
    # the two windows sharing the boundary split ~150 nL with opposite signs, as predicted
    assert r[1] > 1e-10 and r[2] < -1e-10
    np.testing.assert_allclose(r[1:3], predicted[1:3], rtol=0.3)
    # quiet boundaries: the end-point term delta * Q(b) at every boundary stays well below the
    # planted split (at most 53 nL measured, against 147 nL; slow steady flows remain)
    b = recording_bounds(a, fs, P, 1000, quiet=True)
    rq = vca_raw_sums(a, fs, P, 0.0, P.supply_pressure_pa, 150.0, b, False)
    q_at_bounds = rq[2:, _QA]
    assert LEAD_S * np.abs(q_at_bounds).max() < abs(r[1]) / 2.5


def test_valve_lead_identified_on_fixed_windows_and_reduces_the_sum_residual():
    recs = [ld.sim.simulate_vca(duration=30, leak_lpm=0.0, load="spring", params=FAST, seed=s)
            for s in range(3)]
    m, se = identify(recs, P, [1000] * 3, False, [2] * 3, False, False, quiet=False,
                     fit_valve_timing=True)
    assert m.valve_lead_s == pytest.approx(LEAD_S, abs=max(0.05e-3, 3 * se["valve_lead_s"]))
    off, _ = identify(recs, P, [1000] * 3, False, [2] * 3, False, False, quiet=False,
                      fit_valve_timing=False)
    assert off.valve_lead_s == 0.0
    rec = ld.sim.simulate_vca(duration=30, leak_lpm=0.0, load="spring", params=FAST, seed=3,
                              sensors=False)
    raw = vca_raw_sums(_arrays(rec), rec.sample_rate, P, 0.0, P.supply_pressure_pa, 150.0,
                       1000, False)
    nominal = VCAValveModel.nominal(P)
    worst = [np.abs(vca_terms(raw, P, dataclasses.replace(nominal, valve_lead_s=lead))
                    ["balance"][2:]).max() for lead in (0.0, LEAD_S)]
    assert worst[1] < worst[0] / 3  # 1047 -> 153 nL measured


def test_the_last_boundary_also_leaves_a_transient_but_stays_in_the_recording():
    # v5 healthy run of unit 62500438 (spring): a command step 24 ms before the fixed last
    # boundary, the piston still moving there; the last window alarmed with z = -13.3
    busy = np.zeros(5100)
    busy[4976:5030] = np.arange(54)  # the spool moves for 54 ms across the nominal 5000
    busy[5030:] = 53.0
    b = quiet_bounds(busy, 1000, 1000.0)
    assert b[:-1].tolist() == [0, 1000, 2000, 3000, 4000]
    assert b[-1] <= 4976 - 21 or b[-1] >= 5029 + 21  # 20 ms away from the motion
    end = np.zeros(5001)  # the recording ends at the nominal last boundary, mid-motion
    end[4980:] = np.arange(21)
    b = quiet_bounds(end, 1000, 1000.0)
    assert b[-1] <= 5000 and 4959 - b[-1] >= 0  # moved back before the motion, never past the end
