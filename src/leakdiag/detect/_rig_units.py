"""Units of a recording against the rig a physics-based detector models (flow balance, EKF).

A recording without stated units is read as SI (docs/io.md). The feature detectors do not
depend on the scale, but the physics-based ones put the position into chamber volumes and the
pressures into orifice and leak laws: a position in mm read as m, or pressures in bar read as
Pa, gave a leak 1000x too large with an interval and a probability (audit of users'
recordings, 2026-11-27, finding 1: 330 L/min for 0.3 L/min). So those detectors compare the
recording with the rig they model, in physical terms and with no tuned factor:

* the piston cannot travel further than the cylinder's stroke (Tables 2-1 / 3-1: 0.6 m), so a
  position whose range (largest minus smallest) exceeds ``stroke_m`` is not in metres for
  this rig. The range, not the distance from 0: the balance uses displacements, and a
  transducer whose zero lies elsewhere (x from 0.68 to 0.72 m) was sized as without the offset
  (a review, 2026-11-27, found a first version refusing it);
* the chamber pressures of a working actuator reach a sizeable fraction of its pressure level
  (the VCA's supply, Table 2-1; the EHA's charge pressure, which its chambers never fall far
  below): pressures that all stay below a hundredth of it (172 kPa for the VCA, 14 kPa for the
  EHA) are not in pascals (bar, MPa, kPa or psi give 1e-6 to 1e-3 of the value in Pa).
"""

from __future__ import annotations

import numpy as np

from leakdiag.io import RecordingError

__all__ = ["check_rig_units", "PRESSURE_LEVEL_FRACTION"]

#: Fraction of the rig's pressure level that the largest chamber pressure of a recording must
#: reach for it to be read as pascals (leakdiag choice: a factor 100 below the level, where a
#: unit error is a factor 1,000 or more; the simulated rigs reach 0.73 (VCA) and 1.2-2.7 (EHA)
#: of it).
PRESSURE_LEVEL_FRACTION = 0.01


def check_rig_units(rec, where: str, stroke_m: float, pressure_level_pa: float,
                    what: str, position: str = "x", pressures=("p1", "p2")) -> None:
    """Refuse a recording whose position or pressures cannot be in metres and pascals for the
    modelled rig.

    Parameters
    ----------
    rec : Recording
        The recording (its channels read as SI).
    where : str
        Caller, for the message (``"fit"``, ``"predict"``).
    stroke_m : float
        The modelled cylinder's stroke (m).
    pressure_level_pa : float
        The modelled rig's pressure level (Pa): the VCA's supply, the EHA's charge pressure.
    what : str
        The detector and rig, for the message (e.g. ``"the flow balance (vca)"``).
    position, pressures : str, tuple of str
        Channel names.

    Raises
    ------
    leakdiag.io.RecordingError
        Naming the recording, the channel, its range and the likely unit.

    Examples
    --------
    >>> from leakdiag.io import Recording
    >>> rec = Recording({"x": [-8.0, 12.0], "p1": [5e6, 6e6], "p2": [5e6, 6e6]}, 1.0,
    ...                 meta={"source": "rig.csv"})
    >>> check_rig_units(rec, "fit", 0.6, 17.2e6, "the flow balance (vca)")
    Traceback (most recent call last):
    ...
    leakdiag.io.errors.RecordingError: fit: rig.csv: channel 'x' travels 20 m (from -8 to 12), more than the stroke of 0.6 m that the flow balance (vca) models: is the position in mm (or another unit) read as metres? State its unit (e.g. --col x=NAME:mm, or a column map; in Python, a rig of other dimensions is given as params=)
    """
    source = rec.meta.get("source", "<recording>")
    if position in rec.channels:
        x = np.asarray(rec[position], dtype=np.float64)
        travel = float(np.nanmax(x) - np.nanmin(x)) if x.size else 0.0
        if travel > stroke_m:
            raise RecordingError(
                f"{where}: {source}: channel {position!r} travels {travel:.4g} m (from "
                f"{float(np.nanmin(x)):.4g} to {float(np.nanmax(x)):.4g}), more than the stroke "
                f"of {stroke_m:g} m that {what} models: is the position in mm (or another "
                "unit) read as metres? State its unit (e.g. --col x=NAME:mm, or a column map; "
                "in Python, a rig of other dimensions is given as params=)")
    have = [c for c in pressures if c in rec.channels and np.asarray(rec[c]).size]
    if have:
        top = max(float(np.nanmax(np.asarray(rec[c], dtype=np.float64))) for c in have)
        floor = PRESSURE_LEVEL_FRACTION * pressure_level_pa
        if top < floor:
            raise RecordingError(
                f"{where}: {source}: the chamber pressures ({', '.join(have)}) stay below "
                f"{top:.4g} Pa, under {PRESSURE_LEVEL_FRACTION:.0%} of the "
                f"{pressure_level_pa / 1e6:g} MPa pressure level that {what} models: are "
                "they in bar, MPa, kPa or psi read as pascals? State their unit (e.g. --col "
                "p1=NAME:bar, or a column map) or give the rig's own parameters")
