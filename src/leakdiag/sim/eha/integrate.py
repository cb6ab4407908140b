"""Integrators of the EHA model: a fixed-step Rosenbrock kernel (Numba) and a SciPy reference.

The EHA is stiff: the free line orifice couples a 50 cm^3 line to its chamber with a time
constant of a few microseconds, so explicit methods would need steps of ~1e-5 s, and it is
strongly nonlinear where an orifice changes direction (its conductance changes tenfold). The fast
path is the two-stage, L-stable Rosenbrock method ROS2 (order 2,
:math:`\\gamma = 1 + 1/\\sqrt 2`) with the analytic Jacobian and local error control
(steps shrink at the orifice switches, grow elsewhere). Each step factorises
:math:`W = I - \\gamma h J` by the sparse elimination of :mod:`leakdiag.sim.eha.sparse_lu`
(no pivoting; the dense LU with partial pivoting when a pivot is too small). Inputs are given
at the output samples and interpolated linearly in between.
:func:`integrate_reference` solves the same :func:`~leakdiag.sim.eha.model.eha_rhs` with SciPy's
implicit ``Radau`` solver and tight tolerances, for tests and ``make bench``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from leakdiag._validation import as_2d_float, check_int, check_positive
from leakdiag.sim.eha._sparse_lu_kernel import _w_factor, _w_solve
from leakdiag.sim.eha.jacobian import _jacobian_into
from leakdiag.sim.eha.sparse_lu import PIVOT_FLOOR
from leakdiag.sim.eha.model import (
    IN_KLEAK,
    N_INPUTS,
    N_STATES,
    S_P1,
    S_P2,
    S_PA,
    S_PB,
    _rhs_into,
    eha_rhs,
)
from leakdiag.sim.leak import _multipliers, leak_multiplier

__all__ = ["integrate_fast", "integrate_reference", "Solution", "DEFAULT_RTOL",
           "CLOSED_LOOP_RTOL", "DEFAULT_MAX_STEP_S", "ALWAYS_ON"]

#: Default local error tolerance and largest step; chosen by the study in docs/models.md (EHA).
DEFAULT_RTOL = 3e-4
#: Closed loop reaches the same accuracy with a looser tolerance (0.07 % vs 0.16 % at 2x the
#: steps, docs/models.md), so simulate_eha uses this one there.
CLOSED_LOOP_RTOL = 5e-4
DEFAULT_MAX_STEP_S = 1e-3
DEFAULT_JACOBIAN_EVERY = 1
GAMMA = 1.0 + 1.0 / np.sqrt(2.0)  # ROS2 (Verwer et al., 1999)
# Typical magnitude per state: the unit of the error tolerance.
# The motor current gets 100 A (peak currents are ~1 A): its fast ripple does not reach the
# recorded channels and would otherwise dictate the step (docs/models.md, step-size study).
_STATE_SCALE = np.array([1e-2, 1e-1, 1e6, 1e6, 1e6, 1e6, 100.0, 100.0, 1.0])


@numba.njit(cache=True)
def _lu_factor(a, piv):
    """In-place LU factorisation with partial pivoting of an ``N_STATES`` x ``N_STATES`` matrix.

    The fallback of the Rosenbrock step when the sparse elimination
    (:mod:`leakdiag.sim.eha.sparse_lu`) refuses a pivot.

    The size is the module's constant, not ``a.shape[0]``: with loop bounds known at compile
    time the compiler unrolls the short loops (same operations in the same order, so the
    factors are bit-identical; the factorisation plus two solves of a Rosenbrock step took
    395 -> 275 ns, docs/models.md). Not inlined into the kernel, so that it keeps the zero test
    of its division (a singular pivot raises).
    """
    n = N_STATES
    for k in range(n):
        m = k
        big = abs(a[k, k])
        for r in range(k + 1, n):
            if abs(a[r, k]) > big:
                big = abs(a[r, k])
                m = r
        piv[k] = m
        if m != k:
            for c in range(n):
                tmp = a[k, c]
                a[k, c] = a[m, c]
                a[m, c] = tmp
        inv = 1.0 / a[k, k]
        for r in range(k + 1, n):
            a[r, k] *= inv
            f = a[r, k]
            if f != 0.0:
                for c in range(k + 1, n):
                    a[r, c] -= f * a[k, c]


@numba.njit(cache=True)
def _lu_solve(a, piv, b):
    """Solve in place ``A x = b`` with the factors of :func:`_lu_factor` (``N_STATES``)."""
    n = N_STATES
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp
    for r in range(n):
        s = b[r]
        for c in range(r):
            s -= a[r, c] * b[c]
        b[r] = s
    for r in range(n - 1, -1, -1):
        s = b[r]
        for c in range(r + 1, n):
            s -= a[r, c] * b[c]
        b[r] = s / a[r, r]


@numba.njit(cache=True, error_model="numpy")
def _ros2_kernel(y0, inputs, t0, dt_out, params, scale, rtol, h_max, jac_every, out, stats,
                 carry, jac, sched, fs, pivot_floor):
    """Adaptive ROS2 between output samples; writes states at the samples into ``out``.

    The leak column of row ``j`` is multiplied by the schedule ``s(t0 + (j0 + j) / fs)``
    (:func:`~leakdiag.sim.leak.leak_multiplier`, ``sched`` from ``LeakSchedule.to_array``)
    before the rows are interpolated, as the VCA kernel scales its coefficient by ``s(t)``.

    ``stats`` receives [accepted steps, rejected steps, Jacobian evaluations, min step, dense
    factorisations (steps whose W the sparse elimination refused)].
    ``carry`` = [next step (<= 0: start afresh), steps since the Jacobian, orifice regime,
    index of the first sample] is read at the start and holds the controller's state at the
    end, with ``jac`` (the last Jacobian), so that a run can continue bit for bit.
    """
    n_out = inputs.shape[0]
    n = N_STATES  # compile-time bound: the short loops below unroll (integrate_fast checks y0)
    n_in = inputs.shape[1]
    y = y0.copy()
    for m in range(n):
        out[0, m] = y[m]
    f0 = np.empty(n)
    f1 = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    ys = np.empty(n)
    w = np.empty((n, n))
    piv = np.empty(n, dtype=np.int64)
    in0 = np.empty(n_in)
    in1 = np.empty(n_in)
    h = min(h_max, dt_out) * 0.1
    since_jac = jac_every  # force a Jacobian on the first step
    last_regime = -1
    if carry[0] > 0.0:  # continue a previous run
        h = carry[0]
        since_jac = int(carry[1])
        last_regime = int(carry[2])
    j0 = carry[3]
    h_min = 1e-10 * dt_out
    n_acc = 0
    n_rej = 0
    n_jac = 0
    n_dense = 0
    smallest = h_max
    for j in range(n_out - 1):
        tj = t0 + (j0 + j) * dt_out
        t_end = tj + dt_out
        t = tj
        lk0 = inputs[j, IN_KLEAK] * leak_multiplier(t0 + (j0 + j) / fs, sched)
        lk1 = inputs[j + 1, IN_KLEAK] * leak_multiplier(t0 + (j0 + j + 1) / fs, sched)
        while t_end - t > 1e-12 * dt_out:
            remaining = t_end - t
            hs = min(h, h_max)
            if hs >= remaining * 0.999:
                hs = remaining
            elif hs > 0.5 * remaining:
                hs = 0.5 * remaining  # two even steps instead of a sliver at the end
            a0 = (t - tj) / dt_out
            a1 = (t + hs - tj) / dt_out
            for c in range(n_in):
                in0[c] = inputs[j, c] + a0 * (inputs[j + 1, c] - inputs[j, c])
                in1[c] = inputs[j, c] + a1 * (inputs[j + 1, c] - inputs[j, c])
            in0[IN_KLEAK] = lk0 + a0 * (lk1 - lk0)
            in1[IN_KLEAK] = lk0 + a1 * (lk1 - lk0)
            _rhs_into(t, y, in0, params, f0)
            # flow direction through the two line orifices: the Jacobian changes tenfold when
            # one reverses, so a reversal forces a fresh Jacobian
            regime = (1 if y[S_PA] > y[S_P1] else 0) + (2 if y[S_P2] > y[S_PB] else 0)
            if regime != last_regime:
                since_jac = jac_every
                last_regime = regime
            if since_jac >= jac_every:
                _jacobian_into(t, y, in0, params, jac)
                n_jac += 1
                since_jac = 0
            # W = I - gamma h J: the sparse elimination (sparse_lu), or the dense LU with
            # partial pivoting when one of its pivots is too small
            sparse = _w_factor(jac, GAMMA * hs, w, pivot_floor)
            if not sparse:
                n_dense += 1
                for r in range(n):
                    for c in range(n):
                        w[r, c] = -GAMMA * hs * jac[r, c]
                    w[r, r] += 1.0
                _lu_factor(w, piv)
            for r in range(n):
                k1[r] = f0[r]
            if sparse:
                _w_solve(w, k1)
            else:
                _lu_solve(w, piv, k1)
            for r in range(n):
                ys[r] = y[r] + hs * k1[r]
            _rhs_into(t + hs, ys, in1, params, f1)
            for r in range(n):
                k2[r] = f1[r] - 2.0 * k1[r]
            if sparse:
                _w_solve(w, k2)
            else:
                _lu_solve(w, piv, k2)
            # error of the embedded first-order solution y + h k1
            err = 0.0  # max norm: the worst state decides (an RMS norm dilutes transients)
            for r in range(n):
                e = abs(0.5 * hs * (k1[r] + k2[r])) / (rtol * scale[r])
                if e > err:
                    err = e
            if not np.isfinite(err):
                err = 1e10
            if err <= 1.0 or hs <= h_min:
                for r in range(n):
                    y[r] += hs * (1.5 * k1[r] + 0.5 * k2[r])
                t = t_end if hs == remaining else t + hs
                n_acc += 1
                since_jac += 1
                if hs < smallest:
                    smallest = hs
                fac = 0.9 / np.sqrt(max(err, 1e-8))
                h = hs * min(4.0, max(0.2, fac))
            else:
                n_rej += 1
                since_jac = jac_every  # fresh Jacobian for the retry
                h = hs * max(0.1, 0.9 / np.sqrt(err))
        for m in range(n):
            out[j + 1, m] = y[m]
    stats[0] = n_acc
    stats[1] = n_rej
    stats[2] = n_jac
    stats[3] = smallest
    stats[4] = n_dense
    carry[0] = h
    carry[1] = since_jac
    carry[2] = last_regime
    carry[3] = j0 + n_out - 1


#: A schedule that is always on (multiplier 1): the leak column is the coefficient in force.
ALWAYS_ON = np.array([1.0, -np.inf, 0.0])


def _schedule_array(leak_schedule) -> np.ndarray:
    """``LeakSchedule.to_array()`` of a schedule, an encoded schedule, or :data:`ALWAYS_ON`."""
    if leak_schedule is None:
        return ALWAYS_ON
    if hasattr(leak_schedule, "to_array"):
        return leak_schedule.to_array()
    arr = np.ascontiguousarray(leak_schedule, dtype=np.float64)
    if arr.shape != (3,):
        raise ValueError(f"leak_schedule must be a LeakSchedule or its to_array(), got shape "
                         f"{arr.shape}")
    return arr


@dataclass(frozen=True)
class Solution:
    """States at the output samples plus solver statistics.

    Attributes
    ----------
    states : numpy.ndarray
        Shape ``(n, N_STATES)``; row 0 is the initial state.
    n_accepted, n_rejected, n_jacobians : int
        Accepted and rejected steps, Jacobian evaluations.
    min_step_s : float
        Smallest accepted step, s.
    resume : tuple or None
        The step controller's state after the last sample (pass it with the last state to
        ``integrate_fast(..., resume=...)`` to continue the run bit for bit).
    n_dense : int
        Steps (accepted or rejected) whose matrix :math:`W = I - \\gamma h J` the sparse
        elimination refused (a pivot below
        :data:`~leakdiag.sim.eha.sparse_lu.PIVOT_FLOOR`), factorised by the dense LU with
        partial pivoting instead.
    """

    states: np.ndarray
    n_accepted: int
    n_rejected: int
    n_jacobians: int
    min_step_s: float
    resume: tuple | None = None
    n_dense: int = 0


def integrate_fast(y0, inputs, params, sample_rate: float, t0: float = 0.0,
                   rtol: float = DEFAULT_RTOL, max_step: float | None = None,
                   jacobian_every: int = DEFAULT_JACOBIAN_EVERY, resume=None,
                   leak_schedule=None, pivot_floor: float = PIVOT_FLOOR) -> Solution:
    """Integrate the EHA with the adaptive ROS2 kernel; states at the output samples.

    Parameters
    ----------
    y0 : array_like
        Initial state, shape ``(N_STATES,)``.
    inputs : array_like
        Inputs at the output samples, shape ``(n, N_INPUTS)``; linear in between.
    params : numpy.ndarray
        ``EHAParams.to_array(...)``.
    sample_rate : float
        Output rate in Hz; sample ``j`` is at ``t0 + j / sample_rate``.
    t0 : float, default 0.0
        Time of the first sample, s.
    rtol : float, default DEFAULT_RTOL
        Local error tolerance as a fraction of each state's typical magnitude (1 cm, 0.1 m/s,
        1 MPa, 100 A, 100 rad/s, 1 rad), in the max norm over the states.
    max_step : float, optional
        Largest step in s (default ``DEFAULT_MAX_STEP_S``).
    jacobian_every : int, default DEFAULT_JACOBIAN_EVERY
        Re-evaluate the analytic Jacobian every this many accepted steps (and after every
        rejected step and orifice reversal). ROS2 stays second order with an outdated Jacobian.
    resume : tuple, optional
        ``Solution.resume`` of a run whose last state is ``y0`` and whose last input row is
        ``inputs[0]``: continue it (same step, Jacobian and sample clock) instead of starting
        afresh, so that integrating ``[0, m]`` then ``[m, n]`` equals ``[0, n]`` bit for bit.
        ``t0`` and ``sample_rate`` must be those of that run.
    leak_schedule : LeakSchedule or numpy.ndarray, optional
        The leak schedule :math:`s(t)` (or its ``to_array()``): the leak column of sample ``j``
        is multiplied by :math:`s(t_0 + j/f_s)` inside the kernel, so the column can hold the
        full coefficient :math:`k_l` (the convention of both simulators). Default: the column
        is the coefficient in force.
    pivot_floor : float, default PIVOT_FLOOR
        Smallest pivot magnitude the sparse elimination of :math:`W` accepts
        (:mod:`leakdiag.sim.eha.sparse_lu`); a step with a smaller pivot is factorised by the
        dense LU with partial pivoting (``inf``: every step, ``0``: only non-finite pivots).

    Returns
    -------
    Solution
        States and step statistics.

    Raises
    ------
    ValueError
        If shapes do not match, or a value is not finite / positive (``pivot_floor``: >= 0).

    Notes
    -----
    ROS2 of Verwer et al.: with :math:`W = I - \\gamma h J`,
    :math:`W k_1 = f(t_n, y_n)`, :math:`W k_2 = f(t_n + h, y_n + h k_1) - 2 k_1`,
    :math:`y_{n+1} = y_n + \\tfrac32 h k_1 + \\tfrac12 h k_2`. It is second order for any
    matrix :math:`J` and L-stable for the exact Jacobian. The local error is estimated against
    the embedded first-order solution :math:`y_n + h k_1`, i.e.
    :math:`\\tfrac12 h (k_1 + k_2)`, and the step follows the usual
    :math:`0.9\\,\\mathrm{err}^{-1/2}` controller. The Jacobian is also refreshed whenever a
    line orifice reverses (its conductance changes tenfold). Steps end exactly on the output samples, so
    no interpolation of the solution is needed; the sequence of steps depends only on the
    inputs, hence runs are bit-for-bit reproducible.

    References
    ----------
    Verwer, Spee, Blom and Hundsdorfer (1999), SIAM J. Sci. Comput. 20(4), 1456-1480.

    Examples
    --------
    >>> from leakdiag.sim.eha.params import EHAParams
    >>> prm = EHAParams()
    >>> y0 = np.zeros(N_STATES); y0[2:6] = prm.accumulator_pressure_pa
    >>> u = np.tile([0.0, 0.0, 1.0, 1.0, 0.0, 0.0], (11, 1))
    >>> sol = integrate_fast(y0, u, prm.to_array(), sample_rate=1000.0)
    >>> sol.states.shape, float(np.abs(sol.states[-1] - y0).max())
    ((11, 9), 0.0)
    """
    y0 = np.require(np.asarray(y0, dtype=np.float64), requirements=["C", "W"])
    if y0.shape != (N_STATES,):
        raise ValueError(f"y0 must have shape ({N_STATES},), got {y0.shape}")
    # writeable C-contiguous float64 (a read-only array would compile a second kernel)
    inputs = np.require(as_2d_float(inputs, "inputs"), requirements=["C", "W"])
    if inputs.shape[1] != N_INPUTS or inputs.shape[0] < 1:
        raise ValueError(f"inputs must have shape (n >= 1, {N_INPUTS}), got {inputs.shape}")
    params = np.require(np.asarray(params, dtype=np.float64), requirements=["C", "W"])
    fs = check_positive(sample_rate, "sample_rate")
    rtol = check_positive(rtol, "rtol")
    h_max = check_positive(DEFAULT_MAX_STEP_S if max_step is None else max_step, "max_step")
    jac_every = check_int(jacobian_every, "jacobian_every", 1)
    if not float(pivot_floor) >= 0.0:
        raise ValueError(f"pivot_floor={pivot_floor} must be >= 0 (inf: the dense LU at every "
                         "step)")
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(inputs))):
        raise ValueError("y0 and inputs must be finite")
    out = np.empty((inputs.shape[0], N_STATES))
    stats = np.zeros(5)
    if resume is None:
        carry = np.array([0.0, 0.0, -1.0, 0.0])
        jac = np.zeros((N_STATES, N_STATES))
    else:
        carry = np.array(resume[0], dtype=np.float64)
        jac = np.array(resume[1], dtype=np.float64)
        if carry.shape != (4,) or jac.shape != (N_STATES, N_STATES):
            raise ValueError("resume must be the Solution.resume of an earlier run")
    _ros2_kernel(y0, inputs, float(t0), 1.0 / fs, params, _STATE_SCALE, rtol, h_max,
                 jac_every, out, stats, carry, jac, _schedule_array(leak_schedule), fs,
                 float(pivot_floor))
    return Solution(out, int(stats[0]), int(stats[1]), int(stats[2]), float(stats[3]),
                    (carry, jac), int(stats[4]))


def integrate_reference(y0, inputs, params, sample_rate: float, t0: float = 0.0,
                        rtol: float = 1e-7, method: str = "Radau",
                        leak_schedule=None) -> np.ndarray:
    """Integrate the same model with SciPy's implicit ``solve_ivp`` (slow reference).

    Parameters
    ----------
    y0, inputs, params, sample_rate, t0, leak_schedule
        As :func:`integrate_fast`.
    rtol : float, default 1e-7
        Relative tolerance; absolute tolerances are ``rtol`` times a typical state magnitude.
    method : {"Radau", "BDF"}, default "Radau"
        Implicit SciPy method.

    Returns
    -------
    numpy.ndarray
        States at the output samples, shape ``(n, N_STATES)``.

    Raises
    ------
    RuntimeError
        If the SciPy solver fails (its message is included).
    """
    from scipy.integrate import solve_ivp

    y0 = np.ascontiguousarray(y0, dtype=np.float64)
    inputs = as_2d_float(inputs, "inputs").copy()
    params = np.ascontiguousarray(params, dtype=np.float64)
    fs = check_positive(sample_rate, "sample_rate")
    dt_out = 1.0 / fs
    n = inputs.shape[0]
    inputs[:, IN_KLEAK] *= _multipliers(t0 + np.arange(n) / fs, _schedule_array(leak_schedule))
    t_eval = t0 + np.arange(n) * dt_out
    last = n - 1

    def fun(t, y):
        a = (t - t0) / dt_out
        j = min(max(int(np.floor(a)), 0), max(last - 1, 0))
        frac = min(max(a - j, 0.0), 1.0) if last > 0 else 0.0
        row = inputs[j] + frac * (inputs[min(j + 1, last)] - inputs[j])
        return eha_rhs(t, np.ascontiguousarray(y), row, params)

    sol = solve_ivp(fun, (t_eval[0], t_eval[-1]), y0, method=method, t_eval=t_eval,
                    rtol=rtol, atol=rtol * _STATE_SCALE, max_step=dt_out)
    if not sol.success:
        raise RuntimeError(f"reference solver {method} failed: {sol.message}")
    return np.ascontiguousarray(sol.y.T)
