"""Units of recorded channels and their conversion to SI.

Every channel of a :class:`~leakdiag.io.recording.Recording` is stored in SI units (Pa, m, V,
m^3/s, s, rad/s) or, when no scale is known, as raw ADC ``counts``. Readers convert with
:func:`to_si`; the table below is the only place unit factors live.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "UNITS",
    "COUNTS",
    "QUANTITY_SI_UNIT",
    "CHANNEL_QUANTITY",
    "known_units",
    "unit_factor",
    "unit_quantity",
    "to_si",
]

#: The unit of raw analogue-to-digital converter readings: no physical scale.
COUNTS = "counts"

#: SI unit of each physical quantity.
QUANTITY_SI_UNIT: dict[str, str] = {
    "pressure": "Pa",
    "position": "m",
    "voltage": "V",
    "flow": "m^3/s",
    "time": "s",
    "angle": "rad",
    "angular_speed": "rad/s",
}

#: Quantity measured by each standard channel (see ``STANDARD_CHANNELS`` in recording.py).
CHANNEL_QUANTITY: dict[str, str] = {
    "p1": "pressure",
    "p2": "pressure",
    "x": "position",
    "u": "voltage",
    "x_ref": "position",
    "leak_flow": "flow",
    "speed": "angular_speed",  # motor/pump shaft speed (EHA)
    "time": "time",
}

# Exact definitions: 1 in = 0.0254 m (international yard and pound, 1959);
# 1 lbf = 0.45359237 kg * 9.80665 m/s^2 (standard gravity, CGPM 1901).
_INCH_M = 0.0254
_PSI_PA = 0.45359237 * 9.80665 / _INCH_M**2  # = 6894.757293168361 Pa

#: Unit -> (quantity, factor to the quantity's SI unit). SI value = value * factor.
UNITS: dict[str, tuple[str, float]] = {
    # pressure
    "Pa": ("pressure", 1.0),
    "kPa": ("pressure", 1e3),
    "MPa": ("pressure", 1e6),
    "bar": ("pressure", 1e5),  # 1 bar = 100 kPa (exact)
    "psi": ("pressure", _PSI_PA),
    # position
    "m": ("position", 1.0),
    "mm": ("position", 1e-3),
    "um": ("position", 1e-6),
    "in": ("position", _INCH_M),
    # voltage
    "V": ("voltage", 1.0),
    "mV": ("voltage", 1e-3),
    # flow
    "m^3/s": ("flow", 1.0),
    "L/min": ("flow", 1e-3 / 60.0),  # 1 L = 1e-3 m^3
    "L/s": ("flow", 1e-3),
    # time
    "s": ("time", 1.0),
    "ms": ("time", 1e-3),
    "us": ("time", 1e-6),
    # angle (shaft angle of rotary actuators)
    "rad": ("angle", 1.0),
    "deg": ("angle", np.pi / 180.0),
    # angular speed (motor/pump shaft of pump-driven actuators)
    "rad/s": ("angular_speed", 1.0),
    "rpm": ("angular_speed", 2.0 * np.pi / 60.0),  # 1 rev = 2 pi rad, 1 min = 60 s (exact)
}


def known_units() -> list[str]:
    """All unit names accepted in column maps, including ``counts``.

    Returns
    -------
    list of str
        Unit names, grouped by quantity.

    Examples
    --------
    >>> known_units()[:5]
    ['Pa', 'kPa', 'MPa', 'bar', 'psi']
    >>> "counts" in known_units()
    True
    """
    return [*UNITS, COUNTS]


def _unknown(unit: object, where: str) -> ValueError:
    return ValueError(f"{where}unknown unit {unit!r}; known units: {', '.join(known_units())}")


def unit_quantity(unit: str) -> str:
    """Physical quantity a unit measures.

    Parameters
    ----------
    unit : str
        A unit name from :data:`UNITS`, or ``"counts"``.

    Returns
    -------
    str
        ``"pressure"``, ``"position"``, ``"voltage"``, ``"flow"``, ``"time"``, ``"angle"``,
        ``"angular_speed"`` or ``"counts"``.

    Raises
    ------
    ValueError
        If the unit is unknown; the message lists the known units.

    Examples
    --------
    >>> unit_quantity("psi")
    'pressure'
    """
    if unit == COUNTS:
        return COUNTS
    try:
        return UNITS[unit][0]
    except (KeyError, TypeError):
        raise _unknown(unit, "") from None


def unit_factor(unit: str) -> float:
    """Factor that converts a value in ``unit`` to SI (``si = value * factor``).

    Parameters
    ----------
    unit : str
        A unit name from :data:`UNITS`. ``counts`` has no factor.

    Returns
    -------
    float
        The factor.

    Raises
    ------
    ValueError
        If the unit is unknown or is ``counts``.

    Examples
    --------
    >>> unit_factor("bar")
    100000.0
    >>> unit_factor("L/min") * 60 * 1000
    1.0
    """
    if unit == COUNTS:
        raise ValueError("unit 'counts' has no SI factor; give a gain to scale counts")
    try:
        return UNITS[unit][1]
    except (KeyError, TypeError):
        raise _unknown(unit, "") from None


def to_si(values, unit: str | None, *, gain: float | None = None, offset: float = 0.0,
          channel: str | None = None, si_unit: str | None = None) -> tuple[np.ndarray, str | None]:
    """Convert raw values to SI: ``si = (raw - offset) * gain * factor(unit)``.

    Parameters
    ----------
    values : array_like
        Raw values as stored in the file.
    unit : str or None
        Unit of ``(raw - offset) * gain``. None means "already SI" (the channel's SI unit for a
        standard channel, no unit otherwise). ``"counts"`` means raw ADC counts (factor 1).
    gain : float, optional
        Scale applied after subtracting ``offset``, before the unit factor (default 1; for
        counts, giving a gain is what turns counts into SI).
    offset : float, default 0.0
        Raw value subtracted first, in the raw unit.
    channel : str, optional
        Channel name. For a standard channel (``p1``, ``x``, ...) the unit must measure the
        channel's quantity, and counts with a ``gain`` become the channel's SI unit.
    si_unit : str, optional
        SI unit that ``(counts - offset) * gain`` is in, for a non-standard channel
        (e.g. ``"rad"`` for a shaft angle). Must be one of :data:`QUANTITY_SI_UNIT`'s values.

    Returns
    -------
    values : numpy.ndarray
        float64 values in SI (or counts).
    unit : str or None
        Unit of the returned values: the SI unit, ``"counts"`` when counts were given without
        a gain, or None when unknown (a non-standard channel with no unit).

    Raises
    ------
    ValueError
        Unknown unit (lists the known ones), a unit of the wrong quantity for a standard
        channel, counts with a gain on a non-standard channel without ``si_unit``, or a
        non-finite gain/offset.

    Notes
    -----
    Counts without a gain are **kept** as counts (unit ``"counts"``), because a raw ADC scale is
    often unpublished (e.g. the rotary-actuator data set). Scale-invariant features
    (autocorrelation, Eq. 4.1) work on counts unchanged. Counts with a gain give the
    channel's SI unit directly: ``si = (raw - offset) * gain``.

    Examples
    --------
    >>> to_si([1.0, 2.0], "bar", channel="p1")
    (array([100000., 200000.]), 'Pa')
    >>> to_si([8192, 8292], "counts", gain=0.5, offset=8192, channel="p1")
    (array([ 0., 50.]), 'Pa')
    >>> to_si([5, 6], "counts", channel="p1")
    (array([5., 6.]), 'counts')
    """
    where = f"channel {channel!r}: " if channel else ""
    for name, v in (("gain", gain), ("offset", offset)):
        if v is not None and not np.isfinite(float(v)):
            raise ValueError(f"{where}{name}={v!r} must be finite")
    raw = np.asarray(values, dtype=np.float64)
    quantity = CHANNEL_QUANTITY.get(channel) if channel else None
    scaled = (raw - float(offset)) * (1.0 if gain is None else float(gain))
    if unit is None:
        return scaled, (QUANTITY_SI_UNIT[quantity] if quantity else None)
    if unit == COUNTS:
        if gain is None:
            if offset != 0.0:
                raise ValueError(f"{where}counts with an offset but no gain; give a gain too")
            return scaled, COUNTS
        si_units = sorted(set(QUANTITY_SI_UNIT.values()))
        if quantity is None:
            if si_unit is None:
                raise ValueError(
                    f"{where}counts with a gain on a non-standard channel: say which SI unit "
                    f"the gain gives with si_unit (one of {', '.join(si_units)})"
                )
            if si_unit not in si_units:
                raise ValueError(f"{where}si_unit={si_unit!r} must be one of {', '.join(si_units)}")
            return scaled, si_unit
        if si_unit is not None and si_unit != QUANTITY_SI_UNIT[quantity]:
            raise ValueError(
                f"{where}si_unit={si_unit!r} does not match the channel's SI unit "
                f"{QUANTITY_SI_UNIT[quantity]!r}"
            )
        return scaled, QUANTITY_SI_UNIT[quantity]
    if unit not in UNITS:
        raise _unknown(unit, where)
    unit_q, factor = UNITS[unit]
    if quantity is not None and unit_q != quantity:
        si = QUANTITY_SI_UNIT[quantity]
        same = [u for u, (q, _) in UNITS.items() if q == quantity]
        raise ValueError(
            f"{where}unit {unit!r} measures {unit_q}, but the channel is a {quantity} "
            f"(SI unit {si!r}); use one of {', '.join(same)} or counts"
        )
    return scaled * factor, QUANTITY_SI_UNIT[unit_q]
