"""Per-window formulas of the windowed features, shared by all their Numba kernels.

Each function turns the sums of one window, taken about an anchor inside the window
(``docs/features.md``, "Numerical method"), into the feature's value: Eq. 4.1
(:func:`auto_value`), Eq. 4.2 (:func:`cross_value`) for the short-lag kernels of
:mod:`leakdiag.features._kernels.smalllag` and :mod:`leakdiag.features._kernels.stepsums`, and Eq. 4.11-4.14
(:func:`moment_values`). They take and return scalars and are inlined (``inline="always"``)
into the kernels' evaluation loops, which LLVM vectorises.
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features._kernels.chunks import PRODUCT_MAX, PRODUCT_MIN

__all__ = ["auto_value", "cross_value", "moment_values"]


@numba.njit(inline="always", error_model="numpy")
def auto_value(u1, c2, p, f1, l1, l2, dvt, inv, fm):  # pragma: no cover - compiled
    """Eq. 4.1 of one window from its pair-block sums about the anchors ``(ut, vt)``.

    ``u1, c2, p``: sums of ``u = x_j - ut``, ``u^2`` and ``u (x_{j+lag} - vt)`` over the pairs;
    ``f1``: sum of ``x - ut`` over the first ``lag`` samples, ``l1, l2``: of ``x - ut`` and its
    square over the last ``lag``; ``dvt = vt - ut``, ``inv = 1/N``, ``fm = M``. Returns the value
    (NaN for zero variance), 1 if the variance is zero, 1 if the sums are not finite.
    """
    a = u1 + l1
    o = a * inv
    ss = (c2 + l2) - a * o
    v1 = u1 - f1 + l1 - fm * dvt
    dv = dvt - o
    num = p + dv * u1 - o * v1 - fm * o * dv
    ok = ss > 0.0
    return (num / ss if ok else np.nan), (0 if ok else 1), (0 if ss - ss == 0.0 else 1)


@numba.njit(inline="always", error_model="numpy")
def cross_value(y1, x1, cy, cx, p, ly1, ly2, fx1, fx2, inv, fm, split):  # pragma: no cover - compiled
    """Eq. 4.2 of one window from its pair-block sums about the anchors ``(uy, vx)``.

    ``y1, cy``: sums of ``a = y_j - uy`` and ``a^2`` over the pairs, ``x1, cx`` of
    ``b = x_{j+lag} - vx`` and ``b^2``, ``p`` of ``a b``; ``ly1, ly2``: sums of ``y - uy`` and
    its square over ``y``'s last ``lag`` samples, ``fx1, fx2`` of ``x - vx`` over ``x``'s first
    ``lag``. The denominator is ``sqrt(ss_x ss_y)``, or ``sqrt(ss_x) sqrt(ss_y)`` with ``split``.
    Returns the value (NaN if either variance is zero), 1 if so, 1 if the sums are not finite,
    1 if ``ss_x ss_y`` leaves ``[PRODUCT_MIN, PRODUCT_MAX]`` (redo with ``split``; see
    :mod:`leakdiag.features._kernels.chunks`).
    """
    ay = y1 + ly1
    ax = x1 + fx1
    oy = ay * inv
    ox = ax * inv
    ssy = (cy + ly2) - ay * oy
    ssx = (cx + fx2) - ax * ox
    num = p - ox * y1 - oy * x1 + fm * oy * ox
    ok = (ssy > 0.0) & (ssx > 0.0)
    pr = ssx * ssy
    den = np.sqrt(ssx) * np.sqrt(ssy) if split else np.sqrt(pr)
    finite = (ssx - ssx == 0.0) & (ssy - ssy == 0.0)
    in_range = (pr > PRODUCT_MIN) & (pr < PRODUCT_MAX) | ~ok
    return ((num / den if ok else np.nan), (0 if ok else 1), (0 if finite else 1),
            (0 if in_range else 1))


@numba.njit(inline="always")
def shift_moments(s1, s2, s3, s4, n, d):  # pragma: no cover - compiled
    """Given sums of ``(x - c)^p`` (p = 1..4) over ``n`` samples, sums of ``(x - c + d)^p``."""
    d2 = d * d
    m2 = s2 + 2.0 * d * s1 + n * d2
    m3 = s3 + 3.0 * d * s2 + 3.0 * d2 * s1 + n * d2 * d
    m4 = s4 + 4.0 * d * s3 + 6.0 * d2 * s2 + 4.0 * d2 * d * s1 + n * d2 * d2
    return m2, m3, m4


@numba.njit(inline="always", error_model="numpy")
def moment_values(s1, s2, s3, s4, anchor, fn, inv):  # pragma: no cover - compiled
    """Eq. 4.11-4.14 of one window of ``fn`` samples from its power sums about ``anchor``.

    ``s1 .. s4``: sums of ``(x - anchor)^p``; ``inv = 1 / fn``. Returns mean, population
    variance, skewness, kurtosis, 1 for a constant window (0 variance; skewness and kurtosis
    NaN), 1 if the sums are not finite.
    """
    off = s1 * inv
    c2, c3, c4 = shift_moments(s1, s2, s3, s4, fn, -off)
    ok = c2 > 0.0
    v2 = c2 / (fn - 1.0)  # sample variance s^2 (Eq. 4.13-4.14)
    var = c2 * inv if ok else 0.0  # Eq. 4.12, population variance
    skew = c3 / ((fn - 1.0) * v2 * np.sqrt(v2)) if ok else np.nan
    kurt = c4 / ((fn - 1.0) * v2 * v2) if ok else np.nan
    return anchor + off, var, skew, kurt, (0 if ok else 1), (0 if c2 - c2 == 0.0 else 1)
