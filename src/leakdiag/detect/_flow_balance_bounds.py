"""Window boundaries of the VCA flow balance placed where the valve is quiet.

Why (docs/detect.md, section 8.4): the valve model and the pressure acquisition have small
timing errors (a valve bandwidth off Table 2-1 by 15 % is ~0.2 ms, an anti-alias filter delays
the pressures by ~1 ms). Integrated over a window, a timing error ``delta`` of a flow ``Q``
leaves ``delta * (Q(end) - Q(start))`` -- small where the flow is steady at both ends, but when
a boundary falls inside the transient after a command step (spool and flow change within
milliseconds), the end-point linearisation fails and the two windows sharing the boundary get
large residuals of opposite sign (|z| of 6-16 on held-out healthy runs, all within ~35 ms of a
reference step). Moving each boundary to a moment where the spool is at rest keeps every
transient inside one window, where timing errors integrate out.

The boundaries use only the recorded control signal ``u`` through the nominal valve of Table
2-1 (spool velocity, which does not depend on the null offset): no pressure, position or leak
information, and the same boundaries in ``fit`` and ``predict``.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

__all__ = ["fixed_bounds", "quiet_bounds"]

#: Largest move of a boundary from its nominal place, as a fraction of the window (leakdiag
#: choice: windows stay between 0.5 and 1.5 nominal lengths).
SEARCH_FRACTION = 0.25
#: Half-width of the neighbourhood over which the spool must be at rest (s; leakdiag choice:
#: covers the +-3-sample pressure-rate difference, a ~1.3 ms filter delay and the valve's
#: ~1.5 ms lag with margin).
QUIET_HALF_WIDTH_S = 0.02


def fixed_bounds(n_samples: int, window: int) -> np.ndarray:
    """Boundaries ``0, w, 2w, ...`` of contiguous windows of ``window`` intervals.

    Parameters
    ----------
    n_samples : int
        Samples in the recording.
    window : int
        Window length in sample intervals (>= 1).

    Returns
    -------
    numpy.ndarray
        int64 sample indices, one more than the number of windows (empty-window recordings give
        ``[0]``).
    """
    n_win = max(0, (n_samples - 1) // window)
    return np.arange(n_win + 1, dtype=np.int64) * window


def quiet_bounds(spool: np.ndarray, window: int, sample_rate: float,
                 search_fraction: float = SEARCH_FRACTION,
                 half_width_s: float = QUIET_HALF_WIDTH_S) -> np.ndarray:
    """Boundaries moved, within ``+-search_fraction * window``, to where the spool is at rest.

    Each boundary of :func:`fixed_bounds` after the first moves to the sample in its search
    range with the smallest largest spool step ``|x_v[k+1] - x_v[k]|`` within ``+-half_width_s``
    (ties: the one nearest the nominal place). The first stays (it starts the burn-in); the last
    moves within the recording (up to its last sample): a fixed last boundary inside the motion
    after a command step made the last window of a healthy v5 run alarm (z = -13.3;
    docs/detect.md section 8.4).

    Parameters
    ----------
    spool : numpy.ndarray
        Modelled spool position per sample (any offset: only its increments are used).
    window : int
        Nominal window length in sample intervals.
    sample_rate : float
        Hz.
    search_fraction : float, default 0.25
        Largest move as a fraction of the window (< 0.5, so that boundaries keep their order).
    half_width_s : float, default 0.02
        Half-width of the neighbourhood that must be quiet (s).

    Returns
    -------
    numpy.ndarray
        Strictly increasing int64 sample indices; window ``w`` spans samples
        ``bounds[w]..bounds[w + 1]``.

    Raises
    ------
    ValueError
        If ``search_fraction`` is not in [0, 0.5).

    Examples
    --------
    >>> xv = np.zeros(4001); xv[1990:] = 1.0  # a spool step 10 ms before a boundary
    >>> quiet_bounds(xv, 1000, 1000.0).tolist()  # moved to 20 ms after the step
    [0, 1000, 2010, 3000, 4000]
    >>> xv = np.zeros(4200); xv[3990:] = 1.0  # ... and before the last one
    >>> quiet_bounds(xv, 1000, 1000.0).tolist()
    [0, 1000, 2000, 3000, 4010]
    """
    if not 0 <= search_fraction < 0.5:
        raise ValueError(f"search_fraction={search_fraction!r} must be in [0, 0.5)")
    b = fixed_bounds(len(spool), window)
    reach = int(search_fraction * window)
    if len(b) <= 2 or reach == 0:
        return b
    step = np.abs(np.diff(np.asarray(spool, dtype=np.float64)))
    step = np.concatenate([step, step[-1:]])  # one value per sample
    half = max(1, int(round(half_width_s * sample_rate)))
    busy = maximum_filter1d(step, 2 * half + 1, mode="nearest")
    offsets = np.arange(-reach, reach + 1)
    out = b.copy()
    last = len(spool) - 1
    for i in range(1, len(b)):
        cand = b[i] + offsets
        if i == len(b) - 1:
            cand = cand[cand <= last]
        cost = busy[cand]
        best = np.flatnonzero(cost == cost.min())
        out[i] = cand[best[np.argmin(np.abs(offsets[best]))]]
    return out
