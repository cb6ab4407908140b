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

__all__ = ["block_of", "lag0_stats", "lagged_cross_sums", "safe_ratio", "safe_ratio_sqrt"]


@numba.njit(cache=True)
def block_of(starts, w, m_len):  # pragma: no cover - compiled
    """Block start ``b0`` holding ``starts[w]`` and the end ``w_end`` of the run of starts in it."""
    b0 = (starts[w] // m_len) * m_len
    w_end = w + 1
    n_win = starts.shape[0]
    while w_end < n_win and starts[w_end] < b0 + m_len:
        w_end += 1
    return b0, w_end


@numba.njit(cache=True)
def lag0_stats(x, window, starts):  # pragma: no cover - compiled
    """Per window: ``ref`` (a window sample), ``off`` (mean - ref) and sum of squared deviations.

    For a start ``s`` in the block ``[b0, e = b0 + N)`` with ``i = s - b0``, the window is the
    tail ``[s, e)`` (``N - i`` samples, suffix sums ``g*[i]`` anchored at ``x[e-1]``) plus the
    head ``[e, e + i)`` of the next block (``i`` samples, prefix sums ``f*[i]`` anchored at
    ``x[e]``; ``f*[0] = 0``), so the per-window step is branch-free.
    """
    m_len = window
    fm = float(m_len)
    inv_m = 1.0 / fm
    ga = np.empty(m_len)
    gc = np.empty(m_len)
    fa = np.empty(m_len)
    fc = np.empty(m_len)
    n_win = starts.shape[0]
    ref = np.empty(n_win)
    off = np.empty(n_win)
    ss = np.empty(n_win)
    w = 0
    while w < n_win:
        b0, w_end = block_of(starts, w, m_len)
        e = b0 + m_len
        c0 = x[e - 1]
        ta = 0.0
        tc = 0.0
        for j in range(e - 1, starts[w] - 1, -1):
            d = x[j] - c0
            ta += d
            tc += d * d
            ga[j - b0] = ta
            gc[j - b0] = tc
        need = starts[w_end - 1] - b0
        c1 = x[e] if need > 0 else c0
        ta = 0.0
        tc = 0.0
        fa[0] = 0.0
        fc[0] = 0.0
        for i in range(need):
            d = x[e + i] - c1
            ta += d
            tc += d * d
            fa[i + 1] = ta
            fc[i + 1] = tc
        dc = c1 - c0
        for k in range(w, w_end):
            i = starts[k] - b0
            fi = float(i)
            a0 = ga[i]
            a1 = fa[i]
            o = (a0 + a1 + fi * dc) * inv_m
            d1 = dc - o
            ref[k] = c0
            off[k] = o
            ss[k] = (gc[i] - 2.0 * o * a0 + (fm - fi) * o * o
                     + fc[i] + 2.0 * d1 * a1 + fi * d1 * d1)
        w = w_end
    return ref, off, ss


@numba.njit(cache=True)
def lagged_cross_sums(u, v, lag, window, starts, ru, offu, rv, offv):  # pragma: no cover
    """Per window: ``sum_{j=s}^{s+N-lag-1} (u_j - mean u)(v_{j+lag} - mean v)``.

    The window means are given as ``ru + offu`` and ``rv + offv`` (from :func:`lag0_stats`).
    Pair ``j`` is ``(u_j, v_{j+lag})``; blocks of ``M = N - lag`` pairs, laid out as in
    :func:`lag0_stats`; the anchors are the pair at the block's end and the next block's start.
    """
    m_len = window - lag
    fm = float(m_len)
    ga = np.empty(m_len)
    gb = np.empty(m_len)
    gc = np.empty(m_len)
    fa = np.empty(m_len)
    fb = np.empty(m_len)
    fc = np.empty(m_len)
    n_win = starts.shape[0]
    out = np.empty(n_win)
    w = 0
    while w < n_win:
        b0, w_end = block_of(starts, w, m_len)
        e = b0 + m_len
        cu0 = u[e - 1]
        cv0 = v[e - 1 + lag]
        ta = 0.0
        tb = 0.0
        tc = 0.0
        for j in range(e - 1, starts[w] - 1, -1):
            du = u[j] - cu0
            dv = v[j + lag] - cv0
            ta += du
            tb += dv
            tc += du * dv
            ga[j - b0] = ta
            gb[j - b0] = tb
            gc[j - b0] = tc
        need = starts[w_end - 1] - b0
        cu1 = u[e] if need > 0 else cu0
        cv1 = v[e + lag] if need > 0 else cv0
        ta = 0.0
        tb = 0.0
        tc = 0.0
        fa[0] = 0.0
        fb[0] = 0.0
        fc[0] = 0.0
        for i in range(need):
            du = u[e + i] - cu1
            dv = v[e + i + lag] - cv1
            ta += du
            tb += dv
            tc += du * dv
            fa[i + 1] = ta
            fb[i + 1] = tb
            fc[i + 1] = tc
        for k in range(w, w_end):
            i = starts[k] - b0
            fi = float(i)
            du0 = (cu0 - ru[k]) - offu[k]
            dv0 = (cv0 - rv[k]) - offv[k]
            du1 = (cu1 - ru[k]) - offu[k]
            dv1 = (cv1 - rv[k]) - offv[k]
            out[k] = (gc[i] + dv0 * ga[i] + du0 * gb[i] + (fm - fi) * du0 * dv0
                      + fc[i] + dv1 * fa[i] + du1 * fb[i] + fi * du1 * dv1)
        w = w_end
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
