"""The degenerate-window rule: NaN for that window plus ONE counted warning per call."""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["DegenerateWindowWarning", "warn_degenerate"]


class DegenerateWindowWarning(RuntimeWarning):
    """Some windows had a zero denominator (zero variance, or zero metric length in Eq. 4.3).

    Their feature values are NaN. One warning is issued per call, with the count.
    """


def warn_degenerate(bad: np.ndarray, what: str, stacklevel: int = 3) -> None:
    """Warn once if any entry of the boolean mask ``bad`` is set, counting them.

    Parameters
    ----------
    bad : numpy.ndarray of bool
        One entry per window, True where the window is degenerate.
    what : str
        The reason, e.g. ``"zero variance"``.
    stacklevel : int
        Passed to :func:`warnings.warn` so the warning points at the user's call.
    """
    n_bad = int(np.count_nonzero(bad))
    if n_bad:
        warnings.warn(
            f"{n_bad} of {bad.size} windows have {what}; their values are NaN",
            DegenerateWindowWarning,
            stacklevel=stacklevel,
        )
