"""Numba kernels for Eq. 4.1 and 4.2 at short lags: one block structure, fewer running sums.

The general kernels (:mod:`leakdiag.features._kernels.blocksums`) keep two block structures per
window: plain sums over the ``N`` samples (blocks of ``N``) and lagged-pair sums over the
``M = N - lag`` pairs (blocks of ``M``). For a short lag (``lag <= LAG_DIRECT``) everything can
live on the pair blocks alone, because a window's ``N`` samples are its ``M`` pair heads
``[s, s + M)`` plus its last ``lag`` samples ``[s + M, s + N)``:

* Eq. 4.1, anchors ``(ut, vt) = (x[e-1], x[e-1+lag])`` of the pair block holding ``s`` (both
  samples of the window). Running sums over the pairs ``j``: ``U1 = sum (x_j - ut)``,
  ``U2 = sum (x_j - ut)^2``, ``P = sum (x_j - ut)(x_{j+lag} - vt)``. With ``F1`` the sum of
  ``x - ut`` over the first ``lag`` samples and ``L1, L2`` the sums of ``x - ut`` and its square
  over the last ``lag`` samples: ``A = U1 + L1``, ``C = U2 + L2`` about ``ut`` for the whole
  window, and ``V1 = sum (x_{j+lag} - vt) = U1 - F1 + L1 + M (ut - vt)``.
* Eq. 4.2, anchors ``(uy, vx) = (y[e-1], x[e-1+lag])``. Running sums ``Y1, Y2`` of
  ``a_j = y_j - uy``, ``X1, X2`` of ``b_j = x_{j+lag} - vx`` and ``P = sum a_j b_j``; ``y``'s
  window adds its last ``lag`` samples, ``x``'s its first ``lag`` samples.

Three running sums instead of five for Eq. 4.1, five instead of seven for Eq. 4.2, and one block
check per window instead of two. The ``lag``-sample edge sums cost O(lag) per window, which is
why this path is limited to ``lag <= LAG_DIRECT``; the backward pass forms them with scalar loads
(one sample each for ``lag = 1``; gathering them in the vectorised loop was slower). Tails and heads are grown in a backward and a forward pass
exactly as in :mod:`leakdiag.features._kernels.blocksums`, every sum holds samples of the window only,
as deviations from a sample of the window, so the accuracy is that of the general kernels.
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features._kernels.chunks import CHUNK, UINT
from leakdiag.features._kernels.values import auto_value, cross_value

__all__ = ["LAG_DIRECT", "auto_small_core", "cross_small_core"]

LAG_DIRECT = 8  # longest lag summed directly at the window edges (O(lag) per window)


@numba.njit(cache=True, error_model="numpy")
def _auto_small_eval(gu, g2, gp, hu, h2, hp, uta, vta, f1, l1, l2, fn, fm, out, o0, cnt):  # pragma: no cover - compiled
    """Eq. 4.1 from the pair-block sums and edge sums of ``cnt`` windows into ``out[o0:]``."""
    inv = 1.0 / fn
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    for t in range(cnt):
        v, b, f = auto_value(gu[t] + hu[t], g2[t] + h2[t], gp[t] + hp[t], f1[t], l1[t], l2[t],
                             vta[t] - uta[t], inv, fm)
        out[o0 + t] = v
        bad += b
        nf += f
    return bad, nf


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def auto_small_core(x, lag, window, starts, step, out):  # pragma: no cover - compiled
    """Eq. 4.1 for ``lag <= LAG_DIRECT``, windows ``k * step`` (``step > 0``) or sorted ``starts``.

    Returns the numbers of zero-variance windows (their values are NaN) and of windows whose
    sums are not finite (NaN/inf input).
    """
    mm = window - lag
    n_win = out.shape[0]
    kc = max(1, min(CHUNK, n_win))
    gu = np.empty(kc)
    g2 = np.empty(kc)
    gp = np.empty(kc)
    hu = np.empty(kc)
    h2 = np.empty(kc)
    hp = np.empty(kc)
    uta = np.empty(kc)
    vta = np.empty(kc)
    f1 = np.empty(kc)
    l1 = np.empty(kc)
    l2 = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        # ---- tails [s, e), backward
        e = -1
        p = 0
        ut = 0.0
        vt = 0.0
        au = 0.0
        a2 = 0.0
        ap = 0.0
        for k in range(k1 - 1, k0 - 1, -1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s < e - mm:
                e = (s // mm + 1) * mm
                p = e
                ut = x[e - 1]
                vt = x[e - 1 + lag]
                au = 0.0
                a2 = 0.0
                ap = 0.0
            j = p - 1
            while j >= s:  # from the block end down: the same order for any step
                du = x[UINT(j)] - ut
                au += du
                a2 += du * du
                ap += du * (x[UINT(j + lag)] - vt)
                j -= 1
            p = s
            t = k - k0
            gu[t] = au
            g2[t] = a2
            gp[t] = ap
            uta[t] = ut
            vta[t] = vt
            # edges: x - ut over the first lag samples (f1) and the last lag samples (l1, l2)
            if lag == 1:
                f1[t] = x[UINT(s)] - ut
                d = x[UINT(s + mm)] - ut
                l1[t] = d
                l2[t] = d * d
            else:
                fs = 0.0
                ls = 0.0
                l2e = 0.0
                i = 0
                while i < lag:
                    fs += x[UINT(s + i)] - ut
                    d = x[UINT(s + mm + i)] - ut
                    ls += d
                    l2e += d * d
                    i += 1
                f1[t] = fs
                l1[t] = ls
                l2[t] = l2e
        # ---- heads [e, s + M) about the same anchors, forward
        e = -1
        q = 0
        au = 0.0
        a2 = 0.0
        ap = 0.0
        for k in range(k0, k1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s >= e:
                e = (s // mm + 1) * mm
                q = e
                ut = x[e - 1]
                vt = x[e - 1 + lag]
                au = 0.0
                a2 = 0.0
                ap = 0.0
            j = q
            while j < s + mm:
                du = x[UINT(j)] - ut
                au += du
                a2 += du * du
                ap += du * (x[UINT(j + lag)] - vt)
                j += 1
            q = s + mm
            t = k - k0
            hu[t] = au
            h2[t] = a2
            hp[t] = ap
        b, f = _auto_small_eval(gu, g2, gp, hu, h2, hp, uta, vta, f1, l1, l2,
                               float(window), float(mm), out, k0, k1 - k0)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite


@numba.njit(cache=True, error_model="numpy")
def _cross_small_eval(gy1, gy2, gx1, gx2, gp, hy1, hy2, hx1, hx2, hp, ly1, ly2, fx1, fx2,
                      fn, fm, out, o0, cnt, split):  # pragma: no cover - compiled
    """Eq. 4.2 (:func:`cross_value`) from the pair-block and edge sums of ``cnt`` windows into
    ``out[o0:]``; returns the zero-variance, non-finite and out-of-range counts."""
    inv = 1.0 / fn
    bad = 0
    nf = 0  # windows whose sums are not finite: NaN or inf in the input
    nr = 0  # windows where ss_x * ss_y over- or underflows: redo them with split square roots
    for t in range(cnt):
        v, b, f, r = cross_value(gy1[t] + hy1[t], gx1[t] + hx1[t], gy2[t] + hy2[t],
                                 gx2[t] + hx2[t], gp[t] + hp[t], ly1[t], ly2[t], fx1[t], fx2[t],
                                 inv, fm, split)
        out[o0 + t] = v
        bad += b
        nf += f
        nr += r
    return bad, nf, nr


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def cross_small_core(y, x, lag, window, starts, step, out):  # pragma: no cover - compiled
    """Eq. 4.2 (``y_j`` with ``x_{j+lag}``) for ``lag <= LAG_DIRECT``, regular or sorted starts.

    Returns the numbers of windows where ``x`` or ``y`` has zero variance and of windows
    whose sums are not finite (NaN/inf input).
    """
    mm = window - lag
    n_win = out.shape[0]
    kc = max(1, min(CHUNK, n_win))
    gy1 = np.empty(kc)
    gy2 = np.empty(kc)
    gx1 = np.empty(kc)
    gx2 = np.empty(kc)
    gp = np.empty(kc)
    hy1 = np.empty(kc)
    hy2 = np.empty(kc)
    hx1 = np.empty(kc)
    hx2 = np.empty(kc)
    hp = np.empty(kc)
    ly1 = np.empty(kc)
    ly2 = np.empty(kc)
    fx1 = np.empty(kc)
    fx2 = np.empty(kc)
    n_bad = 0
    n_nonfinite = 0
    for k0 in range(0, n_win, kc):
        k1 = min(k0 + kc, n_win)
        # ---- tails [s, e), backward
        e = -1
        p = 0
        uy = 0.0
        vx = 0.0
        ay1 = 0.0
        ay2 = 0.0
        ax1 = 0.0
        ax2 = 0.0
        ap = 0.0
        for k in range(k1 - 1, k0 - 1, -1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s < e - mm:
                e = (s // mm + 1) * mm
                p = e
                uy = y[e - 1]
                vx = x[e - 1 + lag]
                ay1 = 0.0
                ay2 = 0.0
                ax1 = 0.0
                ax2 = 0.0
                ap = 0.0
            j = p - 1
            while j >= s:  # from the block end down: the same order for any step
                a = y[UINT(j)] - uy
                b = x[UINT(j + lag)] - vx
                ay1 += a
                ay2 += a * a
                ax1 += b
                ax2 += b * b
                ap += a * b
                j -= 1
            p = s
            t = k - k0
            gy1[t] = ay1
            gy2[t] = ay2
            gx1[t] = ax1
            gx2[t] = ax2
            gp[t] = ap
            # edges: y - uy over y's last lag samples, x - vx over x's first lag samples
            if lag == 1:
                d = y[UINT(s + mm)] - uy
                ly1[t] = d
                ly2[t] = d * d
                d = x[UINT(s)] - vx
                fx1[t] = d
                fx2[t] = d * d
            else:
                sy1 = 0.0
                sy2 = 0.0
                sx1 = 0.0
                sx2 = 0.0
                i = 0
                while i < lag:
                    d = y[UINT(s + mm + i)] - uy
                    sy1 += d
                    sy2 += d * d
                    d = x[UINT(s + i)] - vx
                    sx1 += d
                    sx2 += d * d
                    i += 1
                ly1[t] = sy1
                ly2[t] = sy2
                fx1[t] = sx1
                fx2[t] = sx2
        # ---- heads [e, s + M) about the same anchors, forward
        e = -1
        q = 0
        ay1 = 0.0
        ay2 = 0.0
        ax1 = 0.0
        ax2 = 0.0
        ap = 0.0
        for k in range(k0, k1):
            s = k * step if step > 0 else starts[k]
            if e < 0 or s >= e:
                e = (s // mm + 1) * mm
                q = e
                uy = y[e - 1]
                vx = x[e - 1 + lag]
                ay1 = 0.0
                ay2 = 0.0
                ax1 = 0.0
                ax2 = 0.0
                ap = 0.0
            j = q
            while j < s + mm:
                a = y[UINT(j)] - uy
                b = x[UINT(j + lag)] - vx
                ay1 += a
                ay2 += a * a
                ax1 += b
                ax2 += b * b
                ap += a * b
                j += 1
            q = s + mm
            t = k - k0
            hy1[t] = ay1
            hy2[t] = ay2
            hx1[t] = ax1
            hx2[t] = ax2
            hp[t] = ap
        b, f, r = _cross_small_eval(gy1, gy2, gx1, gx2, gp, hy1, hy2, hx1, hx2, hp, ly1, ly2,
                                   fx1, fx2, float(window), float(mm), out, k0, k1 - k0, False)
        if r > 0:
            _cross_small_eval(gy1, gy2, gx1, gx2, gp, hy1, hy2, hx1, hx2, hp, ly1, ly2,
                              fx1, fx2, float(window), float(mm), out, k0, k1 - k0, True)
        n_bad += b
        n_nonfinite += f
    return n_bad, n_nonfinite
