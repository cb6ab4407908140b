"""Leak size from a detected change: a calibration of feature shift against leak flow.

A :class:`LeakCalibration` maps the shift of the standardised feature (mean after the onset minus
mean before, in healthy standard deviations) to a leak flow in L/min by least squares of the flow
on the shift (inverse regression), with a prediction interval. It is valid only for the conditions
it was fitted on (rig, load, input, feature settings); those are stored in ``validity`` and the
shift range in ``shift_range``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["LeakCalibration", "fit_leak_calibration"]

#: Minimum calibration runs (two parameters plus a residual degree of freedom).
MIN_CALIBRATION_RUNS = 3
#: Level of the test that the calibration's slope differs from 0 (two-sided, Student's t on
#: ``n - 2`` degrees of freedom); a calibration that fails it is refused.
SLOPE_TEST_LEVEL = 0.05


@dataclass(frozen=True)
class LeakCalibration:
    """Linear map ``leak_lpm = intercept + slope * shift`` with a prediction interval.

    Attributes
    ----------
    intercept_lpm, slope_lpm : float
        Coefficients (L/min, L/min per healthy std).
    residual_std_lpm : float
        Residual standard deviation of the fit (L/min).
    n_runs : int
        Calibration runs.
    shift_mean, shift_ss : float
        Mean and sum of squared deviations of the calibration shifts (for the interval).
    shift_range : tuple of float
        Smallest and largest calibration shift; outside it the estimate is an extrapolation.
    level : float
        Coverage of the prediction interval.
    validity : dict
        Conditions it was fitted on (rig, load, input, feature settings).
    """

    intercept_lpm: float
    slope_lpm: float
    residual_std_lpm: float
    n_runs: int
    shift_mean: float
    shift_ss: float
    shift_range: tuple[float, float]
    level: float = 0.9
    validity: dict[str, Any] = field(default_factory=dict)

    def estimate(self, shift: float) -> tuple[float, tuple[float, float], bool]:
        """Leak flow for a feature shift.

        Parameters
        ----------
        shift : float
            Mean standardised feature after minus before the onset.

        Returns
        -------
        leak_lpm : float
            Point estimate, clipped at 0.
        interval : tuple of float
            Prediction interval at ``level`` (lower bound clipped at 0).
        inside : bool
            Whether ``shift`` lies in the calibrated range.

        Examples
        --------
        >>> cal = fit_leak_calibration([0.0, 1.0, 2.0, 3.0], [0.0, 0.1, 0.2, 0.3])
        >>> round(cal.estimate(1.5)[0], 6)
        0.15
        """
        from scipy import stats

        q = self.intercept_lpm + self.slope_lpm * shift
        dof = self.n_runs - 2
        se = self.residual_std_lpm * np.sqrt(
            1.0 + 1.0 / self.n_runs + (shift - self.shift_mean) ** 2 / max(self.shift_ss, 1e-300))
        half = float(stats.t.ppf(0.5 + self.level / 2.0, dof)) * se
        inside = self.shift_range[0] <= shift <= self.shift_range[1]
        return max(0.0, float(q)), (max(0.0, float(q - half)), max(0.0, float(q + half))), inside


def fit_leak_calibration(shifts, leak_lpm, level: float = 0.9,
                         validity: dict | None = None) -> LeakCalibration:
    """Fit ``leak_lpm = a + b * shift`` by least squares (inverse regression).

    Parameters
    ----------
    shifts : array_like
        Feature shift per calibration run (healthy std units).
    leak_lpm : array_like
        True leak flow of each run in L/min (0 for healthy runs).
    level : float, default 0.9
        Coverage of the prediction interval, in (0, 1).
    validity : dict, optional
        Conditions of the calibration runs, stored as is.

    Returns
    -------
    LeakCalibration

    Raises
    ------
    ValueError
        Fewer than 3 runs, lengths differ, all shifts or all flows equal, or a slope that does not differ
        from 0 at the 5 % level (:data:`SLOPE_TEST_LEVEL`): the feature does not follow the leak
        on these runs, and a size read from it would be noise.

    Notes
    -----
    The interval is the ordinary least-squares prediction interval with Student's t on
    ``n - 2`` degrees of freedom; it assumes the calibration conditions hold. Its level holds
    over leaks drawn like the calibration runs (marginally over their mix of sizes), not at
    each size: a barely detected leak is over-estimated (docs/detect.md section 4).

    Examples
    --------
    >>> cal = fit_leak_calibration([0.0, 1.0, 2.0], [0.0, 0.2, 0.4])
    >>> round(cal.slope_lpm, 6), cal.n_runs
    (0.2, 3)
    """
    s = np.asarray(shifts, dtype=np.float64)
    q = np.asarray(leak_lpm, dtype=np.float64)
    if s.shape != q.shape or s.ndim != 1:
        raise ValueError(f"shifts and leak_lpm must be 1-D of equal length, got {s.shape} and {q.shape}")
    keep = np.isfinite(s) & np.isfinite(q)
    s, q = s[keep], q[keep]
    if len(s) < MIN_CALIBRATION_RUNS:
        raise ValueError(f"fit_leak_calibration needs >= {MIN_CALIBRATION_RUNS} finite runs, got {len(s)}")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level={level!r} must be in (0, 1)")
    ss = float(np.sum((s - s.mean()) ** 2))
    if ss == 0.0:
        raise ValueError("fit_leak_calibration: all feature shifts are equal; the feature does not "
                         "respond to the leak on these runs")
    if float(np.ptp(q)) == 0.0:
        raise ValueError(f"fit_leak_calibration: all {len(q)} runs have the same leak flow "
                         f"({q[0]:g} L/min); a calibration needs runs of different sizes")
    b = float(np.sum((s - s.mean()) * (q - q.mean())) / ss)
    a = float(q.mean() - b * s.mean())
    resid = q - (a + b * s)
    sd = float(np.sqrt(np.sum(resid ** 2) / (len(s) - 2))) if len(s) > 2 else 0.0
    # the slope must differ from 0 (audit 2026-11-27: a ccf-p1p2 calibration on 0.005-0.02
    # L/min runs had t = 0.2 and sized a 0.5 L/min leak 0.04 [0, 0.32] L/min)
    se_b = sd / np.sqrt(ss)
    if se_b > 0.0:
        from scipy import stats

        t_b = abs(b) / se_b
        crit = float(stats.t.ppf(1.0 - SLOPE_TEST_LEVEL / 2.0, len(s) - 2))
        if not t_b >= crit:
            raise ValueError(
                f"fit_leak_calibration: the feature's shift does not follow the leak flow on "
                f"these {len(s)} runs: slope {b:.3g} L/min per healthy std, standard error "
                f"{se_b:.3g} (t = {t_b:.2f}, below {crit:.2f}, the two-sided "
                f"{SLOPE_TEST_LEVEL:.0%} level): this feature cannot size leaks here; calibrate "
                "with larger leaks or more runs, or use a detector that sizes them (flow-balance)")
    return LeakCalibration(intercept_lpm=a, slope_lpm=b, residual_std_lpm=sd, n_runs=len(s),
                           shift_mean=float(s.mean()), shift_ss=ss,
                           shift_range=(float(s.min()), float(s.max())), level=level,
                           validity=dict(validity or {}))
