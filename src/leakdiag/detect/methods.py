"""Detectors for the thesis methods (Ch. 4) and a combined detector over several features.

* :class:`FeatureDetector` -- one windowed feature of :mod:`leakdiag.features` (autocorrelation
  of P1 or P2, cross-correlation of P1 and P2 or of U and X, ratio of metric lengths), given by the
  same settings as :class:`leakdiag.features.spec.MethodSpec`.
* :class:`CombinedDetector` -- several features at once: the Mahalanobis distance of the feature
  vector from its healthy mean (healthy covariance), on the time grid of the coarsest feature.
"""

from __future__ import annotations

import warnings

import numpy as np

from leakdiag._validation import check_int
from leakdiag.detect.base import Detector
from leakdiag.features import DegenerateWindowWarning
from leakdiag.features.registry import feature_names
from leakdiag.features.series import FeatureSeries
from leakdiag.features.spec import MethodSpec, compute_feature, thesis_defaults

__all__ = ["FeatureDetector", "CombinedDetector", "thesis_detector"]


class FeatureDetector(Detector):
    """Leak detector on one thesis feature (Eq. 4.1, 4.2 or 4.3).

    Parameters
    ----------
    method : str, default "autocorrelation"
        ``autocorrelation``, ``cross-correlation`` or ``metric-length`` (aliases accepted).
    channels : tuple of str, optional
        Channels (default: the method's default, ``("p1",)`` or ``("p1", "p2")``); ``("u", "x")``
        is the sensor-light option of thesis Sec. 5.5 (no pressure sensors).
    lag : int, optional
        Lag in samples (correlations; default 1).
    lag_ratio : str or tuple of int, optional
        ``"l:k"`` for the metric-length ratio (default ``"83:3"``).
    window : int, default 200
        Window size N in samples.
    overlap : float, default 5.0
        Overlap in percent.
    alarm : Alarm, optional
        Search settings (default :class:`~leakdiag.detect.base.Alarm`).

    Notes
    -----
    The feature is computed by :func:`leakdiag.features.spec.compute_feature`; the alarm,
    threshold and onset logic is the shared one of :class:`~leakdiag.detect.base.Detector`.

    References
    ----------
    Thesis Sec. 4.1-4.4, Eq. (4.1), (4.2), (4.3).

    Examples
    --------
    >>> FeatureDetector("cross-correlation", ("u", "x"), lag=1, window=100).get_params()["channels"]
    ('u', 'x')
    """

    def __init__(self, method="autocorrelation", channels=None, lag=None, lag_ratio=None,
                 window=200, overlap=5.0, alarm=None):
        self.method = method
        self.channels = channels
        self.lag = lag
        self.lag_ratio = lag_ratio
        self.window = window
        self.overlap = overlap
        self.alarm = alarm

    def spec(self):
        """The :class:`~leakdiag.features.spec.MethodSpec` of this detector's feature.

        Returns
        -------
        MethodSpec
        """
        return MethodSpec(self.method, tuple(self.channels or ()), lag=self.lag,
                          lag_ratio=self.lag_ratio, window=self.window, overlap=self.overlap)

    def _feature_series(self, recording) -> FeatureSeries:
        spec = self.spec()
        if spec.record.outputs:
            raise ValueError(f"FeatureDetector takes a single-valued feature "
                             f"({', '.join(feature_names(single=True))}), not {spec.method}")
        with warnings.catch_warnings():
            # zero-variance windows are NaN and skipped by the alarm (docs/detect.md); counted
            warnings.simplefilter("ignore", DegenerateWindowWarning)
            fs = compute_feature(recording, spec)
        n_nan = int(np.count_nonzero(~np.isfinite(fs.values)))
        return fs.with_values(fs.values, spec.label, {**fs.settings, "n_nan_windows": n_nan})


def thesis_detector(system: str, method: str, channels=None, alarm=None) -> FeatureDetector:
    """A :class:`FeatureDetector` at the thesis's preferred settings for a rig.

    Parameters
    ----------
    system : {"vca", "eha"}
        Rig (Ch. 5 or Ch. 6 settings).
    method : str
        Method name (aliases accepted).
    channels : tuple of str, optional
        Select among the preferred specs by channels (e.g. ``("u", "x")``).
    alarm : Alarm, optional
        Search settings.

    Returns
    -------
    FeatureDetector

    Raises
    ------
    ValueError
        If the thesis has no preferred setting for that method and channels.

    Examples
    --------
    >>> thesis_detector("vca", "metric-length").window
    500
    """
    specs = thesis_defaults(system, method)
    if channels is not None:
        specs = tuple(s for s in specs if s.channels == tuple(channels))
    if not specs:
        raise ValueError(f"no thesis setting for system={system!r}, method={method!r}, "
                         f"channels={channels!r}")
    s = specs[0]
    return FeatureDetector(s.method, s.channels, lag=s.lag,
                           lag_ratio=None if s.lag_ratio is None else f"{s.lag_ratio[0]}:{s.lag_ratio[1]}",
                           window=s.window, overlap=s.overlap, alarm=alarm)


class CombinedDetector(Detector):
    """Several features together: Mahalanobis distance from the healthy mean feature vector.

    Parameters
    ----------
    detectors : list of FeatureDetector
        Feature extractors (only their feature settings are used; their alarms are ignored).
    smooth : int, default 5
        Causal moving average over this many consecutive feature vectors before the distance
        (1: none); averaging reduces the per-window noise that a single distance would add up
        over all features.
    alarm : Alarm, optional
        Search settings of the combined detector.

    Notes
    -----
    Each feature is sampled at the timestamps of the feature with the fewest windows by taking
    its last value known at that time (causal). ``_fit_features`` learns the healthy mean vector
    ``mu`` and covariance ``C`` (after the burn-in); the combined feature is
    ``d_i = sqrt((f_i - mu)^T C^-1 (f_i - mu))``, which grows for a change in any feature or in
    their relation. Leakdiag's extension; the thesis uses one feature at a time.

    Examples
    --------
    >>> det = CombinedDetector([FeatureDetector("autocorrelation", ("p1",)),
    ...                         FeatureDetector("cross-correlation", ("u", "x"))])
    >>> len(det.get_params()["detectors"])
    2
    """

    def __init__(self, detectors=None, smooth=5, alarm=None):
        self.detectors = detectors
        self.smooth = smooth
        self.alarm = alarm

    def _matrix(self, recording) -> tuple[np.ndarray, np.ndarray, dict]:
        if not self.detectors:
            raise ValueError("CombinedDetector needs at least one detector in detectors=")
        series = [d._feature_series(recording) for d in self.detectors]
        ref = min(series, key=len)
        cols = []
        for fs in series:
            idx = np.searchsorted(fs.time, ref.time, side="right") - 1
            col = np.where(idx >= 0, np.asarray(fs.values)[np.clip(idx, 0, None)], np.nan)
            cols.append(col)
        mat = np.column_stack(cols)
        k = check_int(self.smooth, "smooth", 1)
        if k > 1:
            # causal moving average of the finite values (NaN: degenerate windows skipped)
            fin = np.isfinite(mat)
            zero = np.zeros((1, mat.shape[1]))
            c = np.cumsum(np.vstack([zero, np.where(fin, mat, 0.0)]), axis=0)
            n = np.cumsum(np.vstack([zero, fin]), axis=0)
            avg = np.full_like(mat, np.nan)
            cnt = n[k:] - n[:-k]
            with np.errstate(invalid="ignore", divide="ignore"):
                avg[k - 1:] = np.where(cnt > 0, (c[k:] - c[:-k]) / cnt, np.nan)
            mat = avg
        return np.asarray(ref.time), mat, ref

    def _fit_features(self, recordings: list) -> None:
        burn = self._alarm().burn_in_s
        rows = []
        for rec in recordings:
            _, m, ref = self._matrix(rec)
            rows.append(m[ref.window_start >= rec.start_time + burn])
        mat = np.concatenate(rows)
        mat = mat[np.isfinite(mat).all(axis=1)]
        if len(mat) <= mat.shape[1]:
            raise ValueError(f"CombinedDetector.fit: {len(mat)} complete feature vectors is too few "
                             f"for {mat.shape[1]} features")
        self.feature_mean_ = mat.mean(axis=0)
        self.feature_cov_ = np.atleast_2d(np.cov(mat, rowvar=False))
        self.feature_precision_ = np.linalg.pinv(self.feature_cov_)

    def _feature_series(self, recording) -> FeatureSeries:
        if not hasattr(self, "feature_precision_"):
            raise ValueError("CombinedDetector is not fitted; call fit(healthy_recordings) first")
        _, m, ref = self._matrix(recording)
        d = m - self.feature_mean_
        d2 = np.einsum("ij,jk,ik->i", d, self.feature_precision_, d)
        name = "mahalanobis[" + "; ".join(x.spec().label for x in self.detectors) + "]"
        return ref.with_values(np.sqrt(np.maximum(d2, 0.0)), name)
