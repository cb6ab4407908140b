"""The physics-based detectors refuse a position or pressures that cannot be metres and pascals
for the rig they model (detect/_rig_units.py): a position in mm read as m gave a flow-balance
leak of 330 L/min for 0.3 L/min, with an interval (audit of users' recordings, 2026-11-27,
finding 1), since healthy and judged recordings in the same wrong unit agree with each other."""

import dataclasses

import numpy as np
import pytest

import leakdiag as ld
from leakdiag.detect._rig_units import PRESSURE_LEVEL_FRACTION, check_rig_units
from leakdiag.io import Recording, RecordingError


def _scaled(rec, **factors):
    return dataclasses.replace(rec, channels={**rec.channels, **{
        c: np.asarray(rec[c]) * f for c, f in factors.items()}},
        meta={**rec.meta, "source": "rig.csv"})


@pytest.fixture(scope="module")
def runs():
    return [ld.sim.simulate_vca(duration=12, leak_lpm=0.0, load="spring", machine=17, seed=s)
            for s in range(2)]


def test_limits_by_hand():
    ok = Recording({"x": [-0.3, 0.3], "p1": [0.0, 172e3], "p2": [0.0, 1.0]}, 1.0)
    check_rig_units(ok, "fit", 0.6, 17.2e6, "the rig")  # at the stroke, at 1 % of the level
    # a transducer zero elsewhere: the travel counts, not the distance from 0 (a review found
    # x from 0.68 to 0.72 m refused, though it was sized as without the offset)
    check_rig_units(Recording({"x": [0.68, 0.72]}, 1.0), "fit", 0.6, 17.2e6, "the rig")
    with pytest.raises(RecordingError, match=r"channel 'x' travels 0\.6001 m \(from -0\.6001 "
                                             r"to 0\)"):
        check_rig_units(Recording({"x": [0.0, -0.6001]}, 1.0), "fit", 0.6, 17.2e6, "the rig")
    low = Recording({"p1": [0.0, 171.9e3], "p2": [5.0, 100.0]}, 1.0,
                    meta={"source": "low.csv"})
    with pytest.raises(RecordingError, match=r"fit: low\.csv: the chamber pressures \(p1, p2\) "
                       r"stay below 1\.719e\+05 Pa, under 1% of the 17\.2 MPa pressure level"):
        check_rig_units(low, "fit", 0.6, 17.2e6, "the rig")
    assert PRESSURE_LEVEL_FRACTION == 0.01


def test_flow_balance_fit_refuses_mm_and_bar_read_as_si(runs):
    det = ld.detect.FlowBalanceDetector(system="vca", false_alarms_per_hour=100.0)
    with pytest.raises(RecordingError, match=r"fit: rig\.csv: channel 'x' travels \d+\.?\d* m "
                       r"\(from .*\), more than the stroke of 0\.6 m .* --col x=NAME:mm"):
        det.fit([_scaled(r, x=1e3) for r in runs])
    with pytest.raises(RecordingError, match=r"fit: rig\.csv: the chamber pressures \(p1, p2\) "
                       r"stay below .* are they in bar, MPa, kPa or psi"):
        det.fit([_scaled(r, p1=1e-5, p2=1e-5) for r in runs])
    # the simulated rig in SI: the largest pressure 0.73 of the supply, |x| 0.02 of the stroke
    assert max(float(np.max(r["p1"])) for r in runs) > 0.5 * 17.2e6
    assert max(float(np.max(np.abs(r["x"]))) for r in runs) < 0.05 * 0.6


def test_eha_flow_balance_and_ekf_refuse_them_too():
    eha = [ld.sim.simulate_eha(duration=8, leak_lpm=0.0, load="spring", machine=17, seed=s)
           for s in range(2)]
    det = ld.detect.FlowBalanceDetector(system="eha", false_alarms_per_hour=100.0)
    with pytest.raises(RecordingError, match=r"the flow balance \(eha\) models"):
        det.fit([_scaled(r, x=1e3) for r in eha])
    with pytest.raises(RecordingError, match=r"under 1% of the 1\.4 MPa pressure level"):
        det.fit([_scaled(r, p1=1e-5, p2=1e-5) for r in eha])  # bar: 14-37 "Pa"
    vca = ld.sim.simulate_vca(duration=2, leak_lpm=0.0, seed=1)
    from leakdiag.literature.ekf import run_vca_ekf

    with pytest.raises(RecordingError, match=r"the EKF: rig\.csv: channel 'x' travels .* the "
                       r"EKF's VCA model"):
        run_vca_ekf(_scaled(vca, x=1e3))
