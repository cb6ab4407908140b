"""The literature comparison: literature and thesis methods side by side under both excitations.

:func:`comparison_suite` is a mid-size VCA suite (both excitations, leak sizes from 0.02 to
1 L/min) built from the benchmark's :class:`~leakdiag.bench.suite.SystemSuite`;
:func:`compute_seconds_per_hour` measures each method's feature cost. ``docs/literature.md``
reports their numbers.
"""

from __future__ import annotations

import time

from leakdiag._validation import check_int
from leakdiag.bench.registry import make_detector
from leakdiag.bench.suite import EXCITATIONS, SystemSuite
from leakdiag.detect.base import Alarm

__all__ = ["comparison_suite", "compute_seconds_per_hour", "COMPARISON_METHODS"]

#: Methods compared in ``docs/literature.md`` (benchmark registry names).
COMPARISON_METHODS = ("acf-p1", "ccf-p1p2", "ccf-ux", "mlr-p1", "combined", "wavelet-p1",
                      "wavelet-p1p2", "fft-p1", "emd-p1", "ekf")


def comparison_suite(duration_s: float = 100.0, n_fit: int = 5, n_test_healthy: int = 10,
                     n_test_leak: int = 5):
    """The VCA suite of the comparison: no load, low noise, both excitations.

    Parameters
    ----------
    duration_s : float, default 100.0
        Run length in s; onsets uniform in the middle fifth.
    n_fit, n_test_healthy, n_test_leak : int
        Healthy fitting runs, held-out healthy runs, held-out leaking runs per leak size
        (per excitation).

    Returns
    -------
    dict
        ``{"vca": SystemSuite}`` for :func:`leakdiag.bench.run.run_suite`.

    Examples
    --------
    >>> s = comparison_suite()["vca"]
    >>> s.excitations, s.leak_lpm
    (('operating', 'structured'), (0.02, 0.05, 0.1, 0.2, 0.5, 1.0))
    """
    return {"vca": SystemSuite(
        system="vca", leak_lpm=(0.02, 0.05, 0.1, 0.2, 0.5, 1.0), loads=("none",),
        noise_levels={"low": 10e3}, duration_s=float(duration_s),
        onset_range_s=(0.4 * duration_s, 0.6 * duration_s), n_fit=n_fit, n_cal=0,
        n_test_healthy=n_test_healthy, n_test_leak=n_test_leak, base_seed=5_000_000,
        excitations=EXCITATIONS)}


def compute_seconds_per_hour(method: str, recording, system: str = "vca",
                             repeats: int = 1) -> float:
    """CPU seconds one method's feature takes per hour of signal (process time).

    Parameters
    ----------
    method : str
        Benchmark registry name (e.g. ``"emd-p1"``).
    recording : Recording
        Signal to process (its duration sets the scale).
    system : {"vca", "eha"}, default "vca"
        Rig passed to the factory.
    repeats : int, default 1
        Timed repetitions after one warm-up call (Numba compilation excluded); the minimum is
        kept.

    Returns
    -------
    float
        CPU seconds per hour of signal.

    Raises
    ------
    ValueError
        If ``repeats < 1``, the method is unknown, or its feature needs a fitted detector
        (``"combined"``).

    Examples
    --------
    >>> import numpy as np
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.random.default_rng(0).standard_normal(20000)}, 1000.0)
    >>> compute_seconds_per_hour("fft-p1", rec) < 60
    True
    """
    repeats = check_int(repeats, "repeats", 1)
    det = make_detector(method, system, Alarm())
    det._feature_series(recording)  # warm-up: imports, Numba compilation
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        det._feature_series(recording)
        best = min(best, time.process_time() - t0)
    return best * 3600.0 / recording.duration
