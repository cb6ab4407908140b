"""Hydraulic natural frequency (Eq. 2-6 text) that sets the default bands of the signal methods."""

from __future__ import annotations

import math

from leakdiag._validation import check_positive

__all__ = ["hydraulic_natural_frequency_hz", "DEFAULT_NATURAL_FREQUENCY_HZ"]

BULK_MODULUS_PA = 689e6  # Table 2-1 (and Table 3-1)
PISTON_AREA_M2 = 633e-6  # Table 2-1 (and Table 3-1)
MASS_KG = 12.3  # Table 2-1 (and Table 3-1)
HALF_VOLUME_M3 = 234e-6  # Table 2-1 (Table 3-1 prints 234 mm^3, read as cm^3)


def hydraulic_natural_frequency_hz(bulk_modulus_pa: float = BULK_MODULUS_PA,
                                   piston_area_m2: float = PISTON_AREA_M2,
                                   mass_kg: float = MASS_KG,
                                   half_volume_m3: float = HALF_VOLUME_M3) -> float:
    """Hydraulic natural frequency :math:`\\omega_h / 2\\pi` of a centred symmetric actuator.

    Parameters
    ----------
    bulk_modulus_pa : float, default 689e6
        Effective bulk modulus :math:`\\beta` in Pa (Table 2-1).
    piston_area_m2 : float, default 633e-6
        Piston (annulus) area :math:`A` in m^2 (Table 2-1).
    mass_kg : float, default 12.3
        Moving mass :math:`m` in kg (Table 2-1).
    half_volume_m3 : float, default 234e-6
        Fluid volume of one side at mid stroke :math:`V` in m^3 (Table 2-1).

    Returns
    -------
    float
        Natural frequency in Hz.

    Raises
    ------
    ValueError
        If any argument is not a positive finite number.

    Notes
    -----
    From the text under Eq. 2-6 of the thesis:

    .. math:: \\omega_h = \\sqrt{\\frac{2 \\beta A^2}{m V}}

    With the Table 2-1 values it is about 438 rad/s, i.e. 69.7 Hz. Table 3-1 (EHA) lists the
    same mass, area, bulk modulus and volume (its "234 mm^3" is read as cm^3, as in Table 2-1),
    so the same default serves both rigs.

    References
    ----------
    .. [1] H. E. Merritt, *Hydraulic Control Systems*, Wiley, 1967.

    Examples
    --------
    >>> round(hydraulic_natural_frequency_hz(), 1)
    69.7
    """
    beta = check_positive(bulk_modulus_pa, "bulk_modulus_pa")
    area = check_positive(piston_area_m2, "piston_area_m2")
    mass = check_positive(mass_kg, "mass_kg")
    vol = check_positive(half_volume_m3, "half_volume_m3")
    return math.sqrt(2.0 * beta * area**2 / (mass * vol)) / (2.0 * math.pi)


#: Natural frequency of the Table 2-1 actuator, Hz (about 69.7 Hz).
DEFAULT_NATURAL_FREQUENCY_HZ = hydraulic_natural_frequency_hz()
