"""Run a fitted :class:`leakdiag.detect.base.Detector` online: its CUSUM, window by window.

:class:`DetectorScorer` implements the monitor's :class:`~leakdiag.stream.monitor.WindowScorer`
protocol from the detector's fitted state only (``mean_``, ``std_``, ``threshold_`` and its
``alarm`` settings ``drift``, ``direction``, ``burn_in_s``), so that streamed scores equal
``detector.score(recording)`` on the same data: ``z = (f - mean_) / std_``, Page's CUSUM
restarted at every healthy-segment boundary (``threshold_basis_.segment_s`` from the end of the
burn-in) unless it is in alarm (docs/detect.md section 2), score ``max(S+, S-)``, alarm when it
exceeds ``threshold_`` (as ``predict``); windows that start within the burn-in are not scored
(NaN, no alarm; their first sample placed on the sample grid as ``predict`` places it);
NaN features leave the statistics unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.detect.base import Alarm
from leakdiag.detect.cusum import DIRECTIONS, _continued
from leakdiag.features.windowing import window_first_times

__all__ = ["DetectorScorer", "as_scorer"]


class DetectorScorer:
    """Incremental CUSUM scores and alarms of a fitted leakdiag detector.

    Parameters
    ----------
    detector : leakdiag.detect.base.Detector
        Fitted (has ``mean_``, ``std_``, ``threshold_``).
    window : int
        Window size N of the monitored feature in samples (for window start times).
    sample_rate : float
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of the stream's first sample in s (the burn-in counts from it).

    Raises
    ------
    ValueError
        If the detector is not fitted, or its alarm direction is unknown.

    Notes
    -----
    Page's CUSUM on the standardised feature, as in :func:`leakdiag.detect.cusum.cusum`:

    .. math:: S^+_i = \\max(0, S^+_{i-1} + z_i - k),\\quad S^-_i = \\max(0, S^-_{i-1} - z_i - k)

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> det = SimpleNamespace(mean_=0.0, std_=1.0, threshold_=2.0,
    ...                       alarm=SimpleNamespace(drift=0.5, direction="both", burn_in_s=0.0))
    >>> sc = DetectorScorer(det, window=2, sample_rate=1.0)
    >>> sc.score_windows(np.array([1.0, 2.0, 2.0]), np.array([1.0, 2.0, 3.0])).tolist()
    [0.5, 2.0, 3.5]
    """

    def __init__(self, detector: Any, window: int, sample_rate: float, start_time: float = 0.0):
        if not hasattr(detector, "threshold_"):
            raise ValueError(f"{type(detector).__name__} is not fitted; call fit(...) first")
        alarm = getattr(detector, "alarm", None)
        if alarm is None:
            alarm = Alarm()
        self.detector = detector
        self.mean_, self.std_ = float(detector.mean_), float(detector.std_)
        self.threshold_ = float(detector.threshold_)
        self.drift = float(alarm.drift)
        self.direction = str(alarm.direction)
        self._burn_in_end = float(start_time) + float(alarm.burn_in_s)
        self._window = int(window)
        self._rate = check_positive(sample_rate, "sample_rate")
        self._start = float(start_time)
        if self.direction not in DIRECTIONS:
            raise ValueError(f"{type(detector).__name__}: alarm direction {self.direction!r} "
                             f"must be one of {sorted(DIRECTIONS)}")
        self._code = DIRECTIONS[self.direction]
        # S+, S- and the segment of the last window scored (-1: none yet), carried from block to
        # block by the CUSUM kernel (detect.cusum._continued)
        self._state = np.array([0.0, 0.0, -1.0])
        self._judging = False  # a window past the burn-in was scored: all later ones are
        # the CUSUM restarts at every healthy-segment boundary unless in alarm, as
        # Detector.predict's does (detect.cusum.segmented_cusum); None: no basis, no restarts
        seg = getattr(getattr(detector, "threshold_basis_", None), "segment_s", None)
        self._segment_s = float(seg) if seg is not None and np.isfinite(seg) and seg > 0 \
            else None
        #: Segment length and origin of the restarts (s; None: no restarts), for the live page
        self.segment_s_, self.segment_origin_s_ = self._segment_s, self._burn_in_end

    def score_windows(self, values: np.ndarray, time: np.ndarray) -> np.ndarray:
        """CUSUM score ``max(S+, S-)`` after each window (NaN within the burn-in).

        Parameters
        ----------
        values : numpy.ndarray
            Feature values of consecutive windows.
        time : numpy.ndarray
            Their timestamps (s, last sample).

        Returns
        -------
        numpy.ndarray
            Scores in healthy standard deviations, shape of ``values``.
        """
        v = np.asarray(values, dtype=np.float64)
        t = np.asarray(time, dtype=np.float64)
        n = len(v)
        if self._judging:  # past the burn-in (the usual case): every window is scored
            k = 0
        else:
            # each window's first sample on the sample grid, as Detector.predict places it
            # (features.windowing.window_first_times): t - (N-1)/fs can land one rounding below
            first = window_first_times(t, self._window, self._rate, self._start)
            k = int(np.count_nonzero(first < self._burn_in_end))  # times increase: a prefix
            self._judging = k < n
        z = (v[k:] - self.mean_) / self.std_
        up, down = _continued(z, np.ascontiguousarray(t[k:]),
                              self._burn_in_end, self._segment_s or 0.0, self.drift,
                              self._code, self.threshold_, self._state)
        if k:
            pad = np.full(k, np.nan)
            up, down = np.concatenate((pad, up)), np.concatenate((pad, down))
        self.branches_ = (up, down)  # S+ and S- of the last block (live onset estimates)
        return np.maximum(up, down)

    def alarm_windows(self, scores: np.ndarray) -> np.ndarray:
        """Alarm where the score exceeds ``threshold_``, as ``Detector.predict`` (never within the
        burn-in).

        Parameters
        ----------
        scores : numpy.ndarray
            Output of :meth:`score_windows`.

        Returns
        -------
        numpy.ndarray
            Boolean, shape of ``scores``.
        """
        return np.asarray(scores, dtype=np.float64) > self.threshold_  # NaN > h is False


def as_scorer(obj: Any, spec: Any, sample_rate: float, start_time: float = 0.0) -> Any:
    """Return ``obj`` if it has ``score_windows``; wrap a fitted leakdiag detector otherwise.

    Parameters
    ----------
    obj : object
        A :class:`~leakdiag.stream.monitor.WindowScorer` or a fitted detector with ``spec()``.
    spec : MethodSpec
        The monitored feature; must equal the detector's own ``spec()``.
    sample_rate : float
        Sample rate in Hz.
    start_time : float, default 0.0
        Time of the first sample in s.

    Returns
    -------
    object
        Something with ``score_windows``.

    Raises
    ------
    ValueError
        If a detector's feature differs from ``spec``.
    """
    if callable(getattr(obj, "score_windows", None)) or not callable(getattr(obj, "spec", None)):
        return obj
    own = obj.spec()
    if own != spec:
        raise ValueError(
            f"detector feature {own.label!r} differs from the monitored {spec.label!r}")
    return DetectorScorer(obj, spec.window, sample_rate, start_time)
