"""Model error of the flow balance's leak size, measured on virtual machines (size band).

The size interval from the coefficient's standard error (and, on the EHA and the VCA without
load, the transducers' profiled zero error) holds only what the regression knows. The
benchmark v5 (2026-11-26) measured how often it held the truth on held-out units: without
load the VCA's sizes were 0.24-1.52x the truth and their +-1 % intervals held it in 7 of 67
runs; with the spring and on the EHA the sizes were within a few per cent but the intervals,
often narrower still, held it in as few as 0-4 of 10 runs at the larger sizes. What the
intervals miss is model error (dither of the no-load pressure difference that 1 kHz sampling
does not resolve, transducer gains, the valve model's bias; docs/detect.md 8.5).

So the interval is widened to hold it, by normalised split conformal prediction (Lei et al.
2018, Sec. 5.2, "locally weighted"; Vovk et al. 2005). A size ``s`` whose statistical interval
has half-width ``w`` gets the scale

.. math:: \\rho = \\sqrt{a\\,w^2 + (c\\,s)^2}

(the noise the regression sees, ``a`` its weight, and a model error proportional to the size,
``c``), and its error is measured in scales, ``(s - truth) / rho``. Per rig and load
:data:`SIZE_ERROR_MODEL` holds ``a`` and ``c``, fitted on the first half of the leaking runs of
the v5 suite that the benchmark never judges (indexes 10-29 of every size, each its own virtual
machine fitted per unit on 2 own healthy runs; least squares of the squared relative error,
each leak size weighted alike), and the smallest and largest score over the other half's
``n`` detected runs (indexes 30-49; ``perf/flow_balance_size_band.py``, its runs in
docs/flow_balance_study/size_band/size_ratios.csv). If a new unit's score is exchangeable with
those ``n`` (same population of virtual machines and operating conditions), ``truth`` lies in
``[s - high rho, s - low rho]`` with probability at least ``(n - 1) / (n + 1)``. The reported
interval is the union of that band and the statistical interval (a leak is positive: a band
reaching below zero starts at zero).

Until 2026-11-30 (session 31) the score was the ratio ``s / truth`` pooled over all sizes:
valid over the suite's mix of sizes, but a pooled ratio is wide for large leaks and too narrow
for the smallest, whose relative error is largest (the EHA with the spring at 0.02 L/min held
46 of 50 fresh runs against a promise of 0.97; docs/detect.md 8.5). The scale makes the score's
spread about the same at every size. On a real machine the band holds only as far as the
virtual machines' tolerances (sim/machine.py) cover it: a lower bound on the uncertainty there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["SizeErrorModel", "SIZE_ERROR_MODEL", "FLEET_BAND_MISSES", "size_models",
           "size_band", "band_words"]


@dataclass(frozen=True)
class SizeErrorModel:
    """The size's model error on one rig and load, as measured (module docstring).

    Parameters
    ----------
    noise_weight : float
        ``a``: weight of the squared half-width of the statistical interval in the scale.
    relative_error : float
        ``c``: the model error's part proportional to the size.
    score_low, score_high : float
        Smallest and largest calibration score ``(size - truth) / rho``.
    n : int
        Detected calibration runs the scores are from.
    n_fit : int
        Detected runs ``a`` and ``c`` were fitted on (the other half).
    """

    noise_weight: float
    relative_error: float
    score_low: float
    score_high: float
    n: int
    n_fit: int

    def scale(self, size_lpm: float, half_width_lpm: float) -> float:
        """``rho = sqrt(a w^2 + (c s)^2)`` (L/min) of a size and its interval's half-width.

        Examples
        --------
        >>> SizeErrorModel(1.0, 0.1, -2.0, 2.0, 9, 9).scale(1.0, 0.0)
        0.1
        """
        return math.sqrt(self.noise_weight * half_width_lpm ** 2
                         + (self.relative_error * size_lpm) ** 2)

    def band(self, size_lpm: float, half_width_lpm: float) -> tuple[float, float]:
        """``[s - high rho, s - low rho]``, its lower end no lower than zero (L/min).

        Examples
        --------
        >>> SizeErrorModel(0.0, 0.1, -1.0, 2.0, 9, 9).band(1.0, 0.05)
        (0.8, 1.1)
        """
        rho = self.scale(size_lpm, half_width_lpm)
        return max(size_lpm - self.score_high * rho, 0.0), size_lpm - self.score_low * rho

    @property
    def probability(self) -> float:
        """``(n - 1) / (n + 1)``: what the band promises (two extreme order statistics)."""
        return (self.n - 1) / (self.n + 1)


#: ``{system: {load: SizeErrorModel}}``, measured by ``perf/flow_balance_size_band.py``
#: (2026-11-30, session 31, indexes 10-49: the scale fitted on 10-29, the scores on 30-49).
#: Before: one ratio range per group over all sizes (VCA no load 0.6498-1.7655, spring
#: 0.7318-1.1224, EHA no load 0.9835-1.0873, spring 0.9492-1.1056, on 63-72 runs).
SIZE_ERROR_MODEL: dict[str, dict[str, SizeErrorModel]] = {
    "vca": {"none": SizeErrorModel(0.09064, 0.2294, -0.5892, 1.953, 149, 146),
            "spring": SizeErrorModel(0.5093, 0.02542, -2.3122, 1.5659, 160, 160)},
    "eha": {"none": SizeErrorModel(0.0, 0.02653, -1.1544, 3.2702, 140, 140),
            "spring": SizeErrorModel(0.2818, 0.008993, -1.5886, 3.5132, 140, 139)},
}


#: ``(missed, sized)``: leaking flow-balance runs of the committed benchmark v5 in fleet mode
#: (docs/benchmark/v5/fleet-fresh-band/runs.csv.gz: one detector fitted on 300 machines,
#: judged with the band above, 2026-11-30) whose size interval did not hold the true mean
#: leak, out of those given a size. The band was measured with each machine's own fit, so a
#: fleet fit's verdict quotes this instead of the band's promise (tests recount it from the
#: file). With the ratio band, on fleet-conditional/ (older seeds and code): 11 of 188.
FLEET_BAND_MISSES: tuple[int, int] = (14, 183)


def size_models(system: str, load: str | None) -> tuple[list[SizeErrorModel], str]:
    """The error models a verdict's band is the hull of: the load's, or every load of the rig
    when the load is unknown.

    Parameters
    ----------
    system : {"vca", "eha"}
    load : str or None
        ``"none"``, ``"spring"`` or None (unknown: the recording and the fit do not say).

    Returns
    -------
    tuple
        ``(models, the load they were measured under)``.

    Examples
    --------
    >>> models, basis = size_models("vca", None)
    >>> len(models), basis
    (2, 'any load')
    """
    table = SIZE_ERROR_MODEL[system]
    if load in table:
        return [table[load]], f"load {load}"
    return list(table.values()), "any load"


def size_band(system: str, load: str | None, size_lpm: float,
              statistical: tuple[float, float]) -> tuple[float, float]:
    """The measured model-error band of a size (the hull of the load's models' bands); the
    reported interval is its union with the statistical one.

    Parameters
    ----------
    system : {"vca", "eha"}
    load : str or None
        As :func:`size_models`; unknown: the hull of every load's band.
    size_lpm : float
        The size (L/min).
    statistical : tuple of float
        The statistical interval (L/min); its half-width enters the scale.

    Returns
    -------
    tuple of float
        ``(low, high)``, L/min.

    Examples
    --------
    >>> lo, hi = size_band("eha", "spring", 0.1, (0.099, 0.101))
    >>> lo < 0.099 and hi > 0.101
    True
    """
    half = (statistical[1] - statistical[0]) / 2.0
    bands = [m.band(size_lpm, half) for m in size_models(system, load)[0]]
    return min(b[0] for b in bands), max(b[1] for b in bands)


def band_words(system: str, load: str | None, band: tuple[float, float]) -> str:
    """What the widened interval holds, in words, with this size's band (:func:`size_band`).

    Examples
    --------
    >>> band_words("eha", "spring", (0.09, 0.11)).startswith("and the model error measured on ")
    True
    """
    models, basis = size_models(system, load)
    p = min(m.probability for m in models)
    return (f"and the model error measured on {min(m.n for m in models)} virtual machines "
            f"({basis}: a size's error in scales that grow with its statistical interval and "
            f"with the size, here {band[0]:.3g}-{band[1]:.3g} L/min; probability >= {p:.2f} if "
            "this machine is like them and the leak, like theirs, a step that began after the "
            "first windows judged, docs/detect.md 8.5)")
