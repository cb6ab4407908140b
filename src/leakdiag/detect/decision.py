"""A fitted detector's decision on one run: its false-alarm rate for the run, and the run level.

A detector's threshold holds a false-alarm rate per healthy segment (or per hour). A run of
``m`` segments lets ``m`` times as many alarms through by chance (:func:`expected_false_alarms`,
the union bound); at one or more expected false alarms an alarm at the threshold is no evidence
of a leak (flow-balance audit 2026-11-28, finding 4). A run longer than one healthy segment is
judged at the level that holds the whole run to the rate of one healthy segment where the
detector can state one (``run_level``: the flow balance's conformal or model-based level; the
features' conformal rank, guaranteed by their restarts; :func:`longer_than_a_segment`,
:func:`judge_run`); otherwise at its threshold, and its alarm is INCONCLUSIVE from one expected
false alarm on, or, in a run longer than a segment, above the rate asked of the run
(:func:`unheld_long_run`). ``leakdiag detect``, ``leakdiag batch`` and the segments of
``leakdiag monitor --segment`` decide with :func:`judge_run`; ``monitor`` refuses a segment
length in which a detector expects a false alarm and cannot raise its level.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from leakdiag.detect.threshold import SEGMENT_TOLERANCE, count_segments, min_maxima

__all__ = ["detector_rate", "per_run_rate", "expected_false_alarms", "longer_than_a_segment",
           "raised_level", "RunJudgement", "judge_run", "judge", "run_decision",
           "run_segments", "run_level_method", "run_level_how", "run_level_confidence",
           "unheld_long_run", "unheld_words"]


def detector_rate(det) -> tuple[float, float]:
    """The false alarms per hour and the burn-in (s) a fitted detector was fitted with.

    Detectors with their own alarm (the flow balance) keep them on the threshold and on
    themselves, not on the default ``Alarm``.

    Parameters
    ----------
    det : Detector
        A fitted detector.

    Returns
    -------
    per_hour : float
    burn_in_s : float
    """
    a = det._alarm()
    return (float(getattr(det.alarm_threshold_, "target_per_hour", a.false_alarms_per_hour)),
            float(getattr(det, "burn_in_s", a.burn_in_s)))


def per_run_rate(basis, per_hour: float, span_s: float, n_segments: int | None = None,
                 restarts: bool = True) -> tuple[float, bool]:
    """The false-alarm rate a threshold promises for one judged run, and whether data back it.

    A distribution-free (conformal) threshold holds ``bound_per_segment`` per healthy segment
    (``k / (n + 1)``; when the healthy runs do not support the target, the largest maximum's
    ``1 / (n + 1)``, above the target but still a bound), so a run of one segment (or shorter:
    held to the segment's bound, which cannot be scaled down) is held to it, and a run spanning
    ``m > 1`` segments to ``min(1, m * bound_per_segment)`` (union bound): the healthy maxima
    come from fresh segments, and a detector whose statistic restarts at each segment boundary
    unless in alarm (``restarts``, :attr:`Detector.restarts_per_segment`) judges every segment
    as one. Without restarts (the flow balance's GLR) the later segments start with the
    statistic carried over, and the bound is **not guaranteed** beyond the first (docs/detect.md
    section 2; a statistics audit measured 10-25 % against a stated 10 % before the restarts).
    A model-based level (the flow balance's) or no basis guarantees nothing: the rate is the
    requested one per hour times the span, and says so.

    Parameters
    ----------
    basis : ThresholdBasis or None
        ``Detector.threshold_basis_``.
    per_hour : float
        Requested false alarms per hour.
    span_s : float
        Judged span of the run (after the burn-in), s.
    n_segments : int, optional
        Segments the span covers as the detector counted them for its p-value
        (``Verdict.n_segments``); default: ``span_s`` over the basis's ``segment_s``.
    restarts : bool, default True
        Whether the detector's statistic restarts at each segment boundary unless in alarm.

    Returns
    -------
    rate : float
    guaranteed : bool

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> b = conformal_threshold([3.0, 1.0, 2.0, 5.0], 0.2, segment_s=60.0)  # 1/5 per segment
    >>> per_run_rate(b, 12.0, 7.0)  # 7 s judged: 1 segment, not 12/h x 7 s = 0.023
    (0.2, True)
    >>> r = per_run_rate(b, 12.0, 150.0)  # 3 segments: the union bound
    >>> round(r[0], 9), r[1]
    (0.6, True)
    >>> per_run_rate(b, 12.0, 150.0, restarts=False)[1]  # carried over: not guaranteed
    False
    >>> per_run_rate(None, 12.0, 150.0)
    (0.5, False)
    """
    m = conformal_segments(basis, span_s, n_segments)
    if m is not None:
        return min(1.0, float(basis.bound_per_segment) * m), m <= 1 or restarts
    return per_hour * span_s / 3600.0, False


def conformal_segments(basis, span_s: float, n_segments: int | None = None) -> int | None:
    """Healthy segments a judged span covers under a conformal basis (None for another).

    Parameters
    ----------
    basis : ThresholdBasis or None
        ``Detector.threshold_basis_``.
    span_s : float
        Judged span of the run (after the burn-in), s.
    n_segments : int, optional
        Segments as the detector counted them; default ``ceil(span_s / segment_s)`` (a run
        within :data:`~leakdiag.detect.threshold.SEGMENT_TOLERANCE` of a whole number of
        segments holds that number), at least 1.

    Returns
    -------
    int or None
    """
    if basis is None or not basis.method.startswith("conformal") or \
            not math.isfinite(basis.bound_per_segment):
        return None
    return n_segments if n_segments is not None else \
        count_segments(span_s / basis.segment_s)


def expected_false_alarms(basis, per_hour: float, span_s: float,
                          n_segments: int | None = None) -> float:
    """False alarms a threshold lets through by chance in a judged run, not capped at 1.

    :func:`per_run_rate`'s union bound before its cap (a conformal basis: ``m`` segments times
    ``bound_per_segment``; otherwise the rate per hour times the span). At 1 or more an alarm is
    what the threshold expects of a healthy run this long: no evidence of a leak
    (:func:`run_decision`; flow-balance audit 2026-11-28, finding 4).

    Parameters
    ----------
    basis : ThresholdBasis or None
        ``Detector.threshold_basis_``.
    per_hour : float
        Requested false alarms per hour.
    span_s : float
        Judged span of the run (after the burn-in), s.
    n_segments : int, optional
        Segments the span covers (``Verdict.n_segments``).

    Returns
    -------
    float

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> b = conformal_threshold([3.0, 1.0, 2.0, 5.0], 0.2, segment_s=60.0)  # 1/5 per segment
    >>> round(expected_false_alarms(b, 12.0, 600.0), 9)  # 10 segments
    2.0
    >>> expected_false_alarms(None, 20.0, 1800.0)
    10.0
    """
    m = conformal_segments(basis, span_s, n_segments)
    if m is not None:
        return float(basis.bound_per_segment) * m
    return per_hour * span_s / 3600.0


def longer_than_a_segment(basis, per_hour: float, span_s: float,
                          segments: float | None = None) -> bool:
    """Whether a judged run lets more false alarms through at the threshold than one healthy
    segment: the runs :func:`judge_run` holds to one segment's rate at a raised level.

    Under a threshold basis with a segment, a run covering more than one segment
    (``segments``, the detector's own count, when given; else :func:`conformal_segments` for a
    conformal basis, ``span_s / segment_s`` otherwise; each beyond
    :data:`~leakdiag.detect.threshold.SEGMENT_TOLERANCE`). Without a basis (no
    segment to compare with), a run whose threshold expects one false alarm or more
    (:func:`expected_false_alarms`). Until 2026-11-28 (session 19) the rule was the second one
    for every run, so a run expecting 0.94 false alarms at the fitted level was judged there
    (LEAK on a 61 % chance of a false alarm) and one expecting 1.0 at one segment's rate
    (docs/detect.md section 6, "Long runs").

    Parameters
    ----------
    basis, per_hour, span_s
        As :func:`expected_false_alarms` (the threshold basis, false alarms per hour, the
        judged span in s).
    segments : float, optional
        Healthy segments the run covers as the detector counts them (fractional; the flow
        balance's ``segments_spanned``).

    Returns
    -------
    bool

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> b = conformal_threshold([3.0, 1.0, 2.0, 5.0], 0.2, segment_s=60.0)
    >>> longer_than_a_segment(b, 12.0, 60.0), longer_than_a_segment(b, 12.0, 61.0)
    (False, True)
    >>> longer_than_a_segment(None, 1.0, 1800.0), longer_than_a_segment(None, 1.0, 3600.0)
    (False, True)
    """
    seg = float(getattr(basis, "segment_s", float("nan")))
    if basis is None or not math.isfinite(seg) or seg <= 0:
        return expected_false_alarms(basis, per_hour, span_s) >= 1.0
    if segments is not None:
        return segments - SEGMENT_TOLERANCE > 1.0
    m = conformal_segments(basis, span_s)
    if m is not None:
        return m > 1
    return span_s / seg - SEGMENT_TOLERANCE > 1.0


def run_decision(leak, expected: float) -> str:
    """``"leak"``, ``"no-leak"`` or ``"inconclusive"`` for one method's verdict on one run.

    An alarm in a run where its threshold expects one false alarm or more is no evidence of a
    leak (``"inconclusive"``); no verdict (``leak`` None: the method could not judge) is
    ``"inconclusive"`` too.

    Parameters
    ----------
    leak : bool or None
        The verdict's alarm.
    expected : float
        False alarms expected by chance in the run at the level it was judged at
        (:func:`expected_false_alarms`; NaN counts as 0).

    Returns
    -------
    str

    Examples
    --------
    >>> run_decision(True, 0.2), run_decision(True, 1.5), run_decision(False, 9.0)
    ('leak', 'inconclusive', 'no-leak')
    """
    if leak is None:
        return "inconclusive"
    if not leak:
        return "no-leak"
    return "inconclusive" if expected >= 1.0 else "leak"


@dataclass(frozen=True)
class RunJudgement:
    """One fitted detector's verdict on one run, with the false-alarm rate it was judged at.

    Attributes
    ----------
    verdict : Verdict
        The detector's verdict, at ``level`` (``run_level``) or at its threshold.
    per_hour : float
        The false alarms per hour the detector was fitted for.
    span_s : float
        The judged span (duration minus the burn-in), s.
    expected : float
        False alarms expected by chance in the run at the level judged at (not capped).
    per_run : float
        False-alarm rate for the run (``expected`` capped at 1: :func:`per_run_rate`).
    guaranteed : bool
        Whether healthy data back ``per_run`` (a conformal level of a one-segment run or of a
        detector that restarts at each segment).
    expected_at_threshold : float
        False alarms expected at the fitted threshold (equal to ``expected`` unless raised).
    run_level : float or None
        The raised level the run was judged at (None: the fitted threshold).
    decision : str
        :func:`run_decision` of the verdict at the level judged at.
    segment_target : float
        The false-alarm rate requested of one healthy segment (``target_per_segment`` of the
        threshold basis; NaN without one): what a run level holds the whole run to.
    run_level_method : {"conformal", "model-based"} or None
        What backs the run level (None: judged at the threshold): a rank of the healthy maxima
        (``"conformal"``), or the flow balance's bootstrap null where the maxima cannot resolve
        the run (``"model-based"``: its expected false alarms are an estimate, not a bound).
    why_inconclusive : str or None
        Why an alarm is no evidence of a leak (``decision`` ``"inconclusive"`` with an alarm),
        in words; None otherwise.
    confidence : float
        The calibration-conditional confidence of a conformal run level (``confidence`` of
        the threshold basis: the run held to ``segment_target`` with that probability over
        the healthy data); NaN otherwise.
    """

    verdict: object
    per_hour: float
    span_s: float
    expected: float
    per_run: float
    guaranteed: bool
    expected_at_threshold: float
    run_level: float | None
    decision: str
    segment_target: float = float("nan")
    run_level_method: str | None = None
    why_inconclusive: str | None = None
    confidence: float = float("nan")

    def run_level_words(self, threshold: float) -> str | None:
        """The raised level in words, or None when the run was judged at the threshold.

        Parameters
        ----------
        threshold : float
            The detector's fitted threshold.

        Returns
        -------
        str or None
        """
        if self.run_level is None:
            return None
        head = (f"this {self.span_s:.4g}-s run is judged at the level {self.run_level:.4g} "
                f"(fitted level {threshold:.4g}, which expects about "
                f"{self.expected_at_threshold:.3g} false alarms in a run this long)")
        # guaranteed: a rank whose statistic restarts per segment (run_level_how's restarts)
        return (f"{head}, " + run_level_how(self.expected, self.segment_target,
                                              self.run_level_method, self.confidence,
                                              self.guaranteed)
                + " (docs/detect.md section 6, 'Long runs')")


def run_level_how(expected: float, target: float, method: str | None,
                  confidence: float = float("nan"), restarts: bool = True,
                  span: str = "run") -> str:
    """What a run level holds a run to, in words (``detect``, ``batch`` and ``monitor``).

    Parameters
    ----------
    expected : float
        False alarms the run level expects in the run.
    target : float
        The rate requested of one healthy segment.
    method : {"conformal", "model-based"}
        What backs the level (:func:`run_level_method`).
    confidence : float, default NaN
        A calibration-conditional rank's confidence (NaN: the marginal rank).
    restarts : bool, default True
        Whether the detector's statistic restarts at each segment boundary
        (``Detector.restarts_per_segment``); the flow balance's GLR carries its state over,
        so its rank bounds the first segment only (:func:`per_run_rate`; until session 22 the
        words said "at most" for it too). Not used for a model-based level.
    span : str, default "run"
        What is judged ("run", or "segment" for ``monitor --segment``).

    Returns
    -------
    str

    Examples
    --------
    >>> run_level_how(0.06, 0.1, "conformal")[:40]
    'so that it expects at most 0.06, within '
    >>> "not guaranteed beyond its first segment" in run_level_how(0.06, 0.1, "conformal",
    ...                                                              restarts=False)
    True
    """
    if method == "model-based":  # the maxima could not resolve the run
        return (f"so that it expects about {expected:.3g} by the bootstrap null's fitted tail "
                "(no lighter than the healthy maxima at the largest of them), against the "
                f"{target:.3g} requested of one healthy segment: model-based, not "
                "guaranteed by the healthy data, whose maxima are too few to hold a "
                f"{span} this long to a segment's rate")
    if math.isfinite(confidence):  # a calibration-conditional rank (--confidence)
        held = (f"so that with probability {confidence * 100:g} % over the healthy data it "
                f"lets through at most the {target:.3g} false alarms requested of one healthy "
                f"segment (about {expected:.3g} on average; a calibration-conditional rank of "
                "the healthy maxima)")
    else:
        held = (f"so that it expects at most {expected:.3g}, within the {target:.3g} requested "
                "of one healthy segment (a rank of the healthy maxima)")
    if restarts:
        return held
    return (held + ", a bound not guaranteed beyond its first segment: the detector's "
            "statistic carries its state over segment boundaries")


def run_level_confidence(basis, method: str | None) -> float:
    """The confidence a run level holds its run to its target with: the basis's
    calibration-conditional ``confidence`` for a rank of its maxima (``method``
    ``"conformal"``), NaN otherwise (the marginal rank, a model-based level or none).

    Parameters
    ----------
    basis : ThresholdBasis or None
        ``Detector.threshold_basis_``.
    method : {"conformal", "model-based"} or None
        What backs the run level (:func:`run_level_method`; None: judged at the threshold).

    Returns
    -------
    float

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> b = conformal_threshold(range(1, 61), 0.2, segment_s=5.0, confidence=0.9)
    >>> run_level_confidence(b, "conformal"), run_level_confidence(b, "model-based")
    (0.9, nan)
    """
    if method == "conformal" and getattr(basis, "conditional", False):
        return float(basis.confidence)
    return float("nan")


def raised_level(det, n_samples: int, sample_rate_hz: float) -> tuple[float, float] | None:
    """The level a run of ``n_samples`` is judged at when it is longer than one healthy segment.

    ``det.run_level`` for the run (with the segments the detector counts in it,
    ``segments_spanned``) when :func:`longer_than_a_segment`; None when the run is one
    segment or shorter, or the detector cannot raise its level (no ``run_level``, or its
    healthy reference cannot resolve one). A calibration-conditional conformal level
    (``confidence`` given) is raised by the same rule, to its conditional run rank
    (``Detector._run_rank``); until session 22 only from one expected false alarm on.

    Parameters
    ----------
    det : Detector
        A fitted detector.
    n_samples : int
        Samples of the run.
    sample_rate_hz : float
        Its sample rate, Hz.

    Returns
    -------
    (level, expected) or None
    """
    raise_to = getattr(det, "run_level", None)
    if not callable(raise_to):
        return None
    per_hour, burn_in = detector_rate(det)
    basis = getattr(det, "threshold_basis_", None)
    span_s = max(n_samples / float(sample_rate_hz) - burn_in, 0.0)
    segs, n_seg = run_segments(det, n_samples, sample_rate_hz)
    if not longer_than_a_segment(basis, per_hour, span_s, segs):
        return None
    return raise_to(span_s, n_seg)


def run_segments(det, n_samples: int, sample_rate_hz: float
                 ) -> tuple[float | None, int | None]:
    """Healthy segments a run of ``n_samples`` covers, as the detector counts them.

    Parameters
    ----------
    det, n_samples, sample_rate_hz
        As :func:`raised_level` (the fitted detector, the run's samples and rate in Hz).

    Returns
    -------
    segments : float or None
        The detector's fractional count (``segments_spanned``; None for a detector without
        one, which its threshold basis's segment then counts).
    whole : int or None
        ``segments`` as whole segments (:func:`~leakdiag.detect.threshold.count_segments`, as
        the flow balance counts them for its p-value).
    """
    spanned = getattr(det, "segments_spanned", None)
    segs = spanned(n_samples, sample_rate_hz) if callable(spanned) else None
    return segs, None if segs is None else count_segments(segs)


def run_level_method(det, span_s: float, n_segments: int | None = None) -> str:
    """What backs a detector's run level for a span: ``"conformal"`` (a rank of its healthy
    maxima, ``Detector._run_rank`` at least 1) or ``"model-based"`` (the flow balance's
    bootstrap null, where the maxima cannot resolve the run).

    Parameters
    ----------
    det : Detector
        A fitted detector whose ``run_level`` returned a level for the span.
    span_s : float
        The judged span, s.
    n_segments : int, optional
        Segments the span covers (as :func:`run_segments`).

    Returns
    -------
    str
    """
    rank = getattr(det, "_run_rank", None)
    m = conformal_segments(getattr(det, "threshold_basis_", None), span_s, n_segments)
    return "conformal" if callable(rank) and rank(m) >= 1 else "model-based"


def unheld_long_run(det, n_samples: int, sample_rate_hz: float,
                    run_target: float | None = None) -> tuple[float, float, int] | None:
    """A run longer than one healthy segment that no run level holds to the run's target.

    Such a run is judged at the detector's threshold, where it expects ``m`` times a
    segment's false alarms (:func:`expected_false_alarms`). Until session 21 its alarm read
    LEAK whenever that stayed below one: a statistics audit (2026-11-28, finding 1) fitted
    acf-p1 for 24 false alarms per hour on 20 healthy 20-s runs (0.133 per segment, whose
    maxima resolve no run level of 6 segments) and judged healthy 120-s files: 207 of 400 read
    LEAK "at most 0.762". An alarm is evidence only at the rate asked of the run.

    Parameters
    ----------
    det, n_samples, sample_rate_hz
        As :func:`raised_level` (the fitted detector, the run's samples and rate in Hz).
    run_target : float, optional
        The false-alarm rate the run is held to; default the rate requested of one healthy
        segment (``target_per_segment`` of the threshold basis), as a run level holds it.
        ``leakdiag detect`` gives its per-run rate where it fitted a method for ``1/m`` of it
        per segment.

    Returns
    -------
    (expected, target, segments) or None
        The false alarms expected at the threshold in the run, the target it exceeds and
        the whole segments counted; None when the run is one segment or shorter, a run level
        holds it, its expected false alarms are within the target (or 1 or more, the case
        :func:`run_decision` reads inconclusive itself), or there is no target.
    """
    if raised_level(det, n_samples, sample_rate_hz) is not None:
        return None
    return _unheld(det, n_samples, sample_rate_hz, run_target)


def _unheld(det, n_samples: int, sample_rate_hz: float,
            run_target: float | None) -> tuple[float, float, int] | None:
    """:func:`unheld_long_run` for a run no run level holds (``raised_level`` None)."""
    per_hour, burn_in = detector_rate(det)
    basis = getattr(det, "threshold_basis_", None)
    target = float(getattr(basis, "target_per_segment", float("nan"))) \
        if run_target is None else float(run_target)
    span_s = max(n_samples / float(sample_rate_hz) - burn_in, 0.0)
    segs, n_seg = run_segments(det, n_samples, sample_rate_hz)
    if basis is None or not math.isfinite(target) or \
            not longer_than_a_segment(basis, per_hour, span_s, segs):
        return None
    m = conformal_segments(basis, span_s, n_seg)
    if m is None:  # another basis: its segment counts them (longer_than_a_segment's rule)
        seg = float(getattr(basis, "segment_s", float("nan")))
        m = n_seg if n_seg is not None else \
            count_segments(span_s / seg) if math.isfinite(seg) and seg > 0 else 2
    expected = expected_false_alarms(basis, per_hour, span_s, n_seg)
    if expected >= 1.0:
        return None
    if getattr(basis, "conditional", False):
        # with --confidence the threshold holds each segment to target_per_segment with
        # probability c, so the run to m times that; its average (expected) is no part of the
        # promise (a statistics audit, 2026-11-29: 19 of 200 calibrations at c = 0.95 let
        # more than the target through on healthy 2-segment runs, judged by the average)
        held = m * float(basis.target_per_segment) <= target * (1.0 + 1e-9)
    else:
        held = expected <= target * (1.0 + 1e-9)
    return None if held else (expected, target, m)


def unheld_words(expected: float, target: float, m: int, basis) -> str:
    """Why an alarm in a run :func:`unheld_long_run` found is no evidence of a leak.

    Parameters
    ----------
    expected, target, m
        :func:`unheld_long_run`'s answer (false alarms expected at the threshold, the run's
        target, the segments counted).
    basis : ThresholdBasis
        The detector's threshold basis: a conformal one's maxima say how many would resolve
        the run.

    Returns
    -------
    str

    Examples
    --------
    >>> from leakdiag.detect.threshold import conformal_threshold
    >>> b = conformal_threshold(range(1, 19), 0.14, segment_s=5.0)  # 18 maxima, k = 2
    >>> unheld_words(3 * 2 / 19, 0.14, 3, b)[:95]
    'the run covers 3 healthy segments and its healthy reference cannot hold it to the 0.14 false al'
    """
    n = getattr(basis, "n", None)
    fix = ""
    # at the threshold: what the run is expected to let through (a conditional basis holds
    # each segment to its target with probability c, so the run only to m times that)
    at = (f"at the threshold about {expected:.3g} false alarms are expected by chance in a "
          "run this long, so the alarm is no evidence of a leak")
    conformal = n is not None and getattr(basis, "method", "").startswith("conformal") and \
        0 < target < 1
    if conformal and getattr(basis, "conditional", False):
        # the conditional rank for target / m per segment (Detector._run_rank); until session
        # 22 it had none and the words said to fit without --confidence
        c = float(basis.confidence)
        most = int(math.floor(target / -math.expm1(math.log1p(-c) / n) + 1e-9))
        need, held = min_maxima(target / m, c), f" with {c * 100:g} % confidence"
        alpha = float(basis.target_per_segment)
        at = (f"at the threshold each segment is held to {alpha:.3g}{held}, so the run only "
              f"to {min(1.0, m * alpha):.3g} (about {expected:.3g} on average), and the alarm "
              "is no evidence of a leak at the rate asked")
    elif conformal:
        most = int(math.floor(target * (n + 1) + 1e-9))
        need, held = math.ceil(m / target - 1e-9) - 1, ""
    if conformal:
        can = (f"resolve a run of at most {most} segment(s)" if most >= 1 else
               "cannot hold even one segment")
        fix = f" ({n} healthy maxima {can} at {target:.3g}{held}; {max(n + 1, need)} would " \
              f"resolve {m})"
    return (f"the run covers {m} healthy segments and its healthy reference cannot hold it to "
            f"the {target:.3g} false alarms asked of it{fix}: {at}; judge parts as long as the "
            "healthy recordings, give more healthy recordings, or fit for more false alarms per "
            "segment (docs/detect.md section 6, 'Long runs')")


def judge_run(det, rec, run_target: float | None = None) -> RunJudgement:
    """Judge one recording with a fitted detector, holding a long run to a segment's rate.

    The detector's ``predict`` judges ``rec`` at its threshold. When the run is longer than one
    healthy segment (:func:`longer_than_a_segment`: its threshold lets more false alarms through
    in it than in a segment) and the detector can judge at a raised level (a
    ``run_level(span_s)`` method returning the level and the false alarms it expects in the
    run, or None when its healthy reference cannot resolve one), the run is judged at that
    level instead: the whole run is then held to the rate requested of one healthy segment.
    Otherwise it is judged at the threshold, and its alarm is ``"inconclusive"`` when one false
    alarm or more is expected there (:func:`run_decision`), or when the run is longer than one
    segment and the threshold expects more false alarms in it than ``run_target``
    (:func:`unheld_long_run`).

    Parameters
    ----------
    det : Detector
        A fitted detector.
    rec : Recording
        The recording to judge.
    run_target : float, optional
        The false-alarm rate a run judged at the threshold is held to (as
        :func:`unheld_long_run`; default one healthy segment's).

    Returns
    -------
    RunJudgement

    Raises
    ------
    leakdiag.io.RecordingError
        When the detector cannot judge the recording (as its ``predict``).
    """
    return judge(det, rec.n_samples, rec.sample_rate, rec.duration,
                 lambda level: det.predict(rec) if level is None else
                 det.predict(rec, level=level), run_target)


def judge(det, n_samples: int, sample_rate_hz: float, duration_s: float,
          predict: Callable[[float | None], object],
          run_target: float | None = None) -> RunJudgement:
    """:func:`judge_run` on a run given by its length and a ``predict(level)`` of it.

    ``leakdiag batch`` judges the windows it streamed (``Detector.predict_series``) with it,
    :func:`judge_run` a whole recording (``predict``).

    Parameters
    ----------
    det, n_samples, sample_rate_hz
        As :func:`raised_level` (the fitted detector, the run's samples and rate in Hz).
    duration_s : float
        The run's duration, s.
    predict : callable
        ``predict(level)``: the detector's verdict on the run at ``level`` (None: at its
        threshold).
    run_target : float, optional
        As :func:`judge_run`.

    Returns
    -------
    RunJudgement
    """
    per_hour, burn_in = detector_rate(det)
    basis = getattr(det, "threshold_basis_", None)
    restarts = getattr(det, "restarts_per_segment", False)
    span_s = max(duration_s - burn_in, 0.0)
    # decided before predicting: at the threshold, a long healthy run's false alarm can be
    # refused as "no lasting leak" where the run level gives a verdict
    found = raised_level(det, n_samples, sample_rate_hz)
    method = why = None
    if found is not None:
        level, expected = found
        method = run_level_method(det, span_s, run_segments(det, n_samples, sample_rate_hz)[1])
        v = predict(level)
        at_threshold = expected_false_alarms(basis, per_hour, span_s, v.n_segments)
        # guaranteed where the healthy maxima hold the run and the statistic restarts at each
        # segment (the features' CUSUM); not the flow balance's carried-over GLR (run_level),
        # nor its model-based level
        per_run = min(1.0, expected)
        guaranteed = bool(restarts) and method == "conformal"
        decision = run_decision(v.leak, expected)
    else:
        level = None
        v = predict(None)
        expected = at_threshold = expected_false_alarms(basis, per_hour, span_s, v.n_segments)
        per_run, guaranteed = per_run_rate(basis, per_hour, span_s, v.n_segments, restarts)
        decision = run_decision(v.leak, expected)
        over = _unheld(det, n_samples, sample_rate_hz, run_target) \
            if decision == "leak" else None
        if over is not None:  # a long run no run level holds: at its threshold, no evidence
            decision, why = "inconclusive", unheld_words(*over, basis)
    if decision == "inconclusive" and v.leak and why is None:
        why = (f"about {expected:.3g} false alarms are expected by chance in a run this long at "
               "the level it was judged at, so the alarm is no evidence of a leak")
    return RunJudgement(v, per_hour, span_s, expected, per_run, guaranteed, at_threshold, level,
                        decision, float(getattr(basis, "target_per_segment", float("nan"))),
                        method, why, run_level_confidence(basis, method))
