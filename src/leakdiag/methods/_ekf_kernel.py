"""Numba kernel of the VCA extended Kalman filter (see :mod:`leakdiag.methods.ekf`).

The kernel only computes; :func:`leakdiag.methods.ekf.run_vca_ekf` validates and scales.
States are kept in scaled units ``z = state / scale`` so that the covariance is well
conditioned (Pa and m differ by ten orders of magnitude).
"""

from __future__ import annotations

import numba
import numpy as np

from leakdiag.sim.vca_model import vca_leak_flow, vca_rhs

__all__: list[str] = []

N_STATE = 7  # x, v, p1, p2, xv, vv, k_l
MEAS_IDX = (0, 2, 3)  # measured states: x, p1, p2


@numba.njit(cache=True)
def _f_scaled(z, u, scale, prm, inputs, out):
    """Scaled derivative of the augmented state (k_l is a random walk: derivative 0)."""
    phys = np.empty(6)
    for i in range(6):
        phys[i] = z[i] * scale[i]
    inputs[0] = u
    inputs[1] = z[6] * scale[6]
    d = vca_rhs(0.0, phys, inputs, prm)
    for i in range(6):
        out[i] = d[i] / scale[i]
    out[6] = 0.0


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
def ekf_vca_kernel(y, u, dt, n_sub, prm, scale, z0, p0, qd, r, states, innov, nis, leak):
    """Run the EKF over all samples; write states (physical units), innovations, NIS, leak flow.

    ``y`` is ``(n, 3)`` scaled measurements of (x, p1, p2); ``u`` the control signal, held
    constant over each sample interval (zero-order hold of the previous sample).
    """
    n = y.shape[0]
    z = z0.copy()
    p = p0.copy()
    inputs = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    jac = np.empty((N_STATE, N_STATE))
    eye = np.eye(N_STATE)
    h = dt / n_sub
    meas = np.array(MEAS_IDX)
    phys = np.empty(6)
    for k in range(n):
        if k > 0:
            # Prediction: covariance with the Jacobian at the prior estimate, then the state.
            _jacobian(z, u[k - 1], scale, prm, inputs, jac)
            a = jac * h
            step = eye + a + 0.5 * (a @ a)
            f = eye.copy()
            for _ in range(n_sub):
                f = step @ f
            p = f @ p @ f.T
            for i in range(N_STATE):
                p[i, i] += qd[i]
            _rk4(z, u[k - 1], h, n_sub, scale, prm, inputs)
        # Update with the measurements of sample k (Joseph form).
        e = np.empty(3)
        s = np.empty((3, 3))
        pht = np.empty((N_STATE, 3))
        for a_ in range(3):
            e[a_] = y[k, a_] - z[meas[a_]]
            for b_ in range(3):
                s[a_, b_] = p[meas[a_], meas[b_]]
            s[a_, a_] += r[a_]
            for i in range(N_STATE):
                pht[i, a_] = p[i, meas[a_]]
        s_inv = np.linalg.inv(s)
        gain = pht @ s_inv
        ikh = eye.copy()
        for i in range(N_STATE):
            for a_ in range(3):
                ikh[i, meas[a_]] -= gain[i, a_]
        z = z + gain @ e
        p = ikh @ p @ ikh.T
        for i in range(N_STATE):
            for j in range(N_STATE):
                acc = 0.0
                for a_ in range(3):
                    acc += gain[i, a_] * r[a_] * gain[j, a_]
                p[i, j] += acc
        if z[6] < 0.0:  # a leak coefficient cannot be negative: project onto k_l >= 0
            z[6] = 0.0
        nis[k] = e @ (s_inv @ e)
        for a_ in range(3):
            innov[k, a_] = e[a_] * scale[meas[a_]]
        for i in range(N_STATE):
            states[k, i] = z[i] * scale[i]
        for i in range(6):
            phys[i] = states[k, i]
        leak[k] = vca_leak_flow(phys[2], phys[3], states[k, 6], prm)
