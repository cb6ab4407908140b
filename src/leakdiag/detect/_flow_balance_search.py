"""One-sided windowed GLR on the flow-balance leak estimates, and its null calibration.

Per window ``w`` the residual volume is ``e_w = k phi_w + eps_w`` with ``eps_w ~ N(0, s_w^2)``
(error model fitted on healthy data). Over a span ``j..i`` of windows the weighted least-squares
estimate of the leak coefficient and its standardised value are

.. math::

    \\hat k_{j:i} = \\frac{\\sum a_w}{\\sum b_w}, \\qquad
    Z_{j:i} = \\frac{\\sum a_w}{\\sqrt{\\sum b_w}}, \\qquad
    a_w = \\frac{\\phi_w e_w}{s_w^2},\\ b_w = \\frac{\\phi_w^2}{s_w^2},

and the one-sided GLR statistic (Lai 1995, window-limited) is
:math:`G_i = \\max_{i-M < j \\le i} \\max(0, Z_{j:i})`, on the z scale (:math:`G^2/2` is the
log-likelihood ratio). Under the healthy model every :math:`Z_{j:i}` is standard normal whatever
the machine, which makes :math:`G` (near-)pivotal: its null distribution depends only on the
pattern ``c_w = phi_w / s_w`` and on ``M``, not on the unit's flow gain, supply or leak law.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

__all__ = ["GLRThreshold", "TargetBeyondNullError", "glr_scan", "glr_profile",
           "glr_alarm_count", "calibrate_glr", "change_point", "step_information"]


class TargetBeyondNullError(ValueError):
    """The false-alarm target is at least the null's alarm-episode rate at its lowest level.

    Such a level would lie below the simulated grid; :func:`calibrate_glr` used to extrapolate
    the tail's log-linear fit down to it, which gave levels that were not monotone in the
    target (and negative ones). ``largest_per_hour`` is the null's rate at the lowest level
    ``lowest_level`` (z scale): every accepted target is below it.
    """

    def __init__(self, message: str, largest_per_hour: float, lowest_level: float):
        super().__init__(message)
        self.largest_per_hour = float(largest_per_hour)
        self.lowest_level = float(lowest_level)


@numba.njit(cache=True)
def _glr(a, b, max_span, g, arg):
    n = a.shape[0]
    for i in range(n):
        sa = 0.0
        sb = 0.0
        best = 0.0
        bj = i
        for j in range(i, max(-1, i - max_span), -1):
            sa += a[j]
            sb += b[j]
            if sb > 0.0 and sa > 0.0:
                z = sa / np.sqrt(sb)
                if z > best:
                    best = z
                    bj = j
        g[i] = best
        arg[i] = bj


def glr_scan(a: np.ndarray, b: np.ndarray, max_span: int) -> tuple[np.ndarray, np.ndarray]:
    """Window-limited one-sided GLR statistic and the start of its best span.

    Parameters
    ----------
    a, b : numpy.ndarray
        Per-window ``phi e / s^2`` and ``phi^2 / s^2``.
    max_span : int
        Longest span M in windows.

    Returns
    -------
    g : numpy.ndarray
        :math:`G_i` (z scale).
    start : numpy.ndarray
        Index of the first window of the maximising span (``i`` when ``G_i = 0``).
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    b = np.ascontiguousarray(b, dtype=np.float64)
    g = np.zeros(len(a))
    arg = np.zeros(len(a), dtype=np.int64)
    _glr(a, b, int(max_span), g, arg)
    return g, arg


@numba.njit(cache=True)
def _spd_inverse(a, p, chol, out, diag):
    """Inverse of the symmetric p x p Gram matrix ``a`` into ``out`` by Cholesky factorisation
    of its equilibrated form ``D^-1/2 a D^-1/2`` (``D = diag a``, unit diagonal); False
    (``out`` unusable) when that matrix has a determinant below 1e-10 or is not positive
    definite, i.e. the nuisance columns are (numerically) collinear: the nuisance is not
    determined yet. Equilibrated, the test does not depend on the columns' units or sizes: an
    earlier version scaled by ``max(diag a)`` only, so that a column much larger than another
    (the VCA's offset drift on a long recording against its offset and gain columns) held the
    determinant below 1e-10 for a stretch that grew with the recording's length (no test at all
    in a 400-s VCA recording). For the p <= 3 of :func:`glr_profile` this replaces two LAPACK
    calls (``det``, ``inv``) and two array allocations per window: a 60-window replicate took
    32 -> 10 us with one nuisance column, 50 -> 22 us with three."""
    for c in range(p):
        if not a[c, c] > 0.0:
            return False
        diag[c] = np.sqrt(a[c, c])
    det = 1.0
    for c in range(p):  # chol: lower factor L of D^-1/2 a D^-1/2
        for d in range(c + 1):
            v = a[c, d] / (diag[c] * diag[d])
            for e in range(d):
                v -= chol[c, e] * chol[d, e]
            if c == d:
                if not v > 0.0:
                    return False
                det *= v
                chol[c, c] = np.sqrt(v)
            else:
                chol[c, d] = v / chol[d, d]
    if det < 1e-10:
        return False
    for col in range(p):  # column col of the equilibrated inverse: L y = e_col, then L^T x = y
        for c in range(p):
            v = 1.0 if c == col else 0.0
            for e in range(c):
                v -= chol[c, e] * out[e, col]
            out[c, col] = v / chol[c, c]
        for c in range(p - 1, -1, -1):
            v = out[c, col]
            for e in range(c + 1, p):
                v -= chol[e, c] * out[e, col]
            out[c, col] = v / chol[c, c]
    for c in range(p):
        for d in range(p):
            out[c, d] /= diag[c] * diag[d]
    return True


@numba.njit(cache=True)
def _glr_profile(phi, r, w, nu, max_span, min_history, g, arg):
    # one-sided GLR for k with nuisance columns nu (p = 0..3) fitted on all windows <= i
    n = phi.shape[0]
    p = nu.shape[1]
    ann = np.zeros((p, p))
    bn = np.zeros(p)
    akn = np.zeros(p)
    tmp = np.zeros(p)
    ainv = np.zeros((p, p))
    chol = np.zeros((p, p))
    diag = np.zeros(p)
    for i in range(n):
        for c in range(p):
            bn[c] += w[i] * nu[i, c] * r[i]
            for d in range(p):
                ann[c, d] += w[i] * nu[i, c] * nu[i, d]
        g[i] = 0.0
        arg[i] = i
        if i + 1 < min_history:
            continue
        if p > 0:
            if not _spd_inverse(ann, p, chol, ainv, diag):
                continue
            for c in range(p):
                tmp[c] = 0.0
                for d in range(p):
                    tmp[c] += ainv[c, d] * bn[d]
        akk = 0.0
        bk = 0.0
        for c in range(p):
            akn[c] = 0.0
        best = 0.0
        bj = i
        for j in range(i, max(-1, i - max_span), -1):
            akk += w[j] * phi[j] * phi[j]
            bk += w[j] * phi[j] * r[j]
            for c in range(p):
                akn[c] += w[j] * phi[j] * nu[j, c]
            sch = akk
            num = bk
            for c in range(p):
                num -= akn[c] * tmp[c]
                for d in range(p):
                    sch -= akn[c] * ainv[c, d] * akn[d]
            if sch > 1e-12 * akk and num > 0.0:
                z = num / np.sqrt(sch)
                if z > best:
                    best = z
                    bj = j
        g[i] = best
        arg[i] = bj


def glr_profile(phi, r, w, nuisance, max_span: int, min_history: int = 1):
    """One-sided GLR for the leak coefficient with nuisance regressors profiled out.

    For each window ``i`` and span ``j..i`` the weighted least-squares fit of the residuals of
    windows ``0..i`` on ``[phi 1(w >= j), nuisance]`` gives the standardised leak coefficient
    :math:`Z_{j:i} = \\hat k / \\mathrm{se}(\\hat k)` (Schur complement of the nuisance block);
    :math:`G_i = \\max_j \\max(0, Z_{j:i})`.

    Parameters
    ----------
    phi, r, w : numpy.ndarray
        Per window: leak-law term, residual, weight ``1/s^2``.
    nuisance : numpy.ndarray
        Shape ``(n, p)``, ``p`` in 0..3 (e.g. null offset and its linear drift).
    max_span : int
        Longest span in windows.
    min_history : int, default 1
        Windows needed before the first test (nuisance determined).

    Returns
    -------
    g : numpy.ndarray
        :math:`G_i`.
    start : numpy.ndarray
        First window of the maximising span.
    """
    phi = np.ascontiguousarray(phi, dtype=np.float64)
    r = np.ascontiguousarray(r, dtype=np.float64)
    w = np.ascontiguousarray(w, dtype=np.float64)
    nu = np.ascontiguousarray(np.asarray(nuisance, dtype=np.float64).reshape(len(phi), -1))
    g = np.zeros(len(phi))
    arg = np.zeros(len(phi), dtype=np.int64)
    _glr_profile(phi, r, w, nu, int(max_span), int(min_history), g, arg)
    return g, arg


def change_point(phi, r, w, nuisance, last: int) -> tuple[int, np.ndarray]:
    """Maximum-likelihood onset of a step in the leak coefficient, from the whole recording.

    For each candidate ``j <= last`` the weighted least-squares fit of the residuals of *all*
    windows on ``[phi 1(w >= j), nuisance]`` gives :math:`Z_j = \\hat k_j / \\mathrm{se}(\\hat
    k_j)`; the onset is the ``j`` of the largest :math:`Z_j` (for a positive step this
    maximises the likelihood, :math:`Z_j^2` being the weighted residual sum of squares that the
    step removes; Hinkley 1970). Unlike the span of the GLR at its first alarm, which sees only
    the windows up to the alarm and at most ``max_span`` of them, it uses the windows after the
    alarm too and has no span limit. O(n p^2) by suffix sums.

    Parameters
    ----------
    phi, r, w : numpy.ndarray
        Per window: leak-law term, residual, weight ``1/s^2``.
    nuisance : numpy.ndarray
        Shape ``(n, p)``, ``p`` in 0..3, profiled over all windows.
    last : int
        Latest candidate window (e.g. the first alarm's).

    Returns
    -------
    j : int
        The onset window.
    z : numpy.ndarray
        :math:`Z_j` for ``j = 0..last`` (NaN where the step is not determined).

    Examples
    --------
    >>> n = 40
    >>> phi, w = np.ones(n), np.ones(n)
    >>> r = np.where(np.arange(n) >= 25, 1.0, 0.0) + 0.01 * np.sin(np.arange(n))
    >>> change_point(phi, r, w, np.ones((n, 1)), last=30)[0]
    25
    """
    phi = np.asarray(phi, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    n = len(phi)
    nu = np.asarray(nuisance, dtype=np.float64).reshape(n, -1)
    last = int(min(max(last, 0), n - 1))
    wp = w * phi
    akk = np.cumsum((wp * phi)[::-1])[::-1][:last + 1]  # sums over windows >= j
    bk = np.cumsum((wp * r)[::-1])[::-1][:last + 1]
    if nu.shape[1]:
        akn = np.cumsum((wp[:, None] * nu)[::-1], axis=0)[::-1][:last + 1]
        wn = nu * w[:, None]
        ann, bn = wn.T @ nu, wn.T @ r
        d = np.sqrt(np.diag(ann))
        if not np.all(d > 0):
            return last, np.full(last + 1, np.nan)
        # the nuisance block equilibrated (its columns' sizes differ by orders of magnitude)
        inv = np.linalg.pinv(ann / np.outer(d, d)) / np.outer(d, d)
        akk = akk - np.einsum("jc,cd,jd->j", akn, inv, akn)
        bk = bk - akn @ (inv @ bn)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(akk > 1e-12 * np.max(akk, initial=0.0), bk / np.sqrt(akk), np.nan)
    if not np.any(np.isfinite(z)):
        return last, z
    return int(np.nanargmax(z)), z


def step_information(phi, w, nuisance, first: int) -> float:
    """Fisher information on the leak coefficient of a step from window ``first`` to the last.

    The weighted least-squares fit of the residuals of *all* windows on
    ``[phi 1(w >= first), nuisance]`` estimates the step's coefficient with variance
    :math:`1 / I`, :math:`I = \\sum_{w \\ge j} \\phi_w^2 / s_w^2 - a^T A^{-1} a` (the Schur
    complement of the nuisance block ``A``, ``a`` its cross terms with the step). A step of
    coefficient ``k`` moves the :math:`Z` of that span by exactly :math:`k \\sqrt{I}` (the
    residual is linear in ``k``), so :math:`k = (h + z_\\beta) / \\sqrt{I}` reaches level ``h``
    with probability :math:`1 - \\beta` under the error model (the GLR's maximum over spans can
    only be larger). The same algebra as :func:`change_point` for one candidate.

    Parameters
    ----------
    phi, w : numpy.ndarray
        Per window: leak-law term and weight ``1/s^2``.
    nuisance : numpy.ndarray
        Shape ``(n, p)``, ``p`` in 0..3, profiled over all windows.
    first : int
        First window of the step.

    Returns
    -------
    float
        ``I`` (0 when the step is not determined: it lies in the nuisance's span).

    Examples
    --------
    >>> n = 10
    >>> float(step_information(np.ones(n), np.ones(n), np.zeros((n, 0)), 6))  # 4 windows
    4.0
    >>> float(step_information(np.ones(n), np.ones(n), np.ones((n, 1)), 6))  # 4 - 4^2/10
    2.4
    """
    phi = np.asarray(phi, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    n = len(phi)
    nu = np.asarray(nuisance, dtype=np.float64).reshape(n, -1)
    sl = slice(int(first), n)
    wp = w[sl] * phi[sl]
    info = float(wp @ phi[sl])
    if nu.shape[1]:
        akn = wp @ nu[sl]
        ann = (nu * w[:, None]).T @ nu
        d = np.sqrt(np.diag(ann))
        if not np.all(d > 0):
            return 0.0
        # the nuisance block equilibrated, as in change_point
        inv = np.linalg.pinv(ann / np.outer(d, d)) / np.outer(d, d)
        info -= float(akn @ inv @ akn)
    return max(info, 0.0) if info > 1e-12 * float(wp @ phi[sl]) else 0.0


def glr_alarm_count(g: np.ndarray, h: float) -> int:
    """Alarm episodes at level ``h``: upcrossings of ``g`` (the first window counts if above).

    Parameters
    ----------
    g : numpy.ndarray
        GLR statistic per window (:func:`glr_scan`).
    h : float
        Alarm level (z scale).

    Returns
    -------
    int
    """
    above = np.asarray(g) >= h
    if above.size == 0:
        return 0
    return int(above[0]) + int(np.count_nonzero(above[1:] & ~above[:-1]))


@dataclass(frozen=True)
class GLRThreshold:
    """Alarm level of the flow-balance GLR for a false-alarm rate per hour.

    Attributes
    ----------
    threshold : float
        Alarm level (z scale).
    target_per_hour : float
        Requested false alarms per hour of healthy operation.
    method : str
        ``"healthy-residual-bootstrap"``: alarm episodes (upcrossings of the level) counted
        on ``simulated_hours`` of runs with the healthy recordings' ``(phi, s, nuisance)``
        patterns and standardised residuals resampled from the healthy ones (random sign).
    simulated_hours : float
        Length of the Monte-Carlo null.
    healthy_hours : float
        Healthy time the detector was fitted on.
    healthy_alarms : int
        Alarms at ``threshold`` on the healthy recordings themselves (a check, expected ~0).
    grid, rate_per_hour : numpy.ndarray
        Levels and their Monte-Carlo false-alarm rates (before ``scale``).
    scale : float
        Factor (>= 1) applied to the Monte-Carlo levels: the median GLR maximum of the healthy
        recordings over the median of the simulated ones, when the real healthy runs scatter
        more than the null model (serial dependence, tails the bootstrap misses).
    """

    threshold: float
    target_per_hour: float
    method: str
    simulated_hours: float
    healthy_hours: float
    healthy_alarms: int
    grid: np.ndarray
    rate_per_hour: np.ndarray
    scale: float = 1.0

    def rate_at(self, h: float) -> float:
        """False-alarm rate per hour at level ``h`` (log-linear interpolation of the null).

        Parameters
        ----------
        h : float
            Level (z scale).

        Returns
        -------
        float
            Alarms per hour; beyond the last level with alarms, the log-linear tail of the
            last two levels with alarms.
        """
        ok = self.rate_per_hour > 0
        if not ok.any():
            return 1.0 / self.simulated_hours
        return self._log_linear(h, np.flatnonzero(ok), 2)

    def _log_linear(self, h: float, levels: np.ndarray, fit: int) -> float:
        """The null's log rate interpolated over ``levels`` (indices into ``grid``) at
        ``h / scale``; beyond the last, the least-squares slope of the last ``fit`` of them
        (held flat, not rising: episode counts need not fall with the level, since one episode
        above a level can hold several above a higher one; a rising Monte-Carlo tail was
        extrapolated upwards and overflowed for large statistics), anchored at the last."""
        h = h / self.scale
        g, r = self.grid[levels], np.log(self.rate_per_hour[levels])
        if h <= g[-1]:
            return float(np.exp(np.interp(h, g, r)))
        if len(g) < 2:
            return float(np.exp(r[-1]))
        slope = min(0.0, float(np.polyfit(g[-fit:], r[-fit:], 1)[0]))
        return float(np.exp(r[-1] + slope * (h - g[-1])))

    def tail_rate(self, h: float) -> float:
        """False-alarm rate per hour at level ``h`` from the null's fitted exponential tail.

        For a long run's level (``FlowBalanceDetector.run_level``), which needs rates below the
        null's last alarms: the null is interpolated (log-linear) over the levels with at
        least :data:`TAIL_MIN_EPISODES` alarm episodes, and beyond the last of them it falls
        with the least-squares slope of the log rate over the last five such levels, anchored
        at the last. For a Gaussian-like statistic the log rate is concave in the level, so the
        fitted line lies above it beyond the fit: the rate is over-stated and the level too
        high (conservative).

        Parameters
        ----------
        h : float
            Level (z scale).

        Returns
        -------
        float
            Alarms per hour; ``inf`` when fewer than two levels have enough episodes, the last
            rate held flat when the fitted slope does not fall.
        """
        counts = self.rate_per_hour * self.simulated_hours
        ok = np.flatnonzero(counts >= TAIL_MIN_EPISODES - 1e-9)
        if len(ok) < 2:
            return float("inf")
        return self._log_linear(h, ok, 5)


#: Alarm episodes a null level needs to count in :meth:`GLRThreshold.tail_rate`'s fit (levels
#: with 1 or 2 episodes are noise: the null's tail held flat on two of them, 2026-11-28).
TAIL_MIN_EPISODES = 3


@numba.njit(cache=True)
def _count_upcrossings(g, grid, counts):
    """Add to ``counts[k]`` the alarm episodes of ``g`` at level ``grid[k]`` (ascending): one
    if ``g[0] >= grid[k]``, plus one per ``i`` with ``g[i - 1] < grid[k] <= g[i]``; each sample
    adds one to the levels in ``(g[i - 1], g[i]]``, found by bisection (integer counts, the same
    as comparing every sample with every level, which took ~20 us a replicate in NumPy).

    Examples
    --------
    >>> counts = np.zeros(3)
    >>> _count_upcrossings(np.array([2.5, 0.0, 1.5, 3.0]), np.array([1.0, 2.0, 3.0]), counts)
    >>> counts.tolist()   # level 1: at 0 and 2; level 2: at 0 and 3; level 3: at 3
    [2.0, 2.0, 1.0]
    """
    prev = -np.inf
    for i in range(g.shape[0]):
        if g[i] > prev:
            lo = np.searchsorted(grid, prev, side="right")
            hi = np.searchsorted(grid, g[i], side="right")
            for k in range(lo, hi):
                counts[k] += 1.0
        prev = g[i]


def calibrate_glr(runs: list[tuple], window_s: float, max_span: int, target_per_hour: float,
                  min_history: int = 1, seed: int = 0, min_alarms: int = 40,
                  max_hours: float = 1000.0,
                  pool: np.ndarray | None = None):
    """Monte-Carlo null of the GLR: level with ``target_per_hour`` alarm episodes per hour.

    Each replicate takes one healthy recording's pattern ``(phi, s, nuisance)``, draws
    residuals ``s * z`` and runs :func:`glr_profile` on it, as :meth:`predict` does; ``z`` is
    standard normal, or resampled with a random sign from ``pool`` (the healthy standardised
    residuals: their heavier-than-normal tails then enter the null).

    Parameters
    ----------
    runs : list of tuple
        ``(phi, s, nuisance)`` per healthy recording.
    window_s : float
        Window length in s.
    max_span : int
        Longest span in windows.
    target_per_hour : float
        Target rate.
    min_history : int, default 1
        As in :func:`glr_profile`.
    seed : int, default 0
        Seed of the null simulation (fixed: the fit is reproducible).
    min_alarms : int, default 40
        Null hours are chosen for about ``3 min_alarms`` alarms at the target rate.
    max_hours : float, default 1000
        Longest null simulated.
    pool : numpy.ndarray, optional
        Healthy standardised residuals to resample (bootstrap) instead of N(0, 1).

    Returns
    -------
    threshold : float
    grid, rate : numpy.ndarray
        Levels and null rates per hour.
    hours : float
        Simulated null hours.
    maxima : numpy.ndarray
        Per-replicate GLR maxima (one replicate = one healthy recording's length).

    Raises
    ------
    TargetBeyondNullError
        If ``target_per_hour`` is at least the null's rate at the lowest level of the grid
        (z = 0.5): the level would be an extrapolation below the simulated levels.
    ValueError
        If no healthy window has a leak-law term, or the null has too few alarms.
    """
    rng = np.random.default_rng(seed)
    runs = [r for r in runs if len(r[0])]
    if not runs or not any(np.any(r[0] != 0) for r in runs):
        raise ValueError("calibrate_glr: the healthy recordings have no window with a leak-law "
                         "pressure term (phi = 0 everywhere); nothing can be tested")
    hours_needed = min(max_hours, max(20.0, 3.0 * min_alarms / target_per_hour))
    grid = np.arange(0.5, 10.01, 0.05)  # z scale; EHA nulls peak near 1.5
    counts = np.zeros(len(grid))
    maxima = []
    hours = 0.0
    while hours < hours_needed:
        phi, s, nu = runs[int(rng.integers(len(runs)))]
        if pool is None:
            e = s * rng.standard_normal(len(phi))
        else:
            e = s * pool[rng.integers(len(pool), size=len(phi))] * rng.choice((-1.0, 1.0),
                                                                               size=len(phi))
        g, _ = glr_profile(phi, e, 1.0 / s**2, nu, max_span, min_history)
        maxima.append(float(g.max()) if len(g) else 0.0)
        _count_upcrossings(g, grid, counts)
        hours += len(phi) * window_s / 3600.0
    rate = counts / hours
    if not rate[0] > target_per_hour:
        raise TargetBeyondNullError(
            f"calibrate_glr: target_per_hour={target_per_hour:g} is at least the null's "
            f"alarm-episode rate at its lowest level (z = {grid[0]:g}: {rate[0]:.4g} per "
            "hour); the level would be extrapolated below the simulated ones", rate[0], grid[0])
    ok = np.flatnonzero(counts >= 3)
    below = np.flatnonzero(rate <= target_per_hour)
    if len(below) and counts[below[0]] >= 3 and below[0] > 0:
        i = below[0]
        r0, r1 = np.log(rate[i - 1]), np.log(rate[i])
        h = grid[i - 1] + (np.log(target_per_hour) - r0) / (r1 - r0) * (grid[i] - grid[i - 1])
    elif len(ok) >= 2:
        sl, ic = np.polyfit(grid[ok[-5:]], np.log(rate[ok[-5:]]), 1)
        h = (np.log(target_per_hour) - ic) / sl
    else:
        raise ValueError("calibrate_glr: too few null alarms to set a threshold")
    return float(h), grid, rate, float(hours), np.asarray(maxima)
