"""VCA flow balance: window terms of Eq. 2-1 and the per-machine valve identification.

Adding and subtracting the two chamber continuity equations of Eq. 2-1,

.. math::

    \\dot P_1 V_1/\\beta = Q_1 - Q_l - A\\dot x, \\qquad
    \\dot P_2 V_2/\\beta = -Q_2 + Q_l + A\\dot x,

gives a leak-free equation (the *sum*) and the leak equation (the *difference*),

.. math::

    Q_1 - Q_2 = \\frac{V_1 \\dot P_1 + V_2 \\dot P_2}{\\beta}, \\qquad
    Q_l = \\frac{Q_1 + Q_2}{2} - A\\dot x - \\frac{V_1\\dot P_1 - V_2 \\dot P_2}{2\\beta}.

Neither contains the piston's mechanics (mass, damping, friction, spring, end stops). Integrated
over a window, :math:`A\\dot x` becomes :math:`A\\,\\Delta x` and :math:`V_i\\dot P_i` the
Stieltjes sums :math:`\\int V_i\\,dP_i`, so that position and pressure noise enter at the
window's end points (and, weakly, through :math:`A\\,\\int P\\,dx`). The valve flows come from
Eq. 2-2 with the spool position obtained from the recorded ``u`` through the second-order valve
of Table 2-1, discretised exactly for a control held between samples.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.linalg import expm
from scipy.optimize import least_squares

from leakdiag.detect._flow_balance_bounds import fixed_bounds, quiet_bounds
from leakdiag.detect._flow_balance_kernel import spool_positions, vca_window_sums
from leakdiag.detect._flow_balance_offset import offset_words
from leakdiag.sim.vca.params import VCAParams

__all__ = ["VCAValveModel", "VCA_CHANNELS", "vca_raw_sums", "vca_terms", "identify_vca"]

#: Channels the VCA flow balance needs.
VCA_CHANNELS = ("p1", "p2", "x", "u")
#: Columns of the raw window sums (see ``vca_window_sums``).
(_S1, _S2, _DX, _C1, _C2, _PHI, _T, _F, _PHIABS, _QA, _QB, _DP, _SP, _EDIFF, _ESUM, _TR1,
 _TR2) = range(17)
#: Half-width of the central difference for the pressure rate at the window ends (samples).
_RATE_HALF_WIDTH = 3
#: Loads under which the size profiles the chamber transducers' differential zero error out
#: (:mod:`._flow_balance_offset`, as the EHA): without load (and under an unknown one), where a
#: zero error of tens of kPa against a |P1 - P2| of tens of kPa took the leak's coefficient since
#: the onset below zero and left 5 of 20 leaks of 0.02 L/min refused 10 s after their onset
#: (docs/detect.md 8.5). Not with the spring, whose MPa of |P1 - P2| make the offset poorly
#: determined and whose sizes were within 0.73-1.12x without it.
OFFSET_PROFILED_LOADS = ("none", None)


def size_profiles_pressure_offset(load: str | None) -> bool:
    """Whether the size profiles the transducers' differential zero error (``load`` as
    ``FlowBalanceDetector._load_of`` gives it)."""
    return load in OFFSET_PROFILED_LOADS


def confirms_with_offset_profile(load: str | None) -> bool:
    """Whether an alarm is confirmed (the refusal rules of ``predict``) on the size's own
    estimate with the offset profiled, rather than on the measured pressures': wherever the
    VCA's size profiles it."""
    return size_profiles_pressure_offset(load)


def negative_leak_limit(model) -> None:
    """None: the VCA's leak-free windows are not checked for a negative leak (the EHA's
    ``negative_leak_limit``; not measured here)."""
    return None


def size_interval_holds(offset_pa: float | None = None, offset_interval_pa=None) -> str:
    """What the size interval holds, in words (``offset_pa`` None: no offset profiled)."""
    if offset_pa is None:
        return "the coefficient's statistical error"
    return offset_words(offset_pa, offset_interval_pa)


#: Null-offset step used for the offset sensitivity psi = d residual / d offset (V).
_PSI_STEP_V = 1e-3
#: Scale of the null-offset parameters in the identification's nonlinear search (V).
OFFSET_SCALE_V = 1e-2
#: Forward-difference step of the identification's Jacobian, in scaled units (1e-5 V of
#: offset, 100 Pa of supply, 5 mHz of valve bandwidth).
_JAC_STEP = 1e-3
#: Points of the raw-sum memo per recording in the identification.
_RAW_CACHE_POINTS = 3
#: Moving average applied to P1 - P2 for the mean |phi| only (s; leakdiag choice: 5 ms cuts
#: white pressure noise 2.2x; without load the mean |phi| is then -1 % / +14 % off at 10 / 40 kPa
#: noise on the simulator, under the spring load < 0.2 %; docs/detect.md).
DP_SMOOTHING_S = 0.005


@dataclass(frozen=True)
class VCAValveModel:
    """Valve and fluid parameters the flow balance uses for one machine.

    Parameters
    ----------
    flow_gain_factor : float
        Multiplier of the nominal :math:`K_v w` of Table 2-1 (1 = nominal).
    null_offset_v : float
        Control-signal offset the valve adds (V): the spool follows ``u + null_offset_v``.
    supply_pressure_pa : float
        Supply pressure :math:`P_s` (Pa).
    valve_natural_frequency_hz : float
        Valve natural frequency (Hz).
    bulk_modulus_pa : float
        Effective bulk modulus :math:`\\beta` (Pa).
    pressure_delay_s : float
        Delay of the recorded pressures behind the true ones (anti-alias filter, transducer):
        it moves the compressibility integrals' end points by ``delay * V dP/dt``.
    valve_leakage_m3_per_s_pa : float
        Spool-clearance leakage :math:`c_v` of the valve: :math:`c_v(P_s - P_i) - c_v(P_i - P_r)`
        into chamber ``i``; in the difference equation it is a laminar cross-port flow
        :math:`-c_v(P_1 - P_2)`, in the sum equation :math:`2c_v(P_s + P_r - P_1 - P_2)`.
    baseline_leak_coefficient : float
        Leak-law coefficient seen on the healthy recordings; subtracted before testing.
    valve_lead_s : float
        Time by which the unit's valve leads the modelled one (s; a valve faster than Table 2-1
        leads: for a second-order valve the low-frequency lag is ``2 zeta / omega``, so 175 Hz
        instead of 150 Hz at zeta = 0.7 is 0.21 ms). To first order it adds
        ``valve_lead_s * int G_i(P) dx_v`` to the volume through port ``i`` (``Q_i = x_v G_i``).
    """

    flow_gain_factor: float
    null_offset_v: float
    supply_pressure_pa: float
    valve_natural_frequency_hz: float
    bulk_modulus_pa: float
    valve_leakage_m3_per_s_pa: float = 0.0
    baseline_leak_coefficient: float = 0.0
    pressure_delay_s: float = 0.0
    valve_lead_s: float = 0.0

    @classmethod
    def nominal(cls, params: VCAParams) -> "VCAValveModel":
        """The design values of ``params`` (no identification).

        Parameters
        ----------
        params : VCAParams
            Nominal parameters (Table 2-1).

        Returns
        -------
        VCAValveModel
        """
        return cls(1.0, 0.0, params.supply_pressure_pa, params.valve_natural_frequency_hz,
                   params.bulk_modulus_pa, 0.0, 0.0, 0.0, 0.0)

    def to_dict(self) -> dict:
        """Field name -> value.

        Returns
        -------
        dict
        """
        return asdict(self)


def _zoh(params: VCAParams, freq_hz: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of the valve of Eq. 2-1 (second order, Table 2-1) for a held u."""
    phi, gam = _zoh_cached(float(freq_hz), float(params.valve_damping_ratio),
                           float(params.spool_gain_m_per_v), float(dt))
    return phi.copy(), gam.copy()


@functools.lru_cache(maxsize=64)
def _zoh_cached(freq_hz: float, zeta: float, gain: float, dt: float):
    wv = 2.0 * math.pi * freq_hz
    m = np.zeros((3, 3))
    m[0, 1] = 1.0
    m[1, 0] = -wv * wv
    m[1, 1] = -2.0 * zeta * wv
    m[1, 2] = gain * wv * wv
    e = expm(m * dt)
    return np.ascontiguousarray(e[:2, :2]), np.ascontiguousarray(e[:2, 2])


def _arrays(recording) -> tuple:
    return tuple(np.ascontiguousarray(recording[c], dtype=np.float64) for c in VCA_CHANNELS)


def _as_bounds(window, n_samples: int) -> np.ndarray:
    """``window`` as boundaries: an int gives fixed windows, an array is taken as boundaries."""
    if np.ndim(window) == 0:
        return fixed_bounds(n_samples, int(window))
    return np.ascontiguousarray(window, dtype=np.int64)


def recording_bounds(arrays, sample_rate: float, params: VCAParams, window: int,
                     quiet: bool) -> np.ndarray:
    """Window boundaries of one recording: fixed, or moved to where the valve is quiet.

    Parameters
    ----------
    arrays : tuple of numpy.ndarray
        ``(p1, p2, x, u)``; only ``u`` is used.
    sample_rate : float
        Sampling rate of ``u`` (Hz).
    params : VCAParams
        Nominal valve (Table 2-1): the spool follows ``u`` through it (offset 0).
    window : int
        Nominal window length in sample intervals.
    quiet : bool
        Move the boundaries (:func:`~leakdiag.detect._flow_balance_bounds.quiet_bounds`).

    Returns
    -------
    numpy.ndarray
        int64 boundaries (window ``w`` spans samples ``bounds[w]..bounds[w + 1]``).
    """
    u = arrays[3]
    if not quiet:
        return fixed_bounds(len(u), window)
    dt = 1.0 / sample_rate
    phi, gam = _zoh(params, params.valve_natural_frequency_hz, dt)
    xv = np.empty_like(u)
    spool_positions(u, phi, gam, params.spool_gain_m_per_v, 0.0, 0.0, dt, xv)
    return quiet_bounds(xv, window, sample_rate)


def vca_raw_sums(arrays, sample_rate: float, params: VCAParams, null_offset_v: float,
                 supply_pressure_pa: float, valve_natural_frequency_hz: float, window: int,
                 laminar: bool, null_drift_v_per_s: float = 0.0) -> np.ndarray:
    """Raw window sums (columns ``S1 S2 dX C1 C2 PHI T F PHIABS``, time integrals in s).

    Parameters
    ----------
    arrays : tuple of numpy.ndarray
        ``(p1, p2, x, u)`` C-contiguous float64.
    sample_rate : float
        Hz.
    params : VCAParams
        Nominal parameters (area, volume, spool gain, orifice constants).
    null_offset_v, supply_pressure_pa, valve_natural_frequency_hz : float
        Valve model.
    window : int or numpy.ndarray
        Window length in sample intervals, or the window boundaries
        (:func:`recording_bounds`).
    laminar : bool
        Leak law: Eq. 2-5 (True) or Eq. 2-4.
    null_drift_v_per_s : float, default 0.0
        Null offset drift (V/s from the first sample).

    Returns
    -------
    numpy.ndarray
        Shape ``(n_windows, 17)``.
    """
    from scipy.ndimage import uniform_filter1d

    p1, p2, x, u = arrays
    dt = 1.0 / sample_rate
    dps = np.ascontiguousarray(uniform_filter1d(p1 - p2, max(1, int(round(DP_SMOOTHING_S
                                                                          * sample_rate))),
                                                mode="nearest"))
    phi, gam = _zoh(params, valve_natural_frequency_hz, dt)
    xv = np.empty_like(u)
    spool_positions(u, phi, gam, params.spool_gain_m_per_v, float(null_offset_v),
                    float(null_drift_v_per_s), dt, xv)
    bounds = _as_bounds(window, len(u))
    out = np.empty((max(0, len(bounds) - 1), 17))
    gw = params.valve_flow_gain_m1_5_per_kg0_5 * params.orifice_area_gradient_m
    vca_window_sums(xv, p1, p2, x, dps, bounds, params.piston_area_m2,
                    params.chamber_volume_m3, float(supply_pressure_pa), params.tank_pressure_pa,
                    gw, params.valve_transition_pressure_pa, params.leak_transition_pressure_pa,
                    bool(laminar), out)
    out[:, [_S1, _S2, _PHI, _T, _F, _PHIABS, _DP, _SP]] *= dt
    # V_i dP_i/dt at the window ends (central difference over +-3 samples): a pressure delay
    # shifts the compressibility integrals by delay * [V dP/dt] between the ends
    h = _RATE_HALF_WIDTH
    n = len(p1)
    ends = bounds if len(bounds) > 1 else bounds[:0]
    lo = np.clip(ends - h, 0, n - 1)
    hi = np.clip(ends + h, 0, n - 1)
    span = np.maximum(hi - lo, 1) * dt
    r1 = (p1[hi] - p1[lo]) / span
    r2 = (p2[hi] - p2[lo]) / span
    v1 = params.chamber_volume_m3 + params.piston_area_m2 * x[ends]
    v2 = params.chamber_volume_m3 - params.piston_area_m2 * x[ends]
    ed = v1 * r1 - v2 * r2
    es = v1 * r1 + v2 * r2
    out[:, _EDIFF] = np.diff(ed)
    out[:, _ESUM] = np.diff(es)
    return out


def vca_terms(raw: np.ndarray, params: VCAParams, model: VCAValveModel) -> dict[str, np.ndarray]:
    """Window terms of the difference (leak) and sum (leak-free) equations, SI.

    Parameters
    ----------
    raw : numpy.ndarray
        :func:`vca_raw_sums` output.
    params : VCAParams
        Nominal parameters (piston area).
    model : VCAValveModel
        Identified valve model (gain, bulk modulus, baseline leak).

    Returns
    -------
    dict of numpy.ndarray
        ``residual`` (m^3: valve volume minus piston and compressibility volumes minus the
        baseline leak volume; the leak volume plus errors), ``balance`` (m^3, leak-free sum
        equation), ``phi`` (integral of the leak-law pressure term), ``phi_abs``, ``flow``
        (m^3 through the valve), ``duration`` (s), ``edge_flow2`` (sum of the squared valve
        flows at the two end samples, m^6/s^2), ``edge_flows`` (those two flows, m^3/s,
        shape ``(n, 2)``: the size's weights remove the leak's feed from them),
        ``compressibility`` (m^3, the
        compressibility volume of the difference equation) and ``gain_sensitivity`` (m^3: the
        change of ``residual`` per unit of ``flow_gain_factor``, the valve volume of the
        difference equation; ``residual`` is linear in the gain).
    """
    g = model.flow_gain_factor
    beta = model.bulk_modulus_pa
    cv = model.valve_leakage_m3_per_s_pa
    tau = model.pressure_delay_s
    lead = model.valve_lead_s
    r = (0.5 * g * (raw[:, _S1] + raw[:, _S2] + lead * (raw[:, _TR1] + raw[:, _TR2]))
         - params.piston_area_m2 * raw[:, _DX]
         - (raw[:, _C1] - raw[:, _C2] + tau * raw[:, _EDIFF]) / (2.0 * beta)
         - cv * raw[:, _DP] - model.baseline_leak_coefficient * raw[:, _PHI])
    s = (g * (raw[:, _S1] - raw[:, _S2] + lead * (raw[:, _TR1] - raw[:, _TR2]))
         - (raw[:, _C1] + raw[:, _C2] + tau * raw[:, _ESUM]) / beta
         + 2.0 * cv * ((model.supply_pressure_pa + params.tank_pressure_pa) * raw[:, _T]
                       - raw[:, _SP]))
    # d residual / d flow_gain_factor: the valve volume of the difference equation
    gain = 0.5 * (raw[:, _S1] + raw[:, _S2] + lead * (raw[:, _TR1] + raw[:, _TR2]))
    return {"residual": r, "balance": s, "phi": raw[:, _PHI].copy(), "gain_sensitivity": gain,
            "phi_abs": raw[:, _PHIABS].copy(), "flow": g * raw[:, _F],
            "duration": raw[:, _T].copy(),
            "edge_flow2": g * g * (raw[:, _QA] ** 2 + raw[:, _QB] ** 2),
            "edge_flows": g * raw[:, [_QA, _QB]],
            "compressibility": (raw[:, _C1] - raw[:, _C2]) / (2.0 * beta)}


def offset_sensitivity(arrays, sample_rate: float, params: VCAParams, model: VCAValveModel,
                       window: int, laminar: bool, drift: tuple = (0.0, 0.0)) -> np.ndarray:
    """``psi_w``: change of each window residual per volt of null offset (m^3/V).

    Parameters
    ----------
    arrays : tuple of numpy.ndarray
        ``(p1, p2, x, u)``.
    sample_rate : float
        Hz.
    params : VCAParams
        Nominal parameters.
    model : VCAValveModel
        Valve model at which the derivative is taken (central difference of 1 mV).
    window : int or numpy.ndarray
        Window length in sample intervals, or window boundaries.
    laminar : bool
        Leak law.
    drift : tuple of float, default (0, 0)
        Extra null offset (V) and its drift (V/s) of this recording.

    Returns
    -------
    numpy.ndarray
        One value per window.
    """
    res = []
    for d in (-_PSI_STEP_V, _PSI_STEP_V):
        raw = vca_raw_sums(arrays, sample_rate, params, model.null_offset_v + drift[0] + d,
                           model.supply_pressure_pa, model.valve_natural_frequency_hz, window,
                           laminar, drift[1])
        res.append(vca_terms(raw, params, model)["residual"])
    return (res[1] - res[0]) / (2.0 * _PSI_STEP_V)


def drift_profiled(residual: np.ndarray, psi: np.ndarray, duration: np.ndarray) -> np.ndarray:
    """Residual minus its least-squares fit on ``psi (t - mean t)`` (a null drift, linear in t).

    Parameters
    ----------
    residual, psi, duration : numpy.ndarray
        Per window: residual (m^3), offset sensitivity (m^3/V), duration (s).

    Returns
    -------
    numpy.ndarray
        The residual with a linear-in-time null drift of this recording removed.
    """
    t = np.cumsum(duration) - 0.5 * duration
    reg = psi * (t - t.mean())
    rr = float(reg @ reg)
    if rr <= 0:
        return residual
    return residual - reg * (float(reg @ residual) / rr)


def _column_scales(x: np.ndarray) -> np.ndarray:
    """RMS of each column of ``x`` (1 for an all-zero column): the least-squares scaling."""
    col = np.sqrt(np.mean(x * x, axis=0))
    col[col == 0] = 1.0
    return col


def _robust_std(v: np.ndarray) -> float:
    v = v[np.isfinite(v)]
    if v.size == 0:
        return 1.0
    mad = 1.4826 * float(np.median(np.abs(v - np.median(v))))
    return mad if mad > 0 else (float(np.std(v)) or 1.0)


def identify_vca(recordings_arrays, sample_rates, params: VCAParams, windows: list,
                 laminar: bool, skip: list[int], fit_bandwidth: bool, fit_bulk_modulus: bool,
                 fit_valve_timing: bool = False):
    """Identify the valve model of one machine from its healthy recordings.

    Separable nonlinear least squares (variable projection) of the window residuals of both
    equations over all healthy windows. The null offset of each recording, the supply pressure
    and optionally the valve natural frequency enter nonlinearly
    (``scipy.optimize.least_squares`` over them). Each recording has its own null offset
    because the null moves with the fluid temperature (up to ~0.05 V over a 10 K warm-up on the
    virtual machines): one offset shared by recordings made at different temperatures left the
    difference between them to the baseline leak coefficient, a leak-shaped bias of the model
    (docs/detect.md, section 8.4). The model's ``null_offset_v`` is their mean, and
    ``std["null_offset_spread_v"]`` their spread. The flow-gain factor, the spool-clearance
    leakage, the baseline leak coefficient, the pressure delay and optionally the inverse bulk
    modulus enter linearly and are solved exactly at every step. A null drift linear in time is
    profiled out of each recording's leak-equation residuals (projection on
    ``psi (t - mean t)``, with ``psi`` taken at that recording's offset): the slow drift
    allowance. Each equation is weighted by
    a robust scale of its residuals (two passes).

    Parameters
    ----------
    recordings_arrays : list of tuple
        ``(p1, p2, x, u)`` per recording.
    sample_rates : list of float
        Hz per recording.
    params : VCAParams
        Nominal (design) parameters: the starting point.
    windows : list of int or numpy.ndarray
        Per recording: window length in sample intervals, or window boundaries.
    laminar : bool
        Leak law of the baseline term.
    skip : list of int
        Windows left out at the start of each recording (burn-in).
    fit_bandwidth, fit_bulk_modulus : bool
        Also identify the valve natural frequency / the bulk modulus.
    fit_valve_timing : bool, default False
        Also identify the valve's timing error ``valve_lead_s`` (linear: column
        ``int G_i dx_v``, the first-order sensitivity of the valve volume to a lead).

    Returns
    -------
    model : VCAValveModel
    std : dict
        Standard error of each identified field (Jacobian and linear-solve covariances with
        the residual scale; windows are treated as independent, so they are optimistic), and,
        with two or more recordings, ``null_offset_spread_v``: the standard deviation of the
        recordings' own null offsets.
    """
    n_rec = len(recordings_arrays)
    # nonlinear parameters: one null offset per recording (its value at the recording's middle
    # time; the drift around it is profiled), then the shared supply pressure and bandwidth
    shared_names = ["supply_pressure_pa"]
    shared_scales = [1e5]
    if fit_bandwidth:
        shared_names.append("valve_natural_frequency_hz")
        shared_scales.append(5.0)
    nl_scales = np.asarray([OFFSET_SCALE_V] * n_rec + shared_scales)
    lin_names = ["flow_gain_factor", "valve_leakage_m3_per_s_pa", "baseline_leak_coefficient",
                 "pressure_delay_s"]
    if fit_bulk_modulus:
        lin_names.append("inverse_bulk_modulus")
    if fit_valve_timing:
        lin_names.append("valve_lead_volume")  # flow gain factor times valve_lead_s
    base = VCAValveModel.nominal(params)
    beta0 = params.bulk_modulus_pa
    pt = params.tank_pressure_pa

    def offsets(theta) -> np.ndarray:
        return base.null_offset_v + np.asarray(theta[:n_rec]) * OFFSET_SCALE_V

    def shared(theta) -> dict:
        return {nm: getattr(base, nm) + th * sc
                for nm, th, sc in zip(shared_names, theta[n_rec:], shared_scales)}

    # window mid-times of each recording (s; they do not depend on the model)
    mid_times = []
    for a, fs, sk, window in zip(recordings_arrays, sample_rates, skip, windows):
        bounds = _as_bounds(window, len(a[3]))
        mid_times.append((0.5 * (bounds[:-1] + bounds[1:]) / fs)[sk:])

    def make_projectors(offs) -> list:
        """Per recording: the drift regressor ``psi (t - mean t)`` at its offset, and its norm."""
        out = []
        for a, fs, sk, window, off, t in zip(recordings_arrays, sample_rates, skip, windows,
                                             offs, mid_times):
            at = VCAValveModel(**{**base.to_dict(), "null_offset_v": float(off)})
            psi = offset_sensitivity(a, fs, params, at, window, laminar)[sk:]
            reg = psi * (t - t.mean())
            out.append((reg, float(reg @ reg)))
        return out

    projectors = make_projectors(offsets(np.zeros(n_rec)))
    cache: dict = {}

    def raw_of(r: int, off: float, v: dict) -> np.ndarray:
        """Raw sums of recording ``r``, memoised (the last few points: an offset moves one
        recording only, and the Jacobian returns to the base point)."""
        key = (off, v.get("supply_pressure_pa", base.supply_pressure_pa),
               v.get("valve_natural_frequency_hz", base.valve_natural_frequency_hz))
        hits = cache.setdefault(r, [])
        for k, raw in hits:
            if k == key:
                return raw
        a, fs, sk, window = recordings_arrays[r], sample_rates[r], skip[r], windows[r]
        raw = vca_raw_sums(a, fs, params, off, key[1], key[2], window, laminar)[sk:]
        hits.insert(0, (key, raw))
        del hits[_RAW_CACHE_POINTS:]
        return raw

    def design(theta):
        """Stacked (X, y) of both equations, drift-profiled, unweighted."""
        v = shared(theta)
        offs = offsets(theta)
        xr, yr, xs, ys = [], [], [], []
        for r, (reg, rr) in enumerate(projectors):
            raw = raw_of(r, float(offs[r]), v)
            ps = v.get("supply_pressure_pa", base.supply_pressure_pa)
            c_diff = raw[:, _C1] - raw[:, _C2]
            c_sum = raw[:, _C1] + raw[:, _C2]
            cols_r = [0.5 * (raw[:, _S1] + raw[:, _S2]), -raw[:, _DP], -raw[:, _PHI],
                      -raw[:, _EDIFF] / (2.0 * beta0)]
            cols_s = [raw[:, _S1] - raw[:, _S2], 2.0 * ((ps + pt) * raw[:, _T] - raw[:, _SP]),
                      np.zeros(len(raw)), -raw[:, _ESUM] / beta0]
            y_r = params.piston_area_m2 * raw[:, _DX]
            y_s = np.zeros(len(raw))
            if fit_bulk_modulus:
                cols_r.append(-0.5 * c_diff)
                cols_s.append(-c_sum)
            else:
                y_r = y_r + c_diff / (2.0 * beta0)
                y_s = y_s + c_sum / beta0
            if fit_valve_timing:
                cols_r.append(0.5 * (raw[:, _TR1] + raw[:, _TR2]))
                cols_s.append(raw[:, _TR1] - raw[:, _TR2])
            x_r = np.column_stack(cols_r)
            if rr > 0:  # profile the linear null drift out of the leak equation
                x_r = x_r - np.outer(reg, reg @ x_r / rr)
                y_r = y_r - reg * (float(reg @ y_r) / rr)
            xr.append(x_r)
            yr.append(y_r)
            xs.append(np.column_stack(cols_s))
            ys.append(y_s)
        sizes = np.array([len(v) for v in yr])
        return (np.concatenate(xr), np.concatenate(yr), np.concatenate(xs), np.concatenate(ys),
                sizes)

    weights = [1.0, 1.0]
    last: dict = {}

    def weighted(theta):
        x_r, y_r, x_s, y_s, sizes = design(theta)
        x = np.vstack([x_r / weights[0], x_s / weights[1]])
        y = np.concatenate([y_r / weights[0], y_s / weights[1]])
        return x, y, len(y_r), sizes

    def lstsq_scaled(x, y):
        col = _column_scales(x)
        coef, *_ = np.linalg.lstsq(x / col, y, rcond=None)
        return coef / (col[:, None] if np.ndim(coef) == 2 else col)

    def solve(theta):
        x, y, n_r, sizes = weighted(theta)
        coef = lstsq_scaled(x, y)
        last.update(theta=np.array(theta, dtype=float), x=x, y=y, coef=coef, n_r=n_r,
                    sizes=sizes)
        return x @ coef - y

    def jac(theta):
        """Variable-projection Jacobian (Kaufman 1975): ``P (dX/dtheta) coef``, with ``P`` the
        projection off the linear columns. All recordings' offsets are stepped at once (each
        moves its own rows only), so a Jacobian costs 2 + (shared parameters) design
        evaluations whatever the number of recordings."""
        if "theta" not in last or not np.array_equal(last["theta"], theta):
            solve(theta)
        x, coef, n_r, sizes = last["x"], last["coef"], last["n_r"], last["sizes"]
        f0 = x @ coef
        d = np.zeros((len(f0), len(theta)))
        ends = np.cumsum(sizes)
        starts = ends - sizes
        step = np.array(theta, dtype=float)
        step[:n_rec] += _JAC_STEP
        moved = (weighted(step)[0] @ coef - f0) / _JAC_STEP
        for r, (lo, hi) in enumerate(zip(starts, ends)):
            d[lo:hi, r] = moved[lo:hi]
            d[n_r + lo:n_r + hi, r] = moved[n_r + lo:n_r + hi]
        for j in range(n_rec, len(theta)):
            step = np.array(theta, dtype=float)
            step[j] += _JAC_STEP
            d[:, j] = (weighted(step)[0] @ coef - f0) / _JAC_STEP
        return d - x @ lstsq_scaled(x, d)

    theta0 = np.zeros(len(nl_scales))
    res0 = solve(theta0)
    n_r = last["n_r"]
    weights[0] = _robust_std(res0[:n_r])
    weights[1] = _robust_std(res0[n_r:])
    res = least_squares(solve, theta0, jac=jac, method="trf")
    # second pass: drift regressors at each recording's identified offset (the offset
    # sensitivity changes across the valve null), residual scales re-estimated
    projectors = make_projectors(offsets(res.x))
    r1 = solve(res.x) * 1.0
    weights[0] *= _robust_std(r1[:n_r])
    weights[1] *= _robust_std(r1[n_r:])
    res = least_squares(solve, res.x, jac=jac, method="trf")
    fun = solve(res.x)
    coef, x = last["coef"], last["x"]
    dof = max(1, fun.size - len(nl_scales) - len(lin_names))
    s2 = float(fun @ fun) / dof
    std = {}
    offs = offsets(res.x)
    try:
        cov_nl = np.linalg.inv(res.jac.T @ res.jac) * s2 * np.outer(nl_scales, nl_scales)
        # the reported offset is the recordings' mean: its standard error from the block
        std["null_offset_v"] = float(np.sqrt(max(cov_nl[:n_rec, :n_rec].sum(), 0.0)) / n_rec)
        for i, nm in enumerate(shared_names):
            std[nm] = float(np.sqrt(max(cov_nl[n_rec + i, n_rec + i], 0.0)))
    except np.linalg.LinAlgError:
        std.update({nm: float("nan") for nm in ["null_offset_v", *shared_names]})
    col = _column_scales(x)
    cov_lin = np.linalg.pinv((x / col).T @ (x / col)) * s2 / np.outer(col, col)
    for nm, c in zip(lin_names, np.diag(cov_lin)):
        std[nm] = float(np.sqrt(max(c, 0.0)))
    vals = base.to_dict()
    vals.update(shared(res.x))
    vals["null_offset_v"] = float(np.mean(offs))
    if n_rec > 1:  # spread of the recordings' own offsets (temperature, drift between runs)
        std["null_offset_spread_v"] = float(np.std(offs, ddof=1))
    lin = dict(zip(lin_names, (float(c) for c in coef)))
    if fit_bulk_modulus:
        inv = lin.pop("inverse_bulk_modulus")
        if not inv > 0:
            raise ValueError(f"fit: identified 1/beta={inv!r} is not positive; the healthy data "
                             "do not determine the bulk modulus (use fit_bulk_modulus=False)")
        vals["bulk_modulus_pa"] = 1.0 / inv
        std["bulk_modulus_pa"] = std.pop("inverse_bulk_modulus") / inv**2
    if fit_valve_timing:
        g = lin["flow_gain_factor"]
        vals["valve_lead_s"] = lin.pop("valve_lead_volume") / g
        std["valve_lead_s"] = std.pop("valve_lead_volume") / abs(g)
    vals.update(lin)
    return VCAValveModel(**{k: float(v) for k, v in vals.items()}), std


# ---------------------------------------------------------------- backend interface
CHANNELS = VCA_CHANNELS
#: Gauss-Newton steps of each recording's null drift before the test (leakdiag choice: the null
#: moves the valve flows nonlinearly near the null, where the metering edge changes).
DRIFT_ITERATIONS = 2
#: Fewest windows on which a recording's null drift (V/s) is fitted besides its offset
#: (leakdiag choice: fewer windows before a test's span fit the offset only).
DRIFT_MIN_WINDOWS = 20
#: Identification window when the valve bandwidth or bulk modulus is identified (s): short
#: enough that the valve and compressibility dynamics are visible (leakdiag choice).
DYNAMIC_ID_WINDOW_S = 0.02


def default_params() -> VCAParams:
    """Table 2-1 (design values)."""
    return VCAParams()


def wiring_problem(rec, first: int) -> str | None:
    """None: the VCA's channels carry no redundancy that tells their wiring (the EHA's line
    pressures do, :func:`leakdiag.detect._flow_balance_eha.wiring_problem`); a reversed sign
    of ``x`` or ``u`` is found after an alarm (``MIN_PISTON_VALVE_RATIO``).

    Parameters
    ----------
    rec : Recording
        VCA recording.
    first : int
        First sample after the burn-in.

    Returns
    -------
    None
    """
    return None


def check_params(p) -> VCAParams:
    """``p`` if it is a :class:`VCAParams`, else TypeError."""
    if not isinstance(p, VCAParams):
        raise TypeError(f"params={p!r} must be a VCAParams for system='vca'")
    return p


def leak_transition_pa(p: VCAParams) -> float:
    """Laminar core of the turbulent leak law (Pa)."""
    return p.leak_transition_pressure_pa


def terms(rec, nominal: VCAParams, model: VCAValveModel, window: int, laminar: bool,
          quiet: bool = True, drift_windows: int | None = None) -> dict:
    """Window terms of one recording with a given model (see :func:`vca_terms`).

    ``quiet``: window boundaries moved to where the valve is at rest (:func:`recording_bounds`);
    the boundaries are returned as ``bounds``. ``drift_windows``: the recording's null offset
    and drift (the point the test linearises at) are fitted on its windows before this one
    only (default: all): a test that alarmed fits them again on the windows before its span,
    so that a large leak after them does not move them (and with them every earlier window's
    residual: a 1 L/min leak from 60 s alarmed at 10 s; audit of 2026-11-27). With fewer than
    :data:`DRIFT_MIN_WINDOWS` windows before it the drift is not fitted, only the offset.
    """
    arrays = _arrays(rec)
    fs = rec.sample_rate
    bounds = recording_bounds(arrays, fs, nominal, window, quiet)
    drift = np.zeros(2)  # this recording's extra null offset (V) and drift (V/s)
    for _ in range(DRIFT_ITERATIONS + 1):
        raw = vca_raw_sums(arrays, fs, nominal, model.null_offset_v + drift[0],
                           model.supply_pressure_pa, model.valve_natural_frequency_hz, bounds,
                           laminar, drift[1])
        out = vca_terms(raw, nominal, model)
        psi = offset_sensitivity(arrays, fs, nominal, model, bounds, laminar, tuple(drift))
        if _ == DRIFT_ITERATIONS:
            break
        # Gauss-Newton step of the null drift on all windows (burn-in included: the step only
        # linearises; the test profiles the drift again on the windows it uses)
        t0 = bounds[:-1] / fs  # window start, s
        x = np.column_stack([psi, psi * t0])
        sk = min(len(psi) - 1, max(1, int(round(1.0 * fs / window))))
        end = len(psi) if drift_windows is None else min(len(psi), drift_windows)
        if end - sk < 1:
            break  # no window to fit on: the model's own null
        if drift_windows is not None and end - sk < DRIFT_MIN_WINDOWS:
            x = x[:, :1]  # the offset only (a refit before a span: too few windows for both)
        step, *_ = np.linalg.lstsq(x[sk:end], out["residual"][sk:end], rcond=None)
        if not np.all(np.isfinite(step)):
            break
        drift[:len(step)] = drift[:len(step)] - step
    out["nuisance"] = psi
    out["bounds"] = bounds
    return out


def identify(recs, nominal: VCAParams, windows, laminar, skips, fit_bandwidth, fit_bulk_modulus,
             quiet: bool = True, fit_valve_timing: bool = False, like=None):
    """Identify the valve model on healthy recordings (see :func:`identify_vca`).

    ``quiet``: the same window boundaries as :func:`terms` (not for the 20 ms windows of the
    bandwidth / bulk-modulus identification, which must see the transients);
    ``fit_valve_timing``: identify ``valve_lead_s`` (not with ``fit_bandwidth``, which models
    the same error nonlinearly); ``like``: not used (the EHA's choice of balance).
    """
    arrays = [_arrays(r) for r in recs]
    rates = [r.sample_rate for r in recs]
    if fit_bandwidth or fit_bulk_modulus:
        w_id = [max(2, int(round(DYNAMIC_ID_WINDOW_S * fs))) for fs in rates]
        skips = [int(math.ceil(sk * w / wi)) for sk, w, wi in zip(skips, windows, w_id)]
        windows = w_id
        quiet = False
    if len(set(windows)) != 1:
        raise ValueError("fit: healthy recordings have different sample rates "
                         f"{sorted(set(rates))}; resample them to one rate")
    bounds = [recording_bounds(a, fs, nominal, w, quiet) for a, fs, w in zip(arrays, rates, windows)]
    return identify_vca(arrays, rates, nominal, bounds, laminar, skips, fit_bandwidth,
                        fit_bulk_modulus, fit_valve_timing and not fit_bandwidth)
