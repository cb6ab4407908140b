"""Numba kernels of the flow-balance detector (see :mod:`leakdiag.detect.flow_balance`).

The kernels only compute; the wrappers in ``_flow_balance_vca`` / ``_flow_balance_eha``
validate, coerce to C-contiguous float64 and call them. Every integral is the trapezoidal rule
over the samples of a window, so that the window sums of adjacent windows add up exactly.
"""

from __future__ import annotations

import numba
import numpy as np

__all__: list[str] = []


@numba.njit(cache=True)
def _sqrt_reg(dp, ptr):
    # sgn(dp) sqrt(|dp|) with a laminar core below ~ptr (the simulator's regularisation of
    # Eq. 2-2 / 2-4, docs/models.md): dp / (dp^2 + ptr^2)^(1/4); ptr = 0 gives Eq. 2-2 exactly
    if ptr == 0.0:
        return np.sign(dp) * np.sqrt(abs(dp))
    return dp / np.sqrt(np.sqrt(dp * dp + ptr * ptr))


@numba.njit(cache=True)
def spool_positions(u, phi, gamma, kv, offset, drift_per_s, dt, out):
    """Spool position per sample from the held control signal (Table 2-1 valve, exact ZOH).

    ``z_{k+1} = Phi z_k + Gamma (u_k + offset + drift t_k)``, ``z = [x_v, v_v]``; the spool
    starts at its steady state for the first sample. ``Gamma`` includes ``k_v``.
    """
    n = u.shape[0]
    if n == 0:
        return
    u0 = u[0] + offset
    xv = kv * u0
    vv = 0.0
    for k in range(n):
        out[k] = xv
        uk = u[k] + offset + drift_per_s * (k * dt)
        nxv = phi[0, 0] * xv + phi[0, 1] * vv + gamma[0] * uk
        nvv = phi[1, 0] * xv + phi[1, 1] * vv + gamma[1] * uk
        xv = nxv
        vv = nvv


@numba.njit(cache=True)
def vca_window_sums(xv, p1, p2, x, dps, bounds, area, volume, ps, pt, gw, ptr_valve,
                    ptr_leak, laminar, out):
    """Per-window integrals of the VCA flow balance (Eqs. 2-1, 2-2, 2-4/2-5).

    ``out[w]`` = ``[S1, S2, dX, C1, C2, PHI, T, F, PHIABS, QA, QB, DP, SP, -, -, TR1, TR2]``
    (time integrals in sample units, the wrapper multiplies by ``dt``):
    ``S1 = int Q1 dt`` and ``S2 = int Q2 dt`` (valve flows of Eq. 2-2 with flow-gain factor 1,
    ``gw = K_v w``), ``dX = x_end - x_start``, ``C1 = int V1 dP1``, ``C2 = int V2 dP2``,
    ``PHI = int phi(P1 - P2) dt`` (leak-law pressure term), ``T`` window duration and
    ``F = int |Q1 + Q2| / 2 dt`` (flow through the valve, for the error model) and
    ``PHIABS = int |phi(dps)| dt`` (for the mean leak flow; ``dps`` is a smoothed ``P1 - P2``
    so that pressure noise does not inflate it) and ``QA``, ``QB`` the valve flow
    ``(Q1 + Q2) / 2`` at the window's first and last sample (for the end-point error model),
    ``DP = int (P1 - P2) dt`` and ``SP = int (P1 + P2) dt`` (spool-clearance leakage);
    columns 13, 14 are left to the caller; ``TR_i = int G_i(P) dx_v`` with ``Q_i = x_v G_i(P)``
    (Stieltjes sums over the spool increments): a valve that leads its model by ``delta`` (e.g.
    a higher bandwidth) delivers ``delta * TR_i`` more volume, to first order. Window ``w`` runs
    from sample ``bounds[w]`` to ``bounds[w + 1]`` inclusive: adjacent windows share their end sample, so that their sums add
    up to the sums over their union.
    """
    n_win = bounds.shape[0] - 1
    for w in range(n_win):
        i0 = bounds[w]
        window = bounds[w + 1] - i0 + 1
        s1 = 0.0
        s2 = 0.0
        c1 = 0.0
        c2 = 0.0
        phs = 0.0
        pha = 0.0
        pap = 0.0
        fabs = 0.0
        sdp = 0.0
        ssp = 0.0
        q1p = 0.0
        q2p = 0.0
        php = 0.0
        g1p = 0.0
        g2p = 0.0
        tr1 = 0.0
        tr2 = 0.0
        for j in range(window):
            k = i0 + j
            # flow per unit spool opening: Q_i = x_v G_i(P)
            if xv[k] >= 0.0:
                g1 = gw * _sqrt_reg(ps - p1[k], ptr_valve)
                g2 = gw * _sqrt_reg(p2[k] - pt, ptr_valve)
            else:
                g1 = gw * _sqrt_reg(p1[k] - pt, ptr_valve)
                g2 = gw * _sqrt_reg(ps - p2[k], ptr_valve)
            q1 = xv[k] * g1
            q2 = xv[k] * g2
            dp = p1[k] - p2[k]
            if laminar:
                ph = dp
                pa_ = dps[k]
            else:
                ph = _sqrt_reg(dp, ptr_leak)
                pa_ = _sqrt_reg(dps[k], ptr_leak)
            if j == 0:
                out[w, 9] = 0.5 * (q1 + q2)
            if j == window - 1:
                out[w, 10] = 0.5 * (q1 + q2)
            if j > 0:
                dxv = xv[k] - xv[k - 1]
                tr1 += 0.5 * (g1 + g1p) * dxv
                tr2 += 0.5 * (g2 + g2p) * dxv
                s1 += 0.5 * (q1 + q1p)
                s2 += 0.5 * (q2 + q2p)
                phs += 0.5 * (ph + php)
                pha += 0.5 * (abs(pa_) + abs(pap))
                sdp += 0.5 * (p1[k] - p2[k] + p1[k - 1] - p2[k - 1])
                ssp += 0.5 * (p1[k] + p2[k] + p1[k - 1] + p2[k - 1])
                fabs += 0.25 * (abs(q1 + q2) + abs(q1p + q2p))
                v1a = volume + area * x[k - 1]
                v1b = volume + area * x[k]
                v2a = volume - area * x[k - 1]
                v2b = volume - area * x[k]
                c1 += 0.5 * (v1a + v1b) * (p1[k] - p1[k - 1])
                c2 += 0.5 * (v2a + v2b) * (p2[k] - p2[k - 1])
            q1p = q1
            q2p = q2
            g1p = g1
            g2p = g2
            php = ph
            pap = pa_
        out[w, 15] = tr1
        out[w, 16] = tr2
        out[w, 0] = s1
        out[w, 1] = s2
        out[w, 2] = x[i0 + window - 1] - x[i0]
        out[w, 3] = c1
        out[w, 4] = c2
        out[w, 5] = phs
        out[w, 6] = float(window - 1)
        out[w, 7] = fabs
        out[w, 8] = pha
        out[w, 11] = sdp
        out[w, 12] = ssp


@numba.njit(cache=True)
def eha_window_sums(p1, p2, x, w, pa, pb, dps, starts, window, area, volume, ptr_leak, laminar,
                    out):
    """Per-window integrals of the EHA pump-side flow balance (Eqs. 3-6, 3-16 to 3-19, 2-4/2-5).

    ``out[w]`` = ``[TH, dX, CA, CB, dPA, dPB, L, PHI, T, FW, PHIABS, WA, WB]`` (time integrals in
    sample units): ``TH = int omega dt`` (shaft angle), ``dX``, ``CA = int V_A dP_1``,
    ``CB = int V_B dP_2`` (chamber volumes follow the piston), ``dPA``, ``dPB`` line pressure
    changes, ``L = int (P_a - P_b) dt`` (laminar pump leakage), ``PHI = int phi(P1 - P2) dt``,
    ``T`` duration, ``FW = int |omega| dt``, ``PHIABS = int |phi(dps)| dt`` and the speeds at
    the window's first and last samples.
    """
    n_win = starts.shape[0]
    for iw in range(n_win):
        i0 = starts[iw]
        th = 0.0
        ca = 0.0
        cb = 0.0
        lk = 0.0
        phs = 0.0
        pha = 0.0
        fw = 0.0
        php = 0.0
        pap = 0.0
        for j in range(window):
            k = i0 + j
            dp = p1[k] - p2[k]
            if laminar:
                ph = dp
                pa_ = dps[k]
            else:
                ph = _sqrt_reg(dp, ptr_leak)
                pa_ = _sqrt_reg(dps[k], ptr_leak)
            if j > 0:
                th += 0.5 * (w[k] + w[k - 1])
                fw += 0.5 * (abs(w[k]) + abs(w[k - 1]))
                lk += 0.5 * ((pa[k] - pb[k]) + (pa[k - 1] - pb[k - 1]))
                phs += 0.5 * (ph + php)
                pha += 0.5 * (abs(pa_) + abs(pap))
                va = volume + area * 0.5 * (x[k] + x[k - 1])
                vb = volume - area * 0.5 * (x[k] + x[k - 1])
                ca += va * (p1[k] - p1[k - 1])
                cb += vb * (p2[k] - p2[k - 1])
            php = ph
            pap = pa_
        i1 = i0 + window - 1
        out[iw, 0] = th
        out[iw, 1] = x[i1] - x[i0]
        out[iw, 2] = ca
        out[iw, 3] = cb
        out[iw, 4] = pa[i1] - pa[i0]
        out[iw, 5] = pb[i1] - pb[i0]
        out[iw, 6] = lk
        out[iw, 7] = phs
        out[iw, 8] = float(window - 1)
        out[iw, 9] = fw
        out[iw, 10] = pha
        out[iw, 11] = w[i0]
        out[iw, 12] = w[i1]


@numba.njit(cache=True)
def eha_high_side_sums(p1, p2, x, pa, pb, starts, window, area, volume, line_volume, delta,
                       out):
    """Per-window integrals of the EHA's high-side balance (Eqs. 3-16 to 3-19, one side).

    Each sample interval whose mean line pressure difference ``pa - pb`` exceeds ``delta`` in
    size takes the continuity of its *high* line and chamber (line A with chamber 1 for
    ``s = +1``, line B with chamber 2 for ``s = -1``), whose accumulator check valve is shut;
    the others (``g = 0``) take the two-side balance of :func:`eha_window_sums`. ``out[w]`` =
    ``[EXT, S, L2, CH, G]`` (time integrals in sample units): ``EXT = int g s P_s dt`` (``P_s``
    the high line's pressure), ``S = int g s dt``, ``L2 = int (1 - g)(P_a - P_b) dt``, ``CH`` =
    the sum over intervals of ``2 s (V_line dP_s + V_s dP_chamber_s)`` where ``g = 1`` and of
    ``V_line (dP_a - dP_b) + V_A dP_1 - V_B dP_2`` where ``g = 0``, and ``G = int g dt``.
    """
    n_win = starts.shape[0]
    for iw in range(n_win):
        i0 = starts[iw]
        ext = 0.0
        sg = 0.0
        l2 = 0.0
        ch = 0.0
        gg = 0.0
        for k in range(i0 + 1, i0 + window):
            d = 0.5 * ((pa[k] - pb[k]) + (pa[k - 1] - pb[k - 1]))
            xm = 0.5 * (x[k] + x[k - 1])
            if d > delta:
                ext += 0.5 * (pa[k] + pa[k - 1])
                sg += 1.0
                gg += 1.0
                ch += 2.0 * (line_volume * (pa[k] - pa[k - 1])
                             + (volume + area * xm) * (p1[k] - p1[k - 1]))
            elif d < -delta:
                ext -= 0.5 * (pb[k] + pb[k - 1])
                sg -= 1.0
                gg += 1.0
                ch -= 2.0 * (line_volume * (pb[k] - pb[k - 1])
                             + (volume - area * xm) * (p2[k] - p2[k - 1]))
            else:
                l2 += d
                ch += (line_volume * ((pa[k] - pa[k - 1]) - (pb[k] - pb[k - 1]))
                       + (volume + area * xm) * (p1[k] - p1[k - 1])
                       - (volume - area * xm) * (p2[k] - p2[k - 1]))
        out[iw, 0] = ext
        out[iw, 1] = sg
        out[iw, 2] = l2
        out[iw, 3] = ch
        out[iw, 4] = gg


@numba.njit(cache=True)
def leak_law_window_sums(dp, dps, first, last, delta, ptr_leak, laminar, out):
    """Per-window leak-law integrals with the differential pressure offset ``delta`` removed.

    ``out[w]`` = ``[PHI, PHIABS]`` over samples ``first[w]`` to ``last[w]`` inclusive (sample
    units): ``PHI = int phi(dp - delta) dt`` and ``PHIABS = int |phi(dps - delta)| dt``, the
    columns of the same names of :func:`vca_window_sums` and :func:`eha_window_sums` (Eq. 2-4,
    or 2-5 when ``laminar``) for a :math:`P_1` lowered by ``delta``; ``dp`` is the measured
    ``P1 - P2`` and ``dps`` its moving average.
    """
    for w in range(first.shape[0]):
        phs = 0.0
        pha = 0.0
        php = 0.0
        pap = 0.0
        for k in range(first[w], last[w] + 1):
            if laminar:
                ph = dp[k] - delta
                pa_ = dps[k] - delta
            else:
                ph = _sqrt_reg(dp[k] - delta, ptr_leak)
                pa_ = _sqrt_reg(dps[k] - delta, ptr_leak)
            if k > first[w]:
                phs += 0.5 * (ph + php)
                pha += 0.5 * (abs(pa_) + abs(pap))
            php = ph
            pap = pa_
        out[w, 0] = phs
        out[w, 1] = pha
