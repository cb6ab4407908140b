"""Method specifications: which feature, on which channels, at which settings.

A :class:`MethodSpec` names one of the thesis's methods (Ch. 4) with its settings, and
:func:`compute_feature` evaluates it on a :class:`~leakdiag.io.Recording`. The thesis's preferred
settings per system (Ch. 5 and 6, case study 2 tables) are in :data:`THESIS_PREFERRED`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from leakdiag._validation import check_int, check_overlap

__all__ = [
    "MethodSpec",
    "METHODS",
    "THESIS_PREFERRED",
    "normalize_method",
    "parse_lag_ratio",
    "compute_feature",
    "thesis_defaults",
]

#: Canonical method names (CLI spelling) and their default channels.
METHODS: dict[str, tuple[str, ...]] = {
    "autocorrelation": ("p1",),
    "cross-correlation": ("p1", "p2"),
    "metric-length": ("p1",),
    "moments": ("p1",),
}

_ALIASES = {
    "autocorrelation": "autocorrelation",
    "acf": "autocorrelation",
    "cross-correlation": "cross-correlation",
    "cross_correlation": "cross-correlation",
    "crosscorrelation": "cross-correlation",
    "ccf": "cross-correlation",
    "metric-length": "metric-length",
    "metric_length": "metric-length",
    "metric-length-ratio": "metric-length",
    "metric_length_ratio": "metric-length",
    "ratio_of_metric_lengths": "metric-length",
    "ratio-of-metric-lengths": "metric-length",
    "moments": "moments",
}


def normalize_method(name: str) -> str:
    """Canonical method name from any accepted spelling.

    Parameters
    ----------
    name : str
        E.g. ``"cross_correlation"``, ``"ratio_of_metric_lengths"``, ``"metric-length"``.

    Returns
    -------
    str
        One of the keys of :data:`METHODS`.

    Raises
    ------
    ValueError
        For an unknown name (lists the known ones).

    Examples
    --------
    >>> normalize_method("ratio_of_metric_lengths")
    'metric-length'
    """
    key = str(name).strip().lower()
    if key not in _ALIASES:
        raise ValueError(f"unknown method {name!r}; known: {sorted(METHODS)}")
    return _ALIASES[key]


def parse_lag_ratio(lag_ratio) -> tuple[int, int]:
    """Parse a lag ratio ``"l:k"`` (thesis notation, e.g. ``"83:3"``) into ``(l, k)``.

    Parameters
    ----------
    lag_ratio : str or tuple of int
        ``"83:3"`` or ``(83, 3)``: l = 83 (long step), k = 3 (short step), ``l > k >= 1``.

    Returns
    -------
    tuple of int
        ``(l, k)``.

    Raises
    ------
    ValueError
        If malformed or not ``l > k >= 1``.

    Examples
    --------
    >>> parse_lag_ratio("83:3")
    (83, 3)
    """
    if isinstance(lag_ratio, str):
        parts = lag_ratio.replace(" ", "").split(":")
        if len(parts) != 2:
            raise ValueError(f"lag_ratio={lag_ratio!r} must be written 'l:k', e.g. '83:3'")
        try:
            l, k = int(parts[0]), int(parts[1])
        except ValueError:
            raise ValueError(f"lag_ratio={lag_ratio!r} must be two integers 'l:k'") from None
    else:
        try:
            l, k = (int(v) for v in lag_ratio)
        except (TypeError, ValueError):
            raise ValueError(f"lag_ratio={lag_ratio!r} must be 'l:k' or a pair (l, k)") from None
    if not l > k >= 1:
        raise ValueError(f"lag_ratio={lag_ratio!r} needs l > k >= 1 (got l={l}, k={k})")
    return l, k


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
        m = normalize_method(self.method)
        object.__setattr__(self, "method", m)
        chans = tuple(self.channels) if self.channels else METHODS[m]
        if isinstance(self.channels, str):
            chans = tuple(c.strip() for c in self.channels.split(",") if c.strip())
        object.__setattr__(self, "channels", chans)
        object.__setattr__(self, "window", check_int(self.window, "window", 2))
        object.__setattr__(self, "overlap", check_overlap(self.overlap))
        if m in ("autocorrelation", "moments") and len(chans) != 1:
            raise ValueError(f"{m} takes one channel, got {chans}")
        if m == "cross-correlation" and len(chans) != 2:
            raise ValueError(f"cross-correlation takes two channels (y, x), got {chans}")
        if m in ("autocorrelation", "cross-correlation"):
            lag = 1 if self.lag is None else self.lag
            object.__setattr__(self, "lag", check_int(lag, "lag", 0 if m == "cross-correlation" else 1,
                                                      self.window))
        elif self.lag is not None:
            raise ValueError(f"{m} takes no lag (use lag_ratio for metric-length)")
        if m == "metric-length":
            lr = (83, 3) if self.lag_ratio is None else parse_lag_ratio(self.lag_ratio)
            if lr[0] >= self.window:
                raise ValueError(f"lag_ratio l={lr[0]} must be < window={self.window}")
            object.__setattr__(self, "lag_ratio", lr)
        elif self.lag_ratio is not None:
            raise ValueError(f"{m} takes no lag_ratio")

    @property
    def setting(self) -> str:
        """Lag or lag ratio as the thesis writes it (``"1"``, ``"83:3"``, or ``""``)."""
        if self.lag_ratio is not None:
            return f"{self.lag_ratio[0]}:{self.lag_ratio[1]}"
        return "" if self.lag is None else str(self.lag)

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
    FeatureSeries or pandas.DataFrame
        A FeatureSeries (``moments`` returns its DataFrame), timestamps in the recording's time.

    Raises
    ------
    RecordingError
        If a channel is missing or the recording is shorter than one window.

    Examples
    --------
    An alternating signal: in each window of 4 samples the 3 lag-1 products are -1 and the
    sum of squares is 4, so Eq. 4.1 gives -3/4; windows end at samples 3 and 7 (1 kHz).

    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.tile([1.0, -1.0], 4)}, 1000.0)
    >>> fs = compute_feature(rec, MethodSpec("autocorrelation", ("p1",), lag=1, window=4,
    ...                                      overlap=0))
    >>> fs.values.tolist(), fs.time.tolist()
    ([-0.75, -0.75], [0.003, 0.007])
    """
    from leakdiag.io.recording import RecordingError

    recording.require(*spec.channels)
    if recording.n_samples < spec.window:
        raise RecordingError(
            f"{recording.meta.get('source', '<recording>')}: {recording.n_samples} samples is "
            f"shorter than one window (window={spec.window})"
        )
    kw = dict(window=spec.window, overlap=spec.overlap, sample_rate=recording.sample_rate,
              start_time=recording.start_time)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fs = _dispatch(recording, spec, kw)
    source = recording.meta.get("source")
    where = f"{source}: " if source else ""
    for w in caught:  # re-emit naming the file, method and channels
        warnings.warn(f"{where}{spec.label}: {w.message}", w.category, stacklevel=2)
    if spec.method == "moments":
        return fs
    fs.params["channels"] = ",".join(spec.channels)
    fs.params["window"] = spec.window
    fs.params["sample_rate"] = recording.sample_rate
    return fs


def _dispatch(recording, spec: MethodSpec, kw: dict):
    from leakdiag import features as F

    ch = spec.channels
    if spec.method == "autocorrelation":
        return F.autocorrelation(recording[ch[0]], lag=spec.lag, **kw)
    if spec.method == "cross-correlation":
        return F.cross_correlation(recording[ch[0]], recording[ch[1]], lag=spec.lag, **kw)
    if spec.method == "metric-length":
        x = recording[ch[0]] if len(ch) == 1 else np.column_stack([recording[c] for c in ch])
        return F.metric_length_ratio(x, lag_ratio=spec.lag_ratio, **kw)
    return F.moments(recording[ch[0]], **kw)
