"""``monitor --method`` takes the method names of ``leakdiag fit -m`` (docs/operations.md: the
detector's method "under any of its names"); until 2026-11-29 ``--method ccf-p1p2`` for a
``ccf-p1p2`` detector exited 2 ("'ccf-p1p2' is not one of 'autocorrelation', ..."). A fit name
carries its channels: one that contradicts the detector's or ``--channels`` is refused."""

import re

import pytest

from leakdiag.cli.main import main
from leakdiag.io import write_recording
from leakdiag.sim import simulate_vca


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """Three healthy 30-s VCA runs, a leaking one, and acf-p1 and ccf-p1p2 detectors."""
    d = tmp_path_factory.mktemp("rig")
    healthy = [str(write_recording(simulate_vca(duration=30.0, leak_lpm=None, seed=s),
                                   d / f"h{s}.parquet")) for s in (1, 2, 3)]
    leak = str(write_recording(simulate_vca(duration=30.0, leak_lpm=0.5, onset=15.0, seed=9),
                               d / "leak.parquet"))
    dets = {}
    for m in ("acf-p1", "ccf-p1p2"):
        dets[m] = str(d / f"{m}.joblib")
        assert main(["fit", *(a for h in healthy for a in ("--healthy", h)), "-m", m,
                     "--false-alarm-rate", "100", "-o", dets[m], "--no-progress"]) == 0
    return {"leak": leak, **dets}


def _summary(out: str) -> str:
    """The summary line without its wall time."""
    (line,) = [ln for ln in out.splitlines() if " samples at " in ln]
    return re.sub(r" in [0-9.e+-]+ s.*", "", line)


@pytest.mark.parametrize("det, name", [("ccf-p1p2", "ccf-p1p2"), ("acf-p1", "acf-p1"),
                                       ("ccf-p1p2", "cross-correlation"), ("ccf-p1p2", "ccf"),
                                       ("acf-p1", "autocorrelation")])
def test_the_detectors_method_under_its_fit_name_monitors_as_without_it(rig, run_cli, det,
                                                                        name):
    code, plain, err = run_cli(["monitor", "--input", rig["leak"], "--detector", rig[det]])
    assert code == 0, err
    code, named, err = run_cli(["monitor", "--input", rig["leak"], "--detector", rig[det],
                                "--method", name])
    assert code == 0, err
    assert _summary(named) == _summary(plain)
    assert "alarm raising(s)" in _summary(named)


@pytest.mark.parametrize("det, name, feature", [
    ("acf-p1", "acf-p2", "the autocorrelation of p2"),
    ("ccf-p1p2", "ccf-ux", "the cross-correlation of u,x"),
    ("acf-p1", "ccf-p1p2", "the cross-correlation of p1,p2"),
])
def test_a_fit_name_whose_channels_contradict_the_detector_is_refused(rig, run_cli, det, name,
                                                                      feature):
    code, out, err = run_cli(["monitor", "--input", rig["leak"], "--detector", rig[det],
                              "--method", name])
    assert code == 2
    assert (f"--method {name}, {feature}: {rig[det]} holds a detector of another method or "
            f"channels ({det}, ") in " ".join(err.split())
    assert "Traceback" not in err


def test_a_fit_name_without_a_detector_is_its_feature_and_channels(rig, run_cli):
    code, named, err = run_cli(["monitor", "--input", rig["leak"], "--method", "ccf-ux"])
    assert code == 0, err
    code, plain, err = run_cli(["monitor", "--input", rig["leak"], "--method",
                                "cross-correlation", "--channels", "u,x"])
    assert code == 0, err
    assert _summary(named) == _summary(plain)
    assert "(cross-correlation u,x 1 N=200 5%)" in _summary(named)
    code, same, err = run_cli(["monitor", "--input", rig["leak"], "--method", "ccf-ux",
                               "--channels", "u,x"])
    assert code == 0 and _summary(same) == _summary(plain)


@pytest.mark.parametrize("args, said", [
    (["--method", "ccf-ux", "--channels", "p1,p2"],
     "--method ccf-ux is the cross-correlation of u,x; --channels p1,p2 contradicts it"),
    (["--method", "combined"],
     "--method combined is a detector of leakdiag fit -m, not one feature: give --detector"),
    (["--method", "bogus"],
     "'bogus' is not one of 'autocorrelation', 'cross-correlation', 'metric-length', nor a "
     "method of leakdiag fit -m (acf-p1, acf-p2, ccf-p1p2, ccf-ux, combined,"),
])
def test_a_name_monitor_cannot_use_is_refused_in_words(rig, run_cli, args, said):
    code, out, err = run_cli(["monitor", "--input", rig["leak"], *args])
    assert code == 2 and said in " ".join(err.split())
