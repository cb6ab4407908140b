"""Detection: the Sec. 5.2 measure, detectors with calibrated alarms, onset estimation."""

from leakdiag._numba_cache import configure as _configure_numba_cache

_configure_numba_cache()  # before any kernel is defined (leakdiag._numba_cache)

from leakdiag.detect.analysis import Analysis, analyze_recording
from leakdiag.detect.measure import RMSChange, chunk_rms, pct_change, rms_change

__all__ = ["Analysis", "analyze_recording", "RMSChange", "rms_change", "pct_change", "chunk_rms",
           "Alarm", "Detector", "Verdict", "FeatureDetector", "CombinedDetector", "thesis_detector",
           "FlowBalanceDetector", "FlowBalanceVerdict", "judge_run"]

#: Detector names loaded on first use (scikit-learn is slow to import).
_LAZY = {"Alarm": "base", "Detector": "base", "Verdict": "base", "FeatureDetector": "methods",
         "CombinedDetector": "methods", "thesis_detector": "methods",
         "FlowBalanceDetector": "flow_balance", "FlowBalanceVerdict": "flow_balance",
         "judge_run": "decision"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"leakdiag.detect.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'leakdiag.detect' has no attribute {name!r}")


def __dir__() -> list[str]:
    # the lazy names too (an API audit, 2026-11-30: dir(), tab completion and help() listed
    # no detector)
    return sorted(set(globals()) | set(__all__))
