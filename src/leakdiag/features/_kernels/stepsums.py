"""Numba kernels for regular windows at short steps: block sums grown by step increments.

For the features' own windows ``s_k = k * step`` with ``2 <= step <= STEP_MAX`` (overlaps of
about 96-99 % at N = 200), the kernels of :mod:`leakdiag.features._kernels.smalllag`,
:mod:`leakdiag.features.moments` and :mod:`leakdiag.features.metric_length` spend most of their
time on per-window work: each window adds only ``step`` terms to each running sum. Here the
same anchored block sums (``docs/features.md``, "Numerical method") are formed in two steps per
block of ``M`` terms:

1. **Increments.** The sum of each quantity over the ``step`` terms between consecutive window
   starts, for every window of the block, about the block's anchor. This loop has no
   dependency between windows, and with ``step`` a compile-time constant (one copy of the loop
   per step ``2 .. STEP_MAX``, chosen at run time) LLVM vectorises it with interleaved loads.
   Two more conditions keep it vectorising: unsigned indices (``UINT``; Numba's negative-index
   wraparound on signed ones blocks it), and few arrays per loop (each is a run-time overlap
   check, and past about eight LLVM gives up): hence heads added into the tail arrays in place,
   the lag edges in loops of their own, and for lag 1 the edge squares computed, not stored.
2. **Scans.** Tails ``[s, e)`` are the suffix sums of the increments down from the block end,
   heads ``[e, s + M)`` the prefix sums up from the block end (the partial first head and last
   tail are summed term by term); one add per window and quantity.

Every sum still holds only terms of the window, as deviations from a term of the window: the
accuracy argument is the one of the per-term kernels. The order of the additions differs (``step``
terms are added together first), so the values differ from the per-term kernels and from
``every[::step]`` of the ``*_at`` functions in the last bits (tested to 1e-12). The per-window
formula is the per-term kernels' own (the inline functions ``auto_value``, ``cross_value``,
``moment_values``), evaluated per block. Cost at N = 200 against the per-term kernels
(interleaved A/B in ``docs/features.md``): 0.4x (metric length, step 2), 0.6x
(autocorrelation, step 2), 0.7-0.75x (cross-correlation at steps 4-5, moments at step 4); the
cross-correlation at step 2 is as fast either way.

The block loop is written out in each kernel, as in the other kernel modules: the quantities
differ per feature, and Numba helper calls that take arrays pay reference counting (the helpers
here are inlined). The step dispatchers (``_*_incs``, ``_edges``) are written out too: one
generic dispatcher taking the loop as a function argument needs ``*args``, which Numba's
inliner does not take, and without inlining the step is no longer a constant (3x slower).
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.features._kernels.chunks import UINT, fill_times
from leakdiag.features._kernels.smalllag import LAG_DIRECT
from leakdiag.features._kernels.values import auto_value, cross_value, moment_values

__all__ = ["STEP_MAX", "use_step_kernels", "auto_small_steps", "cross_small_steps",
           "moments_steps", "metric_steps", "autocorrelation_steps_regular",
           "cross_correlation_steps_regular", "moments_steps_regular", "metric_steps_regular"]

STEP_MAX = 8  # longest step with its own compiled increment loop (constant stride)


def use_step_kernels(step: int, lag: int = 0) -> bool:
    """Whether the regular windows of ``step`` (and, for Eq. 4.1/4.2, ``lag``) go to these kernels.

    The wrappers decide in Python, so that these kernels, whose eight copies of each loop take
    about 15 s to compile once (then cached on disk), compile only when such a step is used.

    Parameters
    ----------
    step : int
        Samples between window starts.
    lag : int, default 0
        Lag of Eq. 4.1/4.2 in samples (0 for the metric length and the moments).

    Returns
    -------
    bool
        ``2 <= step <= STEP_MAX`` and ``lag <= LAG_DIRECT``.

    Examples
    --------
    >>> [use_step_kernels(2, lag=1), use_step_kernels(1), use_step_kernels(190)]
    [True, False, False]
    >>> use_step_kernels(2, lag=40)  # long lags: the general kernels
    False
    """
    return 2 <= step <= STEP_MAX and lag <= LAG_DIRECT


# ---------------------------------------------------------------- lag edge sums
@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _edge1_h(z, j0, c, h, cnt, s1, s2):  # pragma: no cover - compiled
    """``s1[t] = z[j0 + t h] - c`` and ``s2[t] = s1[t]^2`` for ``t < cnt`` (lag 1)."""
    for t in range(cnt):
        d = z[UINT(j0 + t * h)] - c
        s1[t] = d
        s2[t] = d * d


@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _edges(z, j0, c, lag, h, cnt, s1, s2):  # pragma: no cover - compiled
    """``s1[t], s2[t]`` for ``t < cnt``: sums of ``z_j - c`` and its square over the ``lag``
    samples ``j = j0 + t h + i``, ``i < lag``. For lag 1 (the thesis's setting) a loop per
    compile-time step; longer lags loop over ``i`` inside, which LLVM does not vectorise anyway."""
    if lag == 1:
        if h == 2:
            _edge1_h(z, j0, c, 2, cnt, s1, s2)
        elif h == 3:
            _edge1_h(z, j0, c, 3, cnt, s1, s2)
        elif h == 4:
            _edge1_h(z, j0, c, 4, cnt, s1, s2)
        elif h == 5:
            _edge1_h(z, j0, c, 5, cnt, s1, s2)
        elif h == 6:
            _edge1_h(z, j0, c, 6, cnt, s1, s2)
        elif h == 7:
            _edge1_h(z, j0, c, 7, cnt, s1, s2)
        elif h == 8:
            _edge1_h(z, j0, c, 8, cnt, s1, s2)
        else:
            _edge1_h(z, j0, c, h, cnt, s1, s2)
    else:
        for t in range(cnt):
            a1 = 0.0
            a2 = 0.0
            for i in range(lag):
                d = z[UINT(j0 + t * h + i)] - c
                a1 += d
                a2 += d * d
            s1[t] = a1
            s2[t] = a2


# ---------------------------------------------------------------- Eq. 4.1, lag <= LAG_DIRECT
@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _auto_incs_h(x, j0, lag, ut, vt, h, cnt, g0, g1, g2):  # pragma: no cover - compiled
    """``g0[t], g1[t], g2[t]`` for ``t < cnt``: sums over ``i < h`` of ``u = x_j - ut``, ``u^2``
    and ``u (x_{j+lag} - vt)``, ``j = j0 + t h + i``."""
    for t in range(cnt):
        su = 0.0
        s2 = 0.0
        sp = 0.0
        for i in range(h):
            j = UINT(j0 + t * h + i)
            u = x[j] - ut
            su += u
            s2 += u * u
            sp += u * (x[j + UINT(lag)] - vt)
        g0[t] = su
        g1[t] = s2
        g2[t] = sp


@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _auto_incs(x, j0, lag, ut, vt, h, cnt, g0, g1, g2):  # pragma: no cover - compiled
    """:func:`_auto_incs_h` with the step a compile-time constant for ``h <= STEP_MAX``."""
    if h == 2:
        _auto_incs_h(x, j0, lag, ut, vt, 2, cnt, g0, g1, g2)
    elif h == 3:
        _auto_incs_h(x, j0, lag, ut, vt, 3, cnt, g0, g1, g2)
    elif h == 4:
        _auto_incs_h(x, j0, lag, ut, vt, 4, cnt, g0, g1, g2)
    elif h == 5:
        _auto_incs_h(x, j0, lag, ut, vt, 5, cnt, g0, g1, g2)
    elif h == 6:
        _auto_incs_h(x, j0, lag, ut, vt, 6, cnt, g0, g1, g2)
    elif h == 7:
        _auto_incs_h(x, j0, lag, ut, vt, 7, cnt, g0, g1, g2)
    elif h == 8:
        _auto_incs_h(x, j0, lag, ut, vt, 8, cnt, g0, g1, g2)
    else:
        _auto_incs_h(x, j0, lag, ut, vt, h, cnt, g0, g1, g2)


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def auto_small_steps(x, lag, window, step, out):  # pragma: no cover - compiled
    """Eq. 4.1 for ``lag <= LAG_DIRECT`` and the windows ``s_k = k * step``, ``step >= 2``.

    Pair blocks of ``M = N - lag``, anchors ``(ut, vt) = (x[e-1], x[e-1+lag])`` and edge sums
    as :func:`leakdiag.features._kernels.smalllag.auto_small_core`, formula :func:`auto_value`.
    Returns the numbers of zero-variance windows and of windows whose sums are not finite.
    """
    mm = window - lag
    h = step
    n_win = out.shape[0]
    nb = mm // h + 2  # windows per block, at most
    inc0 = np.empty(nb)  # increments of the current block (tails, then heads)
    inc1 = np.empty(nb)
    inc2 = np.empty(nb)
    gu = np.empty(nb)  # tails [s, e), then window sums: u = x_j - ut, u^2, u (x_{j+lag} - vt)
    g2 = np.empty(nb)
    gp = np.empty(nb)
    f1 = np.empty(nb)  # lag edges
    f2 = np.empty(nb)
    l1 = np.empty(nb)
    l2 = np.empty(nb)
    inv = 1.0 / window
    fm = float(mm)
    n_bad = 0
    n_nonfinite = 0
    k = 0
    while k < n_win:
        s0 = k * h
        e = (s0 // mm + 1) * mm
        cnt = min(n_win, (e - 1) // h + 1) - k  # windows of this block
        ut = x[e - 1]
        vt = x[e - 1 + lag]
        # tails: the last window's [s, e) term by term, the others' increments summed down
        last = s0 + (cnt - 1) * h
        su = 0.0
        s2 = 0.0
        sp = 0.0
        for i in range(e - last):
            j = UINT(last + i)
            u = x[j] - ut
            su += u
            s2 += u * u
            sp += u * (x[j + UINT(lag)] - vt)
        gu[cnt - 1] = su
        g2[cnt - 1] = s2
        gp[cnt - 1] = sp
        _auto_incs(x, s0, lag, ut, vt, h, cnt - 1, inc0, inc1, inc2)
        for i in range(cnt - 1):
            t = cnt - 2 - i
            su += inc0[t]
            s2 += inc1[t]
            sp += inc2[t]
            gu[t] = su
            g2[t] = s2
            gp[t] = sp
        # heads [e, s + M): the first window's term by term, the others' increments summed up,
        # each added to its window's tail (the tails arrays then hold the window sums)
        su = 0.0
        s2 = 0.0
        sp = 0.0
        for i in range(s0 + mm - e):
            j = UINT(e + i)
            u = x[j] - ut
            su += u
            s2 += u * u
            sp += u * (x[j + UINT(lag)] - vt)
        _auto_incs(x, s0 + mm, lag, ut, vt, h, cnt - 1, inc0, inc1, inc2)
        for t in range(cnt):
            if t > 0:
                su += inc0[t - 1]
                s2 += inc1[t - 1]
                sp += inc2[t - 1]
            gu[t] += su
            g2[t] += s2
            gp[t] += sp
        # lag edges: x - ut over the first and the last lag samples of each window
        _edges(x, s0, ut, lag, h, cnt, f1, f2)
        _edges(x, s0 + mm, ut, lag, h, cnt, l1, l2)
        # evaluation (a loop of its own, so that it vectorises)
        dvt = vt - ut
        for t in range(cnt):
            v, b, f = auto_value(gu[t], g2[t], gp[t], f1[t], l1[t], l2[t], dvt, inv, fm)
            out[k + t] = v
            n_bad += b
            n_nonfinite += f
        k += cnt
    return n_bad, n_nonfinite


# ---------------------------------------------------------------- Eq. 4.2, lag <= LAG_DIRECT
@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _cross_incs_h(y, x, j0, lag, uy, vx, h, cnt, inc):  # pragma: no cover - compiled
    """``inc[5 t .. 5 t + 4]`` for ``t < cnt``: sums over ``i < h`` of ``a = y_j - uy``, ``a^2``,
    ``b = x_{j+lag} - vx``, ``b^2`` and ``a b``, ``j = j0 + t h + i`` (one interleaved output
    array: one run-time overlap check instead of five)."""
    for t in range(cnt):
        sa = 0.0
        saa = 0.0
        sb = 0.0
        sbb = 0.0
        sab = 0.0
        for i in range(h):
            j = UINT(j0 + t * h + i)
            a = y[j] - uy
            b = x[j + UINT(lag)] - vx
            sa += a
            saa += a * a
            sb += b
            sbb += b * b
            sab += a * b
        inc[5 * t] = sa
        inc[5 * t + 1] = saa
        inc[5 * t + 2] = sb
        inc[5 * t + 3] = sbb
        inc[5 * t + 4] = sab


@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _cross_incs(y, x, j0, lag, uy, vx, h, cnt, inc):  # pragma: no cover - compiled
    """:func:`_cross_incs_h` with the step a compile-time constant for ``h <= STEP_MAX``."""
    if h == 2:
        _cross_incs_h(y, x, j0, lag, uy, vx, 2, cnt, inc)
    elif h == 3:
        _cross_incs_h(y, x, j0, lag, uy, vx, 3, cnt, inc)
    elif h == 4:
        _cross_incs_h(y, x, j0, lag, uy, vx, 4, cnt, inc)
    elif h == 5:
        _cross_incs_h(y, x, j0, lag, uy, vx, 5, cnt, inc)
    elif h == 6:
        _cross_incs_h(y, x, j0, lag, uy, vx, 6, cnt, inc)
    elif h == 7:
        _cross_incs_h(y, x, j0, lag, uy, vx, 7, cnt, inc)
    elif h == 8:
        _cross_incs_h(y, x, j0, lag, uy, vx, 8, cnt, inc)
    else:
        _cross_incs_h(y, x, j0, lag, uy, vx, h, cnt, inc)


@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _cross_terms(y, x, j0, lag, uy, vx, cnt):  # pragma: no cover - compiled
    """Sums of ``a, a^2, b, b^2, a b`` over the ``cnt`` pairs from ``j0`` up, one at a time."""
    sa = 0.0
    saa = 0.0
    sb = 0.0
    sbb = 0.0
    sab = 0.0
    for i in range(cnt):
        j = UINT(j0 + i)
        a = y[j] - uy
        b = x[j + UINT(lag)] - vx
        sa += a
        saa += a * a
        sb += b
        sbb += b * b
        sab += a * b
    return sa, saa, sb, sbb, sab


@numba.njit(inline="always", error_model="numpy", fastmath={"contract"})
def _cross_eval_block(ga, gaa, gb, gbb, gab, ly1, ly2, fx1, fx2, lag1, inv, fm, out, k, cnt,
                      split):  # pragma: no cover - compiled
    """:func:`cross_value` for the ``cnt`` windows of one block (window pair sums ``ga .. gab``,
    lag edge sums ``ly1 .. fx2``) into ``out[k:]``; returns the zero-variance, non-finite and
    out-of-range counts. Few arrays on purpose: each one is a run-time overlap check with
    ``out``, and past about eight LLVM does not vectorise the loop."""
    bad = 0
    nf = 0
    nr = 0
    if lag1:  # one edge sample: the squares need not be read
        for t in range(cnt):
            v, b, f, r = cross_value(ga[t], gb[t], gaa[t], gbb[t], gab[t], ly1[t],
                                     ly1[t] * ly1[t], fx1[t], fx1[t] * fx1[t], inv, fm, split)
            out[k + t] = v
            bad += b
            nf += f
            nr += r
    else:
        for t in range(cnt):
            v, b, f, r = cross_value(ga[t], gb[t], gaa[t], gbb[t], gab[t], ly1[t], ly2[t],
                                     fx1[t], fx2[t], inv, fm, split)
            out[k + t] = v
            bad += b
            nf += f
            nr += r
    return bad, nf, nr


@numba.njit(cache=True, error_model="numpy", fastmath={"contract"})
def cross_small_steps(y, x, lag, window, step, out):  # pragma: no cover - compiled
    """Eq. 4.2 (``y_j`` with ``x_{j+lag}``) for ``lag <= LAG_DIRECT`` and the windows
    ``s_k = k * step``, ``step >= 2``.

    Pair blocks, anchors ``(uy, vx) = (y[e-1], x[e-1+lag])`` and edge sums as
    :func:`leakdiag.features._kernels.smalllag.cross_small_core`, formula :func:`cross_value`. Returns
    the numbers of windows with a zero variance and of windows whose sums are not finite.
    """
    mm = window - lag
    h = step
    n_win = out.shape[0]
    nb = mm // h + 2  # windows per block, at most
    inc = np.empty(5 * nb)  # increments of the current block (tails, then heads)
    ga = np.empty(nb)  # tails [s, e), then window sums: a, a^2, b, b^2, a b
    gaa = np.empty(nb)
    gb = np.empty(nb)
    gbb = np.empty(nb)
    gab = np.empty(nb)
    ly1 = np.empty(nb)  # lag edges
    ly2 = np.empty(nb)
    fx1 = np.empty(nb)
    fx2 = np.empty(nb)
    inv = 1.0 / window
    fm = float(mm)
    n_bad = 0
    n_nonfinite = 0
    k = 0
    while k < n_win:
        s0 = k * h
        e = (s0 // mm + 1) * mm
        cnt = min(n_win, (e - 1) // h + 1) - k  # windows of this block
        uy = y[e - 1]
        vx = x[e - 1 + lag]
        # tails: the last window's [s, e) term by term, the others' increments summed down
        last = s0 + (cnt - 1) * h
        sa, saa, sb, sbb, sab = _cross_terms(y, x, last, lag, uy, vx, e - last)
        ga[cnt - 1] = sa
        gaa[cnt - 1] = saa
        gb[cnt - 1] = sb
        gbb[cnt - 1] = sbb
        gab[cnt - 1] = sab
        _cross_incs(y, x, s0, lag, uy, vx, h, cnt - 1, inc)
        for i in range(cnt - 1):
            t = cnt - 2 - i
            sa += inc[5 * t]
            saa += inc[5 * t + 1]
            sb += inc[5 * t + 2]
            sbb += inc[5 * t + 3]
            sab += inc[5 * t + 4]
            ga[t] = sa
            gaa[t] = saa
            gb[t] = sb
            gbb[t] = sbb
            gab[t] = sab
        # heads: the first window's [e, s + M) term by term, the others' increments summed up,
        # each added to its window's tail (the tails arrays then hold the window sums)
        sa, saa, sb, sbb, sab = _cross_terms(y, x, e, lag, uy, vx, s0 + mm - e)
        _cross_incs(y, x, s0 + mm, lag, uy, vx, h, cnt - 1, inc)
        for t in range(cnt):
            if t > 0:
                sa += inc[5 * t - 5]
                saa += inc[5 * t - 4]
                sb += inc[5 * t - 3]
                sbb += inc[5 * t - 2]
                sab += inc[5 * t - 1]
            ga[t] += sa
            gaa[t] += saa
            gb[t] += sb
            gbb[t] += sbb
            gab[t] += sab
        # evaluation; a block whose ss_x ss_y leaves the double range is redone with two roots
        # lag edges: y - uy over y's last lag samples, x - vx over x's first lag samples
        _edges(y, s0 + mm, uy, lag, h, cnt, ly1, ly2)
        _edges(x, s0, vx, lag, h, cnt, fx1, fx2)
        b, f, r = _cross_eval_block(ga, gaa, gb, gbb, gab, ly1, ly2, fx1, fx2, lag == 1, inv,
                                    fm, out, k, cnt, False)
        if r > 0:
            _cross_eval_block(ga, gaa, gb, gbb, gab, ly1, ly2, fx1, fx2, lag == 1, inv, fm, out,
                              k, cnt, True)
        n_bad += b
        n_nonfinite += f
        k += cnt
    return n_bad, n_nonfinite


# ---------------------------------------------------------------- Eq. 4.11-4.14
@numba.njit(inline="always", error_model="numpy")
def _moment_incs_h(x, j0, ct, h, cnt, g1, g2, g3, g4):  # pragma: no cover - compiled
    """``g1..g4[t]`` for ``t < cnt``: sums over ``i < h`` of ``(x_j - ct)^p``, ``p = 1..4``,
    ``j = j0 + t h + i``."""
    for t in range(cnt):
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        a4 = 0.0
        for i in range(h):
            d = x[UINT(j0 + t * h + i)] - ct
            dd = d * d
            a1 += d
            a2 += dd
            a3 += dd * d
            a4 += dd * dd
        g1[t] = a1
        g2[t] = a2
        g3[t] = a3
        g4[t] = a4


@numba.njit(inline="always", error_model="numpy")
def _moment_incs(x, j0, ct, h, cnt, g1, g2, g3, g4):  # pragma: no cover - compiled
    """:func:`_moment_incs_h` with the step a compile-time constant for ``h <= STEP_MAX``."""
    if h == 2:
        _moment_incs_h(x, j0, ct, 2, cnt, g1, g2, g3, g4)
    elif h == 3:
        _moment_incs_h(x, j0, ct, 3, cnt, g1, g2, g3, g4)
    elif h == 4:
        _moment_incs_h(x, j0, ct, 4, cnt, g1, g2, g3, g4)
    elif h == 5:
        _moment_incs_h(x, j0, ct, 5, cnt, g1, g2, g3, g4)
    elif h == 6:
        _moment_incs_h(x, j0, ct, 6, cnt, g1, g2, g3, g4)
    elif h == 7:
        _moment_incs_h(x, j0, ct, 7, cnt, g1, g2, g3, g4)
    elif h == 8:
        _moment_incs_h(x, j0, ct, 8, cnt, g1, g2, g3, g4)
    else:
        _moment_incs_h(x, j0, ct, h, cnt, g1, g2, g3, g4)


@numba.njit(inline="always", error_model="numpy")
def _moment_terms(x, j0, ct, cnt):  # pragma: no cover - compiled
    """Sums of ``(x_j - ct)^p``, ``p = 1..4``, over ``cnt`` samples from ``j0`` up."""
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    a4 = 0.0
    for i in range(cnt):
        d = x[UINT(j0 + i)] - ct
        dd = d * d
        a1 += d
        a2 += dd
        a3 += dd * d
        a4 += dd * dd
    return a1, a2, a3, a4


@numba.njit(cache=True, error_model="numpy")
def moments_steps(x, window, step, out):  # pragma: no cover - compiled
    """Mean, variance (Eq. 4.12), skewness and kurtosis into the rows of ``out`` for the
    windows ``s_k = k * step``, ``step >= 2``.

    Blocks of ``N`` samples and anchor ``x[e - 1]`` as :func:`leakdiag.features.moments._moment_core`,
    formula :func:`leakdiag.features.moments.moment_values`. Returns the numbers of constant
    windows and of windows whose sums are not finite.
    """
    nn = window
    h = step
    n_win = out.shape[1]
    nb = nn // h + 2  # windows per block, at most
    i1 = np.empty(nb)  # increments of the current block (tails, then heads)
    i2 = np.empty(nb)
    i3 = np.empty(nb)
    i4 = np.empty(nb)
    g1 = np.empty(nb)  # tails [s, e), then window sums of (x - ct)^p
    g2 = np.empty(nb)
    g3 = np.empty(nb)
    g4 = np.empty(nb)
    mean = out[0]
    var = out[1]
    skew = out[2]
    kurt = out[3]
    fn = float(nn)
    inv = 1.0 / fn
    n_bad = 0
    n_nonfinite = 0
    k = 0
    while k < n_win:
        s0 = k * h
        e = (s0 // nn + 1) * nn
        cnt = min(n_win, (e - 1) // h + 1) - k  # windows of this block
        ct = x[e - 1]
        # tails: the last window's [s, e) term by term, the others' increments summed down
        last = s0 + (cnt - 1) * h
        a1, a2, a3, a4 = _moment_terms(x, last, ct, e - last)
        g1[cnt - 1] = a1
        g2[cnt - 1] = a2
        g3[cnt - 1] = a3
        g4[cnt - 1] = a4
        _moment_incs(x, s0, ct, h, cnt - 1, i1, i2, i3, i4)
        for i in range(cnt - 1):
            t = cnt - 2 - i
            a1 += i1[t]
            a2 += i2[t]
            a3 += i3[t]
            a4 += i4[t]
            g1[t] = a1
            g2[t] = a2
            g3[t] = a3
            g4[t] = a4
        # heads [e, s + N): the first window's term by term, the others' increments summed up,
        # each added to its window's tail
        a1, a2, a3, a4 = _moment_terms(x, e, ct, s0 + nn - e)
        _moment_incs(x, s0 + nn, ct, h, cnt - 1, i1, i2, i3, i4)
        for t in range(cnt):
            if t > 0:
                a1 += i1[t - 1]
                a2 += i2[t - 1]
                a3 += i3[t - 1]
                a4 += i4[t - 1]
            g1[t] += a1
            g2[t] += a2
            g3[t] += a3
            g4[t] += a4
        for t in range(cnt):
            m, v, sk, ku, b, f = moment_values(g1[t], g2[t], g3[t], g4[t], ct, fn, inv)
            mean[k + t] = m
            var[k + t] = v
            skew[k + t] = sk
            kurt[k + t] = ku
            n_bad += b
            n_nonfinite += f
        k += cnt
    return n_bad, n_nonfinite


# ---------------------------------------------------------------- Eq. 4.3, one channel
@numba.njit(inline="always", error_model="numpy")
def _metric_incs_h(x, j0, lk, ll, h, cnt, gk, gl):  # pragma: no cover - compiled
    """``gk[t], gl[t]`` for ``t < cnt``: sums over ``i < h`` of ``|x_{j+k} - x_j|`` and
    ``|x_{j+l} - x_j|``, ``j = j0 + t h + i``."""
    for t in range(cnt):
        ak = 0.0
        al = 0.0
        for i in range(h):
            j = UINT(j0 + t * h + i)
            xj = x[j]
            ak += abs(x[j + UINT(lk)] - xj)
            al += abs(x[j + UINT(ll)] - xj)
        gk[t] = ak
        gl[t] = al


@numba.njit(inline="always", error_model="numpy")
def _metric_incs(x, j0, lk, ll, h, cnt, gk, gl):  # pragma: no cover - compiled
    """:func:`_metric_incs_h` with the step a compile-time constant for ``h <= STEP_MAX``."""
    if h == 2:
        _metric_incs_h(x, j0, lk, ll, 2, cnt, gk, gl)
    elif h == 3:
        _metric_incs_h(x, j0, lk, ll, 3, cnt, gk, gl)
    elif h == 4:
        _metric_incs_h(x, j0, lk, ll, 4, cnt, gk, gl)
    elif h == 5:
        _metric_incs_h(x, j0, lk, ll, 5, cnt, gk, gl)
    elif h == 6:
        _metric_incs_h(x, j0, lk, ll, 6, cnt, gk, gl)
    elif h == 7:
        _metric_incs_h(x, j0, lk, ll, 7, cnt, gk, gl)
    elif h == 8:
        _metric_incs_h(x, j0, lk, ll, 8, cnt, gk, gl)
    else:
        _metric_incs_h(x, j0, lk, ll, h, cnt, gk, gl)


@numba.njit(inline="always", error_model="numpy")
def _metric_terms(x, j0, lk, ll, cnt):  # pragma: no cover - compiled
    """Sums of ``|x_{j+k} - x_j|`` and ``|x_{j+l} - x_j|`` over ``cnt`` terms from ``j0`` up."""
    ak = 0.0
    al = 0.0
    for i in range(cnt):
        j = UINT(j0 + i)
        xj = x[j]
        ak += abs(x[j + UINT(lk)] - xj)
        al += abs(x[j + UINT(ll)] - xj)
    return ak, al


@numba.njit(cache=True, error_model="numpy")
def metric_steps(x, l_step, k_step, window, step, out):  # pragma: no cover - compiled
    """Eq. 4.3 for one channel ``x`` (shape ``(n,)``) and the windows ``s_k = k * step``,
    ``step >= 2``.

    Sums over ``j = s .. s+N-l-1`` of ``|x_{j+k} - x_j|`` and ``|x_{j+l} - x_j|`` in blocks of
    ``M = N - l`` terms as :func:`leakdiag.features.metric_length._metric_core` (non-negative
    terms: no anchor). Returns the numbers of windows with a zero denominator and of windows
    whose sums are not finite.
    """
    mm = window - l_step
    h = step
    n_win = out.shape[0]
    nb = mm // h + 2  # windows per block, at most
    ik = np.empty(nb)  # increments of the current block (tails, then heads)
    il = np.empty(nb)
    gk = np.empty(nb)  # tails [s, e), then window sums
    gl = np.empty(nb)
    n_bad = 0
    n_nonfinite = 0
    k = 0
    while k < n_win:
        s0 = k * h
        e = (s0 // mm + 1) * mm
        cnt = min(n_win, (e - 1) // h + 1) - k  # windows of this block
        # tails: the last window's [s, e) term by term, the others' increments summed down
        last = s0 + (cnt - 1) * h
        ak, al = _metric_terms(x, last, k_step, l_step, e - last)
        gk[cnt - 1] = ak
        gl[cnt - 1] = al
        _metric_incs(x, s0, k_step, l_step, h, cnt - 1, ik, il)
        for i in range(cnt - 1):
            t = cnt - 2 - i
            ak += ik[t]
            al += il[t]
            gk[t] = ak
            gl[t] = al
        # heads [e, s + M): the first window's term by term, the others' increments summed up,
        # each added to its window's tail
        ak, al = _metric_terms(x, e, k_step, l_step, s0 + mm - e)
        _metric_incs(x, s0 + mm, k_step, l_step, h, cnt - 1, ik, il)
        for t in range(cnt):
            if t > 0:
                ak += ik[t - 1]
                al += il[t - 1]
            gk[t] += ak
            gl[t] += al
        for t in range(cnt):
            den = gl[t]
            ok = den > 0.0
            out[k + t] = gk[t] / den if ok else np.nan
            n_bad += 0 if ok else 1
            n_nonfinite += 0 if den - den == 0.0 else 1
        k += cnt
    return n_bad, n_nonfinite


# ---------------------------------------------------------------- entry points (values and times)
@numba.njit(cache=True)
def autocorrelation_steps_regular(x, lag, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """As :func:`leakdiag.features._kernels.blocksums.autocorrelation_regular`, computed by
    :func:`auto_small_steps`."""
    buf = np.empty((2, n_win))
    n_bad, n_nonfinite = auto_small_steps(x, lag, window, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite


@numba.njit(cache=True)
def cross_correlation_steps_regular(y, x, lag, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """As :func:`leakdiag.features._kernels.blocksums.cross_correlation_regular`, computed by
    :func:`cross_small_steps`."""
    buf = np.empty((2, n_win))
    n_bad, n_nonfinite = cross_small_steps(y, x, lag, window, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite


@numba.njit(cache=True)
def moments_steps_regular(x, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """As :func:`leakdiag.features.moments._moments_regular`, by :func:`moments_steps`."""
    buf = np.empty((5, n_win))
    n_bad, n_nonfinite = moments_steps(x, window, step, buf[1:])
    fill_times(buf[0], step, window, sample_rate, start_time)
    return buf, n_bad, n_nonfinite


@numba.njit(cache=True)
def metric_steps_regular(x, l_step, k_step, window, step, n_win, sample_rate, start_time):  # pragma: no cover - compiled
    """As :func:`leakdiag.features.metric_length._metric_regular` for one channel ``x`` (shape
    ``(n,)``), by :func:`metric_steps`."""
    buf = np.empty((2, n_win))
    n_bad, n_nonfinite = metric_steps(x, l_step, k_step, window, step, buf[0])
    fill_times(buf[1], step, window, sample_rate, start_time)
    return buf[0], buf[1], n_bad, n_nonfinite
