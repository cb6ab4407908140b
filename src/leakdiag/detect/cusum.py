"""Page's CUSUM on a standardised feature series: the online search shared by all detectors.

The kernel works on ``z``, the feature standardised with the healthy mean and standard deviation
learned in :meth:`leakdiag.detect.base.Detector.fit`. NaN values (degenerate windows) leave the
statistics unchanged (documented in ``docs/detect.md``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from leakdiag._validation import as_1d_float

__all__ = ["cusum", "cusum_alarm_count", "segmented_cusum", "DIRECTIONS"]

#: Direction name -> kernel code (+1 rise only, -1 fall only, 0 both).
DIRECTIONS: dict[str, int] = {"up": 1, "down": -1, "both": 0}


@numba.njit(cache=True)
def _cusum(z, segment, drift, direction, keep_above, restart_at, sp, sn,
           prev):  # pragma: no cover - compiled
    # from the statistics (sp, sn) after a window of segment ``prev`` (prev == segment[0]: no
    # window before); segment boundaries restart both statistics unless one is above
    # keep_above; a statistic reaching restart_at counts an alarm and restarts both
    # (cusum_alarm_count)
    n = z.shape[0]
    s_up = np.empty(n)
    s_dn = np.empty(n)
    restarted = np.zeros(n, dtype=np.bool_)
    count = 0
    for i in range(n):
        if segment[i] != prev and not (sp > keep_above or sn > keep_above):
            restarted[i] = sp > 0.0 or sn > 0.0  # an excursion dropped here
            sp = 0.0
            sn = 0.0
        prev = segment[i]
        v = z[i]
        if not np.isnan(v):
            if direction >= 0:
                sp = max(0.0, sp + v - drift)
            if direction <= 0:
                sn = max(0.0, sn - v - drift)
        s_up[i] = sp
        s_dn[i] = sn
        if sp >= restart_at or sn >= restart_at:
            count += 1
            sp = 0.0
            sn = 0.0
    return s_up, s_dn, count, restarted


@numba.njit(cache=True)
def _segments(time, t0, segment_s):  # pragma: no cover - compiled
    # floor((time - t0) / segment_s), at least 0 (threshold.segment_index)
    out = np.empty(time.shape[0], dtype=np.int64)
    for i in range(time.shape[0]):
        out[i] = max(0, int(math.floor((time[i] - t0) / segment_s)))
    return out


@numba.njit(cache=True)
def _continued(z, time, t0, segment_s, drift, direction, keep_above,
               state):  # pragma: no cover - compiled
    # the segmented CUSUM of a block that follows the windows summed up by ``state``
    # (S+, S-, segment of the last window; a segment < 0: no window yet), which it updates;
    # segment_s <= 0: no restarts
    n = z.shape[0]
    if segment_s > 0.0:
        seg = _segments(time, t0, segment_s)
    else:
        seg = np.zeros(n, dtype=np.int64)
    if n == 0:
        return np.empty(0), np.empty(0)
    prev = seg[0] if state[2] < 0.0 else np.int64(state[2])
    s_up, s_dn, _, _ = _cusum(z, seg, drift, direction, keep_above, np.inf, state[0], state[1],
                              prev)
    state[0] = s_up[n - 1]
    state[1] = s_dn[n - 1]
    state[2] = seg[n - 1]
    return s_up, s_dn


def _check(z, drift, direction):
    z = as_1d_float(z, "z")
    drift = float(drift)
    if not np.isfinite(drift) or drift < 0:
        raise ValueError(f"drift={drift!r} must be a finite number >= 0 (healthy std units)")
    if direction not in DIRECTIONS:
        raise ValueError(f"direction={direction!r} must be one of {sorted(DIRECTIONS)}")
    return z, drift, DIRECTIONS[direction]


def cusum(z, drift: float = 0.5, direction: str = "both") -> tuple[np.ndarray, np.ndarray]:
    """Two one-sided CUSUM statistics of a standardised series, without restart.

    Parameters
    ----------
    z : array_like
        Standardised feature values (healthy mean 0, std 1), shape ``(m,)``; NaN is skipped.
    drift : float, default 0.5
        Allowance k in healthy standard deviations (optimal for a shift of ``2 k``).
    direction : {"both", "up", "down"}, default "both"
        Which changes to accumulate; the unused statistic stays 0.

    Returns
    -------
    s_up, s_down : numpy.ndarray
        ``S+_i = max(0, S+_{i-1} + z_i - k)`` and ``S-_i = max(0, S-_{i-1} - z_i - k)``, shape ``(m,)``.

    Raises
    ------
    ValueError
        If ``drift`` is negative or ``direction`` unknown.

    Notes
    -----
    Page's CUSUM (Page 1954). The thesis does not estimate the onset automatically (Sec. 7.2
    names it as future work); this is leakdiag's online alarm.

    .. math:: S^+_i = \\max(0, S^+_{i-1} + z_i - k),\\quad S^-_i = \\max(0, S^-_{i-1} - z_i - k)

    References
    ----------
    E. S. Page, "Continuous inspection schemes", Biometrika 41 (1954) 100-115.

    Examples
    --------
    >>> up, down = cusum([0.0, 2.0, 2.0, -1.0], drift=0.5)
    >>> up.tolist(), down.tolist()
    ([0.0, 1.5, 3.0, 1.5], [0.0, 0.0, 0.0, 0.5])
    """
    z, drift, code = _check(z, drift, direction)
    s_up, s_dn, _, _ = _cusum(z, np.zeros(len(z), np.int64), drift, code, np.inf, np.inf,
                              0.0, 0.0, 0)
    return s_up, s_dn


def cusum_alarm_count(z, threshold: float, drift: float = 0.5, direction: str = "both") -> int:
    """Number of alarms of a CUSUM that restarts from 0 after every alarm.

    Parameters
    ----------
    z : array_like
        Standardised feature values, shape ``(m,)``.
    threshold : float
        Alarm level h (healthy std units); an alarm is raised when a statistic reaches ``h``.
    drift : float, default 0.5
        Allowance k.
    direction : {"both", "up", "down"}, default "both"
        Which changes to accumulate.

    Returns
    -------
    int
        Alarms raised.

    Examples
    --------
    >>> cusum_alarm_count([3.0, 3.0, 3.0, 3.0], threshold=5.0, drift=0.5)
    2
    """
    z, drift, code = _check(z, drift, direction)
    return int(_cusum(z, np.zeros(len(z), np.int64), drift, code, np.inf, float(threshold),
                      0.0, 0.0, 0)[2])


def segmented_cusum(z, segment, drift: float = 0.5, direction: str = "both",
                    keep_above: float = np.inf, return_restarts: bool = False) -> tuple:
    """Page's CUSUM restarted at every segment boundary, unless it is above ``keep_above``.

    Parameters
    ----------
    z : array_like
        Standardised feature values, shape ``(m,)``; NaN is skipped.
    segment : array_like of int
        Segment index of each window, non-decreasing: the statistics restart from 0 at the
        first window of each new segment (before its value is added).
    drift : float, default 0.5
        Allowance k.
    direction : {"both", "up", "down"}, default "both"
        Which changes to accumulate.
    keep_above : float, default inf
        An excursion above this level (an alarm: the detector's threshold) is carried into the
        next segment instead; ``inf``: every segment starts fresh (the healthy maxima of
        :func:`~leakdiag.detect.threshold.segment_maxima`).
    return_restarts : bool, default False
        Also return where an excursion in progress was dropped.

    Returns
    -------
    s_up, s_down : numpy.ndarray
        Shape ``(m,)``.
    restarted : numpy.ndarray of bool
        With ``return_restarts``: True at the first window of a segment where a statistic
        above 0 was restarted (an excursion's start lies at or after it: the value recorded
        there already holds that window's ``z``, so no 0 marks the restart).

    Raises
    ------
    ValueError
        If ``segment`` has another shape than ``z``, ``drift`` is negative or ``direction``
        unknown.

    Notes
    -----
    Why (docs/detect.md section 2, "A recording longer than one healthy segment"): the
    threshold's guarantee rests on healthy maxima of fresh segments. A judged segment whose
    statistic restarts at its boundary is, up to its first alarm, a fresh segment too, so
    P(an alarm in a recording of ``m`` segments) <= ``m k / (n + 1)`` for any length; carried
    over, later segments alarmed at 1.5-4.8 times the bound (a statistics audit). An alarm in
    progress is carried, so a restart never clears an alarm.

    Examples
    --------
    >>> up, _ = segmented_cusum([2.0, 2.0, 2.0, 2.0], [0, 0, 1, 1], direction="up")
    >>> up.tolist()                       # fresh at the second segment
    [1.5, 3.0, 1.5, 3.0]
    >>> segmented_cusum([2.0, 2.0, 2.0, 2.0], [0, 0, 1, 1], direction="up",
    ...                 keep_above=2.0)[0].tolist()   # 3.0 > 2.0 at the boundary: carried
    [1.5, 3.0, 4.5, 6.0]
    """
    z, drift, code = _check(z, drift, direction)
    seg = np.ascontiguousarray(np.asarray(segment, dtype=np.int64))
    if seg.shape != z.shape:
        raise ValueError(f"segment has shape {seg.shape}, z {z.shape}")
    s_up, s_dn, _, restarted = _cusum(z, seg, drift, code, float(keep_above), np.inf, 0.0,
                                      0.0, seg[0] if len(seg) else 0)
    return (s_up, s_dn, restarted) if return_restarts else (s_up, s_dn)
