"""Numba kernel of the VCA extended Kalman filter (see :mod:`leakdiag.literature.ekf`).

The kernel only computes; :func:`leakdiag.literature.ekf.run_vca_ekf` validates and scales.
States are kept in scaled units ``z = state / scale`` so that the covariance is well
conditioned (Pa and m differ by ten orders of magnitude).
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.sim.vca.model import vca_leak_flow, vca_rhs

__all__: list[str] = []

N_STATE = 8  # x, v, p1, p2, xv, vv, k_l, f_d (load-force disturbance)
MEAS_IDX = (0, 2, 3)  # measured states: x, p1, p2


@numba.njit(cache=True)
def _f_scaled(z, u, scale, prm, inputs, out):
    """Scaled derivative of the augmented state (k_l and f_d are random walks: derivative 0;
    f_d is an unmodelled force on the piston, N: load, spring or friction model error)."""
    phys = np.empty(6)
    for i in range(6):
        phys[i] = z[i] * scale[i]
    inputs[0] = u
    inputs[1] = z[6] * scale[6]
    d = vca_rhs(0.0, phys, inputs, prm)
    d[1] += z[7] * scale[7] / prm[1]
    for i in range(6):
        out[i] = d[i] / scale[i]
    out[6] = 0.0
    out[7] = 0.0


@numba.njit(cache=True)
def _rk4(z, u, h, n_sub, scale, prm, inputs):
    k1 = np.empty(N_STATE)
    k2 = np.empty(N_STATE)
    k3 = np.empty(N_STATE)
    k4 = np.empty(N_STATE)
    tmp = np.empty(N_STATE)
    for _ in range(n_sub):
        _f_scaled(z, u, scale, prm, inputs, k1)
        for i in range(N_STATE):
            tmp[i] = z[i] + 0.5 * h * k1[i]
        _f_scaled(tmp, u, scale, prm, inputs, k2)
        for i in range(N_STATE):
            tmp[i] = z[i] + 0.5 * h * k2[i]
        _f_scaled(tmp, u, scale, prm, inputs, k3)
        for i in range(N_STATE):
            tmp[i] = z[i] + h * k3[i]
        _f_scaled(tmp, u, scale, prm, inputs, k4)
        for i in range(N_STATE):
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@numba.njit(cache=True)
def _jacobian(z, u, scale, prm, inputs, jac):
    f0 = np.empty(N_STATE)
    f1 = np.empty(N_STATE)
    zp = z.copy()
    _f_scaled(z, u, scale, prm, inputs, f0)
    for j in range(N_STATE):
        eps = 1e-6 * max(1.0, abs(z[j]))
        zp[j] = z[j] + eps
        _f_scaled(zp, u, scale, prm, inputs, f1)
        zp[j] = z[j]
        for i in range(N_STATE):
            jac[i, j] = (f1[i] - f0[i]) / eps


@numba.njit(cache=True)
def _matmul(a, b, out):
    n = a.shape[0]
    m = b.shape[1]
    kk = a.shape[1]
    for i in range(n):
        for j in range(m):
            acc = 0.0
            for k in range(kk):
                acc += a[i, k] * b[k, j]
            out[i, j] = acc


@numba.njit(cache=True)
def _sandwich(f, p, tmp, out):
    """out = f @ p @ f.T for square matrices (tmp is scratch)."""
    n = f.shape[0]
    _matmul(f, p, tmp)
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += tmp[i, k] * f[j, k]
            out[i, j] = acc


@numba.njit(cache=True)
def _inv3(s, out):
    """Inverse of a 3x3 matrix by cofactors; returns False if singular."""
    c00 = s[1, 1] * s[2, 2] - s[1, 2] * s[2, 1]
    c01 = s[1, 2] * s[2, 0] - s[1, 0] * s[2, 2]
    c02 = s[1, 0] * s[2, 1] - s[1, 1] * s[2, 0]
    det = s[0, 0] * c00 + s[0, 1] * c01 + s[0, 2] * c02
    if det == 0.0:
        return False
    inv = 1.0 / det
    out[0, 0] = c00 * inv
    out[1, 0] = c01 * inv
    out[2, 0] = c02 * inv
    out[0, 1] = (s[0, 2] * s[2, 1] - s[0, 1] * s[2, 2]) * inv
    out[1, 1] = (s[0, 0] * s[2, 2] - s[0, 2] * s[2, 0]) * inv
    out[2, 1] = (s[0, 1] * s[2, 0] - s[0, 0] * s[2, 1]) * inv
    out[0, 2] = (s[0, 1] * s[1, 2] - s[0, 2] * s[1, 1]) * inv
    out[1, 2] = (s[0, 2] * s[1, 0] - s[0, 0] * s[1, 2]) * inv
    out[2, 2] = (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0]) * inv
    return True


@numba.njit(cache=True)
def ekf_vca_kernel(y, use, u, dt, n_sub, prm, scale, z0, p0, qd, r, states, innov, nis, sdiag,
                   leak, kvar):
    """Run the EKF over all samples; write states (physical units), innovations, NIS, the
    diagonal of the innovation covariance (scaled units), leak flow and the variance of the
    leak coefficient.

    ``y`` is ``(n, 3)`` scaled measurements of (x, p1, p2); ``use`` ``(n, 3)`` says which of
    them the update takes (a measurement not used -- a frozen sensor -- gets zero gain, zero
    innovation and no NIS term); ``u`` the control signal, held constant over each sample
    interval (zero-order hold of the previous sample). Returns the number of samples whose
    innovation covariance was singular (update skipped).
    """
    n = y.shape[0]
    ns = N_STATE
    z = z0.copy()
    p = p0.copy()
    inputs = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    jac = np.empty((ns, ns))
    a = np.empty((ns, ns))
    a2 = np.empty((ns, ns))
    step = np.empty((ns, ns))
    f = np.empty((ns, ns))
    f2 = np.empty((ns, ns))
    tmp = np.empty((ns, ns))
    h = dt / n_sub
    meas = np.array(MEAS_IDX)
    e = np.empty(3)
    s = np.empty((3, 3))
    s_inv = np.empty((3, 3))
    pht = np.empty((ns, 3))
    gain = np.empty((ns, 3))
    se = np.empty(3)
    n_skipped = 0
    for k in range(n):
        if k > 0:
            # Prediction: covariance with the Jacobian at the prior estimate, then the state.
            _jacobian(z, u[k - 1], scale, prm, inputs, jac)
            for i in range(ns):
                for j in range(ns):
                    a[i, j] = jac[i, j] * h
            _matmul(a, a, a2)
            for i in range(ns):
                for j in range(ns):
                    step[i, j] = a[i, j] + 0.5 * a2[i, j] + (1.0 if i == j else 0.0)
            f[:, :] = step
            for _ in range(n_sub - 1):
                _matmul(step, f, f2)
                f[:, :] = f2
            _sandwich(f, p, tmp, f2)
            p[:, :] = f2
            for i in range(ns):
                p[i, i] += qd[i]
            _rk4(z, u[k - 1], h, n_sub, scale, prm, inputs)
        # Update with the measurements of sample k (Joseph form).
        for a_ in range(3):
            e[a_] = y[k, a_] - z[meas[a_]]
            for b_ in range(3):
                s[a_, b_] = p[meas[a_], meas[b_]]
            s[a_, a_] += r[a_]
            sdiag[k, a_] = s[a_, a_]
            for i in range(ns):
                pht[i, a_] = p[i, meas[a_]]
        for a_ in range(3):
            if not use[k, a_]:  # decoupled: S block-diagonal with 1, P H^T column 0 -> no gain
                e[a_] = 0.0
                for b_ in range(3):
                    s[a_, b_] = 0.0
                    s[b_, a_] = 0.0
                s[a_, a_] = 1.0
                for i in range(ns):
                    pht[i, a_] = 0.0
        if _inv3(s, s_inv):
            _matmul(pht, s_inv, gain)
            for i in range(ns):
                for j in range(ns):
                    step[i, j] = 1.0 if i == j else 0.0
                for a_ in range(3):
                    step[i, meas[a_]] -= gain[i, a_]
            for i in range(ns):
                acc = 0.0
                for a_ in range(3):
                    acc += gain[i, a_] * e[a_]
                z[i] += acc
            _sandwich(step, p, tmp, f2)
            for i in range(ns):
                for j in range(ns):
                    acc = 0.0
                    for a_ in range(3):
                        acc += gain[i, a_] * r[a_] * gain[j, a_]  # 0 for an unused one
                    p[i, j] = f2[i, j] + acc
            for a_ in range(3):
                acc = 0.0
                for b_ in range(3):
                    acc += s_inv[a_, b_] * e[b_]
                se[a_] = acc
            nis[k] = e[0] * se[0] + e[1] * se[1] + e[2] * se[2]
        else:
            n_skipped += 1
            nis[k] = np.nan
        # no projection onto k_l >= 0: a negative estimate shows model bias and is kept
        for a_ in range(3):
            if use[k, a_]:
                innov[k, a_] = e[a_] * scale[meas[a_]]
            else:  # not used: no innovation
                innov[k, a_] = np.nan
                sdiag[k, a_] = np.nan
        for i in range(ns):
            states[k, i] = z[i] * scale[i]
        leak[k] = vca_leak_flow(states[k, 2], states[k, 3], states[k, 6], prm)
        kvar[k] = p[6, 6] * scale[6] * scale[6]
    return n_skipped
