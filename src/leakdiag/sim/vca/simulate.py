"""``simulate_vca``: a closed-loop VCA experiment as a :class:`~leakdiag.io.Recording`."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from leakdiag._validation import check_int, check_positive
from leakdiag.io.recording import Recording
from leakdiag.sim.experiment import (
    calibrate_leak,
    check_coefficient_has_a_leak,
    coefficient_from_healthy,
    experiment_metadata,
    plan_leak,
    random_streams,
    setup,
)
from leakdiag.sim.leak import LeakCalibrationError, log_slope, lpm_to_m3s
from leakdiag.sim.machine import VCAMachine
from leakdiag.sim.reference import as_reference
from leakdiag.sim.sensor_chain import antialias_sos, pressure_chain
from leakdiag.sim.sensors import SensorParams, adc_reading, quantize
from leakdiag.sim._checks import check_params_type
from leakdiag.sim.vca.conditions import OperatingConditions
from leakdiag.sim.vca.control import FixedGainController
from leakdiag.sim.vca.integrate import (
    ClosedLoopResult,
    _SegmentedLoop,
    rk4_advance,
    sos_step,
    valve_null_v,
)
from leakdiag.sim.vca.model import S_P1, S_P2, S_X, vca_leak_flow
from leakdiag.sim.vca.params import LEAK_MODELS, LOADS, VCAParams

__all__ = ["simulate_vca", "DEFAULT_DURATION_S", "DEFAULT_MAX_STEP_S", "initial_leak_coefficient"]

#: Run length of the thesis's experiment (Sec. 4.5), s.
DEFAULT_DURATION_S = 400.0
#: Largest RK4 step (s). Halving it changes pressures by < 0.01 % RMS (docs/models.md), and it
#: keeps the stiffest mode (end-stop contact, ~2850 rad/s) well inside RK4's stability region.
DEFAULT_MAX_STEP_S = 2.5e-4
#: Typical |P1 - P2| used only for the first guess of the leak coefficient (Pa).
_TYPICAL_LOAD_PRESSURE_PA = {"none": 3e4, "spring": 8e5}
_CHUNK_S = 10.0  # progress granularity (s of simulated time)
#: Smallest RK4 step (s) that a (huge) leak coefficient may demand before the run is refused:
#: 1/16 of the default step, 64 steps per sample at the thesis's 1 kHz. A step, not a count per
#: sample, so that a healthy run at a low sample rate (10 Hz: 400 base steps per sample) is not
#: refused as a leak that short-circuits the actuator.
MIN_LEAK_STEP_S = DEFAULT_MAX_STEP_S / 16


def initial_leak_coefficient(leak_lpm: float, leak_model: str, load: str) -> float:
    """First guess of the leakage coefficient for a target mean leak.

    Parameters
    ----------
    leak_lpm : float
        Target mean leak in L/min.
    leak_model : {"turbulent", "laminar"}
        Eq. 2-4 or Eq. 2-5.
    load : {"none", "spring"}
        Sets the typical load pressure used (30 kPa without load, 0.8 MPa with the spring).

    Returns
    -------
    float
        ``Q / sqrt(dp)`` (turbulent) or ``Q / dp`` (laminar), SI.

    Examples
    --------
    >>> round(initial_leak_coefficient(0.6, "laminar", "spring"), 20)
    1.25e-11
    """
    dp = _TYPICAL_LOAD_PRESSURE_PA[load]
    q = lpm_to_m3s(leak_lpm)
    return q / math.sqrt(dp) if leak_model == "turbulent" else q / dp


def _leak_stable_substeps(k_leak: float, leak_model: str, params: VCAParams, fs: float) -> int:
    r"""RK4 steps per sample that keep the leak path stable: ``h * lambda_leak <= 1``.

    The leak couples the chambers with rate :math:`\lambda = \beta (1/V_1 + 1/V_2)\,
    dQ_l/d\Delta p`; with the volumes taken as ``V/2`` (a factor-2 margin for an off-centre
    piston) :math:`\lambda = 4 \beta\, dQ_l/d\Delta p / V`. The slope is :math:`k_l` (laminar)
    or :math:`k_l/\sqrt{p_{tr}}` (regularised turbulent law at 0).
    """
    if k_leak <= 0:
        return 1
    slope = k_leak if leak_model == "laminar" else k_leak / math.sqrt(
        params.leak_transition_pressure_pa)
    lam = 4.0 * params.bulk_modulus_pa * slope / params.chamber_volume_m3
    return max(1, math.ceil(lam / fs))


class _OnsetRestarts:
    """Leak calibration that integrates the leak-free part before the onset once.

    Samples ``[0, split)`` do not depend on the leak coefficient (the schedule is 0 there,
    ``split`` = onset sample - 1 so that no RK4 stage reaches the onset), so they are
    integrated once, at the base step, into the shared output buffer, and every trial
    coefficient restarts from a copy of the carry at ``split`` and overwrites only the samples
    from ``split`` on. The stitched run equals a full run with that coefficient bit for bit;
    after each :meth:`run` the buffer holds that run (the calibration accepts its last run).
    """

    def __init__(self, loop: _SegmentedLoop, split: int, n_sub: int, chunk: int, progress):
        self.loop, self.n_sub, self.chunk, self.progress = loop, n_sub, chunk, progress
        self.result = loop.empty_result()
        self._carry = loop.start()
        loop.advance(self._carry, split, n_sub, loop.coefficients(0.0), self.result, chunk,
                     progress)

    def run(self, k_leak: float, n_sub_after: int, stop: int | None = None) -> ClosedLoopResult:
        """The whole run with coefficient ``k_leak``, ``n_sub_after`` RK4 steps per sample from
        ``split`` on (the leak's stable step); only the part after the onset is new.

        With ``stop``, a pilot: only samples ``[split, stop)`` are integrated, and the buffer
        is a whole run again only after the next :meth:`run` without ``stop``.
        """
        self.loop.advance(self._carry.copy(), self.loop.n if stop is None else stop,
                          n_sub_after, self.loop.coefficients(k_leak), self.result, self.chunk,
                          self.progress)
        return self.result


def _antialias(cutoff_hz: float, fs: float) -> np.ndarray:
    """Anti-alias sections, with an error that names the sample rate and the machine."""
    if not cutoff_hz < fs / 2:
        raise ValueError(f"antialias_cutoff_hz={cutoff_hz:.4g} (sensor_params or machine) must "
                         f"be below the Nyquist frequency of sample_rate={fs:g} Hz")
    return antialias_sos(cutoff_hz, fs)


def _python_controller_run(controller, x_ref, fs, steps, prm, u_max, k_leak, sched, cond, s0,
                           noise1, noise2, sensors: SensorParams | None) -> ClosedLoopResult:
    """Slow path: a user controller ``u = controller(t, x_ref, x_m, p1_m, p2_m)`` in Python.

    ``steps = (n_sub, split, n_sub_after)``: RK4 steps per sample before sample ``split`` and
    from it on, as the compiled path.
    """
    n_sub_before, split, n_sub_after = steps
    n = x_ref.size
    sos = zi1 = zi2 = None
    if sensors is not None and sensors.antialias_cutoff_hz is not None:
        from scipy.signal import sosfilt_zi

        sos = _antialias(sensors.antialias_cutoff_hz, fs)
        zi_unit = sosfilt_zi(sos)
    out_state = np.empty((n, 6))
    out_meas = np.empty((n, 3))
    out_u = np.empty(n)
    out_q = np.empty(n)
    s = s0.copy()
    sched_arr = sched.to_array()
    for k in range(n):
        t = k / fs
        out_state[k] = s
        out_q[k] = vca_leak_flow(s[S_P1], s[S_P2], k_leak * sched.multiplier(t), prm)
        if sensors is not None:
            fsc, q = sensors.pressure_full_scale_pa, sensors.pressure_quantum_pa
            xm = quantize(s[S_X], sensors.position_resolution_m)
            g1, o1 = sensors.transducer_error("p1")
            g2, o2 = sensors.transducer_error("p2")
            r1, r2 = g1 * s[S_P1] + o1, g2 * s[S_P2] + o2
            if sos is not None:
                a1, a2 = r1 + noise1[k], r2 + noise2[k]
                if k == 0:
                    zi1, zi2 = zi_unit * a1, zi_unit * a2
                p1m = adc_reading(sos_step(a1, sos, zi1), 0.0, fsc, q)
                p2m = adc_reading(sos_step(a2, sos, zi2), 0.0, fsc, q)
            else:
                p1m = adc_reading(r1, noise1[k], fsc, q)
                p2m = adc_reading(r2, noise2[k], fsc, q)
        else:
            xm, p1m, p2m = s[S_X], s[S_P1], s[S_P2]
        out_meas[k] = (xm, p1m, p2m)
        u = float(controller(t, x_ref[k], xm, p1m, p2m))
        if not math.isfinite(u):
            raise ValueError(f"controller returned u={u!r} at t={t} s")
        u = min(max(u, -u_max), u_max)
        if sensors is not None:  # 12-bit DAC, as in the compiled path
            u = float(quantize(u, 2 * u_max / 2.0**sensors.control_dac_bits))
        out_u[k] = u
        n_sub = n_sub_before if k < split else n_sub_after
        rk4_advance(s, t, 1.0 / fs / n_sub, n_sub, u + valve_null_v(t, prm, cond), k_leak,
                    sched_arr, cond, prm)
    return ClosedLoopResult(out_state, out_meas, out_u, out_q)


def simulate_vca(
    *,
    duration: float = DEFAULT_DURATION_S,
    leak_lpm: float | None = 0.10,
    onset: float | None = None,
    leak_kind: str = "step",
    ramp_duration: float = 100.0,
    leak_model: str = "turbulent",
    leak_coefficient: float | None = None,
    calibration_rtol: float = 0.02,
    load: str = "none",
    seed: int = 1,
    sample_rate: float = 1000.0,
    sensors: bool = True,
    sensor_params: SensorParams | None = None,
    params: VCAParams | None = None,
    conditions: OperatingConditions | None = None,
    machine: VCAMachine | int | None = None,
    progress: Callable[[int], None] | None = None,
    reference=None,
    reference_seed: int | None = None,
    controller: FixedGainController | Callable | None = None,
    max_step: float = DEFAULT_MAX_STEP_S,
) -> Recording:
    """Simulate a closed-loop valve-controlled actuator experiment (thesis Ch. 2, Sec. 4.5).

    Parameters
    ----------
    duration : float, default 400.0
        Length of the run in s (Sec. 4.5: 400 s).
    leak_lpm : float or None, default 0.10
        Target mean leak after the onset in L/min (Sec. 5.1: 0.047-0.5); 0 or None: no leak.
    onset : float, optional
        Leak onset in s; must lie inside the run. Default: half of ``duration`` (Sec. 4.5:
        leak introduced at 200 s of the 400 s run).
    leak_model : {"turbulent", "laminar"}, default "turbulent"
        Eq. 2-4 or Eq. 2-5.
    load : {"none", "spring"}, default "none"
        No load, or the spring of ``params.spring_stiffness_n_per_m`` (Sec. 4.5).
    seed : int, default 1
        Seed of the reference sequence and the sensor noise: same seed, same output bit for bit.
    sensors : bool, default True
        Record measured signals (ADC, noise, encoder, DAC). False: the true, noise-free states
        at the output rate (the controller then also sees the true position), for physics checks.
    params : VCAParams, optional
        Physical parameters; default Table 2-1.
    sample_rate : float, default 1000.0
        Output and control rate in Hz (not stated in the thesis; 1 kHz chosen).
    leak_kind : {"step", "ramp"}, default "step"
        Step at the onset, or linear ramp over ``ramp_duration`` (seal wear).
    ramp_duration : float, default 100.0
        Ramp length in s.
    leak_coefficient : float, optional
        Use this leakage coefficient instead of calibrating one to ``leak_lpm``.
        It needs ``leak_lpm`` > 0 (the leak and its onset), and ``meta['leak_lpm']`` is then
        the run's mean leak since the onset (the coefficient's, not a target).
    reference : optional
        Anything :func:`~leakdiag.sim.reference.as_reference` accepts; default pseudorandom
        steps of 2-20 mm.
    reference_seed : int, optional
        Seed of the reference alone (another reference sequence for the same noise).
    controller : FixedGainController or callable, optional
        Fixed-gain gains (fast compiled path), or ``controller(t, x_ref, x_m, p1_m, p2_m) -> u``
        in Python (slow path, about 100x slower).
    conditions : OperatingConditions, optional
        Supply ripple, temperature drift, spring change; default nominal.
    sensor_params : SensorParams, optional
        Sensor chain; default Sec. 2.2.
    max_step : float, default 2.5e-4
        Largest RK4 step in s; the step is ``1 / (sample_rate * ceil(1 / (sample_rate * max_step)))``.
    calibration_rtol : float, default 0.02
        Relative tolerance of the leak calibration.
    progress : callable, optional
        ``progress(n)`` with the samples integrated since its last call (as ``tqdm.update``),
        every 10 s of simulated time; a leak's calibration reruns the part after the onset, so
        the calls may add up to more than the run's samples.
    machine : None, int or VCAMachine, default None
        The unit: None is the nominal Table 2-1 rig; an int draws that unit with
        :func:`~leakdiag.sim.machine.draw_machine` (its own random stream, independent of
        ``seed``); a :class:`~leakdiag.sim.machine.VCAMachine` is used as given. Its
        deviations apply on top of ``params`` and ``sensor_params``.

    Returns
    -------
    Recording
        Channels ``p1``, ``p2`` (Pa), ``x`` (m), ``u`` (V), ``leak_flow`` (m^3/s, true), ``x_ref``
        (m). ``meta``: ``system="vca"``, ``onset`` (None without leak), ``leak_lpm`` (target),
        ``leak_lpm_achieved``, ``leak_coefficient``, ``leak_reference_dp_pa`` (1 MPa),
        ``leak_lpm_at_reference_dp`` (the leak law with the full coefficient at that pressure
        difference, L/min), ``leak_model``, ``leak_kind``, ``load``,
        ``seed``, ``params`` (dict, the unit's), ``controller``, ``sensors``, ``conditions``,
        ``rk4_step_s`` (after the onset), ``rk4_step_before_onset_s``, ``calibration_runs``,
        ``calibration_pilot_runs``, ``rated_flow_lpm``, ``machine``
        (:meth:`VCAMachine.to_dict`), ``leakdiag_version``, ``source``.

    Raises
    ------
    ValueError
        If an argument is out of range (the message names it), e.g. an onset outside the run,
        or a sample rate at which the fixed-gain controller's loop is unstable
        (:meth:`FixedGainController.position_loop_gain_per_s`: below 45.6 Hz for Table 2-1).
    leakdiag.sim.leak.LeakCalibrationError
        If the leak cannot be calibrated to the target, or a coefficient would need an RK4
        step below :data:`MIN_LEAK_STEP_S` to stay stable; when the run after the
        onset is shorter than :data:`~leakdiag.sim.leak.MIN_CALIBRATION_WINDOW_S` the message
        says the run is too short to calibrate.

    Notes
    -----
    Model: Eqs. 2-1 to 2-5 (see :func:`~leakdiag.sim.vca.model.vca_rhs`). Integration: fixed-step
    RK4, control held between samples; the leak-free part before the onset at the step of
    ``max_step``, the part after it at the leak's stable step (``rk4_step_before_onset_s``,
    ``rk4_step_s``). The achieved leak is the mean of :math:`|Q_l|` over the
    samples at or after the onset (Sec. 4.5, "the mean of the leak after 200 seconds"). The
    calibration integrates the leak-free part before the onset once, takes its first guess of
    the coefficient from the healthy pressures there (with the window after the onset
    predicted from the reference when the load pressure follows it, e.g. with the spring), and
    reruns only the part after the onset (same seed, bit-identical to a full run with that
    coefficient) until the mean is within ``calibration_rtol``; the delivered run is checked
    against the target. When the first run misses, a pilot reruns only the first 10 % of the
    window after the onset (at least 10 s, :data:`~leakdiag.sim.leak.SLOPE_PILOT_FRACTION`) at
    the proportional step, and the correction uses the log-log slope it measures.
    ``calibration_runs`` counts the post-onset runs (1 with the spring in the cases measured,
    mostly 2 without load, where the pressures react to the leak), ``calibration_pilot_runs``
    the slope pilots (0 or 1; a coarser-step pilot of the whole window was tried and rejected,
    without load it is biased by up to 40 %, docs/models.md). A Python ``controller`` reruns
    whole experiments.

    Examples
    --------
    >>> rec = simulate_vca(duration=4.0, leak_lpm=None, seed=3)
    >>> rec.channel_names
    ['p1', 'p2', 'x', 'u', 'leak_flow', 'x_ref']
    >>> rec.meta["system"], rec.meta["leak_lpm_achieved"], rec.n_samples
    ('vca', 0.0, 4000)
    """
    exp = setup("vca", duration=duration, sample_rate=sample_rate, load=load, loads=LOADS,
                leak_model=leak_model, leak_models=LEAK_MODELS, leak_kind=leak_kind, seed=seed,
                params=params, params_cls=VCAParams, sensor_params=sensor_params,
                default_sensors=SensorParams(), machine=machine,
                sensors=sensors, progress=progress, calibration_rtol=calibration_rtol,
                extra_checks=lambda: check_positive(max_step, "max_step"))
    duration, fs, n = exp.duration, exp.sample_rate, exp.n
    params, sensor_params, machine = exp.params, exp.sensor_params, exp.machine
    max_step = float(max_step)
    conditions = check_params_type(conditions, OperatingConditions, "conditions")
    if not conditions.supply_ripple_pa < params.supply_pressure_pa:  # (a simulator audit,
        # 2026-11-29: a 20 MPa ripple on a 17.2 MPa supply was taken)
        raise ValueError(f"conditions.supply_ripple_pa={conditions.supply_ripple_pa:g} must be "
                         f"below the supply pressure ({params.supply_pressure_pa:g} Pa)")
    n_sub = max(1, math.ceil(1.0 / (fs * max_step) - 1e-9))

    def below_rated_flow(lpm: float) -> None:
        if lpm >= params.rated_flow_lpm:
            raise ValueError(f"leak_lpm={lpm} must be below the rated flow "
                             f"{params.rated_flow_lpm:.1f} L/min")

    if onset is None:  # half the run, as the thesis's experiments (and the CLI)
        onset = duration / 2.0
    plan = plan_leak(leak_lpm, onset, leak_kind, ramp_duration, n=n, sample_rate=fs,
                     duration=duration, check_target=below_rated_flow)
    sched = plan.schedule

    # --- random streams: reference and noise independent, both from `seed`
    ref_ss, noise_ss = random_streams(seed)
    if reference_seed is not None:  # (numpy's "expected non-negative integer" named nothing)
        reference_seed = check_int(reference_seed, "reference_seed", 0)
    ref_rng = np.random.default_rng(ref_ss if reference_seed is None else reference_seed)
    t = np.arange(n) / fs
    x_ref = np.ascontiguousarray(as_reference(reference).samples(t, ref_rng), dtype=np.float64)
    noise = np.random.default_rng(noise_ss).standard_normal((2, n))
    noise *= sensor_params.pressure_noise_std_pa
    sens_arr = sos = None
    if sensors:
        sens_arr = np.array([sensor_params.position_resolution_m,
                             sensor_params.pressure_full_scale_pa,
                             sensor_params.pressure_quantum_pa,
                             2 * params.control_limit_v / 2.0**sensor_params.control_dac_bits,
                             *sensor_params.transducer_error("p1"),
                             *sensor_params.transducer_error("p2")])
        if sensor_params.antialias_cutoff_hz is not None:
            sos = _antialias(sensor_params.antialias_cutoff_hz, fs)

    prm = params.to_array(leak_model, load)
    cond = conditions.to_array(duration)
    p_mid = 0.5 * (params.supply_pressure_pa + params.tank_pressure_pa)
    s0 = np.array([0.0, 0.0, p_mid, p_mid, 0.0, 0.0])
    ctrl = FixedGainController() if controller is None else controller
    chunk = max(1, int(round(_CHUNK_S * fs)))

    fixed = isinstance(ctrl, FixedGainController)
    if not fixed and not callable(ctrl):
        raise TypeError("controller must be a FixedGainController or a callable")
    loop = None
    if fixed:
        gain = ctrl.position_loop_gain_per_s(params)
        if gain / fs >= 2.0:
            raise ValueError(
                f"sample_rate={fs:g} Hz is too low for the fixed-gain controller, which runs at "
                f"the sample rate: its position loop (gain K_p k_v K_q / A = {gain:.3g} 1/s) is "
                f"a sampled integrator, unstable at gain x period >= 2; give a rate above "
                f"{gain / 2.0:.3g} Hz (the thesis's rig: 1000 Hz), or, in Python, a lower "
                "position_gain_v_per_m or a controller of your own")
        loop = _SegmentedLoop(x_ref, fs, prm, ctrl.to_array(), params.control_limit_v,
                              sched.to_array(), cond, s0, noise[0], noise[1], sens_arr, sos)

    def substeps(k_leak: float) -> int:
        n_leak = _leak_stable_substeps(k_leak, leak_model, params, fs)
        # the leak's own step (1 step per sample: no demand of its own, whatever the rate)
        if n_leak > 1 and n_leak * fs * MIN_LEAK_STEP_S > 1.0 + 1e-9:
            raise LeakCalibrationError(
                f"leak coefficient {k_leak:.4g} ({leak_model}) would need {n_leak} RK4 steps per "
                f"sample at {fs:g} Hz (steps of {1e6 / (n_leak * fs):.3g} us, below the "
                f"{MIN_LEAK_STEP_S * 1e6:.3g} us allowed); such a leak short-circuits the "
                f"actuator (rated flow {params.rated_flow_lpm:.1f} L/min)"
            )
        return max(n_sub, n_leak)

    i_on = plan.onset_index
    # samples [0, split) carry no leak, whatever the coefficient (split = onset sample - 1, so
    # that no RK4 stage reaches the onset); without a leak the whole run is one part
    split = max(i_on - 1, 0) if plan.active else n

    def run(k_leak: float) -> ClosedLoopResult:
        # the leak-free part at the base step, the rest at the leak's stable step
        n_sub_k = substeps(k_leak)
        if fixed:
            out = loop.empty_result()
            carry, k_arr = loop.start(), loop.coefficients(k_leak)
            loop.advance(carry, split, n_sub, k_arr, out, chunk, progress)
            loop.advance(carry, n, n_sub_k, k_arr, out, chunk, progress)
            return out
        return _python_controller_run(ctrl, x_ref, fs, (n_sub, split, n_sub_k), prm,
                                      params.control_limit_v, k_leak, sched, cond, s0, noise[0],
                                      noise[1], sensor_params if sensors else None)

    ptr = params.leak_transition_pressure_pa
    laminar = leak_model == "laminar"
    cal = None
    check_coefficient_has_a_leak(leak_coefficient, plan)
    if not plan.active:
        k_leak = 0.0
        result = run(0.0)
    elif leak_coefficient is not None:
        k_leak = check_positive(leak_coefficient, "leak_coefficient")
        result = run(k_leak)
    else:
        history: list[tuple[float, float]] = []
        k0 = slope_pilot = None
        if fixed:
            segments = _OnsetRestarts(loop, split, n_sub, chunk, progress)
            stop = plan.pilot_stop
            pilot_means: dict[float, float] = {}

            def simulate_fn(k: float) -> float:
                flow = segments.run(k, substeps(k)).leak_flow
                q = plan.mean_lpm(flow)
                if stop is not None:
                    pilot_means[k] = plan.pilot_mean_lpm(flow)
                history.append((k, q))
                return q

            def first_slope(k0: float, k1: float) -> float | None:
                # the first run's stretch [onset, stop) against a pilot over it at k1
                q1 = plan.pilot_mean_lpm(segments.run(k1, substeps(k1), stop).leak_flow)
                return log_slope(k0, pilot_means[k0], k1, q1)

            if stop is not None:
                slope_pilot = first_slope

            pre = segments.result  # valid on [0, split) until the first trial
            k0 = coefficient_from_healthy(pre.state[:, S_P1], pre.state[:, S_P2], split, plan,
                                          ptr, laminar, reference=x_ref)
        else:
            runs: dict[float, ClosedLoopResult] = {}

            def simulate_fn(k: float) -> float:
                runs[k] = run(k)
                q = plan.mean_lpm(runs[k].leak_flow)
                history.append((k, q))
                return q

        if k0 is None:
            k0 = initial_leak_coefficient(plan.target_lpm, leak_model, load)
        cal = calibrate_leak(plan, simulate_fn, k0, calibration_rtol, history,
                             first_slope=slope_pilot)
        k_leak = cal.coefficient
        result = segments.result if fixed else runs[k_leak]

    if sensors:
        x_out, p1_out, p2_out = result.measured[:, 0], result.measured[:, 1], result.measured[:, 2]
        if sensor_params.transducer_bandwidth_hz is not None:
            # The closed loop reads the pressures through the transducer errors, the anti-alias
            # filter and the converter (machine.py); the transducer's own bandwidth is applied to
            # the recorded pressures only: the whole chain (sensor_chain.pressure_chain) with the
            # same noise.
            p1_out = pressure_chain(result.state[:, 2], noise[0], sensor_params, channel="p1",
                                    sample_rate=fs)
            p2_out = pressure_chain(result.state[:, 3], noise[1], sensor_params, channel="p2",
                                    sample_rate=fs)
    else:
        x_out, p1_out, p2_out = result.state[:, 0], result.state[:, 2], result.state[:, 3]
    meta = experiment_metadata(
        "vca", plan, result.leak_flow, k_leak=k_leak, leak_model=leak_model, transition_pa=ptr,
        load=load, seed=seed, params=params, sensors=sensors, sensor_params=sensor_params,
        conditions=conditions, machine=machine, calibration=cal,
        calibration_rtol=calibration_rtol, rated_flow_lpm=params.rated_flow_lpm,
        ramp_duration=ramp_duration)
    meta.update({
        "reference_seed": reference_seed,
        "reference": type(as_reference(reference)).__name__,
        "controller": ctrl.to_dict() if isinstance(ctrl, FixedGainController) else repr(ctrl),
        "rk4_step_s": 1.0 / (fs * max(n_sub, _leak_stable_substeps(k_leak, leak_model, params,
                                                                   fs))),
        "rk4_step_before_onset_s": 1.0 / (fs * n_sub),
    })
    channels = {"p1": p1_out, "p2": p2_out, "x": x_out, "u": result.u,
                "leak_flow": result.leak_flow, "x_ref": x_ref}
    return Recording({k: np.array(v) for k, v in channels.items()}, fs, 0.0, {}, meta)
