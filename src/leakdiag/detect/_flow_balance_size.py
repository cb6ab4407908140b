"""Model error of the flow balance's leak size, measured on virtual machines (size band).

The size interval from the coefficient's standard error (and, on the EHA and the VCA without
load, the transducers' profiled zero error) holds only what the regression knows. The benchmark v5 (2026-11-26)
measured how often it held the truth on held-out units: without load the VCA's sizes were
0.24-1.52x the truth and their +-1 % intervals held it in 7 of 67 runs; with the spring and on
the EHA the sizes were within a few per cent but the intervals, often narrower still, held it in
as few as 0-4 of 10 runs at the larger sizes. What the intervals miss is model error (dither of
the no-load pressure difference that 1 kHz sampling does not resolve, transducer gains, the
valve model's bias; docs/detect.md 8.5).

So the interval is widened to hold it: :data:`SIZE_RATIO_RANGE` holds, per rig and load, the
smallest and largest ratio ``size / truth`` over ``n`` detected leaking runs of the v5 suite
that the benchmark never judges (indexes 10-18 of every size, each its own virtual machine,
fitted per unit on 2 own healthy runs; ``perf/flow_balance_size_band.py``, its runs in
docs/flow_balance_study/size_band/size_ratios.csv). If a new unit's
ratio is exchangeable with those ``n`` (same population of virtual machines and operating
conditions), ``truth`` lies in ``[size / max, size / min]`` with probability at least
``(n - 1) / (n + 1)`` (split conformal prediction with the two extreme order statistics;
Vovk et al. 2005, Lei et al. 2018). The reported interval is the union of that band and the
statistical interval. On a real machine the band holds only as far as the virtual machines'
tolerances (sim/machine.py) cover it: a lower bound on the uncertainty there.
"""

from __future__ import annotations

__all__ = ["SIZE_RATIO_RANGE", "FLEET_BAND_MISSES", "size_band", "band_words"]

#: ``{system: {load: (smallest ratio, largest ratio, runs)}}`` of size / true mean leak after
#: the onset, measured by ``perf/flow_balance_size_band.py`` (2026-11-26, seventh session;
#: remeasured 2026-11-29, session 27, when the VCA's no-load size began to profile the
#: transducers' differential zero error: VCA without load 0.1253-1.6483 on 68 runs before; and
#: 2026-11-30, session 30, when the EHA under the spring took the high-side balance (its final
#: form, c0625c7): EHA with
#: the spring 0.9309-1.1783 on 63 runs before, without load unchanged to 1e-13).
SIZE_RATIO_RANGE: dict[str, dict[str, tuple[float, float, int]]] = {
    "vca": {"none": (0.6498, 1.7655, 67), "spring": (0.7318, 1.1224, 72)},
    "eha": {"none": (0.9835, 1.0873, 63), "spring": (0.9492, 1.1056, 63)},
}


#: ``(missed, sized)``: leaking flow-balance runs of the committed benchmark v5 in fleet mode
#: (docs/benchmark/v5/fleet-conditional/runs.csv.gz: one detector fitted on several machines)
#: whose size interval, widened by the band above, did not hold the true mean leak, out of
#: those given a size. The band was measured with each machine's own fit, so a fleet fit's
#: verdict quotes this instead of the band's promise (tests recompute it from the file).
FLEET_BAND_MISSES: tuple[int, int] = (11, 188)


def size_band(system: str, load: str | None) -> tuple[float, float, int, str]:
    """Ratio range for a rig and load; an unknown load takes the widest of the rig's loads.

    Parameters
    ----------
    system : {"vca", "eha"}
    load : str or None
        ``"none"``, ``"spring"`` or None (unknown: the recording and the fit do not say).

    Returns
    -------
    tuple
        ``(smallest ratio, largest ratio, runs, the load it was measured under)``.

    Examples
    --------
    >>> lo, hi, n, basis = size_band("vca", None)
    >>> basis
    'any load'
    """
    table = SIZE_RATIO_RANGE[system]
    if load in table:
        lo, hi, n = table[load]
        return lo, hi, n, f"load {load}"
    return (min(v[0] for v in table.values()), max(v[1] for v in table.values()),
            min(v[2] for v in table.values()), "any load")


def band_words(system: str, load: str | None) -> str:
    """What the widened interval holds, in words.

    Examples
    --------
    >>> band_words("eha", "spring").startswith("and the model error measured on ")
    True
    """
    lo, hi, n, basis = size_band(system, load)
    return (f"and the model error measured on {n} virtual machines ({basis}: sizes "
            f"{lo:.2f}-{hi:.2f}x the truth; probability >= {(n - 1) / (n + 1):.2f} if this "
            "machine is like them and the leak, like theirs, a step that began after the "
            "first windows judged, docs/detect.md 8.5)")
