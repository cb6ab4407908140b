"""Alarm threshold for a target false-alarm rate per hour, estimated from healthy feature series.

The CUSUM of :mod:`leakdiag.detect.cusum` restarts after every alarm. On the healthy series the
number of alarms ``N(h)`` is counted for a grid of thresholds ``h``; the false-alarm rate is
``N(h) / T`` with ``T`` the healthy time in hours. When ``T`` is too short to observe the target
rate directly, ``log rate(h)`` is extrapolated linearly in ``h`` (the CUSUM's run length grows
exponentially with ``h``; Siegmund's approximation) from the grid points with at least
``MIN_ALARMS_FOR_FIT`` alarms. The method used is recorded, never hidden.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from leakdiag._validation import check_positive
from leakdiag.detect.cusum import cusum, cusum_alarm_count

__all__ = ["AlarmThreshold", "calibrate_threshold", "MIN_ALARMS_FOR_FIT"]

#: Healthy runs needed for the run-maxima (Gumbel) threshold (leakdiag choice).
MIN_RUNS_FOR_MAXIMA = 5
#: Grid points need this many healthy alarms to enter the log-linear fit (leakdiag choice).
MIN_ALARMS_FOR_FIT = 3
#: Threshold grid in healthy standard deviations (leakdiag choice; CUSUM levels beyond 200 std
#: are never needed for features standardised on healthy data).
THRESHOLD_GRID = np.concatenate([np.arange(0.25, 10.0, 0.25), np.arange(10.0, 200.0, 1.0)])


@dataclass(frozen=True)
class AlarmThreshold:
    """Result of :func:`calibrate_threshold`.

    Attributes
    ----------
    threshold : float
        CUSUM alarm level h (healthy std units).
    target_per_hour : float
        Requested false-alarm rate (alarms per hour of healthy operation).
    fitted_per_hour : float
        Rate on the healthy series it was fitted on, at ``threshold`` (often 0: measure the
        achieved rate on held-out healthy runs).
    healthy_hours : float
        Healthy time used.
    gumbel_loc, gumbel_scale : float
        Run-maxima model ``P(max over T hours <= h) = exp(-T exp(-(h - loc) / scale))``
        (NaN when not fitted).
    method : str
        ``"run-maxima"`` (Gumbel fit to the per-run CUSUM maxima), ``"empirical"`` (target
        observed directly), ``"extrapolated"`` (log-linear tail) or
        ``"extrapolated-capped"`` (the extrapolation passed the top of the grid, 200 std, and
        was capped there: too little healthy data for the target).
    log_rate_intercept, log_rate_slope : float
        ``log(rate per hour) = a + b h`` fitted on the tail (NaN when not fitted).
    grid, rate_per_hour : numpy.ndarray
        Threshold grid and measured rate at each grid point.
    """

    threshold: float
    target_per_hour: float
    fitted_per_hour: float
    healthy_hours: float
    method: str
    log_rate_intercept: float
    log_rate_slope: float
    grid: np.ndarray
    rate_per_hour: np.ndarray
    gumbel_loc: float = float("nan")
    gumbel_scale: float = float("nan")

    def rate_at(self, h: float) -> float:
        """Estimated false-alarm rate per hour at level ``h``.

        Parameters
        ----------
        h : float
            CUSUM level.

        Returns
        -------
        float
            Measured rate where it was observed with at least ``MIN_ALARMS_FOR_FIT`` alarms,
            else the log-linear extrapolation (or the one-alarm bound ``1 / healthy_hours``).
        """
        if self.method == "run-maxima":
            return float(np.exp(-(h - self.gumbel_loc) / self.gumbel_scale))
        counts = self.rate_per_hour * self.healthy_hours
        ok = counts >= MIN_ALARMS_FOR_FIT
        if ok.any() and h <= self.grid[ok].max():
            return float(np.interp(h, self.grid, self.rate_per_hour))
        if np.isfinite(self.log_rate_slope):
            return float(np.exp(self.log_rate_intercept + self.log_rate_slope * h))
        return 1.0 / self.healthy_hours


def calibrate_threshold(z_series, durations_s, target_per_hour: float, drift: float = 0.5,
                        direction: str = "both") -> AlarmThreshold:
    """CUSUM threshold giving ``target_per_hour`` false alarms per hour on healthy data.

    Parameters
    ----------
    z_series : list of array_like
        Standardised healthy feature series, one per healthy run.
    durations_s : list of float
        Duration covered by each series in seconds.
    target_per_hour : float
        Target false alarms per hour of healthy operation (> 0).
    drift : float, default 0.5
        CUSUM allowance k.
    direction : {"both", "up", "down"}, default "both"
        CUSUM direction.

    Returns
    -------
    AlarmThreshold

    Raises
    ------
    ValueError
        If there is no healthy data, or too few healthy alarms on the grid to fit the tail.

    Notes
    -----
    ``rate(h) = N(h) / T``. The smallest grid ``h`` with ``rate(h) <= target`` is used if the
    healthy time holds at least ``MIN_ALARMS_FOR_FIT / target`` hours. Otherwise, with at least
    ``MIN_RUNS_FOR_MAXIMA`` healthy runs, the per-run CUSUM maxima ``M_i`` over ``T_i`` hours
    are fitted by maximum likelihood to ``P(M <= h) = exp(-T exp(-(h - loc) / scale))``
    (Gumbel; run-to-run differences of the operating point enter through the maxima) and
    ``h = loc - scale log(target)``. With fewer runs, ``h = (log(target) - a) / b`` from the
    least-squares fit of ``log rate = a + b h``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> thr = calibrate_threshold([rng.standard_normal(20000)], [3600.0], 1.0)
    >>> thr.method, thr.threshold > 3
    ('extrapolated', True)
    """
    target = check_positive(target_per_hour, "target_per_hour")
    zs = [np.asarray(z, dtype=np.float64) for z in z_series]
    hours = float(np.sum(durations_s)) / 3600.0
    if not zs or hours <= 0:
        raise ValueError("calibrate_threshold needs at least one healthy series of positive duration")
    grid = THRESHOLD_GRID
    counts = np.array([sum(cusum_alarm_count(z, h, drift, direction) for z in zs) for h in grid],
                      dtype=np.float64)
    rate = counts / hours
    ok = counts >= MIN_ALARMS_FOR_FIT
    a = b = float("nan")
    if ok.sum() >= 2:
        b, a = np.polyfit(grid[ok], np.log(rate[ok]), 1)
    loc = scale = float("nan")
    if target * hours >= MIN_ALARMS_FOR_FIT and (rate <= target).any():
        h = float(grid[np.argmax(rate <= target)])
        method = "empirical"
    elif len(zs) >= MIN_RUNS_FOR_MAXIMA:
        maxima = [float(np.max(np.maximum(*cusum(z, drift, direction)))) if len(z) else 0.0
                  for z in zs]
        loc, scale = _fit_run_maxima(np.array(maxima), np.asarray(durations_s) / 3600.0)
        h = float(loc - scale * np.log(target))
        method = "run-maxima"
    elif np.isfinite(b) and b < 0:
        h = float((np.log(target) - a) / b)
        h = max(h, float(grid[ok].max()))
        method = "extrapolated"
        if h > grid[-1]:
            # a nearly flat tail (few alarm levels) extrapolates absurdly far: cap and say so
            h, method = float(grid[-1]), "extrapolated-capped"
    else:
        raise ValueError(
            f"cannot set a threshold for target_per_hour={target}: only {hours:.3g} h of healthy "
            f"data and {int(ok.sum())} threshold levels with >= {MIN_ALARMS_FOR_FIT} alarms; "
            f"give more or longer healthy recordings"
        )
    fitted = sum(cusum_alarm_count(z, h, drift, direction) for z in zs) / hours
    return AlarmThreshold(threshold=h, target_per_hour=target, fitted_per_hour=float(fitted),
                          healthy_hours=hours, method=method, log_rate_intercept=float(a),
                          log_rate_slope=float(b), grid=grid, rate_per_hour=rate,
                          gumbel_loc=float(loc), gumbel_scale=float(scale))


def _fit_run_maxima(maxima: np.ndarray, hours: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood Gumbel fit with exceedance rate ``exp(-(h - loc) / scale)`` per hour."""
    from scipy.optimize import minimize

    def nll(theta):
        loc, log_scale = theta
        sc = np.exp(log_scale)
        e = (maxima - loc) / sc
        return -float(np.sum(np.log(hours) - log_scale - e - hours * np.exp(-e)))

    sd = float(np.std(maxima)) or 1.0
    sc0 = sd * np.sqrt(6.0) / np.pi
    loc0 = float(np.mean(maxima)) - 0.5772 * sc0 - sc0 * float(np.mean(np.log(hours)))
    res = minimize(nll, [loc0, np.log(sc0)], method="Nelder-Mead",
                   options={"xatol": 1e-6, "fatol": 1e-9, "maxiter": 4000})
    return float(res.x[0]), float(np.exp(res.x[1]))
