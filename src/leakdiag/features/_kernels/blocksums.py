"""Numba kernels: anchored block sums for windowed (lagged) second moments in O(n).

Method (see ``docs/features.md``, "Numerical method")
-----------------------------------------------------
Let a window hold ``M`` terms ``j = s .. s+M-1`` (``M = N`` for plain sums, ``M = N - lag``
for lagged products). Term indices are cut into blocks of ``M`` (block ends at multiples of
``M``). A window then covers the *tail* ``[s, e)`` of the block holding ``s`` (``e`` its end)
and the *head* ``[e, s + M)`` of the next block (possibly empty). Both pieces are summed as
deviations from one **anchor inside the window**: the block's last term ``e - 1`` (for plain
sums the sample ``x[e-1]``, for lagged products the pair ``(x[e-1], x[e-1+lag])``). Every stored
sum therefore holds only samples of the window itself, as deviations bounded by the window's own
range: no global offset, no long running sum, no cancellation between a level far from the data
and its small variation (8.6 MPa +- kPa, level steps). The sums are shifted exactly to the window
mean at the end,

    sum (u - mu)(v - mv) = C + dv * A + du * B + M * du * dv,   du = cu - mu, dv = cv - mv,

with ``A = sum (u - cu)``, ``B = sum (v - cv)``, ``C = sum (u - cu)(v - cv)``, and
``sum (x - mu)^2 = C - A^2 / N`` with ``A, C`` about the anchor: as the anchor is a sample of the
window, ``(anchor - mu)^2 <= sum (x - mu)^2``, so this loses at most a factor ``N + 1`` in
relative precision (about 1e-13 at N = 500).

Passes. Windows are processed in chunks of ``CHUNK`` windows. A backward pass over the chunk's
windows grows the tails (``tail_k = tail_{k+1} + sum over [s_k, s_{k+1})`` while both starts
share a block, restarted at each block end); a forward pass grows the heads the same way
(``head_k = head_{k-1} + sum over [s_{k-1} + M, s_k + M)``). Samples are added one at a time,
tails from the block end down and heads from the block start up, so the order of the additions
(and every bit of the result) is the same for any step and any chunking; plain and lagged-pair
sums share one loop whenever their ranges coincide. The
per-window values are written to small column arrays, and a last branch-free loop over them
(SIMD-vectorised by LLVM, ``error_model="numpy"``) forms the feature. Cost O(n + m) for ``m``
sorted starts, flat in the window size and the step.

Regular windows (``s_k = k * step``, the features' own windows) pass ``step > 0`` and no start
array; the ``*_regular`` entry points also write the window times and return values and times
as two rows of one allocation (each fresh megabyte-sized array costs about 0.4 ms of page faults
on the team's VM, more than the whole kernel at 5 % overlap). Arbitrary starts pass ``step = 0``
and a sorted ``starts`` array (the wrappers sort). For ``lag <= LAG_DIRECT`` the entry points
call the one-structure kernels of :mod:`leakdiag.features._kernels.smalllag` instead (fewer running sums;
same anchors-in-the-window accuracy). Regular windows with ``2 <= step <= STEP_MAX`` go to the
step-increment kernels of :mod:`leakdiag.features._kernels.stepsums` instead (chosen by the Python
wrappers, so that those large kernels compile only when such a step is used).

The block bookkeeping is written out inline in each kernel on purpose: Numba helper calls taking
arrays pay reference counting per call, which made a factored version 10x slower.
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features._kernels.chunks import (CHUNK, NO_STARTS, PRODUCT_MAX, PRODUCT_MIN, UINT,
                                       fill_times)
from leakdiag.features._kernels.smalllag import LAG_DIRECT, auto_small_core, cross_small_core

__all__ = [
    "autocorrelation_sorted",
    "autocorrelation_regular",
    "cross_correlation_sorted",
    "cross_correlation_regular",
]


@numba.njit(cache=True, error_model="numpy")
def _auto_eval(ga, gc, gu, gv, guv, du0, dv0, ha, hc, hu, hv, huv, fn, fm, out, o0, cnt):  # pragma: no cover - compiled
    """Eq. 4.1 from the tail/head sums of ``cnt`` windows, written to ``out[o0:o0+cnt]``."""
    inv = 1.0 / fn
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    for t in range(cnt):
        a = ga[t] + ha[t]
        o = a * inv
        ss = (gc[t] + hc[t]) - a * o
        du = du0[t] - o
        dv = dv0[t] - o
        num = (guv[t] + huv[t]) + dv * (gu[t] + hu[t]) + du * (gv[t] + hv[t]) + fm * du * dv
        ok = ss > 0.0
        out[o0 + t] = num / ss if ok else np.nan
        bad += 0 if ok else 1
        nf += 0 if ss - ss == 0.0 else 1
    return bad, nf


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _auto_core(x, lag, window, starts, step, out):  # pragma: no cover - compiled
    """Eq. 4.1 for windows ``s_k = k * step`` (``step > 0``) or ``starts`` (sorted, ``step = 0``).

    Plain sums (anchor ``ct = x[e0 - 1]``, blocks of ``N``) and lagged pairs (anchor
    ``(ut, vt) = (x[e1 - 1], x[e1 - 1 + lag])``, blocks of ``N - lag``). Returns the numbers of
    zero-variance windows and of windows whose sums are not finite (NaN/inf input).
    """
    nn = window
    mm = window - lag
    n_win = out.shape[0]
    kc = max(1, min(CHUNK, n_win))
    ga = np.empty(kc)
    gc = np.empty(kc)
    gu = np.empty(kc)
    gv = np.empty(kc)
    guv = np.empty(kc)
    du0 = np.empty(kc)
    dv0 = np.empty(kc)
    ha = np.empty(kc)
    hc = np.empty(kc)
    hu = np.empty(kc)
    hv = np.empty(kc)
    huv = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        # ---- tails, backward over the chunk
        e0 = -1
        p0 = 0
        ct = 0.0
        a0 = 0.0
        c0 = 0.0
        e1 = -1
        p1 = 0
        ut = 0.0
        vt = 0.0
        au = 0.0
        av = 0.0
        auv = 0.0
        for k in range(k1 - 1, k0 - 1, -1):
            s = k * step if step > 0 else starts[k]
            if e0 < 0 or s < e0 - nn:
                e0 = (s // nn + 1) * nn
                p0 = e0
                ct = x[e0 - 1]
                a0 = 0.0
                c0 = 0.0
            if e1 < 0 or s < e1 - mm:
                e1 = (s // mm + 1) * mm
                p1 = e1
                ut = x[e1 - 1]
                vt = x[e1 - 1 + lag]
                au = 0.0
                av = 0.0
                auv = 0.0
            if p0 == p1:
                j = p0 - 1
                while j >= s:  # from the block end down: the same order for any step
                    xj = x[UINT(j)]
                    d = xj - ct
                    a0 += d
                    c0 += d * d
                    du = xj - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j -= 1
            else:
                j = p0 - 1
                while j >= s:  # from the block end down: the same order for any step
                    d = x[UINT(j)] - ct
                    a0 += d
                    c0 += d * d
                    j -= 1
                j = p1 - 1
                while j >= s:  # from the block end down: the same order for any step
                    du = x[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j -= 1
            p0 = s
            p1 = s
            t = k - k0
            ga[t] = a0
            gc[t] = c0
            gu[t] = au
            gv[t] = av
            guv[t] = auv
            du0[t] = ut - ct
            dv0[t] = vt - ct
        # ---- heads, forward: plain [e0, s + N) about x[e0 - 1]; pairs [e1, s + M) about
        #      (x[e1 - 1], x[e1 - 1 + lag]): the same anchors as the window's tails
        e0 = -1
        q0 = 0
        a0 = 0.0
        c0 = 0.0
        e1 = -1
        q1 = 0
        au = 0.0
        av = 0.0
        auv = 0.0
        for k in range(k0, k1):
            s = k * step if step > 0 else starts[k]
            if e0 < 0 or s >= e0:
                e0 = (s // nn + 1) * nn
                q0 = e0
                ct = x[e0 - 1]
                a0 = 0.0
                c0 = 0.0
            if e1 < 0 or s >= e1:
                e1 = (s // mm + 1) * mm
                q1 = e1
                ut = x[e1 - 1]
                vt = x[e1 - 1 + lag]
                au = 0.0
                av = 0.0
                auv = 0.0
            r0 = s + nn - q0
            r1 = s + mm - q1
            if r0 == r1:
                i = 0
                while i < r0:
                    d = x[UINT(q0 + i)] - ct
                    a0 += d
                    c0 += d * d
                    j = q1 + i
                    du = x[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    i += 1
            else:
                j = q0
                while j < q0 + r0:
                    d = x[UINT(j)] - ct
                    a0 += d
                    c0 += d * d
                    j += 1
                j = q1
                while j < q1 + r1:
                    du = x[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j += 1
            q0 += r0
            q1 += r1
            t = k - k0
            ha[t] = a0
            hc[t] = c0
            hu[t] = au
            hv[t] = av
            huv[t] = auv
        b, f = _auto_eval(ga, gc, gu, gv, guv, du0, dv0, ha, hc, hu, hv, huv,
                         float(nn), float(mm), out, k0, k1 - k0)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite


@numba.njit(cache=True)
def autocorrelation_sorted(x, lag, window, starts):  # pragma: no cover - compiled
    """Eq. 4.1 for sorted valid starts: ``(values, n_zero_variance)``."""
    out = np.empty(starts.shape[0])
    if lag <= LAG_DIRECT:
        n_bad, _ = auto_small_core(x, lag, window, starts, 0, out)
    else:
        n_bad, _ = _auto_core(x, lag, window, starts, 0, out)
    return out, n_bad


@numba.njit(cache=True)
def autocorrelation_regular(x, lag, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """Eq. 4.1 for the windows ``s_k = k * step``: ``(values, times, n_zero_variance,
    n_nonfinite)``, the last counting windows whose sums are not finite (NaN/inf input)."""
    buf = np.empty((2, n_win))
    if lag <= LAG_DIRECT:
        n_bad, n_nonfinite = auto_small_core(x, lag, window, NO_STARTS, step, buf[0])
    else:
        n_bad, n_nonfinite = _auto_core(x, lag, window, NO_STARTS, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite


@numba.njit(cache=True, error_model="numpy")
def _cross_eval(gay, gcy, gax, gcx, gu, gv, guv, du0, dv0, hay, hcy, hax, hcx, hu, hv, huv,
                fn, fm, out, o0, cnt, split):  # pragma: no cover - compiled
    """Eq. 4.2 from the tail/head sums of ``cnt`` windows, written to ``out[o0:o0+cnt]``.

    Denominator and returned counts as in :func:`leakdiag.features._kernels.smalllag._cross_small_eval`.
    """
    inv = 1.0 / fn
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    nr = 0  # windows where ss_x * ss_y over- or underflows: redo them with split square roots
    for t in range(cnt):
        ay = gay[t] + hay[t]
        ax = gax[t] + hax[t]
        oy = ay * inv
        ox = ax * inv
        ssy = (gcy[t] + hcy[t]) - ay * oy
        ssx = (gcx[t] + hcx[t]) - ax * ox
        du = du0[t] - oy
        dv = dv0[t] - ox
        num = (guv[t] + huv[t]) + dv * (gu[t] + hu[t]) + du * (gv[t] + hv[t]) + fm * du * dv
        ok = (ssy > 0.0) & (ssx > 0.0)
        pr = ssx * ssy
        den = np.sqrt(ssx) * np.sqrt(ssy) if split else np.sqrt(pr)
        out[o0 + t] = num / den if ok else np.nan
        bad += 0 if ok else 1
        nf += 0 if (ssx - ssx == 0.0) & (ssy - ssy == 0.0) else 1
        nr += 0 if (pr > PRODUCT_MIN) & (pr < PRODUCT_MAX) | ~ok else 1
    return bad, nf, nr


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def _cross_core(y, x, lag, window, starts, step, out):  # pragma: no cover - compiled
    """Eq. 4.2, ``y_j`` with ``x_{j+lag}``, for regular or sorted starts (as :func:`_auto_core`).

    Two plain-sum structures (``y`` about ``y[e0 - 1]``, ``x`` about ``x[e0 - 1]``, blocks of
    ``N``) and the pair structure ``(y_j, x_{j+lag})`` about ``(y[e1 - 1], x[e1 - 1 + lag])``.
    The value is ``num / (sqrt(ss_x) sqrt(ss_y))``: the ``1/N`` of Eq. 4.2 cancels against the
    population variances. Returns the numbers of windows where ``x`` or ``y`` has zero
    variance and of windows whose sums are not finite (NaN/inf input).
    """
    nn = window
    mm = window - lag
    n_win = out.shape[0]
    kc = max(1, min(CHUNK, n_win))
    gay = np.empty(kc)
    gcy = np.empty(kc)
    gax = np.empty(kc)
    gcx = np.empty(kc)
    gu = np.empty(kc)
    gv = np.empty(kc)
    guv = np.empty(kc)
    du0 = np.empty(kc)
    dv0 = np.empty(kc)
    hay = np.empty(kc)
    hcy = np.empty(kc)
    hax = np.empty(kc)
    hcx = np.empty(kc)
    hu = np.empty(kc)
    hv = np.empty(kc)
    huv = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        # ---- tails, backward
        e0 = -1
        p0 = 0
        cty = 0.0
        ctx = 0.0
        ay = 0.0
        cy = 0.0
        ax = 0.0
        cx = 0.0
        e1 = -1
        p1 = 0
        ut = 0.0
        vt = 0.0
        au = 0.0
        av = 0.0
        auv = 0.0
        for k in range(k1 - 1, k0 - 1, -1):
            s = k * step if step > 0 else starts[k]
            if e0 < 0 or s < e0 - nn:
                e0 = (s // nn + 1) * nn
                p0 = e0
                cty = y[e0 - 1]
                ctx = x[e0 - 1]
                ay = 0.0
                cy = 0.0
                ax = 0.0
                cx = 0.0
            if e1 < 0 or s < e1 - mm:
                e1 = (s // mm + 1) * mm
                p1 = e1
                ut = y[e1 - 1]
                vt = x[e1 - 1 + lag]
                au = 0.0
                av = 0.0
                auv = 0.0
            if p0 == p1:
                j = p0 - 1
                while j >= s:  # from the block end down: the same order for any step
                    yj = y[UINT(j)]
                    d = yj - cty
                    ay += d
                    cy += d * d
                    d = x[UINT(j)] - ctx
                    ax += d
                    cx += d * d
                    du = yj - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j -= 1
            else:
                j = p0 - 1
                while j >= s:  # from the block end down: the same order for any step
                    d = y[UINT(j)] - cty
                    ay += d
                    cy += d * d
                    d = x[UINT(j)] - ctx
                    ax += d
                    cx += d * d
                    j -= 1
                j = p1 - 1
                while j >= s:  # from the block end down: the same order for any step
                    du = y[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j -= 1
            p0 = s
            p1 = s
            t = k - k0
            gay[t] = ay
            gcy[t] = cy
            gax[t] = ax
            gcx[t] = cx
            gu[t] = au
            gv[t] = av
            guv[t] = auv
            du0[t] = ut - cty
            dv0[t] = vt - ctx
        # ---- heads, forward (same anchors as the window's tails)
        e0 = -1
        q0 = 0
        ay = 0.0
        cy = 0.0
        ax = 0.0
        cx = 0.0
        e1 = -1
        q1 = 0
        au = 0.0
        av = 0.0
        auv = 0.0
        for k in range(k0, k1):
            s = k * step if step > 0 else starts[k]
            if e0 < 0 or s >= e0:
                e0 = (s // nn + 1) * nn
                q0 = e0
                cty = y[e0 - 1]
                ctx = x[e0 - 1]
                ay = 0.0
                cy = 0.0
                ax = 0.0
                cx = 0.0
            if e1 < 0 or s >= e1:
                e1 = (s // mm + 1) * mm
                q1 = e1
                ut = y[e1 - 1]
                vt = x[e1 - 1 + lag]
                au = 0.0
                av = 0.0
                auv = 0.0
            r0 = s + nn - q0
            r1 = s + mm - q1
            if r0 == r1:
                i = 0
                while i < r0:
                    j = q0 + i
                    d = y[UINT(j)] - cty
                    ay += d
                    cy += d * d
                    d = x[UINT(j)] - ctx
                    ax += d
                    cx += d * d
                    j = q1 + i
                    du = y[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    i += 1
            else:
                j = q0
                while j < q0 + r0:
                    d = y[UINT(j)] - cty
                    ay += d
                    cy += d * d
                    d = x[UINT(j)] - ctx
                    ax += d
                    cx += d * d
                    j += 1
                j = q1
                while j < q1 + r1:
                    du = y[UINT(j)] - ut
                    dv = x[UINT(j + lag)] - vt
                    au += du
                    av += dv
                    auv += du * dv
                    j += 1
            q0 += r0
            q1 += r1
            t = k - k0
            hay[t] = ay
            hcy[t] = cy
            hax[t] = ax
            hcx[t] = cx
            hu[t] = au
            hv[t] = av
            huv[t] = auv
        b, f, r = _cross_eval(gay, gcy, gax, gcx, gu, gv, guv, du0, dv0, hay, hcy, hax, hcx,
                             hu, hv, huv, float(nn), float(mm), out, k0, k1 - k0, False)
        if r > 0:
            _cross_eval(gay, gcy, gax, gcx, gu, gv, guv, du0, dv0, hay, hcy, hax, hcx,
                        hu, hv, huv, float(nn), float(mm), out, k0, k1 - k0, True)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite


@numba.njit(cache=True)
def cross_correlation_sorted(y, x, lag, window, starts):  # pragma: no cover - compiled
    """Eq. 4.2 for sorted valid starts: ``(values, n_degenerate)``."""
    out = np.empty(starts.shape[0])
    if lag <= LAG_DIRECT:
        n_bad, _ = cross_small_core(y, x, lag, window, starts, 0, out)
    else:
        n_bad, _ = _cross_core(y, x, lag, window, starts, 0, out)
    return out, n_bad


@numba.njit(cache=True)
def cross_correlation_regular(y, x, lag, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """Eq. 4.2 for the windows ``s_k = k * step``: ``(values, times, n_degenerate,
    n_nonfinite)``, the last counting windows whose sums are not finite (NaN/inf input)."""
    buf = np.empty((2, n_win))
    if lag <= LAG_DIRECT:
        n_bad, n_nonfinite = cross_small_core(y, x, lag, window, NO_STARTS, step, buf[0])
    else:
        n_bad, n_nonfinite = _cross_core(y, x, lag, window, NO_STARTS, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite
