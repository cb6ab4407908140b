"""A change present from the first window judged: the onset is an upper bound, and says so."""

import pytest

import leakdiag as ld
from leakdiag.cli.main import main
from leakdiag.detect import FlowBalanceDetector
from leakdiag.detect.base import Alarm, Verdict

from _detect_helpers import WindowMeanDetector, synthetic


@pytest.fixture(scope="module")
def window_mean():
    return WindowMeanDetector(alarm=Alarm(false_alarms_per_hour=1.0, burn_in_s=0.0,
                                          onset_method="cusum")).fit(
        [synthetic(600.0, s) for s in range(6)])


def test_a_step_before_the_recording_gives_a_censored_onset(window_mean):
    # the step is there from t = 0: the CUSUM never returns to zero before the alarm, so the
    # excursion starts at the first window (its centre: (0 + 0.49) / 2 s)
    v = window_mean.predict(synthetic(300.0, 99, onset=0.0, step=0.5))
    assert v.leak and v.onset_censored
    assert v.onset_s == pytest.approx(0.245)
    assert "onset at or before 0.245 s (cusum: present from the first window judged)" in str(v)
    assert v.as_dict()["onset_censored"] is True


def test_a_step_inside_the_recording_is_not_censored(window_mean):
    v = window_mean.predict(synthetic(300.0, 99, onset=150.0, step=0.5))
    assert v.leak and not v.onset_censored and abs(v.onset_s - 150.0) <= 1.5
    assert "at or before" not in str(v)


def test_a_healthy_verdict_is_not_censored(window_mean):
    v = window_mean.predict(synthetic(300.0, 77))
    assert not v.leak and v.onset_censored is False
    # the 12-field constructor of earlier releases still works (the flag defaults to False)
    assert Verdict(False, None, None, 0.5, None, None, None, 1.0, 4.0, None, "glr",
                   "x").onset_censored is False


@pytest.fixture(scope="module")
def flow_balance_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("censored")
    healthy = [ld.sim.simulate_vca(duration=40, leak_lpm=0.0, load="spring", seed=s)
               for s in range(4)]
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=1.0).fit(healthy)
    early = ld.sim.simulate_vca(duration=40, leak_lpm=0.05, onset=0.0, load="spring", seed=21)
    late = ld.sim.simulate_vca(duration=40, leak_lpm=0.05, onset=20.0, load="spring", seed=21)
    for i, rec in enumerate(healthy):
        ld.io.write_recording(rec, d / f"h{i}.parquet")
    ld.io.write_recording(early, d / "early.parquet")
    return d, det, early, late


def test_flow_balance_leak_from_the_start_is_censored_at_its_first_window(flow_balance_files):
    _, det, early, late = flow_balance_files
    v = det.predict(early)
    assert v.leak and v.onset_censored
    # the onset is the start of the first window judged (the one around the 2-s burn-in's end),
    # not the step the nuisance fit put at about 6 s (found 2026-11-27: the nuisance was fitted
    # on the first p + 1 windows even when the GLR's best span, i.e. the leak, began at the first)
    assert v.onset_s == det._scan(early, "predict")[0]["start"][0] < 2.5
    assert v.leak_lpm == pytest.approx(early.meta["leak_lpm_achieved"], rel=0.05)
    w = det.predict(late)
    assert w.leak and not w.onset_censored and abs(w.onset_s - 20.0) <= 3.0


def test_flow_balance_onset_soon_after_the_burn_in_is_found():
    """A leak from 3 s (the second window): the nuisance is no longer fitted on leaking
    windows, which had put the onset at 6.2 s. It is reported "at or before": leaks present
    from the start were placed up to the 6th window judged (2026-11-27: 48 of 48 VCA runs,
    docs/detect.md 8.5), so an onset this early cannot be told from one."""
    from leakdiag.detect.flow_balance import CENSOR_WINDOWS

    healthy = [ld.sim.simulate_vca(duration=40, leak_lpm=0.0, load="spring", seed=s)
               for s in range(4)]
    det = FlowBalanceDetector(system="vca", false_alarms_per_hour=1.0).fit(healthy)
    v = det.predict(ld.sim.simulate_vca(duration=40, leak_lpm=0.05, onset=3.0, load="spring",
                                        seed=24))
    assert v.leak and abs(v.onset_s - 3.0) <= 1.0
    assert v.onset_censored and f"within the first {CENSOR_WINDOWS} windows judged" in v.onset_why


def test_detect_prints_the_censored_onset_as_an_upper_bound(flow_balance_files, capsys):
    d, _, _, _ = flow_balance_files
    healthy = [a for i in range(4) for a in ("--healthy", str(d / f"h{i}.parquet"))]
    assert main(["fit", "--method", "flow-balance", "--system", "vca", *healthy,
                 "--false-alarm-rate", "1", "-o", str(d / "fb.joblib")]) == 0
    capsys.readouterr()
    assert main(["detect", str(d / "early.parquet"), "--detector", str(d / "fb.joblib"),
                 "--store", str(d / "e.db"), "--actuator", "rig1"]) == 0
    out = capsys.readouterr().out
    assert "Decision: LEAK" in out
    line = next(x for x in out.splitlines() if "onset" in x and "first alarm" in x)
    assert "onset at or before" in line and "began before the recording or within its burn-in" in line
    # the store keeps it, and the fleet page will say "at or before"
    from leakdiag.store import EventStore

    st = EventStore(d / "e.db", create=False)
    assert st.fleet()["onset_censored"].tolist() == [True]
    st.close()
