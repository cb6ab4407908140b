"""Leak size with the differential pressure-transducer offset profiled out (flow balance).

The EHA's window residual, the leak volume of the flow balance (:mod:`._flow_balance_eha`),
does not depend on the pressure transducers' zero errors: it uses the motor encoder, the piston
position and pressure *changes*. Its regressor does: the leak law of Eq. 2-4 evaluated on the
measured :math:`P_1 - P_2`. A differential offset :math:`\\delta = o_1 - o_2` of the two
chamber transducers (0.25 % of a 20.7 MPa full scale each is up to 100 kPa between them) moves
that regressor, and without load, where :math:`|P_1 - P_2|` is tens of kPa, a 33 kPa offset
sized a 0.1 L/min leak 21 % low with an interval that excluded the truth (unit 17,
docs/detect.md 8.5). Healthy recordings cannot identify :math:`\\delta` (the leak term is zero
there), but a leak's own windows can: the leak law's nonlinearity makes the fit of the residual
on :math:`g(P_1 - P_2 - \\delta)` best at the true offset.

The VCA without load has the same problem (its zero errors of tens of kPa took the leak's
coefficient below zero and had leaks refused 10 s after their onset) and the same cure since
2026-11-29; its residual does use the measured pressures (the valve flows of Eq. 2-2), but as
the healthy identification calibrated them, so there too only the leak-law terms take the
offset (:func:`leak_law_at`).

:func:`profile_offset` maximises the profile log-likelihood of :math:`\\delta` over a bounded
range, :math:`\\ell(\\delta) = \\tfrac12 (\\max(\\hat k(\\delta), 0) / \\mathrm{se}(\\delta))^2`
up to a constant (a leak has :math:`k \\ge 0`; weighted least squares with the detector's
error model), on a grid refined by a bounded scalar search, and returns the size at the best
offset with an interval that holds both uncertainties: the union, over the offsets whose
likelihood-ratio statistic is within the chi-square quantile of ``level``, of the
coefficient's interval at each times that offset's mean :math:`|g|`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.optimize import minimize_scalar
from scipy.stats import chi2, norm

from leakdiag.detect._flow_balance_kernel import leak_law_window_sums

__all__ = ["OffsetProfile", "profile_offset", "leak_law_at", "offset_words",
           "SEARCH_HALF_RANGE_PA", "GRID_POINTS", "PLAUSIBLE_OFFSET_PA"]

#: Half-range of the offsets searched, Pa: twice the 100 kPa that two transducers of 0.25 %
#: zero error on a 3000 psi (20.7 MPa) full scale can differ by (sim/machine.py draws within it).
SEARCH_HALF_RANGE_PA = 2e5
#: Points of the grid over the range (10 kPa apart), then a bounded search around the best.
GRID_POINTS = 41
#: Times the range is doubled when the best grid point is at its edge.
MAX_WIDENINGS = 2
#: Differential zero error two calibrated chamber transducers can show, Pa (0.25 % of a
#: 20.7 MPa full scale each, opposite signs): a profiled offset beyond it is flagged.
PLAUSIBLE_OFFSET_PA = 2e5


def offset_words(offset_pa: float, offset_interval_pa=None) -> str:
    """What a size interval with the offset profiled holds, in words.

    Parameters
    ----------
    offset_pa : float
        The effective differential offset found (:attr:`OffsetProfile.offset_pa`), Pa.
    offset_interval_pa : tuple of float, optional
        The offsets the leak's windows allow (:attr:`OffsetProfile.offset_interval_pa`), Pa.

    Returns
    -------
    str
        The words, flagging an offset beyond :data:`PLAUSIBLE_OFFSET_PA`.

    Examples
    --------
    >>> offset_words(-3.2e4, (-4.1e4, -2.5e4)).split("windows, ")[1]
    '-32 kPa (the data allow -41 to -25 kPa)'
    """
    text = ("the coefficient's statistical error and an effective P1-P2 offset (the "
            "transducers' zero error and whatever else shifts P1 - P2 at the working pressure) "
            f"found on the leak's windows, {offset_pa / 1e3:+.3g} kPa")
    if offset_interval_pa is not None:
        lo, hi = offset_interval_pa
        text += f" (the data allow {lo / 1e3:+.3g} to {hi / 1e3:+.3g} kPa)"
    if abs(offset_pa) > PLAUSIBLE_OFFSET_PA:
        text += (f"; beyond the +-{PLAUSIBLE_OFFSET_PA / 1e3:.0f} kPa two calibrated transducers "
                 "can differ by: the offset is poorly determined here (large |P1-P2|, e.g. "
                 "under load) or the transducers' zero needs checking")
    return text


def leak_law_at(rec, start_s, end_s, smoothing_s: float, ptr_leak_pa: float,
                laminar: bool) -> Callable[[float], tuple[np.ndarray, np.ndarray]]:
    """The leak law's window integrals of ``rec`` as functions of the differential offset.

    Only the leak law takes the offset: the rest of the balance (valve or pump flows, the
    spool-clearance term) is kept as the healthy identification calibrated it, on the measured
    pressures; the caller shifts the healthy baseline leak term, a leak-law term, with it
    (``FlowBalanceDetector._offset_profile``; docs/detect.md 8.5). O(n) per offset, without
    recomputing the balance's other window sums.

    Parameters
    ----------
    rec : Recording
        The recording, with channels ``p1`` and ``p2`` (Pa).
    start_s, end_s : numpy.ndarray
        The windows' first and last sample instants (s, the recording's clock), as the
        detector's window terms give them (adjacent windows share their end sample).
    smoothing_s : float
        Moving average of ``P1 - P2`` for the mean ``|phi|`` (the backend's
        ``DP_SMOOTHING_S``).
    ptr_leak_pa : float
        Laminar core of the turbulent leak law (Pa).
    laminar : bool
        Laminar leak law (Eq. 2-5) instead of the turbulent one (Eq. 2-4).

    Returns
    -------
    callable
        ``at(delta) -> (phi, phi_abs)``: per window ``int phi(P1 - P2 - delta) dt`` and
        ``int |phi(smoothed P1 - P2 - delta)| dt`` (s Pa^0.5, or s Pa when laminar), the
        window terms ``phi`` and ``phi_abs`` of a recording whose ``p1`` is lowered by
        ``delta``.

    Examples
    --------
    A laminar law on a constant difference of 5 kPa, one 2-s window at 10 Hz:

    >>> import numpy as np
    >>> from leakdiag.io.recording import Recording
    >>> rec = Recording({"p1": np.full(21, 5e3), "p2": np.zeros(21)}, sample_rate=10.0)
    >>> at = leak_law_at(rec, np.array([0.0]), np.array([2.0]), 0.0, 0.0, laminar=True)
    >>> [float(v[0]) for v in at(2e3)]
    [6000.0, 6000.0]
    """
    fs = float(rec.sample_rate)
    p1 = np.asarray(rec.channels["p1"], dtype=np.float64)
    p2 = np.asarray(rec.channels["p2"], dtype=np.float64)
    dp = np.ascontiguousarray(p1 - p2)
    dps = np.ascontiguousarray(uniform_filter1d(dp, max(1, int(round(smoothing_s * fs))),
                                                mode="nearest"))
    first = np.rint((np.asarray(start_s, dtype=np.float64) - rec.start_time) * fs)
    last = np.rint((np.asarray(end_s, dtype=np.float64) - rec.start_time) * fs)
    first, last = first.astype(np.int64), last.astype(np.int64)
    if len(first) and (first.min() < 0 or last.max() >= len(dp) or np.any(last < first)):
        raise ValueError("leak_law_at: windows outside the recording")

    def at(delta: float) -> tuple[np.ndarray, np.ndarray]:
        out = np.empty((len(first), 2))
        leak_law_window_sums(dp, dps, first, last, float(delta), float(ptr_leak_pa),
                             bool(laminar), out)
        out *= 1.0 / fs  # as the balance's wrappers scale their sums
        return out[:, 0], out[:, 1]

    return at


@dataclass(frozen=True)
class OffsetProfile:
    """Result of :func:`profile_offset`.

    Attributes
    ----------
    offset_pa : float
        Differential offset :math:`\\delta` at the likelihood's maximum, Pa.
    coefficient, coefficient_se : float
        Leak coefficient and its standard error at that offset.
    mean_abs_law : float
        Mean :math:`|g(P_1 - P_2 - \\delta)|` since the onset at that offset.
    size_interval : tuple of float
        Union of ``(k +- z se) * mean |g|`` over the offsets within the chi-square bound
        (units of ``k * mean |g|``, i.e. m^3/s).
    offset_interval_pa : tuple of float
        Smallest and largest offset within that bound (grid points and the maximum).
    n_evaluations : int
        Evaluations of the leak terms.
    """

    offset_pa: float
    coefficient: float
    coefficient_se: float
    mean_abs_law: float
    size_interval: tuple[float, float]
    offset_interval_pa: tuple[float, float]
    n_evaluations: int

    @property
    def size(self) -> float:
        """Mean leak flow at the best offset (``coefficient * mean_abs_law``, m^3/s)."""
        return self.coefficient * self.mean_abs_law


def profile_offset(evaluate: Callable[[float], tuple[float, float, float]], level: float,
                   half_range_pa: float = SEARCH_HALF_RANGE_PA,
                   grid_points: int = GRID_POINTS) -> OffsetProfile:
    """Profile the differential pressure offset out of a leak size.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(delta) -> (k, se, mean_abs_law)``: the leak coefficient, its standard error
        and the mean :math:`|g|` since the onset with :math:`\\delta` subtracted from the
        measured :math:`P_1 - P_2` (Pa).
    level : float
        Two-sided level of the size interval, in (0, 1).
    half_range_pa : float, default SEARCH_HALF_RANGE_PA
        Offsets searched: ``[-half_range_pa, half_range_pa]``, doubled up to
        :data:`MAX_WIDENINGS` times while the best grid point is at the range's edge.
    grid_points : int, default GRID_POINTS
        Grid points over that range (>= 3, odd keeps 0 on the grid).

    Returns
    -------
    OffsetProfile

    Raises
    ------
    ValueError
        If ``level`` is not in (0, 1), ``half_range_pa`` is not positive or ``grid_points``
        is below 3, or no offset gives a finite coefficient with a positive standard error
        (the likelihood is then undefined everywhere; the size interval would be empty).

    Examples
    --------
    A leak whose regressor is ``sqrt|dp - d|`` with ``d = 30 kPa`` (a made-up profile with
    its maximum there and a standard error of 1 % of ``k``):

    >>> def ev(d):
    ...     k = 1.0 - ((d - 3e4) / 1e5) ** 2
    ...     return k, 0.01, 1.0
    >>> p = profile_offset(ev, 0.95)
    >>> round(p.offset_pa / 1e3), p.size_interval[0] < 1.0 < p.size_interval[1]
    (30, True)
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level={level!r} must be in (0, 1)")
    if not half_range_pa > 0:
        raise ValueError(f"half_range_pa={half_range_pa!r} must be > 0")
    if grid_points < 3:
        raise ValueError(f"grid_points={grid_points!r} must be >= 3")
    seen: dict[float, tuple[float, float, float]] = {}

    def at(d: float) -> tuple[float, float, float]:
        if d not in seen:
            seen[d] = tuple(float(v) for v in evaluate(d))
        return seen[d]

    def loglik(d: float) -> float:
        k, se, _ = at(d)
        # least squares with k >= 0 (a leak): the fit's gain over k = 0 is max(k, 0)^2 / se^2
        return 0.5 * (max(k, 0.0) / se) ** 2 if se > 0 and math.isfinite(k) else -math.inf

    for _ in range(MAX_WIDENINGS + 1):
        grid = np.linspace(-half_range_pa, half_range_pa, grid_points)
        lls = np.array([loglik(float(d)) for d in grid])
        i = int(np.argmax(lls))
        if 0 < i < grid_points - 1:
            break
        half_range_pa *= 2.0  # the best offset at the edge: it may lie beyond, widen
    step = grid[1] - grid[0]
    lo, hi = max(grid[0], grid[i] - step), min(grid[-1], grid[i] + step)
    best = float(grid[i])
    if hi > lo:
        res = minimize_scalar(lambda d: -loglik(float(d)), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-3 * step})
        if -res.fun > lls[i]:
            best = float(res.x)
    ll_max = loglik(best)
    if not math.isfinite(ll_max):
        raise ValueError("profile_offset: no offset gave a finite leak coefficient with a "
                         f"positive standard error (evaluations: {sorted(seen.items())[:3]} ...)")
    bound = 0.5 * float(chi2.ppf(level, 1))
    zq = float(norm.ppf(0.5 + level / 2))
    inside = [d for d in seen if ll_max - loglik(d) <= bound]
    lows, highs = [], []
    for d in inside:
        k, se, mabs = at(d)
        lows.append((k - zq * se) * mabs)
        highs.append((k + zq * se) * mabs)
    k, se, mabs = at(best)
    return OffsetProfile(best, k, se, mabs, (min(lows), max(highs)), (min(inside), max(inside)),
                         len(seen))
