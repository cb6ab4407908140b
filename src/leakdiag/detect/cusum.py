"""Page's CUSUM on a standardised feature series: the online search shared by all detectors.

The kernel works on ``z``, the feature standardised with the healthy mean and standard deviation
learned in :meth:`leakdiag.detect.base.Detector.fit`. NaN values (degenerate windows) leave the
statistics unchanged (documented in ``docs/detect.md``).
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag._validation import as_1d_float

__all__ = ["cusum", "cusum_alarm_count", "DIRECTIONS"]

#: Direction name -> kernel code (+1 rise only, -1 fall only, 0 both).
DIRECTIONS: dict[str, int] = {"up": 1, "down": -1, "both": 0}


@numba.njit(cache=True)
def _cusum(z, drift, direction, threshold):  # pragma: no cover - compiled
    n = z.shape[0]
    s_up = np.empty(n)
    s_dn = np.empty(n)
    sp = 0.0
    sn = 0.0
    count = 0
    for i in range(n):
        v = z[i]
        if not np.isnan(v):
            if direction >= 0:
                sp = max(0.0, sp + v - drift)
            if direction <= 0:
                sn = max(0.0, sn - v - drift)
        s_up[i] = sp
        s_dn[i] = sn
        if sp >= threshold or sn >= threshold:
            count += 1
            sp = 0.0
            sn = 0.0
    return s_up, s_dn, count


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
    s_up, s_dn, _ = _cusum(z, drift, code, np.inf)
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
    return int(_cusum(z, drift, code, float(threshold))[2])
