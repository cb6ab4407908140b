"""Intervals for measured rates: every reported false-alarm or detection rate gets one.

:func:`clopper_pearson` is the exact (conservative) binomial interval of Clopper and Pearson,
computed from the beta quantiles of :mod:`scipy.stats`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["clopper_pearson"]


def clopper_pearson(k, n, level: float = 0.95) -> tuple[float, float]:
    """Exact two-sided Clopper-Pearson interval of a binomial proportion ``k / n``.

    Parameters
    ----------
    k : int
        Events (alarms, detections), ``0 <= k <= n``.
    n : int
        Trials (runs), ``n >= 1``; ``n = 0`` gives ``(nan, nan)`` (no data, no interval).
    level : float, default 0.95
        Coverage of the interval, in (0, 1).

    Returns
    -------
    low, high : float
        ``low = B(alpha/2; k, n - k + 1)`` (0 when ``k = 0``) and
        ``high = B(1 - alpha/2; k + 1, n - k)`` (1 when ``k = n``), ``B`` the beta quantile,
        ``alpha = 1 - level``.

    Raises
    ------
    ValueError
        If ``k`` or ``n`` is negative, ``k > n``, or ``level`` is not in (0, 1).

    Notes
    -----
    The interval inverts two one-sided binomial tests, so its coverage is at least ``level``
    for every true proportion (it is conservative). Same values as
    ``scipy.stats.binomtest(k, n).proportion_ci(level, method="exact")``.

    References
    ----------
    C. J. Clopper, E. S. Pearson, "The use of confidence or fiducial limits illustrated in the
    case of the binomial", Biometrika 26 (1934) 404-413.

    Examples
    --------
    >>> lo, hi = clopper_pearson(0, 10)
    >>> round(lo, 6), round(hi, 4)
    (0.0, 0.3085)
    >>> [round(v, 4) for v in clopper_pearson(5, 10)]
    [0.1871, 0.8129]
    """
    from scipy.stats import beta

    k_i, n_i = int(k), int(n)
    if k_i != k or n_i != n:
        raise ValueError(f"k={k!r} and n={n!r} must be integers")
    if n_i < 0 or k_i < 0 or k_i > n_i:
        raise ValueError(f"need 0 <= k <= n, got k={k_i}, n={n_i}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level={level!r} must be in (0, 1)")
    if n_i == 0:
        return float("nan"), float("nan")
    a = 1.0 - level
    low = 0.0 if k_i == 0 else float(beta.ppf(a / 2, k_i, n_i - k_i + 1))
    high = 1.0 if k_i == n_i else float(beta.ppf(1 - a / 2, k_i + 1, n_i - k_i))
    return low, high


def _clopper_pearson_arrays(k, n, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised :func:`clopper_pearson` (NaN where ``n == 0``)."""
    k = np.asarray(k, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64)
    out = [clopper_pearson(int(a), int(b), level) for a, b in zip(k.ravel(), n.ravel())]
    lo = np.array([o[0] for o in out]).reshape(k.shape)
    hi = np.array([o[1] for o in out]).reshape(k.shape)
    return lo, hi
