"""How leakdiag prints an instant in seconds: never in exponent notation, never coarser than 0.1 s.

A recording's time axis may start at 0 or at a clock's reading (a CSV's ``time`` column of Unix
seconds: ``start_time = t[0]``), and a followed stream timed from 0 passes 1e6 s after 11.6
days. Printed with ``.6g``, 1795960057.86 s read ``1.79596e+09 s``, so that an onset 6 s before
its alarm, and the four segments of a run, could not be told apart (a user audit, 2026-11-29);
``.4g`` already lost the tenth of a second above 1,000 s. :func:`seconds` keeps the usual
significant digits where they resolve 0.1 s and switches to one decimal beyond.
"""

from __future__ import annotations

import math

__all__ = ["seconds"]


def seconds(t: float, digits: int = 4) -> str:
    """An instant ``t`` in seconds as text, at least to the tenth of a second.

    Parameters
    ----------
    t : float
        Time in s.
    digits : int, default 4
        Significant digits where they resolve 0.1 s (``|t| < 10**(digits - 1)``).

    Returns
    -------
    str
        ``f"{t:.{digits}g}"`` for ``|t| < 10**(digits - 1)``, else ``f"{t:.1f}"`` (NaN and
        infinities as Python writes them).

    Examples
    --------
    >>> seconds(64.039), seconds(64.039, 6), seconds(1234.56), seconds(1795960057.8595)
    ('64.04', '64.039', '1234.6', '1795960057.9')
    >>> seconds(100059.899, 6), seconds(float("nan"))
    ('100059.9', 'nan')
    """
    t = float(t)
    if math.isfinite(t) and abs(t) < 10.0 ** (digits - 1):
        return f"{t:.{digits}g}"
    return f"{t:.1f}"
