"""When a detector's NO LEAK rests on too little: undefined feature windows (a stuck sensor).

The one rule of ``detect``, ``batch`` (:meth:`leakdiag.detect.base.Detector.predict`) and
``monitor`` (:class:`leakdiag.stream.blind.BlindSpans`), in a module of its own so that the
monitor's page sidecar applies it without importing the detectors (scikit-learn: 1 s).
"""

from __future__ import annotations

__all__ = ["NAN_SPAN_FACTOR", "NAN_SPAN_FLOOR_S", "MAX_UNDEFINED_FRACTION", "undefined_limit",
           "blind_rule", "blind_limit_s"]


#: A judged recording may hold an undefined feature span this many times the healthy
#: recordings' longest before its NO LEAK is refused (leakdiag choice, as the flow balance's
#: ``HOLD_FACTOR`` for held channels) ...
NAN_SPAN_FACTOR = 3.0
#: ... and at least this long (s): an undefined span shorter than a detection delay changes
#: little, and few short healthy runs may show none (an encoder holding its count while the
#: piston rests makes u-x windows undefined for seconds).
NAN_SPAN_FLOOR_S = 10.0
#: ... and NO LEAK is refused whatever the spans when more than this fraction of the judged
#: windows is undefined: on a recording shorter than the floor no span can exceed the limit,
#: and a stuck sensor over most of a 3-s file read NO LEAK on 2 of 15 windows (audit of users'
#: recordings, 2026-11-27, finding 2; leakdiag choice: a decision rests on at least half of
#: the windows it judges).
MAX_UNDEFINED_FRACTION = 0.5


def undefined_limit(healthy_fraction: float = 0.0) -> float:
    """The largest share of undefined judged windows a NO LEAK may rest on:
    ``max(MAX_UNDEFINED_FRACTION, (1 + healthy_fraction) / 2)``, i.e. at least half as many
    defined windows as the healthy recordings had (a review, 2026-11-27: with a fixed half, a
    feature undefined in most healthy windows, ccf u,x while an encoder holds its count, refused
    the detector's own healthy recordings, 310 of 578 windows undefined).

    Parameters
    ----------
    healthy_fraction : float, default 0.0
        Largest share of undefined windows in a healthy recording (``nan_fraction_healthy_``).

    Returns
    -------
    float
        A share in [0.5, 1].

    Examples
    --------
    >>> undefined_limit(0.0), undefined_limit(0.6)
    (0.5, 0.8)
    """
    return max(MAX_UNDEFINED_FRACTION, (1.0 + float(healthy_fraction)) / 2.0)


def blind_rule(healthy_span_s: float, n_windows: int, n_undefined: int,
               longest_span_s: float, healthy_fraction: float = 0.0) -> str | None:
    """Which rule, if any, refuses a NO LEAK over undefined feature windows: ``"span"`` (the
    longest undefined span is longer than :func:`blind_limit_s`), ``"fraction"`` (more than
    :func:`undefined_limit` of the ``n_windows`` judged windows are undefined), or None.

    The one rule of ``detect``, ``batch`` (:meth:`Detector.predict`,
    :meth:`Detector.predict_series`) and ``monitor`` (:class:`leakdiag.stream.BlindSpans`).

    Parameters
    ----------
    healthy_span_s : float
        Longest undefined span of the healthy recordings (``nan_span_healthy_s_``), s.
    n_windows, n_undefined : int
        Windows judged (after the burn-in), and of them undefined (non-finite) ones.
    longest_span_s : float
        Longest run of consecutive undefined windows, s (:func:`~leakdiag.detect.base.longest_nan_run`).
    healthy_fraction : float, default 0.0
        Largest share of undefined windows in a healthy recording (``nan_fraction_healthy_``;
        0 for detectors fitted before it).

    Returns
    -------
    str or None

    Examples
    --------
    >>> blind_rule(0.0, 15, 13, 2.6), blind_rule(0.0, 15, 7, 1.4), blind_rule(0.0, 400, 60, 12.0)
    ('fraction', None, 'span')
    >>> blind_rule(6.9, 578, 310, 6.9, healthy_fraction=0.64)  # as often as healthy: judged
    """
    if longest_span_s > blind_limit_s(healthy_span_s):
        return "span"
    if n_undefined > undefined_limit(healthy_fraction) * n_windows:
        return "fraction"
    return None


def blind_limit_s(healthy_span_s: float) -> float:
    """Longest undefined span (s) a judged run may end in: ``max(NAN_SPAN_FACTOR *
    healthy_span_s, NAN_SPAN_FLOOR_S)``.

    Parameters
    ----------
    healthy_span_s : float
        Longest undefined span of the healthy recordings (``nan_span_healthy_s_``).

    Returns
    -------
    float

    Examples
    --------
    >>> blind_limit_s(0.0), blind_limit_s(4.0)
    (10.0, 12.0)
    """
    return max(NAN_SPAN_FACTOR * float(healthy_span_s), NAN_SPAN_FLOOR_S)
