"""Extended Kalman filter on the VCA model with a leak-coefficient state (An & Sepehri 2005).

The filter tracks the VCA states of Eq. 2-1 (position, velocity, both chamber pressures, spool
position and velocity) plus the leakage coefficient :math:`k_l` of Eq. 2-4 as a random walk,
from the measured control signal ``u`` and the measurements ``x``, ``p1``, ``p2``. Its
innovations (measurement minus prediction) are the residuals of An & Sepehri; the coefficient's
estimate, multiplied by :math:`\\sqrt{|P_1 - P_2|}`, gives the leak flow in L/min.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from leakdiag._format import seconds
from leakdiag._holds import holds
from leakdiag._validation import check_int, check_overlap, check_positive
from leakdiag.detect._rig_units import check_rig_units
from leakdiag.detect.flow_balance import HOLD_FACTOR
from leakdiag.features._degenerate import warn_degenerate
from leakdiag.features.series import FeatureSeries
from leakdiag.features.windowing import window_starts, window_step, window_times
from leakdiag.literature._ekf_kernel import ekf_vca_kernel
from leakdiag.literature._windowed import check_finite_channels, windowed_mean
from leakdiag.sim.leak import LPM_PER_M3S
from leakdiag.sim.vca.params import VCAParams

__all__ = ["EKFParams", "EKFResult", "run_vca_ekf", "ekf_feature", "EKF_FEATURES",
           "match_measurement_noise", "NoiseMatch", "longest_holds_s", "HOLD_FACTOR",
           "MEASURED"]

#: Features the EKF detector can score: mean estimated leak flow, innovation RMS, or the
#: standardised leak coefficient (windowed mean of k_l over the root of its mean variance).
EKF_FEATURES = ("leak_flow", "residual", "coefficient")

# State scaling (choice): 1 mm, 1 cm/s, 1 bar, 10 um spool, 1 cm/s spool, 1e-9 m^3/(s sqrt(Pa)),
# 100 N of load-force disturbance.
_SCALE = np.array([1e-3, 1e-2, 1e5, 1e5, 1e-5, 1e-2, 1e-9, 1e2])
#: Floor of a pressure noise matched to the data (Pa): a noise-free (simulated) recording
#: would otherwise get R = 0 and an overconfident filter (leakdiag choice).
NOISE_FLOOR_PA = 1e3
#: Seconds at the start of a recording the noise matching leaves out (the filter's initial
#: transient from its wide initial covariance; leakdiag choice).
MATCH_SKIP_S = 1.0
#: Most seconds of healthy signal the noise matching runs the filter over per pass (leakdiag
#: choice: bounds a fit's cost, about 15 passes).
MATCH_MAX_SIGNAL_S = 120.0
#: Bound of the matching's doubling (Pa): a noise that would pass it is refused (the last one
#: tried is 65.5 MPa).
NOISE_CEILING_PA = 1e8
#: Median of the chi-square distribution with 1 degree of freedom, ``(Phi^-1(3/4))^2``: the
#: median of ``e^2 / S`` for a Gaussian innovation whose variance the filter knows.
CHI2_1_MEDIAN = 0.4549364231195724
#: Measured channels, in the filter's measurement order.
MEASURED = ("x", "p1", "p2")
# HOLD_FACTOR (imported): how many times longer than the healthy recordings' longest a measured
# channel may hold one exact value before the filter treats it as frozen, the flow balance's
# own factor (one leakdiag choice for both): the encoder holds its count whenever the piston
# rests (healthy VCA runs: up to about 3 s under the pseudorandom steps, 1.9-3.1 s on nominal
# 60-s runs), a noisy pressure transducer for about 15 samples at most.


@dataclass(frozen=True)
class EKFParams:
    """Settings of the VCA extended Kalman filter.

    Parameters
    ----------
    model : VCAParams, default VCAParams()
        Model parameters the filter assumes (Table 2-1 by default).
    load : {"none", "spring"}, default "none"
        Load the filter assumes (as in :meth:`VCAParams.to_array`).
    leak_model : {"turbulent", "laminar"}, default "turbulent"
        Leak law of the coefficient state (Eq. 2-4 or 2-5).
    pressure_noise_std_pa : float, (float, float) or None, default 10e3
        Measurement noise of each pressure, or of ``p1`` and ``p2``, Pa; None matches it to
        the filter's innovations on the recording itself (:func:`match_measurement_noise`:
        only for a recording known to be healthy; a detector matches it on its healthy
        recordings instead, :class:`~leakdiag.literature.detectors.EKFDetector`).
    position_noise_std_m : float, default 1e-5
        Measurement noise of the position (0.03 mm encoder quantum / sqrt(12) ~ 9 um).
    pressure_process_std_pa : float, default 2e3
        Process noise of each pressure per sample (model error, supply ripple).
    velocity_process_std_m_per_s : float, default 1e-4
        Process noise of the velocity per sample (unmodelled forces).
    force_disturbance_walk_n : float, default 200.0
        Random-walk intensity of the load-force disturbance state, N per square-root second
        (an unmodelled spring, load or friction change goes there instead of into k_l).
    leak_coefficient_walk : float, default 2e-10
        Random-walk intensity of :math:`k_l`, in coefficient units per square-root second:
        in one second the coefficient may drift by about this much (0.2e-9 is about
        0.025 L/min at 4 MPa pressure difference).
    substeps : int, default 4
        RK4 substeps per sample for the prediction.
    max_hold_s : tuple of 3 float or None, default None
        Longest hold of one exact value (s) of ``x``, ``p1``, ``p2`` taken as measured; a
        channel holding one value for longer is frozen there (a stuck sensor): the filter does
        not use its samples over the hold, and every window overlapping it is NaN. None: no
        limit. :class:`~leakdiag.literature.detectors.EKFDetector` sets ``HOLD_FACTOR`` times
        its healthy recordings' longest holds.
    window : int, default 1000
        Window size N in samples for the windowed features.
    overlap : float, default 50
        Overlap in percent.
    feature : {"leak_flow", "residual", "coefficient"}, default "leak_flow"
        ``"leak_flow"``: windowed mean of the estimated leak flow, L/min. ``"residual"``:
        windowed RMS of the normalised innovations (dimensionless, 1 when the model fits).
        ``"coefficient"``: windowed mean of :math:`\\hat k_l` over the square root of its
        windowed mean variance (dimensionless).

    Raises
    ------
    ValueError
        For a value out of range (the message names it).
    """

    model: VCAParams = field(default_factory=VCAParams)
    load: str = "none"
    leak_model: str = "turbulent"
    pressure_noise_std_pa: float | tuple | None = 10e3
    position_noise_std_m: float = 1e-5
    pressure_process_std_pa: float = 2e3
    velocity_process_std_m_per_s: float = 1e-4
    leak_coefficient_walk: float = 2e-10
    force_disturbance_walk_n: float = 200.0
    substeps: int = 4
    max_hold_s: tuple | None = None
    window: int = 1000
    overlap: float = 50.0
    feature: str = "leak_flow"

    def __post_init__(self) -> None:
        if not isinstance(self.model, VCAParams):
            raise TypeError(f"model={self.model!r} must be a VCAParams")
        self.model.to_array(self.leak_model, self.load)  # validates both names
        for name in ("position_noise_std_m", "pressure_process_std_pa",
                     "velocity_process_std_m_per_s", "leak_coefficient_walk",
                     "force_disturbance_walk_n"):
            check_positive(getattr(self, name), name)
        noise = self.pressure_noise_std_pa
        if noise is not None and np.ndim(noise) == 0:
            check_positive(noise, "pressure_noise_std_pa")
        elif noise is not None:
            if len(noise) != 2:
                raise ValueError(f"pressure_noise_std_pa={noise!r} must be a number, one per "
                                 "pressure (p1, p2), or None")
            object.__setattr__(self, "pressure_noise_std_pa", tuple(
                check_positive(v, f"pressure_noise_std_pa[{c!r}]")
                for c, v in zip(("p1", "p2"), noise)))
        check_int(self.substeps, "substeps", 1)
        if self.max_hold_s is not None:
            if len(self.max_hold_s) != len(MEASURED):
                raise ValueError(f"max_hold_s={self.max_hold_s!r} must give one limit (s) per "
                                 f"measured channel {MEASURED}")
            object.__setattr__(self, "max_hold_s", tuple(
                check_positive(v, f"max_hold_s[{c!r}]") for c, v in zip(MEASURED, self.max_hold_s)))
        check_int(self.window, "window", 2)
        check_overlap(self.overlap)
        if self.feature not in EKF_FEATURES:
            raise ValueError(f"feature={self.feature!r} must be one of {EKF_FEATURES}")


@dataclass(frozen=True)
class EKFResult:
    """Per-sample output of :func:`run_vca_ekf`.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times, s, shape ``(n,)``.
    states : numpy.ndarray
        Filtered ``[x, v, p1, p2, xv, vv, k_l, f_d]`` (m, m/s, Pa, Pa, m, m/s, coefficient
        units, N), shape ``(n, 8)``.
    innovations : numpy.ndarray
        Measurement minus prediction of ``x`` (m), ``p1``, ``p2`` (Pa), shape ``(n, 3)``.
    nis : numpy.ndarray
        Normalised innovation squared :math:`e^T S^{-1} e` (chi-square, 3 dof), shape ``(n,)``.
    leak_flow_lpm : numpy.ndarray
        Estimated leak flow :math:`\\hat k_l\\,\\mathrm{sgn}(\\Delta P)\\sqrt{|\\Delta P|}`, L/min.
    n_skipped : int
        Samples whose innovation covariance was singular: update skipped, ``nis`` is NaN there
        (0 with positive measurement noise).
    leak_coefficient_var : numpy.ndarray or None
        Filter variance of :math:`\\hat k_l` per sample.
    pressure_noise_std_pa : tuple of float or None
        Measurement noise used for ``p1`` and ``p2`` (given or estimated).
    innovation_var : numpy.ndarray or None
        Diagonal of the innovation covariance :math:`S` of ``x`` (m^2), ``p1``, ``p2`` (Pa^2),
        shape ``(n, 3)``: :math:`e_i^2 / S_{ii}` has mean 1 when the filter's noise model
        fits.
    frozen : tuple of (str, int, int)
        Holds of a measured channel longer than ``EKFParams.max_hold_s``: ``(channel, first
        sample, last sample)``. Their samples were not used (innovation and ``innovation_var``
        NaN there).
    """

    time: np.ndarray
    states: np.ndarray
    innovations: np.ndarray
    nis: np.ndarray
    leak_flow_lpm: np.ndarray
    n_skipped: int = 0
    leak_coefficient_var: np.ndarray | None = None
    pressure_noise_std_pa: tuple | None = None
    innovation_var: np.ndarray | None = None
    frozen: tuple = ()

    @property
    def leak_coefficient(self) -> np.ndarray:
        """Estimated leak coefficient :math:`\\hat k_l` per sample."""
        return self.states[:, 6]

    @property
    def leak_size_lpm(self) -> np.ndarray:
        """The leak's size with the sign of :math:`\\hat k_l`, L/min per sample.

        :math:`\\hat k_l\\,|g(\\Delta\\hat P)|` with :math:`g` the leak law (Eq. 2-4 or 2-5,
        odd in :math:`\\Delta P`): the flow's magnitude when :math:`\\hat k_l \\ge 0`, and
        negative when the filter's coefficient is (model bias, kept visible rather than
        folded into a positive flow by ``abs``).
        """
        dp = self.states[:, 2] - self.states[:, 3]
        return self.leak_flow_lpm * np.sign(dp)

    @property
    def load_force_disturbance_n(self) -> np.ndarray:
        """Estimated load-force disturbance per sample, N."""
        return self.states[:, 7]


def longest_holds_s(recording) -> tuple[float, float, float]:
    """Longest hold of one exact value of each measured channel (``x``, ``p1``, ``p2``), s.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Holds the measured channels.

    Returns
    -------
    tuple of 3 float
        Seconds (samples / sample rate).

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"x": [0.0, 0.0, 0.0, 1.0], "p1": [1.0, 2.0, 3.0, 4.0],
    ...                  "p2": [5.0, 5.0, 6.0, 7.0]}, sample_rate=10.0)
    >>> longest_holds_s(rec)
    (0.3, 0.1, 0.2)
    """
    return tuple(float(holds(recording[c])[1].max(initial=0)) / recording.sample_rate
                 for c in MEASURED)


def _frozen_holds(recording, max_hold_s) -> tuple[np.ndarray, tuple]:
    """The measurement-use mask ``(n, 3)`` and the holds longer than ``max_hold_s``."""
    n = recording.n_samples
    use = np.ones((n, len(MEASURED)), dtype=np.bool_)
    found = []
    if max_hold_s is None:
        return use, ()
    for j, (c, limit) in enumerate(zip(MEASURED, max_hold_s)):
        starts, lengths = holds(recording[c])
        for i0, m in zip(starts, lengths):
            if m > limit * recording.sample_rate + 1e-6:  # a hold of the limit is kept
                use[i0:i0 + m, j] = False
                found.append((c, int(i0), int(i0 + m - 1)))
    return use, tuple(sorted(found, key=lambda h: h[1]))


@dataclass(frozen=True)
class NoiseMatch:
    """Pressure measurement noise matched to a filter's innovations
    (:func:`match_measurement_noise`).

    Attributes
    ----------
    pressure_noise_std_pa : float
        Matched measurement noise of each pressure (``p1`` and ``p2``), Pa.
    median_ratio : float
        Median of the pressures' :math:`e_i^2 / S_{ii}` over ``CHI2_1_MEDIAN`` at the matched
        value: at most 1 by construction, just below it unless the floor was reached.
    ratio : tuple of float
        Mean :math:`e_i^2 / S_{ii}` of ``x``, ``p1``, ``p2`` at the matched value (1 when the
        noise model fits every innovation; more when the model misses some).
    mean_nis : float
        Mean NIS at the matched value (3, the measurement dimension, when the noise model
        fits all three channels; the position's noise is not matched).
    passes : int
        Filter passes run.
    signal_s : float
        Seconds of signal per pass.
    """

    pressure_noise_std_pa: float
    median_ratio: float
    ratio: tuple
    mean_nis: float
    passes: int
    signal_s: float


def _innovation_stats(recs, params, sigma, skip_s, max_signal_s):
    """One filter pass over ``recs`` (up to ``max_signal_s`` s after ``skip_s`` in each) with
    pressure noise ``sigma``: the median of the pressures' ``e_i^2 / S_ii`` over its value for
    Gaussian innovations, the mean ``e_i^2 / S_ii`` per channel, the mean NIS, seconds used."""
    p = dataclasses.replace(params, pressure_noise_std_pa=float(sigma), max_hold_s=None)
    ratio, nis, n, used_s, pressure = np.zeros(3), 0.0, 0, 0.0, []
    for rec in recs:
        if used_s >= max_signal_s:
            break
        # the filter is causal: the part after what is used changes nothing, so it is not run
        rec = rec.slice_time(None, rec.start_time + skip_s + max_signal_s - used_s)
        res = run_vca_ekf(rec, p)
        t = res.time - rec.start_time
        keep = (t >= skip_s) & (t < skip_s + max_signal_s - used_s) & np.isfinite(res.nis)
        r = res.innovations[keep] ** 2 / res.innovation_var[keep]
        ratio += r.sum(axis=0)
        pressure.append(r[:, 1:].ravel())
        nis += float(res.nis[keep].sum())
        n += int(keep.sum())
        used_s += float(keep.sum()) / rec.sample_rate
    if n == 0:
        raise ValueError(f"match_measurement_noise: no sample after skip_s={skip_s:g} s in "
                         f"{len(recs)} recording(s)")
    med = float(np.median(np.concatenate(pressure))) / CHI2_1_MEDIAN
    return med, ratio / n, nis / n, used_s


def match_measurement_noise(recordings, params: "EKFParams | None" = None, *,
                            skip_s: float = MATCH_SKIP_S,
                            max_signal_s: float = MATCH_MAX_SIGNAL_S,
                            rtol: float = 0.01) -> NoiseMatch:
    """Pressure measurement noise that makes the bulk of the EKF's pressure innovations
    consistent (robust covariance matching).

    With :math:`e_i` the innovation of channel :math:`i` and :math:`S_{ii}` the filter's own
    variance of it, :math:`e_i^2 / S_{ii}` is chi-square with 1 degree of freedom when the
    filter's noise model fits, median ``CHI2_1_MEDIAN`` = 0.455. The matched value is the
    smallest pressure noise :math:`\\sigma` (the same for ``p1`` and ``p2``) at which the
    median of the pressures' :math:`e_i^2 / S_{ii}` is at most that: searched on a factor-2
    grid from ``NOISE_FLOOR_PA`` up, then by bisection (in :math:`\\log\\sigma`) to a
    relative width ``rtol``; one filter pass per value tried (11-17). The position's noise
    (``params.position_noise_std_m``, the encoder's) is kept.

    Parameters
    ----------
    recordings : Recording or sequence of Recording
        Healthy recordings (VCA), used in order up to ``max_signal_s`` seconds.
    params : EKFParams, optional
        Filter settings (default ``EKFParams()``); its ``pressure_noise_std_pa`` is ignored.
    skip_s : float, default 1.0
        Seconds at the start of each recording left out (the filter's initial transient).
    max_signal_s : float, default 120.0
        Most seconds of signal per pass (bounds the cost).
    rtol : float, default 0.01
        Relative precision of the result.

    Returns
    -------
    NoiseMatch

    Raises
    ------
    ValueError
        If no recording has a sample after ``skip_s``, or no noise the doubling reaches below
        ``NOISE_CEILING_PA`` (100 MPa; the last tried is 65.5 MPa) makes the
        innovations consistent.

    Notes
    -----
    What the value is. The innovations hold the sensor noise (after the anti-alias filter and
    the converter) and what the filter's model misses. On the simulator's nominal actuator
    (the filter's own model) it is the sensor noise: 9.7, 24.9, 40.2 kPa for 10, 25, 40 kPa,
    mean NIS 2.9-3.0. On a virtual machine (``machine=int``: an anti-alias filter delaying the
    pressures by about a sample, valve, supply and transducers off Table 2-1) the model misses
    the transients, where the innovations are large: under the spring load the bulk is
    sensor noise and the value is within 10 % of the chain's own noise after the anti-alias
    filter (machine 3: 6.7, 18.3, 30.1 kPa against 7.2, 17.7, 28.2 kPa), while the mean NIS
    is 7-33 from the missed transients; without load the model misses the bulk too and the
    value grows with the machine's error (machine 3: 84, 88, 93 kPa; machine 4: 8.6, 21, 32
    kPa). In every case tested it grows with the sensor noise, continuously.

    Why the median. Matching the mean (:math:`\\overline{e_i^2 / S_{ii}} = 1`, Mehra's
    covariance matching) lets the missed transients set :math:`\\sigma`: 300-410 kPa under the
    spring load on machines 1, 3, 5 and 6 (not monotone on machine 5), a filter that follows
    its model instead of the pressures; fitted on 20 healthy v5 runs it missed every
    0.5 L/min leak that the median's 25 kPa finds (5 of 5). Why one value for both pressures:
    matched apart, one channel took up the other's model error (machine 3, mean: 69 and 178
    kPa). Why not the position: matched with the pressures, the split between them was not
    identifiable (machine 5: 30 kPa and 0.23 mm, then 97 kPa and 0.02 mm between 25 and 40 kPa
    of sensor noise).

    The former estimate, the median of a channel's second differences, measured the 5.05 kPa
    converter step of a low-pass filtered pressure, not its noise: 3057, 9170 and 12226 Pa on
    machine 3 for 10, 25, 40 kPa (multiples of :math:`1.4826 \\cdot 5050 / \\sqrt 6`), mean
    NIS 45-69, and a feature that jumped between recordings whose estimate fell on different
    steps.

    References
    ----------
    .. [1] R. K. Mehra, "Approaches to adaptive filtering", IEEE Trans. Automatic Control
       17(5), 1972.

    Examples
    --------
    At rest the filter sees pure measurement noise: the matched value is its std (20 kPa).

    >>> from leakdiag.io.recording import Recording
    >>> rng = np.random.default_rng(0)
    >>> n = 20_000
    >>> rec = Recording({"u": np.zeros(n), "x": np.zeros(n),
    ...                  "p1": 8.6e6 + 2e4 * rng.standard_normal(n),
    ...                  "p2": 8.6e6 + 2e4 * rng.standard_normal(n)}, sample_rate=1000.0)
    >>> round(match_measurement_noise(rec).pressure_noise_std_pa / 2e4, 1)
    1.0
    """
    params = EKFParams() if params is None else params
    recs = [recordings] if hasattr(recordings, "channels") else list(recordings)
    check_positive(rtol, "rtol")
    passes = 0

    def stats(sigma):
        nonlocal passes
        passes += 1
        return _innovation_stats(recs, params, sigma, skip_s, max_signal_s)

    lo = hi = NOISE_FLOOR_PA
    hi_stats = stats(hi)
    while hi_stats[0] > 1.0:
        lo, hi = hi, 2.0 * hi
        if hi > NOISE_CEILING_PA:
            raise ValueError("match_measurement_noise: no pressure noise up to "
                             f"{NOISE_CEILING_PA:g} Pa makes the innovations consistent")
        hi_stats = stats(hi)
    while lo < hi and hi / lo > 1.0 + rtol:
        mid = float(np.sqrt(lo * hi))
        mid_stats = stats(mid)
        if mid_stats[0] > 1.0:
            lo = mid
        else:
            hi, hi_stats = mid, mid_stats
    med, ratio, nis, used_s = hi_stats
    return NoiseMatch(float(hi), med, tuple(float(v) for v in ratio), float(nis), passes,
                      used_s)


def run_vca_ekf(recording, params: EKFParams = EKFParams()) -> EKFResult:
    """Run the VCA extended Kalman filter over a recording.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Must hold ``u`` (V), ``x`` (m), ``p1`` and ``p2`` (Pa), all finite.
    params : EKFParams, optional
        Filter settings.

    Returns
    -------
    EKFResult
        Filtered states, innovations, NIS and estimated leak flow per sample.

    Raises
    ------
    leakdiag.io.RecordingError
        If a channel is missing or holds NaN or inf (the message names the recording, the
        channel and the first bad sample).
    ValueError
        If the recording has fewer than 2 samples or its ``meta['system']`` is not ``"vca"``.

    Notes
    -----
    Model (Eqs. 2-1, 2-2, 2-4, through ``leakdiag.sim.vca.model.vca_rhs``) augmented with
    :math:`\\dot k_l = w(t)` and a load-force disturbance :math:`f_d` on the piston
    (:math:`m\\dot v \\mathrel{+}= f_d`, :math:`\\dot f_d = w_f(t)`), white noises.
    Prediction over one sample with RK4 substeps and the
    covariance propagated with :math:`F = (I + A + A^2/2)^{n}`, :math:`A = J\\,\\Delta t/n`,
    :math:`J` the finite-difference Jacobian at the prior estimate; update with the Joseph
    form. :math:`\\hat k_l` is not clipped: a negative estimate is model bias made visible
    (and :attr:`EKFResult.leak_size_lpm` keeps its sign).

    Assumptions where An & Sepehri (2005) are not specific to this rig: the measured signals
    (x, P1, P2, as in Sec. 2.2), the noise levels above, the random-walk leak state (their
    residual test is replaced by the coefficient estimate, which also sizes the leak), the
    initial state (measured x, P1, P2; zero velocity; spool at ``k_v u``) and covariance.
    The filter's model is ``params.model`` (Table 2-1 by default): exact for the simulator's
    nominal actuator (``simulate_vca(machine=None)``), not for a drawn virtual machine
    (``machine=int``: its valve gain, null offset, supply pressure, bulk modulus and
    transducer offsets and gains differ from Table 2-1 and stay unknown to the filter), nor
    for a rig. Model error shows up in the residuals and biases :math:`\\hat k_l`, either
    way (on machine 5 :math:`\\hat k_l < 0` in 99 % of a healthy run's samples).

    References
    ----------
    .. [1] L. An and N. Sepehri, "Hydraulic actuator leakage fault detection using extended
       Kalman filter", Int. J. Fluid Power 6(1), 2005.

    Examples
    --------
    At rest with equal pressures the filter stays there and sees no leak:

    >>> from leakdiag.io.recording import Recording
    >>> n = 200
    >>> rec = Recording({"u": np.zeros(n), "x": np.zeros(n), "p1": np.full(n, 8.6e6),
    ...                  "p2": np.full(n, 8.6e6)}, sample_rate=1000.0)
    >>> res = run_vca_ekf(rec)
    >>> float(np.abs(res.leak_flow_lpm).max())
    0.0
    """
    system = recording.meta.get("system", "vca")
    if system != "vca":
        raise ValueError(f"{recording.meta.get('source', '<recording>')}: system={system!r}; "
                         "the EKF implements the VCA model only (no EHA filter)")
    recording.require("u", "x", "p1", "p2")
    n = recording.n_samples
    if n < 2:
        raise ValueError(f"{recording.meta.get('source', '<recording>')}: {n} sample(s); the "
                         "EKF needs at least 2")
    check_finite_channels(recording, ("u", "x", "p1", "p2"), "the EKF")
    # a position or pressures that cannot be metres and pascals for the modelled rig (a unit
    # left unstated: detect/_rig_units.py)
    check_rig_units(recording, "the EKF", float(params.model.stroke_m),
                    float(params.model.supply_pressure_pa), "the EKF's VCA model")
    dt = 1.0 / recording.sample_rate
    prm = params.model.to_array(params.leak_model, params.load)
    u = np.ascontiguousarray(recording["u"], dtype=np.float64)
    y = np.ascontiguousarray(np.column_stack([recording["x"] / _SCALE[0],
                                              recording["p1"] / _SCALE[2],
                                              recording["p2"] / _SCALE[3]]))
    z0 = np.array([y[0, 0], 0.0, y[0, 1], y[0, 2],
                   params.model.spool_gain_m_per_v * u[0] / _SCALE[4], 0.0, 0.0, 0.0])
    p0 = np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 10.0]) ** 2
    qd = np.array([
        (1e-7 / _SCALE[0]) ** 2,
        (params.velocity_process_std_m_per_s / _SCALE[1]) ** 2,
        (params.pressure_process_std_pa / _SCALE[2]) ** 2,
        (params.pressure_process_std_pa / _SCALE[3]) ** 2,
        (1e-8 / _SCALE[4]) ** 2,
        (1e-4 / _SCALE[5]) ** 2,
        (params.leak_coefficient_walk / _SCALE[6]) ** 2 * dt,
        (params.force_disturbance_walk_n / _SCALE[7]) ** 2 * dt,
    ])
    noise = params.pressure_noise_std_pa
    if noise is None:  # matched on this recording itself
        sig = (match_measurement_noise(recording, params).pressure_noise_std_pa,) * 2
    elif np.ndim(noise) == 0:
        sig = (float(noise),) * 2
    else:
        sig = (float(noise[0]), float(noise[1]))
    r = np.array([(params.position_noise_std_m / _SCALE[0]) ** 2,
                  (sig[0] / _SCALE[2]) ** 2, (sig[1] / _SCALE[3]) ** 2])
    use, frozen = _frozen_holds(recording, params.max_hold_s)
    states = np.empty((n, 8))
    innov = np.empty((n, 3))
    nis = np.empty(n)
    sdiag = np.empty((n, 3))
    leak = np.empty(n)
    kvar = np.empty(n)
    skipped = ekf_vca_kernel(y, use, u, dt, params.substeps, prm, _SCALE, z0, p0, qd, r, states,
                             innov, nis, sdiag, leak, kvar)
    meas_scale = _SCALE[[0, 2, 3]]
    return EKFResult(recording.time, states, innov, nis, leak * LPM_PER_M3S, int(skipped), kvar,
                     sig, sdiag * meas_scale**2, frozen)


def ekf_feature(recording, params: EKFParams = EKFParams()) -> FeatureSeries:
    """Windowed EKF feature of a recording: mean leak size, innovation RMS or standardised
    leak coefficient.

    Parameters
    ----------
    recording : leakdiag.io.Recording
        Must hold ``u``, ``x``, ``p1``, ``p2``.
    params : EKFParams, optional
        Filter and window settings; ``params.feature`` selects the feature.

    Returns
    -------
    FeatureSeries
        ``name="ekf_leak_flow"`` (L/min, windowed mean of :attr:`EKFResult.leak_size_lpm`,
        the leak's size :math:`\\hat k_l |g(\\Delta \\hat P)|` with the sign of
        :math:`\\hat k_l`),
        ``name="ekf_residual"`` (windowed RMS of :math:`\\sqrt{NIS/3}`, dimensionless) or
        ``name="ekf_coefficient"`` (windowed mean of :math:`\\hat k_l` over the root of its
        windowed mean filter variance).

    Raises
    ------
    leakdiag.io.RecordingError
        If a channel is missing or holds NaN or inf (as :func:`run_vca_ekf`).

    Notes
    -----
    The leak's size is averaged because the thesis sizes a leak by the mean flow after the
    onset (Sec. 4.5), the same quantity as ``meta['leak_lpm']`` of a simulation. Its sign is
    :math:`\\hat k_l`'s: a negative mean is model bias, not a leak, and is not folded into a
    positive flow (for :math:`\\hat k_l \\ge 0` it equals the flow's magnitude).

    Examples
    --------
    >>> from leakdiag.io.recording import Recording
    >>> n = 3000
    >>> rec = Recording({"u": np.zeros(n), "x": np.zeros(n), "p1": np.full(n, 8.6e6),
    ...                  "p2": np.full(n, 8.6e6)}, sample_rate=1000.0)
    >>> ekf_feature(rec, EKFParams(overlap=0)).values.tolist()
    [0.0, 0.0, 0.0]
    """
    res = run_vca_ekf(recording, params)
    starts = window_starts(recording.n_samples, params.window, params.overlap)
    if params.feature == "leak_flow":
        values = windowed_mean(res.leak_size_lpm, params.window, params.overlap)
    elif params.feature == "coefficient":
        k = windowed_mean(res.leak_coefficient, params.window, params.overlap)
        var = windowed_mean(res.leak_coefficient_var, params.window, params.overlap)
        values = k / np.sqrt(var)
    else:
        values = np.sqrt(windowed_mean(res.nis / 3.0, params.window, params.overlap))
    if res.frozen:  # windows overlapping a frozen hold are undefined (counted warning)
        hit = np.zeros(recording.n_samples + 1)
        for _, i0, i1 in res.frozen:
            hit[i0 + 1:i1 + 2] = 1.0
        hits = np.cumsum(hit)
        bad = hits[starts + params.window] - hits[starts] > 0
        values = np.where(bad, np.nan, values)
        warn_degenerate(int(bad.sum()), len(values), "a measured channel frozen (held one value "
                        "longer than max_hold_s; " + ", ".join(
                            f"{c} from {recording.start_time + i0 / recording.sample_rate:.6g} "
                            f"to {seconds(recording.start_time + i1 / recording.sample_rate, 6)} s"
                            for c, i0, i1 in res.frozen) + ")")
    times = window_times(starts, params.window, recording.sample_rate, recording.start_time)
    return FeatureSeries(times, values, f"ekf_{params.feature}",
                         {"feature": params.feature, "leak_model": params.leak_model,
                          "load": params.load}, window=params.window, overlap=params.overlap,
                         step=window_step(params.window, params.overlap),
                         sample_rate=recording.sample_rate, start_time=recording.start_time)
