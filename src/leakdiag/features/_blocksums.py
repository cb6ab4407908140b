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

The correlation kernels advance the mean/variance blocks (``N`` samples) and the lagged-product
blocks (``N - lag`` pairs) together, one window at a time, and write each window's value
directly: no per-window intermediate arrays (on the team's VM a fresh 1.6 MB array costs about
0.4 ms of page faults). Their block bookkeeping is written out inline on purpose: Numba helper
calls taking arrays pay reference counting per call, which made a factored version 10x slower.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["block_of", "autocorrelation_sorted", "cross_correlation_sorted"]


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
def autocorrelation_sorted(x, lag, window, starts):  # pragma: no cover - compiled
    """Eq. 4.1 for sorted valid starts: ``(values, n_zero_variance)``.

    Structure 0: plain sums in blocks of ``N`` (suffix anchor ``c00 = x[e0-1]``, prefix anchor
    ``c01 = x[e0]``, ``fl0`` prefix entries filled). Structure 1: pairs ``(x_j, x_{j+lag})`` in
    blocks of ``N - lag`` (anchors ``cu0, cv0`` and ``cu1, cv1``).
    """
    m0 = window
    m1 = window - lag
    fm0 = float(m0)
    fm1 = float(m1)
    inv0 = 1.0 / fm0
    g0a = np.empty(m0)
    g0c = np.empty(m0)
    f0a = np.empty(m0)
    f0c = np.empty(m0)
    g1a = np.empty(m1)
    g1b = np.empty(m1)
    g1c = np.empty(m1)
    f1a = np.empty(m1)
    f1b = np.empty(m1)
    f1c = np.empty(m1)
    n_win = starts.shape[0]
    out = np.empty(n_win)
    n_bad = 0
    b0 = 0
    e0 = -1
    fl0 = 0
    c00 = 0.0
    c01 = 0.0
    b1 = 0
    e1 = -1
    fl1 = 0
    cu0 = 0.0
    cv0 = 0.0
    cu1 = 0.0
    cv1 = 0.0
    for k in range(n_win):
        s = starts[k]
        # ---- plain sums, blocks of N
        if e0 < 0 or s >= e0:
            b0 = (s // m0) * m0
            e0 = b0 + m0
            fl0 = 0
            c00 = x[e0 - 1]
            c01 = c00
            ta = 0.0
            tc = 0.0
            for j in range(e0 - 1, s - 1, -1):
                d = x[j] - c00
                ta += d
                tc += d * d
                g0a[j - b0] = ta
                g0c[j - b0] = tc
            f0a[0] = 0.0
            f0c[0] = 0.0
        i0 = s - b0
        if fl0 < i0:
            if fl0 == 0:
                c01 = x[e0]
            ta = f0a[fl0]
            tc = f0c[fl0]
            for t in range(fl0, i0):
                d = x[e0 + t] - c01
                ta += d
                tc += d * d
                f0a[t + 1] = ta
                f0c[t + 1] = tc
            fl0 = i0
        # ---- lagged pairs, blocks of N - lag
        if e1 < 0 or s >= e1:
            b1 = (s // m1) * m1
            e1 = b1 + m1
            fl1 = 0
            cu0 = x[e1 - 1]
            cv0 = x[e1 - 1 + lag]
            cu1 = cu0
            cv1 = cv0
            ta = 0.0
            tb = 0.0
            tc = 0.0
            for j in range(e1 - 1, s - 1, -1):
                du = x[j] - cu0
                dv = x[j + lag] - cv0
                ta += du
                tb += dv
                tc += du * dv
                g1a[j - b1] = ta
                g1b[j - b1] = tb
                g1c[j - b1] = tc
            f1a[0] = 0.0
            f1b[0] = 0.0
            f1c[0] = 0.0
        i1 = s - b1
        if fl1 < i1:
            if fl1 == 0:
                cu1 = x[e1]
                cv1 = x[e1 + lag]
            ta = f1a[fl1]
            tb = f1b[fl1]
            tc = f1c[fl1]
            for t in range(fl1, i1):
                du = x[e1 + t] - cu1
                dv = x[e1 + t + lag] - cv1
                ta += du
                tb += dv
                tc += du * dv
                f1a[t + 1] = ta
                f1b[t + 1] = tb
                f1c[t + 1] = tc
            fl1 = i1
        # ---- window mean (ref c00 + off o) and variance sum
        fi = float(i0)
        dc = c01 - c00
        a0 = g0a[i0]
        a1 = f0a[i0]
        o = (a0 + a1 + fi * dc) * inv0
        d1 = dc - o
        ss = g0c[i0] - 2.0 * o * a0 + (fm0 - fi) * o * o + f0c[i0] + 2.0 * d1 * a1 + fi * d1 * d1
        if ss > 0.0:
            fj = float(i1)
            du0 = (cu0 - c00) - o
            dv0 = (cv0 - c00) - o
            du1 = (cu1 - c00) - o
            dv1 = (cv1 - c00) - o
            num = (g1c[i1] + dv0 * g1a[i1] + du0 * g1b[i1] + (fm1 - fj) * du0 * dv0
                   + f1c[i1] + dv1 * f1a[i1] + du1 * f1b[i1] + fj * du1 * dv1)
            out[k] = num / ss
        else:
            out[k] = np.nan
            n_bad += 1
    return out, n_bad


@numba.njit(cache=True)
def cross_correlation_sorted(y, x, lag, window, starts):  # pragma: no cover - compiled
    """Eq. 4.2 for sorted valid starts, ``y_j`` with ``x_{j+lag}``: ``(values, n_degenerate)``.

    As :func:`autocorrelation_sorted` with two plain-sum structures (``y``: anchors ``cy0, cy1``;
    ``x``: ``cx0, cx1``; both in blocks of ``N``, so they share ``b0, e0, fl0``) and the pair
    structure ``(y_j, x_{j+lag})``. The value is ``num / (sqrt(ss_x) sqrt(ss_y))``: the ``1/N`` of
    Eq. 4.2 cancels against the population variances.
    """
    m0 = window
    m1 = window - lag
    fm0 = float(m0)
    fm1 = float(m1)
    inv0 = 1.0 / fm0
    gya = np.empty(m0)
    gyc = np.empty(m0)
    fya = np.empty(m0)
    fyc = np.empty(m0)
    gxa = np.empty(m0)
    gxc = np.empty(m0)
    fxa = np.empty(m0)
    fxc = np.empty(m0)
    g1a = np.empty(m1)
    g1b = np.empty(m1)
    g1c = np.empty(m1)
    f1a = np.empty(m1)
    f1b = np.empty(m1)
    f1c = np.empty(m1)
    n_win = starts.shape[0]
    out = np.empty(n_win)
    n_bad = 0
    b0 = 0
    e0 = -1
    fl0 = 0
    cy0 = 0.0
    cy1 = 0.0
    cx0 = 0.0
    cx1 = 0.0
    b1 = 0
    e1 = -1
    fl1 = 0
    cu0 = 0.0
    cv0 = 0.0
    cu1 = 0.0
    cv1 = 0.0
    for k in range(n_win):
        s = starts[k]
        # ---- plain sums of y and x, blocks of N
        if e0 < 0 or s >= e0:
            b0 = (s // m0) * m0
            e0 = b0 + m0
            fl0 = 0
            cy0 = y[e0 - 1]
            cx0 = x[e0 - 1]
            cy1 = cy0
            cx1 = cx0
            tya = 0.0
            tyc = 0.0
            txa = 0.0
            txc = 0.0
            for j in range(e0 - 1, s - 1, -1):
                dy = y[j] - cy0
                dx = x[j] - cx0
                tya += dy
                tyc += dy * dy
                txa += dx
                txc += dx * dx
                gya[j - b0] = tya
                gyc[j - b0] = tyc
                gxa[j - b0] = txa
                gxc[j - b0] = txc
            fya[0] = 0.0
            fyc[0] = 0.0
            fxa[0] = 0.0
            fxc[0] = 0.0
        i0 = s - b0
        if fl0 < i0:
            if fl0 == 0:
                cy1 = y[e0]
                cx1 = x[e0]
            tya = fya[fl0]
            tyc = fyc[fl0]
            txa = fxa[fl0]
            txc = fxc[fl0]
            for t in range(fl0, i0):
                dy = y[e0 + t] - cy1
                dx = x[e0 + t] - cx1
                tya += dy
                tyc += dy * dy
                txa += dx
                txc += dx * dx
                fya[t + 1] = tya
                fyc[t + 1] = tyc
                fxa[t + 1] = txa
                fxc[t + 1] = txc
            fl0 = i0
        # ---- lagged pairs (y_j, x_{j+lag}), blocks of N - lag
        if e1 < 0 or s >= e1:
            b1 = (s // m1) * m1
            e1 = b1 + m1
            fl1 = 0
            cu0 = y[e1 - 1]
            cv0 = x[e1 - 1 + lag]
            cu1 = cu0
            cv1 = cv0
            ta = 0.0
            tb = 0.0
            tc = 0.0
            for j in range(e1 - 1, s - 1, -1):
                du = y[j] - cu0
                dv = x[j + lag] - cv0
                ta += du
                tb += dv
                tc += du * dv
                g1a[j - b1] = ta
                g1b[j - b1] = tb
                g1c[j - b1] = tc
            f1a[0] = 0.0
            f1b[0] = 0.0
            f1c[0] = 0.0
        i1 = s - b1
        if fl1 < i1:
            if fl1 == 0:
                cu1 = y[e1]
                cv1 = x[e1 + lag]
            ta = f1a[fl1]
            tb = f1b[fl1]
            tc = f1c[fl1]
            for t in range(fl1, i1):
                du = y[e1 + t] - cu1
                dv = x[e1 + t + lag] - cv1
                ta += du
                tb += dv
                tc += du * dv
                f1a[t + 1] = ta
                f1b[t + 1] = tb
                f1c[t + 1] = tc
            fl1 = i1
        # ---- window means (c*0 + o*) and sums of squared deviations
        fi = float(i0)
        dcy = cy1 - cy0
        ay0 = gya[i0]
        ay1 = fya[i0]
        oy = (ay0 + ay1 + fi * dcy) * inv0
        dy1 = dcy - oy
        ssy = (gyc[i0] - 2.0 * oy * ay0 + (fm0 - fi) * oy * oy
               + fyc[i0] + 2.0 * dy1 * ay1 + fi * dy1 * dy1)
        dcx = cx1 - cx0
        ax0 = gxa[i0]
        ax1 = fxa[i0]
        ox = (ax0 + ax1 + fi * dcx) * inv0
        dx1 = dcx - ox
        ssx = (gxc[i0] - 2.0 * ox * ax0 + (fm0 - fi) * ox * ox
               + fxc[i0] + 2.0 * dx1 * ax1 + fi * dx1 * dx1)
        if ssx > 0.0 and ssy > 0.0:
            fj = float(i1)
            du0 = (cu0 - cy0) - oy
            dv0 = (cv0 - cx0) - ox
            du1 = (cu1 - cy0) - oy
            dv1 = (cv1 - cx0) - ox
            num = (g1c[i1] + dv0 * g1a[i1] + du0 * g1b[i1] + (fm1 - fj) * du0 * dv0
                   + f1c[i1] + dv1 * f1a[i1] + du1 * f1b[i1] + fj * du1 * dv1)
            out[k] = num / (np.sqrt(ssx) * np.sqrt(ssy))
        else:
            out[k] = np.nan
            n_bad += 1
    return out, n_bad
