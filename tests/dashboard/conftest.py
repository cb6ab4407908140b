"""Fixtures of the dashboard tests: a leaking VCA recording, a calibrated detector, a browser."""

import os
import shutil
import tempfile
from pathlib import Path

import pytest

import _skip_lines

CHROMIUM = os.environ.get("LEAKDIAG_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
CHROME_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--window-size=1200,1000"]


def browser_missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
        return ("no chromium/chromedriver on this machine (Debian: apt-get install chromium "
                "chromium-driver; .ci/run does it)")
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[dev]')"
    return None


if browser_missing():  # said once at the end of the run (tests/conftest.py)
    _skip_lines.add(f"tests/dashboard: headless-browser tests skipped: {browser_missing()}")


@pytest.fixture(scope="session")
def leak_case(tmp_path_factory):
    """A 60 s VCA recording with a 0.2 L/min leak from 30 s and a calibrated detector.

    Returns a dict with the recording path, the detector file (leakdiag fit format), the detector and its
    offline verdict on the recording (cusum onset, so the live page can be compared exactly).
    """
    from leakdiag.detect.base import Alarm
    from leakdiag.detect.methods import thesis_detector
    from leakdiag.io import read_recording, write_recording
    from leakdiag.sim import simulate_vca
    from leakdiag.stream.detector_file import DetectorMeta, save_detector

    d = tmp_path_factory.mktemp("leakcase")
    rec_path = d / "rig7.parquet"
    write_recording(simulate_vca(duration=60.0, leak_lpm=0.2, onset=30.0, seed=1), rec_path)
    healthy = [simulate_vca(duration=120.0, leak_lpm=None, seed=s) for s in (10, 11)]
    det = thesis_detector("vca", "autocorrelation",
                          alarm=Alarm(onset_method="cusum", burn_in_s=5.0,
                                      # 2 healthy 115-s maxima support 1/3 per segment at best
                                      # (conformal threshold): 12 per hour is 0.38 per segment
                                      false_alarms_per_hour=12.0)).fit(healthy)
    # a leak-size calibration given by hand (the page shows size and interval as predict
    # does): acf-p1's shift does not follow these simulated leaks, which calibrate refuses
    from leakdiag.detect.leaksize import fit_leak_calibration

    det.calibration_ = fit_leak_calibration([-3.0, -2.0, -1.0, 0.0, 1.0],
                                            [0.4, 0.3, 0.22, 0.1, 0.05])
    det_path = d / "det.joblib"
    save_detector(det, DetectorMeta("acf-p1", "vca", 1000.0, ("p1",), {"p1": "Pa"},
                                    false_alarms_per_hour=12.0, n_healthy=2), det_path)
    rec = read_recording(rec_path)
    return {"recording": rec_path, "detector_path": det_path, "detector": det,
            "verdict": det.predict(rec), "rec": rec, "dir": d}


@pytest.fixture
def browser():
    """A headless Debian Chromium driven by selenium (skips with the reason when missing)."""
    why = browser_missing()
    if why:
        pytest.skip(why)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    os.environ.setdefault("SE_OFFLINE", "true")  # never let selenium download a driver
    profile = tempfile.mkdtemp(prefix="leakdiag-chromium-")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in CHROME_FLAGS + [f"--user-data-dir={profile}"]:
        opts.add_argument(a)
    drv = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    try:
        yield drv
    finally:
        drv.quit()
        shutil.rmtree(profile, ignore_errors=True)


def process_gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (gone, or a zombie; Linux /proc)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


def src_env():
    """Environment for a child ``leakdiag`` process that imports this tree."""
    src = str(Path(__file__).resolve().parents[2] / "src")
    return {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", "")}


class AbsScorer:
    """A scorer whose score is the feature's absolute value, alarm level 0.5."""

    threshold_ = 0.5

    def score_windows(self, values, time):
        import numpy as np

        return np.abs(values)


def abs_monitor_hooks(tmp_path, actuator: str, window: int):
    """An autocorrelation monitor of p1 (lag 1, ``window`` samples, 1 kHz) scored by
    :class:`AbsScorer`, and its hooks storing into ``tmp_path / "ev.db"``."""
    from leakdiag.dashboard.hooks import MonitorHooks
    from leakdiag.features.spec import MethodSpec
    from leakdiag.stream import Monitor

    spec = MethodSpec("autocorrelation", ("p1",), lag=1, window=window, overlap=0)
    mon = Monitor(spec, 1000.0, 0.0, scorers=AbsScorer())
    hooks = MonitorHooks(actuator, spec, mon, "x", 1000.0, store=str(tmp_path / "ev.db"),
                         say=lambda m: None)
    return mon, hooks
