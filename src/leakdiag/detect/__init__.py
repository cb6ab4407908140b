"""Detection: the Sec. 5.2 measure, detectors with calibrated alarms, onset estimation."""

from leakdiag.detect.analysis import Analysis, analyze_recording
from leakdiag.detect.measure import RMSChange, chunk_rms, pct_change, rms_change

__all__ = ["Analysis", "analyze_recording", "RMSChange", "rms_change", "pct_change", "chunk_rms"]
