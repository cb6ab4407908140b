"""Numba kernels: anchored block sums for windowed (lagged) second moments in O(n).

Method (see ``docs/features.md``, "Numerical method")
-----------------------------------------------------
Let a window hold ``M`` pair terms ``j = s .. s+M-1`` (``M = N`` for plain sums, ``M = N - lag``
for lagged products). Pair indices are cut into blocks of ``M``. A window then covers the *tail*
of block ``b = s // M`` and the *head* of block ``b + 1`` (one of them possibly empty). For the
tail we keep suffix sums anchored at the block's last pair; for the head, prefix sums anchored at
the next block's first pair. Both anchors are samples **inside** the window, so every stored sum
is of deviations bounded by the window's own range: no global offset, no long running sum, no
cancellation between a level far from the data and its small variation (8.6 MPa +- kPa, level
steps). Each piece is then shifted exactly to the window mean,

    sum (u - mu)(v - mv) = C + dv * A + du * B + n * du * dv,   du = cu - mu, dv = cv - mv,

with ``A = sum (u - cu)``, ``B = sum (v - cv)``, ``C = sum (u - cu)(v - cv)``. The mean itself is
kept as ``ref + off`` (a window sample plus a small offset) so that ``du`` is formed from
differences of window samples only. Suffix sums are filled once per block down to the first
requested start, prefix sums lazily up to the longest requested head, so the cost is O(n + m)
for ``m`` sorted starts, flat in the window size and the step.

Kernels require ``starts`` sorted ascending (the wrappers sort) and valid (``s + N <= n``).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["lag0_stats", "lagged_cross_sums", "safe_ratio", "safe_ratio_sqrt"]


@numba.njit(cache=True)
def lag0_stats(x, window, starts):  # pragma: no cover - compiled
    """Per window: ``ref`` (a window sample), ``off`` (mean - ref) and sum of squared deviations."""
    n = x.shape[0]
    m_len = window
    ga = np.empty(m_len)
    gc = np.empty(m_len)
    fa = np.empty(m_len)
    fc = np.empty(m_len)
    n_win = starts.shape[0]
    ref = np.empty(n_win)
    off = np.empty(n_win)
    ss = np.empty(n_win)
    inv_m = 1.0 / m_len
    b0 = 0
    e = -1  # end of the current block; -1: none yet (starts are sorted, so blocks only advance)
    c0 = 0.0
    f_b0 = -1
    f_len = 0
    c1 = 0.0
    sa = 0.0
    sc = 0.0
    for w in range(n_win):
        s = starts[w]
        if s >= b0 + m_len or e < 0:  # entered a new block: one integer division per block
            b0 = (s // m_len) * m_len
            e = min(b0 + m_len, n)
            c0 = x[e - 1]
            ta = 0.0
            tc = 0.0
            for j in range(e - 1, s - 1, -1):
                d = x[j] - c0
                ta += d
                tc += d * d
                ga[j - b0] = ta
                gc[j - b0] = tc
        i0 = s - b0
        n0 = e - s
        n1 = m_len - n0
        a0 = ga[i0]
        if n1 > 0:
            if f_b0 != e:
                f_b0 = e
                f_len = 0
                c1 = x[e]
                sa = 0.0
                sc = 0.0
            while f_len < n1:
                d = x[e + f_len] - c1
                sa += d
                sc += d * d
                fa[f_len] = sa
                fc[f_len] = sc
                f_len += 1
            dc = c1 - c0
            a1 = fa[n1 - 1]
            o = (a0 + a1 + n1 * dc) * inv_m
            d0 = -o
            d1 = dc - o
            acc = gc[i0] + 2.0 * d0 * a0 + n0 * d0 * d0
            acc += fc[n1 - 1] + 2.0 * d1 * a1 + n1 * d1 * d1
        else:
            o = a0 * inv_m
            acc = gc[i0] - o * a0
        ref[w] = c0
        off[w] = o
        ss[w] = acc
    return ref, off, ss


@numba.njit(cache=True)
def lagged_cross_sums(u, v, lag, window, starts, ru, offu, rv, offv):  # pragma: no cover
    """Per window: ``sum_{j=s}^{s+N-lag-1} (u_j - mean u)(v_{j+lag} - mean v)``.

    The window means are given as ``ru + offu`` and ``rv + offv`` (from :func:`lag0_stats`).
    """
    n_pairs = u.shape[0] - lag
    m_len = window - lag
    ga = np.empty(m_len)
    gb = np.empty(m_len)
    gc = np.empty(m_len)
    fa = np.empty(m_len)
    fb = np.empty(m_len)
    fc = np.empty(m_len)
    n_win = starts.shape[0]
    out = np.empty(n_win)
    b0 = 0
    e = -1
    gcu = 0.0
    gcv = 0.0
    f_b0 = -1
    f_len = 0
    fcu = 0.0
    fcv = 0.0
    sa = 0.0
    sb = 0.0
    sc = 0.0
    for w in range(n_win):
        s = starts[w]
        if s >= b0 + m_len or e < 0:
            b0 = (s // m_len) * m_len
            e = min(b0 + m_len, n_pairs)
            gcu = u[e - 1]
            gcv = v[e - 1 + lag]
            ta = 0.0
            tb = 0.0
            tc = 0.0
            for j in range(e - 1, s - 1, -1):
                du = u[j] - gcu
                dv = v[j + lag] - gcv
                ta += du
                tb += dv
                tc += du * dv
                ga[j - b0] = ta
                gb[j - b0] = tb
                gc[j - b0] = tc
        i0 = s - b0
        n0 = e - s
        du0 = (gcu - ru[w]) - offu[w]
        dv0 = (gcv - rv[w]) - offv[w]
        acc = gc[i0] + dv0 * ga[i0] + du0 * gb[i0] + n0 * du0 * dv0
        n1 = m_len - n0
        if n1 > 0:
            if f_b0 != e:
                f_b0 = e
                f_len = 0
                fcu = u[e]
                fcv = v[e + lag]
                sa = 0.0
                sb = 0.0
                sc = 0.0
            while f_len < n1:
                du = u[e + f_len] - fcu
                dv = v[e + f_len + lag] - fcv
                sa += du
                sb += dv
                sc += du * dv
                fa[f_len] = sa
                fb[f_len] = sb
                fc[f_len] = sc
                f_len += 1
            du1 = (fcu - ru[w]) - offu[w]
            dv1 = (fcv - rv[w]) - offv[w]
            k = n1 - 1
            acc += fc[k] + dv1 * fa[k] + du1 * fb[k] + n1 * du1 * dv1
        out[w] = acc
    return out


@numba.njit(cache=True)
def safe_ratio(num, den):  # pragma: no cover - compiled
    """``num / den`` with NaN where ``den <= 0`` (a degenerate window); also the NaN count."""
    out = np.empty(num.shape[0])
    n_bad = 0
    for i in range(num.shape[0]):
        if den[i] > 0.0:
            out[i] = num[i] / den[i]
        else:
            out[i] = np.nan
            n_bad += 1
    return out, n_bad


@numba.njit(cache=True)
def safe_ratio_sqrt(num, den_x, den_y):  # pragma: no cover - compiled
    """``num / (sqrt(den_x) sqrt(den_y))``, NaN where either is ``<= 0``; also the NaN count."""
    out = np.empty(num.shape[0])
    n_bad = 0
    for i in range(num.shape[0]):
        if den_x[i] > 0.0 and den_y[i] > 0.0:
            out[i] = num[i] / (np.sqrt(den_x[i]) * np.sqrt(den_y[i]))
        else:
            out[i] = np.nan
            n_bad += 1
    return out, n_bad
