"""The shared orifice law and the one leak law of both rigs (Eqs. 2-2, 2-4, 2-5, 3-9..3-12)."""

import numpy as np
import pytest

from leakdiag.sim.eha.model import IN_KLEAK, N_INPUTS, N_STATES, S_P1, S_P2, eha_leak_flow
from leakdiag.sim.eha.params import EHAParams
from leakdiag.sim.leak import leak_flow
from leakdiag.sim.orifice import orifice_flow, signed_sqrt
from leakdiag.sim.vca.model import vca_leak_flow
from leakdiag.sim.vca.params import VCAParams


def test_signed_sqrt_hand_values():
    # dp = 3e4, p_tr = 4e4: (9e8 + 16e8)^(1/4) = (25e8)^(1/4) = 50^(1/2) * 10^2 = 223.607
    assert signed_sqrt(3e4, 4e4) == pytest.approx(3e4 / 223.60679775, rel=1e-10)
    assert signed_sqrt(-3e4, 4e4) == -signed_sqrt(3e4, 4e4)
    # the two spellings of the law agree to rounding
    dp = np.linspace(-2e7, 2e7, 101)
    assert np.allclose(orifice_flow(2.5e-8, dp, 1e4), 2.5e-8 * signed_sqrt(dp, 1e4),
                       rtol=1e-15, atol=0.0)


def test_leak_flow_is_the_law_of_both_rigs():
    k, dp, ptr = 1.6e-8, 2.5e6, 1e4
    want = k * dp / (dp * dp + ptr * ptr) ** 0.25          # Eq. 2-4, regularised
    assert leak_flow(k, dp, ptr, False) == pytest.approx(want, rel=1e-14)
    assert leak_flow(4e-12, dp, ptr, True) == pytest.approx(1e-5, rel=1e-14)  # Eq. 2-5
    vca = VCAParams().to_array("turbulent")
    assert vca_leak_flow(3.5e6, 1e6, k, vca) == leak_flow(k, dp, 1e4, False)
    eha = EHAParams().to_array()
    y = np.zeros(N_STATES)
    y[S_P1], y[S_P2] = 3.5e6, 1e6
    u = np.zeros(N_INPUTS)
    u[IN_KLEAK] = k
    assert eha_leak_flow(y, u, eha) == leak_flow(k, dp, EHAParams().laminar_transition_pa, False)
    # arrays: the recorded leak flow uses the same compiled law
    dps = np.array([-dp, 0.0, dp])
    assert leak_flow(np.full(3, k), dps, ptr, False).tolist() == [
        leak_flow(k, -dp, ptr, False), 0.0, leak_flow(k, dp, ptr, False)]
