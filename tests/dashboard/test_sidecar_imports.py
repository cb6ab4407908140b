"""The monitor's page sidecar stays light: taking chunks of a detector with a healthy span (the
path that starts its blind check) imports neither the detectors nor scikit-learn. It did, at
its first chunk (1.0-1.5 s of CPU on the other core while the monitor replayed; closing the
page then took up to 1.7 s after a 0.4-s replay)."""

import json
import subprocess
import sys

CHILD = """
import json, sys
from types import SimpleNamespace
import numpy as np
import leakdiag.dashboard.sidecar, leakdiag.dashboard.app
from leakdiag.dashboard.recorder import ChunkRecorder, ScorerFacts
det = SimpleNamespace(calibration_=None, nan_span_healthy_s_=2.0)
scorer = SimpleNamespace(threshold_=5.0, mean_=0.0, std_=1.0, segment_s_=None,
                         segment_origin_s_=0.0, detector=det)
rec = ChunkRecorder(None, None, "rig", "acf p1", ScorerFacts(scorer), 0.2)
for k in range(3):
    t = 0.2 * np.arange(10 * k, 10 * k + 10) + 0.2
    v = np.where(np.arange(10) == 3, np.nan, 0.5)
    s = np.where(np.isnan(v), np.nan, 1.0)
    rec.apply([(t, v, s, s > 5.0, None, 0.0)])
live = rec.board._live["rig"]
print(json.dumps({"blind": live._blind is not None,
                  "heavy": sorted(m for m in ("sklearn", "leakdiag.detect.base", "scipy.stats")
                                  if m in sys.modules)}))
"""


def test_taking_chunks_imports_no_detector_code():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                         check=True).stdout
    got = json.loads(out.strip().splitlines()[-1])
    assert got["blind"]  # the blind check ran (it needs the rules of detect.blind_rules)
    assert got["heavy"] == []
