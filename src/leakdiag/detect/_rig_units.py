"""Units of a recording against the rig a physics-based detector models (flow balance, EKF).

A recording without stated units is read as SI (docs/io.md). The feature detectors do not
depend on the scale, but the physics-based ones put the position into chamber volumes and the
pressures into orifice and leak laws: a position in mm read as m, or pressures in bar read as
Pa, gave a leak 1000x too large with an interval and a probability (audit of users'
recordings, 2026-11-27, finding 1: 330 L/min for 0.3 L/min). So those detectors compare the
recording with the rig they model, in physical terms and with no tuned factor:

* the piston cannot travel further than the cylinder's stroke (Tables 2-1 / 3-1: 0.6 m), so a
  position whose range (largest minus smallest) exceeds ``stroke_m`` (by more than
  :data:`STROKE_TOLERANCE` for noise and end stops) is not in metres for this rig. The
  range, not the distance from 0: the balance uses displacements, and a transducer whose
  zero lies elsewhere (x from 0.68 to 0.72 m) was sized as without the offset
  (a review, 2026-11-27, found a first version refusing it);
* the chamber pressures of a working actuator reach a sizeable fraction of its pressure level
  (the VCA's supply, Table 2-1; the EHA's charge pressure, which its chambers never fall far
  below): pressures that all stay below a hundredth of it (172 kPa for the VCA, 14 kPa for the
  EHA) are not in pascals (bar, MPa, kPa or psi give 1e-6 to 1e-3 of the value in Pa); nor
  are pressures that exceed it a hundredfold (1.7 GPa, 140 MPa: pascals stated as kPa, bar
  or MPa give 1e3 to 1e6);
* the position's scale is not checked by its range (the simulated VCA travels 3.9 cm of its
  60-cm stroke: centimetres read as millimetres, travel 3.9 mm, are as plausible), but by the
  balance itself: the piston flow ``A dx/dt`` must match the modelled valve's or pump's flow
  (Eq. 2-1 / 3-1), so :func:`check_flow_scale` refuses an identified flow-gain (VCA) or
  displacement (EHA) factor beyond a factor :data:`FLOW_SCALE_LIMIT` of 1. A statistics and CLI
  audit (2026-11-28) fitted the flow balance on recordings whose position was in cm read as
  mm: the factor became 0.10-0.12 and every leak size a tenth of the truth, its interval
  excluding it.
"""

from __future__ import annotations

import numpy as np

from leakdiag.io import RecordingError

__all__ = ["check_rig_units", "check_flow_scale", "PRESSURE_LEVEL_FRACTION",
           "PRESSURE_CEILING_FACTOR", "FLOW_SCALE_LIMIT", "STROKE_TOLERANCE"]

#: Fraction of the rig's pressure level that the largest chamber pressure of a recording must
#: reach for it to be read as pascals (leakdiag choice: a factor 100 below the level, where a
#: unit error is a factor 1,000 or more; the simulated rigs reach 0.73 (VCA) and 1.2-2.7 (EHA)
#: of it).
PRESSURE_LEVEL_FRACTION = 0.01
#: Multiple of the rig's pressure level that no chamber pressure of a recording in pascals
#: reaches (leakdiag choice, the floor's mirror: a unit error is a factor 1,000 or more).
PRESSURE_CEILING_FACTOR = 100.0
#: Fraction of the stroke by which a recorded travel may exceed it (leakdiag choice: the
#: transducer's noise and the end stops' compliance: the simulated EHA driven at 0.2-0.5 rad/s
#: sits on its end stops and records a travel of 0.6005-0.6015 m for its 0.6-m stroke, which
#: was refused as a unit error until session 22; a unit error is a factor 10 or more).
STROKE_TOLERANCE = 0.05
#: Largest factor between the identified and the modelled flow scale (flow-gain or pump
#: displacement factor) accepted at fit (leakdiag choice: a real servo valve's flow gain is
#: within some 20 % of its rating, the issue's worst case +5 %; a unit error is a factor 10 or
#: more, cm as mm 0.1, mm as cm 10).
FLOW_SCALE_LIMIT = 3.0


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
    leakdiag.io.errors.RecordingError: fit: rig.csv: channel 'x' travels 20 m (from -8 to 12), more than the stroke of 0.6 m that the flow balance (vca) models (with 5% for noise and end stops): is the position in mm (or another unit) read as metres? State its unit (e.g. --col x=NAME:mm, or a column map; in Python, convert the values with leakdiag.io.units.to_si or read the file with leakdiag.io.read_recording and a column map, and give a rig of other dimensions as params=)
    """
    source = rec.meta.get("source", "<recording>")
    if position in rec.channels:
        x = np.asarray(rec[position], dtype=np.float64)
        travel = float(np.nanmax(x) - np.nanmin(x)) if x.size else 0.0
        if travel > stroke_m * (1.0 + STROKE_TOLERANCE):
            raise RecordingError(
                f"{where}: {source}: channel {position!r} travels {travel:.4g} m (from "
                f"{float(np.nanmin(x)):.4g} to {float(np.nanmax(x)):.4g}), more than the stroke "
                f"of {stroke_m:g} m that {what} models (with {STROKE_TOLERANCE:.0%} for noise "
                "and end stops): is the position in mm (or another unit) read as metres? State "
                "its unit (e.g. --col x=NAME:mm, or a column map; in Python, convert the values "
                "with leakdiag.io.units.to_si or read the file with leakdiag.io.read_recording "
                "and a column map, and give a rig of other dimensions as params=)")
    have = [c for c in pressures if c in rec.channels and np.asarray(rec[c]).size]
    if have:
        top = max(float(np.nanmax(np.asarray(rec[c], dtype=np.float64))) for c in have)
        floor = PRESSURE_LEVEL_FRACTION * pressure_level_pa
        ceiling = PRESSURE_CEILING_FACTOR * pressure_level_pa
        if top > ceiling:
            worst = max(have, key=lambda c: float(np.nanmax(np.asarray(rec[c], np.float64))))
            row = int(np.nanargmax(np.asarray(rec[worst], dtype=np.float64)))
            raise RecordingError(
                f"{where}: {source}: channel {worst!r} reaches {top:.4g} Pa (data row {row}), "
                f"{top / pressure_level_pa:.3g} times the {pressure_level_pa / 1e6:g} MPa "
                f"pressure level that {what} models: no hydraulic chamber holds that; were "
                "they read in too large a unit (values in pascals stated as kPa give 1,000 "
                "times the pressure, as bar 100,000 times, as MPa 1,000,000 times)? State "
                "their unit (e.g. --col p1=NAME:Pa, or a column map; in Python, convert the values "
                "with leakdiag.io.units.to_si or read the file with leakdiag.io.read_recording "
                "and a column map, and give a rig of another pressure level as params=)")
        if top < floor:
            raise RecordingError(
                f"{where}: {source}: the chamber pressures ({', '.join(have)}) stay below "
                f"{top:.4g} Pa, under {PRESSURE_LEVEL_FRACTION:.0%} of the "
                f"{pressure_level_pa / 1e6:g} MPa pressure level that {what} models: are "
                "they in bar, MPa, kPa or psi read as pascals? State their unit (e.g. --col "
                "p1=NAME:bar, or a column map; in Python, convert the values with "
                "leakdiag.io.units.to_si or read the file with leakdiag.io.read_recording and a "
                "column map, and give a rig of another pressure level as params=)")


def check_flow_scale(factor: float, std: float, where: str, what: str, name: str,
                     n_recordings: int) -> None:
    """Refuse an identified flow scale that no valve or pump of the modelled rig gives.

    The flow balance identifies how the piston flow ``A dx/dt`` (with the compressibility
    terms) scales with the modelled valve's (VCA, Eq. 2-2: ``flow_gain_factor``) or pump's
    (EHA, Eq. 3-1: ``displacement_factor``) flow on the healthy recordings. A position or
    pressure in another unit than stated scales it by 10, 100 or 1,000; the balance would then
    size every leak by the same wrong factor with a confident interval.

    Parameters
    ----------
    factor, std : float
        The identified factor and its standard error.
    where : str
        Caller, for the message (``"fit"``).
    what : str
        The detector and rig (e.g. ``"the flow balance (vca)"``).
    name : str
        The factor's name (``"flow-gain factor"``, ``"pump displacement factor"``).
    n_recordings : int
        Healthy recordings it was identified on.

    Raises
    ------
    ValueError
        When ``factor`` is not within :data:`FLOW_SCALE_LIMIT` of 1, naming the likely unit.

    Examples
    --------
    >>> check_flow_scale(0.99, 0.001, "fit", "the flow balance (vca)", "flow-gain factor", 4)
    >>> check_flow_scale(0.118, 0.001, "fit", "the flow balance (vca)", "flow-gain factor",
    ...                  4)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: fit: the 4 healthy recording(s) give a flow-gain factor of 0.118 (+- 0.001)...
    """
    f = float(factor)
    if np.isfinite(f) and 1.0 / FLOW_SCALE_LIMIT <= f <= FLOW_SCALE_LIMIT:
        return
    if not (np.isfinite(f) and f > 0.0):
        # no unit error gives zero or a negative factor: the identification failed (an audit,
        # 2026-11-29: slow sine references of 1-2 mm on some units gave -1e-7, with a null
        # offset of -6167 V), which the unit wording below would misname
        raise ValueError(
            f"{where}: the {n_recordings} healthy recording(s) do not identify the {name} "
            f"(got {f:.3g} +- {float(std):.2g}, where 1 is the modelled rig's): {what} cannot "
            "be fitted on them; the operation moves the valve too little or too slowly to "
            "separate its flow from the null offset and leakage (give recordings of the "
            "actuator's usual motion)")
    guess = (" (a unit error scales it by a power of 10: a position in cm read as mm gives "
             "0.1, in mm read as cm 10, in m read as mm 0.001)")
    raise ValueError(
        f"{where}: the {n_recordings} healthy recording(s) give a {name} of {f:.3g} (+- "
        f"{float(std):.2g}): the piston flow A dx/dt is {f:.3g} times the flow that {what} "
        f"models, where a real valve or pump is within some 20 % of it (accepted: "
        f"{1 / FLOW_SCALE_LIMIT:.3g}-{FLOW_SCALE_LIMIT:g}){guess}. The position or pressures "
        "are likely in another unit than stated (state it: --col x=NAME:mm, or a column "
        "map), or the rig is not the modelled one (in Python, give its params=); its leak "
        "sizes would be off by the same factor")
