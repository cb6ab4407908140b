"""The load pressure as a linear response to the reference: a window correction of the first
guess of a leak coefficient.

The first guess of :math:`k_l` (:func:`~leakdiag.sim.experiment.coefficient_from_healthy`)
divides the target flow by the mean leak law :math:`\\overline{|g(P_1 - P_2)|}` of the healthy
pressures *before* the onset, but the target is a mean *after* it, over other reference
steps. Where the load pressure follows the reference (a spring load: :math:`A (P_1 - P_2)
\\approx k_s x + m\\ddot x + \\dots`, Eq. 2-1), the healthy load pressure after the onset can be
predicted before it is integrated: :func:`window_ratio` fits a linear filter from the
reference to :math:`P_1 - P_2` on the healthy part (least squares, Wiener-Hopf normal equations)
and returns the ratio of the predicted leak-law means after and before the onset. The fit is
used only when it explains most of the pressure's variance (:data:`MIN_R2`): without load the
pressure difference is friction and inertia, not a linear response of the position (measured
:math:`R^2` 0.31-0.52), and the correction is not applied.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from scipy.linalg import LinAlgError, solve_toeplitz

__all__ = ["window_ratio", "MIN_R2", "GRID_HZ", "MEMORY_S"]

#: Smallest share of the variance of :math:`P_1 - P_2` the linear response must explain
#: before the onset for the correction to apply (measured, 400 s runs, 100 Hz grid: 0.93-0.96
#: with the spring, 0.31-0.52 without load; docs/models.md).
MIN_R2 = 0.8
#: Rate of the grid on which the response is fitted and evaluated, Hz (the reference's steps
#: and the closed loop's transients are resolved at 10 ms; a 1 kHz fit gave the same ratios
#: within 0.1 %).
GRID_HZ = 100.0
#: Memory of the linear filter, s (the closed loop settles within it after a step).
MEMORY_S = 0.3


def window_ratio(reference: np.ndarray, dp: np.ndarray, start: int, split: int, onset: int,
                 sample_rate: float, law: Callable[[np.ndarray], np.ndarray],
                 multipliers: np.ndarray) -> float | None:
    """Predicted mean leak law after the onset over the healthy mean before it.

    Parameters
    ----------
    reference : numpy.ndarray
        The run's reference (or drive) at every sample, known before integrating.
    dp : numpy.ndarray
        Healthy :math:`P_1 - P_2`, Pa, valid on ``[0, split)``.
    start, split : int
        The fit uses samples ``[start, split)`` (past the start-up, before the onset).
    onset : int
        First sample at or after the onset; the prediction is averaged over ``[onset, n)``.
    sample_rate : float
        Rate of ``reference`` and ``dp``, Hz.
    law : callable
        :math:`|g(\\Delta p)|`, the leak law with unit coefficient, on an array.
    multipliers : numpy.ndarray
        The schedule :math:`s(t)` at every sample of the run.

    Returns
    -------
    float or None
        :math:`\\overline{s\\,|g(\\hat{\\Delta p})|}_{\\text{after}} /
        \\overline{|g(\\hat{\\Delta p})|}_{\\text{before}}` with :math:`\\hat{\\Delta p}` the
        linear response, both means on the :data:`GRID_HZ` grid; None when the response
        explains less than :data:`MIN_R2` of the variance before the onset, the reference does
        not vary there, or there are too few samples.

    Examples
    --------
    A pressure that is exactly a lagged multiple of the reference:

    >>> rng = np.random.default_rng(0)
    >>> x = np.repeat(rng.uniform(-1, 1, 400), 500)          # 200 s of 0.5 s steps, 1 kHz
    >>> dp = 3.0 + 2.0 * np.concatenate([np.zeros(50), x[:-50]])
    >>> r = window_ratio(x, dp, 1000, 100_000, 100_000, 1000.0, np.abs, np.ones(200_000))
    >>> bool(abs(r - np.abs(dp[100_000::10]).mean() / np.abs(dp[1000:100_000:10]).mean()) < 1e-6)
    True
    """
    m = max(1, int(round(sample_rate / GRID_HZ)))
    taps = max(1, int(math.ceil(MEMORY_S * sample_rate / m)))
    xs = np.asarray(reference, dtype=np.float64)[::m]
    a, b, on = -(-start // m), -(-split // m), -(-onset // m)
    if b - a < 10 * taps or on >= xs.size or a < taps:
        return None
    x_fit = xs[a:b]
    d_fit = np.asarray(dp[a * m:b * m:m], dtype=np.float64)
    xc, dc = x_fit - x_fit.mean(), d_fit - d_fit.mean()
    nfft = 1 << int(math.ceil(math.log2(xc.size + taps)))
    fx = np.fft.rfft(xc, nfft)
    rxx = np.fft.irfft(fx * np.conj(fx), nfft)[:taps]
    rxd = np.fft.irfft(np.fft.rfft(dc, nfft) * np.conj(fx), nfft)[:taps]
    ddc = float(np.dot(dc, dc))
    if not (rxx[0] > 0 and ddc > 0):
        return None
    rxx[0] *= 1.0 + 1e-9  # diagonal loading against a nearly singular system
    try:
        h = solve_toeplitz(rxx, rxd)
    except LinAlgError:
        return None
    if not float(np.dot(h, rxd)) / ddc >= MIN_R2:
        return None
    pred = np.convolve(xs, h)[:xs.size] + (d_fit.mean() - h.sum() * x_fit.mean())
    before = float(np.mean(law(pred[a:b])))
    after = float(np.mean(np.asarray(multipliers)[::m][on:] * law(pred[on:])))
    if not (before > 0 and math.isfinite(after)):
        return None
    return after / before
