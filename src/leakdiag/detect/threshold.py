"""Alarm thresholds with a stated guarantee: conformal order statistics of healthy maxima.

The healthy runs are cut into segments of a fixed duration ``segment_s`` (default: the shortest
healthy run's monitored span, i.e. one segment per run when the runs have equal length). In
each segment the largest CUSUM value is recorded (the CUSUM runs through the whole recording,
as in monitoring). With ``n`` such healthy maxima and a target false-alarm probability
``alpha`` per segment, the threshold is the ``k``-th largest maximum with
``k = floor(alpha (n + 1))``: if a new healthy segment is exchangeable with the ``n`` healthy
ones, the probability that its maximum exceeds the threshold is at most ``k / (n + 1) <= alpha``
(split-conformal argument; Vovk et al. 2005, Angelopoulos & Bates 2023). When ``k < 1`` the data
cannot support ``alpha``: :class:`InsufficientHealthyDataError` (or, on request, a recorded
unsupported basis and an :class:`InsufficientHealthyDataWarning`). Nothing is extrapolated.

That bound holds on average over calibrations: the rate of one fitted threshold is itself
random, ``Beta(k, n + 1 - k)``-distributed (mean ``k / (n + 1)``), so with ``n = 100`` and
``k = 1`` one calibration in seven gives more than twice the target. With ``confidence=c``
the rank is chosen **calibration-conditionally** (Vovk 2012, "Conditional validity of inductive
conformal predictors"): the largest ``k`` with ``P(Binomial(n, alpha) <= k - 1) <= 1 - c``, so
that *this very threshold's* rate is at most ``alpha`` with probability at least ``c`` over the
healthy data. It needs more maxima (``n >= log(1 - c) / log(1 - alpha)``: 299 for 1 % at
``c = 0.95``) and gives a higher level.

A per-hour target ``lambda`` maps to ``alpha = lambda * segment_s / 3600``: the expected number
of segments with an alarm per hour of healthy operation is then at most ``lambda``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.detect.cusum import _segments, segmented_cusum
from leakdiag.detect.rates import clopper_pearson

__all__ = ["ThresholdBasis", "ReferenceMaxima", "InsufficientHealthyDataError",
           "InsufficientHealthyDataWarning", "conformal_threshold", "conditional_rank",
           "min_maxima", "segment_maxima", "segment_index",
           "binned_maxima", "clopper_pearson", "SEGMENT_TOLERANCE", "count_segments"]

#: Relative tolerance when counting complete segments in a run (a run of 59.99 s holds one
#: 60 s segment): sample-grid rounding must not drop a segment (leakdiag choice).
SEGMENT_TOLERANCE = 1e-3


def count_segments(segments: float) -> int:
    """Whole healthy segments in a fractional count: a run within :data:`SEGMENT_TOLERANCE`
    of a whole number of segments holds that number; at least 1.

    One rule for every count (the flow balance's p-value, the run level, the decision; a
    statistics audit, 2026-11-28, found the flow balance counting ``ceil(windows / per)`` and
    the decision ``ceil(segments - 1e-3)``, two counts for one run of 1,001 windows of 1,000).

    Parameters
    ----------
    segments : float
        Segments as a fraction (a span over the segment, windows over windows per segment).

    Returns
    -------
    int

    Examples
    --------
    >>> count_segments(1.0004), count_segments(1.01), count_segments(0.2)
    (1, 2, 1)
    """
    return max(1, math.ceil(float(segments) - SEGMENT_TOLERANCE))


#: Rank tolerance: ``alpha (n + 1)`` within this of an integer counts as that integer
#: (a per-run target converted to per hour and back must not lose one rank to rounding).
_RANK_TOL = 1e-9


class InsufficientHealthyDataError(ValueError):
    """The healthy maxima given cannot support the requested false-alarm rate (``k < 1``)."""


class InsufficientHealthyDataWarning(UserWarning):
    """Issued when a detector is fitted with an unsupported threshold basis on request."""


@dataclass(frozen=True)
class ReferenceMaxima:
    """Healthy segment maxima from other units (e.g. many virtual machines), to pool.

    Parameters
    ----------
    maxima : array_like
        CUSUM maxima of healthy segments, each computed on a unit standardised by **its own**
        fit and on segments **not** used in that fit (out-of-sample), in healthy std units.
    segment_s : float
        Segment duration (s) the maxima were taken over.
    drift : float
        CUSUM allowance used.
    direction : str
        CUSUM direction used.
    burn_in_s : float
        Burn-in used.
    source : str, default ""
        Where they come from (e.g. ``"benchmark v5, 300 VCA machines, spring load"``).
    n_units : int, default 0
        Number of distinct units the maxima come from (0: unknown).

    Notes
    -----
    Pooling rule (docs/detect.md, "False alarms"): pooled maxima must be exchangeable with the
    unit's future healthy segments -- same detector settings, same alarm settings (checked by
    :meth:`check_compatible`), same rig type, load and excitation, and units drawn from a
    population the monitored unit belongs to. Only the first two can be checked by code.

    Examples
    --------
    >>> ref = ReferenceMaxima([1.0, 2.0, 3.0], segment_s=60.0, drift=0.5, direction="both",
    ...                       burn_in_s=5.0)
    >>> ref.maxima.tolist()
    [1.0, 2.0, 3.0]
    """

    maxima: np.ndarray
    segment_s: float
    drift: float
    direction: str
    burn_in_s: float
    source: str = ""
    n_units: int = 0

    def __post_init__(self) -> None:
        m = np.asarray(self.maxima, dtype=np.float64).ravel()
        if not np.all(np.isfinite(m)):
            raise ValueError("reference maxima must all be finite")
        object.__setattr__(self, "maxima", m)
        check_positive(self.segment_s, "segment_s")

    def check_compatible(self, segment_s: float, drift: float, direction: str,
                         burn_in_s: float) -> None:
        """Raise if these maxima were not computed with the given alarm settings.

        Parameters
        ----------
        segment_s, drift, direction, burn_in_s
            The settings of the detector being fitted.

        Raises
        ------
        ValueError
            Naming the first setting that differs.
        """
        if abs(self.segment_s - segment_s) > SEGMENT_TOLERANCE * segment_s:
            raise ValueError(f"reference maxima were taken over segment_s={self.segment_s} s, "
                             f"the detector uses segment_s={segment_s} s: they cannot be pooled")
        for name, mine, theirs in (("drift", drift, self.drift), ("burn_in_s", burn_in_s,
                                                                  self.burn_in_s)):
            if not math.isclose(mine, theirs, rel_tol=1e-9, abs_tol=1e-12):
                raise ValueError(f"reference maxima used {name}={theirs}, the detector "
                                 f"{name}={mine}: they cannot be pooled")
        if direction != self.direction:
            raise ValueError(f"reference maxima used direction={self.direction!r}, the "
                             f"detector direction={direction!r}: they cannot be pooled")


@dataclass(frozen=True)
class ThresholdBasis:
    """How an alarm threshold was set, and what it guarantees (``Detector.threshold_basis_``).

    Attributes
    ----------
    method : str
        ``"conformal"`` (supported) or ``"conformal-unsupported"`` (``k < 1``: fitted on request
        at the largest healthy maximum, the target is **not** guaranteed); ``"glr-model"``: the
        flow balance's model-based level, used when its maxima do not support the target.
    threshold : float
        Alarm level h (healthy std units); an alarm is raised when the CUSUM exceeds it.
    n : int
        Healthy maxima used (own + reference).
    n_own, n_reference : int
        Maxima from the unit's own healthy recordings and from :class:`ReferenceMaxima`.
    k : int
        Rank: the threshold is the k-th largest maximum (0 when unsupported).
    segment_s : float
        Segment duration (s).
    target_per_segment : float
        Requested false-alarm probability per segment, ``target_per_hour * segment_s / 3600``.
    bound_per_segment : float
        Guaranteed bound ``k / (n + 1)`` (``1 / (n + 1)`` achieved level when unsupported; NaN
        for ``"glr-model"``, whose rate no data bound).
    target_per_hour, bound_per_hour : float
        The same per hour of healthy operation (expected segments with an alarm per hour).
    conditional_upper_95 : float
        95 % upper bound of the rate **conditional on this calibration** (beta quantile
        ``Beta(k, n + 1 - k)``): the achieved rate of this very threshold exceeds it with
        probability 5 %.
    supported : bool
        ``k >= 1``.
    min_n_for_target : int
        Smallest ``n`` that supports the target: ``ceil(1 / alpha) - 1``.
    reference_source : str
        ``ReferenceMaxima.source`` ("" without reference).
    maxima : numpy.ndarray
        The pooled maxima, sorted in decreasing order (for p-values).
    statistic : str, default "CUSUM"
        The per-segment statistic whose maxima set the level (``"GLR"`` for the flow balance).
    confidence : float, default NaN
        Calibration-conditional rank (``conformal_threshold(..., confidence=c)``): with
        probability at least ``c`` over the healthy maxima, this threshold's rate is at most
        ``target_per_segment``. NaN: the rank ``floor(alpha (n + 1))``, whose bound holds on
        average over calibrations.

    Examples
    --------
    >>> b = conformal_threshold([3.0, 1.0, 2.0, 5.0, 4.0], 0.4, segment_s=60.0)
    >>> b.k, b.threshold, round(b.bound_per_segment, 4)
    (2, 4.0, 0.3333)
    """

    method: str
    threshold: float
    n: int
    n_own: int
    n_reference: int
    k: int
    segment_s: float
    target_per_segment: float
    bound_per_segment: float
    target_per_hour: float
    bound_per_hour: float
    conditional_upper_95: float
    supported: bool
    min_n_for_target: int
    reference_source: str = ""
    maxima: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    statistic: str = "CUSUM"
    confidence: float = float("nan")

    @property
    def conditional(self) -> bool:
        """Whether the rank was chosen calibration-conditionally (``confidence`` given)."""
        return bool(np.isfinite(self.confidence))

    def __str__(self) -> str:
        """The basis as one sentence: level, rank among the healthy maxima, segment, and the
        false-alarm rate it guarantees -- or that it guarantees none (``supported`` False).

        Examples
        --------
        >>> print(conformal_threshold([3.0, 1.0, 2.0, 5.0, 4.0], 0.4, segment_s=60.0))
        ... # doctest: +NORMALIZE_WHITESPACE
        4 = the 2nd largest of 5 healthy CUSUM maxima (5 own; 60-s segments): at most 0.333 false
        alarm(s) per segment, i.e. 20 per hour (requested 24 per hour; 95 % upper bound for this
        very threshold 0.657 per segment)
        """
        src = f"{self.n_own} own" + (f", {self.n_reference} from other units"
                                     if self.n_reference else "")
        of = f"{self.n} healthy {self.statistic} maxima ({src}; {self.segment_s:g}-s segments)"
        if self.method == "glr-model":
            return (f"{self.threshold:.4g} = the model-based level of the healthy-residual "
                    f"bootstrap, NOT distribution-free: {of} support at best "
                    f"{1 / (self.n + 1):.3g} per segment; the requested {self.target_per_hour:.3g}"
                    f" false alarm(s) per hour needs at least {self.min_n_for_target} maxima to be "
                    "guaranteed by data (docs/detect.md 8.4)")
        at = (f" at {self.confidence * 100:g} % confidence over the healthy data"
              if self.conditional else "")
        if not self.supported:
            return (f"{self.threshold:.4g} = the largest of {of}: UNSUPPORTED, the requested "
                    f"{self.target_per_hour:.3g} false alarm(s) per hour{at} needs at least "
                    f"{self.min_n_for_target} maxima; this threshold holds only "
                    f"{self.bound_per_segment:.3g} per segment")
        k = self.k
        suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
        rank = "largest" if k == 1 else f"{k}{suffix} largest"
        if self.conditional:
            return (f"{self.threshold:.4g} = the {rank} of {of}: at most "
                    f"{self.target_per_segment:.3g} false alarm(s) per segment, i.e. "
                    f"{self.target_per_hour:.3g} per hour, with probability "
                    f"{self.confidence * 100:g} % over the healthy data (calibration-conditional; "
                    f"{self.bound_per_segment:.3g} per segment on average over calibrations)")
        return (f"{self.threshold:.4g} = the {rank} of {of}: at most "
                f"{self.bound_per_segment:.3g} false alarm(s) per segment, i.e. "
                f"{self.bound_per_hour:.3g} per hour (requested {self.target_per_hour:.3g} per "
                f"hour; 95 % upper bound for this very threshold {self.conditional_upper_95:.3g} "
                "per segment)")

    def p_value(self, score: float, n_segments: int = 1) -> float:
        """Conformal p-value of a maximum ``score`` observed over ``n_segments`` segments.

        Parameters
        ----------
        score : float
            Largest CUSUM value of the recording judged.
        n_segments : int, default 1
            Segments the recording spans (a union bound multiplies by it).

        Returns
        -------
        float
            ``min(1, n_segments * (1 + #{maxima >= score}) / (n + 1))``: the probability, under
            exchangeability, that healthy data scores at least this high; never below
            ``1 / (n + 1)`` (the resolution of the healthy reference).
        """
        ge = int(np.count_nonzero(self.maxima >= score))
        return float(min(1.0, max(1, int(n_segments)) * (1 + ge) / (self.n + 1)))

    def at_floor(self, score: float) -> bool:
        """Whether :meth:`p_value` of ``score`` is its floor, ``n_segments / (n + 1)``.

        Parameters
        ----------
        score : float
            Largest statistic of the recording judged.

        Returns
        -------
        bool
            True for a data-backed (``supported``) basis when ``score`` is above every
            healthy maximum: the p-value is then the reference's resolution, not a measure of
            how far above them the score lies.
        """
        return bool(self.supported and self.n > 0
                    and not np.count_nonzero(self.maxima >= score))

    def as_dict(self) -> dict:
        """Flat dict of the basis (without the maxima), for printing and tables.

        Returns
        -------
        dict
            Every attribute except ``maxima``.
        """
        return {k: getattr(self, k) for k in (
            "method", "threshold", "n", "n_own", "n_reference", "k", "segment_s",
            "target_per_segment", "bound_per_segment", "target_per_hour", "bound_per_hour",
            "conditional_upper_95", "supported", "min_n_for_target", "reference_source",
            "statistic", "confidence")}


def segment_maxima(z, time, segment_s: float, t0: float, span_s: float, drift: float = 0.5,
                   direction: str = "both") -> np.ndarray:
    """Largest CUSUM value in each complete segment of one standardised series.

    Parameters
    ----------
    z : array_like
        Standardised feature, shape ``(m,)`` (NaN skipped by the CUSUM).
    time : array_like
        Window timestamps (s), shape ``(m,)``.
    segment_s : float
        Segment duration (s).
    t0 : float
        Start of the monitored span (s): recording start + burn-in.
    span_s : float
        Monitored duration (s); ``floor(span_s / segment_s + SEGMENT_TOLERANCE)`` complete
        segments are used, the remainder is left out.
    drift : float, default 0.5
        CUSUM allowance.
    direction : {"both", "up", "down"}, default "both"
        CUSUM direction.

    Returns
    -------
    numpy.ndarray
        One maximum per complete segment (0 for a segment without a window).

    Examples
    --------
    >>> segment_maxima([2.0, 2.0, -3.0, 0.0], [1.0, 2.0, 3.0, 4.0], 2.0, 0.5, 4.0).tolist()
    [3.0, 2.5]
    """
    z = np.asarray(z, dtype=np.float64)
    check_positive(segment_s, "segment_s")
    if len(z) == 0:
        return np.zeros(0)
    # every segment fresh: the CUSUM restarts at each boundary (segmented_cusum), as a judged
    # recording's does unless in alarm, so that its segments match these maxima
    up, dn = segmented_cusum(z, segment_index(time, t0, segment_s), drift, direction)
    return binned_maxima(np.maximum(up, dn), time, segment_s, t0, span_s)


def segment_index(time, t0: float, segment_s: float) -> np.ndarray:
    """Healthy segment of each window: ``floor((time - t0) / segment_s)``, at least 0.

    Parameters
    ----------
    time : array_like
        Window timestamps (s, last sample).
    t0 : float
        Start of the monitored span (s): recording start + burn-in.
    segment_s : float
        Segment duration (s).

    Returns
    -------
    numpy.ndarray of int64

    Examples
    --------
    >>> segment_index([1.0, 2.0, 2.6, 4.9], 0.5, 2.0).tolist()
    [0, 0, 1, 2]
    """
    return _segments(np.ascontiguousarray(time, dtype=np.float64).reshape(-1), float(t0),
                     float(segment_s))


def binned_maxima(stat, time, segment_s: float, t0: float, span_s: float) -> np.ndarray:
    """Largest value of a statistic in each complete segment of a monitored span.

    Parameters
    ----------
    stat : array_like
        Statistic per window, shape ``(m,)``.
    time : array_like
        Window timestamps (s), shape ``(m,)``; a window belongs to the segment its timestamp
        falls in.
    segment_s : float
        Segment duration (s).
    t0 : float
        Start of the monitored span (s).
    span_s : float
        Monitored duration (s); ``floor(span_s / segment_s + SEGMENT_TOLERANCE)`` complete
        segments are used, the remainder is left out.

    Returns
    -------
    numpy.ndarray
        One maximum per complete segment (0 for a segment without a window).

    Raises
    ------
    ValueError
        If ``segment_s`` is not positive.

    Examples
    --------
    >>> binned_maxima([1.0, 4.0, 2.0, 3.0], [1.0, 2.0, 3.0, 4.0], 2.0, 0.5, 4.0).tolist()
    [4.0, 3.0]
    """
    stat = np.asarray(stat, dtype=np.float64)
    time = np.asarray(time, dtype=np.float64)
    check_positive(segment_s, "segment_s")
    n_seg = int(math.floor(span_s / segment_s + SEGMENT_TOLERANCE))
    if n_seg < 1 or len(stat) == 0:
        return np.zeros(0)
    idx = segment_index(time, t0, segment_s)
    keep = idx < n_seg
    out = np.zeros(n_seg)
    np.maximum.at(out, idx[keep], stat[keep])
    return out


def conditional_rank(n: int, alpha: float, confidence: float) -> int:
    """Largest rank whose threshold holds ``alpha`` with probability ``confidence``.

    Parameters
    ----------
    n : int
        Healthy maxima, >= 0.
    alpha : float
        Target false-alarm probability per segment, in (0, 1).
    confidence : float
        Probability over the healthy data that the threshold's rate is at most ``alpha``, in
        (0, 1).

    Returns
    -------
    int
        The largest ``k`` in ``[1, n]`` with ``P(Binomial(n, alpha) <= k - 1) <= 1 -
        confidence``, or 0 when even ``k = 1`` does not qualify (``(1 - alpha)^n > 1 -
        confidence``).

    Notes
    -----
    For exchangeable maxima with a continuous law the rate of the ``k``-th largest of ``n``,
    ``P(M > M_(k) | M_1..M_n)``, is distributed as the ``k``-th smallest of ``n`` uniforms,
    ``Beta(k, n + 1 - k)``, and ``P(Beta(k, n + 1 - k) > alpha) = P(Binomial(n, alpha) <= k -
    1)`` (Vovk 2012, Prop. 2a; ties only lower the rate).

    Examples
    --------
    >>> conditional_rank(100, 0.01, 0.95), conditional_rank(299, 0.01, 0.95)
    (0, 1)
    >>> conditional_rank(1000, 0.01, 0.95)
    5
    """
    from scipy.stats import binom

    if n < 1:
        return 0
    cdf = binom.cdf(np.arange(n), n, alpha)  # cdf[k - 1] = P(Binomial <= k - 1)
    return int(np.count_nonzero(cdf <= (1.0 - confidence) * (1.0 + _RANK_TOL)))


def min_maxima(alpha: float, confidence: float | None = None) -> int:
    """Fewest healthy maxima that support a target per segment.

    Parameters
    ----------
    alpha : float
        Target false-alarm probability per segment, in (0, 1).
    confidence : float, optional
        Calibration-conditional confidence (:func:`conditional_rank`); None: the rank
        ``floor(alpha (n + 1))``.

    Returns
    -------
    int
        ``ceil(1 / alpha) - 1`` (rank 1 of the marginal rule), or ``ceil(log(1 - c) / log(1 -
        alpha))`` with a confidence ``c``.

    Examples
    --------
    >>> min_maxima(0.01), min_maxima(0.01, 0.95)
    (99, 299)
    """
    if confidence is None:
        return int(math.ceil(1.0 / alpha - _RANK_TOL)) - 1
    return int(math.ceil(math.log1p(-confidence) / math.log1p(-alpha) - _RANK_TOL))


def conformal_threshold(maxima, target_per_segment: float, *, segment_s: float,
                        reference: ReferenceMaxima | None = None,
                        on_insufficient: str = "raise",
                        confidence: float | None = None) -> ThresholdBasis:
    """Threshold = k-th largest healthy maximum, ``k = floor(alpha (n + 1))``.

    Parameters
    ----------
    maxima : array_like
        The unit's own healthy segment maxima.
    target_per_segment : float
        Target false-alarm probability per segment ``alpha``, in (0, 1).
    segment_s : float
        Segment duration (s), recorded and used for the per-hour figures.
    reference : ReferenceMaxima, optional
        Maxima from other units, pooled with ``maxima`` (compatibility is the caller's check).
    on_insufficient : {"raise", "warn"}, default "raise"
        What to do when ``k < 1``: raise :class:`InsufficientHealthyDataError`, or return an
        unsupported basis at the largest maximum with an
        :class:`InsufficientHealthyDataWarning`.
    confidence : float, optional
        Choose the rank calibration-conditionally (:func:`conditional_rank`): with probability
        at least ``confidence`` over the healthy maxima the threshold's own rate is at most
        ``alpha``. None: ``k = floor(alpha (n + 1))``, a bound on average over calibrations.

    Returns
    -------
    ThresholdBasis

    Raises
    ------
    InsufficientHealthyDataError
        If ``k < 1`` and ``on_insufficient="raise"``; the message names the number of maxima
        needed.
    ValueError
        For a target or confidence outside (0, 1), no maxima at all, or a maximum that is NaN
        or infinite (a NaN sorts first and would become the threshold; an infinite one a
        threshold nothing crosses).

    Notes
    -----
    With healthy maxima ``M_(1) >= ... >= M_(n)`` and a new healthy maximum ``M`` exchangeable
    with them, the rank of ``M`` among the ``n + 1`` is uniform, so

    .. math:: P(M > M_{(k)}) \\le k / (n + 1) \\le \\alpha .

    The bound holds on average over calibrations; the rate of one calibration is
    ``Beta(k, n + 1 - k)``-distributed, whose 95 % quantile is recorded. With ``confidence``
    the rank is the calibration-conditional one instead (module docstring).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> b = conformal_threshold(rng.exponential(size=299), 0.01, segment_s=60.0)
    >>> b.k, round(b.bound_per_segment, 4)
    (3, 0.01)
    >>> c = conformal_threshold(rng.exponential(size=299), 0.01, segment_s=60.0, confidence=0.95)
    >>> c.k, bool(c.conditional_upper_95 <= 0.01)
    (1, True)
    """
    from scipy.stats import beta

    alpha = float(target_per_segment)
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"target_per_segment={alpha!r} must be in (0, 1)")
    if on_insufficient not in ("raise", "warn"):
        raise ValueError(f"on_insufficient={on_insufficient!r} must be 'raise' or 'warn'")
    own = np.asarray(maxima, dtype=np.float64).ravel()
    ref = reference.maxima if reference is not None else np.zeros(0)
    for name, vals in (("healthy segment maxima", own), ("reference maxima", ref)):
        bad = np.flatnonzero(~np.isfinite(vals))
        if bad.size:  # a statistics audit (2026-11-28, finding 5): a NaN became the threshold
            raise ValueError(f"{bad.size} of {vals.size} {name} are not finite (first: index "
                             f"{bad[0]}, {vals[bad[0]]}): a healthy segment whose statistic "
                             "is undefined or diverged cannot set a threshold")
    pooled = np.sort(np.concatenate([own, ref]))[::-1]
    n = len(pooled)
    if n == 0:
        raise InsufficientHealthyDataError("no healthy segment maxima: give healthy recordings "
                                           f"at least segment_s={segment_s} s long")
    seg_h = segment_s / 3600.0
    if confidence is None:
        conf = float("nan")
        k = min(int(math.floor(alpha * (n + 1) + _RANK_TOL)), n)
        floor = f"support false-alarm probabilities down to 1/(n+1) = {1 / (n + 1):.3g} per segment"
        asked = f"{alpha:.3g} per segment ({alpha / seg_h:.3g} per hour)"
    else:
        conf = float(confidence)
        if not 0.0 < conf < 1.0:
            raise ValueError(f"confidence={confidence!r} must be in (0, 1)")
        k = conditional_rank(n, alpha, conf)
        floor = (f"hold a rate at {conf * 100:g} % confidence down to "
                 f"{-math.expm1(math.log1p(-conf) / n):.3g} per segment")
        asked = (f"{alpha:.3g} per segment ({alpha / seg_h:.3g} per hour) at {conf * 100:g} % "
                 "confidence")
    need = min_maxima(alpha, confidence)
    src = reference.source if reference is not None else ""
    if k < 1:
        msg = (f"{n} healthy maxima of {segment_s:g} s segments ({len(own)} own, {len(ref)} "
               f"reference) {floor}; {asked} needs at "
               f"least {need} maxima, i.e. about {need * segment_s / 3600:.3g} h of healthy data. "
               "Give more healthy recordings, reference maxima from other units, or a larger "
               "target")
        if on_insufficient == "raise":
            raise InsufficientHealthyDataError(msg)
        warnings.warn(msg + " -- fitted anyway at the largest healthy maximum (unsupported "
                      "basis recorded).", InsufficientHealthyDataWarning, stacklevel=3)
        return ThresholdBasis("conformal-unsupported", float(pooled[0]), n, len(own), len(ref),
                              0, float(segment_s), alpha, 1.0 / (n + 1), alpha / seg_h,
                              1.0 / (n + 1) / seg_h, float(beta.ppf(0.95, 1, n)), False, need,
                              src, pooled, confidence=conf)
    bound = k / (n + 1)
    return ThresholdBasis("conformal", float(pooled[k - 1]), n, len(own), len(ref), k,
                          float(segment_s), alpha, bound, alpha / seg_h, bound / seg_h,
                          float(beta.ppf(0.95, k, n + 1 - k)), True, need, src, pooled,
                          confidence=conf)
