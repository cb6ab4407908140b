"""Without a browser, the headless-browser tests skip and the run says why in one line."""

import os
import subprocess
import sys
from pathlib import Path

from .conftest import src_env

HERE = Path(__file__).resolve().parent


def test_no_browser_skips_with_one_visible_line(tmp_path):
    env = {**src_env(), "LEAKDIAG_CHROMIUM": str(tmp_path / "no-chromium")}
    # in two processes, as make test runs the suite: the workers' line reaches the end
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-n", "2",
                        "--basetemp", str(tmp_path / "bt"), str(HERE / "test_browser.py")],
                       cwd=HERE.parents[1], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = [ln for ln in r.stdout.splitlines() if "headless-browser tests skipped" in ln]
    assert lines == ["tests/dashboard: headless-browser tests skipped: no chromium/chromedriver "
                     "on this machine (Debian: apt-get install chromium chromium-driver; "
                     ".ci/run does it)"], r.stdout
    assert "2 skipped" in r.stdout and "passed" not in r.stdout
    assert not os.path.exists(tmp_path / "no-chromium")
