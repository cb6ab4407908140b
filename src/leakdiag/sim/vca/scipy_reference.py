"""Reference solution of the closed-loop VCA with SciPy's implicit ``solve_ivp`` (slow, exact).

Same model (:func:`~leakdiag.sim.vca.model.vca_rhs`), same control law and zero-order hold as
the fast RK4 kernel, ideal sensors; each sample interval is integrated by an implicit solver
with tight tolerances. Used by the tests (accuracy of the fixed RK4 step) and by ``make bench``
(speed ratio).
"""

from __future__ import annotations

import numpy as np

from leakdiag._validation import as_1d_float, check_positive
from leakdiag.sim.leak import leak_multiplier
from leakdiag.sim.vca.conditions import fill_inputs
from leakdiag.sim.vca.control import control_law
from leakdiag.sim.vca.integrate import ClosedLoopResult
from leakdiag.sim.vca.model import vca_leak_flow, vca_rhs

__all__ = ["integrate_closed_loop_scipy"]


def integrate_closed_loop_scipy(x_ref, sample_rate, params, gains, u_max, leak_coefficient,
                                schedule, cond, state0, method: str = "Radau",
                                rtol: float = 1e-8) -> ClosedLoopResult:
    """Closed-loop VCA with ideal sensors, integrated by ``scipy.integrate.solve_ivp``.

    Parameters
    ----------
    x_ref : array_like
        Reference position (m) per output sample.
    sample_rate : float
        Output and control rate in Hz.
    params, gains : numpy.ndarray
        :meth:`VCAParams.to_array`, :meth:`FixedGainController.to_array`.
    u_max : float
        Control saturation in V.
    leak_coefficient : float
        Full leakage coefficient.
    schedule, cond : numpy.ndarray
        :meth:`LeakSchedule.to_array`, :meth:`OperatingConditions.to_array`.
    state0 : array_like
        Initial state, shape ``(6,)``.
    method : str, default "Radau"
        An implicit ``solve_ivp`` method ("Radau", "BDF", "LSODA").
    rtol : float, default 1e-8
        Relative tolerance; absolute tolerances are ``rtol`` times 1 mm, 1 m/s, 1 MPa, 1 mm,
        1 m/s for position, velocity, pressures, spool position and velocity.

    Returns
    -------
    ClosedLoopResult
        As :func:`~leakdiag.sim.vca.integrate.integrate_closed_loop` with ideal sensors.

    Raises
    ------
    RuntimeError
        If the solver fails on an interval (the message names the time).

    Notes
    -----
    Inputs (leak schedule, operating conditions) are evaluated at the solver's own times, so
    with a supply ripple this is the exact reference and the fast kernel's per-stage evaluation
    is compared against it. Roughly 1000 times slower than the Numba kernel.

    Examples
    --------
    >>> from leakdiag.sim import VCAParams, FixedGainController, LeakSchedule, OperatingConditions
    >>> res = integrate_closed_loop_scipy(np.full(20, 1e-3), 1000.0, VCAParams().to_array(),
    ...     FixedGainController().to_array(), 10.0, 0.0, LeakSchedule().to_array(),
    ...     OperatingConditions().to_array(1.0), [0, 0, 8.6e6, 8.6e6, 0, 0])
    >>> bool(res.state[-1, 0] > 0)  # moving towards +1 mm
    True
    """
    from scipy.integrate import solve_ivp

    xr = as_1d_float(x_ref, "x_ref")
    fs = check_positive(sample_rate, "sample_rate")
    prm = np.ascontiguousarray(params, dtype=np.float64)
    gains = np.ascontiguousarray(gains, dtype=np.float64)
    sched = np.ascontiguousarray(schedule, dtype=np.float64)
    cond = np.ascontiguousarray(cond, dtype=np.float64)
    s = as_1d_float(state0, "state0").copy()
    n = xr.size
    dt = 1.0 / fs
    scale = np.array([1e-3, 1.0, 1e6, 1e6, 1e-3, 1.0])
    inp = np.empty(6)
    out_state = np.empty((n, 6))
    out_u = np.empty(n)
    out_q = np.empty(n)
    integral = 0.0
    k_leak = float(leak_coefficient)
    for k in range(n):
        t = k * dt
        out_state[k] = s
        out_q[k] = vca_leak_flow(s[2], s[3], k_leak * leak_multiplier(t, sched), prm)
        u, integral = control_law(xr[k] - s[0], integral, s[2] - s[3], dt, gains, float(u_max))
        out_u[k] = u
        t_in = t if cond[0] == 0.0 else None  # per-sample inputs, as the kernel, unless ripple

        def f(tt, y, u=u, t_in=t_in):
            fill_inputs(tt if t_in is None else t_in, u, k_leak, sched, cond, inp)
            return vca_rhs(tt, y, inp, prm)

        sol = solve_ivp(f, (t, t + dt), s, method=method, rtol=rtol, atol=rtol * scale)
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed at t={t} s: {sol.message}")
        s = np.ascontiguousarray(sol.y[:, -1])
    return ClosedLoopResult(out_state, out_state[:, [0, 2, 3]].copy(), out_u, out_q)
