"""The recording's own valve flow gain as a nuisance of the flow-balance test (VCA).

The window residual is linear in the flow-gain factor; ``gain_sensitivity`` must be its exact
derivative, and with ``profile_flow_gain=True`` the GLR must not move when a recording's gain
differs from the fitted one (the cause of the early alarms in no-load runs, docs/detect.md 8.4).
"""

import dataclasses

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect._flow_balance_vca import VCAValveModel, vca_raw_sums, vca_terms
from leakdiag.sim.vca.params import VCAParams

P = VCAParams()


@pytest.fixture(scope="module")
def runs():
    return [ld.sim.simulate_vca(duration=20, leak_lpm=0.0, load="none", machine=31, seed=s)
            for s in range(3)]


def test_gain_sensitivity_is_the_exact_derivative_of_the_residual(runs):
    rec = runs[0]
    arrays = tuple(np.ascontiguousarray(rec[c]) for c in ("p1", "p2", "x", "u"))
    model = VCAValveModel.nominal(P)
    raw = vca_raw_sums(arrays, rec.sample_rate, P, model.null_offset_v,
                       model.supply_pressure_pa, model.valve_natural_frequency_hz, 1000, False)
    base = vca_terms(raw, P, model)
    up = vca_terms(raw, P, dataclasses.replace(model, flow_gain_factor=1.02))
    # linear in the gain: a 2 % step changes the residual by 0.02 x the sensitivity exactly
    np.testing.assert_allclose(up["residual"] - base["residual"],
                               0.02 * base["gain_sensitivity"], rtol=1e-9, atol=1e-18)
    assert np.abs(base["gain_sensitivity"]).max() > 1e-6  # the valve moved: a real test


@pytest.mark.parametrize("profile", [True, False])
def test_a_recordings_gain_error_moves_the_glr_only_when_not_profiled(runs, profile):
    det = FlowBalanceDetector(system="vca", profile_flow_gain=profile).fit(runs[:2])
    t = det._terms(runs[2])
    assert t["nuisance"].shape[1] == (3 if profile else 2)
    g, _ = det._glr(t)
    # this recording's valve delivers 3 % more than the fitted model says
    det.profile_flow_gain = True  # only to read the sensitivity column of the same windows
    sens = det._terms(runs[2])["nuisance"][:, 2]
    det.profile_flow_gain = profile
    g_err, _ = det._glr(t, residual=t["residual"] + 0.03 * sens)
    if profile:
        np.testing.assert_allclose(g_err, g, rtol=1e-6, atol=1e-6)
    else:
        assert np.abs(g_err - g).max() > 0.5
