"""Method specifications: which feature, on which channels, at which settings.

A :class:`MethodSpec` names one registered feature (:mod:`leakdiag.features.registry`; the
thesis's four of Ch. 4 are in :mod:`leakdiag.features.catalog`) with its settings, checked once
against the feature's record, and :func:`compute_feature` evaluates it on a
:class:`~leakdiag.io.Recording`. The thesis's preferred settings per system (Ch. 5 and 6, case
study 2 tables) are in :data:`THESIS_PREFERRED`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

from leakdiag._validation import check_int, check_overlap, parse_lag_ratio
from leakdiag.features._args import plan_windows, signal_1d
from leakdiag.features.registry import (
    compute_planned,
    feature_names,
    feature_record,
    normalize_method,
)
from leakdiag.io.checks import check_channel_finite, check_length

__all__ = [
    "MethodSpec",
    "THESIS_PREFERRED",
    "normalize_method",
    "parse_lag_ratio",
    "compute_feature",
    "thesis_defaults",
    "feature_names",
]


@dataclass(frozen=True)
class MethodSpec:
    """One thesis method with its settings.

    Parameters
    ----------
    method : str
        ``autocorrelation`` (Eq. 4.1), ``cross-correlation`` (Eq. 4.2), ``metric-length``
        (Eq. 4.3) or ``moments`` (Eq. 4.11-4.14); aliases accepted.
    channels : tuple of str
        Channels: one for autocorrelation/moments; two ``(y, x)`` for cross-correlation in the
        order of Eq. 4.2; one or more for metric length (more than one uses the Euclidean norm of
        Eq. 4.4 over channels).
    lag : int, optional
        Lag tau in samples (correlations).
    lag_ratio : tuple of int, optional
        ``(l, k)`` for metric length (string ``"l:k"`` accepted).
    window : int
        Window size N in samples.
    overlap : float
        Overlap in percent.

    Examples
    --------
    >>> MethodSpec("metric_length", ("p1",), lag_ratio="83:3", window=500, overlap=5).label
    'metric-length p1 83:3 N=500 5%'
    """

    method: str
    channels: tuple[str, ...] = field(default=())
    lag: int | None = None
    lag_ratio: tuple[int, int] | None = None
    window: int = 200
    overlap: float = 5.0

    def __post_init__(self) -> None:
        rec = feature_record(self.method)
        object.__setattr__(self, "method", rec.name)
        object.__setattr__(self, "channels", rec.check_channels(self.channels))
        window = check_int(self.window, "window", 2)
        object.__setattr__(self, "window", window)
        object.__setattr__(self, "overlap", check_overlap(self.overlap))
        if rec.setting != "lag" and self.lag is not None:
            hint = " (use lag_ratio for metric-length)" if rec.setting == "lag_ratio" else ""
            raise ValueError(f"{rec.name} takes no lag{hint}")
        if rec.setting != "lag_ratio" and self.lag_ratio is not None:
            raise ValueError(f"{rec.name} takes no lag_ratio")
        value = self.lag_ratio if rec.setting == "lag_ratio" else self.lag
        checked = rec.check_setting(value, window)
        object.__setattr__(self, "lag" if rec.setting != "lag_ratio" else "lag_ratio", checked)

    @property
    def record(self):
        """The feature's :class:`~leakdiag.features.registry.FeatureRecord`."""
        return feature_record(self.method)

    @property
    def value(self):
        """The feature's setting: the lag (int), the lag ratio ``(l, k)`` or None."""
        return self.lag_ratio if self.lag_ratio is not None else self.lag

    @property
    def setting(self) -> str:
        """Lag or lag ratio as the thesis writes it (``"1"``, ``"83:3"``, or ``""``)."""
        return self.record.setting_label(self.value)

    @property
    def label(self) -> str:
        """Short human-readable description."""
        s = f" {self.setting}" if self.setting else ""
        return f"{self.method} {','.join(self.channels)}{s} N={self.window} {self.overlap:g}%"

    def as_dict(self) -> dict:
        """Settings as plain columns (for tables).

        Returns
        -------
        dict
            ``method``, ``channels`` (comma-joined), ``lag`` (None for metric length),
            ``lag_ratio`` (``"l:k"`` or None), ``window`` (samples), ``overlap`` (%).
        """
        return {"method": self.method, "channels": ",".join(self.channels),
                "lag": self.lag, "lag_ratio": None if self.lag_ratio is None else self.setting,
                "window": self.window, "overlap": self.overlap}


#: Preferred settings of the thesis (the case-study-2 tables 5-4, 5-8, 5-12, 5-16, 6-4, 6-8,
#: 6-12, 6-16).
THESIS_PREFERRED: dict[str, tuple[MethodSpec, ...]] = {
    "vca": (
        MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=5),
        MethodSpec("cross-correlation", ("p1", "p2"), lag=1, window=100, overlap=5),
        MethodSpec("cross-correlation", ("u", "x"), lag=1, window=100, overlap=5),
        MethodSpec("metric-length", ("p1",), lag_ratio=(83, 3), window=500, overlap=5),
    ),
    "eha": (
        MethodSpec("autocorrelation", ("p1",), lag=1, window=200, overlap=10),
        MethodSpec("cross-correlation", ("p1", "p2"), lag=16, window=100, overlap=10),
        MethodSpec("cross-correlation", ("u", "x"), lag=8, window=100, overlap=5),
        MethodSpec("metric-length", ("p1",), lag_ratio=(43, 3), window=400, overlap=5),
    ),
}


def thesis_defaults(system: str = "vca", method: str | None = None) -> tuple[MethodSpec, ...]:
    """The thesis's preferred settings for a system, optionally for one method.

    Parameters
    ----------
    system : {"vca", "eha"}
        Test rig.
    method : str, optional
        Restrict to one method (any alias).

    Returns
    -------
    tuple of MethodSpec

    Raises
    ------
    ValueError
        Unknown system.

    Examples
    --------
    >>> [s.label for s in thesis_defaults("vca", "autocorrelation")]
    ['autocorrelation p1 1 N=200 5%']
    """
    key = system.lower()
    if key not in THESIS_PREFERRED:
        raise ValueError(f"unknown system {system!r}; known: {sorted(THESIS_PREFERRED)}")
    specs = THESIS_PREFERRED[key]
    if method is None:
        return specs
    m = normalize_method(method)
    return tuple(s for s in specs if s.method == m)


def compute_feature(recording, spec: MethodSpec):
    """Evaluate a method on a recording.

    Parameters
    ----------
    recording : Recording
        Source of the channels named in ``spec``.
    spec : MethodSpec
        Method and settings.

    Returns
    -------
    FeatureSeries or tuple of FeatureSeries
        The feature's series (one per output for a multi-valued feature such as ``moments``),
        timestamps in the recording's time, ``channels`` the spec's.

    Raises
    ------
    RecordingError
        If a channel is missing or not finite, or the recording is shorter than one window.

    Examples
    --------
    An alternating signal: in each window of 4 samples the 3 lag-1 products are -1 and the
    sum of squares is 4, so Eq. 4.1 gives -3/4; windows end at samples 3 and 7 (1 kHz).

    >>> import numpy as np
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.tile([1.0, -1.0], 4)}, 1000.0)
    >>> fs = compute_feature(rec, MethodSpec("autocorrelation", ("p1",), lag=1, window=4,
    ...                                      overlap=0))
    >>> fs.values.tolist(), fs.time.tolist(), fs.channels
    ([-0.75, -0.75], [0.003, 0.007], ('p1',))
    """
    recording.require(*spec.channels)
    check_length(recording, spec.window)
    source = recording.meta.get("source")
    where = f"{source}: " if source else ""
    for c in spec.channels:  # named here: the kernels know their arguments, not the channels
        check_channel_finite(recording[c], c, source or "<recording>")
    # the spec checked window, overlap and setting; the recording its rate and start time
    plan = plan_windows(recording.n_samples, spec.window, spec.overlap, recording.sample_rate,
                        recording.start_time)
    arrays = tuple(signal_1d(recording[c], c, finite=False) for c in spec.channels)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = compute_planned(spec.record, arrays, spec.value, plan, spec.channels)
    for w in caught:  # re-emit naming the file, method and channels
        warnings.warn(f"{where}{spec.label}: {w.message}", w.category, stacklevel=2)
    return out
