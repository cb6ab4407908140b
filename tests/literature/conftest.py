"""Simulated VCA runs shared by the method tests (60 s, structured excitation, leak at 30 s)."""

import pytest

ONSET_S = 30.0
DURATION_S = 60.0
LEAK_LPM = 1.0


@pytest.fixture(scope="session")
def vca_runs():
    """Four healthy runs to fit on, one held-out healthy run and one leaking run (1 L/min at 30 s).

    All with the periodic-step structured excitation; seeds differ (sensor noise).
    """
    from leakdiag.sim.excitation import structured_excitation
    from leakdiag.sim.vca.simulate import simulate_vca

    ref = structured_excitation("vca")
    fit = [simulate_vca(duration=DURATION_S, leak_lpm=None, onset=ONSET_S, seed=s, reference=ref) for s in (11, 12, 13, 14)]
    healthy = simulate_vca(duration=DURATION_S, leak_lpm=None, onset=ONSET_S, seed=15, reference=ref)
    leak = simulate_vca(duration=DURATION_S, leak_lpm=LEAK_LPM, onset=ONSET_S, seed=16, reference=ref)
    return {"fit": fit, "healthy": healthy, "leak": leak}
