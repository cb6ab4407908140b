"""The detector interface: one feature extractor + the shared alarm (threshold, CUSUM, onset).

Protocol (scikit-learn conventions)
-----------------------------------
Every detector subclasses :class:`Detector` and implements **one** method::

    def _feature_series(self, recording) -> FeatureSeries: ...

returning the feature (one value per window, timestamp = window's last sample, ``params`` holding
``window`` in samples and ``sample_rate`` in Hz so that window centres are known). Everything else
is shared: *what is scored* (the feature) is separate from *how it is searched* (the
:class:`Alarm`: CUSUM threshold for a target false-alarm rate per hour, onset search).

Rules for a subclass (so that ``get_params``, ``set_params`` and ``sklearn.base.clone`` work):

* ``__init__`` takes every setting as an explicit keyword argument, **including** ``alarm=None``,
  and stores each one verbatim (``self.window = window``) -- no validation, no derived values
  (validate in ``_feature_series``);
* fitted state goes in attributes ending in ``_``; a detector that must learn something about its
  features from healthy data (e.g. a covariance) overrides ``_fit_features(recordings)``, which
  :meth:`Detector.fit` calls first;
* register it for the benchmark in :data:`leakdiag.bench.registry.METHODS` by name.

Life cycle::

    det = FeatureDetector("autocorrelation", ("p1",), lag=1, window=200, overlap=5)
    det.fit(healthy_recordings)           # healthy mean/std, threshold_, penalty_
    det.score(rec)                        # FeatureSeries: CUSUM evidence over time (std units)
    det.predict(rec)                      # Verdict: leak, onset_s, alarm_time_s, confidence, ...
    det.calibrate(leaking_simulations)    # optional: calibration_ for leak_lpm (L/min)

Fitting (:meth:`Detector.fit`), for healthy runs only: the feature's healthy mean ``mean_`` and
standard deviation ``std_`` (pooled over windows after ``burn_in_s``); the standardised series
``z = (f - mean_) / std_``; the CUSUM level ``threshold_`` from a conformal order statistic of the
healthy segment maxima (:func:`leakdiag.detect.threshold.conformal_threshold`), recorded with its
guarantee in ``threshold_basis_``; the change-point penalty ``penalty_`` = ``alarm.penalty_factor``
x the largest single-split L2 gain on the healthy ``z`` series, so that the offline search finds
no change on the healthy runs it was fitted on.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator

from leakdiag._format import seconds
from leakdiag._validation import check_int, check_number, check_positive
from leakdiag.detect.cusum import DIRECTIONS, cusum, segmented_cusum
from leakdiag.detect.blind_rules import blind_limit_s, blind_rule, undefined_limit
from leakdiag.detect.leaksize import MIN_CALIBRATION_RUNS, fit_leak_calibration
from leakdiag.detect.onset import ONSET_METHODS, best_split_gain, change_points, cusum_onset
from leakdiag.detect.threshold import (
    ReferenceMaxima,
    ThresholdBasis,
    conformal_threshold,
    count_segments,
    segment_index,
    segment_maxima,
)
from leakdiag.features.series import FeatureSeries
from leakdiag.io.checks import same_rate
from leakdiag.io.errors import RecordingError
from leakdiag.io.recording import load_name, machine_unit

__all__ = ["Alarm", "Verdict", "Detector", "TooShortToJudge"]


class TooShortToJudge(RecordingError):
    """A recording too short for the detector to judge: no complete window after its burn-in
    (feature detectors), or fewer windows than its test needs (the flow balance). What a
    stream's last, shorter segment usually is (``monitor --segment`` leaves such a segment out
    of the store after judged ones, :class:`leakdiag.stream.segments.SegmentVerdict`)."""


@dataclass(frozen=True)
class Alarm:
    """How a detector searches its feature: the shared alarm logic.

    Parameters
    ----------
    false_alarms_per_hour : float, default 1.0
        Target false alarms per hour of healthy operation; sets the CUSUM threshold through the
        per-segment probability ``false_alarms_per_hour * segment / 3600`` (docs/detect.md,
        "False alarms").
    drift : float, default 0.5
        CUSUM allowance k in healthy standard deviations.
    direction : {"both", "up", "down"}, default "both"
        Feature changes that count as evidence (the thesis sees correlations fall and the
        metric-length ratio rise; "both" assumes neither).
    onset_method : {"binseg", "pelt", "cusum"}, default "binseg"
        Onset estimator: offline change points (``ruptures``) or the CUSUM's excursion start.
    burn_in_s : float, default 5.0
        Seconds at the start of each recording left out (start-up transient).
    penalty_factor : float, default 1.0
        Change-point penalty as a multiple of the largest healthy single-split gain.
    min_size : int, default 5
        Minimum segment length (windows) for the change-point search.
    segment_s : float or None, default None
        Duration (s) of the healthy segments whose CUSUM maxima set the threshold; None: the
        shortest healthy recording's monitored span (one segment per run for equal runs).
    on_insufficient : {"raise", "warn"}, default "raise"
        When the healthy maxima cannot support the target (``k < 1``): raise
        :class:`~leakdiag.detect.threshold.InsufficientHealthyDataError`, or fit at the largest
        healthy maximum with an unsupported basis and a warning.
    confidence : float or None, default None
        Choose the threshold's rank calibration-conditionally: with this probability over the
        healthy data, the fitted threshold's own false-alarm rate is at most the target
        (:func:`~leakdiag.detect.threshold.conditional_rank`; needs more healthy maxima, e.g.
        299 for 1 % per segment at 0.95). None: the rank ``floor(alpha (n + 1))``, whose bound
        holds on average over calibrations.

    Raises
    ------
    ValueError
        For a value out of range (the message names it).

    Examples
    --------
    >>> Alarm(false_alarms_per_hour=0.1).onset_method
    'binseg'
    """

    false_alarms_per_hour: float = 1.0
    drift: float = 0.5
    direction: str = "both"
    onset_method: str = "binseg"
    burn_in_s: float = 5.0
    penalty_factor: float = 1.0
    min_size: int = 5
    segment_s: float | None = None
    on_insufficient: str = "raise"
    confidence: float | None = None

    def __post_init__(self) -> None:
        check_positive(self.false_alarms_per_hour, "false_alarms_per_hour")
        check_positive(self.penalty_factor, "penalty_factor")
        check_int(self.min_size, "min_size", 1)
        for name in ("drift", "burn_in_s"):  # (an API audit, 2026-11-29: drift="a" raised
            # numpy's "ufunc 'isfinite' not supported", naming no argument)
            check_number(getattr(self, name), name, low=0.0)
        if self.direction not in DIRECTIONS:
            raise ValueError(f"direction={self.direction!r} must be one of {sorted(DIRECTIONS)}")
        if self.onset_method not in ONSET_METHODS:
            raise ValueError(f"onset_method={self.onset_method!r} must be one of {ONSET_METHODS}")
        if self.segment_s is not None:
            check_positive(self.segment_s, "segment_s")
        if self.on_insufficient not in ("raise", "warn"):
            raise ValueError(f"on_insufficient={self.on_insufficient!r} must be 'raise' or 'warn'")
        if self.confidence is not None and not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence={self.confidence!r} must be in (0, 1) or None")


@dataclass(frozen=True)
class Verdict:
    """What a detector concludes about one recording.

    Attributes
    ----------
    leak : bool
        True if the alarm statistic (the CUSUM; the flow balance's GLR) crossed
        ``threshold``.
    onset_s : float or None
        Estimated leak onset (s), None without an alarm.
    alarm_time_s : float or None
        Time of the first alarm (s): when an online monitor would have raised it.
    confidence : float
        Conformal p-value of ``score_max`` against the healthy maxima,
        ``min(1, m (1 + #{healthy maxima >= score_max}) / (n + 1))`` with ``m`` the segments
        the recording spans: the probability that healthy operation scores at least this high.
        Small = strong evidence of a leak; a LEAK verdict has it <= the basis's bound (times
        ``m``); it never falls below ``1 / (n + 1)``, the resolution of the healthy reference.
        On a model-based threshold (the flow balance's ``glr-model`` basis, when the healthy
        maxima are too few) it is the model's probability of a healthy alarm at
        ``score_max`` in this span instead, never below one episode in the GLR null's
        simulated hours, that reference's resolution.
    leak_lpm : float or None
        Leak flow estimate in L/min when the detector has a calibration and raised an alarm.
    leak_lpm_interval : tuple of float or None
        Prediction interval of ``leak_lpm``.
    leak_lpm_in_range : bool or None
        Whether the feature shift lies inside the calibrated range.
    score_max : float
        Largest value of the alarm statistic after the burn-in (the CUSUM, std units; the flow
        balance's GLR, z scale): the per-run statistic.
    threshold : float
        CUSUM alarm level used.
    shift : float or None
        Mean standardised feature after minus before ``onset_s``.
    onset_method : str
        Estimator that produced ``onset_s`` (``"cusum"`` when the offline search found nothing).
    detector : str
        Feature name.
    onset_censored : bool, default False
        True when the onset estimate is the first window judged (after the burn-in): the
        change was there from the start of the judged data, so it began at or before
        ``onset_s`` (before the recording, or during the burn-in), which is then only an upper
        bound of the onset, and the leak size is its mean from there on.
    n_segments : int or None, default None
        Healthy segments (of the threshold basis) the judged span covers, at least 1: the
        ``m`` of the p-value and of the run's false-alarm bound (None: not known).
    onset_why : str, default ""
        Why a censored onset is only an upper bound, when it is not the start of the judged
        data: e.g. the alarming excursion crossed an undefined span longer than the healthy
        recordings allow (a stuck sensor), and ``onset_s`` is the first window after it.
    confidence_floor : bool, default False
        True when ``confidence`` is the smallest p-value the healthy reference resolves for
        this span (a conformal p-value with ``score_max`` above every healthy maximum,
        ``n_segments / (n + 1)``; on a model basis, the floor of one episode in the null's
        simulated hours): the score is stronger evidence than the p-value can say, and more
        healthy recordings (or a longer null simulation) resolve smaller p-values.
    """

    leak: bool
    onset_s: float | None
    alarm_time_s: float | None
    confidence: float
    leak_lpm: float | None
    leak_lpm_interval: tuple[float, float] | None
    leak_lpm_in_range: bool | None
    score_max: float
    threshold: float
    shift: float | None
    onset_method: str
    detector: str
    onset_censored: bool = False
    n_segments: int | None = None
    onset_why: str = ""
    n_windows: int | None = None
    n_undefined: int | None = None
    confidence_floor: bool = False

    @property
    def undefined_words(self) -> str:
        """``"k of n windows undefined"`` when some judged window was undefined (the decision
        rests on fewer windows), else empty.

        Returns
        -------
        str
        """
        if not self.n_undefined or self.n_windows is None:
            return ""
        return f"{self.n_undefined} of {self.n_windows} windows undefined"

    @property
    def onset_bound_words(self) -> str:
        """Why the onset is "at or before" (empty when it is not censored).

        Returns
        -------
        str
        """
        if not self.onset_censored:
            return ""
        return self.onset_why or "present from the first window judged"

    def __str__(self) -> str:
        """The verdict in words (``repr`` keeps every field).

        Examples
        --------
        >>> v = Verdict(True, 59.8, 60.8, 8e-05, 0.0202, (0.0200, 0.0205), None, 132.6, 4.11,
        ...             None, "glr", "flow_balance")
        >>> for part in str(v).split("; "):
        ...     print(part)
        LEAK (flow_balance): alarm at 60.8 s, onset 59.8 s (glr)
        leak 0.0202 L/min, interval 0.02-0.0205 L/min
        score max 133 against threshold 4.11, p-value 8e-05
        >>> print(Verdict(False, None, None, 0.93, None, None, None, 1.2, 4.11, None, "glr",
        ...               "flow_balance"))
        NO LEAK (flow_balance): score max 1.2 against threshold 4.11, p-value 0.93
        >>> print(Verdict(False, None, None, 0.93, None, None, None, 1.2, 4.11, None, "cusum",
        ...               "acf p1", n_windows=15, n_undefined=3))
        NO LEAK (acf p1): score max 1.2 against threshold 4.11, p-value 0.93; 3 of 15 windows undefined
        """
        if not self.leak:
            head = f"NO LEAK ({self.detector}): "
        else:
            at = "at or before " if self.onset_censored else ""
            head = (f"LEAK ({self.detector}): alarm at {seconds(self.alarm_time_s)} s, onset {at}"
                    f"{seconds(self.onset_s)} s ({self.onset_method}"
                    + (f": {self.onset_bound_words}" if self.onset_censored else "")
                    + "); ")
            if self.leak_lpm is not None:
                head += f"leak {self.leak_lpm:.3g} L/min"
                if self.leak_lpm_interval is not None:
                    lo, hi = self.leak_lpm_interval
                    head += f", interval {lo:.3g}-{hi:.3g} L/min"
                head += "; "
        return (head + f"score max {self.score_max:.3g} against threshold {self.threshold:.3g}"
                + (f", p-value {self.confidence:.3g}" if self.confidence is not None else "")
                + (" (the smallest the healthy reference resolves for this span: the score "
                   "is above every healthy maximum it holds)" if self.confidence_floor else "")
                + (f"; {self.undefined_words}" if self.undefined_words else ""))

    def as_dict(self) -> dict[str, Any]:
        """Fields as a flat dict (interval split in two columns).

        Returns
        -------
        dict
            One key per field; ``leak_lpm_interval`` becomes ``leak_lpm_low``/``leak_lpm_high``.
        """
        lo, hi = self.leak_lpm_interval if self.leak_lpm_interval else (None, None)
        return {"leak": self.leak, "onset_s": self.onset_s, "alarm_time_s": self.alarm_time_s,
                "confidence": self.confidence, "leak_lpm": self.leak_lpm,
                "leak_lpm_low": lo, "leak_lpm_high": hi,
                "leak_lpm_in_range": self.leak_lpm_in_range, "score_max": self.score_max,
                "threshold": self.threshold, "shift": self.shift,
                "onset_method": self.onset_method, "detector": self.detector,
                "onset_censored": self.onset_censored, "n_segments": self.n_segments,
                "onset_why": self.onset_why, "n_windows": self.n_windows,
                "n_undefined": self.n_undefined, "windows_undefined": self.undefined_words,
                "confidence_floor": self.confidence_floor}


@dataclass(frozen=True)
class _Trace:
    time: np.ndarray
    start: np.ndarray
    z: np.ndarray
    s_up: np.ndarray
    s_down: np.ndarray
    series: FeatureSeries  # the feature series the trace was computed from
    restarted: np.ndarray | None = None  # windows where an excursion was dropped (segmented)

    @property
    def name(self) -> str:
        return self.series.name

    def derived(self, values: np.ndarray, name: str, **extra) -> FeatureSeries:
        """A series on the trace's windows (after the burn-in) with the feature's geometry."""
        return self.series.with_values(values, name, {**self.series.settings, **extra},
                                       time=self.time)


def check_recording_type(obj, where: str) -> None:
    """Refuse what is not a recording (duck-typed: ``channels``, ``sample_rate`` and ``meta``)
    with a TypeError that names what was given and how to make one (an API audit,
    2026-11-30: a DataFrame given to fit failed deep inside with "'str' object has no
    attribute 'sample_rate'", its column names taken for recordings).

    Parameters
    ----------
    obj : object
        What was given.
    where : str
        The method, for the message (``"fit"``, ``"predict"``...).

    Raises
    ------
    TypeError
        If ``obj`` is not a recording.
    """
    if all(hasattr(obj, a) for a in ("channels", "sample_rate", "meta")):
        return
    name = type(obj).__name__
    if hasattr(obj, "columns") and hasattr(obj, "iloc"):
        how = "a pandas DataFrame: leakdiag.io.Recording.from_pandas(df) makes one"
    elif isinstance(obj, Mapping):
        how = ("a mapping: leakdiag.io.Recording(channels, sample_rate) makes one of channel "
               "arrays")
    elif isinstance(obj, (str, bytes, os.PathLike)):
        how = "a file name: leakdiag.io.read_recording(path) reads one"
    else:
        how = "leakdiag.io.Recording, read_recording or leakdiag.sim make one"
    raise TypeError(f"{where} expects leakdiag Recording objects, got {name} ({how})")


def _as_recordings(recordings, where: str = "fit") -> Sequence:
    """A sequence of recordings; a lazy sequence (loading on access) is kept as it is (its
    items are checked as they are used, :func:`check_recording_type`)."""
    if hasattr(recordings, "channels"):
        return [recordings]
    if (recordings is None or isinstance(recordings, (str, bytes, os.PathLike, Mapping))
            or hasattr(recordings, "columns")):
        check_recording_type(recordings, where)  # not a sequence of recordings: refused
    recs = recordings if isinstance(recordings, Sequence) else list(recordings)
    if len(recs) == 0:
        raise ValueError("fit needs at least one healthy recording, got none")
    return recs


def params_snapshot(estimator) -> dict:
    """The estimator's parameters (``get_params(deep=False)``) as :meth:`Detector.fit` leaves
    them, lists copied, for :func:`check_params_unchanged`.

    Parameters
    ----------
    estimator : BaseEstimator
        A detector.

    Returns
    -------
    dict
        Parameter name to value.
    """
    return {k: (list(v) if isinstance(v, list) else v)
            for k, v in estimator.get_params(deep=False).items()}


def _same_param(a, b) -> bool:
    if a is b:
        return True
    try:
        return bool(a == b)
    except (TypeError, ValueError):  # arrays: elementwise
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def check_params_unchanged(estimator) -> None:
    """Refuse a fitted detector whose parameters changed after :meth:`fit` (``set_params`` or
    an attribute): its model, threshold and healthy statistics belong to the settings it was
    fitted with. An API audit (2026-11-30) found ``set_params(lag=5)`` on a fitted feature
    detector read 3 of 3 healthy runs LEAK (score 3,900 against 26.9) under a label naming the
    new lag, and a new ``false_alarms_per_hour`` silently kept the old threshold. Parameters
    that only :meth:`predict` reads (the estimator's ``predict_time_params``, e.g. the flow
    balance's ``interval_level``) may change.

    Parameters
    ----------
    estimator : BaseEstimator
        A fitted detector (one saved before this check, without ``fitted_params_``, passes).

    Raises
    ------
    ValueError
        Naming each changed parameter with its fitted and its present value.
    """
    snap = getattr(estimator, "fitted_params_", None)
    if snap is None:
        return
    now = estimator.get_params(deep=False)
    free = getattr(estimator, "predict_time_params", ())
    changed = [k for k in snap if k in now and k not in free
               and not _same_param(snap[k], now[k])]
    if changed:
        what = "; ".join(f"{k}: fitted with {snap[k]!r}, now {now[k]!r}" for k in changed)
        raise ValueError(f"{type(estimator).__name__}: parameters changed since fit ({what}): "
                         "the fitted model, threshold and healthy statistics belong to the "
                         "settings it was fitted with; fit it again, or set them back")


class Detector(BaseEstimator):
    """Base class of every leak detector (see the module docstring for the protocol).

    Subclasses implement ``_feature_series(recording) -> FeatureSeries`` and keep an ``alarm``
    parameter (an :class:`Alarm` or None for the defaults).
    """

    alarm: Alarm | None = None
    #: The alarm statistic restarts at every healthy-segment boundary unless in alarm
    #: (:meth:`_trace_of`), so the threshold's per-segment guarantee holds in every segment of
    #: a longer recording (union bound); a detector with a statistic of its own says False.
    restarts_per_segment: bool = True
    #: Parameters that only ``predict`` reads, which may change after ``fit``
    #: (:func:`check_params_unchanged`); every other one is held to its fitted value.
    predict_time_params: tuple = ()

    # -------------------------------------------------------------- subclass hooks
    def _feature_series(self, recording) -> FeatureSeries:  # pragma: no cover - abstract
        raise NotImplementedError(f"{type(self).__name__} must implement _feature_series")

    def _fit_features(self, recordings: list) -> None:
        """Learn feature-level state from healthy recordings (default: nothing)."""

    # -------------------------------------------------------------- helpers
    def _alarm(self) -> Alarm:
        a = self.alarm if self.alarm is not None else Alarm()
        if not isinstance(a, Alarm):
            raise TypeError(f"alarm={a!r} must be an Alarm or None")
        return a

    def reference_settings(self) -> dict:
        """Settings that :class:`~leakdiag.detect.threshold.ReferenceMaxima` made with this
        detector must carry to be pooled (``segment_s``, ``drift``, ``direction``, ``burn_in_s``).

        Returns
        -------
        dict
            From the detector's :class:`Alarm`.
        """
        a = self._alarm()
        return {"segment_s": a.segment_s, "drift": a.drift, "direction": a.direction,
                "burn_in_s": a.burn_in_s}

    def _check_fitted(self) -> None:
        if not hasattr(self, "threshold_"):
            from sklearn.exceptions import NotFittedError  # a ValueError and AttributeError

            raise NotFittedError(f"{type(self).__name__} is not fitted; call "
                                 "fit(healthy_recordings) first")
        check_params_unchanged(self)

    def _series(self, recording) -> tuple[np.ndarray, np.ndarray, np.ndarray, FeatureSeries]:
        return self._after_burn_in(self._feature_series(recording), recording.start_time)

    def _after_burn_in(self, fs: FeatureSeries, start_time: float
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, FeatureSeries]:
        t = np.asarray(fs.time, dtype=np.float64)
        v = np.asarray(fs.values, dtype=np.float64)
        start = fs.window_start
        keep = start >= start_time + self._alarm().burn_in_s
        return t[keep], start[keep], v[keep], fs

    def _trace(self, recording, level: float | None = None) -> _Trace:
        self._check_fitted()
        check_recording_type(recording, "predict")
        self._check_like_healthy(recording.sample_rate, recording.meta.get("system"),
                                 recording.meta.get("source", "<recording>"), recording.meta)
        return self._trace_of(*self._series(recording),
                              t0=recording.start_time + self._alarm().burn_in_s, level=level)

    def _check_like_healthy(self, sample_rate, system, source: str, meta=None) -> None:
        """Refuse a recording of another sample rate or rig than the healthy ones of ``fit``
        (windows and lags are in samples; a feature's healthy level is the rig's), or whose
        metadata ``meta`` states another load or machine unit than every healthy recording
        stated (a feature's healthy level and spread are the load's and the unit's: an API
        audit, 2026-11-30, found a spring-fitted feature detector judging a no-load run, and
        one of unit 17 judging unit 23, NO LEAK without a word, where the flow balance and
        the command line refuse them)."""
        rate = getattr(self, "sample_rate_", None)  # None: fitted before 2026-11-27
        if rate is not None and sample_rate is not None and \
                not same_rate(sample_rate, rate):
            raise RecordingError(
                f"{source}: sampled at {float(sample_rate):g} Hz, but {type(self).__name__} was "
                f"fitted on healthy recordings at {rate:g} Hz: its windows and lags are in "
                "samples, so its feature means something else here; resample the recording "
                "or fit on healthy recordings at this rate")
        fitted = getattr(self, "system_", None)
        if fitted is not None and system is not None and str(system).lower() != fitted:
            raise RecordingError(
                f"{source}: a {str(system).lower()!r} recording, but {type(self).__name__} was "
                f"fitted on {fitted!r} recordings; fit it on healthy recordings of this rig")
        if meta is None:
            return
        for what, fitted, here in (
                ("load", getattr(self, "healthy_load_", None), load_name(meta.get("load"))),
                ("machine unit", getattr(self, "healthy_machine_", None), machine_unit(meta))):
            if fitted is not None and here is not None and fitted != here:
                raise RecordingError(
                    f"{source}: recording of {what} {here!r}, but {type(self).__name__} was "
                    f"fitted on healthy recordings of {what} {fitted!r}: its threshold is "
                    f"the healthy variation there; fit it on healthy recordings of this "
                    f"{what}")

    def _trace_of(self, t, start, v, fs, t0: float | None = None,
                  level: float | None = None) -> _Trace:
        """The standardised feature and its CUSUM. With the span's start ``t0`` (recording
        start + burn-in) and a threshold basis, the CUSUM restarts at every healthy-segment
        boundary unless it is in alarm (above ``level``, default ``threshold_``:
        :func:`~leakdiag.detect.cusum.segmented_cusum`), so that each segment of a long
        recording is judged as the healthy maxima were made."""
        z = (v - self.mean_) / self.std_
        a = self._alarm()
        basis = getattr(self, "threshold_basis_", None)
        seg = getattr(basis, "segment_s", None)
        restarted = None
        if t0 is None or seg is None or not np.isfinite(seg) or seg <= 0:
            s_up, s_down = cusum(z, a.drift, a.direction)
        else:
            s_up, s_down, restarted = segmented_cusum(
                z, segment_index(t, t0, seg), a.drift, a.direction,
                keep_above=float(getattr(self, "threshold_", np.inf) if level is None
                                 else level), return_restarts=True)
        return _Trace(t, start, z, s_up, s_down, fs, restarted)

    # -------------------------------------------------------------- public API
    def _reference_maxima(self) -> ReferenceMaxima | None:
        """Reference calibration shipped with the detector (default: none).

        A detector class may override this to return :class:`ReferenceMaxima` made on many
        virtual machines; :meth:`fit` pools them with the unit's own maxima.
        """
        return None

    def fit(self, recordings, y=None, reference_maxima: ReferenceMaxima | None = None
            ) -> "Detector":
        """Learn the healthy feature distribution, the alarm threshold and the penalty.

        Parameters
        ----------
        recordings : sequence of Recording
            Healthy runs (no leak). A single Recording is accepted; a lazy sequence (loading
            each recording on access) is read once per pass.
        y : ignored
            Present for scikit-learn compatibility.
        reference_maxima : ReferenceMaxima, optional
            Healthy maxima from other units, pooled with this unit's own (default: the
            detector's shipped reference, :meth:`_reference_maxima`, if any).

        Returns
        -------
        Detector
            ``self``, with ``mean_``, ``std_``, ``threshold_`` (float), ``threshold_basis_``
            (:class:`~leakdiag.detect.threshold.ThresholdBasis`; ``alarm_threshold_`` is the same
            object), ``healthy_maxima_``, ``penalty_``, ``n_healthy_``, ``healthy_hours_``,
            ``feature_name_``, ``sample_rate_`` (Hz) and ``system_`` (the rig by the
            recordings' metadata, None when they do not say): :meth:`predict` and
            :meth:`score` refuse a recording of another rate or rig.

        Raises
        ------
        InsufficientHealthyDataError
            If the healthy maxima cannot support the target rate (``Alarm.on_insufficient``
            "raise"); the message says how much healthy data is needed.
        ValueError
            No usable windows, zero healthy variance, recordings shorter than ``segment_s``,
            reference maxima made with other alarm settings; a recording whose metadata says
            it leaks (``leak_lpm`` > 0), the same samples given twice, or recordings of
            different sample rates or rigs.
        """
        recs = _as_recordings(recordings)
        self.__dict__.pop("fitted_params_", None)  # fitting anew: no settings to hold it to
        self._alarm()  # a bad alarm argument fails before any work
        self._fit_features(recs)
        parts = [self._fit_part(r) for r in recs]
        return self._fit_from_parts(parts, reference_maxima)

    def _fit_part(self, recording) -> tuple:
        """What :meth:`fit` needs from one healthy recording (lets a caller read it only once
        for several detectors): ``(time, values, t0, feature name, monitored span, info)``
        with ``info`` the recording's source, sample rate, rig, metadata leak and a digest of
        its samples (:func:`healthy_info`)."""
        a = self._alarm()
        check_recording_type(recording, "fit")
        t, _, v, fs = self._series(recording)
        # digests of the channels the detector reads only: a copy of a healthy run with another
        # set of columns (a CSV export without the simulator's leak_flow, an extra temperature)
        # is the same run to it (a CLI audit, 2026-11-29: such copies counted as two healthy
        # runs and were judged against their own threshold)
        chans = fingerprint_channels(self, recording)
        return (t, v, recording.start_time + a.burn_in_s, fs.name,
                max(0.0, recording.duration - a.burn_in_s),
                {**healthy_info(recording, chans),
                 "fingerprint": fingerprint(recording, chans), "channels": chans,
                 "shape": (int(recording.n_samples), float(recording.sample_rate))})

    def _fit_from_parts(self, parts: list, reference_maxima=None) -> "Detector":
        """The rest of :meth:`fit`, from :meth:`_fit_part` of every healthy recording."""
        self.__dict__.pop("fitted_params_", None)
        a = self._alarm()
        series = [p[:4] for p in parts]
        spans = [p[4] for p in parts]
        recs = parts
        infos = [p[5] for p in parts if len(p) > 5]
        rate, system = check_healthy(infos)
        rates = sorted({info["sample_rate"] for info in infos})
        if infos and rate is None:  # not one rate within io's tolerance (check_healthy)
            raise ValueError(f"fit: the healthy recordings have different sample rates "
                             f"({', '.join(f'{r:g}' for r in rates)} Hz): windows and lags "
                             "are in samples; resample them to one rate")
        for s, p in zip(series, parts):  # as predict refuses to judge such a recording
            if len(s[1]) and not np.isfinite(s[1]).any():
                # it would add segment maxima of 0 (the CUSUM holds across undefined windows),
                # understating the bound, and lift the blind-span limits to the whole run (a
                # statistics audit, 2026-11-30: 50 such runs beside 99 took a 1/150 bound to a
                # measured 1/105; one stuck run let 73 % undefined windows read NO LEAK)
                src = p[5]["source"] if len(p) > 5 else "<recording>"
                raise ValueError(
                    f"fit: healthy recording {src}: no finite feature value in its "
                    f"{len(s[1])} window(s) after the {a.burn_in_s:g}-s burn-in (zero "
                    "variance: a constant or stuck channel?): it holds no evidence of healthy "
                    "behaviour; leave it out")
        values = np.concatenate([s[1] for s in series])
        values = values[np.isfinite(values)]
        if len(values) < 2:
            raise ValueError(f"fit: only {len(values)} finite feature values after "
                             f"burn_in_s={a.burn_in_s} in {len(recs)} healthy recording(s)")
        mean, std = float(values.mean()), float(values.std(ddof=1))
        if not std > 0:
            raise ValueError(f"fit: the healthy feature has zero variance (all {mean!r}); "
                             "it cannot separate leaking from healthy runs")
        self.mean_, self.std_ = mean, std
        zs = [(s[1] - mean) / std for s in series]
        seg = float(a.segment_s) if a.segment_s is not None else float(min(spans))
        if not seg > 0:
            raise ValueError(f"fit: a healthy recording is not longer than burn_in_s={a.burn_in_s}")
        # out-of-sample maxima: run i standardised with the mean and std of the other runs
        # (leave one run out), so that the maxima are those of runs the standardisation never
        # saw, as in monitoring (docs/detect.md, "False alarms")
        loo = _leave_one_out_z([s[1] for s in series]) if len(series) > 1 else zs
        maxima = np.concatenate([segment_maxima(z, s[0], seg, s[2], span, a.drift, a.direction)
                                 for z, s, span in zip(loo, series, spans)])
        ref = reference_maxima if reference_maxima is not None else self._reference_maxima()
        if ref is not None:
            ref.check_compatible(seg, a.drift, a.direction, a.burn_in_s)
        alpha = a.false_alarms_per_hour * seg / 3600.0
        if alpha >= 1.0:
            raise ValueError(f"false_alarms_per_hour={a.false_alarms_per_hour} is one or more "
                             f"alarms per {seg:g} s segment: choose a smaller target or segment_s")
        self.threshold_basis_: ThresholdBasis = conformal_threshold(
            maxima, alpha, segment_s=seg, reference=ref, on_insufficient=a.on_insufficient,
            confidence=a.confidence)
        self.alarm_threshold_ = self.threshold_basis_
        self.threshold_ = self.threshold_basis_.threshold
        self.healthy_maxima_ = maxima
        gains = [best_split_gain(z[np.isfinite(z)], a.min_size) for z in zs]
        self.penalty_ = a.penalty_factor * max(max(gains), 1.0)
        self.n_healthy_ = len(recs)
        self.healthy_hours_ = float(sum(spans)) / 3600.0
        self.feature_name_ = series[0][3]
        self.sample_rate_, self.system_ = rate, system
        # the longest undefined (NaN) feature span of the healthy recordings, which sets how
        # long one a judged run may have before its NO LEAK is refused: a constant channel (a
        # stuck sensor) makes windows NaN and the CUSUM holds across them (docs/detect.md,
        # section 2, "Blind spans")
        self.nan_span_healthy_s_ = max(longest_nan_run(s[0], s[1])[2] for s in series)
        # the healthy recordings, so that none of them is judged against this threshold
        self.healthy_fingerprints_ = frozenset(i["fingerprint"] for i in infos
                                               if "fingerprint" in i)
        self.fingerprint_channels_ = next((i["channels"] for i in infos if "channels" in i),
                                          None)
        # their lengths and rates: monitor and batch read a file whole to compare its samples
        # only when it has one of them (own_healthy_samples_reason)
        self.healthy_shapes_ = frozenset(i["shape"] for i in infos if "shape" in i)
        # the load the healthy recordings state (one, or none: check_healthy), which a
        # calibration on known leaks must share (calibrate)
        self.healthy_load_ = next((i["load"] for i in infos if i.get("load") is not None),
                                  None)
        # ... and the machine unit, when every one of them names the same (None: unstated,
        # or several: a fleet fit), which a judged recording that names its unit must share
        units = {i.get("machine") for i in infos}
        self.healthy_machine_ = units.pop() if len(units) == 1 else None
        # ... and the largest share of undefined windows in a healthy recording, which sets the
        # share a judged run may have (undefined_limit: a feature undefined in most healthy
        # windows, ccf u,x while an encoder holds its count, is not a stuck sensor)
        self.nan_fraction_healthy_ = max(
            float(np.mean(~np.isfinite(np.asarray(s[1], dtype=np.float64)))) if len(s[1])
            else 0.0 for s in series)
        self.fitted_params_ = params_snapshot(self)  # what predict holds the fit to
        return self

    def segment_maxima(self, recordings) -> np.ndarray:
        """Healthy segment maxima of recordings under this fitted detector (out-of-sample).

        Use it on healthy runs **not** given to :meth:`fit` to build a
        :class:`~leakdiag.detect.threshold.ReferenceMaxima` for other units.

        Parameters
        ----------
        recordings : sequence of Recording
            Healthy recordings of the unit this detector was fitted on.

        Returns
        -------
        numpy.ndarray
            CUSUM maxima of every complete ``threshold_basis_.segment_s`` segment.
        """
        self._check_fitted()
        a = self._alarm()
        seg = self.threshold_basis_.segment_s
        out = []
        for r in _as_recordings(recordings):
            tr = self._trace(r)
            out.append(segment_maxima(tr.z, tr.time, seg, r.start_time + a.burn_in_s,
                                      r.duration - a.burn_in_s, a.drift, a.direction))
        return np.concatenate(out) if out else np.zeros(0)

    def standardize(self, recording) -> FeatureSeries:
        """The feature standardised with the healthy mean and std, after the burn-in.

        Parameters
        ----------
        recording : Recording
            Any recording with the channels the feature needs.

        Returns
        -------
        FeatureSeries
            ``z = (f - mean_) / std_`` (healthy standard deviations).
        """
        tr = self._trace(recording)
        return tr.derived(tr.z, f"z[{tr.name}]")

    def score(self, recording) -> FeatureSeries:
        """Evidence of a leak over time: the CUSUM ``max(S+, S-)`` in healthy std units.

        Parameters
        ----------
        recording : Recording
            Recording to score.

        Returns
        -------
        FeatureSeries
            One value per window after the burn-in; an alarm is raised where it exceeds
            ``threshold_``.
        """
        tr = self._trace(recording)
        return tr.derived(np.maximum(tr.s_up, tr.s_down), f"cusum[{tr.name}]",
                          threshold=self.threshold_)

    def shift(self, recording, onset_s: float) -> float:
        """Mean standardised feature after minus before ``onset_s``.

        Windows ending before ``onset_s`` count as before, windows starting at or after it as
        after; windows spanning the onset are left out.

        Parameters
        ----------
        recording : Recording
            Recording.
        onset_s : float
            Onset time in seconds.

        Returns
        -------
        float
            NaN when one side has no finite window.
        """
        tr = self._trace(recording)
        return _shift(tr, float(onset_s))

    def run_level(self, span_s: float, n_segments: int | None = None
                  ) -> tuple[float, float] | None:
        """The level that holds a run of ``span_s`` to the false-alarm rate of one segment.

        The threshold holds ``alpha`` (``target_per_segment``) per healthy segment; a run of
        ``m`` segments expects ``m`` times as many false alarms at it. The run level is the
        ``k'``-th largest healthy maximum, ``k' = floor(alpha (n + 1) / m)`` (union bound ``m k'
        / (n + 1) <= alpha``), guaranteed by the healthy maxima because the CUSUM restarts at
        every segment boundary unless in alarm (:attr:`restarts_per_segment`, at the level
        judged at). A calibration-conditional basis (``confidence`` c) takes the conditional
        rank for ``alpha / m`` per segment instead (:meth:`_run_rank`: the run held to ``alpha``
        with probability c). None when the maxima cannot resolve it (``k' = 0``) or the basis
        is not a supported conformal one: :func:`leakdiag.detect.decision.judge_run` then
        judges at the threshold (docs/detect.md section 6, "Which runs are long").

        Parameters
        ----------
        span_s : float
            The judged span (duration minus the burn-in), s.
        n_segments : int, optional
            Segments the span covers; default ``ceil(span_s / segment_s)`` (as :meth:`predict`
            counts them).

        Returns
        -------
        (level, expected) or None
            The level (at least ``threshold_``) and the false alarms it lets through in the run.
        """
        from leakdiag.detect.decision import conformal_segments

        self._check_fitted()
        b = self.threshold_basis_
        m = conformal_segments(b, span_s, n_segments)
        k = self._run_rank(m)
        if k < 1:
            return None
        return max(float(b.maxima[k - 1]), float(self.threshold_)), m * k / (b.n + 1)

    def _run_rank(self, m: int | None) -> int:
        """Rank ``k'`` of the healthy maxima (in decreasing order) that holds ``m`` segments to
        one segment's rate (:meth:`run_level`); 0 when the maxima cannot, the basis is not
        conformal (``m`` None) or not supported.

        A calibration-conditional basis (``confidence`` c) takes the conditional rank for
        ``alpha / m`` per segment (:func:`~leakdiag.detect.threshold.conditional_rank`): with
        probability c over the healthy data each segment's rate is at most ``alpha / m``, so
        the run's is at most ``alpha`` (union bound); for ``m = 1`` the fitted rank. Until
        session 22 it had none, and a run of 2 or more segments under one expected false alarm
        read INCONCLUSIVE (an audit, 2026-11-29)."""
        from leakdiag.detect.threshold import conditional_rank

        b = getattr(self, "threshold_basis_", None)
        if m is None or b is None or not b.supported:
            return 0
        if b.conditional:
            return conditional_rank(b.n, float(b.target_per_segment) / m, float(b.confidence))
        return int(math.floor(float(b.target_per_segment) * (b.n + 1) / m + 1e-9))

    def predict(self, recording, level: float | None = None) -> Verdict:
        """Verdict on one recording: leak or not, onset, alarm time, confidence, leak size.

        Parameters
        ----------
        recording : Recording
            Recording to judge.
        level : float, optional
            Judge at this level instead of ``threshold_`` (at least it; a long run's
            :meth:`run_level`).

        Returns
        -------
        Verdict

        Raises
        ------
        leakdiag.io.RecordingError
            If no window after the burn-in has a finite feature value: the recording is too
            short to judge, or its channel is constant (nothing was tested, so no verdict).
        """
        level = self._check_level(level)
        tr = self._trace(recording, level)
        return self._verdict(tr, recording.duration, recording.meta.get("source", "<recording>"),
                             level)

    def _check_level(self, level: float | None) -> float | None:
        """``level`` as a float (None stays None); ValueError below the threshold."""
        if level is None:
            return None
        self._check_fitted()
        if not (np.isfinite(level) and level >= self.threshold_):
            raise ValueError(f"predict: level={level!r} must be finite and at least the "
                             f"threshold {self.threshold_:.4g}")
        return float(level)

    def predict_series(self, series: FeatureSeries, duration_s: float,
                       start_time: float = 0.0, source: str = "<series>",
                       level: float | None = None) -> Verdict:
        """Verdict from the detector's feature computed elsewhere, e.g. window by window.

        ``leakdiag batch`` streams a recording through the detector's feature
        (:class:`leakdiag.stream.StreamingFeature`) and judges the concatenated windows here:
        the same :class:`Verdict` as :meth:`predict` gives on the whole recording, because the
        streamed feature equals the offline one (``tests/stream``).

        Parameters
        ----------
        series : FeatureSeries
            The detector's feature over the whole recording (``spec()``'s method, window and
            sample rate).
        duration_s : float
            Duration of the recording in s (``n_samples / sample_rate``; it sets how many
            healthy-reference segments the p-value counts).
        start_time : float, default 0.0
            Time of the recording's first sample in s (the burn-in counts from it).
        source : str, default "<series>"
            Name of the recording in error messages.
        level : float, optional
            Judge at this level instead of ``threshold_`` (as :meth:`predict`).

        Returns
        -------
        Verdict

        Raises
        ------
        ValueError
            If ``series`` is not the detector's feature (method or window size differ).
        leakdiag.io.RecordingError
            As :meth:`predict`, when no window after the burn-in has a finite value.
        """
        self._check_fitted()
        spec = self.spec() if callable(getattr(self, "spec", None)) else None
        if spec is not None:
            if series.name not in (spec.method, spec.label) or series.window != spec.window:
                raise ValueError(f"predict_series: {source}: the series is {series.name!r} "
                                 f"over N={series.window}, the detector's feature "
                                 f"{spec.label!r} over N={spec.window}")
            series = series.with_values(series.values, spec.label)  # the verdict's name
        self._check_like_healthy(series.sample_rate, None, source)
        level = self._check_level(level)
        tr = self._trace_of(*self._after_burn_in(series, float(start_time)),
                            t0=float(start_time) + self._alarm().burn_in_s, level=level)
        return self._verdict(tr, float(duration_s), source, level)

    def _verdict(self, tr: _Trace, duration_s: float, source: str,
                 level: float | None = None) -> Verdict:
        """The verdict on a trace (:meth:`predict`, :meth:`predict_series`), at ``level``
        (default ``threshold_``)."""
        a = self._alarm()
        if not np.isfinite(tr.z).any():
            if len(tr.z) == 0:
                raise TooShortToJudge(
                    f"predict: {source}: too short to judge: {duration_s:.4g} s leaves no "
                    f"complete window of the feature after the {a.burn_in_s:g}-s burn-in")
            raise RecordingError(
                f"predict: {source}: no finite feature value in the {len(tr.z)} window(s) "
                f"after the {a.burn_in_s:g}-s burn-in (zero variance: constant channel?)")
        h = self.threshold_ if level is None else level
        stat = np.maximum(tr.s_up, tr.s_down)
        smax = float(stat.max()) if len(stat) else 0.0
        basis = self.threshold_basis_
        span = duration_s - a.burn_in_s
        n_seg = count_segments(span / basis.segment_s)
        confidence = basis.p_value(smax, n_seg)
        floor = basis.at_floor(smax)
        above = np.flatnonzero(stat > h)
        if len(above) == 0:
            self._check_blind_spans(tr, source)  # NO LEAK needs every span looked at
            return Verdict(False, None, None, confidence, None, None, None, smax, h, None,
                           a.onset_method, tr.name, n_segments=n_seg, n_windows=len(tr.z),
                           n_undefined=int((~np.isfinite(tr.z)).sum()), confidence_floor=floor)
        i_alarm = int(above[0])
        branch = tr.s_up if tr.s_up[i_alarm] > h else tr.s_down
        j = cusum_onset(branch, i_alarm)
        if tr.restarted is not None:  # the excursion starts at or after its last restart
            dropped = np.flatnonzero(tr.restarted[:i_alarm + 1])
            if len(dropped) and dropped[-1] > j:
                j = int(dropped[-1])
        method = "cusum"
        if a.onset_method != "cusum":
            finite = np.flatnonzero(np.isfinite(tr.z))
            cps = change_points(tr.z[finite], self.penalty_, a.onset_method, a.min_size)
            cps = [int(finite[c]) for c in cps if finite[c] <= i_alarm]
            if cps:
                j, method = cps[-1], a.onset_method
        censored = j <= int(np.flatnonzero(np.isfinite(tr.z))[0])  # from the first judged window
        why = ""
        blind = self._after_blind_span(tr, j, i_alarm)
        if blind is not None:  # the excursion crossed a blind span: at or before its end
            j, censored = blind[0], True
            why = (f"the feature was undefined from {seconds(blind[1], 6)} to "
                   f"{seconds(blind[2], 6)} s, longer "
                   "than the healthy recordings allow (a stuck sensor?), and the change was "
                   "there from the first window after it: the leak may have begun inside that "
                   "span or before it")
        onset = float((tr.time[j] + tr.start[j]) / 2.0)
        shift = _shift(tr, onset)
        lpm = interval = inside = None
        cal = getattr(self, "calibration_", None)
        if cal is not None and np.isfinite(shift):
            lpm, interval, inside = cal.estimate(shift)
        return Verdict(True, onset, float(tr.time[i_alarm]), confidence, lpm, interval, inside,
                       smax, h, shift, method, tr.name, censored, n_seg, why, len(tr.z),
                       int((~np.isfinite(tr.z)).sum()), floor)

    def _after_blind_span(self, tr: _Trace, j: int, i_alarm: int) -> tuple | None:
        """``(index, span start s, span end s)``: the first defined window after the last
        undefined span longer than :func:`blind_limit_s` between the onset window ``j`` and the
        alarm ``i_alarm``, and that span's first window start and last window time; or None.

        The CUSUM holds its value across undefined windows, so an excursion that began before
        such a span (a healthy fluctuation) and alarms after it (a leak that began inside it)
        dates the onset before the span, where nothing ties it to the leak. What the data say
        is that the leak's signature is there from the first window after the span: the onset
        is *at or before* that window (docs/detect.md, section 3).
        """
        healthy = getattr(self, "nan_span_healthy_s_", None)
        if healthy is None or i_alarm <= j:
            return None
        bad = ~np.isfinite(tr.z[j:i_alarm + 1])
        if not bad.any():
            return None
        edges = np.diff(np.concatenate(([0], bad.view(np.int8), [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        long_ = np.flatnonzero((ends - starts) * _window_step(tr.time) > blind_limit_s(healthy))
        if not len(long_):
            return None
        k = int(long_[-1])  # the alarm window is defined: ends[k] <= i_alarm - j
        return (j + int(ends[k]), float(tr.start[j + int(starts[k])]),
                float(tr.time[j + int(ends[k]) - 1]))

    def _check_blind_spans(self, tr: _Trace, source: str) -> None:
        """Refuse a NO LEAK that the defined windows cannot support (:func:`blind_rule`): an
        undefined span longer than :func:`blind_limit_s` of the healthy recordings' longest
        (``nan_span_healthy_s_``; detectors fitted before it: no check), anywhere in the
        recording (after a span that ends, the defined part may be too short for a leak that
        began inside it to show), or more than
        :data:`~leakdiag.detect.blind_rules.MAX_UNDEFINED_FRACTION` of the judged windows
        undefined (a short recording cannot hold a span beyond the limit's floor)."""
        healthy = getattr(self, "nan_span_healthy_s_", None)
        if healthy is None:
            return
        n, i, span = longest_nan_run(tr.time, tr.z)
        n_undefined = int((~np.isfinite(tr.z)).sum())
        fraction = float(getattr(self, "nan_fraction_healthy_", 0.0))  # 0: fitted before it
        rule = blind_rule(healthy, len(tr.z), n_undefined, span, fraction)
        if rule is None:
            return
        t0, t1 = float(tr.start[i]), float(tr.time[i + n - 1])
        counted = f"{n_undefined} of {len(tr.z)} windows undefined"
        if rule == "span":
            raise RecordingError(
                f"predict: {source}: the feature {tr.name!r} is undefined in {n} consecutive "
                f"windows from {seconds(t0, 6)} to {seconds(t1, 6)} s (a channel it reads is "
                "constant there, or "
                f"holds one value longer than in the healthy recordings: a stuck sensor?); the "
                f"healthy recordings had undefined spans of at most {healthy:.3g} s (limit "
                f"{blind_limit_s(healthy):.3g} s), so no leak can be ruled out over that span "
                f"({counted})")
        raise RecordingError(
            f"predict: {source}: the feature {tr.name!r} is undefined in {n_undefined} of the "
            f"{len(tr.z)} windows judged (more than {undefined_limit(fraction):.0%}"
            + (f", the healthy recordings had at most {fraction:.0%}" if fraction > 0 else "")
            + f"; the longest span {n} windows from "
            f"{seconds(t0, 6)} to {seconds(t1, 6)} s: a channel it reads is constant there, a "
            "stuck sensor?), "
            f"so no NO LEAK can rest on the {len(tr.z) - n_undefined} defined window(s)")

    def calibrate(self, recordings, level: float = 0.9, validity: dict | None = None) -> "Detector":
        """Fit ``calibration_``: the feature shift that :meth:`predict` reports (at its own
        estimated onset, on the runs it alarms on) against the true leak flow.

        A size is read only from an alarmed run's shift at the estimated onset, so the map is
        fitted on the same quantity: until 2026-11-29 it was fitted on the shift at the *true*
        onset of every run, and near the smallest sizes a detected run's shift at its
        estimated onset (the split that maximises the change, and only the runs whose shift
        was large enough to alarm) sat above that map, so the 90 % interval held the truth in
        45-82 % of detected runs at the smallest calibrated size (a statistics audit). Runs it
        does not alarm on are left out (a healthy run among them too): their sizes are never
        read.

        Parameters
        ----------
        recordings : list of Recording
            Simulated runs with ``meta['onset']`` (s) and ``meta['leak_lpm']`` (L/min; the
            delivered mean since the onset, ``meta['leak_lpm_achieved']``, is used where
            present); disjoint from the runs the detector will be scored on.
        level : float, default 0.9
            Prediction-interval coverage.
        validity : dict, optional
            Conditions of the calibration (rig, load, input); stored in the calibration.

        Returns
        -------
        Detector
            ``self`` with ``calibration_`` (:class:`~leakdiag.detect.leaksize.LeakCalibration`).

        Raises
        ------
        ValueError
            If a recording lacks ``onset`` or ``leak_lpm`` metadata, states another load than
            the healthy recordings of ``fit``, holds the same samples as another one, fewer
            than 3 of them alarm, or the feature's shift does not follow the leak
            (:func:`~leakdiag.detect.leaksize.fit_leak_calibration`).
        """
        shifts, flows, missed = [], [], []
        seen: dict[str, int] = {}
        fitted_load = getattr(self, "healthy_load_", None)  # None: unstated, or fitted before
        recs = _as_recordings(recordings)
        for i, rec in enumerate(recs):
            src = rec.meta.get("source", "<recording>")
            if rec.onset is None or rec.meta.get("leak_lpm") is None:
                raise ValueError(f"{src}: calibrate needs meta['onset'] and meta['leak_lpm']")
            load = load_name(rec.meta.get("load"))
            if fitted_load is not None and load is not None and load != fitted_load:
                # a CLI audit, 2026-11-29: spring runs calibrated a no-load detector, which
                # then sized a 0.5 L/min no-load leak 3.6 L/min
                raise ValueError(f"calibrate: {src} states load {load!r}, but the healthy "
                                 f"recordings of fit state {fitted_load!r}: a feature's shift "
                                 "per L/min is the load's; calibrate on leaks under that load")
            # the same samples twice would count as two independent leaks: more degrees of
            # freedom, a narrower interval (the audit: a refused calibration passed its test
            # with its three files given twice, and its interval missed the truth)
            digest = healthy_info(rec, fingerprint_channels(self, rec))["digest"]
            j = seen.setdefault(digest, i)
            if j != i:
                first = recs[j].meta.get("source", "<recording>")
                raise ValueError(f"calibrate: recording {i + 1} ({src}) holds the same samples "
                                 f"as recording {j + 1} ({first}): a recording given twice "
                                 "would count as two known leaks; give each once")
            v = self.predict(rec)
            shift = getattr(v, "shift", None)
            if not v.leak or shift is None or not np.isfinite(shift):
                missed.append(src)
                continue
            shifts.append(float(shift))
            # the delivered mean leak since the onset (the thesis's measure, what a size
            # estimates) where the simulator recorded it; the requested one otherwise
            flows.append(float(rec.meta.get("leak_lpm_achieved", rec.meta["leak_lpm"])))
        if len(shifts) < MIN_CALIBRATION_RUNS:
            raise ValueError(
                f"calibrate: the detector alarms on {len(shifts)} of the {len(recs)} "
                f"calibration recordings (not on {', '.join(map(str, missed[:5]))}"
                f"{', ...' if len(missed) > 5 else ''}); a size is read from an alarmed run's "
                f"shift, so the calibration needs at least {MIN_CALIBRATION_RUNS} alarmed "
                "runs: give larger leaks or more recordings")
        try:
            self.calibration_ = fit_leak_calibration(shifts, flows, level, validity)
        except ValueError as exc:
            if not missed:
                raise
            raise ValueError(f"{exc} (the detector alarms on {len(shifts)} of the {len(recs)} "
                             "calibration recordings; the others are left out)") from None
        return self


def _window_step(time) -> float:
    t = np.asarray(time, dtype=np.float64)
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def longest_nan_run(time, values) -> tuple[int, int, float]:
    """The longest run of consecutive undefined (non-finite) windows: ``(count, first index,
    span in s)``, a run of n windows spanning n window steps.

    Parameters
    ----------
    time : array_like
        Window times (their last samples, s), increasing.
    values : array_like
        Feature values.

    Returns
    -------
    count, first : int
    span : float
        ``(0, 0, 0.0)`` without undefined windows.

    Examples
    --------
    >>> nan = float("nan")
    >>> longest_nan_run([1.0, 2.0, 3.0, 4.0, 5.0], [0.0, nan, nan, 1.0, nan])
    (2, 1, 2.0)
    """
    bad = ~np.isfinite(np.asarray(values, dtype=np.float64))
    if not bad.any():
        return 0, 0, 0.0
    edges = np.diff(np.concatenate(([0], bad.view(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(ends - starts))
    n = int(ends[k] - starts[k])
    return n, int(starts[k]), n * _window_step(time)


#: Channels a detector without a ``channels`` attribute may read (e.g. the EKF).
_STANDARD_CHANNELS = ("p1", "p2", "x", "u")


def read_channels(det, recording=None) -> tuple[str, ...]:
    """Channels a detector reads (also ``leakdiag.cli.fit.detector_channels``): its
    ``channels``, a combination's parts' channels, else the standard channels that
    ``recording`` has (the EKF reads them all).

    Parameters
    ----------
    det : Detector
        A (fitted or not) detector.
    recording : Recording, optional
        Used for detectors that read every standard channel (e.g. the EKF).

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> from leakdiag.bench.registry import make_detector
    >>> from leakdiag.detect.base import Alarm
    >>> read_channels(make_detector("combined", "vca", Alarm()))
    ('p1', 'p2', 'u', 'x')
    """
    chans = getattr(det, "channels", None)
    if chans:
        return tuple(chans)
    parts = getattr(det, "detectors", None)
    if parts:
        out: list[str] = []
        for p in parts:
            out += [c for c in read_channels(p) if c not in out]
        return tuple(out)
    if recording is not None:
        return tuple(c for c in _STANDARD_CHANNELS if c in recording.channels)
    return _STANDARD_CHANNELS


def meta_leak_lpm(meta) -> float | None:
    """The leak (L/min) a recording's metadata states (``leak_lpm``); None when it states none
    or no finite number.

    Examples
    --------
    >>> meta_leak_lpm({"leak_lpm": 0.02}), meta_leak_lpm({"leak_lpm": None}), meta_leak_lpm({})
    (0.02, None, None)
    """
    q = meta.get("leak_lpm")
    if q is None or isinstance(q, bool):
        return None
    try:
        q = float(q)
    except (TypeError, ValueError):
        return None
    return q if math.isfinite(q) else None


def fingerprint_channels(det, recording) -> tuple[str, ...]:
    """The channels whose samples identify a recording to ``det``: those it reads, sorted
    (:func:`read_channels`). Its healthy recordings' digests and fingerprints cover these only.

    Parameters
    ----------
    det : Detector
        The detector.
    recording : Recording
        A recording it fits on or judges.

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> from leakdiag.detect.methods import FeatureDetector
    >>> from leakdiag.io import Recording
    >>> rec = Recording({c: np.zeros(4) for c in ("x", "p1", "leak_flow", "p2")}, 1.0)
    >>> fingerprint_channels(FeatureDetector("cross-correlation", ("p2", "p1")), rec)
    ('p1', 'p2')
    """
    return tuple(sorted(read_channels(det, recording)))


def fingerprint(recording, channels=None) -> str:
    """A cheap fingerprint of a recording's samples: its channel names, length, rate and about
    4,096 evenly spaced samples of each channel (a few microseconds, where a digest of every
    sample costs half a ``predict``). Equal for the same file read twice; not a defence against
    a file built to collide. Used to refuse judging a recording with a detector fitted on it
    (:meth:`Detector.fit`'s ``healthy_fingerprints_``), over the channels it reads
    (``channels``; default: all).

    Examples
    --------
    >>> from leakdiag.io import Recording
    >>> a = Recording({"p1": np.arange(10.0)}, 1.0)
    >>> fingerprint(a) == fingerprint(Recording({"p1": np.arange(10.0)}, 1.0))
    True
    >>> fingerprint(a) == fingerprint(Recording({"p1": np.arange(10.0) + 1}, 1.0))
    False
    >>> b = Recording({"p1": np.arange(10.0), "temp": np.ones(10)}, 1.0)
    >>> fingerprint(a) == fingerprint(b), fingerprint(a, ["p1"]) == fingerprint(b, ["p1"])
    (False, True)
    """
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    n = int(recording.n_samples)
    h.update(f"{n} {float(recording.sample_rate)!r}".encode())
    step = max(1, n // 4096)
    for name in sorted(recording.channels if channels is None else channels):
        h.update(name.encode())
        h.update(np.ascontiguousarray(np.asarray(recording[name])[::step],
                                      dtype=np.float64).tobytes())
    return h.hexdigest()


def refuse_own_healthy(det, recording, where: str) -> None:
    """Refuse to judge a recording that is one of the healthy recordings ``det`` was fitted on
    (its threshold set by that very recording: compared with itself a leak reads NO LEAK; a
    review, 2026-11-27, of the ``--healthy`` refusal, which a detector file got around).
    ``leakdiag detect`` calls it; ``predict`` and ``score`` do not (in Python, scoring the fit
    runs is a legitimate in-sample look); ``batch`` and ``monitor``, which read a file in
    chunks, refuse it by the file's bytes
    (:func:`leakdiag.stream.detector_file.own_healthy_reason`).

    Raises
    ------
    leakdiag.io.RecordingError
        Naming the recording.
    """
    why = own_healthy_words(det, recording)
    if why is not None:
        raise RecordingError(f"{where}: {recording.meta.get('source', '<recording>')}: {why}")


def own_healthy_words(det, recording, fitted_on: str | None = None) -> str | None:
    """Why ``det`` does not judge ``recording`` (it holds the same samples as one of its
    healthy recordings, over the channels it reads), or None: the one comparison of
    :func:`refuse_own_healthy` (``detect``) and of ``monitor`` and ``batch``
    (:func:`leakdiag.stream.detector_file.own_healthy_samples_reason`).

    Parameters
    ----------
    det : Detector
        The fitted detector.
    recording : Recording
        The recording to judge.
    fitted_on : str, optional
        What the message names as fitted (a detector file); default: this detector's class.

    Returns
    -------
    str or None
    """
    own = getattr(det, "healthy_fingerprints_", None)  # None: fitted before 2026-11-27
    # fitted before 2026-11-29: fingerprints of all channels
    chans = getattr(det, "fingerprint_channels_", None)
    if chans is not None and not set(chans) <= set(recording.channels):
        return None  # not a recording the detector reads: predict says which channel it lacks
    if not own or fingerprint(recording, chans) not in own:
        return None
    who = f"this {type(det).__name__}" if fitted_on is None else fitted_on
    return (f"holds the same samples as one of the {len(own)} healthy recordings {who} was "
            "fitted on: judged against a threshold it set itself, a leak reads NO LEAK; judge "
            "recordings other than the healthy ones (or fit without this one)")


def healthy_info(recording, channels=None) -> dict:
    """What ``fit`` checks of a healthy recording besides its feature (:func:`check_healthy`):
    its source, sample rate, rig, the leak its metadata states and a digest of the samples of
    ``channels`` (default: all)."""
    import hashlib

    h = hashlib.blake2b(digest_size=16)
    for name in (sorted(recording.channels) if channels is None else channels):
        h.update(name.encode())
        h.update(np.ascontiguousarray(recording[name], dtype=np.float64).tobytes())
    meta = recording.meta
    return {"source": str(meta.get("source", "<recording>")),
            "sample_rate": float(recording.sample_rate),
            "system": None if meta.get("system") is None else str(meta["system"]).lower(),
            "load": load_name(meta.get("load")), "machine": machine_unit(meta),
            "leak_lpm": meta_leak_lpm(meta), "onset": meta.get("onset"),
            "digest": h.hexdigest()}


def check_healthy(infos: list[dict]) -> tuple[float | None, str | None]:
    """Refuse healthy recordings that leak by their metadata or repeat one another
    (:func:`healthy_info` of each); return their sample rate (None when they differ) and
    rig (None when unknown).

    Raises
    ------
    leakdiag.io.RecordingError
        Naming the recording (by position and source) and the problem.
    ValueError
        If the recordings state different rigs or different loads.
    """
    def name(i):
        return f"healthy recording {i + 1} ({infos[i]['source']})"

    for i, info in enumerate(infos):
        q = info["leak_lpm"]
        if q is not None and q > 0:
            onset = info["onset"]
            since = f" from {float(onset):g} s" if onset is not None else ""
            raise RecordingError(f"fit: {name(i)} leaks by its metadata (leak_lpm={q:g} L/min"
                                 f"{since}): fit on healthy recordings only")
    seen: dict[str, int] = {}
    for i, info in enumerate(infos):
        j = seen.setdefault(info["digest"], i)
        if j != i:
            raise RecordingError(f"fit: {name(i)} holds the same samples as {name(j)}: a "
                                 "recording given twice would count as two independent "
                                 "healthy runs")
    # one rate when all are within io's tolerance of the first (timestamp jitter moves a
    # rate estimated from a time column: audit 2026-11-27, finding 6); else None
    rates = [info["sample_rate"] for info in infos]
    rate = rates[0] if rates and all(
        r is not None and rates[0] is not None and same_rate(r, rates[0]) for r in rates) \
        else None
    systems = sorted({info["system"] for info in infos if info["system"] is not None})
    if len(systems) > 1:
        raise ValueError(f"fit: the healthy recordings come from different rigs ({systems}); "
                         "fit one detector per rig")
    loads = sorted({info.get("load") for info in infos if info.get("load") is not None})
    if len(loads) > 1:  # pooled, the load's own variation set the threshold: a leak was missed
        first = {ld: next(i for i, info in enumerate(infos) if info.get("load") == ld)
                 for ld in loads}
        raise ValueError(
            "fit: the healthy recordings state different loads ("
            + ", ".join(f"{ld!r} in {name(i)}" for ld, i in first.items())
            + "); fit one detector per load (pooled, the difference between the loads sets "
            "the threshold: a flow balance on no-load and spring runs got 102 against 2.4 and "
            "missed a 0.02 L/min leak)")
    return rate, (systems[0] if systems else None)


def _leave_one_out_z(values: list) -> list:
    """Each run standardised with the mean and std (ddof 1) of all the other runs' windows."""
    fin = [v[np.isfinite(v)] for v in values]
    n = np.array([len(f) for f in fin], dtype=np.float64)
    s1 = np.array([f.sum() for f in fin])
    s2 = np.array([(f * f).sum() for f in fin])
    out = []
    for i, v in enumerate(values):
        m = n.sum() - n[i]
        if m < 2:
            raise ValueError("fit: leaving one healthy run out leaves fewer than 2 finite "
                             "feature values; give more or longer healthy runs")
        mean = (s1.sum() - s1[i]) / m
        var = max((s2.sum() - s2[i] - m * mean * mean) / (m - 1), 0.0)
        if not var > 0:
            raise ValueError("fit: the healthy feature has zero variance without one run")
        out.append((v - mean) / np.sqrt(var))
    return out


def _shift(tr: _Trace, onset: float) -> float:
    finite = np.isfinite(tr.z)
    before = finite & (tr.time < onset)
    after = finite & (tr.start >= onset)
    if not before.any() or not after.any():
        return float("nan")
    return float(tr.z[after].mean() - tr.z[before].mean())
